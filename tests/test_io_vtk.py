"""The VTK family through VTK's own readers (afferent.io._vtk): files meshio refuses (Kratos' and
FreeFEM's legacy binary .vtk), parallel .pvtu records (deal.II), .vtm multiblock files and JSON
file series (Kratos), the 'vtk' extra's error when VTK is missing, and item 7 of issue 20:
names are hints, values decide (Kratos' STRAIN_ENERGY, 9-component tensors, step numbers).

Real files from real tools, made by the scripts beside them (tests/data/*/README.md).
"""

from __future__ import annotations

import os
import shutil
import re
import subprocess
import sys
import warnings

import meshio
import numpy as np
import pytest

from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw, read_sed
from afferent.io._vtk import EXTRA, merge_piece_nodes

DATA = os.path.join(os.path.dirname(__file__), "data")
KRATOS_VTK = os.path.join(DATA, "kratos", "vtk", "Structure_0_1.vtk")
KRATOS_VTK2 = os.path.join(DATA, "kratos", "vtk", "Structure_0_2.vtk")
KRATOS_VTM = os.path.join(DATA, "kratos", "vtu", "Structure_1.vtm")
KRATOS_SERIES = os.path.join(DATA, "kratos", "vtu", "Structure.vtm.series")
FREEFEM_POINT = os.path.join(DATA, "freefem", "block_point.vtk")
FREEFEM_CELL = os.path.join(DATA, "freefem", "block_cell.vtk")
DEALII_PVD = os.path.join(DATA, "dealii", "block.pvd")
DEALII_PVTU = [os.path.join(DATA, "dealii", f"block_0{k}.pvtu") for k in (0, 1)]

pytest.importorskip("vtkmodules")


@pytest.mark.parametrize("path", [KRATOS_VTK, FREEFEM_POINT])
def test_legacy_vtk_that_meshio_refuses_is_read_through_vtk(path):
    with pytest.raises((meshio.ReadError, ValueError)):  # Kratos: ReadError; FreeFEM: ValueError
        meshio.vtk.read(path)
    raw = read_raw(path)
    assert raw.reader.startswith("VTK 9.") and raw.notes[0].endswith("(meshio could not read it).")
    assert raw.cells is not None and raw.points.shape[1] == 3


def test_kratos_strain_energy_is_a_density_by_its_values():
    """Kratos' STRAIN_ENERGY (point data: extrapolated to the nodes) is 1/2 strain:stress at each
    integration point: a density, refused before from its name alone; the tensors decide."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)  # a decision from the values needs no warning
        f = read_sed(KRATOS_VTK, length_unit="m", sed_unit="Pa")
    assert f.points.shape == (405, 3) and f.cells.n_cells == 256 and f.location == "point"
    assert f.sed.max() == pytest.approx(100.16343, rel=1e-6)  # J/m^3
    check = f.provenance.checks["density_by_values"]
    assert check["density"] and 0.5 < check["scale"] < 2 and check["relative_difference"] < 0.5
    assert any("is named like an energy, but its values are a density" in n for n in f.provenance.notes)
    cell = read_sed(KRATOS_VTK, length_unit="m", sed_unit="Pa", location="cell")
    assert cell.location == "cell" and cell.provenance.checks["density_by_values"]["density"]


def test_kratos_tensors_give_sed_with_the_kratos_preset():
    """CAUCHY_STRESS_VECTOR / GREEN_LAGRANGE_STRAIN_VECTOR (engineering shear) are recognised; per
    element (cell data: Gauss-point means) 1/2 sigma:eps is close to the element's STRAIN_ENERGY."""
    exact = read_sed(KRATOS_VTK, length_unit="m", stress_unit="Pa", sed_from="exact", preset="kratos", location="cell")
    field = read_sed(KRATOS_VTK, length_unit="m", sed_unit="Pa", location="cell")
    rel = np.linalg.norm(exact.sed - field.sed) / np.linalg.norm(field.sed)
    assert rel < 0.2  # the mean of products is not the product of means: 0.13 measured


def test_an_energy_named_array_without_tensors_asks_for_one_flag():
    msg = (f"SED file {KRATOS_VTM!r}: column 'STRAIN_ENERGY' holds an energy, not an energy density ('Strain Energy' "
           "(Workbench) is an element energy, not a density; Kratos' STRAIN_ENERGY is a density despite its name); so "
           "its name says, and the file has no stress and strain tensors to decide from the values. Export the density, "
           "or divide by the element volume first; if it is a density after all, confirm with sed_column='STRAIN_ENERGY' "
           "(--sed-column STRAIN_ENERGY).")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_sed(KRATOS_VTM, length_unit="m", sed_unit="Pa")
    f = read_sed(KRATOS_VTM, length_unit="m", sed_unit="Pa", sed_column="STRAIN_ENERGY")
    assert any("read as a density because sed_column= says so (the file has no stress and strain tensors to decide from "
               "the values)" in n for n in f.provenance.notes)


def test_an_element_energy_beside_tensors_is_refused_by_its_values(tmp_path):
    """The same Kratos mesh with STRAIN_ENERGY x element volume (an energy in J): refused, with the scale."""
    raw = read_raw(KRATOS_VTK)
    mesh = meshio.Mesh(raw.points, [("hexahedron", np.asarray(meshio.vtk.read(_ascii_copy(tmp_path)).cells[0].data))],
                       cell_data={name: [raw.arrays[key].values[0] * (1.25e-10 if name == "STRAIN_ENERGY" else 1)]
                                  for key, name in (("STRAIN_ENERGY@cell", "STRAIN_ENERGY"),
                                                    ("CAUCHY_STRESS_VECTOR@cell", "CAUCHY_STRESS_VECTOR"),
                                                    ("GREEN_LAGRANGE_STRAIN_VECTOR@cell", "GREEN_LAGRANGE_STRAIN_VECTOR"))})
    path = tmp_path / "energy.vtu"
    mesh.write(path)
    with pytest.raises(SEDFormatError, match=r"holds an energy, not an energy density .*; its values are 1\.\d+e-10 x "
                                             r"1/2 sigma:eps of the file's tensors"):
        read_sed(path, length_unit="m", sed_unit="Pa")


def _ascii_copy(tmp_path):
    """The Kratos mesh as an ASCII legacy file meshio reads (written by VTK), for its cells."""
    from vtkmodules.vtkIOLegacy import vtkGenericDataObjectReader, vtkUnstructuredGridWriter

    r = vtkGenericDataObjectReader()
    r.SetFileName(KRATOS_VTK)
    r.Update()
    w = vtkUnstructuredGridWriter()
    w.SetInputData(r.GetOutput())
    w.SetFileName(str(tmp_path / "ascii.vtk"))
    w.SetFileVersion(42)
    w.Write()
    return str(tmp_path / "ascii.vtk")


def test_freefem_cell_tensors_reproduce_its_sed():
    """FreeFEM's savevtk writes unnamed 6-vectors in the script's order (xx yy zz xy yz xz, tensor shear)."""
    field = read_sed(FREEFEM_CELL, length_unit="mm", sed_unit="MPa")
    exact = read_sed(FREEFEM_CELL, length_unit="mm", stress_unit="MPa", sed_from="exact", shear="tensor")
    np.testing.assert_allclose(exact.sed, field.sed, rtol=1e-9)
    assert field.location == "cell" and field.cells.n_cells == 648


def test_kratos_series_without_times_gets_step_numbers_not_seconds():
    f = read_sed([KRATOS_VTK, KRATOS_VTK2], length_unit="m", sed_unit="Pa")
    assert f.times.tolist() == [0.0, 1.0] and f.provenance.units["time"] == "step"
    assert any("step numbers, not seconds" in n for n in f.provenance.notes)
    # twice the push: displacements exactly 2 x, SED 3.98-4.0007 x (Kratos' law computes STRAIN_ENERGY from
    # the Green-Lagrange strain of the displacements, which is not exactly linear in them)
    assert f.sed[1].max() == pytest.approx(4 * f.sed[0].max(), rel=1e-2)


def test_kratos_vtm_equals_its_block_read_by_meshio_and_the_json_series_states_times():
    block = os.path.join(DATA, "kratos", "vtu", "Structure", "Structure_elements_1.vtu")
    a, b = read_raw(KRATOS_VTM), read_raw(block)
    assert a.reader.startswith("VTK") and b.reader.startswith("meshio")
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.cells.tetra, b.cells.tetra)
    np.testing.assert_array_equal(a.arrays["STRAIN_ENERGY"].values.ravel(), b.arrays["STRAIN_ENERGY"].values.ravel())
    f = read_sed(KRATOS_SERIES, length_unit="m", sed_unit="Pa", sed_column="STRAIN_ENERGY")
    assert f.times.tolist() == [1.0, 2.0] and f.provenance.units["time_source"] != "declared"


def _dealii_sed(points_mm, t):
    """The field make_pvtu.cc interpolates (MPa): Q1 interpolation is exact at the nodes."""
    x, y, z = points_mm.T
    return 1e-4 * t * np.exp(-((x - 2) ** 2 + (y - 2) ** 2) / 0.5) * (z / 2) ** 2


def test_dealii_pvd_of_pvtu_pieces_is_one_mesh_with_its_times():
    f = read_sed(DEALII_PVD, length_unit="mm", sed_unit="MPa")
    assert f.times.tolist() == [0.5, 1.0] and f.cells.n_cells == 256
    # 2048 per-cell patch nodes (deal.II writes each cell's nodes); 211 shared by the two pieces merged when the
    # pieces are joined, then the copies inside each piece merged by read_sed: the 9 x 9 x 5 nodes of the mesh
    assert f.points.shape == (9 * 9 * 5, 3)
    assert f.provenance.coincident["n_points"] == 2048 - 211 and f.provenance.coincident["n_nodes"] == 405
    assert any("2 pieces merged into one mesh: 211 node(s) that pieces share" in n for n in f.provenance.notes)
    for k, t in enumerate((0.5, 1.0)):
        np.testing.assert_allclose(f.sed[k] / 1e6, _dealii_sed(f.points * 1e3, t), rtol=1e-6, atol=1e-12)


def test_a_list_of_pvtu_records_is_a_series_numbered_by_step():
    f = read_sed(DEALII_PVTU, length_unit="mm", sed_unit="MPa")
    assert f.times.tolist() == [0.0, 1.0] and f.provenance.units["time"] == "step"


def test_a_pvtu_with_a_missing_piece_names_it(tmp_path):
    text = open(DEALII_PVTU[0]).read().replace("block_00.1.vtu", "missing.vtu")
    (tmp_path / "block_00.0.vtu").write_bytes(open(os.path.join(DATA, "dealii", "block_00.0.vtu"), "rb").read())
    p = tmp_path / "r.pvtu"
    p.write_text(text)
    with pytest.raises(FileNotFoundError, match=re.escape(f"SED file {str(p)!r} lists the piece "
                                                          f"{str(tmp_path / 'missing.vtu')!r}, which does not exist.")):
        read_raw(p)


def test_truncated_legacy_vtk_is_refused_not_read_in_part(tmp_path):
    """VTK reads a cut legacy binary file up to the cut and only warns: refused here."""
    p = tmp_path / "cut.vtk"
    p.write_bytes(open(KRATOS_VTK, "rb").read()[:30000])
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r} could not be read as .vtk (truncated or corrupt?): ReadError: ; VTK 9.")) as err:
        read_raw(p)
    assert "Error reading" in str(err.value)


def test_merge_piece_nodes_merges_only_shared_nodes_with_equal_values():
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0, 0], [3, 0, 0], [3, 0, 0.0]])
    piece = np.array([0, 0, 1, 0, 1, 1, 1])
    sed = np.array([1.0, 2.0, 2.0, 3.0, 4.0, 5.0, 5.0])  # node 2: same values; node 3: different; 5, 6: one piece
    keep, index, n_diff = merge_piece_nodes(points, piece, [sed], tol=1e-6)
    assert keep.tolist() == [0, 1, 3, 4, 5, 6] and index.tolist() == [0, 1, 1, 2, 3, 4, 5] and n_diff == 2


def test_the_reader_lists_every_file_a_pvd_of_pvtu_records_names():
    """RawExport.files (hashed by the cache and run.json): the series, each record, each piece or block."""
    from afferent.io import read_raw

    def export_files(path):
        return read_raw(path).files

    files = [os.path.basename(f) for f in export_files(DEALII_PVD)]
    assert files == ["block.pvd", "block_00.pvtu", "block_00.0.vtu", "block_00.1.vtu", "block_01.pvtu",
                     "block_01.0.vtu", "block_01.1.vtu"]
    assert [os.path.basename(f) for f in export_files(KRATOS_SERIES)] == [
        "Structure.vtm.series", "Structure_1.vtm", "Structure_elements_1.vtu", "Structure_2.vtm", "Structure_elements_2.vtu"]


def test_nine_component_tensors_need_no_shear_flag(tmp_path):
    """A full 3x3 tensor's off-diagonals are tensor components whatever the tool's convention."""
    rng = np.random.default_rng(0)
    pts = rng.random((20, 3))
    eps = rng.normal(size=(20, 3, 3)) * 1e-3
    eps = (eps + eps.transpose(0, 2, 1)) / 2
    sig = 2 * 1e3 * eps + 1e3 * np.trace(eps, axis1=1, axis2=2)[:, None, None] * np.eye(3)
    path = tmp_path / "nine.vtu"
    meshio.Mesh(pts, [("vertex", np.arange(20)[:, None])],
                point_data={"stress": sig.reshape(20, 9), "strain": eps.reshape(20, 9)}).write(path)
    f = read_sed(path, length_unit="mm", stress_unit="Pa", sed_from="exact")
    np.testing.assert_allclose(f.sed[0], 0.5 * np.einsum("nij,nij->n", sig, eps), rtol=1e-12)
    assert any("9 components" in n for n in f.provenance.notes)


_NO_VTK = "import sys; sys.modules['vtkmodules'] = None; sys.modules['vtk'] = None; "


@pytest.mark.parametrize("path, first", [
    (KRATOS_VTK, f"SED file {KRATOS_VTK!r} could not be read as .vtk (truncated or corrupt?): ReadError: "),
    (DEALII_PVTU[0], f"SED file {DEALII_PVTU[0]!r} is a parallel VTU record, which meshio does not read"),
    (KRATOS_VTM, f"SED file {KRATOS_VTM!r} is a VTK multiblock file, which meshio does not read"),
])
def test_without_vtk_the_error_names_the_extra(path, first):
    code = _NO_VTK + "from afferent.cli import main; sys.exit(main(['info', sys.argv[1]]))"
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    done = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 2, done.stderr
    assert done.stderr == f"afferent: error: {first}; VTK's own readers read it: {EXTRA}.\n"
    assert EXTRA == "pip install 'afferent-skin[vtk]'"


def test_info_says_which_reader_read_the_file(capsys):
    from afferent.cli import main

    assert main(["info", FREEFEM_POINT]) == 0
    assert re.search(r"^  reader +VTK 9\.\d+\.\d+$", capsys.readouterr().out, re.M)
    assert main(["info", KRATOS_VTK]) == 0
    assert ("'STRAIN_ENERGY' (point data) is named like an energy, but its values are a density: 1.11 x 1/2 sigma:eps "
            "of the file's tensors (relative difference 0.12 for the best preset;") in capsys.readouterr().out
    assert main(["info", os.path.join(DATA, "kratos", "vtu", "Structure", "Structure_elements_1.vtu")]) == 0
    assert re.search(r"^  reader +meshio \d", capsys.readouterr().out, re.M)


def test_a_pvd_without_timesteps_is_numbered_by_step_not_given_seconds(tmp_path):
    for k in (1, 2):  # the steps inside the collection's folder (files outside it are refused unless allowed)
        shutil.copy(os.path.join(DATA, "kratos", "vtu", "Structure", f"Structure_elements_{k}.vtu"), tmp_path)
    block = "Structure_elements_{}.vtu"
    p = tmp_path / "no_times.pvd"
    p.write_text('<?xml version="1.0"?><VTKFile type="Collection"><Collection>'
                 + "".join(f'<DataSet file="{block.format(k)}"/>' for k in (1, 2)) + "</Collection></VTKFile>")
    f = read_sed(p, length_unit="m", sed_unit="Pa", sed_column="STRAIN_ENERGY")
    assert f.times.tolist() == [0.0, 1.0] and f.provenance.units["time"] == "step"
    assert f.provenance.units["time_source"] == "none in the file: steps numbered 0, 1, ..."
    half = tmp_path / "half.pvd"
    half.write_text(p.read_text().replace('<DataSet file', '<DataSet timestep="1" file', 1))
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(half)!r}: entry 1 states no time while others do")):
        read_sed(half, length_unit="m", sed_unit="Pa", sed_column="STRAIN_ENERGY")


def test_a_vtm_with_a_surface_block_reads_its_volume_block(tmp_path):
    """A multiblock written by VTK itself: the Kratos volume and its surface (PolyData) as two blocks."""
    from vtkmodules.vtkCommonDataModel import vtkMultiBlockDataSet
    from vtkmodules.vtkFiltersGeometry import vtkDataSetSurfaceFilter
    from vtkmodules.vtkIOLegacy import vtkGenericDataObjectReader
    from vtkmodules.vtkIOXML import vtkXMLMultiBlockDataWriter

    r = vtkGenericDataObjectReader()
    r.SetFileName(KRATOS_VTK)
    r.Update()
    surface = vtkDataSetSurfaceFilter()
    surface.SetInputData(r.GetOutput())
    surface.Update()
    mb = vtkMultiBlockDataSet()
    mb.SetBlock(0, r.GetOutput())
    mb.SetBlock(1, surface.GetOutput())
    w = vtkXMLMultiBlockDataWriter()
    w.SetInputData(mb)
    w.SetFileName(str(tmp_path / "two.vtm"))
    w.Write()
    raw = read_raw(tmp_path / "two.vtm")
    assert raw.points.shape == (405, 3) and raw.cells.n_cells == 256
    assert "1 block(s) that are not unstructured grids (PolyData) left out." in raw.notes
    np.testing.assert_array_equal(raw.arrays["STRAIN_ENERGY"].values, read_raw(KRATOS_VTK).arrays["STRAIN_ENERGY"].values)


def test_a_pvtu_record_named_vtu_is_told_to_be_named_pvtu(tmp_path):
    p = tmp_path / "record.vtu"
    p.write_text(open(DEALII_PVTU[0]).read())
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r} holds a parallel index (.pvtu) listing its pieces, not the UnstructuredGrid (volume "
            "mesh) afferent reads from a .vtu; name it .pvtu (read through VTK, the 'vtk' extra).")):
        read_raw(p)


def test_spiking_on_step_numbers_is_refused_unless_confirmed_and_run_json_says_so(tmp_path):
    """A Kratos series states no times: spiking on its step numbers is refused (issue 34; a warning before),
    and run with the confirmation [scene] accept = ["step-times"] the record says so."""
    import json

    from afferent.scene import SceneError, run_scene_cli

    (tmp_path / "r.csv").write_text("id,x,y,z\n1,2,2,1.9\n2,1.5,2,1.9\n3,2.5,2,1.9\n")
    scene = tmp_path / "s.toml"
    scene.write_text(f"""[export]
files = [{KRATOS_VTK!r}, {KRATOS_VTK2!r}]
length_unit = "m"
sed_unit = "Pa"
[receptors]
file = "r.csv"
length_unit = "mm"
[transduction]
params = "start"
[synthesis]
kind = "longitudinal"
[spikes]
engine = "exact"
[outputs]
want = ["spikes"]
""")
    said = ("The export states no step times: its 2 steps are numbered 0 .. 1, and spiking would read those numbers as "
            "seconds (1 s per step, 1 s in all); give the steps' times with times=T0,T1,... (in s; [export] times in a "
            "scene file)")
    with pytest.raises(ValueError, match=re.escape(said + "; if it is intended, confirm it with accept='step-times' "
                                                   "(a scene file: [scene] accept = [\"step-times\"]).")) as caught:
        run_scene_cli(scene, output=tmp_path / "out", quiet=True, cache_dir=tmp_path / "cache")
    assert not isinstance(caught.value, SceneError) and not (tmp_path / "out").exists()
    scene.write_text('[scene]\naccept = ["step-times"]\n' + scene.read_text())
    run_scene_cli(scene, output=tmp_path / "out", quiet=True, cache_dir=tmp_path / "cache")
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    assert record["field"]["units"]["time"] == "step" and record["scene"]["scene"]["accept"] == ["step-times"]
    assert any(w["message"] == said + " (confirmed: accept='step-times')." for w in record["warnings"])


def _two_piece_series(folder, steps):
    """A .pvtu series of two hexahedra (pieces) sharing the face x = 1; ``steps``: per step, the
    'sed' of piece 0's and piece 1's nodes on that face (the other nodes carry 1)."""
    hexa = np.array([[0, 1, 3, 2, 4, 5, 7, 6]])
    files = []
    for k, (a, b) in enumerate(steps):
        for j, (x0, face) in enumerate(((0.0, a), (1.0, b))):
            pts = np.array([[x0 + dx, dy, dz] for dz in (0, 1) for dy in (0, 1) for dx in (0, 1)], float)
            sed = np.where(pts[:, 0] == 1.0, face, 1.0)
            meshio.Mesh(pts, [("hexahedron", hexa)], point_data={"sed": sed}).write(folder / f"s{k}_{j}.vtu")
        (folder / f"s{k}.pvtu").write_text(
            '<?xml version="1.0"?><VTKFile type="PUnstructuredGrid" version="0.1"><PUnstructuredGrid GhostLevel="0">'
            '<PPointData><PDataArray type="Float64" Name="sed"/></PPointData><PPoints><PDataArray type="Float64" '
            f'NumberOfComponents="3"/></PPoints><Piece Source="s{k}_0.vtu"/><Piece Source="s{k}_1.vtu"/>'
            '</PUnstructuredGrid></VTKFile>')
        files.append(str(folder / f"s{k}.pvtu"))
    return files


def test_a_series_merges_the_pieces_once_by_its_first_and_last_steps(tmp_path):
    """All zero at t = 0, discontinuous between the pieces later: one merge for every step (none here)."""
    files = _two_piece_series(tmp_path, [(0.0, 0.0), (2.0, 3.0)])
    alone = read_raw(files[0])
    assert alone.points.shape == (12, 3)  # read alone, step 0's equal face nodes are merged
    f = read_sed(files, length_unit="mm", sed_unit="Pa")
    # the join keeps the face's 4 + 4 copies apart (values differ at t = 1); read_sed then merges them as
    # coincident copies (the discontinuous-output rule, recorded in provenance.coincident)
    assert f.provenance.coincident["n_points"] == 16 and f.points.shape == (12, 3) and f.sed.shape == (2, 12)
    assert any("0 node(s) that pieces share" in n and "8 coincident node(s) of different pieces with different values kept"
               in n for n in f.provenance.notes)


def test_a_series_whose_pieces_part_between_first_and_last_steps_is_refused(tmp_path):
    files = _two_piece_series(tmp_path, [(0.0, 0.0), (2.0, 3.0), (1.0, 1.0)])
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {files[1]!r}: nodes its pieces share carry different values here but equal ones at the first and "
            "last steps ('s0.pvtu', 's2.pvtu')")):
        read_sed(files, length_unit="mm", sed_unit="Pa")


# ------------------------------------------------------------- issue 33, item 11: malformed index files
def test_a_vtm_with_an_undefined_entity_is_named_not_an_internal_error(tmp_path):
    """VTK's parser skips an undefined entity under an external DTD; Python's refused it unguarded while
    listing the blocks: before, 'internal error (please report): ParseError: undefined entity &foo;'."""
    import shutil

    shutil.copytree(os.path.join(DATA, "kratos", "vtu", "Structure"), tmp_path / "Structure")
    text = open(KRATOS_VTM).read().replace('<?xml version="1.0"?>', '<?xml version="1.0"?>\n<!DOCTYPE VTKFile SYSTEM "x.dtd">')
    p = tmp_path / "ent.vtm"
    p.write_text(text.replace('name="Structure_elements">', 'name="Structure_elements">&foo;'))
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} is not a valid .vtm (XML) file: "
                                                       "undefined entity &foo;: line 5, column")):
        read_raw(p)


def test_a_pvtu_listing_itself_is_refused_not_recursed(tmp_path):
    """Before: RecursionError (exit 1), from the reader and from data_files."""
    from afferent.io import data_files

    (tmp_path / "block_00.0.vtu").write_bytes(open(os.path.join(DATA, "dealii", "block_00.0.vtu"), "rb").read())
    p = tmp_path / "self.pvtu"
    p.write_text(open(DEALII_PVTU[0]).read().replace("block_00.1.vtu", "self.pvtu"))
    message = re.escape(f"SED file {str(p)!r} lists the piece {str(p)!r}, a parallel record itself; the pieces of a "
                        ".pvtu are .vtu files.")
    for read in (read_raw, data_files):
        with pytest.raises(SEDFormatError, match=message):
            read(str(p))


def test_vtm_blocks_leading_back_to_the_vtm_are_refused(tmp_path):
    """Before: data_files (which sizes a run's read) recursed without end: RecursionError, exit 1."""
    from afferent.io import data_files

    text = open(KRATOS_VTM).read()
    (tmp_path / "a.vtm").write_text(text.replace("Structure/Structure_elements_1.vtu", "b.vtm"))
    (tmp_path / "b.vtm").write_text(text.replace("Structure/Structure_elements_1.vtu", "a.vtm"))
    a, b = str(tmp_path / "a.vtm"), str(tmp_path / "b.vtm")
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {b!r} lists {a!r}, which lists {b!r} again (directly "
                                                       "or through other files): a loop.")):
        data_files(a)


def test_a_crash_of_vtks_legacy_reader_is_an_error_naming_the_file_not_the_end_of_the_process(tmp_path):
    # session 8's fuzzing: a CONNECTIVITY line whose data type runs into the next keyword kills the process in
    # VTK 9.7's legacy reader (SIGSEGV); the legacy reader now runs in a child process (afferent.io._child)
    data = open(os.path.join(DATA, "fuzz", "SIGSEGV-vtk-legacy-reader.bin"), "rb").read()
    start = data.index(b"# vtk DataFile")
    path = str(tmp_path / "crash.vtk")
    with open(path, "wb") as f:
        f.write(data[start:])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {path!r} could not be read as ")) as info:
        read_raw(path)
    # a VTK whose legacy reader does not crash on it still refuses it (the data type is garbage)
    assert "crashed on it (signal 11, SIGSEGV)" in str(info.value) or "could not read it either" in str(info.value)
    out = subprocess.run([sys.executable, "-m", "afferent", "info", path], capture_output=True, text=True)
    assert out.returncode == 2 and out.stderr.startswith("afferent: error: SED file") and out.stderr.count("\n") == 1


def test_a_child_reader_dying_by_a_signal_is_an_error_saying_which(tmp_path):
    from afferent.io._child import call_in_child

    with pytest.raises(SEDFormatError, match=re.escape(
            "SED file 'f.vtk' could not be read as a test file: the tool's compiled code crashed on it (signal 6, "
            "SIGABRT); the hint.")):
        call_in_child("os", "abort", path="f.vtk", reading="a test file", tool="the tool", crash_hint="the hint")
    with pytest.raises(SEDFormatError, match=re.escape(
            "SED file 'f.vtk' could not be read as a test file: the process reading it with the tool exited with "
            "code 3")):
        call_in_child("os", "_exit", 3, path="f.vtk", reading="a test file", tool="the tool", crash_hint="the hint")
    assert call_in_child("math", "hypot", 3.0, 4.0, path="f", reading="r", tool="t", crash_hint="h") == 5.0
    with pytest.raises(ZeroDivisionError):  # the function's own exception comes back as it is
        call_in_child("operator", "truediv", 1, 0, path="f", reading="r", tool="t", crash_hint="h")
