"""VTKHDF files (issue 36, item 2): afferent's own reader on h5py (:mod:`afferent.io._vtkhdf`, the default
install) against VTK's vtkHDFReader and the values tests/data/vtkhdf/make_vtkhdf.py wrote with VTK 9.7.2's
vtkHDFWriter; every file its HDF5 names (virtual datasets, external links) through the one resolver."""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

from afferent.exceptions import SEDFormatError
from afferent.io import read_raw, read_sed

DATA = os.path.join(os.path.dirname(__file__), "data", "vtkhdf")
FILES = ("block.vtkhdf", "block_steps.vtkhdf", "block_external_steps.vtkhdf")


def _vtk_steps(path: str):
    """[(points, {('point'|'cell', name): values})] of each step, as VTK's vtkHDFReader reads them."""
    pytest.importorskip("vtkmodules")
    from vtkmodules.numpy_interface import dataset_adapter as dsa
    from vtkmodules.vtkIOHDF import vtkHDFReader

    r = vtkHDFReader()
    r.SetFileName(path)
    r.UpdateInformation()
    out = []
    for k in range(max(r.GetNumberOfSteps(), 1)):
        r.SetStep(k)
        r.Update()
        w = dsa.WrapDataObject(r.GetOutput())
        arrays = {("point", n): np.array(w.PointData[n]) for n in w.PointData.keys()}
        arrays.update({("cell", n): np.array(w.CellData[n]) for n in w.CellData.keys()})
        out.append((np.array(w.Points), np.array(w.CellTypes), arrays))
    return out


@pytest.mark.parametrize("name", FILES)
def test_every_array_of_every_step_equals_vtks_reader(name):
    path = os.path.join(DATA, name)
    raw = read_raw(path)
    steps = _vtk_steps(path)
    assert raw.n_times == len(steps) and raw.reader == "afferent (h5py)"
    volume = np.isin(steps[0][1], (10, 12, 13, 14))  # VTK_TETRA, HEXAHEDRON, WEDGE, PYRAMID: the triangle is left out
    for k, (points, _, arrays) in enumerate(steps):
        np.testing.assert_array_equal(raw.points, points)
        assert {(a.location, a.name) for a in raw.arrays.values()} == set(arrays)
        for a in raw.arrays.values():
            want = arrays[(a.location, a.name)]
            np.testing.assert_array_equal(a.values[k], want[volume] if a.location == "cell" else want)
    assert raw.cells.n_cells == int(volume.sum()) == 14


def test_values_are_the_ones_the_script_wrote():
    raw = read_raw(os.path.join(DATA, "block_steps.vtkhdf"))
    np.testing.assert_allclose(raw.times, [0.0, 0.5, 1.0])
    x, y, z = raw.points.T
    for k, t in enumerate(raw.times):
        np.testing.assert_allclose(raw.arrays["SED"].values[k], (1 + x + 2 * y + 3 * z) * (1 + t))
        np.testing.assert_allclose(raw.arrays["displacement"].values[k], np.column_stack([x, y, z]) * t)
        np.testing.assert_allclose(raw.arrays["stress"].values[k], np.outer(x + 1, np.arange(1.0, 7.0)) * (1 + t))
    np.testing.assert_array_equal(raw.arrays["material"].values[0], [1] * 12 + [2] * 2)


def test_read_sed_gives_si_values_and_lists_the_external_step_files():
    field = read_sed(os.path.join(DATA, "block_external_steps.vtkhdf"), length_unit="mm", sed_unit="kPa")
    assert field.sed.shape == (3, 41) and field.sed.max() == pytest.approx(28e3)
    names = [os.path.basename(f) for f in field.provenance.files]
    assert names[0] == "block_external_steps.vtkhdf"
    assert {f"block_external_steps_{k}.vtkhdf" for k in range(3)} <= set(names)


def test_virtual_dataset_files_outside_the_folder_are_refused(tmp_path, monkeypatch):
    """vtkHDFWriter's UseExternalTimeSteps stores the values in other files through HDF5 virtual datasets, their
    sources named as the writer was given the file: given an absolute name it writes absolute sources, and the
    index moved to another folder then reads values from files outside its own."""
    pytest.importorskip("vtkmodules")
    import importlib.util

    import h5py

    spec = importlib.util.spec_from_file_location("make_vtkhdf", os.path.join(DATA, "make_vtkhdf.py"))
    make = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make)
    (tmp_path / "written").mkdir()
    (tmp_path / "moved").mkdir()
    source = make.Temporal()
    w = make.writer(str(tmp_path / "written" / "index.vtkhdf"))  # an absolute name, as a script or ParaView gives it
    w.SetInputConnection(source.GetOutputPort())
    w.SetWriteAllTimeSteps(True)
    w.SetUseExternalTimeSteps(True)
    w.Write()
    index = tmp_path / "moved" / "index.vtkhdf"
    shutil.move(tmp_path / "written" / "index.vtkhdf", index)
    with h5py.File(index, "r") as h:
        assert h["VTKHDF/Points"].is_virtual
        assert os.path.isabs(h["VTKHDF/Points"].virtual_sources()[0].file_name)
    with pytest.raises(SEDFormatError, match=r"points to the source of HDF5 virtual dataset .*written.*outside the folder "
                                             r"of the export .*allow_outside_files=True"):
        read_raw(str(index))


def test_external_link_outside_the_folder_is_refused_and_allowed_on_purpose(tmp_path):
    import h5py

    shutil.copy(os.path.join(DATA, "block.vtkhdf"), tmp_path / "mesh.vtkhdf")
    (tmp_path / "sub").mkdir()
    index = tmp_path / "sub" / "linked.vtkhdf"
    with h5py.File(index, "w") as h:
        h["VTKHDF"] = h5py.ExternalLink("../mesh.vtkhdf", "/VTKHDF")
    with pytest.raises(SEDFormatError, match=r"points to the target of the HDF5 external link 'VTKHDF' "
                                             r"'../mesh.vtkhdf'.*outside the folder"):
        read_raw(str(index))
    raw = read_raw(str(index), allow_outside_files=True)
    assert raw.arrays["SED"].values.shape == (1, 41)
    assert any(f.endswith("mesh.vtkhdf") for f in raw.files)


def test_other_types_and_other_files_are_refused_naming_what_they_are(tmp_path):
    import h5py

    poly = tmp_path / "surface.vtkhdf"
    with h5py.File(poly, "w") as h:
        g = h.create_group("VTKHDF")
        g.attrs["Type"] = np.bytes_(b"PolyData")
        g.attrs["Version"] = [2, 2]
    with pytest.raises(SEDFormatError, match=r"is a VTKHDF file holding a surface \(PolyData\); export the volume "
                                             r"mesh; afferent reads the UnstructuredGrid type"):
        read_raw(str(poly))
    other = tmp_path / "other.vtkhdf"
    with h5py.File(other, "w") as h:
        h["x"] = [1.0]
    with pytest.raises(SEDFormatError, match=r"is HDF5 without a '/VTKHDF' group: not a VTKHDF file"):
        read_raw(str(other))
    text = tmp_path / "text.vtkhdf"
    text.write_text("not hdf5")
    with pytest.raises(SEDFormatError, match=r"could not be read as VTKHDF \(HDF5; truncated or corrupt\?\)"):
        read_raw(str(text))


def test_inconsistent_counts_are_refused(tmp_path):
    import h5py

    bad = tmp_path / "bad.vtkhdf"
    shutil.copy(os.path.join(DATA, "block.vtkhdf"), bad)
    with h5py.File(bad, "r+") as h:
        h["VTKHDF/NumberOfCells"][0] = 16
    with pytest.raises(SEDFormatError, match=r"part 0 \(step 0\) is inconsistent: its counts \(41 points, 16 cells"):
        read_raw(str(bad))
