"""Figures quoted in docs/method.md, docs/spikes.md and the sample scenes, recomputed from the code and the
bundled sample, so that a quoted number cannot go stale (issue 21: "numbers quoted in docs come from
a command that a test re-runs"). Each test names the passage and the computation behind it."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import afferent
from afferent.pipeline import run_pipeline
from afferent.profiles import compare_profiles, read_observed
from afferent.spiking import LIF_PRESETS, simulate_lif
from afferent.transduction import STUDY_PARAMS

from conftest import SAMPLE_DIR

ROOT = Path(__file__).resolve().parents[1]
METHOD = (ROOT / "docs" / "method.md").read_text(encoding="utf-8")
SPIKES = (ROOT / "docs" / "spikes.md").read_text(encoding="utf-8")
RA = LIF_PRESETS["ra"]
needs_sample = pytest.mark.skipif(not (SAMPLE_DIR / "block4" / "receptors.csv").is_file(), reason="sample_sed not generated")


def _block4(name):
    field = afferent.read_sed(str(SAMPLE_DIR / "block4" / name), length_unit="mm", sed_unit="MPa")
    return field, afferent.read_receptors(SAMPLE_DIR / "block4" / "receptors.csv", length_unit="mm")


@needs_sample
def test_saturated_longitudinal_fit_r2_quoted_in_method():
    """method.md, "Saturation": R^2_study of the saturated longitudinal parameters on the 1.32 mm
    indenter, longitudinal sections, against sample_sed/observed/synthetic_1p32mm_longitudinal.csv."""
    field, layout = _block4("indent_1p32mm.vtu")
    obs = read_observed(SAMPLE_DIR / "observed" / "synthetic_1p32mm_longitudinal.csv", length_unit="mm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # saturation / tiny-modulation warnings: the point of the passage
        res = run_pipeline(field, layout, STUDY_PARAMS["longitudinal"], synthesis="longitudinal")
        fit = compare_profiles(res.afferent, obs)
    quoted = re.search(r"gives \$R\^2_\\text\{study\}\$ = ([0-9.]+) \(the study reports 0.95", METHOD)
    assert quoted, "the passage moved: update this test"
    assert quoted.group(1) == f"{fit.r2_study:.3f}"
    # the modulation really is ~1e-9 of alpha and the normalised shape is -sum exp(-gamma SED) per section
    cur = res.current.values[-1] / STUDY_PARAMS["longitudinal"].alpha
    assert 0 < 1 - cur.min() < 1e-8
    g = STUDY_PARAMS["longitudinal"].gamma
    from afferent.synthesis import Branching

    w = Branching.longitudinal(layout).weights
    tail = -(w @ np.exp(-g * res.sed.values[-1]))
    e = res.afferent.values[-1]
    np.testing.assert_allclose((e - e.min()) / np.ptp(e), (tail - tail.min()) / np.ptp(tail), atol=1e-3)


def test_spike_rates_quoted_in_method_spikes_and_readme():
    """method.md "From current to membrane", spikes.md "Engines" and "From current to membrane": the study's longitudinal
    fit saturates 17 receptors per longitudinal section of block4 at alpha = 9.29e-7 A each, i.e.
    158 x the rheobase of ra: 814 Hz exact (closed form), 833 Hz on the grid at dt = 0.1 ms (warned);
    --drive rheobase with K = 2: 232.6 Hz (closed form 1 / (t_ref + tau_m ln 2))."""
    drive = 17 * STUDY_PARAMS["longitudinal"].alpha
    ratio = drive / RA.rheobase
    exact = float(RA.steady_rate(drive))
    k2 = float(RA.steady_rate(2.0 * RA.rheobase))
    assert f"{ratio:.0f}" == "158" and f"{exact:.0f}" == "814" and f"{k2:.1f}" == "232.6"
    with pytest.warns(afferent.exceptions.AfferentWarning, match="1/t_ref"):
        grid = simulate_lif(np.full((1, 1), drive), RA, dt=1e-4, engine="fast-numpy", duration=0.02)
    assert f"{grid.peak_rate()[0]:.0f}" == "833"
    assert "driven at 158 times the rheobase" in METHOD and "fires at 814 Hz (the closed form" in METHOD
    assert "with $K = 2$ gives 232.6 Hz" in METHOD and "834" not in METHOD and "238 Hz" not in METHOD
    assert "833 Hz on the grid, 814 Hz exact" in SPIKES
    flat = " ".join(SPIKES.split())
    assert "at 158 x the rheobase, 814 Hz everywhere" in flat and "is 232.6 Hz" in flat


def _pct(x: float) -> str:
    """A relative error as the docs print it: two significant digits, whole percent from 100 %."""
    return f"{100 * x:.2g} %" if x < 1 else f"{100 * x:.0f} %"


@needs_sample
def test_d2_law_errors_quoted_in_method_spikes_and_scene():
    """method.md "A static solution over time" (its table), spikes.md "Driving a static export over time" and the
    spikes_ramp scene's comment: the d^2 law of the 0.5 mm step of sample_sed/block4/series_0p88mm against the
    series' own steps, over all 119 tips and over the scene's 51 (1.5 <= x <= 2.5 mm), as
    afferent.stimulus.depth_scaling_error computes it (the run's warning prints the same 0.1 mm figure)."""
    import types

    from afferent.stimulus import depth_scaling_error

    field, layout = _block4("series_0p88mm/indent.pvd")
    sed = afferent.sample_sed(field, layout, method="linear")
    depths = np.arange(6) * 1e-4  # m: 0, 0.1, ..., 0.5 mm
    x = layout.positions[:, 0]
    rows = {}
    for name, keep in (("all", np.ones(x.size, bool)), ("band", (x >= 1.5e-3) & (x <= 2.5e-3))):
        check = depth_scaling_error(types.SimpleNamespace(values=sed.values[:, keep]), depths)
        errors = " | ".join(_pct(check.rel_error_l2[k]) for k in (4, 3, 2, 1))  # 0.4, 0.3, 0.2, 0.1 mm
        rows[name] = (int(keep.sum()), f"{errors} | {np.nanmin(check.exponent):.2f}-{np.nanmax(check.exponent):.2f} |",
                      check.rel_error_l2)
    assert rows["all"][0] == 119 and rows["band"][0] == 51
    assert f"| all 119 tips | {rows['all'][1]}" in METHOD
    assert f"(51 tips; the `spikes_ramp` scene) | {rows['band'][1]}" in METHOD
    band = rows["band"][2]
    flat = " ".join(SPIKES.split())
    assert f"would be {_pct(band[4])} off at 0.4 mm but {_pct(band[1])} off at 0.1 mm" in flat
    scene = (ROOT / "sample_sed" / "scenes" / "spikes_ramp.toml").read_text(encoding="utf-8")
    assert f"({_pct(band[1])} at 0.1 mm, {_pct(band[4])} at 0.4 mm for this region" in scene
