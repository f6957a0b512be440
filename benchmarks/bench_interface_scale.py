"""Benchmark: time and peak memory of interface-aware sampling against the number of receptors (issues 33, 38).

Run from the repository root::

    .venv/bin/python benchmarks/bench_interface_scale.py                 # 1e4, 1e5 and 1e6 receptors
    .venv/bin/python benchmarks/bench_interface_scale.py --counts 1e4 1e5
    .venv/bin/python benchmarks/bench_interface_scale.py --afferent /path/to/other/checkout   # another tree

The mesh is the bundled sample ``sample_sed/block4/indent_0p88mm.vtu`` (41,595 nodes, 224,112
tetrahedra, its ``layer`` array as material ids), point data. The receptors are drawn uniformly
on its material interfaces (random points of the triangles shared by tetrahedra of two
materials, seed 12): every one of them touches two materials, the worst case for
:func:`afferent._interfaces.build_interface`, which finds for each receptor every tetrahedron
holding it (before issue 33: every receptor-candidate pair at once, ~30 kB a receptor; now in
chunks of ``PAIRS_PER_CHUNK`` candidates).

Each count runs in a fresh child process (importing afferent from ``--afferent``), which
reports the wall time and the peak resident memory (``VmHWM``, Linux; the interpreter, the mesh
and the layout included, printed apart as "setup") of ``build_interface`` and then of the whole
``sample_sed(field, layout)`` (linear sampling, the side report of every receptor).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

_CHILD = r"""
import json, sys, time, warnings
import numpy as np
warnings.simplefilter("ignore")
import afferent
from afferent._interfaces import build_interface

def peak():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024

n = int(float(sys.argv[1]))
field = afferent.read_sed(sys.argv[2], length_unit="mm", sed_unit="MPa")
tet, mat = field.cells.tetra, field.cells.materials[field.cells.parent]
faces = np.sort(np.concatenate([tet[:, [0, 1, 2]], tet[:, [0, 1, 3]], tet[:, [0, 2, 3]], tet[:, [1, 2, 3]]]), axis=1)
owner = np.tile(mat, 4)
order = np.lexsort(faces.T[::-1])
faces, owner = faces[order], owner[order]
interface = faces[1:][np.all(faces[1:] == faces[:-1], axis=1) & (owner[1:] != owner[:-1])]
rng = np.random.default_rng(12)
corners = field.points[interface[rng.integers(0, len(interface), n)]]
layout = afferent.ReceptorLayout(np.einsum("nk,nkd->nd", rng.dirichlet([1, 1, 1], n), corners))
out = {"setup_mb": peak(), "triangles": int(len(interface))}
t = time.perf_counter()
isamp = build_interface(field, layout)
out.update(build_s=time.perf_counter() - t, build_mb=peak(), rows=int(isamp.receptor.size))
t = time.perf_counter()
sed = afferent.sample_sed(field, layout)
out.update(sample_s=time.perf_counter() - t, sample_mb=peak(), on_interface=sed.interface["n_on_interface"])
print(json.dumps(out))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--counts", nargs="+", default=["1e4", "1e5", "1e6"], help="receptor counts")
    parser.add_argument("--afferent", default=ROOT, help="the checkout whose afferent runs (default: this one)")
    args = parser.parse_args()
    tree = os.path.abspath(args.afferent)
    mesh = os.path.join(ROOT, "sample_sed", "block4", "indent_0p88mm.vtu")
    print("command:", " ".join([os.path.basename(sys.executable)] + sys.argv))
    print(f"afferent from {tree}; mesh {os.path.relpath(mesh, ROOT)}")
    for count in args.counts:
        done = subprocess.run([sys.executable, "-c", _CHILD, count, mesh], capture_output=True, text=True, cwd=tree,
                              env=dict(os.environ, PYTHONPATH=tree, MPLBACKEND="Agg"))
        if done.returncode:
            print(f"{float(count):>9,.0f} receptors: failed: {done.stderr.strip().splitlines()[-1]}")
            continue
        got = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{float(count):>9,.0f} receptors ({got['on_interface']:,} on the interface): setup peak "
              f"{got['setup_mb']:6.0f} MB; build_interface {got['build_s']:7.2f} s, peak {got['build_mb']:6.0f} MB; "
              f"sample_sed {got['sample_s']:7.2f} s, peak {got['sample_mb']:6.0f} MB")


if __name__ == "__main__":
    main()
