"""brian2 must not take over the process's warnings (issue 32).

Importing brian2 calls ``logging.captureWarnings(True)`` and replaces ``sys.excepthook``: before
afferent.spiking._brian2, every later warning went through logging (``WARNING .../_drive.py:220:
AfferentWarning ... [py.warnings]``), ``-q`` did not hide it, run.json lost the warnings raised after
the import (1 where 'fast' recorded 3) and 27 pyparsing deprecation blocks printed. Each test runs
in a fresh process: brian2's import happens once per process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("brian2")

ROOT = Path(__file__).resolve().parents[1]
BLOCK = ROOT / "sample_sed" / "block4"
ENV = dict(os.environ, MPLBACKEND="Agg", AFFERENT_FIGURE_PROCESS="0")


def test_brian2_leaves_warnings_logging_and_excepthook_as_they_were():
    code = """
import logging, sys, warnings
import numpy as np
from afferent.spiking import simulate_lif, LIF_PRESETS
before = (warnings.showwarning, logging._warnings_showwarning, sys.excepthook,
          list(logging.getLogger('py.warnings').handlers))
p = LIF_PRESETS['ra']
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter('always')
    res = simulate_lif(np.full((50, 2), 3 * p.rheobase), p, dt=1e-4, engine='brian2')
    warnings.warn('after brian2', UserWarning)
after = (warnings.showwarning, logging._warnings_showwarning, sys.excepthook,
         list(logging.getLogger('py.warnings').handlers))
print(int(res.counts.sum()), 'brian2' in sys.modules, before == after, [str(w.message) for w in caught])
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""  # no pyparsing deprecation blocks, nothing through logging
    n, imported, same, caught = out.stdout.strip().split(" ", 3)
    assert int(n) > 0 and imported == "True"
    assert same == "True"
    assert caught == "['after brian2']"  # recorded, not sent to logging; brian2 itself warned nothing


def _run(engine: str, out: Path, *extra: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "afferent", "run", str(BLOCK / "indent_0p88mm.vtu"),
           "--receptors", str(BLOCK / "receptors.csv"), "--length-unit", "mm", "--sed-unit", "MPa",
           "--params", "start", "--waveform", "ramp:0.5,5,2", "--d-ref-mm", "0.5", "--spikes",
           "--engine", engine, "--duration-s", "0.1", "--drive", "rheobase", "--rheobase-multiple", "500",
           "--no-plots", "-o", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=600)


@pytest.mark.slow
def test_run_json_holds_the_same_warnings_whichever_engine_ran_and_q_hides_them(tmp_path):
    """A saturated drive warns after spiking (the 90 %-of-ceiling warning, and for grid engines the
    1/t_ref one): run.json holds every warning with each engine, and ``-q`` prints none."""
    got = {}
    for engine in ("exact", "fast", "brian2"):
        res = _run(engine, tmp_path / engine, "-q")
        assert res.returncode == 0, res.stderr
        assert res.stderr == "", (engine, res.stderr[:500])
        got[engine] = [w["message"] for w in json.loads((tmp_path / engine / "run.json").read_text())["warnings"]]
    # 2: the false "states no step times" warning (the waveform's times drive the run, issue 34/37) is gone
    assert len(got["fast"]) == 2 and any(m.startswith("All 7 afferents fire at >= 90%") for m in got["fast"])
    assert not any("step times" in m for m in got["fast"] + got["exact"])
    assert got["brian2"] == got["fast"]
    grid_only = [m for m in got["fast"] if m.startswith("The grid engine at dt = ")]
    assert len(grid_only) == 1 and got["exact"] == [m for m in got["fast"] if m not in grid_only]

    loud = _run("brian2", tmp_path / "loud")  # without -q: afferent's own one-line form, nothing else
    warned = [line for line in loud.stderr.splitlines() if "warning" in line.lower()]
    assert loud.returncode == 0 and "py.warnings" not in loud.stderr and "Deprecat" not in loud.stderr
    assert len(warned) == 2 and all(line.startswith("afferent: warning: ") for line in warned), warned
