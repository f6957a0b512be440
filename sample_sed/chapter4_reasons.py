#!/usr/bin/env python
"""The 3-D/2-D ratio of the peak RA-I SED read several ways from the committed chapter-4 VTUs (no solve).

Issue 35 lists reasons why the sample's 3-D and 2-D ridged blocks might not show the study's focalizing
(3-D peak > 2-D peak). Two of them are read off the existing solutions here, one at a time:

* **side**: the SED at a tip node from the dermis elements only, or the epidermis elements only
  (volume-weighted average of the centroid SED of that layer's hexahedra sharing the node), instead of
  the nodal average across both layers that the VTUs carry;
* **table**: every papilla tip of the 3-D block at least one pitch from the side faces (every tip along z,
  pitch 0.22 mm; the same places on the 2-D block's continuous ridges) instead of the 10 x 10 table,
  which reads every second papilla along z.

The geometry (discrete pegs), the relaxed dermis and the mesh need new solves (sample_sed/README.md,
"Chapter 4: the stated reasons, one at a time"). Units: SED in Pa.

    python sample_sed/chapter4_reasons.py
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
INDENTERS = ("bar", "gap", "gap90", "circle")
LAYER_EPIDERMIS, LAYER_DERMIS = 1, 2


def hex_volumes(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Volumes (mm^3) of VTK hexahedra, five tetrahedra each."""
    v = np.zeros(len(cells))
    for a, b, c, d in ((0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6)):
        pa = points[cells[:, a]]
        v += np.abs(np.einsum("ij,ij->i", np.cross(points[cells[:, b]] - pa, points[cells[:, c]] - pa),
                              points[cells[:, d]] - pa)) / 6.0
    return v


def peaks(folder: Path, indenter: str, table: np.ndarray, every: np.ndarray) -> dict:
    """Largest SED (Pa) over the table's tips and over every tip, read four ways."""
    import meshio
    from scipy.spatial import cKDTree

    m = meshio.read(folder / f"{indenter}.vtu")
    cells, layer = m.cells[0].data, m.cell_data["layer"][0]
    sed, vol = m.cell_data["SED"][0].astype(float), hex_volumes(m.points, cells)
    tree = cKDTree(m.points)

    def nodes(xyz):
        d, i = tree.query(xyz)
        assert d.max() < 1e-6, f"{folder}: a tip {d.max():.3g} mm from every node"
        return i

    def side(idx, lay):
        out = []
        for n in idx:
            k = np.flatnonzero((cells == n).any(axis=1) & (layer == lay))
            out.append(np.sum(sed[k] * vol[k]) / np.sum(vol[k]))
        return np.asarray(out) * 1e6

    t, e = nodes(table), nodes(every)
    return {"nodal average (the sample)": m.point_data["SED"][t].max() * 1e6, "dermis side": side(t, LAYER_DERMIS).max(),
            "epidermis side": side(t, LAYER_EPIDERMIS).max(),
            "every tip, nodal average": m.point_data["SED"][e].max() * 1e6, "every tip, dermis side": side(e, LAYER_DERMIS).max()}


def ratio_table(sample: Path = HERE) -> list[str]:
    info = json.loads((sample / "chapter4" / "build_info.json").read_text())
    every = np.asarray(info["models"]["3d"]["sites"]["all_tips_xyz_mm"], dtype=float)
    res = {}
    for model in ("3d", "2d"):
        folder = sample / "chapter4" / f"ridged{model}"
        table = np.loadtxt(folder / "ra_sites.csv", delimiter=",", skiprows=1, ndmin=2)[:, 1:4]
        tips = every.copy()
        tips[:, 1] = table[0, 1]  # the 2-D block's ridge tops at the same height as the 3-D tips (y = 2.50)
        res[model] = {ind: peaks(folder, ind, table, tips) for ind in INDENTERS}
    rows = ["| read as | 3-D/2-D peak RA-I SED: bar, gap, gap90, circle | bar: 3-D, 2-D (Pa) |", "|---|---|---|"]
    for key in res["3d"]["bar"]:
        r = ", ".join(f"{res['3d'][i][key] / res['2d'][i][key]:.3f}" for i in INDENTERS)
        rows.append(f"| {key} | {r} | {res['3d']['bar'][key]:.0f}, {res['2d']['bar'][key]:.0f} |")
    return rows


if __name__ == "__main__":
    print("\n".join(ratio_table()))
