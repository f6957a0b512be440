"""Benchmark: cost and error of the sampling methods, and of reading a VTU series.

Run:  python benchmarks/bench_sampling.py [--points 270000] [--receptors 150 10000]

A structured hexahedral block (0 <= x, z <= 4 mm, 0 <= y <= 3.1 mm) carries a smooth analytic
SED field, SED(x, y, z) = 100 Pa * (1 + sin(2 pi x / 0.88 mm) cos(2 pi z / 0.88 mm) / 2) * exp(y / 3.1 mm),
i.e. it varies on the scale of the indenters (wavelength 0.88 mm). Receptors are placed at random
inside the block (seeded). For each method we time building the weights (once) and applying
them to every time step (``apply_s``: all steps), and report the error against the analytic value
over every step: the measurement of ``afferent report`` (:func:`afferent.report.measure_sampling`),
here on a larger mesh.

``--scattered N``: instead, linear sampling on the bundled COMSOL point table (22,099 points,
no connectivity: a Delaunay tetrahedralisation locates the receptors), N receptors drawn
anywhere in its bounding box (and 10 % beyond in every direction), 5 seeds: CPU time of
building the sampler (median and max) and how many receptors fell outside.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import tracemalloc

import meshio
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's afferent

import afferent  # noqa: E402
from afferent.receptors import ReceptorLayout  # noqa: E402
from afferent.report import block_dims, hex_block, measure_sampling  # noqa: E402


def analytic(p_mm):
    x, y, z = p_mm.T
    return 100.0 * (1 + 0.5 * np.sin(2 * np.pi * x / 0.88) * np.cos(2 * np.pi * z / 0.88)) * np.exp(y / 3.1)


def scattered(n_receptors: int) -> None:
    """CPU time of linear sampling on the bundled COMSOL table, receptors anywhere."""
    import warnings

    from afferent.sampling import build_sampler

    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_sed", "block4",
                        "indent_0p88mm_comsol.csv")
    field = afferent.read_sed(path, length_unit="mm", sed_unit="Pa")
    lo, hi = field.points.min(axis=0), field.points.max(axis=0)
    print(f"# command: python benchmarks/bench_sampling.py --scattered {n_receptors}")
    print(f"# {os.path.basename(path)}: {field.n_points:,} points; {n_receptors} receptors uniform in the box +-10 %")
    cpus = []
    for seed in range(5):
        pos = np.random.default_rng(seed).uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), (n_receptors, 3))
        t = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = build_sampler(field, ReceptorLayout(pos), method="linear")
        cpus.append(time.process_time() - t)
        print(f"seed {seed}: build_sampler {cpus[-1]:.3f} s CPU, {int(s.outside.sum())} outside")
    print(f"median {np.median(cpus):.3f} s, max {max(cpus):.3f} s CPU")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--scattered", type=int, metavar="N", help="linear sampling of the COMSOL table, N receptors")
    ap.add_argument("--points", type=int, default=270_000, help="approximate number of mesh nodes")
    ap.add_argument("--receptors", type=int, nargs="+", default=[150, 10_000])
    ap.add_argument("--steps", type=int, default=6, help="time steps in the VTU series")
    args = ap.parse_args(argv)
    if args.scattered:
        return scattered(args.scattered)

    nx, ny, nz = block_dims(args.points)
    points, hexes = hex_block(nx, ny, nz, size=(4.0, 3.1, 4.0))
    tmp = tempfile.mkdtemp()
    paths = []
    for k in range(args.steps):
        p = os.path.join(tmp, f"step_{k:03d}.vtu")
        meshio.write(p, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": (k + 1) / args.steps * analytic(points) / 1e6}),
                     binary=True, compression="zlib")
        paths.append(p)
    h = 4.0 / nx
    print(f"# mesh: {len(points):,} nodes, {len(hexes):,} hexahedra, h = {h * 1e3:.0f} um; {args.steps} VTU steps "
          f"({os.path.getsize(paths[0]) / 1e6:.1f} MB each)")
    print(f"# command: python benchmarks/bench_sampling.py --points {args.points} --receptors {' '.join(map(str, args.receptors))} --steps {args.steps}")

    t = time.perf_counter()
    field1 = afferent.read_sed(paths[0], length_unit="mm", sed_unit="MPa")
    t_one = time.perf_counter() - t
    t = time.perf_counter()
    field = afferent.read_sed(paths, length_unit="mm", sed_unit="MPa")
    t_series = time.perf_counter() - t
    t = time.perf_counter()
    for p in paths:
        meshio.read(p)
    t_meshio = time.perf_counter() - t
    print(f"read one VTU: {t_one:.2f} s; series of {args.steps} (mesh decoded once): {t_series:.2f} s; "
          f"meshio.read on every file: {t_meshio:.2f} s")

    rng = np.random.default_rng(0)
    scale = (np.arange(args.steps) + 1) / args.steps  # step k carries (k + 1) / steps x the analytic field
    print(f"{'receptors':>9} {'method':>8} {'weights_s':>10} {'apply_s':>8} {'peak_MB':>8} {'max_err_Pa':>11} {'rms_err_Pa':>11} {'max_rel':>8}")
    for n_r in args.receptors:
        pos = rng.uniform([0.05, 0.05, 0.05], [3.95, 3.05, 3.95], (n_r, 3))
        layout = ReceptorLayout(pos * 1e-3)
        exact = scale[:, None] * analytic(pos)[None, :]
        for method in ("nearest", "linear"):
            tracemalloc.start()
            row, = measure_sampling(field, layout, exact, methods=(method,), repeat=1)  # afferent report's measurement
            peak = tracemalloc.get_traced_memory()[1] / 1e6
            tracemalloc.stop()
            print(f"{n_r:>9} {method:>8} {row['weights_s']:>10.3f} {row['per_step_s'] * args.steps:>8.4f} {peak:>8.0f} "
                  f"{row['abs_err_max_pa']:>11.3g} {row['abs_err_rms_pa']:>11.3g} {row['err_max']:>8.2%}")
    del field1


if __name__ == "__main__":
    main()
