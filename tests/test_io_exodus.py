"""Exodus II files written here by real tools (tests/data/exodus/README.md, make_exodus.py): a
two-layer skin block solved by SfePy 2026.3 (2 x 2 x 1 mm, epidermis E = 0.5 MPa over dermis
E = 0.1 MPa, nu = 0.45, mm/N/s), written through VTK 9.7.2's IOSS writer (SEACAS's Exodus
library: netCDF-3, 4 steps, two named element blocks) and by SfePy's own Exodus output (meshio
5.3.5 + netCDF4: netCDF-4/HDF5). References: the same variables read straight from the netCDF
file with scipy here, Hooke's law of each block's material, and one tool's file against the other's.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.io import netcdf_file

from afferent import read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import read_raw
from afferent.receptors import ReceptorLayout
from afferent.strain_energy import sed_exact

from conftest import DATA_DIR

EXO = DATA_DIR / "exodus"
LAYERS = EXO / "layers_ioss.e"  # 2 HEX8 blocks (dermis 32, epidermis 16 cells), 100 nodes, 4 steps
SFEPY = EXO / "layers_sfepy.e"  # the last step as SfePy writes Exodus: netCDF-4, nodal vector 'u'
PLATE = EXO / "plate_ioss.e"  # the 2-D section: QUAD4 blocks, 2 steps
COMPONENTS = ("xx", "yy", "zz", "xy", "yz", "xz")
E_DERMIS, E_EPIDERMIS, NU = 0.1, 0.5, 0.45  # MPa (make_exodus.py)


def _netcdf(path, name):
    with netcdf_file(path, mmap=False) as nc:
        return np.array(nc.variables[name].data)


def _names(path, name):
    return ["".join(c.decode() for c in row if c != b"").strip() for row in _netcdf(path, name)]


def test_every_time_step_and_variable_is_read_as_the_file_holds_it():
    raw = read_raw(LAYERS)
    np.testing.assert_array_equal(raw.times, _netcdf(LAYERS, "time_whole"))
    np.testing.assert_array_equal(raw.times, [0.25, 0.5, 0.75, 1.0])
    assert raw.cells.cell_types == ("hexahedron", "hexahedron") and raw.cells.n_cells == 48
    assert raw.points.shape == (100, 3)  # the blocks share the interface nodes
    nodal, elemental = _names(LAYERS, "name_nod_var"), _names(LAYERS, "name_elem_var")
    assert nodal == ["displacement_x", "displacement_y", "displacement_z", "sed"] and len(elemental) == 13
    for i, name in enumerate(nodal, start=1):
        assert raw.arrays[name].location == "point"
        np.testing.assert_array_equal(raw.arrays[name].values, _netcdf(LAYERS, f"vals_nod_var{i}"))
    for i, name in enumerate(elemental, start=1):  # block 1's cells, then block 2's
        key = f"{name}@cell" if name in nodal else name  # 'sed' is nodal and elemental
        assert raw.arrays[key].location == "cell"
        both = np.concatenate([_netcdf(LAYERS, f"vals_elem_var{i}eb1"), _netcdf(LAYERS, f"vals_elem_var{i}eb2")], 1)
        np.testing.assert_array_equal(raw.arrays[key].values, both)
    uz = raw.arrays["displacement_z"].values
    np.testing.assert_allclose(uz.min(1), [-0.025, -0.05, -0.075, -0.1], rtol=1e-12)  # the push, step by step


def _tensors(raw, step=slice(None)):
    s = np.stack([raw.arrays[f"stress_{c}"].values[step] for c in COMPONENTS], -1)
    e = np.stack([raw.arrays[f"strain_{c}"].values[step] for c in COMPONENTS], -1)
    return s, e


def test_each_blocks_tensors_are_hookes_law_of_its_material_with_tensor_shear():
    """stress = C : strain with tensor shear, cell by cell, at every step, with the Young's modulus
    of the cell's element block: the blocks are the materials, and the components are where
    their names say (SfePy's 11 22 33 12 13 23 reordered, its doubled shear halved)."""
    raw = read_raw(LAYERS)
    s, e = _tensors(raw)
    material = raw.arrays["material"].values[0]
    young = np.where(material == 2, E_EPIDERMIS, E_DERMIS)[None, :, None]
    lam, g = young * NU / ((1 + NU) * (1 - 2 * NU)), young / (2 * (1 + NU))
    hooke = np.concatenate([lam * e[..., :3].sum(-1, keepdims=True) + 2 * g * e[..., :3], 2 * g * e[..., 3:]], -1)
    np.testing.assert_allclose(hooke, s, rtol=1e-9, atol=1e-12 * np.abs(s).max())
    assert np.abs(s[..., 3:]).max() > 0.1 * np.abs(s).max()  # real shear under the punch edge
    assert not np.allclose(g * e[..., 3:], s[..., 3:], rtol=0.1)  # engineering shear would be off by 2
    assert not np.allclose(hooke, s[..., [0, 1, 2, 3, 5, 4]], rtol=1e-3)  # yz and xz exchanged


def test_sed_from_the_tensors_and_sfepys_own_element_sed():
    """1/2 sigma:eps of the element-averaged tensors (tensor shear) is what read_sed gives; SfePy's
    own element-average SED is the mean of a quadratic form, never below it (Jensen), and close."""
    field = read_sed(LAYERS, length_unit="mm", stress_unit="MPa", sed_from="exact", shear="tensor")
    s, e = _tensors(read_raw(LAYERS))
    assert field.location == "cell" and field.n_times == 4
    np.testing.assert_allclose(field.sed, sed_exact(s, e) * 1e6, rtol=1e-12)
    own = read_sed(LAYERS, length_unit="mm", sed_unit="MPa", sed_column="sed", location="cell")
    ratio = own.sed / field.sed
    assert ratio.min() > 1 - 1e-9 and np.median(ratio) < 1.5
    np.testing.assert_allclose(own.sed / own.sed[-1], np.broadcast_to((np.arange(1, 5) / 4.0)[:, None] ** 2, own.sed.shape),
                               rtol=1e-9)  # linear: SED grows with the depth squared


def test_linear_sampling_on_the_exodus_mesh_reproduces_nodal_values():
    """SfePy's nodal SED (an L2 projection: slightly negative at some nodes, within the tolerance: set to 0)."""
    raw = read_raw(LAYERS)
    nodal = raw.arrays["sed"].values
    assert -0.15 < nodal.min() / nodal.max() < 0
    with pytest.warns(UserWarning, match="negative"):
        field = read_sed(LAYERS, length_unit="mm", sed_unit="MPa", sed_column="sed", location="point")
    assert field.location == "point" and field.sed.min() == 0
    nodes = np.unique(raw.cells.tetra)[::5]
    got = sample_sed(field, ReceptorLayout(raw.points[nodes] * 1e-3), method="linear").values
    np.testing.assert_allclose(got, field.sed[:, nodes], rtol=1e-12, atol=1e-12 * field.sed.max())


def test_two_dimensional_files_have_no_volume_cells():
    raw = read_raw(PLATE)  # the x-y plane-strain section, QUAD4 blocks (IOSS writes z = 0)
    assert raw.cells is None and raw.points.shape == (36, 3) and np.all(raw.points[:, 2] == 0)
    assert "ignored block 1 (QUAD4, 16 elements), block 2 (QUAD4, 8 elements)" in raw.notes[0]
    np.testing.assert_array_equal(raw.arrays["displacement_y"].values, _netcdf(PLATE, "vals_nod_var2"))
    assert "stress_xx" not in raw.arrays  # element variables need volume cells


def test_a_file_with_a_mesh_and_no_time_step(tmp_path):
    """The mesh of the IOSS file without its time steps and variables (what a mesher's .g holds)."""
    out = tmp_path / "mesh.g"
    with netcdf_file(LAYERS, mmap=False) as nc, netcdf_file(out, "w", version=2) as g:
        keep = [k for k in nc.variables if not k.startswith(("vals_", "name_", "time_", "elem_var_tab"))]
        for name, size in nc.dimensions.items():
            if not name.startswith(("num_nod_var", "num_elem_var")):
                g.createDimension(name, 0 if size is None else size)
        for k in keep:
            var = nc.variables[k]
            g.createVariable(k, var.data.dtype, var.dimensions)[:] = var.data
            for key, value in var._attributes.items():
                setattr(g.variables[k], key, value)
    mesh = read_raw(out)
    assert mesh.times is None and set(mesh.arrays) == {"material"} and "no time step" in mesh.notes[-1]
    with pytest.raises(SEDFormatError, match="has no strain-energy-density array"):
        read_sed(out, length_unit="mm", sed_unit="Pa")


def test_netcdf4_exodus_written_by_sfepy_through_meshio():
    """SfePy's own Exodus output: netCDF-4 (HDF5), coordinates in one 'coord' variable, the nodal
    vector 'u' as one (time, node, 3) variable (refused before: '300 values'), the same solution as
    the IOSS file's last step, solved by the same script."""
    raw = read_raw(SFEPY)
    assert raw.notes[0] == "Exodus II, netCDF-4 (HDF5): 1 time step(s), 1 volume block(s)."
    assert raw.arrays["u"].values.shape == (1, 100, 3) and "material" not in raw.arrays  # one block
    ioss = read_raw(LAYERS)
    order = np.lexsort(raw.points.T)
    np.testing.assert_array_equal(raw.points[order], ioss.points[np.lexsort(ioss.points.T)])
    u = np.stack([ioss.arrays[f"displacement_{a}"].values[-1] for a in "xyz"], -1)
    np.testing.assert_allclose(raw.arrays["u"].values[0][order], u[np.lexsort(ioss.points.T)], rtol=1e-12, atol=1e-15)


def test_netcdf4_exodus_with_element_variables_through_hdf5(tmp_path):
    """netCDF-4 Exodus files are HDF5 files with the same variables: the IOSS file's variables copied
    into HDF5 datasets with h5py (the layout netCDF-4 uses) give the same arrays, element variables
    and block ids included."""
    h5py = pytest.importorskip("h5py")
    out = tmp_path / "layers_nc4.e"
    with netcdf_file(LAYERS, mmap=False) as nc, h5py.File(out, "w") as h5:
        for name, var in nc.variables.items():
            ds = h5.create_dataset(name, data=np.array(var.data))
            for key, value in var._attributes.items():
                ds.attrs[key] = value
    a, b = read_raw(LAYERS), read_raw(out)
    assert b.notes[0].startswith("Exodus II, netCDF-4 (HDF5)") and a.notes[1:] == b.notes[1:]
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.cells.tetra, b.cells.tetra)
    assert set(a.arrays) == set(b.arrays)
    for key in a.arrays:
        np.testing.assert_array_equal(a.arrays[key].values, b.arrays[key].values)


def test_damaged_exodus_files_are_named(tmp_path):
    data = LAYERS.read_bytes()
    cut = tmp_path / "cut.e"
    cut.write_bytes(data[: len(data) // 3])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(cut)!r}")):
        read_raw(cut)
    text = tmp_path / "text.e"
    text.write_text("not an exodus file\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(text)!r} is not an Exodus II file: it must be netCDF ('CDF' or HDF5 signature); got b'not ' "
            "instead.")):
        read_raw(text)


def test_a_nodal_variable_of_the_wrong_size_is_named(tmp_path):
    out = tmp_path / "short.e"
    with netcdf_file(LAYERS, mmap=False) as nc, netcdf_file(out, "w", version=2) as g:
        for name, size in sorted(nc.dimensions.items(), key=lambda d: d[1] is not None):  # the record one first
            g.createDimension(name, size)
        g.createDimension("short", 99)
        for k, var in nc.variables.items():
            dims = ("time_step", "short") if k == "vals_nod_var2" else var.dimensions
            data = var.data[:, :99] if k == "vals_nod_var2" else var.data
            g.createVariable(k, var.data.dtype, dims)[:] = data
            for key, value in var._attributes.items():
                setattr(g.variables[k], key, value)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(out)!r}: nodal variable 'displacement_y' must have one value per node (100) at each of the "
            "4 time step(s); got 396 values (shape (4, 99)) instead.")):
        read_raw(out)


def test_info_describes_an_exodus_file(capsys):
    assert main(["info", str(LAYERS)]) == 0
    out = capsys.readouterr().out
    assert "format       exodus" in out and "time steps   4, t = 0.25 .. 1" in out
    assert "'stress_xy'                  cell " in out
    assert "Exodus II, netCDF-3 (64-bit offset): 4 time step(s), 2 volume block(s)" in out
    assert "materials    'material' (cell data): 1 (32 cells), 2 (16 cells)" in out


# ---------------------------------------------------------------------------------------------
# Element blocks as materials: dermis (block id 1, z < 2/3 mm) and epidermis (id 2) on top.
# ---------------------------------------------------------------------------------------------
def test_element_block_ids_are_the_cell_array_material():
    raw = read_raw(LAYERS)
    arr = raw.arrays["material"]
    assert arr.location == "cell" and arr.values.shape == (4, 48)
    np.testing.assert_array_equal(arr.values[0], np.repeat([1.0, 2.0], [32, 16]))
    centres = np.array([raw.points[c].mean(0) for c in raw.cells.tetra[::6]])  # 6 tetrahedra per hexahedron
    np.testing.assert_array_equal(arr.values[0][raw.cells.parent[::6]] == 2, centres[:, 2] > 2 / 3)
    assert "cell array 'material': the element block id of each cell (2 blocks: 1 'dermis', 2 'epidermis')" in raw.notes


def _with_block_ids(tmp_path, ids):
    out = tmp_path / f"ids_{'_'.join(map(str, ids))}.e"
    with netcdf_file(LAYERS, mmap=False) as nc, netcdf_file(out, "w", version=2) as g:
        for name, size in sorted(nc.dimensions.items(), key=lambda d: d[1] is not None):  # the record one first
            g.createDimension(name, size)
        for k, var in nc.variables.items():
            g.createVariable(k, var.data.dtype, var.dimensions)[:] = np.array(ids) if k == "eb_prop1" else var.data
            for key, value in var._attributes.items():
                setattr(g.variables[k], key, value)
    return out


def test_the_material_is_the_block_id_not_its_position(tmp_path):
    raw = read_raw(_with_block_ids(tmp_path, [7, 3]))
    np.testing.assert_array_equal(raw.arrays["material"].values[0], np.repeat([7.0, 3.0], [32, 16]))
    assert "cell array 'material': the element block id of each cell (2 blocks: 7 'dermis', 3 'epidermis')" in raw.notes
    assert "material" not in read_raw(_with_block_ids(tmp_path, [5, 5])).arrays  # one id: one material


INTERFACE = "id,x,y,z\ncentre,1.0,1.0,{z}\nside,0.5,0.5,{z}\ndeep,1.0,1.0,0.3\n".format(z=2 / 3)


def test_info_and_side_see_the_two_blocks_as_materials(tmp_path, capsys):
    receptors = tmp_path / "receptors.csv"
    receptors.write_text(INTERFACE)
    assert main(["info", str(LAYERS), "--receptors", str(receptors), "--receptor-unit", "mm", "--length-unit", "mm",
                 "--sed-unit", "MPa", "--sed-column", "sed", "--location", "cell"]) == 0
    out = capsys.readouterr().out
    assert "3 from " in out and ": 2 on an interface (materials 1/2: 2), 1 not" in out
    assert re.search(r"--side 2: 2 receptors change, by a median -\d\.\d+ %", out)
    field = read_sed(LAYERS, length_unit="mm", sed_unit="MPa", sed_column="sed", location="cell")
    layout = ReceptorLayout(np.array([[1.0, 1.0, 2 / 3], [0.5, 0.5, 2 / 3], [1.0, 1.0, 0.3]]) * 1e-3)
    assert field.provenance.columns["material"] == "material"
    assert "cell array 'material': the element block id of each cell (2 blocks: 1 'dermis', 2 'epidermis')" in \
        field.provenance.notes  # the run record says where the materials came from
    np.testing.assert_array_equal(np.unique(field.cells.materials), [1, 2])
    one, two = sample_sed(field, layout, side=1), sample_sed(field, layout, side=2)
    assert one.interface["interfaces"] == {"1/2": 2} and two.interface["side"] == 2
    assert np.all(np.abs(one.values[:, :2] - two.values[:, :2]) > 0.01 * two.values[:, :2])  # the sides differ
    np.testing.assert_array_equal(one.values[:, 2], two.values[:, 2])  # inside the dermis: no side


def test_element_types_spelled_otherwise_are_recognised_by_family_and_nodes():
    from afferent.io._exodus import _volume_type

    assert [_volume_type(t, n) for t, n in (("HEXAHEDRON", 8), ("HEX", 20), ("TETRA", 4), ("TET10", 10),
                                            ("WEDGE", 6), ("PYRAMID", 5), ("SHELL4", 4), ("BAR2", 2))] == [
        "hexahedron", "hexahedron20", "tetra", "tetra10", "wedge", "pyramid", None, None]


def test_the_development_check_script_runs_on_exodus_files(capsys):
    """benchmarks/check_exodus_files.py (how MOOSE's files were checked): the IOSS HEX20 file passes;
    the two-material file fails a one-material Hooke's law check, as it must."""
    import importlib.util

    from conftest import DATA_DIR as data

    path = data.parent.parent / "benchmarks" / "check_exodus_files.py"
    spec = importlib.util.spec_from_file_location("check_exodus_files", path)
    check = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(check)
    assert check.main([str(EXO / "hex20_ioss.e")]) == 0
    assert "ok   node order  hexahedron20: largest mid-node offset 0 of the edge length" in capsys.readouterr().out
    assert check.main([str(LAYERS), "--young", str(E_DERMIS), "--poisson", str(NU)]) == 1
    assert "FAIL shear       stress_* vs strain_* (cell)" in capsys.readouterr().out


def test_a_variable_larger_than_the_mesh_allows_is_refused_before_it_is_read(tmp_path):
    """Issue 33 item 10: a netCDF-4 Exodus file whose nodal variable holds 1e9 values (chunks never written:
    HDF5 would hand back 8 GB of fill value) on a mesh of 100 nodes and one step. Before: read whole (8 GB);
    now refused from its shape, in a child that stays under 400 MB."""
    import shutil

    import h5py
    from _memory import in_child

    path = tmp_path / "bomb.e"
    shutil.copy(SFEPY, path)
    with h5py.File(path, "r+") as f:
        del f["vals_nod_var2"]
        f.create_dataset("vals_nod_var2", shape=(1, 10**9), dtype="f8", chunks=(1, 1 << 20))
    got = in_child(f"""
        from afferent.io import read_raw
        read_raw({str(path)!r})
    """)
    assert got["error"] == ["SEDFormatError", f"SED file {str(path)!r}: Exodus variable 'vals_nod_var2': the dataset holds "
                            "1,000,000,000 values (shape (1, 1000000000)) where 900 are expected: the file is corrupt; "
                            "refused before reading it."], got
    assert got["peak_mb"] < 400, got
