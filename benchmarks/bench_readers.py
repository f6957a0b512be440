"""Benchmark: time to read each real FE test file, and a large CalculiX .frd.

Run:  python benchmarks/bench_readers.py [--frd-elements 40]

For every file under tests/data that a real FE tool wrote (CalculiX, DOLFINx, SfePy's Exodus
through VTK's IOSS writer and through meshio, SfePy's VTK, and the MAPDL file
ansys-mapdl-reader ships), ``afferent.io.read_raw`` is timed (first call, including the
reader's imports, then the best of 5). With ``ccx`` on the PATH a
C3D8 version of tests/data/calculix's model with N x N x N/2 elements is solved and its .frd
read (the default N = 40 gives 35,301 nodes and a 34 MB file).

``--vs-meshio FILE.vtu``: instead, ``afferent.read_sed`` against meshio's bare read of the same
VTU (``meshio.vtu.read``), in turn 9 times each after a warm-up: CPU-time medians and the
median of the pairwise ratios.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FILES = [
    "tests/data/calculix/block_c3d8.frd", "tests/data/calculix/block_c3d8_binary.frd", "tests/data/calculix/block_c3d8.frd.gz",
    "tests/data/calculix/block_c3d20r.frd", "tests/data/calculix/block_c3d10.frd", "tests/data/calculix/block_c3d8.dat",
    "tests/data/dolfinx/block.xdmf", "tests/data/exodus/layers_ioss.e",
    "tests/data/exodus/layers_sfepy.e", "tests/data/exodus/hex20_ioss.e", "tests/data/sfepy/block.vtk",
    # issue 20: tools this project had not met (each folder's README: tool, version, how made)
    "tests/data/calculix/block_c3d15.frd", "tests/data/calculix/block_c3d8_print.dat",
    "tests/data/calculix/block_c3d8_print.dat.gz", "tests/data/kratos/vtk/Structure_0_1.vtk",
    "tests/data/kratos/vtu/Structure.vtm.series", "tests/data/kratos/vtu/Structure_1.vtm",
    "tests/data/freefem/block_point.vtk", "tests/data/freefem/block_cell.vtk", "tests/data/dealii/block.pvd",
    "tests/data/dealii/block_00.pvtu", "tests/data/dealii/indent_block.vtu", "tests/data/med/block_hexa.rmed",
    "tests/data/med/block_tetra.med", "tests/data/med/kratos_block.med", "tests/data/vtk/lagrange_hex27.vtu",
    "tests/data/vtk/wedge15_pyramid13.vtu",
]


def timed(path) -> tuple[float, float, object]:
    from afferent.io import read_raw

    t = time.perf_counter()
    raw = read_raw(str(path))
    first = time.perf_counter() - t
    best = min(_once(path) for _ in range(5))
    return first, best, raw


def _once(path) -> float:
    from afferent.io import read_raw

    t = time.perf_counter()
    read_raw(str(path))
    return time.perf_counter() - t


def vs_meshio(path: str) -> None:
    """read_sed against meshio's bare read of the same file, interleaved, CPU time."""
    import warnings

    import meshio
    import numpy as np

    import afferent

    warnings.simplefilter("ignore")  # read_sed's warnings on the file (said once each by afferent info) are not timed
    print(f"$ python benchmarks/bench_readers.py --vs-meshio {path}")
    pairs = []
    for k in range(10):
        t = time.process_time()
        meshio.vtu.read(path)
        m = time.process_time() - t
        t = time.process_time()
        field = afferent.read_sed(path, length_unit="mm", sed_unit="MPa")
        a = time.process_time() - t
        if k:  # the first pair warms up
            pairs.append((m, a))
    m, a = np.median(pairs, axis=0)
    print(f"{os.path.basename(path)} ({os.path.getsize(path) / 1e6:.1f} MB, {field.n_points:,} nodes): meshio {m:.3f} s, "
          f"read_sed {a:.3f} s CPU (medians of 9); read_sed / meshio {np.median([p[1] / p[0] for p in pairs]):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frd-elements", type=int, default=40, help="elements across the block for the large .frd")
    parser.add_argument("--vs-meshio", metavar="VTU", help="read_sed against meshio's bare read of this file")
    args = parser.parse_args()
    if args.vs_meshio:
        return vs_meshio(args.vs_meshio)
    print(f"$ python benchmarks/bench_readers.py --frd-elements {args.frd_elements}")
    files = [ROOT / f for f in FILES]
    try:
        from ansys.mapdl.reader import examples

        files.append(Path(examples.rstfile))
    except ImportError:
        print("(ansys-mapdl-reader not installed: the .rst file is skipped)")
    print(f"{'file':<40} {'size':>9} {'nodes':>7} {'steps':>5} {'first s':>8} {'best s':>8}  reader")
    for f in files:
        first, best, raw = timed(f)
        n = raw.points.shape[0] if raw.points is not None else 0
        print(f"{f.name:<40} {f.stat().st_size / 1e3:>7.0f}KB {n:>7} {raw.n_times:>5} {first:>8.3f} {best:>8.4f}  "
              f"{raw.reader or raw.format}")
    if shutil.which("ccx") is None or args.frd_elements <= 0:
        print("(no large .frd: ccx not on the PATH, or --frd-elements 0)")
        return
    spec = importlib.util.spec_from_file_location("mk", ROOT / "tests/data/calculix/make_calculix.py")
    mk = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mk)
    with tempfile.TemporaryDirectory() as tmp:
        mk.HERE = Path(tmp)
        n = args.frd_elements
        t = time.perf_counter()
        mk.write_inp(Path(tmp) / "big.inp", "C3D8", n_xy=n, n_z=n // 2)
        mk.run("big")
        solve = time.perf_counter() - t
        first, best, raw = timed(Path(tmp) / "big.frd")
        size = os.path.getsize(Path(tmp) / "big.frd")
        print(f"large .frd: {raw.points.shape[0]:,} nodes, {raw.cells.n_cells:,} C3D8, {raw.n_times} steps, "
              f"{size / 1e6:.1f} MB (ccx solve {solve:.0f} s): read {first:.2f} s first, {best:.2f} s best of 5")


if __name__ == "__main__":
    sys.exit(main())
