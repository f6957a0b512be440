"""Benchmark: the first exact-engine call in a fresh process (issue 38's row "first exact-engine call").

Each round starts a fresh Python, imports afferent's spiking stage, then times: ``import numba``, the
first call of the numba exact kernel (``engine='exact-numba'``: numba loads the cached kernel and, before
it, its target context: every typing and lowering registry, numpy's BLAS check imports
``scipy.linalg``), a second call, and, for comparison, the same first call on numpy
(``engine='exact-numpy'``) and ``import scipy.linalg`` alone.

Run::

    python benchmarks/bench_first_call.py --repeat 5
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
t = time.perf_counter
import numpy as np
from afferent.spiking import simulate_lif, LIF_PRESETS
current, p = np.full((101, 2), 2e-7), LIF_PRESETS["ra"]
out = {}
if sys.argv[1] == "numba":
    a = t(); import numba; out["import numba"] = t() - a
    a = t(); simulate_lif(current, p, engine="exact-numba", dt=1e-3); out["first call (numba)"] = t() - a
    a = t(); simulate_lif(current, p, engine="exact-numba", dt=1e-3); out["second call (numba)"] = t() - a
elif sys.argv[1] == "numpy":
    a = t(); simulate_lif(current, p, engine="exact-numpy", dt=1e-3); out["first call (numpy)"] = t() - a
else:
    a = t(); import scipy.linalg; out["import scipy.linalg"] = t() - a
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    rows: dict[str, list[float]] = {}
    for _ in range(args.repeat):
        for mode in ("numba", "numpy", "scipy"):
            done = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True, env=env,
                                  check=True)
            for k, v in json.loads(done.stdout.strip().splitlines()[-1]).items():
                rows.setdefault(k, []).append(v)
    print(f"$ {shlex.join([sys.executable, *sys.argv])}")
    print(f"load average {os.getloadavg()[0]:.1f}; medians of {args.repeat} fresh processes (min-max)")
    for k, v in rows.items():
        v = sorted(v)
        print(f"{k:24s} {v[len(v) // 2]:.3f} s ({v[0]:.3f}-{v[-1]:.3f})")


if __name__ == "__main__":
    main()
