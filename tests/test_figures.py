"""Every figure the package writes, rendered and checked as a reader sees it (tests/_figcheck.py):
no legend box over a plotted point, no two labels overlapping.

Drives the real routes with small inputs: the bundled scenes (sample_sed/scenes: SED map,
profiles and fit, ramp-and-hold spikes) and the report's figures from a stored 'tiny' report
(tests/data/report/tiny_results.json: ``afferent report --size tiny``'s results.json).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from _figcheck import collect_figure_problems, figure_problems

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "sample_sed" / "scenes"
needs_sample = pytest.mark.skipif(not SCENES.is_dir(), reason="bundled sample (sample_sed/) not present")


def _readable(found: dict) -> None:
    bad = {name: p for name, p in found.items() if p}
    assert not bad, "figures a reader cannot read:\n" + "\n".join(f"{n}: {'; '.join(p)}" for n, p in bad.items())


def test_checker_sees_a_legend_over_a_point_and_overlapping_labels():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], "o-", label="data")
    ax.legend(loc="lower left")  # over the point (0, 0)
    assert any("covers" in p and "'data'" in p for p in figure_problems(fig))
    fig = Figure(figsize=(2, 2))
    ax = fig.subplots()
    ax.set_xticks(range(10), [f"label {i}" for i in range(10)])
    assert any("tick" in p and "overlaps" in p for p in figure_problems(fig))
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], "o-", label="data")
    ax.legend(loc="lower right")
    assert figure_problems(fig) == ["no title"]
    ax.set_title("a title")
    assert figure_problems(fig) == []
    ax.plot([0, 1], [0, 1], "o-", label="the same data, drawn over")
    ax.set_xlabel("x (across) (mm)")
    assert figure_problems(fig) == ["axes 0: line 'data' hidden under 'the same data, drawn over'",
                                    "axes 0 x label 'x (across) (mm)' has more than one (...)"]


@needs_sample
@pytest.mark.parametrize("scene", ["sed_map", "profiles", "spikes_ramp"])
def test_run_figures_are_readable(scene, tmp_path, monkeypatch):
    from afferent.scene import load_scene, run_scene

    found = collect_figure_problems(monkeypatch)
    res = run_scene(load_scene(SCENES / f"{scene}.toml").with_output(tmp_path / scene), cache_dir=tmp_path / "c")
    pngs = {f for f in res.files if str(f).endswith(".png")}
    assert pngs and {Path(f).name for f in pngs} <= set(found)
    _readable(found)


def test_report_figures_are_readable(tmp_path, monkeypatch):
    import afferent.report.render as rep

    results = json.loads((ROOT / "tests" / "data" / "report" / "tiny_results.json").read_text())
    found = collect_figure_problems(monkeypatch)
    rep._plots(results, str(tmp_path))
    assert {"sampling.png", "spiking.png", "receptors.png", "calibration.png", "series.png"} <= set(found)
    _readable(found)


@needs_sample
@needs_sample
def test_a_run_whose_recording_is_a_few_percent_ripple_says_what_its_r2_measures(tmp_path):
    """A fit of profiles min-max normalisation stretched from a few % to 0..1 was reported as an R^2 without a word."""
    import json

    from afferent.scene import load_scene, run_scene

    block = ROOT / "sample_sed" / "block4"
    lines = (ROOT / "sample_sed" / "observed" / "synthetic_1p32mm_longitudinal.csv").read_text().splitlines()
    rows = [r.split(",") for r in lines if r and r[0].isdigit()]
    ripple = tmp_path / "ripple.csv"  # the recording's positions, its response flattened to 100 .. 105 %
    ripple.write_text("position,response\n" + "".join(f"{x},{1.0 + 0.05 * (k % 2)}\n" for k, (x, _) in enumerate(rows)))
    scene = tmp_path / "fit.toml"
    scene.write_text(f'[export]\nfile = "{block / "indent_1p32mm.vtu"}"\nlength_unit = "mm"\nsed_unit = "MPa"\n'
                     f'[receptors]\nfile = "{block / "receptors.csv"}"\n[synthesis]\nkind = "longitudinal"\n'
                     f'[fit]\nobserved = "{ripple}"\nlength_unit = "mm"\n[outputs]\nwant = ["fit"]\n')
    run_scene(load_scene(scene).with_output(tmp_path / "out"), cache_dir=tmp_path / "c")
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    said = [w["message"] for w in record["warnings"] if "min-max normalisation" in w["message"]]
    assert len(said) == 1 and said[0].startswith("Before min-max normalisation the observed profile varies by 4.8 % of "
                                                 "its largest value (under 10 %)"), record["warnings"]
    assert f"R^2 = {record['fit']['r2']:.3g}" in said[0]


def test_fit_and_calibration_figures_are_readable(tmp_path, monkeypatch):
    from afferent.cli import main
    from afferent.scene import load_scene, run_scene

    block = ROOT / "sample_sed" / "block4"
    observed = ROOT / "sample_sed" / "observed" / "synthetic_1p32mm_longitudinal.csv"
    scene = tmp_path / "fit.toml"
    scene.write_text(f'[export]\nfile = "{block / "indent_1p32mm.vtu"}"\nlength_unit = "mm"\nsed_unit = "MPa"\n'
                     f'[receptors]\nfile = "{block / "receptors.csv"}"\n[synthesis]\nkind = "longitudinal"\n'
                     f'[fit]\nobserved = "{observed}"\nlength_unit = "mm"\n[outputs]\nwant = ["fit", "plots"]\n')
    found = collect_figure_problems(monkeypatch)
    run_scene(load_scene(scene).with_output(tmp_path / "fit"), cache_dir=tmp_path / "c")
    assert "fit.png" in found
    sed_csv = tmp_path / "sed.csv"
    assert main(["sample", str(block / "indent_1p32mm.vtu"), "--receptors", str(block / "receptors.csv"),
                 "--length-unit", "mm", "--sed-unit", "MPa", "-o", str(sed_csv)]) == 0
    assert main(["calibrate", str(sed_csv), "--observed", str(observed), "--observed-unit", "mm",
                 "--synthesis", "longitudinal", "-o", str(tmp_path / "calib")]) == 0
    assert {"profile.png", "ssd.png"} <= set(found)
    _readable(found)


def test_fit_of_profiles_with_little_contrast_says_min_max_stretched_them():
    import numpy as np

    from afferent.plotting import plot_fit
    from afferent.profiles import compare_profiles

    # observed varies by 5 %, the prediction by 1.4 %: both become 0..1 and R^2 is meaningless without a word
    fit = compare_profiles(np.array([1.0, 1.014, 1.007, 1.0]), np.array([1.0, 1.03, 1.05, 1.01]),
                           positions=np.array([1.0, 2.0, 3.0, 4.0]) * 1e-3)
    assert fit.variation == pytest.approx((0.014 / 1.014, 0.05 / 1.05))
    ax = plot_fit(fit)
    note = ax.figure.legends[0].get_title().get_text()
    assert "predicted varies by 1.4 %" in note and "observed varies by 4.8 %" in note and "stretched" in note
    assert figure_problems(ax.figure) == []
    # a profile with contrast gets no note
    fit = compare_profiles(np.array([1.0, 3.0, 2.0]), np.array([0.5, 3.0, 1.0]), positions=np.array([1.0, 2.0, 3.0]) * 1e-3)
    assert plot_fit(fit).figure.legends[0].get_title().get_text() == ""


def test_report_spiking_figure_keeps_units_apart_and_names_the_points_a_log_axis_drops(tmp_path, monkeypatch):
    import afferent.report.render as rep

    results = json.loads((ROOT / "tests" / "data" / "report" / "tiny_results.json").read_text())
    fast = [r for r in results["spiking"] if r["engine"] == "fast" and r.get("wall_s") is not None]
    fast[0]["rate_err_median"] = 0.0  # e.g. dt = 0.001 ms: the same rates as the exact engine
    figures = []
    monkeypatch.setattr("afferent.plotting.save_figure", lambda fig, path: figures.append(fig) or path)
    rep._plot_spiking(results, str(tmp_path))
    fig = figures[0]
    assert f"zero, not drawn: rate at dt = {fast[0]['dt_s'] * 1e3:g} ms" in fig.legends[0].get_title().get_text()
    for ax in fig.axes:  # one unit per y axis: seconds never beside a relative error
        labels = [ln.get_label() for ln in ax.get_lines()]
        assert not (any("relative" in lab for lab in labels) and any("(s" in lab for lab in labels)), labels
    assert figure_problems(fig) == []


@needs_sample
def test_one_folder_names_its_two_clocks(tmp_path, monkeypatch):
    """With a waveform, sed_map.png shows an export step (FE time) and the profiles the stimulus' peak:
    both times are named, and steps count from 1."""
    from matplotlib.figure import Figure

    from afferent.scene import load_scene, run_scene

    text = (SCENES / "spikes_ramp.toml").read_text()
    text = text.replace('file = "../', f'file = "{SCENES.parent}/').replace(
        'want = ["spikes", "profiles", "plots"]', 'want = ["sed_map", "profiles", "plots"]')
    text = text[:text.index("[spikes]")] + text[text.index("[outputs]"):]
    (tmp_path / "s.toml").write_text(text)
    titles = {}
    original = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, f, *a, **k: (
        titles.setdefault(str(f), [ax.get_title() for ax in self.axes]), original(self, f, *a, **k))[1])
    run_scene(load_scene(tmp_path / "s.toml").with_output(tmp_path / "out"), cache_dir=tmp_path / "c")
    sed_map = next(t for f, t in titles.items() if "sed_map" in f)[0]
    profiles = next(t for f, t in titles.items() if "profiles_x" in f)[0]
    assert "step 6 of 6, FE time = " in sed_map and "the stimulus peaks at t = 0.1 s" in sed_map, sed_map
    assert "t = 0.1 s (peak)" in profiles and "FE time" not in profiles, profiles


def test_demo_summary_figure_is_readable(tmp_path, monkeypatch):
    """indenters_x.png: the 4 mm curve's peaks sat under the legend boxes (seen on the demo's figure)."""
    from afferent.cli._demo import _plot_indenters

    found = collect_figure_problems(monkeypatch)
    x = np.linspace(-3.5, 3.5, 61) * 1e-3  # curves that reach every corner of the panels, as the 4 mm one does
    profiles = [(w, x, np.cos(x * 1e3 * (1 + w)) ** 2, x, np.sin(x * 1e3 * (1 + w)) ** 2) for w in (0.44, 0.88, 4.0)]
    findings = [{"finding": "interchange zone", "study": "0.66-0.88 mm", "sample": "1.32 mm", "criterion": "2 peaks",
                 "holds": False, "note": "the tips sit deep"}]
    _plot_indenters(profiles, findings, str(tmp_path / "indenters_x.png"))
    assert set(found) == {"indenters_x.png"}
    _readable(found)


def _curves_in_every_corner(n: int = 4):
    """n curves (values 0..1) over 61 points that reach every corner of the Axes, as the demo's 4 mm one does."""
    x = np.linspace(-3.5, 3.5, 61)
    return x, [np.cos(x * (1 + w)) ** 2 for w in (0.44, 0.88, 2.0, 4.0)[:n]]


def test_checker_sees_a_legend_over_a_histogram():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    ax.stairs(np.full(20, 5.0), np.linspace(0, 1, 21), fill=True, label="rate")
    ax.legend(loc="upper right")
    assert any("covers" in p and "'bar rate'" in p for p in figure_problems(fig))


def test_sed_profiles_on_one_axes_keep_their_legend_beside():
    """plot_sed_profile with a label, several on one Axes: the legend sat over a profile's point; each call now
    replaces the one box beside the Axes (fails before: the legend covered a point of '0.44 mm')."""
    from afferent.plotting import plot_sed_profile
    from afferent.receptors import grid_layout
    from afferent.sampling import ReceptorSED

    layout = grid_layout(x_range=(0.0, 5.28e-3), z_range=(0.0, 2.2e-3), y=-0.75e-3)
    x_mm = layout.positions[:, 0] * 1e3
    ax = None
    for w in (0.44, 0.88, 2.0, 4.0):
        values = 1.0 + 100.0 * np.cos(x_mm * (1 + w))[None, :] ** 2  # Pa
        sed = ReceptorSED(values, np.array([0.1]), layout, "linear", np.zeros(layout.n_receptors, bool))
        ax = plot_sed_profile(sed, ax=ax, label=f"{w:g} mm", normalise=True)
    ax.set_title("SED along x")
    assert figure_problems(ax.figure) == []
    (box,) = ax.figure.legends  # one box, holding every profile
    assert [t.get_text() for t in box.get_texts()] == ["0.44 mm", "0.88 mm", "2 mm", "4 mm"]


def test_psth_legend_is_beside_the_bars():
    """plot_psth with labels (two populations on one Axes, as notebook 05 draws them): the legend sat on the bars
    (fails before: it covered bins of 'rate-sensitive')."""
    from afferent.plotting import plot_psth
    from afferent.spiking import LIFParams, simulate_lif

    t = np.linspace(0.0, 1.0, 1001)  # s
    lif = LIFParams.from_preset("ra")
    ax = None
    for label, level in (("static", 3e-7), ("rate-sensitive", 2e-7)):  # A: steady firing over the whole second
        spikes = simulate_lif(np.full((t.size, 5), level), lif, times=t, duration=1.0)
        ax = plot_psth(spikes, 0.02, ax=ax, label=label)
    assert figure_problems(ax.figure) == []


def _calibration_result(fit):
    """A CalibrationResult around ``fit`` (what the two figures read), its ssd history filling the Axes."""
    import pandas as pd

    from afferent.calibration import CalibrationResult
    from afferent.transduction import STUDY_PARAMS, saturation_report

    rng = np.random.default_rng(0)
    runs = pd.DataFrame({"evaluation": np.arange(1, 201), "ssd": 10 ** rng.uniform(-3, 0, 200), "degenerate": False})
    iters = pd.DataFrame({"evaluations": [1, 50, 120, 200], "ssd": [1.0, 0.1, 0.01, 1e-3]})
    p = STUDY_PARAMS["start"]
    return CalibrationResult(p, fit.ssd, fit.r2_study, fit.r2, iters, runs, None, (),
                             saturation_report(np.array([[50.0, 300.0]]), p), True, "converged", "", 200, "rsm1",
                             "longitudinal", "both", p, fit)


def test_calibration_figures_keep_their_legends_beside():
    """profile.png and ssd.png of `afferent calibrate` drew plain legends: on a profile or a history that fills the
    Axes they covered points (fails before: 3 'observed' points; 6 evaluated points and 1 of the best line)."""
    from afferent.calibration import plot_calibrated_profile, plot_ssd_history
    from afferent.profiles import compare_profiles

    positions = np.linspace(0.0, 5e-3, 200)  # m
    observed = np.random.default_rng(1).uniform(0.0, 1.0, positions.size)
    fit = compare_profiles(np.linspace(0.0, 1.0, positions.size), observed, positions=positions, normalise="neither")
    result = _calibration_result(fit)
    found = {name: figure_problems(plot(result).figure) for name, plot in
             (("profile.png", plot_calibrated_profile), ("ssd.png", plot_ssd_history))}
    _readable(found)


def test_save_figure_lays_out_and_draws_once_with_the_pixels_savefig_gives(tmp_path, monkeypatch):
    """savefig of a laid-out figure drew it twice (a layout pass drawing nothing, then the render):
    save_figure lays it out once at the saved dpi and draws once, and the PNG must not change."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure
    from PIL import Image

    from afferent.plotting import legend_beside, save_figure

    def figure():
        fig, ax = plt.subplots(figsize=(4, 3), layout="constrained")
        ax.plot([0, 1, 2], [0, 1, 0], label="a curve with a long name")
        ax.set(xlabel="x (mm)", ylabel="SED (Pa = J/m³)", title="a title")
        legend_beside(ax)
        return fig

    reference = figure()
    reference.savefig(tmp_path / "savefig.png", dpi=150, format="png")
    plt.close(reference)
    draws = []
    original = Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: (draws.append(1), original(self, renderer))[1])
    save_figure(figure(), str(tmp_path / "save_figure.png"))
    assert len(draws) == 1
    a, b = (np.asarray(Image.open(tmp_path / f)) for f in ("savefig.png", "save_figure.png"))
    assert a.shape == b.shape and np.array_equal(a, b)



@needs_sample
def test_frequency_figure_is_readable(tmp_path, monkeypatch):
    """frequency.png (afferent cycles): SED at the deepest points and mean rate vs frequency, the legends beside."""
    import pandas as pd

    from afferent.plotting import plot_frequency, save_figure

    info = json.loads((ROOT / "sample_sed" / "vibration" / "build_info.json").read_text())["models"]
    rates = {"3d": [86.7, 120.0, 160.0, 192.0], "2d": [84.0, 122.0, 163.3, 186.7]}  # afferent cycles on the sample
    rows = [{"group": m, "frequency_hz": f, "n_cycles": 3, "rate_hz": rates[m][i],
             "sed_first_pa": info[m]["series"][f"{m}_{f}Hz"]["deepest"]["site_SED_Pa"][0],
             "sed_last_pa": info[m]["series"][f"{m}_{f}Hz"]["deepest"]["site_SED_Pa"][-1]}
            for m in ("3d", "2d") for i, f in enumerate((20, 30, 50, 80))]
    found = collect_figure_problems(monkeypatch)
    save_figure(plot_frequency(pd.DataFrame(rows)), str(tmp_path / "frequency.png"))
    assert set(found) == {"frequency.png"}
    _readable(found)
