"""Shared fixtures: tiny meshes built in code, the bundled sample folder, a seeded RNG."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import meshio
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

# Runs of the suite never read or fill the user's cache (~/.cache/afferent): each test process
# gets its own empty one (tests that exercise the cache pass their own cache_dir).
os.environ["AFFERENT_CACHE_DIR"] = tempfile.mkdtemp(prefix="afferent-test-cache-")
SAMPLE_DIR = ROOT / "sample_sed"
DATA_DIR = Path(__file__).resolve().parent / "data"


def hex_box(nx=4, ny=3, nz=5, size=(1.3, 0.7, 1.9)):
    """A structured hexahedral box (VTK node order), coordinates in mm; returns (points, hexes)."""
    xs, ys, zs = (np.linspace(0.0, s, n + 1) for s, n in zip(size, (nx, ny, nz)))
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def nid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    hexes = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                # VTK hexahedron: bottom face (z = k) counter-clockwise, then top face (z = k+1)
                hexes.append([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                              nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)])
    return points, np.array(hexes)


def linear_sed(points_mm):
    """A field linear in space, in MPa: 'linear' sampling must reproduce it exactly."""
    x, y, z = points_mm.T
    return 1e-4 * (1.0 + 0.37 * x + 0.11 * y + 0.23 * z)


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


@pytest.fixture
def sample_sed_dir():
    return SAMPLE_DIR


@pytest.fixture
def data_dir():
    return DATA_DIR


@pytest.fixture
def box_vtu(tmp_path):
    """A small hex-mesh VTU in mm / MPa with point 'SED' (linear), cell 'SED' and cell 'layer'."""
    points, hexes = hex_box()
    cell_centres = points[hexes].mean(axis=1)
    mesh = meshio.Mesh(
        points,
        [("hexahedron", hexes)],
        point_data={"SED": linear_sed(points)},
        cell_data={"SED": [linear_sed(cell_centres)], "layer": [np.arange(len(hexes)) % 3 + 1]},
    )
    path = tmp_path / "box.vtu"
    meshio.write(path, mesh, binary=True, compression="zlib")
    return path


#: Papilla pitch across (x) and along (z) the ridges of the bump grid, mm.
PITCH_X, PITCH_Z = 0.44, 0.22


def write_bump(folder, n_xz: int):
    """A 4 x 3.1 x 4 mm hex block (``n_xz`` cells across x and z) with a Gaussian SED bump (MPa) centred at
    x = z = 2 mm, as ``bump.vtu``, and a papilla grid 2.35 mm up as ``R.csv`` (mm); returns (vtu, receptors, xs, zs)."""
    import pandas as pd

    points, hexes = hex_box(n_xz, 4, n_xz, size=(4.0, 3.1, 4.0))
    x, y, z = points.T
    sed = 1.9e-4 * np.exp(-((x - 2.0) ** 2 + (z - 2.0) ** 2) / 0.6) * (y / 3.1)
    vtu = folder / "bump.vtu"
    meshio.write(vtu, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}))
    xs, zs = np.arange(PITCH_X / 2, 4.0, PITCH_X), np.arange(PITCH_Z / 2, 4.0, PITCH_Z)
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    receptors = folder / "R.csv"
    pd.DataFrame({"x": X.ravel(), "y": 2.35, "z": Z.ravel()}).to_csv(receptors, index=False)
    return vtu, receptors, xs, zs
