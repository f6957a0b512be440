"""Figures that do not mislead (issue 34, item 8), tested on the figure objects, never on pixels:
the method a calibration figure draws, the range of an axis, the counts a legend names, the units of a
profile, the demo's findings text against its table, the markers of rates.png.

The layout of each figure (no legend over a point, no overlapping labels) is tests/test_figures.py's.
"""

from __future__ import annotations

import numpy as np
import pytest

from _figcheck import figure_problems

TRIANGLES = set("^v<>1234")


@pytest.fixture(autouse=True)
def _close_figures():
    """Each test's figures closed after it (pyplot warns past 20 open figures)."""
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def _line(ax, label: str):
    found = [ln for ln in ax.get_lines() if ln.get_label() == label]
    assert len(found) == 1, [ln.get_label() for ln in ax.get_lines()]
    return found[0]


def _spikes_and_ramp():
    """Three afferents through a ramp-and-hold with release (phases loading, hold, unloading, off)."""
    from afferent.spiking import LIFParams, simulate_lif
    from afferent.stimulus import ramp_and_hold
    from afferent.synthesis import AfferentCurrent

    ramp = ramp_and_hold(5e-4, 5e-3, 0.1, dt=1e-3, post=0.1)  # 0.1 s each: loading, hold, unloading, off
    t = np.arange(0.0, 0.4, 1e-4)
    cur = AfferentCurrent(np.tile([5e-8, 2e-7, 4e-7], (t.size, 1)), t, [0.0, 4.4e-4, 8.8e-4], ["L0", "L1", "L2"],
                          "longitudinal")
    return simulate_lif(cur, LIFParams.from_preset("ra"), dt=1e-4, engine="fast-numpy"), cur, ramp


def test_rates_off_phase_and_peak_rate_look_different():
    """rates.png drew the 'off' phase as a red triangle (the 4th default colour, 'v') and the peak instantaneous
    rate as a crimson triangle ('^'): two red triangles, told apart only by their direction (fails before)."""
    from matplotlib.colors import to_rgb

    from afferent.plotting import plot_rates

    spikes, cur, ramp = _spikes_and_ramp()
    ax = plot_rates(spikes, cur, waveform=ramp)
    labels = [t.get_text() for t in (ax.get_legend() or ax.figure.legends[0]).get_texts()]
    assert "off phase" in labels and "peak instantaneous (1 / shortest ISI)" in labels, labels
    off, peak = _line(ax, "off phase"), _line(ax, "peak instantaneous (1 / shortest ISI)")
    assert not {off.get_marker(), peak.get_marker()} <= TRIANGLES, (off.get_marker(), peak.get_marker())
    phases = [ln for ln in ax.get_lines() if ln.get_label().endswith(" phase")]
    assert len(phases) == 4
    for ln in phases:  # no phase in the peak's colour family
        gap = np.abs(np.subtract(to_rgb(ln.get_color()), to_rgb(peak.get_color()))).sum()
        assert gap > 0.5, (ln.get_label(), ln.get_color(), peak.get_color())
    assert len({ln.get_marker() for ln in phases + [peak]}) == 5
    assert figure_problems(ax.figure) == []


def _frequency_rows(n_cycles):
    """frequency_summary rows of one model: SED falling 1.6 % from the first to the last deepest point (Pa)."""
    import pandas as pd

    return pd.DataFrame([{"group": "3d", "run": f"3d_{f}Hz", "frequency_hz": float(f), "n_cycles": n,
                          "sed_first_pa": 350.0 + f, "sed_last_pa": (350.0 + f) * 0.984, "rate_hz": 80.0 + f}
                         for f, n in zip((20, 30, 50, 80), n_cycles)])


def test_frequency_figure_starts_its_axes_at_zero_and_names_each_runs_cycle_count():
    """frequency.png: the SED axis spanned the data only (a 1.6 % fall from the first to the last deepest point
    filled the panel, a steep fall to the eye), and the last point's legend named the group's largest cycle count
    ('deepest point 12') for runs of 3 and 5 cycles too (fails before)."""
    from afferent.plotting import plot_frequency

    fig = plot_frequency(_frequency_rows((3, 3, 5, 12)))
    ax_sed, ax_rate = fig.axes[:2]
    assert ax_sed.get_ylim()[0] == 0.0 and ax_sed.get_ylim()[1] >= 430.0
    assert ax_rate.get_ylim()[0] == 0.0
    labels = [ln.get_label() for ln in ax_sed.get_lines()]
    assert labels == ["3d, 1st deepest point", "3d, last deepest point: cycle 3 at 20, 30 Hz, 5 at 50 Hz, 12 at 80 Hz"]
    fig = plot_frequency(_frequency_rows((3, 3, 3, 3)))
    assert [ln.get_label() for ln in fig.axes[0].get_lines()][1] == "3d, last deepest point: cycle 3"
    assert figure_problems(fig) == []


def _three_methods():
    """{method: CalibrationResult} on one observed profile: least_squares fits best (lowest ssd), rsm1 stalled."""
    import dataclasses

    import pandas as pd

    from afferent.calibration import CalibrationResult
    from afferent.profiles import compare_profiles
    from afferent.transduction import STUDY_PARAMS, saturation_report

    x = np.linspace(0.5e-3, 3.5e-3, 7)  # m
    observed = np.exp(-((x - 2e-3) / 8e-4) ** 2)
    p = STUDY_PARAMS["start"]
    runs = pd.DataFrame({"evaluation": [1, 2, 3], "ssd": [0.3, 0.2, 0.1], "degenerate": False})
    iters = pd.DataFrame({"iteration": [0, 1], "evaluations": [1, 3], "ssd": [0.3, 0.1]})
    base = CalibrationResult(p, 0.0, 0.0, 0.0, iters, runs, pd.DataFrame(), (),
                             saturation_report(np.array([[50.0, 300.0]]), p), True, "converged", "", 3, "rsm1",
                             "longitudinal", "both", p, None)
    out = {}
    for method, width in (("rsm1", 1.6e-3), ("least_squares", 8.2e-4), ("rsm2", 1.2e-3)):
        fit = compare_profiles(np.exp(-((x - 2e-3) / width) ** 2), observed, positions=x, normalise="both")
        out[method] = dataclasses.replace(base, method=method, ssd=fit.ssd, r2_study=fit.r2_study, r2=fit.r2, fit=fit)
    return out


def test_calibrate_all_draws_the_best_method_and_every_method_can_be_drawn(tmp_path, monkeypatch):
    """calibrate --method all drew only rsm1 in profile.png (the stalled fit) and no figure of least_squares or
    rsm2: now profile.png draws every method, the best by the ssd named in its title and legend, and each
    method's folder holds its own profile.png and ssd.png (fails before: one line, 'calibrated', rsm1's)."""
    import json

    from afferent import plotting
    from afferent.cli._calibrate import _write_one

    results = _three_methods()
    assert min(results, key=lambda m: results[m].ssd) == "least_squares"
    drawn = {}
    monkeypatch.setattr(plotting, "save_figure", lambda ax, path, **kw: drawn.setdefault(
        str(path), getattr(ax, "figure", ax)))
    _write_one(results, "rsm1", str(tmp_path), plots=True, extra={})
    names = {str(p).replace(str(tmp_path), "").lstrip("/") for p in drawn}
    assert names == {"profile.png", "ssd.png", "least_squares/profile.png", "least_squares/ssd.png",
                     "rsm2/profile.png", "rsm2/ssd.png"}, names
    fig = drawn[str(tmp_path / "profile.png")]
    ax = fig.axes[0]
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert labels[0] == "observed" and labels[1].startswith("least_squares: ssd ") and labels[1].endswith("(best)")
    assert sorted(lb.split(":")[0] for lb in labels[2:]) == ["rsm1", "rsm2"]
    assert ax.get_title().startswith("best by ssd: least_squares, longitudinal: ssd ")
    assert ax.get_lines()[1].get_linewidth() > max(ln.get_linewidth() for ln in ax.get_lines()[2:])
    assert figure_problems(fig) == []
    assert drawn[str(tmp_path / "rsm2" / "profile.png")].axes[0].get_title().startswith("rsm2, longitudinal")
    assert json.loads((tmp_path / "result.json").read_text())["best_method"] == "least_squares"


def _summary_rows(zones):
    """summary.csv rows as afferent demo writes them (SED Pa, widths mm) with the interchange zone per indenter."""
    widths = (0.44, 0.66, 0.88, 1.10, 1.32, 2.00, 4.00)
    return [{"indenter_mm": w, "sed_max_pa": 300.0, "interchange_zone": z, "afferent_peaks_longitudinal": 1 + (w > 1.5),
             "afferent_peaks_cross": 1 + (w > 1.5), "peak_prominence": 0.05} for w, z in zip(widths, zones)]


def test_demo_findings_text_names_what_its_table_says(tmp_path, monkeypatch):
    """The demo's findings text said 'interchange zone from 1.32 mm' while its table had the zone at 0.88 mm too
    (and not at 1.10 mm): the text names the narrower indenters the table gives a zone (fails before: '1.32 mm').
    The printed lines and the figure's text are one function's (finding_text) of the findings.csv rows."""
    from afferent import plotting
    from afferent.cli import _demo

    rows = _summary_rows([False, False, True, False, True, True, True])
    zone = _demo.study_findings(rows)[1]
    assert zone["sample"] == "1.32 mm (also at 0.88 mm, not at every wider one)" and not zone["holds"]
    assert _demo.study_findings(_summary_rows([False, False, True, True, True, True, True]))[1]["sample"] == "0.88 mm"
    findings = _demo.study_findings(rows)
    drawn = {}
    monkeypatch.setattr(plotting, "save_figure", lambda fig, path, **kw: drawn.setdefault("fig", fig))
    x = np.linspace(-2e-3, 2e-3, 9)
    _demo._plot_indenters([(w, x, np.cos(x * 1e3), x, np.cos(x * 1e3)) for w in (0.88, 4.0)], findings,
                          str(tmp_path / "indenters_x.png"))
    text = "\n".join(t.get_text() for sub in drawn["fig"].subfigs for t in sub.texts)
    for f in findings:
        assert _demo.finding_text(f, why="\n    why: ") in text
        assert _demo.finding_text(f).split("; why: ")[0] in text


def _profiles_inputs():
    """SED (Pa) on a 9 x 9 grid of receptors peaking in the middle, its receptor currents and longitudinal afferents."""
    from afferent.receptors import ReceptorLayout
    from afferent.sampling import ReceptorSED
    from afferent.synthesis import Branching, synthesize
    from afferent.transduction import STUDY_PARAMS, transduce

    xs, zs = np.arange(9) * 0.44e-3, np.arange(9) * 0.22e-3
    layout = ReceptorLayout(np.array([[x, 2.45e-3, z] for x in xs for z in zs]))
    p = layout.positions
    sed_pa = 100.0 + 400.0 * np.exp(-((p[:, 0] - 1.76e-3) ** 2 + (p[:, 2] - 0.88e-3) ** 2) / 1e-6)
    sed = ReceptorSED(sed_pa[None, :], np.array([0.0]), layout, "linear", np.zeros(layout.n_receptors, bool))
    current = transduce(sed, STUDY_PARAMS["start"])
    return sed, current, synthesize(current, Branching.longitudinal(layout))


def test_profiles_figure_can_show_magnitudes_in_pa_and_na():
    """profiles_x.png showed only min-max normalised curves: 100..500 Pa and 0.1..10 nA looked alike. With
    scale='magnitude' the SED is in Pa on the left axis and the currents in nA on the right, from zero
    (fails before: no 'scale')."""
    from afferent.plotting import plot_section_profiles
    from afferent.receptors import central_line

    sed, current, afferent = _profiles_inputs()
    ax = plot_section_profiles(sed, current, afferent, axis="x", scale="magnitude")
    twin = [a for a in ax.figure.axes if a is not ax]
    assert len(twin) == 1 and ax.get_ylabel() == "SED at the receptors (Pa)" and twin[0].get_ylabel() == "current (nA)"
    idx, _, _ = central_line(sed.layout, "x")
    sed_line = [ln for ln in ax.get_lines() if ln.get_label().startswith("SED")][0]
    np.testing.assert_allclose(sed_line.get_ydata(), sed.values[0, idx])
    by_label = {ln.get_label(): ln for ln in twin[0].get_lines()}
    np.testing.assert_allclose(by_label["receptor current, nA"].get_ydata(), current.values[0, idx] * 1e9)
    np.testing.assert_allclose(np.sort(by_label["afferent current (longitudinal sections), nA"].get_ydata()),
                               np.sort(afferent.values[0] * 1e9))
    assert ax.get_ylim()[0] == 0.0 and twin[0].get_ylim()[0] == 0.0
    assert ax.get_ylim()[1] >= sed.values[0, idx].max()
    assert figure_problems(ax.figure) == []
    norm = plot_section_profiles(sed, current, afferent, axis="x")  # the default stays the study's normalised view
    assert norm.get_ylabel() == "normalised (min-max)" and len(norm.figure.axes) == 1
    with pytest.raises(ValueError, match="scale must be 'normalised' or 'magnitude'; got 'raw' instead"):
        plot_section_profiles(sed, current, afferent, scale="raw")
