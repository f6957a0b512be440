"""From a reader's raw table to an SEDField: columns, units, tensors, joins, NaN handling.

The CSV files under tests/data/csv are synthetic files in several tools' documented layouts
(see tests/data/csv/README.md); the values checked here are read off those files by hand.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from afferent import read_sed
from afferent.exceptions import SEDFormatError, UnitError

CSV = "tests/data/csv"


def test_workbench_units_come_from_the_headers():
    f = read_sed(f"{CSV}/workbench_tab.txt")
    np.testing.assert_allclose(f.points[1], [-0.7e-3, 1.4142135623730951e-3, 2.5e-3], rtol=1e-15)
    np.testing.assert_allclose(f.sed[0], [5.6e-4 * 1e6, 1.2345678901234567e-3 * 1e6, 0.00011111111111111112 * 1e6], rtol=1e-15)
    assert f.provenance.units["length_source"] == "file" and f.provenance.units["sed"] == "MPa"
    assert f.provenance.columns["sed"] == "Strain Energy Density"


def test_declared_unit_must_agree_with_the_file():
    with pytest.raises(UnitError, match=re.escape("'length_unit' is 'm' but SED file 'tests/data/csv/workbench_tab.txt' states 'mm' for the coordinates")):
        read_sed(f"{CSV}/workbench_tab.txt", length_unit="m")
    f = read_sed(f"{CSV}/workbench_tab.txt", length_unit="mm", sed_unit="N/mm^2")  # same units, other spelling
    assert f.provenance.units["sed_source"] == "declared"


def test_comsol_one_column_per_step():
    f = read_sed(f"{CSV}/comsol_time_suffix.csv")
    np.testing.assert_allclose(f.times, [0.0, 0.05, 0.1])
    np.testing.assert_allclose(f.sed[:, 0], [0.0, 0.14285714285714285, 0.2857142857142857], rtol=1e-15)
    np.testing.assert_allclose(f.points[2], [0.7e-3, 0.8e-3, 0.9e-3], rtol=1e-15)


def test_comsol_nan_rows_error_or_drop():
    with pytest.raises(SEDFormatError, match=re.escape(
            "SED column 'solid.Ws' must be finite; got 1 non-finite value(s) (first: NaN at row 3) instead. "
            "Pass on_nan='drop' to leave such rows out.")):
        read_sed(f"{CSV}/comsol_spreadsheet.csv")
    f = read_sed(f"{CSV}/comsol_spreadsheet.csv", on_nan="drop")
    assert f.n_points == 2 and "2 of 4 rows with NaN dropped (on_nan='drop')." in f.provenance.notes


def test_febio_logfile_with_a_node_table(tmp_path):
    nodes = tmp_path / "nodes.csv"
    nodes.write_text("node,x,y,z\n3,0.3,0.0,1.0\n1,0.1,0.0,1.0\n2,0.2,0.0,1.0\n")  # any order
    f = read_sed(f"{CSV}/febio_log.txt", coordinates=nodes, length_unit="mm", sed_unit="MPa")
    np.testing.assert_allclose(f.points[:, 0], [0.1e-3, 0.2e-3, 0.3e-3], rtol=1e-15)
    np.testing.assert_allclose(f.times[:2], [0.1, 0.2])
    np.testing.assert_allclose(f.sed[0], np.array([0.00033333333333333332, 0.00016666666666666666, 0.0]) * 1e6, rtol=1e-15)
    assert "coordinates joined from" in " ".join(f.provenance.notes)


def test_join_errors(tmp_path):
    nodes = tmp_path / "nodes.csv"
    nodes.write_text("node,x,y,z\n1,0.1,0.0,1.0\n2,0.2,0.0,1.0\n")
    with pytest.raises(SEDFormatError, match=re.escape(f"Coordinates file {str(nodes)!r} lacks 1 id(s) of SED file 'tests/data/csv/febio_log.txt' (first: 3).")):
        read_sed(f"{CSV}/febio_log.txt", coordinates=nodes, length_unit="mm", sed_unit="MPa")
    elements = tmp_path / "elements.csv"
    elements.write_text("element,x,y,z\n1,0.1,0.0,1.0\n2,0.2,0.0,1.0\n")
    repeated = tmp_path / "repeated.csv"
    repeated.write_text("element,SED\n1,0.1\n1,0.2\n2,0.3\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            "ids in column 'element' repeat (integration-point rows without an integration-point column?)")):
        read_sed(repeated, coordinates=elements, length_unit="mm", sed_unit="MPa")


def test_integration_point_rows_are_averaged_per_element_then_placed(tmp_path):
    # abaqus_tensors.rpt: element 1 has integration points 1 and 2, element 2 point 1
    elements = tmp_path / "elements.csv"
    elements.write_text("element,x,y,z\n1,0.1,0.0,1.0\n2,0.2,0.0,1.0\n")
    f = read_sed(f"{CSV}/abaqus_tensors.rpt", coordinates=elements, length_unit="mm", stress_unit="MPa",
                 sed_from="exact", preset="abaqus")
    assert f.n_points == 2
    assert "SED at 3 integration points averaged per element (2 elements, 1, 2 point(s) each, equal weights" in \
        " ".join(f.provenance.notes)
    from afferent.io import read_raw

    a = read_raw(f"{CSV}/abaqus_tensors.rpt").arrays
    stress = np.stack([a[k].values[0] for k in ("S.S11", "S.S22", "S.S33", "S.S12", "S.S23", "S.S13")], -1)
    strain = np.stack([a[k].values[0] for k in ("LE.LE11", "LE.LE22", "LE.LE33", "LE.LE12", "LE.LE23", "LE.LE13")], -1)
    strain[:, 3:] /= 2  # Abaqus LE shear is engineering
    at_points = 0.5 * ((stress[:, :3] * strain[:, :3]).sum(1) + 2 * (stress[:, 3:] * strain[:, 3:]).sum(1))  # MPa
    # SED at each integration point first, then the element mean (1/2 sigma:eps is quadratic)
    np.testing.assert_allclose(f.sed[0], np.array([at_points[:2].mean(), at_points[2]]) * 1e6, rtol=1e-12)
    np.testing.assert_allclose(f.points[:, 0], [0.1e-3, 0.2e-3])


def test_no_coordinates_says_how_to_add_them():
    with pytest.raises(SEDFormatError, match=re.escape(
            "must have one x coordinate column (e.g. 'x', 'X', 'COORD1', 'X Location'); found no. "
            "Found columns 'Node Label', 'SENER'.")):
        read_sed(f"{CSV}/abaqus_sener.rpt", length_unit="mm", sed_unit="MPa")


def _tensor_table(tmp_path, *, engineering: bool, names, extra=None):
    rng = np.random.default_rng(7)
    eps = rng.normal(0, 1e-3, (5, 6))  # canonical xx yy zz xy yz xz, tensor shear
    lam, G = 0.3, 0.02  # MPa
    sig = 2 * G * eps
    sig[:, :3] += lam * eps[:, :3].sum(1, keepdims=True)
    u = 0.5 * ((sig[:, :3] * eps[:, :3]).sum(1) + 2 * (sig[:, 3:] * eps[:, 3:]).sum(1))  # MPa
    order = [0, 1, 2, 3, 5, 4]  # names are given in Abaqus order 11 22 33 12 13 23
    e = eps[:, order].copy()
    if engineering:
        e[:, 3:] *= 2
    df = pd.DataFrame(rng.uniform(0, 1, (5, 3)), columns=["X", "Y", "Z"])
    for k, n in enumerate(names[:6]):
        df[n] = sig[:, order][:, k]
    for k, n in enumerate(names[6:]):
        df[n] = e[:, k]
    for k, v in (extra or {}).items():
        df[k] = v
    path = tmp_path / "tensors.csv"
    df.to_csv(path, index=False, float_format="%.17g")
    return path, u * 1e6


ABQ = ["S11", "S22", "S33", "S12", "S13", "S23", "E11", "E22", "E33", "E12", "E13", "E23"]
COMSOL = ["solid.sx", "solid.sy", "solid.sz", "solid.sxy", "solid.sxz", "solid.syz",
          "solid.eXX", "solid.eYY", "solid.eZZ", "solid.eXY", "solid.eXZ", "solid.eYZ"]


@pytest.mark.parametrize("names, preset, engineering", [(ABQ, "abaqus", True), (COMSOL, "comsol", False)])
def test_csv_tensors_by_name_give_the_exact_sed(tmp_path, names, preset, engineering):
    path, expected = _tensor_table(tmp_path, engineering=engineering, names=names)
    f = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset=preset)
    np.testing.assert_allclose(f.sed[0], expected, rtol=1e-12)
    assert f.provenance.columns["stress"].split(", ")[3] == names[3]


def test_shear_convention_must_be_declared_and_matters(tmp_path):
    path, expected = _tensor_table(tmp_path, engineering=True, names=ABQ)
    wrong = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", shear="tensor")
    assert not np.allclose(wrong.sed[0], expected, rtol=1e-3)
    with pytest.raises(ValueError, match=re.escape("sed_unit='MPa' does not apply with sed_from='exact'")):
        read_sed(path, length_unit="mm", sed_unit="MPa", sed_from="exact", preset="abaqus")


def test_incomplete_tensor_names_the_missing_components(tmp_path):
    path, _ = _tensor_table(tmp_path, engineering=True, names=ABQ)
    df = pd.read_csv(path).drop(columns=["S13"])
    df.to_csv(path, index=False)
    with pytest.raises(SEDFormatError, match=re.escape("has no complete stress tensor (found 'S11', 'S22', 'S33', 'S12', 'S23'); missing component(s) xz.")):
        read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="abaqus")


def test_energy_column_is_refused(tmp_path):
    p = tmp_path / "else.csv"
    p.write_text("x,y,z,ELSE\n0,0,0,1.5\n1,0,0,2.5\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            "column 'ELSE' holds an energy, not an energy density (Abaqus/CalculiX ELSE is the element's total strain energy (J), not a density)")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_sed_columns_one_per_step_by_name(tmp_path):
    p = tmp_path / "steps.csv"
    p.write_text("x,y,z,SED_a,SED_b\n0,0,0,1.5,3.0\n1,0,0,2.5,5.0\n")
    f = read_sed(p, length_unit="mm", sed_unit="kPa", sed_column=["SED_a", "SED_b"], times=[0.0, 0.1])
    np.testing.assert_allclose(f.sed, [[1500.0, 2500.0], [3000.0, 5000.0]])
    np.testing.assert_allclose(f.times, [0.0, 0.1])


def test_file_unit_that_afferent_does_not_know(tmp_path):
    p = tmp_path / "u.csv"
    p.write_text("x (mm),y (mm),z (mm),SED (psi)\n0,0,0,1.5\n1,0,0,2.5\n")
    with pytest.raises(UnitError, match=re.escape("states the unit 'psi' for SED column 'SED', which afferent does not know")):
        read_sed(p)


def _tensor_raw(stress, strain, *, ncomp, components=(), preset=None):
    from afferent.io._assemble import ReadOptions, assemble  # noqa: F401
    from afferent.io._raw import RawArray, RawExport

    pts = np.array([[0.0, 0.0, 0.0]])
    return RawExport(
        files=("mem.vtu",), format="vtu", points=pts, preset=preset,
        arrays={
            "S": RawArray("S", np.asarray(stress, float).reshape(1, 1, ncomp), components=components),
            "E": RawArray("E", np.asarray(strain, float).reshape(1, 1, ncomp), components=components),
        },
    )


@pytest.mark.parametrize("preset", ["abaqus", "ansys", "sfepy", "comsol", "calculix-frd"])
def test_full_3x3_strain_is_never_halved_again(preset):
    # Pure shear tau_xy = 1 Pa, eps_xy = 0.2 (tensor): SED = 1/2 * 2 * tau * eps = 0.2 J/m^3 for
    # every preset: a 9-component array holds tensor components whatever the tool's 6-vector shear.
    from afferent.io._assemble import ReadOptions, assemble

    s = [[0, 1, 0], [1, 0, 0], [0, 0, 0]]
    e = [[0, 0.2, 0], [0.2, 0, 0], [0, 0, 0]]
    f = assemble(_tensor_raw(s, e, ncomp=9), ReadOptions(length_unit="m", stress_unit="Pa", sed_from="exact", preset=preset))
    np.testing.assert_allclose(f.sed, [[0.2]], rtol=1e-15)


def test_named_six_component_arrays_are_ordered_by_their_names():
    # CalculiX .frd order SXX SYY SZZ SXY SYZ SZX: a yz-only shear state, read by names under
    # the 'abaqus' preset (whose positional order would put it in xz), gives the same SED.
    from afferent.io._assemble import ReadOptions, assemble

    names = ("SXX", "SYY", "SZZ", "SXY", "SYZ", "SZX")
    s = [0, 0, 0, 0, 3.0, 1.0]
    e = [0, 0, 0, 0, 0.1, 0.0]  # eps_yz only (tensor shear)
    raw = _tensor_raw(s, e, ncomp=6, components=names)
    f = assemble(raw, ReadOptions(length_unit="m", stress_unit="Pa", sed_from="exact", shear="tensor"))
    np.testing.assert_allclose(f.sed, [[3.0 * 0.1]], rtol=1e-15)  # 1/2 * 2 * s_yz * e_yz


def test_the_files_own_convention_is_used_and_a_contradicting_preset_refused():
    from afferent.io._assemble import ReadOptions, assemble

    s = [0, 0, 0, 2.0, 0, 0]
    e = [0, 0, 0, 0.1, 0, 0]
    raw = _tensor_raw(s, e, ncomp=6, preset="sfepy")  # engineering shear: eps_xy = 0.05
    f = assemble(raw, ReadOptions(length_unit="m", stress_unit="Pa", sed_from="exact"))
    np.testing.assert_allclose(f.sed, [[2.0 * 0.05]], rtol=1e-15)
    assert "implied by the file format" in " ".join(f.provenance.notes)
    with pytest.raises(ValueError, match=re.escape("preset='abaqus' contradicts SED file 'mem.vtu', which only 'sfepy' writes")):
        assemble(raw, ReadOptions(length_unit="m", stress_unit="Pa", sed_from="exact", preset="abaqus"))


def _abaqus_like_vtu(path):
    """Isotropic material (E 1 MPa, nu 0.3), random strains at the nodes; Abaqus conventions:
    S11 S22 S33 S12 S13 S23, engineering shear strain (LE), SENER = 1/2 sigma:eps computed here."""
    import meshio

    from conftest import hex_box

    pts, hexes = hex_box(3, 3, 3)
    rng = np.random.default_rng(7)
    lam, mu = 0.3 / (1.3 * 0.4), 1 / 2.6
    eps = rng.normal(size=(len(pts), 3, 3)) * 1e-2
    eps = (eps + eps.transpose(0, 2, 1)) / 2
    sig = lam * np.trace(eps, axis1=1, axis2=2)[:, None, None] * np.eye(3) + 2 * mu * eps
    sed = 0.5 * np.einsum("nij,nij->n", sig, eps)

    def voigt(t, f):
        return np.stack([t[:, 0, 0], t[:, 1, 1], t[:, 2, 2], f * t[:, 0, 1], f * t[:, 0, 2], f * t[:, 1, 2]], -1)

    meshio.write(path, meshio.Mesh(pts, [("hexahedron", hexes)], point_data={"SENER": sed, "S": voigt(sig, 1), "LE": voigt(eps, 2)}))
    return path, sed


def test_a_wrong_shear_convention_is_caught_against_the_exports_own_sed(tmp_path, capsys):
    import warnings

    from afferent.cli import main
    from afferent.exceptions import AfferentWarning

    path, sed = _abaqus_like_vtu(tmp_path / "abq.vtu")
    kw = dict(length_unit="mm", stress_unit="MPa", sed_from="exact")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        right = read_sed(path, preset="abaqus", **kw)
    np.testing.assert_allclose(right.sed[0], sed * 1e6, rtol=1e-12)
    check = right.provenance.checks["tensor_sed_vs_export_sed"]
    assert check["agree"] and check["relative_difference"] < 1e-12 and check["scale"] == pytest.approx(1.0)  # both MPa
    assert check["by_preset"]["comsol"] > 0.1  # engineering shear read as tensor shear: shear energy doubled
    # the material-free shear check: 2G for normal and shear components alike (E = 1 MPa, nu = 0.3)
    shear = right.provenance.checks["shear_convention"]
    assert shear["consistent"] and shear["ratio"] == pytest.approx(1.0, abs=1e-12)
    assert shear["k_shear"] == pytest.approx(1e6 / 1.3, rel=1e-12)  # 2G in Pa
    with pytest.raises(SEDFormatError, match=re.escape(
            "with the shear strain read as tensor (preset='comsol'), the shear components of stress and strain are "
            "0.5 x as stiff as the normal ones (1 for an isotropic solid): the file's shear strain looks engineering, "
            "and read as tensor the SED from its tensors is wrong (its shear terms doubled)")):
        read_sed(path, preset="comsol", **kw)
    with pytest.warns(AfferentWarning, match=re.escape(
            "with the shear strain read as tensor (preset='comsol' shear='tensor'), the shear components of stress "
            "and strain are 0.5 x as stiff as the normal ones (1 for an isotropic solid): the file's shear strain "
            "looks engineering. Check the preset or pass shear='engineering'.")):
        wrong = read_sed(path, preset="comsol", shear="tensor", **kw)  # the convention confirmed: a warning
    assert not wrong.provenance.checks["shear_convention"]["consistent"]
    # at the nodes 1/2 sigma:eps and an SED array differ by nodal averaging alone (10-40 %): no alarm from it there
    assert wrong.provenance.checks["tensor_sed_vs_export_sed"]["agree"]
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert ("cross-check  1/2 sigma:eps from the tensors vs the SED array 'SENER' (step 0, relative L2 after the best scale, "
            "1 for 'abaqus'): abaqus/ansys/sfepy/kratos < 1e-7 % (round-off); openfoam ") in out and "; comsol/" in out



def test_points_listed_twice_merge_when_they_agree_and_are_refused_when_not(tmp_path):
    same = tmp_path / "same.csv"
    same.write_text("x,y,z,SED\n0,0,0,1\n1,0,0,3\n0,0,0,1\n0,1,0,3\n0,0,1,4\n")
    f = read_sed(same, length_unit="mm", sed_unit="MPa")
    assert f.n_points == 4 and "1 point(s) listed twice with the same SED merged" in " ".join(f.provenance.notes)
    np.testing.assert_array_equal(f.sed[0], np.array([1, 3, 3, 4]) * 1e6)
    differ = tmp_path / "element_nodal.csv"
    differ.write_text("x,y,z,SED\n0,0,0,1\n1,0,0,3\n0,0,0,2\n0,1,0,3\n0,0,1,4\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(differ)!r} lists the point (0, 0, 0) more than once with different SED (rows 0 and 2: "
            "1e+06 and 2e+06 J/m^3); 1 point(s) repeat. These look like unaveraged element-nodal values")):
        read_sed(differ, length_unit="mm", sed_unit="MPa")
