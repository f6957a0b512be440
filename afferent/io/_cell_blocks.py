"""meshio cell blocks to afferent's cells: the volume blocks, their split into linear tetrahedra.

Every mesh reader (VTU, XDMF, .frd, Exodus, MED, .rst, .xplt) hands its cells over as meshio
``CellBlock``-like objects (``.type``, ``.data``: VTK node order); :func:`cells_from_meshio` keeps
the volume blocks and splits them into the linear tetrahedra afferent locates points in, with a
quadratic mesh's full connectivity beside them. :func:`volume_type_blocks` renames VTK Lagrange
cells of degree <= 2 and refuses the volume cells afferent cannot interpolate in;
:func:`_volume_rows` says which of a file's cells are volume cells (for cell arrays over all of them).
"""

from __future__ import annotations

import os
import re

import numpy as np

from ..exceptions import SEDFormatError
from ..field import Cells

__all__ = ["cells_from_meshio", "volume_type_blocks"]

# Corner nodes of each volume cell type, then its split into linear tetrahedra (VTK node order).
_TETS = {
    "tetra": [(0, 1, 2, 3)],
    "hexahedron": [(0, 6, 1, 2), (0, 6, 2, 3), (0, 6, 3, 7), (0, 6, 7, 4), (0, 6, 4, 5), (0, 6, 5, 1)],
    "wedge": [(0, 1, 2, 3), (1, 2, 3, 4), (2, 3, 4, 5)],
    "pyramid": [(0, 1, 2, 4), (0, 2, 3, 4)],
}
_HIGHER = {
    "tetra10": "tetra", "tetra14": "tetra", "hexahedron20": "hexahedron", "hexahedron24": "hexahedron",
    "hexahedron27": "hexahedron", "wedge15": "wedge", "wedge18": "wedge", "pyramid13": "pyramid",
    "pyramid14": "pyramid",
}


#: VTK Lagrange cells of degree 1 and 2 (meshio name, node count) -> the meshio type with the same
#: nodes in the same order: VTK >= 9 numbers a quadratic Lagrange cell as its quadratic cell
#: (vtkLagrange*.PointIndexFromIJK, checked in tests/test_quadratic.py). Higher degrees are refused.
_LAGRANGE = {
    ("VTK_LAGRANGE_TETRAHEDRON", 4): "tetra", ("VTK_LAGRANGE_TETRAHEDRON", 10): "tetra10",
    ("VTK_LAGRANGE_HEXAHEDRON", 8): "hexahedron", ("VTK_LAGRANGE_HEXAHEDRON", 27): "hexahedron27",
    ("VTK_LAGRANGE_WEDGE", 6): "wedge", ("VTK_LAGRANGE_WEDGE", 18): "wedge18",
}
#: VTK files written before VTK 9 (VTU file version < 2.1, legacy file version < 5.1) number the
#: mid-edge nodes on the vertical edges (x=0, y=1) and (x=1, y=1) of a quadratic Lagrange hexahedron
#: the other way round; VTK's own readers swap them back (nodes 18 and 19), as does afferent.
_OLD_LAGRANGE_HEX = np.r_[0:18, 19, 18, 20:27]
#: Topological dimension of the cell types meshio 5.3 can read from VTK files but leaves out of its
#: own table (``meshio._mesh.topological_dimension``): without them reading a file holding one
#: fails with ``KeyError: 'wedge15'``.
_MESHIO_MISSING_DIMENSIONS = {
    "wedge15": 3, "pyramid13": 3, "hexahedron24": 3, "wedge12": 3, "penta_prism": 3, "hexa_prism": 3,
    "polyhedron": 3, "quad6": 2, "triangle7": 2, "pixel": 2, "empty": 0, "VTK_BEZIER_CURVE": 1,
    "VTK_BEZIER_TRIANGLE": 2, "VTK_BEZIER_QUADRILATERAL": 2, "VTK_BEZIER_TETRAHEDRON": 3,
    "VTK_BEZIER_HEXAHEDRON": 3, "VTK_BEZIER_WEDGE": 3, "VTK_BEZIER_PYRAMID": 3,
}


def _complete_meshio_dimensions() -> None:
    """Add the missing entries of :data:`_MESHIO_MISSING_DIMENSIONS` to meshio's table (only missing ones)."""
    from meshio._mesh import topological_dimension

    for name, dim in _MESHIO_MISSING_DIMENSIONS.items():
        topological_dimension.setdefault(name, dim)


class _Block:  # what cells_from_meshio reads: .type and .data
    def __init__(self, ctype, data):
        self.type, self.data = ctype, data


def _old_lagrange_numbering(path: str) -> bool:
    """Whether a VTK file numbers Lagrange hexahedra as before VTK 9 (see :data:`_OLD_LAGRANGE_HEX`)."""
    ext = os.path.splitext(path)[1].lower()
    if ext == ".vtu":
        return (_vtu_version(path) or (0, 0)) < (2, 1)
    if ext != ".vtk":
        return False
    with open(path, "rb") as fh:
        m = re.match(rb"#\s*vtk DataFile Version (\d+)\.(\d+)", fh.readline())
    return m is not None and (int(m.group(1)), int(m.group(2))) < (5, 1)


#: How the tools that write Lagrange cells of a higher degree write them of degree 2 or less
#: (checked on tests/data/mfem and tests/data/ngsolve: docs/fe-export.md).
_LAGRANGE_HINT = (" A Lagrange cell's degree is the export's: MFEM's ParaViewDataCollection with SetHighOrderOutput(true) "
                  "writes cells of degree SetLevelsOfDetail(n) (write n <= 2, or SetHighOrderOutput(false): n x n x n "
                  "linear cells per element); NGSolve's VTKOutput(order=k) cells of degree k (write order=2, or "
                  "order=1 with subdivision).")


def volume_type_blocks(cells, path: str) -> list:
    """meshio cell blocks with VTK Lagrange cells of degree <= 2 renamed to the equivalent meshio type.

    Raises SEDFormatError naming the file and the cell type for a volume cell type afferent cannot
    interpolate in (Lagrange cells of degree 3 and more, Bezier cells, polyhedra): such a mesh is
    never treated as scattered points.
    """
    from meshio._mesh import topological_dimension

    out = []
    for block in cells:
        data = np.asarray(block.data)
        ctype = _LAGRANGE.get((block.type, data.shape[1] if data.ndim == 2 else 0), block.type)
        if _HIGHER.get(ctype, ctype) not in _TETS and topological_dimension.get(ctype, 3) == 3:
            n = data.shape[1] if data.ndim == 2 else "a varying number of"
            raise SEDFormatError(
                f"SED file {path!r} holds {len(data)} volume cell(s) of type {ctype!r} ({n} nodes), which afferent "
                "cannot interpolate in; it reads tetrahedra, hexahedra, wedges and pyramids, linear or quadratic "
                "(tetra10, hexahedron20/27, wedge15/18, pyramid13), and VTK Lagrange cells of degree 1 or 2. "
                "Convert the mesh to quadratic cells (ParaView: Tessellate; or export VTK_QUADRATIC_* cells)."
                + (_LAGRANGE_HINT if ctype.startswith("VTK_LAGRANGE") else ""))
        if block.type == "VTK_LAGRANGE_HEXAHEDRON" and ctype == "hexahedron27" and _old_lagrange_numbering(path):
            data = data[:, _OLD_LAGRANGE_HEX]
        out.append(block if ctype == block.type else _Block(ctype, data))
    return out


def _volume_blocks(cells) -> list[tuple[int, str, np.ndarray]]:
    out = []
    for k, block in enumerate(cells):
        base = _HIGHER.get(block.type, block.type)
        if base in _TETS:
            out.append((k, block.type, np.asarray(block.data)))
    return out


def cells_from_meshio(cells, path: str) -> Cells | None:
    """Split meshio volume cell blocks into linear tetrahedra; None when the mesh has no volume cells.

    Every cell is split by its corner nodes (to locate points); a mesh with cells other than linear
    tetrahedra keeps every block's full connectivity in VTK/meshio node order (:attr:`Cells.nodes`),
    which 'linear' sampling interpolates in with the cells' own shape functions. Surface and
    line blocks are ignored. A block whose rows do not hold its cell type's node count is
    refused, naming ``path`` (the export).
    """
    from meshio._common import num_nodes_per_cell

    blocks = _volume_blocks(cells)
    if not blocks:
        return None
    for _, ctype, conn in blocks:
        if conn.ndim != 2 or conn.shape[1] != num_nodes_per_cell[ctype]:
            raise SEDFormatError(f"SED file {path!r}: a block of {ctype!r} cells must hold {num_nodes_per_cell[ctype]} "
                                 f"node numbers per cell; got an array of shape {conn.shape} instead.")
    # every cell but the tetrahedron has shape functions of its own (afferent/_shape_functions.py): its full
    # connectivity is kept, and its tetrahedra are split from it when used (Cells.split: sampling a few
    # receptors splits the cells near them only); a mesh of tetrahedra alone needs no more than its tetrahedra
    patterns = [np.asarray(_TETS[_HIGHER.get(ctype, ctype)]) for _, ctype, _ in blocks]
    n_cells, types = sum(b[2].shape[0] for b in blocks), tuple(b[1] for b in blocks)
    if any(ctype != "tetra" for _, ctype, _ in blocks):
        return Cells.split([(p, b[2]) for p, b in zip(patterns, blocks)], n_cells=n_cells, cell_types=types, nodes=True)
    tets = [np.take(conn.astype(np.int64, copy=False), p.ravel(), axis=1).reshape(-1, 4) for p, (_, _, conn) in zip(patterns, blocks)]
    parent = np.arange(n_cells)  # one tetrahedron a cell
    return Cells(tets[0] if len(tets) == 1 else np.concatenate(tets), parent, n_cells, types)


def _vtu_version(path: str) -> tuple[int, int] | None:
    """The VTKFile version attribute of a .vtu, as (major, minor); None when absent or unreadable."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return None
    m = re.search(rb'<VTKFile[^>]*\bversion="(\d+)\.(\d+)"', head)
    return None if m is None else (int(m.group(1)), int(m.group(2)))


def _volume_rows(blocks) -> np.ndarray | None:
    """The rows of the volume cells among all the cells of ``blocks`` (in the blocks' order: a VTU's
    file order); None when every block is of volume cells."""
    vol = [k for k, _, _ in _volume_blocks(blocks)]
    if len(vol) == len(blocks):
        return None
    starts = np.cumsum([0] + [len(b.data) for b in blocks])
    return np.concatenate([np.arange(starts[k], starts[k + 1]) for k in vol] or [np.zeros(0, np.int64)])
