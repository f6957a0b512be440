"""Benchmark: ``afferent sample`` of a 2,000,376-node hexahedral VTU against meshio's bare read (issue 38).

Run from the repository root::

    python benchmarks/bench_large_vtu.py --repeat 3                      # this checkout
    python benchmarks/bench_large_vtu.py --repeat 3 --tree /tmp/old      # and another (e.g. a git archive of main)
    python benchmarks/bench_large_vtu.py --n 40 --repeat 1               # a 68,921-node smoke test

The file: a box of ``--n`` ** 3 nodes (default 126: 2,000,376 nodes, 1,953,125 hexahedra) written by
``meshio.write`` (binary, zlib: meshio's default; 52 MB) with one point array ``SED`` (MPa, lengths in
mm), and ``--receptors`` sites (default 500) drawn inside it. Each measurement is a fresh process,
interpreter start and imports included, as a user runs it:

* ``meshio``: ``meshio.vtu.read(FILE)``, nothing else (the reference: a bare read);
* ``afferent``: ``python -m afferent sample FILE --receptors R.csv --length-unit mm --sed-unit MPa
  --method linear -o OUT.csv`` (reading, checks, locating the receptors, weights, the CSV).

With ``--after-imports`` both are run once more with the modules they import (numpy, scipy.sparse
and scipy.spatial, meshio, afferent's CLI) imported before a clock in the process starts: the
time after that clock is the work alone (printed as ``after its imports``).

Each process reports its own peak resident memory (``VmHWM`` of ``/proc/self/status``, Linux, at
exit: a new process image starts its own count); the wall time is the parent's around the
process. The runs are interleaved ``--repeat`` times and the minimum of each is printed (the
machine may be shared: the load average is printed beside them). The files go to a temporary
folder, deleted at the end (``--folder`` keeps them, and reuses them on the next run).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")

_MAKE = """
import sys
import meshio
import numpy as np
n, path, receptors, count = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
xs = np.linspace(0.0, 10.0, n)  # mm
x, y, z = (a.ravel() for a in np.meshgrid(xs, xs, xs, indexing="ij"))
i, j, k = (a.ravel() for a in np.meshgrid(*(np.arange(n - 1),) * 3, indexing="ij"))
node = lambda a, b, c: (a * n + b) * n + c
hexes = np.column_stack([node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
                         node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)])
rng = np.random.default_rng(38)
sed = 1e-4 * (1 + np.sin(x) * np.cos(y) + 0.1 * z) + 1e-6 * rng.random(len(x))  # MPa: 100-280 J/m^3
meshio.write(path, meshio.Mesh(np.column_stack([x, y, z]), [("hexahedron", hexes)], point_data={"SED": sed}))
np.savetxt(receptors, rng.uniform(0.5, 9.5, size=(count, 3)), delimiter=",", header="x,y,z", comments="")
"""

#: Runs ``sys.argv[1:]`` (``meshio FILE`` or ``afferent ARGS...``, ``+``: the modules it imports imported before
#: the clock starts) and prints its own peak memory and the time after its imports at exit.
_CHILD = """
import atexit, runpy, sys, time
def _peak():
    with open("/proc/self/status") as status:
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024
    sys.stderr.write(f"\\nPEAK_MB {peak:.1f}\\nWORK_S {time.perf_counter() - start:.3f}\\n")
atexit.register(_peak)
if sys.argv[1].endswith("+"):  # what the run imports, before the clock (the time then is the work alone)
    import meshio, scipy.sparse, scipy.spatial, afferent.cli._main, afferent.cli._sample, afferent.io._meshio
start = time.perf_counter()
if sys.argv[1].startswith("meshio"):
    import meshio
    meshio.vtu.read(sys.argv[2])
else:
    sys.argv = ["afferent"] + sys.argv[2:]
    runpy.run_module("afferent", run_name="__main__", alter_sys=True)
"""


def run(what: str, args: list, tree: str) -> tuple[float, float, float]:
    """(wall time s, peak MB, time after the imports s) of one fresh process running ``what`` (``meshio`` or
    ``afferent``; ``+``: its imports before the clock) from ``tree``."""
    env = dict(os.environ, PYTHONPATH=tree, MPLBACKEND="Agg")
    t = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _CHILD, what, *args], capture_output=True, text=True, env=env, cwd=tree)
    wall = time.perf_counter() - t
    if done.returncode:
        raise SystemExit(f"{what} failed ({done.returncode}): {done.stderr.strip()[-2000:]}")
    got = {line.split()[0]: float(line.split()[1]) for line in done.stderr.splitlines()
           if line.startswith(("PEAK_MB", "WORK_S"))}
    return wall, got["PEAK_MB"], got["WORK_S"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=126, help="nodes along each edge of the box (default 126: 2,000,376 nodes)")
    parser.add_argument("--receptors", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--tree", action="append", default=[], help="another checkout to measure (repeatable)")
    parser.add_argument("--after-imports", action="store_true",
                        help="also time both after their imports (the run's modules imported before the clock)")
    parser.add_argument("--folder", help="where to write the files (kept, reused); default: a temporary folder, deleted")
    args = parser.parse_args()
    print("command:", shlex.join([os.path.basename(sys.executable)] + sys.argv))
    trees = [os.path.abspath(ROOT)] + [os.path.abspath(t) for t in args.tree]
    with tempfile.TemporaryDirectory(prefix="bench_large_vtu_") as tmp:
        folder = args.folder or tmp
        os.makedirs(folder, exist_ok=True)
        vtu = os.path.join(folder, f"box_{args.n}.vtu")
        receptors = os.path.join(folder, f"receptors_{args.receptors}.csv")
        if not (os.path.isfile(vtu) and os.path.isfile(receptors)):
            subprocess.run([sys.executable, "-c", _MAKE, str(args.n), vtu, receptors, str(args.receptors)], check=True)
        print(f"{vtu}: {args.n ** 3:,} nodes, {(args.n - 1) ** 3:,} hexahedra, {os.path.getsize(vtu) / 1e6:.1f} MB; "
              f"{args.receptors} receptors")
        runs: dict = {}
        loads = []
        for _ in range(args.repeat):
            loads.append(os.getloadavg()[0])
            runs.setdefault("meshio.vtu.read", []).append(run("meshio", [vtu], trees[0]))
            for k, tree in enumerate(trees):
                out = os.path.join(folder, f"out_{k}.csv")
                cli = ["sample", vtu, "--receptors", receptors, "--length-unit", "mm", "--sed-unit", "MPa",
                       "--method", "linear", "-o", out, "--overwrite", "-q"]
                runs.setdefault(f"afferent sample ({tree})", []).append(run("afferent", cli, tree))
            if args.after_imports:
                runs.setdefault("meshio.vtu.read, after its imports", []).append(run("meshio+", [vtu], trees[0]))
                runs.setdefault("afferent sample, after its imports", []).append(run("afferent+", cli, trees[0]))
        print(f"load average (1 min) at each repeat: {', '.join(f'{v:.1f}' for v in loads)}")
        base = min(r[0] for r in runs["meshio.vtu.read"]), min(r[1] for r in runs["meshio.vtu.read"])
        for name, got in runs.items():
            wall, peak, work = (min(r[i] for r in got) for i in range(3))
            work = f"; after its imports {work:5.2f} s" if "after its imports" in name else ""
            print(f"{name:<60} wall {wall:6.2f} s (min of {len(got)}; {wall / base[0]:.2f} x meshio), "
                  f"peak {peak:6.0f} MB ({peak / base[1]:.2f} x meshio){work}")


if __name__ == "__main__":
    main()
