"""Write a MED mesh with Kratos Multiphysics' MED application (a second MED writer, mesh only).

Regenerate (Kratos 10.4.4 wheels; KratosMedApplication needs MPICH's libmpi.so.12)::

    /work/venvs/med/bin/pip install KratosMultiphysics==10.4.4 KratosMedApplication==10.4.4
    apt-get install libmpich12 && mkdir -p /work/venvs/med/mpilib && \\
        ln -sf /usr/lib/x86_64-linux-gnu/libmpich.so.12 /work/venvs/med/mpilib/libmpi.so.12
    LD_LIBRARY_PATH=/work/venvs/med/mpilib /work/venvs/med/bin/python tests/data/med/make_kratos_mesh.py

The mesh: 2 x 2 x 1 Kratos ``Hexahedra3D8`` geometries of 1 mm (coordinates in m), nodes
numbered x fastest, then y, then z; Kratos's MedModelPartIO converts its node order to MED's.
KratosMedApplication writes meshes only (no result fields).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import KratosMultiphysics as KM
import KratosMultiphysics.MedApplication as Med

HERE = Path(__file__).resolve().parent


def main() -> None:
    model = KM.Model()
    mp = model.CreateModelPart("block")
    ids = {}
    for k, j, i in itertools.product(range(2), range(3), range(3)):
        ids[(i, j, k)] = len(ids) + 1
        mp.CreateNewNode(ids[(i, j, k)], i * 1e-3, j * 1e-3, k * 1e-3)
    for g, (j, i) in enumerate(itertools.product(range(2), range(2)), start=1):
        corner = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        mp.CreateNewGeometry("Hexahedra3D8", g, [ids[(i + a, j + b, c)] for a, b, c in corner])
    path = HERE / "kratos_block.med"
    path.unlink(missing_ok=True)
    Med.MedModelPartIO(str(path), KM.IO.WRITE).WriteModelPart(mp)


if __name__ == "__main__":
    main()
