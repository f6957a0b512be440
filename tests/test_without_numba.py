"""numba is a dependency for speed only: without it every engine runs on numpy with the same spikes.

docs/performance.md, "Install size": numba (and llvmlite) are 213 MB of the default install; a user who
removes them (``pip uninstall numba llvmlite``) keeps every result. Checked here in a child process whose
imports of numba and llvmlite fail, against this process (numba installed).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("numba", "llvmlite"):
            raise ImportError(f"{name} is not installed (blocked by the test)")
        return None
if sys.argv[1] == "block":
    sys.meta_path.insert(0, Block())
import numpy as np
from afferent.spiking import simulate_lif, LIF_PRESETS
current = np.abs(np.random.default_rng(0).normal(2.5e-7, 1e-7, size=(2001, 3000)))  # A; rheobase 1e-7 A
times = np.arange(2001) * 5e-4
out = {"numba": None}
for engine in ("exact", "exact-numpy", "fast"):
    kw = {"dt": 1e-4, "times": times} if engine == "fast" else {"times": times}
    out[engine] = simulate_lif(current, LIF_PRESETS["ra"], engine=engine, **kw).summary()["n_spikes"].astype(int).tolist()
out["numba"] = "numba" in sys.modules
print(json.dumps(out))
"""


def _run(mode: str) -> dict:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_every_engine_gives_the_same_spikes_without_numba():
    pytest.importorskip("numba")
    without, with_ = _run("block"), _run("free")
    assert without.pop("numba") is False  # nothing imported it
    assert with_.pop("numba") is True  # the 'fast' engine ran its numba loop here
    assert sum(with_["exact"]) > 100_000
    assert without == with_
