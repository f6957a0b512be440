"""CalculiX .frd files written by CalculiX itself (ccx 2.20; tests/data/calculix/README.md).

The model (make_calculix.py): a 2 x 2 x 1 mm block, E = 0.1 MPa, nu = 0.45, a 1 x 1 mm patch of
the top face pushed down 1/3, 2/3 and 3/3 of 0.1 mm in three linear steps; mm/N/s, so stress
and ENER are in MPa. References: Hooke's law for that material (the .frd's own stress and
strain), the integration-point values ccx prints to the .dat, and the ASCII twin of the binary
file.
"""

from __future__ import annotations

import gzip
import re
import warnings

import numpy as np
import pytest

from afferent import read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw
from afferent.receptors import ReceptorLayout
from afferent.strain_energy import sed_exact

from conftest import DATA_DIR

CCX = DATA_DIR / "calculix"
E_MPA, NU = 0.1, 0.45
G_PA = E_MPA * 1e6 / (2 * (1 + NU))


def _read(name, **kw):
    kw.setdefault("length_unit", "mm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)  # the nodal ENER artefacts, tested below
        return read_sed(CCX / name, **kw)


@pytest.mark.parametrize("name, cell_type, n_cells, n_nodes", [
    ("block_c3d8.frd", "hexahedron", 32, 75), ("block_c3d20r.frd", "hexahedron20", 4, 51),
    ("block_c3d10.frd", "tetra10", 24, 75), ("block_c3d8_binary.frd", "hexahedron", 32, 75),
])
def test_every_output_step_mesh_and_component_is_read(name, cell_type, n_cells, n_nodes):
    raw = read_raw(CCX / name)
    assert raw.format == "frd" and raw.preset == "calculix-frd"
    assert raw.cells.cell_types == (cell_type,) and raw.cells.n_cells == n_cells and raw.points.shape == (n_nodes, 3)
    np.testing.assert_array_equal(raw.times, [1.0, 2.0, 3.0])
    assert list(raw.arrays) == ["DISP", "STRESS", "TOSTRAIN", "ENER", "ERROR"]
    assert raw.arrays["STRESS"].components == ("SXX", "SYY", "SZZ", "SXY", "SYZ", "SZX")
    assert raw.arrays["TOSTRAIN"].components == ("EXX", "EYY", "EZZ", "EXY", "EYZ", "EZX")
    assert raw.arrays["DISP"].components == ("D1", "D2", "D3")  # 'ALL' is computed by ccx's viewer, not stored
    # the patch goes down by 1/3, 2/3, 3/3 of 0.1 mm: the smallest z displacement of each step
    np.testing.assert_allclose(raw.arrays["DISP"].values[:, :, 2].min(axis=1), [-0.1 / 3, -0.2 / 3, -0.1], rtol=1e-5)


def test_binary_gzip_and_ascii_files_of_one_run_agree():
    ascii_, gz, binary = (read_raw(CCX / n) for n in ("block_c3d8.frd", "block_c3d8.frd.gz", "block_c3d8_binary.frd"))
    assert gzip.decompress((CCX / "block_c3d8.frd.gz").read_bytes()) == (CCX / "block_c3d8.frd").read_bytes()
    for other, rtol in ((gz, 0.0), (binary, 5e-6)):  # ASCII keeps 6 digits (%12.5E); binary is float32
        np.testing.assert_array_equal(other.points, ascii_.points)
        np.testing.assert_array_equal(other.cells.tetra, ascii_.cells.tetra)
        for key, arr in ascii_.arrays.items():
            scale = np.abs(arr.values).max()
            np.testing.assert_allclose(other.arrays[key].values, arr.values, rtol=0, atol=rtol * scale, err_msg=key)


@pytest.mark.parametrize("name", ["block_c3d8.frd", "block_c3d20r.frd", "block_c3d10.frd", "block_c3d8_binary.frd"])
def test_nodal_stress_is_hookes_law_of_the_nodal_strain_with_tensor_shear(name):
    """ccx extrapolates and averages each component linearly, so sigma = C : eps holds at the nodes.
    It holds with tensor shear (the calculix-frd preset) and fails by 2x on the shear terms otherwise:
    this checks the component order and the shear convention on the tool's own numbers."""
    raw = read_raw(CCX / name)
    s, e = raw.arrays["STRESS"].values, raw.arrays["TOSTRAIN"].values  # MPa; XX YY ZZ XY YZ ZX
    lam = E_MPA * NU / ((1 + NU) * (1 - 2 * NU))
    g = E_MPA / (2 * (1 + NU))
    tr = e[..., :3].sum(-1, keepdims=True)
    hooke = np.concatenate([lam * tr + 2 * g * e[..., :3], 2 * g * e[..., 3:]], axis=-1)
    assert np.abs(hooke - s).max() < 2e-5 * np.abs(s).max()
    engineering = np.concatenate([hooke[..., :3], hooke[..., 3:] / 2], axis=-1)
    assert np.abs(engineering - s).max() > 0.05 * np.abs(s).max()
    field = _read(name, stress_unit="MPa", sed_from="exact")  # preset implied by the file
    shear = field.provenance.checks["shear_convention"]
    assert shear["consistent"] and shear["ratio"] == pytest.approx(1.0, abs=1e-4)
    assert shear["k_shear"] == pytest.approx(2 * G_PA, rel=1e-4)


def test_integration_point_energy_density_is_half_sigma_eps_with_tensor_shear():
    """The .dat prints S, E and ENER at the integration points, in the order xx yy zz xy xz yz
    (CalculiX's printout.f): there 1/2 sigma:eps = ENER to the print precision."""
    raw = read_raw(CCX / "block_c3d8.dat")
    a = raw.arrays
    s = np.stack([a[k].values for k in ("sxx", "syy", "szz", "sxy", "syz", "sxz")], -1)
    e = np.stack([a[k].values for k in ("exx", "eyy", "ezz", "exy", "eyz", "exz")], -1)
    ener = a["internal energy density"].values
    assert ener.shape == (3, 32 * 8) and ener.min() > 0  # no negative value at the integration points
    np.testing.assert_allclose(sed_exact(s, e), ener, rtol=2e-6, atol=1e-6 * ener.max())
    engineering = e.copy()
    engineering[..., 3:] /= 2
    assert np.abs(sed_exact(s, engineering) - ener).max() > 0.01 * ener.max()


def test_nodal_ener_extrapolation_artefacts_are_accepted_counted_and_reported():
    """ccx extrapolates ENER from the integration points (all > 0) to the nodes: near the patch
    edge, a singularity, nodal values go negative (measured: -3.5 % of the largest for this C3D8
    mesh, -16 % for C3D10). They are read, set to 0, counted and warned about."""
    with pytest.warns(AfferentWarning, match=re.escape("12 of 225 SED value(s) are negative (down to -0.035 x the largest SED")):
        field = read_sed(CCX / "block_c3d8.frd", length_unit="mm", sed_unit="MPa")
    neg = field.provenance.negative_sed
    assert neg["count"] == 12 and neg["action"] == "set to 0" and neg["min_relative"] == pytest.approx(-0.0347, abs=5e-4)
    assert field.sed.min() == 0.0 and field.sed.max() == pytest.approx(1.83016e-3 * 1e6, rel=1e-5)
    raw = read_raw(CCX / "block_c3d8.frd")
    np.testing.assert_array_equal(field.sed, np.maximum(raw.arrays["ENER"].values, 0) * 1e6)
    for name in ("block_c3d20r.frd", "block_c3d10.frd"):  # quadratic elements overshoot more
        f = _read(name, sed_unit="MPa")
        assert -0.25 < f.provenance.negative_sed["min_relative"] < -0.05


def test_linear_sampling_at_the_corner_nodes_returns_the_nodal_values():
    field = _read("block_c3d8.frd", sed_unit="MPa")
    raw = read_raw(CCX / "block_c3d8.frd")
    corners = np.unique(raw.cells.tetra)
    layout = ReceptorLayout(raw.points[corners] * 1e-3)
    got = sample_sed(field, layout, method="linear").values
    np.testing.assert_allclose(got, field.sed[:, corners], rtol=1e-9, atol=1e-9 * field.sed.max())


def test_nodal_sed_and_half_sigma_eps_differ_by_nodal_averaging_only():
    """At the nodes, ENER (extrapolated) and 1/2 sigma:eps of the extrapolated tensors differ by
    the averaging alone (measured 40 % relative L2 on this coarse mesh, 8 % on a 16 x 16 x 8 one):
    the cross-check records it without crying wolf; the shear check above is the one that decides."""
    field = _read("block_c3d8.frd", stress_unit="MPa", sed_from="exact")
    chk = field.provenance.checks["tensor_sed_vs_export_sed"]
    assert chk["location"] == "point" and chk["agree"] and 0.2 < chk["relative_difference"] < 0.5


def test_damaged_frd_files_are_named_with_the_line(tmp_path):
    text = (CCX / "block_c3d8.frd").read_bytes()
    cut = tmp_path / "cut.frd"
    cut.write_bytes(text[: text.index(b"    3C")] + text[text.index(b"    3C"):][:2000])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(cut)!r}, line")) as err:
        read_raw(cut)
    assert "the element block has no end (' -3'): the file is truncated." in str(err.value)
    binary = (CCX / "block_c3d8_binary.frd").read_bytes()
    short = tmp_path / "short.frd"
    short.write_bytes(binary[: binary.index(b"    3C") - 50])  # inside the binary node records
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(short)!r} ends inside the binary node block (after line 12): it needs 2100 bytes, 2050 remain "
            "(truncated?).")):
        read_raw(short)
    other = tmp_path / "not.frd"
    other.write_text("x,y,z\n1,2,3\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(other)!r} is not a CalculiX .frd file: it must start with the '    1C' header line; "
            "got 'x,y,z' instead.")):
        read_raw(other)
    bad = tmp_path / "bad_number.frd"
    lines = text.decode().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.startswith(" -1") and "E" in line and i > 200)
    lines[k] = lines[k][:20] + "x.xxxxxE+00" + lines[k][31:]
    bad.write_text("".join(lines))
    with pytest.raises(SEDFormatError, match=re.escape("holds a field that is not a number")):
        read_raw(bad)


def test_info_describes_a_frd(capsys):
    assert main(["info", str(CCX / "block_c3d8_binary.frd")]) == 0
    out = capsys.readouterr().out
    assert "format       frd" in out and "32 volume cells (hexahedron)" in out and "time steps   3, t = 1 .. 3" in out
    assert "'STRESS'                     point 6 components" in out
    assert "negative SED 12 of 225 values" in out
    assert "CalculiX .frd (binary), written by CalculiX Version 2.20: 3 output step(s)" in out


def _inp_mesh(path):
    """Nodes and C3D8 elements of a .inp deck, parsed here independently of afferent."""
    nodes, elements, block = {}, {}, None
    for line in path.read_text().splitlines():
        if line.startswith("*"):
            block = line.split(",")[0].strip().upper()
            continue
        parts = [p.strip() for p in line.split(",") if p.strip()]
        if block == "*NODE":
            nodes[int(parts[0])] = [float(v) for v in parts[1:4]]
        elif block == "*ELEMENT":
            elements[int(parts[0])] = [int(v) for v in parts[1:9]]
    return nodes, elements


def test_integration_point_tables_average_per_element_at_the_frd_centroids():
    """.dat *EL PRINT rows (8 integration points per C3D8) averaged per element and placed at the
    element centroid (mean of its corner nodes) from the .frd of the same run."""
    import pandas as pd

    field = read_sed(CCX / "block_c3d8.dat", coordinates=CCX / "block_c3d8.frd", length_unit="mm", sed_unit="MPa")
    assert field.n_points == 32 and field.n_times == 3
    assert "SED at 256 integration points averaged per element (32 elements, 8 point(s) each" in " ".join(field.provenance.notes)
    raw = read_raw(CCX / "block_c3d8.dat")
    df = pd.DataFrame({"elem": raw.arrays["elem"].values[-1], "ener": raw.arrays["internal energy density"].values[-1]})
    per_element = df.groupby("elem")["ener"].mean()
    nodes, elements = _inp_mesh(CCX / "block_c3d8.inp")
    centroids = np.array([np.mean([nodes[n] for n in elements[e]], axis=0) for e in per_element.index])
    np.testing.assert_allclose(field.points, centroids * 1e-3, rtol=0, atol=1e-12)
    np.testing.assert_allclose(field.sed[-1], per_element.to_numpy() * 1e6, rtol=1e-12)
    assert field.provenance.negative_sed is None  # integration points hold no extrapolation artefact
    # from the tensors at the integration points (the .dat implies CalculiX's .dat order and tensor shear)
    exact = read_sed(CCX / "block_c3d8.dat", coordinates=CCX / "block_c3d8.frd", length_unit="mm", stress_unit="MPa",
                     sed_from="exact")
    np.testing.assert_allclose(exact.sed, field.sed, rtol=2e-5)
    assert exact.provenance.checks["shear_convention"]["consistent"]
    assert exact.provenance.checks["tensor_sed_vs_export_sed"]["agree"]


def test_a_vtu_as_ccx2paraview_writes_it_is_ordered_by_its_component_names(tmp_path):
    """ccx2paraview converts .frd to VTU with S and E as 6-component arrays named XX YY ZZ XY YZ ZX
    (ComponentName attributes, which meshio drops): afferent reads the names, so even a preset
    with another order (abaqus: 11 22 33 12 13 23) puts every component in its place. (No SED
    measure can tell: 1/2 sigma:eps and the von Mises-based equivalent SED are both unchanged by
    a consistent relabelling of the shear components.)"""
    import meshio

    from afferent.io._assemble import ReadOptions, find_tensors

    raw = read_raw(CCX / "block_c3d8.frd")
    s, e = raw.arrays["STRESS"].values[-1], raw.arrays["TOSTRAIN"].values[-1]
    mesh = meshio.Mesh(raw.points, [("vertex", np.arange(len(raw.points)).reshape(-1, 1))], point_data={"S": s, "E": e})
    path = tmp_path / "job.vtu"
    meshio.write(path, mesh, binary=False)
    names = ('ComponentName0="XX" ComponentName1="YY" ComponentName2="ZZ" ComponentName3="XY" ComponentName4="YZ" '
             'ComponentName5="ZX"')
    text = path.read_text()
    for arr in ("S", "E"):
        text = text.replace(f'Name="{arr}"', f'Name="{arr}" {names}', 1)
    path.write_text(text)
    named = read_raw(path)
    assert named.arrays["S"].components == ("XX", "YY", "ZZ", "XY", "YZ", "ZX")
    (_, stress, _), _ = find_tensors(named, ReadOptions(sed_from="exact", preset="abaqus", shear="tensor"))
    np.testing.assert_array_equal(stress[0], s)  # canonical xx yy zz xy yz xz = the file's XX .. ZX
    meshio.write(tmp_path / "unnamed.vtu", mesh, binary=False)
    (_, by_preset, _), _ = find_tensors(read_raw(tmp_path / "unnamed.vtu"),
                                        ReadOptions(sed_from="exact", preset="abaqus", shear="tensor"))
    np.testing.assert_array_equal(by_preset[0][:, [4, 5]], s[:, [5, 4]])  # positions read as 13, 23: swapped


# ---------------------------------------------------------------------------------------------
# Two materials (block_layers*.frd): the element block's material numbers become cell data, so
# that an interface between two materials of a CalculiX model is found as on a VTU with a
# 'layer' array. Model (make_calculix.write_layered_inp): 1.5 x 1 x 1.5 mm, y up, the
# EPIDERMIS / DERMIS interface at y = 0.5 + 0.08 cos(2 pi x / 0.5) cos(2 pi z / 0.5) mm.
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["block_layers.frd", "block_layers_binary.frd"])
def test_material_numbers_of_the_element_block_are_cell_data_in_material_card_order(name):
    raw = read_raw(CCX / name)
    arr = raw.arrays["material"]
    assert arr.location == "cell" and arr.values.shape == (1, 864)
    mat = arr.values[0]
    # elements 1..432 (the lower three element layers) are the DERMIS set, the second *MATERIAL card,
    # though its *SOLID SECTION comes first in the deck
    assert np.array_equal(mat[:432], np.full(432, 2.0)) and np.array_equal(mat[432:], np.full(432, 1.0))
    assert any("material number of each element" in n for n in raw.notes)


def test_a_single_material_model_gets_no_material_array():
    """One material carries no interface: no array that would only repeat the number 1."""
    assert "material" not in read_raw(CCX / "block_c3d8.frd").arrays


@pytest.mark.parametrize("kind", ["tips", "bases"])
def test_tips_and_bases_are_found_on_the_interface_of_a_calculix_model(tmp_path, kind):
    """Tips: the 13 interior maxima of the relief (both cosines +1 or both -1); bases: its 12 interior minima
    (the cosines of opposite signs); nothing else; SED symmetric as the model."""
    out = tmp_path / "sites.csv"
    code = main(["sample", str(CCX / "block_layers.frd"), "--length-unit", "mm", "--sed-unit", "MPa", "--grid", kind,
                 "--material-array", "material", "--upper", "1", "--lower", "2", "-q", "-o", str(out)])
    assert code == 0
    import pandas as pd

    df = pd.read_csv(out)
    x, z = df["x_m"].to_numpy() * 1e3, df["z_m"].to_numpy() * 1e3
    found = sorted(zip(np.round(x, 6), np.round(z, 6)))
    plus, minus = (0.5, 1.0), (0.25, 0.75, 1.25)
    pairs = ((plus, plus), (minus, minus)) if kind == "tips" else ((plus, minus), (minus, plus))
    expected = sorted((a, b) for xs, zs in pairs for a in xs for b in zs)
    assert found == expected
    assert np.allclose(df["y_m"] * 1e3, 0.58 if kind == "tips" else 0.42)  # 0.5 +- 0.08
    sed = dict(zip(found, df.sort_values(["x_m", "z_m"])["sed_pa"]))
    for (a, b), value in sed.items():  # mirror x, mirror z, swap x and z: the model's symmetries
        for twin in ((1.5 - a, b), (a, 1.5 - b), (b, a)):
            assert sed[tuple(np.round(twin, 6))] == pytest.approx(value, rel=1e-4)
