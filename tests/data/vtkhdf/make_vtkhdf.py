"""Write the VTKHDF test files with VTK's own vtkHDFWriter (run: python tests/data/vtkhdf/make_vtkhdf.py).

A 3 x 2 x 2 box of unit hexahedra (mm) with a tetrahedron and a wedge glued beside it, and a triangle
(a surface cell, which afferent ignores), on which every array is an exact function of the coordinates
and the step time t, so that a test can compare what afferent reads with the values written here:

- point ``SED`` = (1 + x + 2y + 3z) (1 + t), ``displacement`` (3 components) = (x t, y t, z t),
  ``stress`` (6 components, VTK's symmetric order XX YY ZZ XY YZ XZ) = (1, 2, 3, 4, 5, 6) (x + 1) (1 + t);
- cell ``E`` = 10 + cell index, ``material`` (int32) = 1 for the hexahedra, 2 for the others.

Files: ``block.vtkhdf`` (one step, no ``Steps`` group), ``block_steps.vtkhdf`` (three steps t = 0, 0.5,
1 s from a temporal source, written with ``WriteAllTimeSteps``: VTK writes the mesh again at each step),
``block_external_steps.vtkhdf`` (the same with ``UseExternalTimeSteps``: each step in its own file
``block_external_steps_<k>.vtkhdf``, the index's datasets HDF5 virtual datasets over them) and
``steps.vtkhdf.series`` (a ParaView JSON file series over those step files, written by this script).
"""

import json
import os

import numpy as np
from vtkmodules.numpy_interface import dataset_adapter as dsa
from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
from vtkmodules.vtkCommonCore import vtkPoints, vtkVersion
from vtkmodules.vtkCommonDataModel import (VTK_HEXAHEDRON, VTK_TETRA, VTK_TRIANGLE, VTK_WEDGE, vtkUnstructuredGrid)
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP
from vtkmodules.vtkIOHDF import vtkHDFWriter

HERE = os.path.dirname(os.path.abspath(__file__))
TIMES = (0.0, 0.5, 1.0)


def grid(t: float) -> vtkUnstructuredGrid:
    nx, ny, nz = 4, 3, 3  # nodes of the 3 x 2 x 2 box
    xyz = np.array([(x, y, z) for z in range(nz) for y in range(ny) for x in range(nx)], dtype=float)
    extra = np.array([(4, 0, 0), (4, 1, 0), (4, 0, 1), (4, 1, 1), (4, 2, 0)], dtype=float)
    pts = np.vstack([xyz, extra])
    ug = vtkUnstructuredGrid()
    p = vtkPoints()
    for q in pts:
        p.InsertNextPoint(*q)
    ug.SetPoints(p)

    def nid(x, y, z):
        return x + nx * (y + ny * z)

    for z in range(nz - 1):
        for y in range(ny - 1):
            for x in range(nx - 1):
                ug.InsertNextCell(VTK_HEXAHEDRON, 8, [nid(x, y, z), nid(x + 1, y, z), nid(x + 1, y + 1, z),
                                                      nid(x, y + 1, z), nid(x, y, z + 1), nid(x + 1, y, z + 1),
                                                      nid(x + 1, y + 1, z + 1), nid(x, y + 1, z + 1)])
    e = len(xyz)
    ug.InsertNextCell(VTK_TETRA, 4, [nid(3, 0, 0), e + 0, e + 1, e + 2])
    ug.InsertNextCell(VTK_WEDGE, 6, [nid(3, 0, 0), e + 0, nid(3, 1, 0), nid(3, 0, 1), e + 2, nid(3, 1, 1)])
    ug.InsertNextCell(VTK_TRIANGLE, 3, [e + 1, e + 4, nid(3, 2, 0)])
    w = dsa.WrapDataObject(ug)
    x, y, z = pts.T
    w.PointData.append((1 + x + 2 * y + 3 * z) * (1 + t), "SED")
    w.PointData.append(np.column_stack([x * t, y * t, z * t]), "displacement")
    w.PointData.append(np.outer(x + 1, np.arange(1.0, 7.0)) * (1 + t), "stress")
    n = ug.GetNumberOfCells()
    w.CellData.append(10.0 + np.arange(n), "E")
    w.CellData.append(np.array([1] * 12 + [2] * 3, dtype=np.int32), "material")
    return ug


class Temporal(VTKPythonAlgorithmBase):
    """A source of :func:`grid` at the times :data:`TIMES`."""

    def __init__(self):
        super().__init__(nInputPorts=0, nOutputPorts=1, outputType="vtkUnstructuredGrid")

    def RequestInformation(self, request, inInfo, outInfo):
        info = outInfo.GetInformationObject(0)
        info.Set(SDDP.TIME_STEPS(), TIMES, len(TIMES))
        info.Set(SDDP.TIME_RANGE(), (TIMES[0], TIMES[-1]), 2)
        return 1

    def RequestData(self, request, inInfo, outInfo):
        info = outInfo.GetInformationObject(0)
        t = info.Get(SDDP.UPDATE_TIME_STEP()) if info.Has(SDDP.UPDATE_TIME_STEP()) else 0.0
        vtkUnstructuredGrid.GetData(outInfo).ShallowCopy(grid(t))
        return 1


def writer(name: str) -> vtkHDFWriter:
    w = vtkHDFWriter()
    w.SetChunkSize(64)  # the default (25,000 rows a chunk) makes a 3 MB file of this small mesh
    w.SetFileName(name)  # relative (run in HERE): the index's virtual datasets then name their step files relatively
    return w


def main() -> None:
    os.chdir(HERE)
    w = writer("block.vtkhdf")
    w.SetInputData(grid(0.25))
    w.Write()
    source = Temporal()  # kept referenced: VTK holds no Python reference to it
    for name, external in (("block_steps.vtkhdf", False), ("block_external_steps.vtkhdf", True)):
        w = writer(name)
        w.SetInputConnection(source.GetOutputPort())
        w.SetWriteAllTimeSteps(True)
        w.SetUseExternalTimeSteps(external)
        w.Write()
    # the step files vtkHDFWriter wrote beside block_external_steps.vtkhdf, as a ParaView JSON file series
    series = {"file-series-version": "1.0",
              "files": [{"name": f"block_external_steps_{k}.vtkhdf", "time": t} for k, t in enumerate(TIMES)]}
    with open(os.path.join(HERE, "steps.vtkhdf.series"), "w") as fh:
        json.dump(series, fh, indent=1)
    print("VTK", vtkVersion.GetVTKVersion())


if __name__ == "__main__":
    main()
