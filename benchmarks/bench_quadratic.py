"""Benchmark: quadratic cells sampled with their own shape functions vs from their corners only.

Run:  python benchmarks/bench_quadratic.py [--cells 20] [--receptors 150 10000]

A block of 4 x 3.1 x 4 mm in n x n x n boxes, each box one hexahedron20 or six tetra10 (the same
nodes: a structured grid of spacing h/2), written with meshio as a VTU and read back with
``afferent.read_sed``. It carries the smooth analytic SED of ``bench_sampling.py`` (wavelength
0.88 mm) at every node, mid-side nodes included, as an FE tool would export a quadratic solution.
Receptors at random inside the block (seeded). For each cell type and receptor count: the time
(wall clock, and CPU time of the process: steadier on a shared machine) to build the weights (``build_sampler``, once) with the cells' shape functions and with their
corners only (``Cells`` without ``nodes``, as afferent did before), and the error against the
analytic value.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import meshio
import scipy.sparse  # noqa: F401 (imported before timing)
import scipy.spatial  # noqa: F401
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's afferent

import afferent  # noqa: E402
from afferent._shape_functions import _nodes  # noqa: E402
from afferent.field import Cells, SEDField  # noqa: E402
from afferent.receptors import ReceptorLayout  # noqa: E402
from afferent.sampling import build_sampler  # noqa: E402

SIZE = np.array([4.0, 3.1, 4.0])  # mm
_KUHN = [np.array([[1, 0, 0], [1, 1, 0], [1, 1, 1]])[:, list(p)]
         for p in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0))]


def analytic(p_mm):
    x, y, z = p_mm.T
    return 100.0 * (1 + 0.5 * np.sin(2 * np.pi * x / 0.88) * np.cos(2 * np.pi * z / 0.88)) * np.exp(y / 3.1)


def block(ctype: str, n: int):
    """(points in mm, connectivity in VTK order) of an n x n x n block of ``ctype`` cells."""
    g = np.arange(2 * n + 1)
    points = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) / (2.0 * n) * SIZE
    xi = _nodes(ctype)
    local = [xi @ k for k in _KUHN] if ctype == "tetra10" else [xi]
    bases = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    conn = []
    for loc in local:
        ijk = np.rint(2 * (bases[:, None, :] + loc[None])).astype(int)
        conn.append((ijk[..., 0] * (2 * n + 1) + ijk[..., 1]) * (2 * n + 1) + ijk[..., 2])
    return points, np.concatenate(conn)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", type=int, default=20, help="boxes along each side")
    ap.add_argument("--receptors", type=int, nargs="+", default=[150, 10_000])
    args = ap.parse_args(argv)
    tmp = tempfile.mkdtemp()
    print(f"# command: python benchmarks/bench_quadratic.py --cells {args.cells} --receptors "
          f"{' '.join(map(str, args.receptors))}")
    print("cells         n_cells   nodes  receptors  interpolation     weights_s  cpu_s  max_err_Pa  rms_err_Pa")
    for ctype in ("tetra10", "hexahedron20"):
        pts, conn = block(ctype, args.cells)
        path = os.path.join(tmp, f"{ctype}.vtu")
        meshio.write(path, meshio.Mesh(pts, [(ctype, conn)], point_data={"SED": analytic(pts)}))
        field = afferent.read_sed(path, length_unit="mm", sed_unit="Pa")
        corners = field.cells
        corners = Cells(corners.tetra, corners.parent, corners.n_cells, corners.cell_types)
        for n_r in args.receptors:
            pos = np.random.default_rng(0).random((n_r, 3)) * SIZE * 1e-3
            layout = ReceptorLayout(pos, np.arange(n_r).astype(str))
            exact = analytic(pos * 1e3)
            for name, cells in (("shape functions", field.cells), ("corners only", corners)):
                f = SEDField(field.points, field.sed, field.times, "point", cells)
                t0, c0 = time.perf_counter(), time.process_time()
                s = build_sampler(f, layout)
                dt, dc = time.perf_counter() - t0, time.process_time() - c0
                err = s.apply(f.sed)[0] - exact
                print(f"{ctype:12s} {conn.shape[0]:8,d} {len(pts):7,d} {n_r:10,d}  {name:16s} {dt:9.3f} {dc:6.3f} "
                      f"{np.nanmax(np.abs(err)):11.3g} {np.sqrt(np.nanmean(err ** 2)):11.3g}")


if __name__ == "__main__":
    main()
