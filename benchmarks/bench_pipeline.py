"""Benchmark: wall time of each static-pipeline stage for 150 and for 100,000 receptors.

Run:  python benchmarks/bench_pipeline.py [--export PATH --length-unit mm --sed-unit MPa] [--receptors 150 100000]

Without --export a structured 4 x 3.1 x 4 mm hexahedral block of about 270,000 nodes with a
smooth SED bump is written to a temporary VTU first (the size the brief quotes for real
fingertip meshes). Receptors lie on a regular x-z grid at the papilla depth (y = 2.35 mm),
as many as asked (for 100,000 the grid is far denser than real papillae: it measures cost).
Stages: read, sampling (weights once + apply), transduction, synthesis (longitudinal and
random:13), profile comparison.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import meshio
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's afferent

import afferent  # noqa: E402
from afferent.profiles import ObservedProfile, compare_profiles  # noqa: E402
from afferent.receptors import ReceptorLayout, grid_layout  # noqa: E402
from afferent.report import hex_block  # noqa: E402
from afferent.synthesis import Branching  # noqa: E402
from afferent.transduction import STUDY_PARAMS, saturation_report  # noqa: E402


def synthetic_export(n_points: int) -> str:
    n = (n_points / (4 * 4 * 3.1)) ** (1 / 3)
    nx = nz = max(2, round(n * 4)) - 1
    ny = max(2, round(n * 3.1)) - 1
    points, hexes = hex_block(nx, ny, nz, size=(4.0, 3.1, 4.0))
    x, y, z = points.T
    sed = 1.9e-4 * np.exp(-((x - 2) ** 2 + (z - 2) ** 2) / 0.6) * y / 3.1
    path = os.path.join(tempfile.mkdtemp(), "bench.vtu")
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}), binary=True, compression="zlib")
    return path


def grid(n_receptors: int, lo=0.1e-3, hi=3.9e-3, y=2.35e-3) -> ReceptorLayout:
    """A k x k grid (k = ceil(sqrt(n))) with section labels from the grid indices (not regrouped:
    at 100,000 receptors the pitch, 12 um, is below the default grouping tolerance)."""
    k = int(np.ceil(np.sqrt(n_receptors)))
    pitch = (hi - lo) / (k - 1)
    layout = grid_layout(x_range=(lo, hi), z_range=(lo, hi), y=y, pitch_x=pitch, pitch_z=pitch, origin=(lo, lo))
    return layout.subset(np.arange(min(n_receptors, layout.n_receptors)))


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--export")
    ap.add_argument("--length-unit", default="mm")
    ap.add_argument("--sed-unit", default="MPa")
    ap.add_argument("--points", type=int, default=270_000)
    ap.add_argument("--receptors", type=int, nargs="+", default=[150, 100_000])
    args = ap.parse_args(argv)
    path = args.export or synthetic_export(args.points)
    print(f"# command: python benchmarks/bench_pipeline.py {' '.join(sys.argv[1:]) if argv is None else ' '.join(argv)}")
    t = time.perf_counter()
    field = afferent.read_sed(path, length_unit=args.length_unit, sed_unit=args.sed_unit)
    t_read = time.perf_counter() - t
    print(f"# export: {path}: {field.n_points:,} points, {field.cells.n_cells if field.cells else 0:,} cells; read {t_read:.2f} s")
    params = STUDY_PARAMS["start"]
    t = time.perf_counter()
    import sklearn.metrics  # noqa: F401  (compare_profiles' r2 uses it: import cost once, not per call)
    print(f"# import sklearn.metrics (first comparison only): {time.perf_counter() - t:.2f} s")
    print(f"{'receptors':>9} {'sample_w_s':>10} {'sample_s':>9} {'transduce_s':>11} {'saturation_s':>12} {'long_synth_s':>12} "
          f"{'random13_s':>10} {'compare_s':>9}")
    for n in args.receptors:
        layout = grid(n)
        t = time.perf_counter(); sampler = afferent.sampling.build_sampler(field, layout); t_w = time.perf_counter() - t
        t = time.perf_counter(); sed = afferent.sample_sed(field, layout, sampler=sampler); t_s = time.perf_counter() - t
        t = time.perf_counter(); cur = afferent.transduce(sed, params); t_t = time.perf_counter() - t
        t = time.perf_counter(); saturation_report(sed, params); t_sat = time.perf_counter() - t
        t = time.perf_counter(); aff = afferent.synthesize(cur, Branching.longitudinal(layout)); t_l = time.perf_counter() - t
        t = time.perf_counter(); afferent.synthesize(cur, Branching.random(layout, 13, rng=0)); t_r = time.perf_counter() - t
        obs = ObservedProfile(aff.positions, np.exp(-((aff.positions - 2e-3) / 1e-3) ** 2))
        t = time.perf_counter(); compare_profiles(aff, obs); t_c = time.perf_counter() - t
        print(f"{n:>9} {t_w:>10.3f} {t_s:>9.4f} {t_t:>11.4f} {t_sat:>12.4f} {t_l:>12.4f} {t_r:>10.3f} {t_c:>9.4f}")


if __name__ == "__main__":
    main()
