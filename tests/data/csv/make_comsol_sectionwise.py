"""Write comsol_sectionwise.txt of this folder: a piece of the sample skin block in COMSOL's Sectionwise layout.

Run from the repository root: ``python tests/data/csv/make_comsol_sectionwise.py`` (needs meshio and numpy; no
COMSOL). The layout imitates real COMSOL Results > Export > Data files with Data format: Sectionwise (README.md
here and docs/fe-export.md, COMSOL section, say which real files): a ``% Key:`` preamble padded to column 22,
``% Coordinates`` (one point a line, numbers left-aligned in 25-character fields), ``% Elements (tetrahedra)``
(1-based point numbers in 10-character fields), then one ``% Data (expr (unit) @ t=T)`` section per expression
and time with one value a line, every line ending in blanks as COMSOL's do.

The mesh is the hexahedra of ``sample_sed/block4`` inside a small box around some receptor sites, each split into
six tetrahedra along its 0-6 diagonal (the split afferent itself makes of a hexahedron, so that linear sampling in
this file equals linear sampling in the VTU), the points renumbered from 1. The SED is the sample's (MPa) written
in J/m^3 at t=0.5 (indent_0p44mm.vtu) and t=1 (indent_0p88mm.vtu).
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

HERE = Path(__file__).parent
BLOCK = HERE.parents[2] / "sample_sed" / "block4"
#: The box (mm) the hexahedra are taken from: receptor sites 1-3 and their neighbours in x lie inside.
BOX = (np.array([0.55, 2.3, 0.1]), np.array([1.25, 2.6, 0.8]))
#: afferent's split of a VTK hexahedron into tetrahedra (afferent/io/_cell_blocks.py, _TETS).
HEX_TETS = [(0, 6, 1, 2), (0, 6, 2, 3), (0, 6, 3, 7), (0, 6, 7, 4), (0, 6, 4, 5), (0, 6, 5, 1)]


def _row(values, width: int) -> str:
    return "".join(f"{v!s:<{width}}" for v in values) + "\n"


def main() -> None:
    meshes = {t: meshio.read(BLOCK / f"indent_{name}.vtu") for t, name in (("0.5", "0p44mm"), ("1", "0p88mm"))}
    mesh = meshes["1"]
    hexes = mesh.cells_dict["hexahedron"]
    centre = mesh.points[hexes].mean(axis=1)
    keep = hexes[np.all((centre > BOX[0]) & (centre < BOX[1]), axis=1)]
    tets = keep[:, np.array(HEX_TETS).ravel()].reshape(-1, 4)
    used = np.unique(tets)
    number = np.full(len(mesh.points), -1)
    number[used] = np.arange(1, len(used) + 1)
    out = [
        "% Model:              skin_block.mph\n",
        "% Version:            COMSOL 6.2.0.290\n",
        "% Date:               Nov 24 2026, 10:00\n",
        "% Dimension:          3\n",
        f"% Nodes:              {len(used)}\n",
        f"% Elements:           {len(tets)}\n",
        "% Expressions:        2\n",
        "% Description:        Elastic strain energy density\n",
        "% Length unit:        mm\n",
        "% Coordinates\n",
    ]
    out += [_row([float(c) for c in p], 25) for p in mesh.points[used]]
    out.append("% Elements (tetrahedra)\n")
    out += [_row(r, 10) for r in number[tets].tolist()]
    for t, m in meshes.items():
        out.append(f"% Data (solid.Ws (J/m^3) @ t={t})\n")
        out += [_row([float(v) * 1e6], 25) for v in m.point_data["SED"][used]]
    (HERE / "comsol_sectionwise.txt").write_text("".join(out))
    print(f"comsol_sectionwise.txt: {len(used)} points, {len(keep)} hexahedra -> {len(tets)} tetrahedra")


if __name__ == "__main__":
    main()
