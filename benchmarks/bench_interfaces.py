"""Benchmark: what coincident points and material interfaces did to receptor SED, and what the fix costs.

Run:  python benchmarks/bench_interfaces.py

1. The deal.II export of tests/data/dealii (discontinuous output: 8 copies per node): receptor SED
   with 'linear' and 'nearest' against the mean of the copies at each receptor node (what
   read_sed now gives; before, the sampler took one copy).
2. The packaged sample (afferent/data/sample/block4, cell SED, 119 papilla tips on the
   epidermis/dermis interface): 'nearest' on cell data against the nodal SED (the volume
   average of the cells around each node), and each side against the average.
3. Time of read_sed and sample_sed on sample_sed/block8 (89,739 nodes, 595 tips), warm.
"""

from __future__ import annotations

import os
import sys
import time
import warnings

import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)  # this checkout's afferent

import afferent  # noqa: E402
from afferent.io import read_raw  # noqa: E402


def _off(a, b) -> str:
    d = np.abs(np.asarray(a) / np.asarray(b) - 1)
    return f"median {100 * np.median(d):.3g} %, max {100 * d.max():.3g} %"


def dealii() -> None:
    vtu = os.path.join(ROOT, "tests", "data", "dealii", "indent_block.vtu")
    lay = afferent.read_receptors(os.path.join(ROOT, "tests", "data", "dealii", "receptors.csv"), length_unit="mm")
    raw = read_raw(vtu)
    nodes = [i for i, r in enumerate(lay.ids) if r != "mid"]
    ref = []
    for i in nodes:
        at = np.all(np.abs(raw.points - lay.positions[i] * 1e3) < 1e-6, axis=1)
        ref.append(raw.arrays["sed"].values[0, at].mean() * 1e6)
    field = afferent.read_sed(vtu, length_unit="mm", sed_unit="MPa")
    for method in ("linear", "nearest"):
        got = afferent.sample_sed(field, lay, method=method).values[0, nodes]
        print(f"deal.II, {method}: receptor SED vs the mean of the copies: {_off(got, ref)}")
    print(f"deal.II, copies: {field.provenance.coincident}")


def sample() -> None:
    folder = os.path.join(ROOT, "afferent", "data", "sample", "block4")
    lay = afferent.read_receptors(os.path.join(folder, "receptors.csv"), length_unit="mm")
    path = os.path.join(folder, "indent_0p88mm.vtu")
    cell = afferent.read_sed(path, length_unit="mm", sed_unit="MPa", location="cell")
    nodal = afferent.sample_sed(afferent.read_sed(path, length_unit="mm", sed_unit="MPa"), lay, method="nearest").values
    avg = afferent.sample_sed(cell, lay, method="nearest")
    print(f"sample, nearest on cell data vs the nodal SED: {_off(avg.values, nodal)}")
    for side in (1, 2):
        got = afferent.sample_sed(cell, lay, method="nearest", side=side).values
        print(f"sample, side={side} vs 'average': {_off(got, avg.values)}")


def timing() -> None:
    folder = os.path.join(ROOT, "sample_sed", "block8")
    path, rec = os.path.join(folder, "indent_4p00mm.vtu"), os.path.join(folder, "receptors.csv")
    if not os.path.exists(path):
        print("sample_sed/block8 absent: timing skipped")
        return
    lay = afferent.read_receptors(rec, length_unit="mm")
    field = afferent.read_sed(path, length_unit="mm", sed_unit="MPa")
    afferent.sample_sed(field, lay)
    t = time.perf_counter()
    field = afferent.read_sed(path, length_unit="mm", sed_unit="MPa")
    t_read = time.perf_counter() - t
    t = time.perf_counter()
    afferent.sample_sed(field, lay)
    print(f"block8 (warm): read_sed {t_read:.3f} s, sample_sed {time.perf_counter() - t:.3f} s "
          f"({field.n_points} nodes, {lay.n_receptors} receptors)")


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    dealii()
    sample()
    timing()
