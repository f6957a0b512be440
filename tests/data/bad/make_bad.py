"""Write the hostile-input corpus of tests/data/bad (each file one way a user's file goes wrong).

Regenerate: ``.venv/bin/python tests/data/bad/make_bad.py``. tests/test_hostile.py runs the CLI
on every file and pins the exit code (2), the one-line message and that no output is left.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import h5py
import meshio
import numpy as np

HERE = Path(__file__).resolve().parent


def cube():
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    return pts, np.array([[0, 1, 3, 2, 4, 5, 7, 6]])


def ascii_vtu(pts, connectivity: str, sed, cell_data=None) -> str:
    """One hexahedron as a hand-written ASCII VTU: ``connectivity`` as written, point array SED, cell arrays."""
    coords = " ".join(f"{v:g}" for v in pts.ravel())
    cells = "".join(f'<DataArray type="Float64" Name="{name}" format="ascii">{" ".join(map(str, values))}</DataArray>'
                    for name, values in (cell_data or {}).items())
    return ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian"><UnstructuredGrid>'
            '<Piece NumberOfPoints="8" NumberOfCells="1"><Points><DataArray type="Float64" NumberOfComponents="3" '
            f'format="ascii">{coords}</DataArray></Points><Cells><DataArray type="Int64" Name="connectivity" format="ascii">'
            f'{connectivity}</DataArray><DataArray type="Int64" Name="offsets" format="ascii">8</DataArray>'
            '<DataArray type="UInt8" Name="types" format="ascii">12</DataArray></Cells><PointData>'
            f'<DataArray type="Float64" Name="SED" format="ascii">{" ".join(map(str, sed))}</DataArray></PointData>'
            + (f"<CellData>{cells}</CellData>" if cells else "") + '</Piece></UnstructuredGrid></VTKFile>\n')


def main():
    pts, hexa = cube()
    sed = np.linspace(1e-4, 2e-4, 8)
    (HERE / "empty.vtu").write_bytes(b"")
    (HERE / "header_only.csv").write_text("x,y,z,SED\n")
    meshio.write(HERE / "whole.vtu", meshio.Mesh(pts, [("hexahedron", hexa)], point_data={"SED": sed}))
    data = (HERE / "whole.vtu").read_bytes()
    (HERE / "truncated.vtu").write_bytes(data[: len(data) // 2])
    corrupt = bytearray(data)
    i = corrupt.index(b'format="binary"')
    j = corrupt.index(b">", i) + 10
    corrupt[j:j + 20] = b"@" * 20
    (HERE / "corrupt.vtu").write_bytes(bytes(corrupt))
    (HERE / "whole.vtu").unlink()
    (HERE / "binary.csv").write_bytes(bytes(range(256)) * 4)
    rows = "\n".join(f"{x},{y},{z},{s}" for (x, y, z), s in zip(pts, sed))
    (HERE / "nan_sed.csv").write_text("x,y,z,SED\n" + rows.replace(str(sed[3]), "nan", 1) + "\n")
    (HERE / "inf_sed.csv").write_text("x,y,z,SED\n" + rows.replace(str(sed[3]), "inf", 1) + "\n")
    (HERE / "negative_sed.csv").write_text("x,y,z,SED\n" + "\n".join(f"{x},{y},{z},{-s}" for (x, y, z), s in zip(pts, sed)) + "\n")
    (HERE / "duplicated_points.csv").write_text("x,y,z,SED\n" + rows + f"\n0.0,0.0,0.0,{sed[5]}\n")
    (HERE / "no_coordinates.csv").write_text("node,SED\n" + "\n".join(f"{k + 1},{s}" for k, s in enumerate(sed)) + "\n")
    (HERE / "nonmonotonic_times.csv").write_text(
        "time,x,y,z,SED\n" + "\n".join(f"{t},{x},{y},{z},{s}" for t in (0.0, 0.2, 0.1) for (x, y, z), s in zip(pts, sed)) + "\n")
    (HERE / "duplicated_times.csv").write_text(
        "time,x,y,z,SED\n" + "\n".join(f"{t},{x},{y},{z},{s}" for t in (0.0, 0.1, 0.1) for (x, y, z), s in zip(pts, sed)) + "\n")
    (HERE / "unknown_unit.csv").write_text("x,y,z,SED (furlong-poundals)\n" + rows + "\n")
    (HERE / "element_energy.csv").write_text("x,y,z,ELSE\n" + rows + "\n")
    mesh = meshio.Mesh(pts, [("hexahedron", hexa)], point_data={"SED": sed})
    # hand-written ASCII VTUs: a point array with 7 values for 8 points; a negative node index in the
    # connectivity; a cell array with 2 values for 1 cell (meshio keeps the first, silently)
    (HERE / "length_mismatch.vtu").write_text(ascii_vtu(pts, "0 1 3 2 4 5 7 6", sed[:7]))
    (HERE / "negative_connectivity.vtu").write_text(ascii_vtu(pts, "0 1 3 2 4 5 7 -2", sed))
    (HERE / "cell_array_long.vtu").write_text(ascii_vtu(pts, "0 1 3 2 4 5 7 6", sed, {"E": [1.0, 2.0]}))
    # a corrupt component count on a second point array (meshio skips the array; afferent looped 1e10 times)
    (HERE / "huge_component_count.vtu").write_text(ascii_vtu(pts, "0 1 3 2 4 5 7 6", sed).replace(
        "</PointData>", '<DataArray type="Float64" Name="E" NumberOfComponents="9999999999" ComponentName0="XX" '
        f'format="ascii">{" ".join(["0"] * 48)}</DataArray></PointData>'))
    meshio.write(HERE / "step_a.vtu", mesh)
    meshio.write(HERE / "step_b.vtu", meshio.Mesh(pts[:7] * 2, [("tetra", np.array([[0, 1, 2, 4]]))], point_data={"SED": sed[:7]}))
    (HERE / "different_meshes.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>\n'
        '<DataSet timestep="0" file="step_a.vtu"/>\n<DataSet timestep="1" file="step_b.vtu"/>\n</Collection></VTKFile>\n')
    (HERE / "receptors_text.csv").write_text("id,x,y,z\nr0,0.5,0.5,0.5\nr1,0.5,n/a,0.5\n")
    (HERE / "receptors_ok.csv").write_text("id,x,y,z\nr0,0.5,0.5,0.5\nr1,0.25,0.5,0.5\n")
    (HERE / "receptors_outside.csv").write_text("id,x,y,z\nr0,0.5,0.5,0.5\nfar,5.0,0.5,0.5\n")
    (HERE / "ok.csv").write_text("x,y,z,SED\n" + rows + "\n")
    (HERE / "scene_wrong_types.toml").write_text(
        '[export]\nfile = "ok.csv"\nlength_unit = "mm"\nsed_unit = "MPa"\n[receptors]\nfile = "receptors_ok.csv"\n'
        '[sampling]\nmethod = 3\n[outputs]\nwant = ["sed"]\n')
    with h5py.File(HERE / "corrupt_heavy.h5", "w") as h5:
        h5["geometry"] = pts
    raw = (HERE / "corrupt_heavy.h5").read_bytes()
    (HERE / "corrupt_heavy.h5").write_bytes(raw[:600])
    (HERE / "corrupt_heavy.xdmf").write_text(
        '<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>\n<Grid Name="mesh" GridType="Uniform">'
        '<Topology TopologyType="Hexahedron" NumberOfElements="1" NodesPerElement="8"><DataItem Dimensions="1 8" '
        'Format="XML">0 1 3 2 4 5 7 6</DataItem></Topology><Geometry GeometryType="XYZ"><DataItem Dimensions="8 3" '
        'Format="HDF">corrupt_heavy.h5:/geometry</DataItem></Geometry></Grid>\n'
        '<Grid Name="f" GridType="Collection" CollectionType="Temporal"><Grid Name="f" GridType="Uniform">'
        '<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" xpointer="xpointer(/Xdmf/Domain/Grid[1]/*)"/>'
        '<Time Value="0"/><Attribute Name="SED" Center="Node"><DataItem Dimensions="8 1" Format="XML">'
        + " ".join(map(str, sed)) + '</DataItem></Attribute></Grid></Grid>\n</Domain></Xdmf>\n')
    # an XDMF whose SED dataset is complex (what a PETSc complex build of DOLFINx would store)
    with h5py.File(HERE / "complex_heavy.h5", "w") as h5:
        h5["sed"] = sed.astype(complex) + 1j
    (HERE / "complex_heavy.xdmf").write_text(
        '<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>\n<Grid Name="mesh" GridType="Uniform">'
        '<Topology TopologyType="Hexahedron" NumberOfElements="1" NodesPerElement="8"><DataItem Dimensions="1 8" '
        'Format="XML">0 1 3 2 4 5 7 6</DataItem></Topology><Geometry GeometryType="XYZ"><DataItem Dimensions="8 3" '
        f'Format="XML">{" ".join(f"{v:g}" for v in pts.ravel())}</DataItem></Geometry></Grid>\n'
        '<Grid Name="f" GridType="Collection" CollectionType="Temporal"><Grid Name="f" GridType="Uniform">'
        '<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" xpointer="xpointer(/Xdmf/Domain/Grid[1]/*)"/>'
        '<Time Value="0"/><Attribute Name="SED" Center="Node"><DataItem Dimensions="8 1" Format="HDF">'
        'complex_heavy.h5:/sed</DataItem></Attribute></Grid></Grid>\n</Domain></Xdmf>\n')
    (HERE / "nan_timestep.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>\n'
        '<DataSet timestep="0" file="step_a.vtu"/>\n<DataSet timestep="nan" file="step_a.vtu"/>\n</Collection></VTKFile>\n')
    (HERE / "all_zero.csv").write_text("x,y,z,SED\n" + "\n".join(f"{x},{y},{z},0" for x, y, z in pts) + "\n")
    # shapes real exports take, which must read: gzip, decimal commas, BOM, CRLF, a long preamble
    (HERE / "good_gzip.csv.gz").write_bytes(gzip.compress(("x,y,z,SED\n" + rows + "\n").encode(), mtime=0))
    (HERE / "good_decimal_comma.csv").write_text("x;y;z;SED\n" + "\n".join(
        f"{x};{y};{z};{s}".replace(".", ",") for (x, y, z), s in zip(pts, sed)) + "\n")
    (HERE / "good_bom_crlf.csv").write_bytes(("\ufeffx,y,z,SED\r\n" + rows.replace("\n", "\r\n") + "\r\n").encode("utf-8"))
    (HERE / "good_long_preamble.csv").write_text("".join(f"% preamble line {k}, with, commas\n" for k in 300 * [0])
                                                  + "% x,y,z,SED\n" + rows + "\n")

    # an FEBio plot file cut in its last state (FEBio killed while writing): tests/data/febio/block_hex8.xplt
    plot = (HERE.parent / "febio" / "block_hex8.xplt").read_bytes()
    (HERE / "truncated.xplt").write_bytes(plot[:-100])


if __name__ == "__main__":
    main()
