"""Benchmark: peak memory and time of reading a large VTU, raw appended against inline (issue 33, item 10).

Run from the repository root::

    .venv/bin/python benchmarks/bench_vtu_memory.py                 # a 230 MB raw appended file, zlib (VTK's default)
    .venv/bin/python benchmarks/bench_vtu_memory.py --points 200000  # smaller, for a smoke test
    .venv/bin/python benchmarks/bench_vtu_memory.py --afferent /path/to/other/checkout   # another tree's reader

It writes one hexahedral box (``--points`` nodes; point arrays ``SED``, ``U`` (3), ``stress`` (6),
``strain`` (6), Float64, and a cell array ``material``) with VTK's own XML writer (the ``vtk``
extra) in two layouts: raw appended data (``SetDataModeToAppended``, ``EncodeAppendedDataOff``)
and inline base64 (``SetDataModeToBinary``), compressed with ``--compressor``. The files go to
``--folder`` (default: a temporary folder, deleted at the end) and are never part of the repository.

Each file is then read by ``afferent.io.read_sed`` (``SED``, in MPa and mm) in a fresh child
process, which reports its wall time and its peak resident memory (``VmHWM`` of
``/proc/self/status``, Linux: the interpreter and imports included, ~60-110 MB; not ``ru_maxrss``,
which a child inherits from its parent's size at its start). Before issue 33 the raw appended file was
inflated and re-encoded as base64 whole at parse time (every array, used or not): 1.37 GB at
peak against 0.62 GB inline for a 230 MB file.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")

_CHILD = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
t0 = time.perf_counter()
from afferent.io import read_sed
t1 = time.perf_counter()
field = read_sed(sys.argv[1], length_unit="mm", sed_unit="MPa")
t2 = time.perf_counter()
with open("/proc/self/status") as status:  # VmHWM: this process's own peak (ru_maxrss starts at the parent's size)
    peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024
print(json.dumps({"import_s": t1 - t0, "read_s": t2 - t1, "peak_mb": peak,
                  "n_points": int(field.points.shape[0])}))
"""


def write_box(path: str, n_points: int, mode: str, compressor: str) -> None:
    """A hexahedral box of about ``n_points`` nodes written by VTK's XML writer in ``mode`` ("appended": raw, or "inline")."""
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

    n = max(int(round(n_points ** (1 / 3))), 2)
    xs = np.linspace(0.0, 10.0, n)
    x, y, z = (a.ravel() for a in np.meshgrid(xs, xs, xs, indexing="ij"))
    points = np.column_stack([x, y, z])
    i, j, k = (a.ravel() for a in np.meshgrid(*(np.arange(n - 1),) * 3, indexing="ij"))

    def node(a, b, c):
        return (a * n + b) * n + c

    hexes = np.column_stack([node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
                             node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)])
    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(points, deep=True))
    grid.SetPoints(pts)
    cells = vtk.vtkCellArray()
    cells.SetData(numpy_to_vtkIdTypeArray(8 * np.arange(len(hexes) + 1, dtype=np.int64), deep=True),
                  numpy_to_vtkIdTypeArray(hexes.ravel().astype(np.int64), deep=True))
    grid.SetCells(vtk.VTK_HEXAHEDRON, cells)
    rng = np.random.default_rng(33)
    sed = 1e-4 * (1 + np.sin(x) * np.cos(y) + 0.1 * z) + 1e-6 * rng.random(len(x))
    for name, values in (("SED", sed), ("U", rng.normal(size=(len(x), 3))), ("stress", rng.normal(size=(len(x), 6))),
                         ("strain", rng.normal(size=(len(x), 6)))):
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        grid.GetPointData().AddArray(array)
    material = numpy_to_vtk((k > n // 2).astype(np.float64), deep=True)
    material.SetName("material")
    grid.GetCellData().AddArray(material)
    writer = vtk.vtkXMLUnstructuredGridWriter()
    writer.SetFileName(path)
    writer.SetInputData(grid)
    {"zlib": writer.SetCompressorTypeToZLib, "lzma": writer.SetCompressorTypeToLZMA,
     "none": writer.SetCompressorTypeToNone}[compressor]()
    writer.SetHeaderTypeToUInt64()
    if mode == "appended":
        writer.SetDataModeToAppended()
        writer.EncodeAppendedDataOff()
    else:
        writer.SetDataModeToBinary()
    if writer.Write() != 1:
        raise SystemExit(f"VTK could not write {path}")


def measure(path: str, tree: str) -> dict:
    """Time and peak memory of ``read_sed(path)`` in a child process importing afferent from ``tree``."""
    env = dict(os.environ, PYTHONPATH=tree, MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", _CHILD, os.path.abspath(path)], capture_output=True, text=True, env=env,
                          cwd=tree)  # python -c puts its folder first on the path: the tree's afferent, not this one's
    if done.returncode:
        return {"error": done.stderr.strip().splitlines()[-1]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=1_700_000, help="nodes of the box (default: a 230 MB raw appended file)")
    parser.add_argument("--compressor", choices=("zlib", "lzma", "none"), default="zlib")
    parser.add_argument("--folder", help="where to write the files (kept); default: a temporary folder, deleted")
    parser.add_argument("--afferent", default=ROOT, help="the checkout whose afferent reads the files (default: this one)")
    args = parser.parse_args()
    print("command:", " ".join([os.path.basename(sys.executable)] + sys.argv))
    print(f"afferent from {os.path.abspath(args.afferent)}")
    with tempfile.TemporaryDirectory(prefix="bench_vtu_memory_") as tmp:
        folder = args.folder or tmp
        os.makedirs(folder, exist_ok=True)
        for mode in ("appended", "inline"):
            path = os.path.join(folder, f"box_{args.points}_{args.compressor}_{mode}.vtu")
            if not os.path.isfile(path):
                write_box(path, args.points, mode, args.compressor)
            got = measure(path, os.path.abspath(args.afferent))
            size = os.path.getsize(path) / 1e6
            if "error" in got:
                print(f"{mode:>8}: {size:7.1f} MB file: error: {got['error']}")
                continue
            print(f"{mode:>8}: {size:7.1f} MB file, {got['n_points']:,} points: read_sed {got['read_s']:6.2f} s, "
                  f"peak RSS {got['peak_mb']:7.0f} MB (imports {got['import_s']:.2f} s)")


if __name__ == "__main__":
    main()
