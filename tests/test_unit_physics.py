"""No plausible wrong numbers (issue 34, items 1 and 2): units from physics, and arrays that are what their values say.

Before: ``--sed-unit kPa`` on an MPa export ran to the end with an SED 1000 x too low, and a von Mises array passed
as ``--sed-column`` ran with an SED ~9 x too high; ``afferent info`` called both plausible. Now the stiffness
2 SED / eps:eps the SED implies (from the export's strain tensor or the gradient of its displacements) must be soft
tissue's, and an array that is a stress measure (by its name or its values) is not read as SED, unless confirmed.
"""

from __future__ import annotations

import json
import re
import warnings

import meshio
import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError, UnitError

from conftest import DATA_DIR, SAMPLE_DIR

BLOCK4 = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu"  # mm / MPa, point SED and displacements 'U'
TENSORS = SAMPLE_DIR / "block4" / "indent_0p88mm_tensors.vtu"  # cell S and E (MPa), no SED
COMSOL = DATA_DIR / "csv" / "comsol_spreadsheet.csv"  # solid.Ws (J/m^3) beside solid.mises (N/m^2)
CONFIRM_MODULUS = "; if it is intended, confirm it with accept='modulus' (a scene file: [scene] accept = [\"modulus\"])."


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


def test_kpa_declared_on_an_mpa_export_is_refused_naming_mpa_and_the_confirming_flag():
    field = _quiet(read_sed, BLOCK4, length_unit="mm", sed_unit="MPa")
    check = field.provenance.checks["implied_modulus"]
    assert check["verdict"] == "plausible" and 5e4 < check["modulus_pa"] < 2e5  # the sample's layers: 34..136 kPa
    assert check["strain_from"] == "displacement gradient of 'U' in the cells"
    with pytest.raises(UnitError, match=(
            r"^SED file '.*indent_0p88mm.vtu': the SED read with sed_unit='kPa' implies an elastic stiffness "
            r"2 SED / eps:eps of [0-9.]+ Pa \(the median over \d+ of its most loaded values at step 0, the strain from "
            r"the displacement gradient of 'U' in the cells\), far below soft tissue's 1 kPa..10 MPa: the SED is most "
            r"likely in MPa \(1e3 x kPa\), not a material that soft; declare sed_unit='MPa'" + re.escape(CONFIRM_MODULUS)
            + "$")):
        read_sed(BLOCK4, length_unit="mm", sed_unit="kPa")
    for unit, likely in (("Pa", "1e6 x Pa"), ("GPa", "1e-3 x GPa")):
        with pytest.raises(UnitError, match=f"most likely in MPa \\({likely}\\)"):
            read_sed(BLOCK4, length_unit="mm", sed_unit=unit)
    with pytest.warns(AfferentWarning, match=r"sed_unit='kPa' implies .*; declare sed_unit='MPa' \(confirmed: accept='modulus'\)"):
        confirmed = read_sed(BLOCK4, length_unit="mm", sed_unit="kPa", accept="modulus")
    np.testing.assert_allclose(confirmed.sed * 1e3, field.sed)
    assert confirmed.provenance.checks["implied_modulus"]["accepted"] is True
    with pytest.raises(ValueError, match=r"'accept' must name checks among .*'modulus', 'sed-column' and 'large-strain'; got 'modulos' "
                                         r"instead. Did you mean 'modulus'\?"):
        read_sed(BLOCK4, length_unit="mm", sed_unit="kPa", accept="modulos")


def test_afferent_run_with_the_kpa_slip_exits_2_in_one_line_and_records_the_modulus_when_right(tmp_path, capsys):
    argv = ["run", str(BLOCK4), "--grid", "y=2.35", "--length-unit", "mm", "--sed-unit", "kPa", "--params", "start",
            "--no-cache", "--no-plots", "-q", "-o", str(tmp_path / "out")]
    assert main(argv) == 2 and not (tmp_path / "out").exists()
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: SED file ") and err.count("\n") == 1
    assert ("the SED is most likely in MPa (1e3 x kPa), not a material that soft; declare --sed-unit MPa; if it is "
            "intended, confirm it with --accept modulus (a scene file: [scene] accept = [\"modulus\"]).") in err
    assert main(argv + ["--accept", "modulus"]) == 0, capsys.readouterr().err
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    assert record["scene"]["scene"]["accept"] == ["modulus"]
    assert record["field"]["checks"]["implied_modulus"]["accepted"] is True
    argv[argv.index("kPa")] = "MPa"
    assert main(argv[:-1] + [str(tmp_path / "right")]) == 0, capsys.readouterr().err
    modulus = json.loads((tmp_path / "right" / "run.json").read_text())["field"]["checks"]["implied_modulus"]
    assert modulus["verdict"] == "plausible" and 5e4 < modulus["modulus_pa"] < 2e5 and modulus["unit"] == "MPa"


#: Real exports of tests/data and sample_sed whose physics tells their unit: (file, read options, right unit, slip),
#: the unit declared by the key of the options. Their stiffness 2 SED / eps:eps lies in 23 kPa..0.7 MPa in their
#: right unit; the slip moves it out of soft tissue's band by 1e3 or more (docs/fe-export.md, "Units from physics").
REAL = [
    (SAMPLE_DIR / "block4" / "indent_0p88mm.vtu", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (TENSORS, {"length_unit": "mm", "sed_from": "exact", "preset": "abaqus"}, "stress_unit", "MPa", "kPa"),
    (DATA_DIR / "calculix" / "block_c3d8.frd", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "calculix" / "block_layers.frd", {"length_unit": "mm"}, "sed_unit", "MPa", "GPa"),
    (DATA_DIR / "dealii" / "indent_block.vtu", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "dolfinx" / "block.xdmf", {"length_unit": "mm"}, "sed_unit", "MPa", "Pa"),
    (DATA_DIR / "exodus" / "hex20_ioss.e", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "febio" / "block_hex8.xplt", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "freefem" / "block_point.vtk", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "kratos" / "vtk" / "Structure_0_1.vtk", {"length_unit": "m"}, "sed_unit", "Pa", "kPa"),
    (DATA_DIR / "med" / "block_tetra.med", {"length_unit": "m"}, "sed_unit", "Pa", "kPa"),
    (DATA_DIR / "mfem" / "block" / "block.pvd", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "ngsolve" / "block_tensors.vtu", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
    (DATA_DIR / "sfepy" / "block.vtk", {"length_unit": "mm"}, "sed_unit", "MPa", "kPa"),
]


@pytest.mark.parametrize("path, opts, key, right, slip", REAL, ids=[p.parent.name + "/" + p.name for p, *_ in REAL])
def test_each_real_export_passes_in_its_unit_and_refuses_a_slip_naming_it(path, opts, key, right, slip):
    field = _quiet(read_sed, str(path), **opts, **{key: right})
    check = field.provenance.checks["implied_modulus"]
    assert check["verdict"] == "plausible" and 2e4 < check["modulus_pa"] < 1e6, check
    with pytest.raises(UnitError, match=rf"read with {key}={slip!r} implies an elastic stiffness .* most likely in "
                                        rf"{right} "):
        _quiet(read_sed, str(path), **opts, **{key: slip})


def test_a_material_no_unit_makes_skin_is_a_warning_not_a_refusal(tmp_path):
    """Steel in Pa (2G ~ 1.6e11 Pa): no unit puts it in soft tissue's band, so it is not a unit slip."""
    path = _tensor_block(tmp_path, modulus=2.4e11, name="SED")
    with pytest.warns(AfferentWarning, match=r"implies an elastic stiffness 2 SED / eps:eps of 1\.\d+e\+11 Pa .*far "
                                             r"above soft tissue's 1 kPa..10 MPa, and no unit of Pa, kPa, MPa, GPa puts "
                                             r"it inside: a material stiffer than skin"):
        field = read_sed(path, length_unit="mm", sed_unit="Pa")
    assert field.provenance.checks["implied_modulus"]["verdict"] == "material"


def test_an_export_without_strain_or_displacements_is_recorded_as_not_checkable():
    field = _quiet(read_sed, SAMPLE_DIR / "block4" / "series_0p88mm" / "indent.pvd", length_unit="mm", sed_unit="kPa")
    check = field.provenance.checks["implied_modulus"]
    assert check["checkable"] is False and "no strain tensor" in check["note"]


def test_a_read_confirmed_once_is_not_served_from_the_cache_to_a_run_that_does_not_confirm(tmp_path, capsys,
                                                                                             monkeypatch):
    monkeypatch.setenv("AFFERENT_CACHE_DIR", str(tmp_path / "cache"))
    argv = ["run", str(BLOCK4), "--receptors", str(SAMPLE_DIR / "block4" / "receptors.csv"), "--length-unit", "mm",
            "--sed-unit", "kPa", "--params", "start", "--no-plots", "-q"]
    assert main(argv + ["--accept", "modulus", "-o", str(tmp_path / "a")]) == 0, capsys.readouterr().err
    assert any((tmp_path / "cache").rglob("*.npz"))  # the confirmed read was cached
    assert main(argv + ["-o", str(tmp_path / "b")]) == 2
    assert "--accept modulus" in capsys.readouterr().err


def test_a_von_mises_array_passed_as_sed_column_is_refused_by_its_name(tmp_path, capsys):
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(COMSOL)!r}: SED column 'solid.mises' is not a strain-energy density: 'solid.mises' is "
            "named like a von Mises stress; the file's SED array looks like 'solid.Ws' (sed_column='solid.Ws'); if it "
            "is intended, confirm it with accept='sed-column' (a scene file: [scene] accept = [\"sed-column\"]).")):
        read_sed(COMSOL, sed_column="solid.mises", sed_unit="Pa", on_nan="drop")
    argv = ["info", str(COMSOL), "--grid", "y=1", "--method", "nearest", "--sed-column", "solid.mises", "--sed-unit", "Pa",
            "--on-nan", "drop"]  # exit 0 before
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: SED file") and err.count("\n") == 1
    assert "looks like 'solid.Ws' (--sed-column solid.Ws); if it is intended, confirm it with --accept sed-column" in err
    with pytest.warns(AfferentWarning, match=r"named like a von Mises stress; .* \(confirmed: accept='sed-column'\)"):
        field = read_sed(COMSOL, sed_column="solid.mises", sed_unit="Pa", on_nan="drop", accept="sed-column")
    assert field.provenance.checks["sed_array_is_sed"]["accepted"] is True
    with pytest.raises(SEDFormatError, match="'Equivalent Stress' is named like an equivalent \\(von Mises\\) stress; "
                                             "the file's SED array looks like 'Strain Energy Density'"):
        read_sed(DATA_DIR / "csv" / "workbench_tab.txt", sed_column="Equivalent Stress")


@pytest.mark.parametrize("name, values, said", [
    ("SED", "mises", r"its values are the von Mises stress of the stress tensor 'S' \(median relative difference "),
    ("energy", "pressure", r"its values are 1000 x the pressure \(-1/3 trace\) of the stress tensor 'S'"),
    ("SED", "0.9 mises", r"its values are [0-9.]+ x 1/2 sigma:eps of the file's tensors at step 0, not 1/2 sigma:eps in "
                         r"some unit \(0.2..5 x a power of 1000\), as a stress measure is about 1/eps x it"),
])
def test_an_array_whose_values_are_a_stress_measure_is_refused_whatever_its_name(tmp_path, name, values, said):
    """The sample's real cell stress and strain (MPa) beside a scalar computed from them."""
    from afferent.io._find_arrays import find_tensors
    from afferent.io._unit_physics import _measures
    from afferent.io import read_raw
    from afferent.io._read_options import ReadOptions

    raw = read_raw(str(TENSORS))
    (_, s, _), _ = find_tensors(raw, ReadOptions(sed_from="exact", preset="vtk"))
    m = _measures(s[0])
    scalar = {"mises": m["the von Mises stress"], "pressure": 1e3 * m["the pressure (-1/3 trace)"],
              "0.9 mises": 0.9 * m["the von Mises stress"]}[values]
    mesh = meshio.read(TENSORS)
    mesh.cell_data[name] = [scalar]
    path = tmp_path / "b.vtu"
    meshio.write(path, mesh)
    with pytest.raises(SEDFormatError, match=rf"SED column {name!r} is not a strain-energy density: {said}"):
        read_sed(path, length_unit="mm", sed_unit="MPa", sed_column=name)


def test_a_true_sed_beside_the_tensors_passes_and_records_the_comparison(tmp_path):
    from afferent.strain_energy import sed_exact
    from afferent.io._find_arrays import find_tensors
    from afferent.io import read_raw
    from afferent.io._read_options import ReadOptions

    (_, s, _), (_, e, _) = find_tensors(read_raw(str(TENSORS)), ReadOptions(sed_from="exact", preset="abaqus"))
    mesh = meshio.read(TENSORS)
    mesh.cell_data["SED"] = [sed_exact(s[0], e[0])]
    meshio.write(tmp_path / "b.vtu", mesh)
    field = _quiet(read_sed, tmp_path / "b.vtu", length_unit="mm", sed_unit="MPa")
    check = field.provenance.checks["tensor_sed_vs_export_sed"]
    assert check["scale_consistent"] is True and abs(check["scale"] - 1) < 1e-6 and check["unit_factor"] == 1
    assert field.provenance.checks["implied_modulus"]["strain_from"] == "strain tensor 'E' (cell data)"


@pytest.mark.parametrize("name, what", [
    ("S.Mises", "a von Mises stress"), ("S_Mises", "a von Mises stress"), ("von_mises", "a von Mises stress"),
    ("SEQV", "a von Mises stress (ANSYS SEQV)"), ("S.Tresca", "a Tresca stress"), ("SINT", "a stress intensity (ANSYS SINT)"),
    ("S.Press", "a pressure"), ("PRESS", "a pressure"), ("pressure", "a pressure"), ("S.Max. Principal", "a principal stress"),
    ("S1", "a principal stress"), ("S3", "a principal stress"), ("solid.sp1", "a principal stress"),
    ("VMIS", "a von Mises stress"), ("PRIN_1", "a principal stress"), ("Equivalent Stress", "an equivalent (von Mises) stress"),
    ("effective stress", "an effective (von Mises) stress"),
])
def test_stress_measures_are_known_by_their_names(name, what):
    from afferent.io._unit_physics import stress_measure_named

    assert stress_measure_named(name) == what


def test_no_sed_name_is_taken_for_a_stress_measure():
    from afferent.io import _columns as C
    from afferent.io._unit_physics import stress_measure_named

    for name in (*C.SED_ALIASES, "SED", "SENER", "ESEDEN", "SEND ELASTIC", "solid.Ws", "ENER", "sed_cell", "sed_nodal",
                 "Strain Energy Density", "STRAIN_ENERGY", "internal energy density", "ENEL_NOEU", "U", "layer", "s"):
        assert stress_measure_named(name) is None, name


def test_afferent_info_says_which_unit_the_physics_implies(capsys):
    assert main(["info", str(BLOCK4)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"physics +an elastic stiffness 2 SED / eps:eps of 0\.0\d+ x the SED unit \(strain from the "
                     r"displacement gradient of 'U' in the cells\): soft tissue \(1 kPa..10 MPa\) in: MPa\n", out)
    assert main(["info", str(TENSORS)]) == 0
    assert re.search(r"physics +an elastic stiffness 2 SED / eps:eps of 0\.0\d+ x the stress unit \(strain from the "
                     r"strain tensor 'E' \(cell data\)\): soft tissue \(1 kPa..10 MPa\) in: MPa\n", capsys.readouterr().out)
    assert main(["info", str(DATA_DIR / "csv" / "units_row.csv")]) == 0
    assert "physics      cannot tell the SED unit: the export has no strain tensor" in capsys.readouterr().out


def test_a_scene_confirms_with_its_accept_key_and_a_wrong_name_is_refused(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    text = (f'[scene]\naccept = ["modulus"]\n[export]\nfile = "{BLOCK4}"\nlength_unit = "mm"\nsed_unit = "kPa"\n'
            f'[receptors]\nfile = "{SAMPLE_DIR / "block4" / "receptors.csv"}"\n[outputs]\nwant = ["sed_map"]\n')
    scene.write_text(text)
    assert main(["run", str(scene), "-q", "--no-cache", "-o", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    scene.write_text(text.replace('"modulus"', '"modulos"'))
    assert main(["run", str(scene), "-q", "--no-cache", "-o", str(tmp_path / "out2")]) == 2
    assert "'waveform-step', 'modulus', 'sed-column' and 'large-strain'; got 'modulos' instead" in capsys.readouterr().err


def _tensor_block(tmp_path, *, modulus: float, name: str):
    """A 2 x 2 x 1 mm hex block under a uniform strain, cell stress = modulus x strain (shear too) and an SED array."""
    from conftest import hex_box

    points, hexes = hex_box(4, 4, 2, size=(2.0, 2.0, 1.0))
    n = len(hexes)
    rng = np.random.default_rng(3)
    e = np.tile([0.0, -0.01, 0.005, 0.002, 0.0, 0.001], (n, 1)) * (1 + 0.1 * rng.random((n, 1)))
    s = 0.5 * modulus * e
    sed = 0.5 * (np.sum(s[:, :3] * e[:, :3], axis=1) + 2 * np.sum(s[:, 3:] * e[:, 3:], axis=1))
    path = tmp_path / "steel.vtu"
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], cell_data={"S": [s], "E": [e], name: [sed]}))
    return path
