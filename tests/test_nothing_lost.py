"""Nothing lost: a run killed at any moment (SIGINT, SIGTERM, SIGKILL) leaves the previous
complete results or none at the output name - never a half-written folder or file - and the
SED cache never holds a half-written entry. Real subprocesses are killed mid-run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import SAMPLE_DIR

EXPORT = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu"
RECEPTORS = SAMPLE_DIR / "block4" / "receptors.csv"
pytestmark = pytest.mark.skipif(not EXPORT.is_file(), reason="bundled sample not generated")
EXPECTED = {"receptors.csv", "afferents.csv", "receptors.vtu", "run.json", "sed_map.png", "profiles_x.png",
            "profiles_z.png"}


def _start(out, cache, *extra):
    env = dict(os.environ, MPLBACKEND="Agg", AFFERENT_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "afferent", "run", str(EXPORT), "--receptors", str(RECEPTORS), "--length-unit", "mm",
           "--sed-unit", "MPa", "--params", "start", "-o", str(out), *extra]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _complete(folder) -> bool:
    names = {p.name for p in folder.iterdir()}
    if not EXPECTED <= names:
        return False
    json.loads((folder / "run.json").read_text())  # a whole JSON document
    return all((folder / n).stat().st_size > 0 for n in EXPECTED)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_a_run_killed_at_any_moment_leaves_complete_results_or_none(tmp_path, sig):
    # timings measured on this machine: a whole run takes ~1.5-2.5 s (imports, reading, plots)
    for delay in (0.3, 0.9, 1.5, 2.1):
        out = tmp_path / f"fresh_{delay}"
        proc = _start(out, tmp_path / "cache")
        time.sleep(delay)
        proc.send_signal(sig)
        proc.wait(timeout=60)
        if out.exists():
            assert _complete(out), (sig, delay, sorted(p.name for p in out.iterdir()))
    # a previous complete result survives a killed --overwrite, or is replaced whole
    out = tmp_path / "previous"
    first = _start(out, tmp_path / "cache")
    assert first.wait(timeout=120) == 0, first.stderr.read().decode()
    before = (out / "run.json").read_text()
    for delay in (0.3, 1.2, 2.0):
        proc = _start(out, tmp_path / "cache", "--overwrite")
        time.sleep(delay)
        proc.send_signal(sig)
        proc.wait(timeout=60)
        if out.exists():
            assert _complete(out), (sig, delay)
            after = (out / "run.json").read_text()
            assert after == before or json.loads(after)["outputs"]
    leftovers = [p.name for p in tmp_path.iterdir() if not p.name.startswith((".", "fresh_", "previous", "cache"))]
    assert not leftovers


@pytest.mark.slow
def test_the_cache_never_serves_a_half_written_entry(tmp_path):
    """Kill scenes while they store their sampled SED; every entry left must load, and a run
    afterwards either hits a whole entry or rebuilds it."""
    scene = tmp_path / "scene.toml"
    scene.write_text(f"""
[export]
file = {str(EXPORT)!r}
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = {str(RECEPTORS)!r}
[outputs]
want = ["sed_map"]
""")
    cache = tmp_path / "cache"
    env = dict(os.environ, MPLBACKEND="Agg", AFFERENT_CACHE_DIR=str(cache))
    for k, delay in enumerate((0.4, 0.8, 1.2, 1.6)):
        proc = subprocess.Popen([sys.executable, "-m", "afferent", "run", str(scene), "-o", str(tmp_path / f"o{k}")],
                                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    import numpy as np

    for entry in cache.rglob("*.npz") if cache.exists() else ():
        with np.load(entry) as data:
            assert data.files  # a whole, readable archive
    done = subprocess.run([sys.executable, "-m", "afferent", "run", str(scene), "-o", str(tmp_path / "final")], env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "final" / "run.json").is_file()
