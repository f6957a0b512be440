"""Write the small seed files of the fuzz corpus (fuzz/seeds/), each a valid input of its kind."""

import shutil
from pathlib import Path

import meshio
import numpy as np

HERE = Path(__file__).resolve().parent / "seeds"
DOLFINX = Path(__file__).resolve().parent.parent / "tests" / "data" / "dolfinx"


def main():
    HERE.mkdir(exist_ok=True)
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    hexa = np.array([[0, 1, 3, 2, 4, 5, 7, 6]])
    sed = np.linspace(0, 1e-4, 8)
    six = np.tile([1e-3, 2e-3, 3e-3, 1e-4, 2e-4, 3e-4], (8, 1))
    mesh = meshio.Mesh(pts, [("hexahedron", hexa)], point_data={"SED": sed, "S": six, "E": six * 10},
                       cell_data={"layer": [np.array([1.0])]})
    meshio.write(HERE / "step.vtu", mesh)  # binary, zlib: the step a .pvd seed points to
    meshio.write(HERE / "ascii.vtu", mesh, binary=False)
    meshio.write(HERE / "legacy.vtk", mesh, binary=False)
    meshio.write(HERE / "inline.xdmf", mesh, data_format="XML")
    (HERE / "series.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n<Collection>\n'
        '<DataSet timestep="0" part="0" file="step.vtu"/>\n<DataSet timestep="0.1" part="0" file="step.vtu"/>\n'
        "</Collection>\n</VTKFile>\n")
    (HERE / "receptors.csv").write_text("id,x,y,z,longitudinal,cross\nr0,0.2,0.5,0.3,0,0\nr1,0.6,0.5,0.3,1,0\n")
    (HERE / "waveform.csv").write_text("time,depth\n0,0\n0.1,0.5\n0.2,0.5\n0.3,0\n")
    (HERE / "sed_table.csv").write_text(
        "receptor,x_m,y_m,z_m,time_s,sed_pa\nr0,2e-4,5e-4,3e-4,0,120.5\nr1,6e-4,5e-4,3e-4,0,80.25\n")
    # DOLFINx 0.5.2's temporal collections with their HDF5 heavy data, renamed to heavy.h5 (xdmf-* targets)
    shutil.copy(DOLFINX / "block.h5", HERE / "heavy.h5")
    (HERE / "collection.xdmf").write_text((DOLFINX / "block.xdmf").read_text().replace("block.h5:", "heavy.h5:"))
    # csv-long: the first byte is the repeat exponent (2**14 here: a 180 kB first row), then a one-row CSV
    (HERE / "long_row.csv").write_bytes(bytes([14]) + b"1234567890,\nx,y,z,sed\n0,0,0,1\n")


if __name__ == "__main__":
    main()
