"""Write small VTK files with quadratic and Lagrange cells, with VTK itself.

Regenerate (VTK 9.7.2, the ``vtk`` wheel)::

    python tests/data/vtk/make_vtk.py

Each file holds a point array ``SED`` = 1 + x + y^2 + x z (x, y, z in the file's length unit),
exactly quadratic, so that sampling in a quadratic cell with its own shape functions gives it
back to rounding. The cells are the VTK reference cells (``GetParametricCoords``) under an affine
map (a shear and a stretch), so that their edges are straight and the field stays quadratic in
their natural coordinates.

- ``wedge15_pyramid13.vtu`` / ``.vtk``: one VTK_QUADRATIC_WEDGE and one VTK_QUADRATIC_PYRAMID
  side by side (XML file version 0.1 / legacy 5.1): meshio 5.3.5 failed on both with
  ``KeyError: 'wedge15'``.
- ``lagrange_hex27.vtk``: one VTK_LAGRANGE_HEXAHEDRON of degree 2 (27 nodes), legacy 5.1
  (VTK >= 9 node numbering).
- ``lagrange_hex27.vtu``: the same as VTK XML, which VTK writes as file version 2.3 (meshio reads
  0.1 and 1.0 only).
- ``lagrange_hex64.vtk``: one VTK_LAGRANGE_HEXAHEDRON of degree 3 (64 nodes), legacy 5.1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk

HERE = Path(__file__).resolve().parent
AFFINE = np.array([[1.0, 0.3, 0.1], [0.0, 0.8, 0.2], [0.1, 0.0, 1.2]])


def sed(p: np.ndarray) -> np.ndarray:
    x, y, z = p.T
    return 1 + x + y**2 + x * z


def _reference(cell) -> np.ndarray:
    pc = cell.GetParametricCoords()
    return np.array([pc[i] for i in range(3 * cell.GetNumberOfPoints())]).reshape(-1, 3)


def _grid(cells: list[tuple[int, np.ndarray]]):
    """An unstructured grid of the given (VTK cell type, node coordinates) cells, nodes not shared."""
    grid = vtk.vtkUnstructuredGrid()
    pts = np.vstack([xyz for _, xyz in cells])
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(pts, deep=True))
    grid.SetPoints(points)
    start = 0
    for ctype, xyz in cells:
        ids = vtk.vtkIdList()
        for i in range(start, start + len(xyz)):
            ids.InsertNextId(i)
        grid.InsertNextCell(ctype, ids)
        start += len(xyz)
    arr = numpy_to_vtk(sed(pts), deep=True)
    arr.SetName("SED")
    grid.GetPointData().AddArray(arr)
    return grid


def _lagrange_hex(n_points: int) -> np.ndarray:
    cell = vtk.vtkLagrangeHexahedron()
    cell.SetUniformOrderFromNumPoints(n_points)
    cell.GetPointIds().SetNumberOfIds(n_points)
    cell.GetPoints().SetNumberOfPoints(n_points)
    cell.Initialize()
    return _reference(cell)


def write(grid, name: str) -> None:
    if name.endswith(".vtu"):
        w = vtk.vtkXMLUnstructuredGridWriter()
        w.SetDataModeToAscii()
    else:
        w = vtk.vtkUnstructuredGridWriter()
    w.SetFileName(str(HERE / name))
    w.SetInputData(grid)
    w.Write()


def main() -> None:
    wedge = _reference(vtk.vtkQuadraticWedge()) @ AFFINE.T
    pyramid = _reference(vtk.vtkQuadraticPyramid()) @ AFFINE.T + [2.0, 0.0, 0.0]
    mixed = _grid([(vtk.VTK_QUADRATIC_WEDGE, wedge), (vtk.VTK_QUADRATIC_PYRAMID, pyramid)])
    write(mixed, "wedge15_pyramid13.vtu")
    write(mixed, "wedge15_pyramid13.vtk")
    hex27 = _grid([(vtk.VTK_LAGRANGE_HEXAHEDRON, _lagrange_hex(27) @ AFFINE.T)])
    write(hex27, "lagrange_hex27.vtk")
    write(hex27, "lagrange_hex27.vtu")
    write(_grid([(vtk.VTK_LAGRANGE_HEXAHEDRON, _lagrange_hex(64) @ AFFINE.T)]), "lagrange_hex64.vtk")


if __name__ == "__main__":
    main()
