"""Mistakes that used to pass (issue 22): receptors collapsing onto one cell in the wrong unit, observed
positions in the wrong unit, a series' negative SED reported for one step, ``afferent sample`` reading
before refusing its output."""

from __future__ import annotations

import json
import re
import warnings

import meshio
import numpy as np
import pandas as pd
import pytest

from afferent.cli import main
from afferent.exceptions import AfferentWarning, UnitError

from conftest import DATA_DIR, SAMPLE_DIR, hex_box


@pytest.fixture
def block(tmp_path):
    """A 4 x 3.1 x 4 mm hex block (coordinates in mm) with a smooth SED (MPa), receptors in m and in mm."""
    folder, vtu = _block(tmp_path)
    mm = pd.read_csv(folder / "R_mm.csv")
    (folder / "R_m.csv").write_text((mm / 1000).to_csv(index=False))  # positions in m, to be read as mm
    return folder, vtu


def test_receptors_in_the_wrong_unit_collapsing_onto_one_cell_are_refused_naming_the_unit_flag(block, capsys):
    from afferent import read_receptors, read_sed, sample_sed

    folder, vtu = block
    field = read_sed(vtu, length_unit="mm", sed_unit="MPa")
    ok = sample_sed(field, read_receptors(folder / "R_mm.csv", length_unit="mm"))
    assert np.unique(ok.values).size > 50
    with pytest.raises(UnitError, match=r"All 162 receptors of receptor file '.*R_m.csv' inside the field fall in one "
                                        r"cell or on one point \(\d+ field value\(s\) feed them all\)"):
        sample_sed(field, read_receptors(folder / "R_m.csv", length_unit="mm"), method="linear")
    with pytest.raises(UnitError, match="Declare the receptors' unit"):
        sample_sed(field, read_receptors(folder / "R_m.csv", length_unit="mm"), method="nearest")
    argv = ["run", str(vtu), "--receptors", str(folder / "R_m.csv"), "--length-unit", "mm", "--sed-unit", "MPa",
            "--params", "start", "--no-cache", "--no-plots", "-o", str(folder / "out")]
    assert main(argv) == 2 and not (folder / "out").exists()
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: All 162 receptors") and "(--receptor-unit, [receptors] length_unit)" in err
    assert main(argv[:4] + ["--receptor-unit", "m"] + argv[4:]) == 0, capsys.readouterr().err


def test_calibrate_refuses_observed_positions_whose_span_is_orders_from_the_afferents_either_way(tmp_path):
    from afferent import read_receptors, read_sed, sample_sed
    from afferent.calibration import calibrate
    from afferent.profiles import ObservedProfile

    folder, vtu = _block(tmp_path)
    sed = sample_sed(read_sed(vtu, length_unit="mm", sed_unit="MPa"), read_receptors(folder / "R_mm.csv",
                                                                                       length_unit="mm"))
    pos = np.linspace(0.0, 4.0, 12)
    for factor, ratio in ((1.0, "0.000"), (1e-6, "[0-9.]+e\\+03|[0-9]{3,}")):  # mm read as m; um read as mm
        obs = ObservedProfile(pos * factor, np.exp(-(pos - 2.0) ** 2), source="obs.csv")
        with pytest.raises(UnitError, match=rf"The afferent positions span [0-9.e-]+ m, the observed positions of "
                                            rf"'obs.csv' [0-9.e+-]+ m \(({ratio})"):
            calibrate(sed, obs, max_iter=1)
        with pytest.raises(UnitError, match="Declare the unit they are written in \\(--observed-unit; "):
            calibrate(sed, obs, max_iter=1)


def _block(tmp_path):
    points, hexes = hex_box(8, 4, 8, size=(4.0, 3.1, 4.0))
    x, y, z = points.T
    vtu = tmp_path / "b.vtu"
    meshio.write(vtu, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": 1e-4 * (1 + x + z) * (y / 3.1)}))
    X, Z = np.meshgrid(np.arange(0.22, 4.0, 0.44), np.arange(0.11, 4.0, 0.22), indexing="ij")
    pd.DataFrame({"x": X.ravel(), "y": 2.35, "z": Z.ravel()}).to_csv(tmp_path / "R_mm.csv", index=False)
    return tmp_path, vtu


def test_a_series_negative_sed_warning_counts_every_step_truthfully(tmp_path):
    from afferent import iter_sed

    points, hexes = hex_box(3, 3, 3, size=(1.0, 1.0, 1.0))
    files = []
    for k in range(5):
        sed = 1e-3 * (k + 1) * (1 + points[:, 0])
        sed[:2] = -1e-7  # a nodal-extrapolation artefact, within the tolerance, in every step
        if k == 2:
            sed[2] = -2e-7
        files.append(tmp_path / f"s{k}.vtu")
        meshio.write(files[-1], meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        steps = list(iter_sed([str(f) for f in files], length_unit="mm", sed_unit="MPa",
                              times=[0.0, 0.1, 0.2, 0.3, 0.4]))
    assert len(steps) == 5 and all(s.sed.min() == 0.0 for s in steps)
    neg = [str(w.message) for w in caught if issubclass(w.category, AfferentWarning) and "negative" in str(w.message)]
    assert len(neg) == 1, neg
    assert re.match(r"SED series '.*s0.vtu' and 4 more file\(s\): negative SED values in 5 of 5 step\(s\) \(step\(s\) "
                    r"0, 1, 2, 3, 4; counted from 0\): 11 of 320 values in total", neg[0]), neg[0]


def test_sample_refuses_an_existing_output_before_reading_the_export(tmp_path, capsys):
    bad = tmp_path / "broken.vtu"
    bad.write_text("<VTKFile>not a mesh")  # reading it would fail with another message
    (tmp_path / "R.csv").write_text("x,y,z\n0,0,0\n")
    out = tmp_path / "sed.csv"
    out.write_text("keep me\n")
    assert main(["sample", str(bad), "--receptors", str(tmp_path / "R.csv"), "--length-unit", "mm",
                 "--sed-unit", "MPa", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "exists" in err and "broken.vtu" not in err, err
    assert out.read_text() == "keep me\n"


# ------------------------------------------------------------------------------------------------------------
# Issue 34: no plausible wrong numbers. Each mistake of the tester's table ends in exit 2 with one sentence naming
# its likely cause and the confirmation (--accept CHECK, [scene] accept; --shear for the shear convention), or
# in a result that is right.
B4 = SAMPLE_DIR / "block4"
KRATOS = DATA_DIR / "kratos" / "vtk"


def _run(tmp_path, export, *extra, receptors=None, out="out"):
    argv = ["run", *map(str, export if isinstance(export, (list, tuple)) else [export]),
            "--receptors", str(receptors or B4 / "receptors.csv"), "--params", "start", "--no-cache", "--no-plots",
            "-o", str(tmp_path / out), *map(str, extra)]
    return main(argv)


def _moved(tmp_path, name, change):
    df = pd.read_csv(B4 / "receptors.csv")
    change(df)
    df.to_csv(tmp_path / name, index=False)
    return tmp_path / name


def test_receptor_heights_given_as_depths_below_the_surface_are_refused_naming_the_cause(tmp_path, capsys):
    """Row 1: y = depth below the top (0.68 mm) for the tips' height (2.45 mm): sampled in the subcutis (here 294
    instead of 1192 Pa at the most loaded receptor; the tester's export: 866 instead of 1843), exit 0. Now refused,
    naming the materials and the likely cause."""
    depth = _moved(tmp_path, "depth.csv", lambda df: df.__setitem__("y", 3.13 - df["y"]))
    mm = ("--length-unit", "mm", "--sed-unit", "MPa")
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, receptors=depth) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: 119 of the 119 receptors of receptor file {str(depth)!r} lie more than "
                          "0.2 mm from the epidermis/dermis interface (materials 1 above and 2 below in cell array "
                          "'layer'), where RA-I receptors sit: 119 in material 3, 1.67 mm from the interface at the "
                          "median; the likely cause y given as a depth below the surface (the top of the block is at "
                          "y = 3.13 mm; the heights are 3.13 mm minus the depths);"), err
    assert err.endswith("confirm it with --accept placement (a scene file: [scene] accept = [\"placement\"]).\n")
    assert not (tmp_path / "out").exists()
    # the tips where they are: 1192 Pa at the most loaded receptor, and run.json says which materials they touch
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, out="right") == 0, capsys.readouterr().err
    record = json.loads((tmp_path / "right" / "run.json").read_text())
    assert record["receptor_sites"]["materials"] == {"1/2": 119} and record["receptor_sites"]["n_away"] == 0
    sed = pd.read_csv(tmp_path / "right" / "sed_map.csv")["sed_pa"]
    assert sed.max() == pytest.approx(1192, rel=1e-3)
    # deliberately in the subcutis: confirmed, warned and recorded
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, "--accept", "placement", receptors=depth, out="ok") == 0
    assert "(confirmed: --accept placement)." in capsys.readouterr().err
    assert pd.read_csv(tmp_path / "ok" / "sed_map.csv")["sed_pa"].max() < 0.3 * sed.max()  # the subcutis


def test_a_cached_sampling_of_misplaced_receptors_is_judged_again(tmp_path, capsys, monkeypatch):
    """Row 1 through the sampled-SED cache: an entry written by a run that confirmed the placement does not let
    a later run without the confirmation through (the placement record is kept with the entry)."""
    monkeypatch.setenv("AFFERENT_CACHE_DIR", str(tmp_path / "cache"))
    depth = _moved(tmp_path, "depth.csv", lambda df: df.__setitem__("y", 3.13 - df["y"]))
    argv = ["run", str(B4 / "indent_0p88mm.vtu"), "--receptors", str(depth), "--length-unit", "mm", "--sed-unit",
            "MPa", "--params", "start", "--no-plots"]
    assert main(argv + ["--accept", "placement", "-o", str(tmp_path / "first")]) == 0
    assert json.loads((tmp_path / "first" / "run.json").read_text())["cache"]["written"]
    capsys.readouterr()
    assert main(argv + ["-o", str(tmp_path / "second")]) == 2
    assert "lie more than 0.2 mm from the epidermis/dermis interface" in capsys.readouterr().err
    assert main(argv + ["--accept", "placement", "-o", str(tmp_path / "third")]) == 0
    assert json.loads((tmp_path / "third" / "run.json").read_text())["cache"]["hit"]


def test_swapped_receptor_axes_are_named_inside_and_outside_the_field(tmp_path, capsys):
    """Row 1: y and z swapped. Receptors that fall outside: the refusal names the swap that puts them all inside;
    receptors that stay inside (z < 3 mm): the placement refusal names it as the likely cause."""
    mm = ("--length-unit", "mm", "--sed-unit", "MPa")
    out = _moved(tmp_path, "out.csv", lambda df: df.__setitem__(["y", "z"], df[["z", "y"]].to_numpy()))
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, receptors=out) == 2
    err = capsys.readouterr().err
    assert ("lie outside the SED field (first: receptor '15' at [0.00068, 0.00332, 0.00245] m; field bounds x [0, "
            "0.004] y [0, 0.00313] z [0, 0.004] m). All 119 receptors fit inside the field's bounds with y and z "
            "swapped (the file's y column holds z): check the receptor file. Pass --on-outside nan") in err, err
    df = pd.read_csv(B4 / "receptors.csv")
    inside = tmp_path / "inside.csv"
    df[df["z"] < 3.0].rename(columns={"y": "z", "z": "y"}).to_csv(inside, index=False)
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, receptors=inside) == 2
    err = capsys.readouterr().err
    assert "lie more than 0.2 mm from the epidermis/dermis interface" in err
    assert "the likely cause y and z swapped (the file's y column holds z); place them at the interface" in err, err


def test_receptors_in_the_lower_half_of_a_block_without_materials_are_warned_about(tmp_path, capsys):
    """Row 1 without material arrays (the 0.88 mm sample without its 'layer' array): a warning naming the likely
    cause; the COMSOL table of the same case, which covers y >= 1.82 mm only: outside, the cause named."""
    depth = _moved(tmp_path, "depth.csv", lambda df: df.__setitem__("y", 3.13 - df["y"]))
    mesh = meshio.read(B4 / "indent_0p88mm.vtu")
    del mesh.cell_data["layer"]
    bare = tmp_path / "bare.vtu"
    mesh.write(bare)
    mm = ("--length-unit", "mm", "--sed-unit", "MPa")
    assert _run(tmp_path, bare, *mm, receptors=depth) == 0
    err = capsys.readouterr().err
    assert (f"afferent: warning: The receptors of receptor file {str(depth)!r} sit in the lower half of the block, "
            "2.45 mm below its top (median y = 0.68 mm of 0 .. 3.13 mm; the skin surface at the top), far below where "
            "RA-I receptors sit (the epidermis/dermis interface, under a millimetre beneath the surface): the likely "
            "cause y given as a depth below the surface (the top of the block is at y = 3.13 mm; the heights are "
            "3.13 mm minus the depths).") in err, err
    assert _run(tmp_path, bare, *mm, out="right") == 0 and "lower half" not in capsys.readouterr().err
    inner = tmp_path / "inner.csv"
    df = pd.read_csv(depth)
    df[df["x"].between(0.7, 3.3) & df["z"].between(0.7, 3.3)].to_csv(inner, index=False)
    assert _run(tmp_path, B4 / "indent_0p88mm_comsol.csv", "--receptor-unit", "mm", receptors=inner, out="c") == 2
    assert ("All 55 receptors fit inside the field's bounds with y given as a depth below the surface (the top of the "
            "block is at y = 3.13 mm; the heights are 3.13 mm minus the depths): check the receptor file."
            ) in capsys.readouterr().err


def test_a_unit_key_without_its_unit_is_never_answered_with_a_key_of_another_unit(tmp_path, capsys):
    """Row 2: d_ref = 0.5 got "Did you mean 'd_ref_m'?"; following it ran at d_ref = 0.5 m: 0 spikes, exit 0."""
    from afferent.scene import SceneError, load_scene

    text = (f'[export]\nfile = "{B4 / "series_0p88mm" / "indent.pvd"}"\nlength_unit = "mm"\nsed_unit = "MPa"\n'
            f'[receptors]\nfile = "{B4 / "receptors.csv"}"\n[stimulus]\nwaveform = "ramp"\nreference_step = -1\n'
            'depth_mm = 0.5\nhold_s = 0.2\nD_REF\n[spikes]\nengine = "exact"\n[outputs]\nwant = ["spikes"]\n')
    scene = tmp_path / "s.toml"
    scene.write_text(text.replace("D_REF", "d_ref = 0.5"))
    with pytest.raises(SceneError) as caught:
        load_scene(scene)
    said = str(caught.value)
    assert "Did you mean 'd_ref_m'" not in said
    assert said.endswith("'d_ref' is a length, whose key names the unit, one of d_ref_m, d_ref_mm, d_ref_um: "
                         "d_ref_mm = 0.5 is 0.5 mm, d_ref_m = 0.5 is 0.5 m."), said
    scene.write_text(text.replace("D_REF", "d_ref_cm = 0.05"))
    with pytest.raises(SceneError, match=re.escape("Did you mean d_ref_mm = 0.5 (0.05 cm)?")):
        load_scene(scene)
    scene.write_text(text.replace("D_REF", "d_ref_m = 0.5"))  # the old suggestion followed: 1000 x too deep
    assert main(["run", str(scene), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == ("afferent: error: d_ref (500 mm) is 1000 x the waveform's deepest point (0.5 mm): the SED of the "
                   "export is scaled by (d / d_ref)^2 <= 1e-06, so the afferents fall silent, the likely cause d_ref "
                   "written in the wrong unit (a value in mm under a key in m); 500 mm read in another unit is 0.5 mm: "
                   "d_ref_mm = 0.5 (--d-ref-mm 0.5); give the depth at which the export was solved; if it is intended, "
                   "confirm it with --accept d-ref (a scene file: [scene] accept = [\"d-ref\"]).\n"), err
    scene.write_text(text.replace("D_REF", "d_ref_mm = 0.5"))
    assert main(["run", str(scene), "-o", str(tmp_path / "right")]) == 0, capsys.readouterr().err
    assert len(pd.read_csv(tmp_path / "right" / "spikes.csv")) > 0


def test_a_reference_step_that_is_not_the_deepest_is_refused_naming_the_step(tmp_path, capsys):
    """Row 3: --reference-step 1 (the 0.1 mm step of the 0..0.5 mm series) with --d-ref-mm 0.5: every afferent
    silent, the warning blaming the drive. Now refused, naming the deepest step."""
    series = B4 / "series_0p88mm" / "indent.pvd"
    argv = ("--length-unit", "mm", "--sed-unit", "MPa", "--waveform", "ramp:0.5,5,0.2", "--d-ref-mm", "0.5",
            "--spikes", "--engine", "exact")
    assert _run(tmp_path, series, *argv, "--reference-step", "1") == 2
    err = capsys.readouterr().err
    assert err == ("afferent: error: The reference step 1 (t = 0.02 s) is not the deepest step of the export's 6-step "
                   "series: step 5 (t = 0.1 s) has 50.3 x its SED (L2 over the receptors); scaled by (d / d_ref)^2 with "
                   "d_ref = 0.5 mm, a shallower step gives too little SED (afferents fall silent), the likely cause a "
                   "step counted from 1 or from the other end; give the deepest step, reference_step = 5 or -1 "
                   "(--reference-step -1); if it is intended, confirm it with --accept reference-step (a scene file: "
                   "[scene] accept = [\"reference-step\"]).\n"), err
    assert _run(tmp_path, series, *argv, "--reference-step", "0") == 2
    assert "The reference step 0 (t = 0 s) is not the deepest step of the export's 6-step series: it has no SED, " \
           "step 5 (t = 0.1 s) has;" in capsys.readouterr().err
    assert _run(tmp_path, series, *argv, "--reference-step", "-1", out="right") == 0
    assert len(pd.read_csv(tmp_path / "right" / "spikes.csv")) > 0


@pytest.mark.parametrize("export, preset, columns", [
    (DATA_DIR / "sfepy" / "block.vtk", "vtk", None),
    (B4 / "indent_0p88mm_abaqus_elements.csv", "calculix-frd", (1.1, 2.9)),
])
def test_a_shear_preset_the_data_contradict_is_refused_naming_the_presets_that_fit(tmp_path, capsys, export, preset,
                                                                                   columns):
    """Row 4: an SfePy file read with 'vtk', an Abaqus element table with 'calculix-frd': a good warning, but the SED
    +34 % at the median (up to 73 %), exit 0. Now exit 2 naming the presets with engineering shear; --shear confirms."""
    if columns is None:
        receptors = tmp_path / "r.csv"
        receptors.write_text("x,y,z\n1,0.9,0.5\n0.5,0.9,0.5\n1.5,0.9,0.5\n")
    else:
        df = pd.read_csv(B4 / "receptors.csv")
        receptors = tmp_path / "r.csv"
        df[df["x"].between(*columns) & df["z"].between(*columns)].to_csv(receptors, index=False)
    argv = ("--length-unit", "mm", "--stress-unit", "MPa", "--sed-from", "exact", "--preset", preset)
    assert _run(tmp_path, export, *argv, receptors=receptors) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: SED file {str(export)!r}: with the shear strain read as tensor (--preset "
                          f"{preset}), the shear components of stress and strain are "), err
    assert ("the file's shear strain looks engineering, and read as tensor the SED from its tensors is wrong (its shear "
            "terms doubled), the likely cause the preset of another tool; give the preset of the tool that wrote it, one "
            "of 'abaqus', 'ansys', 'sfepy', 'kratos' (engineering shear), or confirm the tensor convention with --shear "
            "tensor.") in err, err
    assert _run(tmp_path, export, *argv, "--shear", "tensor", receptors=receptors, out="confirmed") == 0
    assert "afferent: warning: " in capsys.readouterr().err


def test_spiking_on_step_numbers_is_refused_and_a_time_s_column_never_holds_them(tmp_path, capsys):
    """Row 5: a Kratos series without times: step numbers under 'time_s', no note; spiking read them as seconds.
    And the false warning of issue 37: with a waveform the export's step times are not used."""
    series = [KRATOS / "Structure_0_1.vtk", KRATOS / "Structure_0_2.vtk"]
    receptors = tmp_path / "r.csv"
    receptors.write_text("id,x,y,z\n1,2,2,1.9\n2,1.5,2,1.9\n3,2.5,2,1.9\n")
    units = ("--receptor-unit", "mm", "--length-unit", "m", "--sed-unit", "Pa", "--results-format", "csv")
    assert _run(tmp_path, series, *units, "--spikes", receptors=receptors) == 2
    assert capsys.readouterr().err == (
        "afferent: error: The export states no step times: its 2 steps are numbered 0 .. 1, and spiking would read "
        "those numbers as seconds (1 s per step, 1 s in all); give the steps' times with --times T0,T1,... (in s; "
        "[export] times in a scene file); if it is intended, confirm it with --accept step-times (a scene file: "
        "[scene] accept = [\"step-times\"]).\n")
    assert _run(tmp_path, series, *units, receptors=receptors, out="map") == 0
    capsys.readouterr()
    for name in ("sed_map.csv", "receptors.csv", "afferents.csv", "profiles.csv"):
        header = (tmp_path / "map" / name).read_text().splitlines()[0].split(",")
        assert "step" in header and "time_s" not in header, (name, header)
    assert _run(tmp_path, series, *units, "--spikes", "--times", "0,0.1", receptors=receptors, out="timed") == 0
    assert "time_s" in (tmp_path / "timed" / "sed_map.csv").read_text().splitlines()[0]
    assert _run(tmp_path, series, *units, "--spikes", "--waveform", "ramp:0.5,5,0.1", "--d-ref-mm", "0.5",
                "--reference-step", "-1", receptors=receptors, out="driven") == 0
    assert "step times" not in capsys.readouterr().err


def test_a_vibration_sampled_coarser_than_a_twentieth_of_its_period_is_refused_and_the_default_fits(tmp_path, capsys):
    """Row 6: 80 Hz with the default 1 ms step: the deepest sampled point of the last cycle 0.984 x the first's (SED),
    unflagged. Now the default step is 1/20 of the period (every peak sampled) and a coarser one is refused."""
    argv = ("--length-unit", "mm", "--sed-unit", "MPa", "--waveform", "sine:80,0.25,0.0375", "--d-ref-mm", "0.5")
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *argv) == 0, capsys.readouterr().err
    capsys.readouterr()
    w = pd.read_csv(tmp_path / "out" / "waveform.csv")
    assert np.diff(w["time_s"]).max() == pytest.approx(0.625e-3, rel=1e-9)
    peaks = [w["depth_m"][(w["time_s"] >= k / 80) & (w["time_s"] < (k + 1) / 80)].max() for k in range(3)]
    np.testing.assert_allclose(peaks, 0.5e-3, rtol=1e-9)  # each cycle's deepest sampled point is the peak
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *argv, "--waveform-dt-ms", "1", out="coarse") == 2
    assert capsys.readouterr().err == (
        "afferent: error: --waveform-dt-ms (1 ms) samples the 80 Hz sine 12.5 times a period, fewer than 20: its peaks "
        "fall between samples at another phase each cycle, so the deepest sampled depth (and the SED, as its square) "
        "changes from cycle to cycle, an artefact of the sampling; set --waveform-dt-ms to 0.625 or less (1/20 of the "
        "12.5 ms period; left out, it is chosen so); if it is intended, confirm it with --accept waveform-step (a scene "
        "file: [scene] accept = [\"waveform-step\"]).\n")


def test_rate_keys_that_cannot_act_are_named_not_ignored(tmp_path, capsys):
    """Row 7: spikes.gain_ms swept with SA-I afferents on the static export: 38/38/38 spikes, the key without effect
    (a constant current has no rate); with the RA-I class's static input it has none either."""
    mm = ("--length-unit", "mm", "--sed-unit", "MPa", "--spikes")
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, "--class", "SA-I", "--gain-s", "0.1") == 2
    assert capsys.readouterr().err == (
        "afferent: error: --gain-s has no effect: the export has one step and no waveform drives it, so the current is "
        "constant and the slowly-adapting input's rate term is 0 (every value of it gives the same spikes); give a "
        "waveform (--waveform) or leave --gain-s out.\n")
    assert _run(tmp_path, B4 / "indent_0p88mm.vtu", *mm, "--gain-s", "0.1") == 2
    assert capsys.readouterr().err == (
        "afferent: error: --gain-s applies to input = 'rate-sensitive' or 'slowly-adapting', not 'static' (the RA-I "
        "class's input), which has no rate term: every value of it gives the same spikes; set --input or leave "
        "--gain-s out.\n")
    scene = tmp_path / "sa1.toml"  # the sweep's scene: the key named with its line
    scene.write_text(f'[afferent]\nclass = "SA-I"\n[export]\nfile = "{B4 / "indent_0p88mm.vtu"}"\nlength_unit = "mm"\n'
                     f'sed_unit = "MPa"\n[receptors]\nfile = "{B4 / "receptors.csv"}"\n[spikes]\ngain_ms = 100\n'
                     '[outputs]\nwant = ["spikes"]\n')
    assert main(["run", str(scene), "-o", str(tmp_path / "scene")]) == 2
    assert capsys.readouterr().err.startswith(f"afferent: error: Scene file {str(scene)!r}, line 10: [spikes] 'gain_ms' "
                                              "has no effect: the export has one step and no waveform drives it")
