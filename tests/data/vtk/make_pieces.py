"""Write VTU files with several ``<Piece>`` elements, with VTK itself.

Regenerate (VTK 9.7.2, the ``vtk`` wheel)::

    python tests/data/vtk/make_pieces.py

A box of 4 x 3 x 2 hexahedra (unit edges, x in 0..4, y in 0..3, z in 0..2, file unit mm) is split
by ``vtkExtractUnstructuredGridPiece`` into two pieces of 12 cells each, each reduced to the
points its cells use by ``vtkRemoveUnusedPoints`` (the points on
the face between the pieces are written twice, once in each), which
``vtkXMLUnstructuredGridWriter`` with ``SetNumberOfPieces(2)`` streams into one file with two
``<Piece>`` elements. Arrays:

- point ``SED`` = 1 + 2x + 3y + z (linear: any sampling inside the cells gives it back exactly);
- point ``S``: 6 components named XX YY ZZ XY YZ ZX (``ComponentName0..5``), component k = k + x;
- cell ``cell_id``: the cell's number in the whole box (0..23), in the writer's order.

``pieces3_empty.vtu``: a 1 x 1 x 2 box streamed in three pieces, the middle one empty (0 points,
0 cells, as a parallel writer's idle rank leaves it; meshio's decoder fails on its empty zlib arrays).

``pieces2.vtu``: VTK's default layout (appended raw binary, zlib), all three arrays.
``pieces2_ascii.vtu``: ASCII, the point arrays only. meshio 5.3.5 reads both pieces' points
(80) from each but only the last piece's 12 cells; afferent before its own VTU reader refused
the first ("expected one Piece in a series step") and read the second with half its cells.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk

HERE = Path(__file__).resolve().parent


def box(NX: int = 4, NY: int = 3, NZ: int = 2) -> vtk.vtkUnstructuredGrid:  # noqa: N803 (the box's cell counts)
    """The NX x NY x NZ hexahedra box with its arrays (see the module docstring)."""
    idx = np.arange((NX + 1) * (NY + 1) * (NZ + 1)).reshape(NZ + 1, NY + 1, NX + 1)
    z, y, x = np.meshgrid(np.arange(NZ + 1), np.arange(NY + 1), np.arange(NX + 1), indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()]).astype(float)
    grid = vtk.vtkUnstructuredGrid()
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(pts, deep=True))
    grid.SetPoints(points)
    for k in range(NZ):
        for j in range(NY):
            for i in range(NX):
                corner = [idx[k, j, i], idx[k, j, i + 1], idx[k, j + 1, i + 1], idx[k, j + 1, i]]
                top = [idx[k + 1, j, i], idx[k + 1, j, i + 1], idx[k + 1, j + 1, i + 1], idx[k + 1, j + 1, i]]
                grid.InsertNextCell(vtk.VTK_HEXAHEDRON, 8, [int(c) for c in corner + top])
    sed = numpy_to_vtk(1 + 2 * pts[:, 0] + 3 * pts[:, 1] + pts[:, 2], deep=True)
    sed.SetName("SED")
    grid.GetPointData().AddArray(sed)
    s = numpy_to_vtk(np.arange(6)[None, :] + pts[:, :1], deep=True)
    s.SetName("S")
    for c, name in enumerate(("XX", "YY", "ZZ", "XY", "YZ", "ZX")):
        s.SetComponentName(c, name)
    grid.GetPointData().AddArray(s)
    cid = numpy_to_vtk(np.arange(grid.GetNumberOfCells(), dtype=float), deep=True)
    cid.SetName("cell_id")
    grid.GetCellData().AddArray(cid)
    return grid


def write(name: str, ascii_: bool, cell_data: bool, size=(4, 3, 2), pieces: int = 2) -> None:
    grid = box(*size)
    if not cell_data:
        grid.GetCellData().RemoveArray("cell_id")
    split = vtk.vtkExtractUnstructuredGridPiece()
    split.SetInputData(grid)
    used = vtk.vtkRemoveUnusedPoints()  # each piece keeps only the points its cells use
    used.SetInputConnection(split.GetOutputPort())
    used.SetGenerateOriginalPointIds(False)
    writer = vtk.vtkXMLUnstructuredGridWriter()
    writer.SetInputConnection(used.GetOutputPort())
    writer.SetFileName(str(HERE / name))
    writer.SetNumberOfPieces(pieces)
    if ascii_:
        writer.SetDataModeToAscii()
    if not writer.Write():
        raise RuntimeError(f"VTK could not write {name}")


if __name__ == "__main__":
    write("pieces2.vtu", ascii_=False, cell_data=True)
    write("pieces2_ascii.vtu", ascii_=True, cell_data=False)
    write("pieces3_empty.vtu", ascii_=False, cell_data=True, size=(1, 1, 2), pieces=3)
    for name in ("pieces2.vtu", "pieces2_ascii.vtu", "pieces3_empty.vtu"):
        print(name, (HERE / name).stat().st_size, "bytes")
