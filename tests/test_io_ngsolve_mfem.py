"""Exports of NGSolve 6.2.2608 (``VTKOutput``) and MFEM 4.10 (PyMFEM ``ParaViewDataCollection``) read
against the tools' own evaluation of the same fields at the same points.

tests/data/ngsolve and tests/data/mfem (README.md in each): a two-layer skin block pressed on top in
three load steps, SED = 1/2 sigma:eps computed in the tool; ``reference.csv`` holds the tool's own
point evaluation (NGSolve ``mesh(x, y, z)``, MFEM ``Mesh.FindPoints`` + ``GridFunction.GetValue``).
Both tools write discontinuous output (every element its own copies of its nodes).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from afferent import read_receptors, read_sed, sample_sed
from afferent._shape_functions import inside_reference, natural_coordinates, shape_functions
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw

DATA = Path(__file__).parent / "data"
NGSOLVE, MFEM = DATA / "ngsolve", DATA / "mfem"


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)
        return fn(*args, **kw)


def _reference(folder: Path):
    """The tool's own SED (MPa) at the five points, shape (steps, points), and the points (mm)."""
    ref = np.genfromtxt(folder / "reference.csv", delimiter=",", names=True)
    steps = np.unique(ref["step"])
    sed = np.array([ref["sed"][ref["step"] == s] for s in steps])
    last = ref["step"] == steps[-1]
    return sed, np.c_[ref["x"][last], ref["y"][last], ref["z"][last]]


def _in_own_cell(path: Path, ctype: str, points: np.ndarray) -> np.ndarray:
    """SED of the file at ``points``, from the copies of the one cell holding each point (no merge), (steps, points)."""
    raw = read_raw(str(path))
    conn = raw.cells.nodes[raw.cells.cell_types.index(ctype)]
    xyz = np.asarray(raw.points, float)
    sed = raw.arrays["sed"]
    values = np.asarray(sed.values, float).reshape(sed.shape[0], -1)
    out = []
    for p in points:
        xi, ok = natural_coordinates(ctype, np.tile(p, (len(conn), 1)), xyz[conn])
        k = np.flatnonzero(ok & inside_reference(ctype, xi, 1e-9))
        assert k.size == 1, f"{p} lies in {k.size} cells"
        out.append(values[:, conn[k[0]]] @ shape_functions(ctype, xi[k])[0])
    return np.array(out).T


def test_ngsolve_float32_raw_appended_series_reads_every_step():
    # VTKOutput(floatsize="single") writes raw appended data; meshio's re-encoding gave 'connectivity'
    # the 'offsets' array (its base64 offset 5216 + ... equals the raw offset of the next array):
    # step 2 failed to read ('array sed has shape (1,) per value') or a file read with swapped arrays
    raw = read_raw(str(NGSOLVE / "block.pvd"))
    assert raw.times.tolist() == [1.0, 2.0, 3.0]
    assert [Path(f).name for f in raw.files][1:] == ["block.vtu", "block_step00001.vtu", "block_step00002.vtu"]
    assert raw.cells.n_cells == 326 and raw.points.shape == (1304, 3)  # 4 copies per tetrahedron
    sed = np.asarray(raw.arrays["sed"].values, float)[..., 0]
    # linear elasticity: SED scales with the load squared (0.004, 0.008, 0.012 MPa)
    np.testing.assert_allclose(sed[1], 4 * sed[0], rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(sed[2], 9 * sed[0], rtol=1e-5, atol=1e-12)
    step = read_raw(str(NGSOLVE / "block_step00001.vtu"))
    np.testing.assert_array_equal(step.cells.tetra, raw.cells.tetra)
    np.testing.assert_array_equal(np.asarray(step.arrays["sed"].values, float)[0, :, 0], sed[1])


def test_ngsolve_order2_cells_hold_ngsolve_own_values():
    # SED of a P2 displacement is quadratic in each tetrahedron: the tetra10 copies reproduce it exactly
    ref, points = _reference(NGSOLVE)
    got = _in_own_cell(NGSOLVE / "block_order2.vtu", "tetra10", points)
    np.testing.assert_allclose(got[0], ref[-1], rtol=1e-6)  # Float32


def test_mfem_lagrange_hexahedra_hold_mfem_own_values_at_every_step():
    # order-2 L2 SED (Q2 in each hexahedron), written as VTK Lagrange hexahedra of degree 2 (read as hexahedron27)
    ref, points = _reference(MFEM)
    raw = read_raw(str(MFEM / "block" / "block.pvd"))
    assert raw.times.tolist() == [1.0, 2.0, 3.0] and raw.cells.cell_types == ("hexahedron27",)
    got = _in_own_cell(MFEM / "block" / "block.pvd", "hexahedron27", points)
    np.testing.assert_allclose(got, ref, rtol=1e-6)


def test_material_ids_of_both_tools_are_found():
    # NGSolve: mesh.MaterialCF written as point data of NumberOfComponents="1" (shape (n, 1)), was not found
    ng = _quiet(read_sed, NGSOLVE / "block_order2.vtu", length_unit="mm", sed_unit="MPa")
    assert ng.provenance.columns["material"] == "material_id"
    assert ng.provenance.columns["material_location"] == "point data constant per cell"
    centre_z = np.zeros(ng.cells.n_cells)
    centre_z[ng.cells.parent] = ng.points[ng.cells.tetra, 2].mean(axis=1)  # one tetrahedron per tetra10
    np.testing.assert_array_equal(ng.cells.materials, np.where(centre_z > 0.8e-3, 2, 1))  # epidermis above 0.8 mm
    assert np.bincount(ng.cells.materials).tolist() == [0, 173, 153]
    # MFEM: ParaViewDataCollection writes each element's attribute as the cell array 'attribute'
    mf = _quiet(read_sed, MFEM / "block" / "block.pvd", length_unit="mm", sed_unit="MPa")
    assert mf.provenance.columns["material"] == "attribute"
    assert np.bincount(mf.cells.materials).tolist() == [0, 64, 16]


@pytest.mark.parametrize("folder, name, low, high", [
    (MFEM, "block/block.pvd", 0.94, 1.02),  # Q2 copies merged into nodes, per material
    # the merge by the element-node rule (unweighted mean of the copies; the volume-weighted mean before gave
    # 0.87-1.18, mean |log ratio| 0.078 on block_order2 and 1.17-1.53, 0.315 on block.pvd: now 0.071 and 0.254)
    (NGSOLVE, "block_order2.vtu", 0.95, 1.27),  # 326 tetrahedra: the merge moves a coarse mesh's SED more
    (NGSOLVE, "block.pvd", 1.15, 1.40),  # order-1 output of a quadratic SED: linear between merged corners
])
def test_receptor_sed_against_the_tool(folder, name, low, high):
    ref, points = _reference(folder)
    field = _quiet(read_sed, folder / name, length_unit="mm", sed_unit="MPa")
    layout = read_receptors(folder / "receptors.csv", length_unit="mm")
    np.testing.assert_allclose(layout.positions * 1e3, points)
    got = np.asarray(_quiet(sample_sed, field, layout).values) / 1e6  # J/m^3 -> MPa
    ratio = got / ref[-got.shape[0]:]
    assert low <= ratio.min() and ratio.max() <= high, ratio


def test_ngsolve_tensors_give_the_sed_ngsolve_wrote():
    # 'stress' and 'strain' are 3 x 3 (9 components, row-major), tensor shear
    direct = _quiet(read_sed, NGSOLVE / "block_tensors.vtu", length_unit="mm", sed_unit="MPa")
    exact = _quiet(read_sed, NGSOLVE / "block_tensors.vtu", length_unit="mm", stress_unit="MPa",
                   sed_from="exact", preset="vtk")
    np.testing.assert_allclose(exact.sed, direct.sed, rtol=1e-5, atol=1e-6 * direct.sed.max())


@pytest.mark.parametrize("path, cell", [
    (MFEM / "order3" / "order3.pvd", "VTK_LAGRANGE_HEXAHEDRON' \\(64 nodes\\)"),
    (NGSOLVE / "block_order3.vtu", "VTK_LAGRANGE_TETRAHEDRON' \\(20 nodes\\)"),
])
def test_lagrange_cells_of_degree_3_are_refused_with_the_tools_way_out(path, cell, capsys):
    with pytest.raises(SEDFormatError, match=cell + r".*SetLevelsOfDetail\(n\) \(write n <= 2.*VTKOutput\(order=k\)"):
        read_sed(path, length_unit="mm", sed_unit="MPa")
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: ") and err.count("\n") == 1 and "SetHighOrderOutput(false)" in err


def test_info_names_each_cell_type_once(capsys):
    # subdivision=1 writes a wedge block and a tetrahedron block per element (652 blocks: 326 wedges, 1,630 tetrahedra)
    assert main(["info", str(NGSOLVE / "block_sub1.vtu")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.strip().startswith("cells"))
    assert "1,956 volume cells (wedge, tetra)," in line


def test_cli_samples_the_mfem_series(tmp_path):
    out = tmp_path / "sed.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)
        code = main(["sample", str(MFEM / "block" / "block.pvd"), "--receptors", str(MFEM / "receptors.csv"),
                     "--length-unit", "mm", "--sed-unit", "MPa", "-q", "-o", str(out)])
    assert code == 0
    rows = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding=None)
    assert sorted(set(rows["time_s"].tolist())) == [1.0, 2.0, 3.0] and len(rows) == 15
    ref, _ = _reference(MFEM)
    last = rows["sed_pa"][rows["time_s"] == 3.0] / 1e6
    np.testing.assert_allclose(last, ref[-1], rtol=0.06)


@pytest.mark.parametrize("compressor", ["none", "zlib", "lzma"])
@pytest.mark.parametrize("header", [32, 64])
def test_raw_appended_data_of_every_layout_vtk_writes(tmp_path, compressor, header):
    # the raw appended parse (afferent/io/_vtu.py _raw_appended) on files from VTK's own writer:
    # uncompressed and compressed blocks, UInt32 and UInt64 headers; Float32 arrays as NGSolve writes them
    vtk = pytest.importorskip("vtkmodules.all")
    from vtkmodules.util.numpy_support import numpy_to_vtk

    rng = np.random.default_rng(3)
    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(rng.random((8, 3)).astype(np.float32), deep=True))
    grid.SetPoints(pts)
    for cell in ((0, 1, 2, 3), (4, 5, 6, 7)):
        grid.InsertNextCell(vtk.VTK_TETRA, 4, cell)
    sed = rng.random(8).astype(np.float32)
    for name, values in (("displacement", rng.random((8, 3)).astype(np.float32)), ("sed", sed)):
        arr = numpy_to_vtk(values, deep=True)
        arr.SetName(name)
        grid.GetPointData().AddArray(arr)
    path = tmp_path / "raw.vtu"
    writer = vtk.vtkXMLUnstructuredGridWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(grid)
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetHeaderTypeToUInt64() if header == 64 else writer.SetHeaderTypeToUInt32()
    {"none": writer.SetCompressorTypeToNone, "zlib": writer.SetCompressorTypeToZLib,
     "lzma": writer.SetCompressorTypeToLZMA}[compressor]()
    assert writer.Write() == 1 and b'encoding="raw"' in path.read_bytes()
    raw = read_raw(str(path))
    np.testing.assert_array_equal(np.asarray(raw.arrays["sed"].values, float).ravel(), sed)
    np.testing.assert_array_equal(raw.cells.tetra, [[0, 1, 2, 3], [4, 5, 6, 7]])


def test_a_2d_export_says_it_is_2d(capsys):
    # a plane-strain section: triangles only, every element with its own copies of its nodes;
    # afferent interpolates in volume cells, so the points are scattered samples, and their copies are refused
    assert main(["info", str(NGSOLVE / "plane_2d.vtu")]) == 0
    out = capsys.readouterr().out
    assert "No volume cells in the file (its cells: triangle; a 2-D model?)" in out
    with pytest.raises(SEDFormatError, match=r"plane_2d\.vtu' lists the point \(0, 0\.2, 0\) more than once"):
        read_sed(NGSOLVE / "plane_2d.vtu", length_unit="mm", sed_unit="MPa")


def test_mfem_series_without_settime_is_numbered_not_refused():
    # ParaViewDataCollection writes timestep="0" for every step unless SetTime is called: was refused
    # ('timesteps must be strictly increasing; got 0.0 followed by 0.0'); now numbered steps, and times= applies
    path = MFEM / "notime" / "notime.pvd"
    field = _quiet(read_sed, path, length_unit="mm", sed_unit="MPa")
    assert field.times.tolist() == [0.0, 1.0] and field.provenance.units["time"] == "step"
    timed = _quiet(read_sed, path, length_unit="mm", sed_unit="MPa", times=[0.5, 1.0])
    assert timed.times.tolist() == [0.5, 1.0] and timed.provenance.units["time"] == "s"
    np.testing.assert_array_equal(field.sed[0], field.sed[1])  # the same load saved twice


def test_ngsolve_step_counter_times_are_noted():
    # VTKOutput.Do() without a time states the step counter 0, 1 as the time: read as s, with a note
    field = _quiet(read_sed, NGSOLVE / "notime.pvd", length_unit="mm", sed_unit="MPa")
    assert field.times.tolist() == [0.0, 1.0] and field.provenance.units["time"] == "s"
    assert any("are its step numbers (NGSolve's VTKOutput.Do()" in n for n in field.provenance.notes)
    timed = _quiet(read_sed, NGSOLVE / "block.pvd", length_unit="mm", sed_unit="MPa")  # times 1, 2, 3 stated
    assert not any("step numbers (NGSolve" in n for n in timed.provenance.notes)


@pytest.mark.parametrize("name, what", [("run_000003.mfem_root", "an MFEM VisItDataCollection"),
                                        ("sed.gf", "an MFEM/GLVis grid function"), ("block.vol", "a Netgen/NGSolve mesh")])
def test_the_tools_native_files_are_named_with_the_export_to_write(tmp_path, name, what, capsys):
    path = tmp_path / name
    path.write_text("MFEM VisIt DataCollection\n")  # the content is never looked at: the ending decides
    with pytest.raises(SEDFormatError, match=f"is {what}, which afferent does not read; write VTU: MFEM's "
                                             r"ParaViewDataCollection \(a \.pvd\), NGSolve's VTKOutput"):
        read_sed(path, length_unit="mm", sed_unit="MPa")
    assert main(["info", str(path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
