"""The static pipeline end to end on a small field built in code, and `afferent run`."""

from __future__ import annotations

import json
import re

import meshio
import numpy as np
import pandas as pd
import pytest

from afferent import read_sed, sample_sed
from afferent.sampling import PLACEMENTS
from afferent.cli import main
from afferent.pipeline import run_pipeline
from afferent.profiles import ObservedProfile
from afferent.receptors import ReceptorLayout
from afferent.synthesis import make_branching
from afferent.transduction import STUDY_PARAMS, sigmoid

from conftest import hex_box, write_bump

@pytest.fixture
def bump(tmp_path):
    """A 4 x 3.1 x 4 mm hex block with a Gaussian SED bump (MPa) centred at x = z = 2 mm, and a papilla grid."""
    vtu, receptors, xs, zs = write_bump(tmp_path, 16)
    return vtu, receptors, xs.size * zs.size, len(xs), len(zs)


def test_pipeline_conserves_current_and_matches_the_sigmoid(bump):
    vtu, receptors, n, nx, nz = bump
    field = read_sed(vtu, length_unit="mm", sed_unit="MPa")
    from afferent.receptors import read_receptors

    layout = read_receptors(receptors, length_unit="mm")
    params = STUDY_PARAMS["start"]
    res = run_pipeline(field, layout, params)
    np.testing.assert_allclose(res.current.values, sigmoid(res.sed.values, params), rtol=1e-15)
    assert res.afferent.n_afferents == nx
    # synthesis conserves the total current (longitudinal sections partition the receptors)
    np.testing.assert_allclose(res.afferent.values.sum(), res.current.values.sum(), rtol=1e-13)
    cross = run_pipeline(field, layout, params, synthesis="cross")
    assert cross.afferent.n_afferents == nz
    np.testing.assert_allclose(cross.afferent.values.sum(), res.current.values.sum(), rtol=1e-13)
    assert set(res.timings) == {"sampling", "transduction", "synthesis"}


def test_the_fit_finds_the_parameters_that_made_the_profile_and_rejects_others(bump):
    """A profile made by the model at known parameters (then put in arbitrary recording units by an
    affine map, which min-max normalisation removes) fits perfectly at those parameters and
    measurably worse at others: the comparison discriminates, it does not just echo the model."""
    from afferent.receptors import read_receptors
    from afferent.transduction import SigmoidParams

    vtu, receptors, *_ = bump
    field = read_sed(vtu, length_unit="mm", sed_unit="MPa")
    layout = read_receptors(receptors, length_unit="mm")
    true = SigmoidParams(alpha=2.46e-8, gamma=2e-2, lambda_=120.0)  # sensitive over the bump's 0-190 Pa
    made = run_pipeline(field, layout, true)
    observed = ObservedProfile(made.afferent.positions, 3.0 * made.afferent.values[-1] / true.alpha + 7.0)
    at_truth = run_pipeline(field, layout, true, observed=observed).fit
    assert at_truth.ssd == pytest.approx(0.0, abs=1e-20) and at_truth.r2 == pytest.approx(1.0, abs=1e-12)
    for other in (STUDY_PARAMS["start"], SigmoidParams(alpha=2.46e-8, gamma=2e-2, lambda_=20.0)):
        fit = run_pipeline(field, layout, other, observed=observed).fit
        assert fit.ssd > 1e-3 and fit.r2 < at_truth.r2, (other, fit.ssd)


def test_make_branching_specs():
    layout = ReceptorLayout(np.array([[0, 0, 0], [0, 0, 2.2e-4], [4.4e-4, 0, 0], [4.4e-4, 0, 2.2e-4]]))
    assert make_branching("longitudinal", layout).n_afferents == 2
    assert make_branching("cross", layout).kind == "cross"
    assert make_branching("random:2", layout, rng=1).kind == "random"
    with pytest.raises(ValueError, match=re.escape("Invalid value for the 'synthesis' parameter. Allowed values are 'longitudinal', 'cross', 'map:' and 'random:', but got 'radial' instead.")):
        make_branching("radial", layout)
    with pytest.raises(ValueError, match=re.escape("'synthesis' random:N needs a whole number of receptors per afferent; got 'x' instead.")):
        make_branching("random:x", layout)


def test_names_moved_to_their_stages_still_import_from_pipeline():
    """make_branching, parse_synthesis, SYNTHESES (synthesis), apply_waveform (stimulus), INPUTS (spiking) live in their
    stage modules; afferent.pipeline hands out the same objects, as before the move."""
    import afferent.pipeline as pipeline
    from afferent import spiking, stimulus, synthesis
    from afferent.pipeline import apply_waveform, make_branching as moved  # noqa: F401 (the import is the test)

    assert moved is synthesis.make_branching and apply_waveform is stimulus.apply_waveform
    assert pipeline.parse_synthesis is synthesis.parse_synthesis and pipeline.SYNTHESES is synthesis.SYNTHESES
    assert pipeline.INPUTS is spiking.INPUTS
    with pytest.raises(AttributeError, match="module 'afferent.pipeline' has no attribute 'write_pipeline_outputs'"):
        pipeline.write_pipeline_outputs  # noqa: B018


def test_run_cli_writes_every_output(capsys, tmp_path, bump):
    vtu, receptors, n, nx, nz = bump
    obs = tmp_path / "obs.csv"
    pos = np.linspace(0, 4, 11)
    pd.DataFrame({"position": pos, "response": np.exp(-((pos - 2) ** 2))}).to_csv(obs, index=False)
    out = tmp_path / "out"
    argv = ["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
            "--params", "start", "--observed", str(obs), "--results-format", "csv", "-o", str(out)]
    assert main(argv) == 2 and not out.exists()  # the observed positions' unit is never guessed
    assert capsys.readouterr().err == ("afferent: error: --observed needs --observed-unit, the length unit of the observed "
                                       "positions (e.g. mm); afferent never guesses a unit.\n")
    code = main(argv + ["--observed-unit", "mm"])
    assert code == 0, capsys.readouterr().err
    names = {p.name for p in out.iterdir()}
    assert names == {".afferent-output.json", "receptors.csv", "afferents.csv", "fit.csv", "profile_fit.csv", "receptors.vtu", "run.json",
                     "sed_map.png", "profiles_x.png", "profiles_z.png", "fit.png", "sed_map.csv", "profiles.csv"}
    rec = pd.read_csv(out / "receptors.csv")
    assert list(rec.columns) == ["receptor", "x_m", "y_m", "z_m", "longitudinal", "cross", "time_s", "sed_pa", "current_a"]
    assert len(rec) == n
    aff = pd.read_csv(out / "afferents.csv")
    assert list(aff.columns) == ["afferent", "position_m", "time_s", "current_a"] and len(aff) == nx
    np.testing.assert_allclose(aff["current_a"].sum(), rec["current_a"].sum(), rtol=1e-12)
    record = json.loads((out / "run.json").read_text())
    assert record["transduction"]["alpha_a"] == STUDY_PARAMS["start"].alpha
    assert record["field"]["units"]["sed"] == "MPa" and len(record["inputs"]) == 3
    assert (record["field"]["location"], record["field"]["location_source"]) == ("point", "only point data")
    assert (record["sampling"]["method"], record["sampling"]["placement"]) == ("linear", PLACEMENTS[("point", "shape")])
    vtk = meshio.read(out / "receptors.vtu")
    assert vtk.points.shape == (n, 3) and "sed_pa" in vtk.point_data
    # a second run into the same folder refuses, and leaves it intact
    code = main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and f"Output folder {str(out)!r} already exists" in err
    assert {p.name for p in out.iterdir()} == names


def test_run_cli_requires_parameters(capsys, tmp_path, bump):
    vtu, receptors, *_ = bump
    code = main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--alpha", "1e-8", "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2
    assert err == ("afferent: error: Transduction parameters --gamma, --lambda are missing: give --alpha A --gamma G "
                   "--lambda L (A, 1/Pa, Pa) or --params one of start, longitudinal, cross.\n")
    assert not (tmp_path / "o").exists() and not list(tmp_path.glob(".o.*"))


def test_run_cli_spikes_with_a_ramp_and_hold(capsys, tmp_path, bump):
    """--waveform + --spikes: rate-sensitive input fires at onset and offset, not in the hold."""
    vtu, receptors, n, nx, nz = bump
    out = tmp_path / "ramp"
    code = main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "--waveform", "ramp:0.5,5,0.5", "--d-ref-mm", "0.5", "--spikes",
                 "--input", "rate-sensitive", "--gain-s", "2", "--no-plots", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    spikes = pd.read_csv(out / "spikes.csv")
    assert list(spikes.columns) == ["afferent", "spike_time_s"] and len(spikes) > 0
    t = spikes["spike_time_s"].to_numpy()
    # ramp 0-0.1 s, hold to 0.6 s, release 0.6-0.7 s
    assert np.any(t < 0.12) and np.any((t > 0.6) & (t < 0.75)) and not np.any((t > 0.2) & (t < 0.55))
    summary = pd.read_csv(out / "spike_summary.csv")
    assert {"afferent", "position_m", "n_spikes", "rate_hz", "first_spike_latency_s"} <= set(summary.columns)
    record = json.loads((out / "run.json").read_text())
    assert record["spikes"]["input"] == "rate-sensitive" and record["stimulus"]["waveform"]["kind"] == "ramp-and-hold"


def test_run_cli_spikes_on_a_static_export(capsys, tmp_path, bump):
    vtu, receptors, *_ = bump
    out = tmp_path / "static"
    code = main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "--spikes", "--no-plots", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    record = json.loads((out / "run.json").read_text())
    assert record["spikes"]["duration_s"] == pytest.approx(1.0) and record["spikes"]["input"] == "static"


def test_run_cli_spike_option_errors(capsys, tmp_path, bump):
    vtu, receptors, *_ = bump
    base = ["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start"]
    code = main(base + ["--waveform", "ramp:0.5,5", "--d-ref-mm", "0.5", "-o", str(tmp_path / "a")])
    assert code == 2 and "--waveform ramp: needs 3 comma-separated values; got 2 in 'ramp:0.5,5' instead." in capsys.readouterr().err
    code = main(base + ["--waveform", "ramp:0.5,5,1", "-o", str(tmp_path / "b")])
    assert code == 2 and "--waveform needs --d-ref-mm" in capsys.readouterr().err
    code = main(base + ["--spikes", "--input", "rate-sensitive", "--waveform", "ramp:0.5,5,1", "--d-ref-mm", "0.5",
                        "-o", str(tmp_path / "c")])
    assert code == 2 and "--input rate-sensitive needs --gain-s (s): how much" in capsys.readouterr().err
    assert not any(p.name.startswith(("a", "b", "c", ".")) for p in tmp_path.iterdir() if p.name not in ("bump.vtu", "R.csv"))


def test_run_cli_waveform_on_a_series_needs_the_reference_step(capsys, tmp_path):
    from conftest import SAMPLE_DIR

    series = SAMPLE_DIR / "block4" / "series_0p88mm" / "indent.pvd"
    receptors = SAMPLE_DIR / "block4" / "receptors.csv"
    if not series.is_file():
        pytest.skip("bundled loading series not generated")
    argv = ["run", str(series), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
            "--params", "start", "--waveform", "ramp:0.5,5,0.1", "--d-ref-mm", "0.5", "--no-plots"]
    assert main(argv + ["-o", str(tmp_path / "a")]) == 2 and not (tmp_path / "a").exists()
    assert capsys.readouterr().err == (
        "afferent: error: A waveform scales one static FE step by (d / d_ref)^2, but the export has 6 steps "
        "(t = 0 .. 0.1 s); say which step was solved at d_ref with --reference-step K (-1: the last, usually the "
        "deepest). A loading series can also be used as it is, without a waveform.\n")
    out = tmp_path / "b"
    code = main(argv + ["--reference-step", "-1", "--series-depths-mm", "0,0.1,0.2,0.3,0.4,0.5", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert len([line for line in err.splitlines() if line.startswith("afferent: warning: The d^2 scaling of export step 5")]) == 1
    scaling = json.loads((out / "run.json").read_text())["stimulus"]["scaling"]
    assert scaling["reference_step"] == 5 and scaling["measured"]["rel_error_l2"][1] > 0.5


def test_run_json_records_cell_data_and_its_placement(capsys, tmp_path, bump):
    _, receptors, *_ = bump
    points, hexes = hex_box(16, 4, 16, size=(4.0, 3.1, 4.0))
    vtu = tmp_path / "cells.vtu"
    meshio.write(vtu, meshio.Mesh(points, [("hexahedron", hexes)], cell_data={"SED": [np.full(len(hexes), 1e-4)]}))
    for method, placement in (("linear", PLACEMENTS[("cell", "shape")]),
                              ("nearest", "cell value of the containing cell")):
        out = tmp_path / method
        code = main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                     "--params", "start", "--method", method, "--no-plots", "-o", str(out)])
        assert code == 0, capsys.readouterr().err
        record = json.loads((out / "run.json").read_text())
        assert (record["field"]["location"], record["field"]["location_source"]) == ("cell", "only cell data")
        assert (record["sampling"]["method"], record["sampling"]["placement"]) == (method, placement)


def test_waveform_runs_show_the_peak_step_in_both_routes(capsys, tmp_path):
    """A ramp-and-hold-and-release ends at SED 0: figures, receptors.vtu, the fit and the record
    show the step of the largest afferent current in 'afferent run EXPORT' and in a scene alike
    (was the last step - a one-colour map and flat profiles - in the first)."""
    from conftest import SAMPLE_DIR

    from afferent.scene import load_scene, run_scene

    export, receptors = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu", SAMPLE_DIR / "block4" / "receptors.csv"
    if not export.is_file():
        pytest.skip("bundled sample not generated")
    out = tmp_path / "cli"
    code = main(["run", str(export), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "--waveform", "ramp:0.5,5,0.2", "--d-ref-mm", "0.5", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    cli_step = json.loads((out / "run.json").read_text())["profile_step"]
    vtu = meshio.read(out / "receptors.vtu")
    assert vtu.point_data["sed_pa"].max() > 0  # not the released last step
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(f"""
[export]
file = {str(export)!r}
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = {str(receptors)!r}
[transduction]
params = "start"
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5
hold_s = 0.2
[outputs]
want = ["profiles", "vtu"]
""")
    res = run_scene(load_scene(scene_file).with_output(tmp_path / "scene"), use_cache=False)
    assert res.record["profile_step"] == cli_step
    assert cli_step["index"] > 0 and cli_step["index"] < cli_step["n_steps"] - 1 and cli_step["time_s"] > 0.09
    np.testing.assert_array_equal(meshio.read(tmp_path / "scene" / "receptors.vtu").point_data["sed_pa"],
                                  vtu.point_data["sed_pa"])
    from afferent.export import step_title

    assert step_title("SED at receptor sites", [0.0, 0.1, 0.2], 1, 3) == "SED at receptor sites\nstep 2 of 3, t = 0.1 s (peak)"
    assert "step 3 of 3" in step_title("SED", [0.0, 0.1, 0.2], -1, 3)  # 1-based: the last is not "step 2 of 3"


def test_profiles_of_three_afferents_show_the_raw_currents(bump):
    import matplotlib

    matplotlib.use("Agg")
    from afferent import plotting
    from afferent.receptors import read_receptors
    from afferent.synthesis import Branching, synthesize

    vtu, receptors, *_ = bump
    field = read_sed(vtu, length_unit="mm", sed_unit="MPa")
    layout = read_receptors(receptors, length_unit="mm")
    res = run_pipeline(field, layout, STUDY_PARAMS["start"])
    keep = np.isin(layout.longitudinal, np.unique(layout.longitudinal)[:3])
    sub = layout.subset(keep)
    sed = sample_sed(field, sub)
    from afferent.transduction import transduce

    cur = transduce(sed, STUDY_PARAMS["start"])
    aff = synthesize(cur, Branching.longitudinal(sub))
    assert aff.n_afferents == 3
    ax = plotting.plot_section_profiles(sed, cur, aff, axis="x")
    note = " ".join(ax.figure.legends[0].get_title().get_text().split())  # the legend's heading, beside the data
    assert "only 3 afferents: their min-max normalised profile is 0-1 by construction" in note
    twin = [a for a in ax.figure.axes if a is not ax][0]
    assert twin.get_ylabel() == "afferent current, raw (nA)"
    np.testing.assert_allclose(np.sort(twin.lines[0].get_ydata()), np.sort(aff.values[-1] * 1e9))
    full = plotting.plot_section_profiles(res.sed, res.current, res.afferent, axis="x")
    assert not full.texts and len(full.figure.axes) == 1  # enough afferents: no raw axis


#: run.json fields that record the route itself (how the run was asked for, when, how long it took)
ROUTE_FIELDS = ("command", "scene_file", "started_utc", "wall_seconds", "stages")


@pytest.mark.parametrize("case", ["fit", "ramp_spikes"])
def test_cli_options_and_the_equivalent_scene_file_give_identical_results(capsys, tmp_path, case):
    """`afferent run EXPORT ...` and `afferent run SCENE.toml` are one route: same tables byte for byte, same
    record but for the fields that say how and when the run was asked for (ROUTE_FIELDS, and the output folder)."""
    from conftest import SAMPLE_DIR

    export, receptors = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu", SAMPLE_DIR / "block4" / "receptors.csv"
    if not export.is_file():
        pytest.skip("bundled sample not generated")
    obs = tmp_path / "obs.csv"
    pos = np.linspace(0, 4, 11)
    pd.DataFrame({"position": pos, "response": np.exp(-((pos - 2) ** 2))}).to_csv(obs, index=False)
    base = ["run", str(export), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa", "--no-cache"]
    head = f"""[scene]
name = "run"
[export]
file = {str(export)!r}
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = {str(receptors)!r}
"""
    if case == "fit":
        options = ["--params", "start", "--synthesis", "cross", "--observed", str(obs), "--observed-unit", "mm",
                   "--normalise", "prediction", "--no-plots"]
        body = f"""[transduction]
params = "start"
[synthesis]
kind = "cross"
[fit]
observed = {str(obs)!r}
length_unit = "mm"
normalise = "prediction"
[outputs]
want = ["currents", "profiles", "sed_map", "vtu", "fit"]
"""
    else:
        options = ["--params", "longitudinal", "--alpha", "3e-8", "--waveform", "ramp:0.5,5,0.2", "--d-ref-mm", "0.5",
                   "--spikes", "--input", "rate-sensitive", "--gain-s", "0.2", "--tau-ms", "5", "--dt-ms", "0.1"]
        body = """[transduction]
params = "longitudinal"
alpha_a = 3e-8
[stimulus]
waveform = "ramp"
depth_mm = 0.5
speed_mm_per_s = 5.0
hold_s = 0.2
d_ref_mm = 0.5
[spikes]
input = "rate-sensitive"
gain_s = 0.2
tau_ms = 5.0
dt_ms = 0.1
[outputs]
want = ["currents", "profiles", "sed_map", "vtu", "spikes", "plots"]
"""
    cli_out, toml_out = tmp_path / "cli" / "run", tmp_path / "toml" / "run"
    assert main(base + options + ["-o", str(cli_out)]) == 0, capsys.readouterr().err
    scene = tmp_path / "scene.toml"
    scene.write_text(head + body)
    assert main(["run", str(scene), "-o", str(toml_out), "--no-cache"]) == 0, capsys.readouterr().err
    names = sorted(p.name for p in cli_out.iterdir())
    assert names == sorted(p.name for p in toml_out.iterdir())
    tables = [n for n in names if n.endswith((".csv", ".vtu", ".nc"))]
    assert {"currents.nc", "profiles.csv", "sed_map.csv", "receptors.vtu"} <= set(tables)
    assert ("spikes.csv" in tables) == (case == "ramp_spikes") and ("fit.csv" in tables) == (case == "fit")
    for name in tables:
        assert (cli_out / name).read_bytes() == (toml_out / name).read_bytes(), name
    a, b = (json.loads((d / "run.json").read_text()) for d in (cli_out, toml_out))
    assert a["command"].startswith("afferent run " + str(export)) and b["scene_file"]["path"] == str(scene)
    for rec in (a, b):
        for key in ROUTE_FIELDS:
            rec.pop(key)
        for key in ("seconds", "start_s", "waited_s"):  # the figures' timings (afferent._figure_process)
            rec.get("figures", {}).pop(key, None)
        rec["scene"]["outputs"].pop("dir")
    assert a == b


def test_cli_errors_found_by_the_scene_speak_the_commands_options(capsys, tmp_path, bump):
    vtu, receptors, *_ = bump
    base = ["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa", "--params",
            "start", "--no-cache", "-o", str(tmp_path / "o")]
    for extra, message in (
        (["--spikes", "--lif-preset", "nope"], "--lif-preset must be one of 'ra', 'sa1'; got 'nope' instead."),
        (["--spikes", "--dt-ms", "-1"], "--dt-ms must be > 0; got -0.001 s instead."),
        (["--waveform", "ramp:0.5,5,1", "--d-ref-mm", "nan"], "--d-ref-mm must be a finite number in mm; got nan instead."),
    ):
        assert main(base + extra) == 2
        assert capsys.readouterr().err == f"afferent: error: {message}\n"
    assert main([a for a in base if a not in ("--length-unit", "mm")] + ["--sed-unit", "MPa"]) == 2
    assert capsys.readouterr().err.startswith("afferent: error: --receptors needs the unit of R.csv's x, y, z: "
                                              "--receptor-unit U or --length-unit U")
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------- issue 33, item 13: --on-outside nan|warn
def _corner_cut_bump(folder):
    """write_bump's block without its cells beyond x = z = 3 mm: the papilla grid there lies outside the field."""
    vtu, receptors, *_ = write_bump(folder, 8)
    mesh = meshio.read(vtu)
    hexes = mesh.cells_dict["hexahedron"]
    centre = mesh.points[hexes].mean(axis=1)
    hexes = hexes[~((centre[:, 0] > 3.0) & (centre[:, 2] > 3.0))]
    used = np.unique(hexes)
    index = np.full(len(mesh.points), -1)
    index[used] = np.arange(used.size)
    meshio.write(vtu, meshio.Mesh(mesh.points[used], [("hexahedron", index[hexes])],
                                  point_data={"SED": mesh.point_data["SED"][used]}))
    return vtu, receptors


@pytest.mark.parametrize("mode", ["file", "grid"])
@pytest.mark.parametrize("on_outside", ["nan", "warn"])
def test_receptors_outside_the_field_are_left_out_of_every_stage_and_said(tmp_path, capsys, mode, on_outside):
    """Before: 'afferent: error: 'sed' must not contain NaN; ... must be dropped before transduction' (exit 2) for
    every input mode, although the refusal of on_outside='raise' offers --on-outside nan and warn. Now the receptors
    outside are NaN in the SED table and left out from transduction on, the afferents that lose receptors are named
    in a warning and run.json, and every current and spike count is finite: an afferent's current is the sum of its
    receptors inside."""
    import xarray as xr

    vtu, receptors = _corner_cut_bump(tmp_path)
    where = ["--receptors", str(receptors)] if mode == "file" else ["--grid", "y=2.35"]
    out = tmp_path / "out"
    code = main(["run", str(vtu), *where, "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start", "--spikes",
                 "--drive", "rheobase", "--no-plots", "--no-cache", "--on-outside", on_outside, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    record = json.loads((out / "run.json").read_text())["outside"]
    n_out, n = record["n_receptors"], record["of"]
    partly = record["afferents_partly_outside"]
    assert 0 < n_out < n and partly and all(0 < k < m for k, m in partly.values())
    warned = [line for line in err.splitlines() if line.startswith("afferent: warning: ")]
    assert len([w for w in warned if "outside the SED field" in w]) == 1, err
    assert (f"afferent: warning: {n_out} of {n} receptors lie outside the SED field (" in err
            and f": their SED is NaN in the SED tables, and they are left out of every stage from transduction on. "
                f"{len(partly)} afferent(s) keep only their receptors "
                "inside, so their currents sum fewer receptors than they have: " in err), err
    with xr.open_dataset(out / "currents.nc", engine="h5netcdf") as ds:
        assert ds.sizes["receptor"] == n - n_out and not set(record["receptors"]) & set(ds.receptor_id.values.tolist())
        for v in ("sed_pa", "current_a", "afferent_current_a"):
            assert np.isfinite(ds[v].values).all(), v
        by_section = ds.current_a.groupby("longitudinal").sum().values
        np.testing.assert_allclose(by_section, ds.afferent_current_a.values, rtol=1e-12)
    summary = pd.read_csv(out / "spike_summary.csv")
    assert len(summary) == ds.sizes["afferent"] and summary["n_spikes"].notna().all()
    sed_map = pd.read_csv(out / "sed_map.csv", dtype={"receptor": str})  # the SED table: NaN where outside
    assert sorted(sed_map.loc[sed_map["sed_pa"].isna(), "receptor"]) == sorted(record["receptors"])


def test_sites_found_on_the_export_outside_the_field_are_left_out_too(tmp_path, capsys, monkeypatch):
    """The site finder's mode (--grid tips): its sites lie on the mesh, so three of them are lifted 1 mm above it
    here (as a finder working on another file than the sampled one would place them). Before: the same refusal
    "'sed' must not contain NaN" (exit 2)."""
    import xarray as xr

    import afferent.receptors._tips
    from afferent.receptors import ReceptorLayout, sites_from_export as found
    from conftest import ROOT

    on_raw = afferent.receptors._tips.sites_from_raw  # the finder on the export as read (one read)

    def lifted(*args, **kwargs):
        tips = on_raw(*args, **kwargs)
        pos = tips.positions.copy()
        pos[:3, 1] += 1e-3
        return ReceptorLayout(pos, tips.ids, tips.longitudinal, tips.cross, source=tips.source, site=tips.site)

    monkeypatch.setattr(afferent.receptors._tips, "sites_from_raw", lifted)
    out = tmp_path / "out"
    code = main(["run", str(ROOT / "afferent" / "data" / "sample" / "block4" / "indent_0p88mm.vtu"), "--grid", "tips",
                 "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start", "--spikes", "--drive", "rheobase",
                 "--no-plots", "--no-cache", "--on-outside", "nan", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    record = json.loads((out / "run.json").read_text())["outside"]
    assert record["n_receptors"] == 3 and f"afferent: warning: 3 of {record['of']} receptors lie outside" in err
    assert record["afferents_partly_outside"] or record["afferents_all_outside"]
    assert record["receptors"] == [str(i) for i in found(ROOT / "afferent" / "data" / "sample" / "block4" /
                                                         "indent_0p88mm.vtu", length_unit="mm", kind="tips", upper=1,
                                                         lower=2, pitch_x=0.44e-3, pitch_z=0.22e-3).ids[:3]]
    with xr.open_dataset(out / "currents.nc", engine="h5netcdf") as ds:
        assert ds.sizes["receptor"] == record["of"] - 3 and np.isfinite(ds["afferent_current_a"].values).all()
