"""Exodus II files written by real tools (tests/data/exodus/README.md): MOOSE (BlackBear test
gold files) and Cubit (a mesh from Exodus.jl's tests). References: the same variables read
straight from the netCDF file with scipy here, and Hooke's law for the MOOSE model's material
(its input file: ComputeIsotropicElasticityTensor, E = 3.1e10 Pa, nu = 0.18).
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
EMBEDDED = EXO / "EqualValueEmbeddedConstraint_out.e"  # 1 HEX8 + 2 EDGE2 truss blocks, 11 steps, tensors
BAR = EXO / "tensile_bar_out.e"  # 40 HEX8, 21 steps, nodal disp, element stress_xx
COMPONENTS = ("xx", "yy", "zz", "xy", "yz", "xz")


def _netcdf(path, name):
    with netcdf_file(path, mmap=False) as nc:
        return np.array(nc.variables[name].data)


def _names(path, name):
    return ["".join(c.decode() for c in row if c != b"").strip() for row in _netcdf(path, name)]


def test_every_time_step_and_variable_is_read_as_the_file_holds_it():
    raw = read_raw(BAR)
    np.testing.assert_array_equal(raw.times, _netcdf(BAR, "time_whole"))
    assert raw.times.size == 21 and raw.cells.cell_types == ("hexahedron",) and raw.cells.n_cells == 40
    nodal, elemental = _names(BAR, "name_nod_var"), _names(BAR, "name_elem_var")
    for i, name in enumerate(nodal, start=1):
        assert raw.arrays[name].location == "point"
        np.testing.assert_array_equal(raw.arrays[name].values, _netcdf(BAR, f"vals_nod_var{i}"))
    for i, name in enumerate(elemental, start=1):
        assert raw.arrays[name].location == "cell"
        np.testing.assert_array_equal(raw.arrays[name].values, _netcdf(BAR, f"vals_elem_var{i}eb1"))
    assert raw.arrays["disp_x"].values[0].max() == 0 and raw.arrays["disp_x"].values[-1].max() > 0  # the load grows


def test_moose_tensor_components_are_tensor_shear_hookes_law_of_its_own_numbers():
    """stress = C : elastic_strain with tensor shear, at every step, for MOOSE's RankTwoAux output:
    the convention afferent assumes for MOOSE files, checked on the tool's numbers."""
    raw = read_raw(EMBEDDED)
    assert raw.cells.n_cells == 1 and "ignored block 2 (EDGE2, 8 elements), block 3 (EDGE2, 8 elements)" in raw.notes[0]
    s = np.stack([raw.arrays[f"stress_{c}"].values[:, 0] for c in COMPONENTS], -1)
    e = np.stack([raw.arrays[f"elastic_strain_{c}"].values[:, 0] for c in COMPONENTS], -1)
    young, nu = 3.1e10, 0.18
    lam, g = young * nu / ((1 + nu) * (1 - 2 * nu)), young / (2 * (1 + nu))
    hooke = np.concatenate([lam * e[:, :3].sum(-1, keepdims=True) + 2 * g * e[:, :3], 2 * g * e[:, 3:]], -1)
    np.testing.assert_allclose(hooke[:, :3], s[:, :3], rtol=1e-12, atol=1e-9 * np.abs(s).max())
    np.testing.assert_allclose(hooke[1:, 3:], s[1:, 3:], rtol=1e-6)  # shear: tiny (1e-12 strain) but exact
    assert not np.allclose(hooke[1:, 3:] / 2, s[1:, 3:], rtol=0.1)  # engineering shear would be off by 2
    field = read_sed(EMBEDDED, length_unit="mm", stress_unit="Pa", sed_from="exact", shear="tensor",
                     strain_columns=[f"elastic_strain_{c}" for c in COMPONENTS])
    assert field.location == "cell" and field.n_times == 11
    np.testing.assert_allclose(field.sed[:, 0], sed_exact(s, e), rtol=1e-14)
    np.testing.assert_allclose(field.sed[-1, 0], 155.30302167, rtol=1e-8)  # 1/2 sigma:eps, uniaxial 1e-4 stretch


def test_linear_sampling_on_the_exodus_mesh_reproduces_nodal_values():
    field = read_sed(BAR, length_unit="m", sed_column="disp_x", sed_unit="Pa")  # any nodal scalar will do
    raw = read_raw(BAR)
    corners = np.unique(raw.cells.tetra)[:20]
    got = sample_sed(field, ReceptorLayout(raw.points[corners]), method="linear").values
    np.testing.assert_allclose(got, field.sed[:, corners], rtol=1e-12, atol=1e-18)


def test_surface_meshes_and_mesh_only_files():
    raw = read_raw(EXO / "circular_out.e")  # 2-D QUAD4 + TRI3 (MOOSE): no volume cells
    assert raw.cells is None and raw.points.shape == (101, 3) and np.all(raw.points[:, 2] == 0)
    np.testing.assert_array_equal(raw.arrays["u"].values, _netcdf(EXO / "circular_out.e", "vals_nod_var4"))
    mesh = read_raw(EXO / "cubit_mixed_element_mesh.g")  # a Cubit mesh: no time step, no variable
    assert mesh.times is None and not mesh.arrays and "no time step" in mesh.notes[-1]
    with pytest.raises(SEDFormatError, match="has no strain-energy-density array"):
        read_sed(EXO / "cubit_mixed_element_mesh.g", length_unit="mm", sed_unit="Pa")


def test_netcdf4_exodus_is_read_through_hdf5(tmp_path):
    """netCDF-4 Exodus files are HDF5 files with the same variables. No tool here writes one, so
    the MOOSE file's variables are copied into HDF5 datasets with h5py (the layout netCDF-4
    uses); the reader must give the same arrays."""
    h5py = pytest.importorskip("h5py")
    out = tmp_path / "bar_nc4.e"
    with netcdf_file(BAR, mmap=False) as nc, h5py.File(out, "w") as h5:
        for name, var in nc.variables.items():
            ds = h5.create_dataset(name, data=np.array(var.data))
            for key, value in var._attributes.items():
                ds.attrs[key] = value
    a, b = read_raw(BAR), read_raw(out)
    assert b.notes[0].startswith("Exodus II, netCDF-4 (HDF5)")
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.cells.tetra, b.cells.tetra)
    for key in a.arrays:
        np.testing.assert_array_equal(a.arrays[key].values, b.arrays[key].values)


def test_damaged_exodus_files_are_named(tmp_path):
    data = BAR.read_bytes()
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


def test_info_describes_an_exodus_file(capsys):
    assert main(["info", str(EMBEDDED)]) == 0
    out = capsys.readouterr().out
    assert "format       exodus" in out and "time steps   11, t = 0 .. 10" in out
    assert "'stress_xy'                  cell " in out
    assert "Exodus II, netCDF-3 (64-bit offset): 11 time step(s), 1 volume block(s)" in out


PATCH = EXO / "elastic_patch_quadratic_out.e"  # MOOSE patch test: 7 irregular HEX20, closed-form state


def test_moose_patch_test_closed_form_and_its_own_energy_density():
    """Every exterior node displaced so that exx = eyy = ezz = 1e-4 and (tensor) exy = eyz = exz = 5e-5
    everywhere; lambda = G = 4e5: sxx = 200, sxy = 40, and MOOSE's own elastic energy density
    (ElasticEnergyAux, 1/2 sigma:eps) 0.036, at the nodes and in the cells."""
    raw = read_raw(PATCH)
    assert raw.cells.cell_types == ("hexahedron20",) and raw.cells.n_cells == 7
    last = {k: a.values[-1] for k, a in raw.arrays.items()}
    for name in ("stress_xx", "stress_yy", "stress_zz", "stress_xx@cell"):
        np.testing.assert_allclose(last[name], 200.0, rtol=1e-8)
    for name in ("stress_xy", "stress_yz", "stress_zx", "stress_xy@cell"):
        np.testing.assert_allclose(last[name], 40.0, rtol=1e-8)  # = 2 G eps_xy: tensor shear
    # 1/2 sigma:eps with tensor shear: 1/2 (3 x 200 x 1e-4 + 2 x 3 x 40 x 5e-5) = 0.036
    assert 0.5 * (3 * 200 * 1e-4 + 2 * 3 * 40 * 5e-5) == pytest.approx(0.036)
    for location in ("point", "cell"):
        field = read_sed(PATCH, length_unit="mm", sed_unit="MPa", sed_column="elastic_energy", location=location)
        np.testing.assert_allclose(field.sed[-1], 0.036e6, rtol=1e-8)
        assert field.location == location


def test_moose_plasticity_file_with_total_and_plastic_strain():
    raw = read_raw(EXO / "pull_push.e")
    assert raw.times.size == 31 and raw.cells.n_cells == 2
    np.testing.assert_allclose(raw.times, np.round(np.arange(31) * 0.1, 10), atol=1e-12)
    np.testing.assert_array_equal(raw.arrays["straint_xz"].values, _netcdf(EXO / "pull_push.e", "vals_elem_var15eb1"))
    assert _names(EXO / "pull_push.e", "name_elem_var")[14] == "straint_xz"


def test_netcdf4_exodus_written_by_seacas():
    raw = read_raw(EXO / "aero_blunt_wedge_wall_test3.ex2")  # IOSS, netCDF-4 (HDF5), SHELL4 only
    assert raw.notes[0].startswith("Exodus II, netCDF-4 (HDF5): 5 time step(s), 0 volume block(s); ignored block 1 (SHELL4")
    assert raw.cells is None and raw.points.shape == (10, 3)
    np.testing.assert_allclose(raw.times[[0, -1]], [3.08136e-4, 1.66369e-3], rtol=1e-5)


def test_element_types_spelled_otherwise_are_recognised_by_family_and_nodes():
    from afferent.io._exodus import _volume_type

    assert [_volume_type(t, n) for t, n in (("HEXAHEDRON", 8), ("HEX", 20), ("TETRA", 4), ("TET10", 10),
                                            ("WEDGE", 6), ("PYRAMID", 5), ("SHELL4", 4), ("BAR2", 2))] == [
        "hexahedron", "hexahedron20", "tetra", "tetra10", "wedge", "pyramid", None, None]
