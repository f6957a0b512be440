"""Afferent classes (afferent.classes): the SA-I static-plus-rate input against its closed forms and the
Gerling-group generator function, the presets through scenes and the command line, and the published
qualitative contrast on the bundled sample (SA-I fires through a hold, RA-I at onset and release)."""

from __future__ import annotations

import json
import re
import textwrap
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from afferent.classes import AFFERENT_CLASSES, DEFAULT_CLASS, afferent_class
from afferent.cli import main
from afferent.scene import SceneError, load_scene, resolve, run_scene
from afferent.scene import parse_scene as _parse
from afferent.scene.schema import SpikesSpec
from afferent.stimulus import adapting_input
from afferent.synthesis import AfferentCurrent

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "sample_sed" / "scenes"
BLOCK = ROOT / "sample_sed" / "block4"
needs_sample = pytest.mark.skipif(not (BLOCK / "series_0p88mm" / "indent.pvd").is_file(), reason="sample not present")


def _current(values, dt=1e-4):
    t = np.arange(len(values)) * dt
    return AfferentCurrent(np.asarray(values, float)[:, None], t, [0.0], ["A0"], "longitudinal")


# ------------------------------------------------------------------ the SA-I input
def test_static_plus_rate_on_a_ramp_and_hold_matches_its_closed_form():
    # ramp at s = 1e-6 A/s for 0.3 s, hold 0.3 s, release at -s: I_in = max(k_s I + k_d r, 0)
    dt, tau, k_s, k_d, s = 1e-4, 8e-3, 0.5, 0.2, 1e-6
    n = 3000
    i = np.concatenate([s * dt * np.arange(n), np.full(n, s * dt * n), s * dt * n - s * dt * np.arange(1, n + 1)])
    out = adapting_input(_current(i, dt), gain=k_d, tau=tau, static_gain=k_s, mode="static-plus-rate")
    assert out.kind == "slowly-adapting" and out.static_gain == k_s and out.off_gain is None
    v = out.values[:, 0]
    # late in the ramp the rate is s (to exp(-30)): k_s I + k_d s (I the sample, held over its interval as the
    # static input is; the rate the interval's mean)
    j = 2500
    assert v[j] == pytest.approx(k_s * i[j] + k_d * s, rel=1e-9)
    # late in the hold the rate has decayed: the static part alone (SA-I fires through the hold)
    assert v[2 * n - 10] == pytest.approx(k_s * i[2 * n - 10], rel=1e-9)
    # the rate term adds k_d s / (k_s I) at the end of the ramp: 0.2 * 1e-6 / (0.5 * 3e-7) = 1.33
    assert v[n - 2] / v[2 * n - 10] == pytest.approx(1 + k_d * s / (k_s * s * dt * n), rel=1e-3)
    # release: max(k_s I - k_d s, 0), rectified at 0 (no offset response)
    assert v[-100] == 0.0 and v.min() >= 0.0


def test_static_plus_rate_is_one_component_of_the_gerling_generator_function():
    # gen_function.py of yw5aj/PlosCompBiol up to its commit 1276cc4 (12 Feb 2016): one component
    # K * conv(k1 exp(-t / tau) + 1 - k1, dI), rectified whole; the same as rectify='sum' with k_s = K (1 - k1),
    # k_d = K k1 tau (docs/classes.md)
    dt, tau, big_k, k1 = 5e-5, 8e-3, 2.0, 0.96
    t = np.arange(0, 0.4, dt)
    i = 1e-9 * np.interp(t, [0, 0.1, 0.3, 0.35, 0.4], [0, 1.0, 1.0, 0.2, 0.2])
    kernel = big_k * (k1 * np.exp(-t / tau) + 1 - k1)
    ref = np.maximum(np.convolve(kernel, np.r_[0, np.diff(i)])[: t.size], 0)
    out = adapting_input(_current(i, dt), gain=big_k * k1 * tau, tau=tau, static_gain=big_k * (1 - k1),
                         mode="static-plus-rate").values[:, 0]
    scale = ref.max()
    # the reference jumps by a step per sample, ours is the mean over it: they differ by O(dt / tau) of the peak
    assert np.max(np.abs(out - ref)) / scale < 2 * dt / tau
    assert out[int(0.25 / dt)] == pytest.approx(big_k * (1 - k1) * 1e-9, rel=1e-6)  # the hold: static only


def _ramp_hold_release(dt, n):
    """A current ramping at 1e-6 A/s for n samples, held n samples, released at -1e-6 A/s (A)."""
    s = 1e-6
    return np.concatenate([s * dt * np.arange(n), np.full(n, s * dt * n), s * dt * n - s * dt * np.arange(1, n + 1)])


def test_rectifying_each_component_keeps_the_static_term_through_the_release():
    # the current gen_function.py (commit d5bb72c of 13 Feb 2016 to the last, 27fec46) rectifies each component:
    # while the current falls the static term k_s I still drives, the rate term is clipped at 0; rectifying the
    # sum (the default) lets the falling rate cancel it: 0 through most of the release
    dt, tau, k_s, k_d, n = 1e-4, 8e-3, 0.5, 0.2, 3000
    i = _ramp_hold_release(dt, n)
    cur = _current(i, dt)
    summed = adapting_input(cur, gain=k_d, tau=tau, static_gain=k_s, mode="static-plus-rate").values[:, 0]
    each = adapting_input(cur, gain=k_d, tau=tau, static_gain=k_s, mode="static-plus-rate",
                          rectify="components").values[:, 0]
    np.testing.assert_array_equal(each[: 2 * n - 1], summed[: 2 * n - 1])  # ramp and hold: no term is negative
    j = 2 * n + n // 2  # mid-release: the rate has settled at -1e-6 A/s
    assert summed[j] == 0.0  # k_s I - k_d s = 0.5 * 1.5e-7 - 2e-7 < 0
    assert each[j] == pytest.approx(k_s * i[j], rel=1e-9)  # the static term alone
    assert any("each component rectified" in note for note in adapting_input(
        cur, gain=k_d, tau=tau, mode="static-plus-rate", rectify="components").notes)


def test_components_with_the_slow_term_match_the_cited_code_by_direct_convolution():
    # the current gen_function.py: sum_c max(k_c conv(exp(-t / tau_c), dI), 0) with tau_1 = 8 ms, tau_2 = 200 ms,
    # tau_3 = inf and fit_model.py's start values k = 1, 0.3, 0.04; in the package's terms k_s = k_3,
    # k_d = k_1 tau_1, slow_gain = k_2 tau_2 (docs/classes.md)
    dt = 5e-5
    t = np.arange(0, 0.8, dt)
    i = 1e-9 * np.interp(t, [0, 0.1, 0.4, 0.5, 0.8], [0, 1.0, 1.0, 0.2, 0.2])
    di = np.r_[0, np.diff(i)]
    ref = sum(np.maximum(np.convolve(k * np.exp(-t / tau), di)[: t.size], 0)
              for k, tau in ((1.0, 8e-3), (0.3, 0.2), (0.04, np.inf)))
    out = adapting_input(_current(i, dt), gain=1.0 * 8e-3, tau=8e-3, static_gain=0.04, mode="static-plus-rate",
                         rectify="components", slow_gain=0.3 * 0.2, slow_tau=0.2).values[:, 0]
    assert np.max(np.abs(out - ref)) / ref.max() < 2 * dt / 8e-3  # a step per sample against the interval's mean
    # the slow term: 0.3 / 0.04 = 7.5 times the static one at a step, left at exp(-0.3 / 0.2) = 0.22 of its
    # end-of-ramp value 0.3 s into the hold
    hold_end = int(0.4 / dt) - 1
    assert out[hold_end] / (0.04 * i[hold_end]) > 1.5


def test_generator_options_apply_to_the_sa1_input_only():
    cur = _current(np.linspace(0, 1e-9, 50))
    with pytest.raises(ValueError, match=re.escape("'rectify' applies to mode='static-plus-rate', not "
                                                   "'rectified-rate'; got rectify='components' instead.")):
        adapting_input(cur, gain=0.1, rectify="components")
    with pytest.raises(ValueError, match=re.escape("'slow_gain' applies to mode='static-plus-rate'")):
        adapting_input(cur, gain=0.1, slow_gain=1.0)
    with pytest.raises(ValueError, match=re.escape("'slow_tau' needs 'slow_gain'")):
        adapting_input(cur, gain=0.1, slow_tau=0.2, mode="static-plus-rate")
    with pytest.raises(ValueError, match="Allowed values are 'sum' and 'components', but got 'each' instead"):
        adapting_input(cur, gain=0.1, rectify="each", mode="static-plus-rate")
    with pytest.raises(SceneError, match=re.escape("[spikes] 'rectify' applies to input = 'slowly-adapting', "
                                                   "not 'static'.")):
        parse_scene(_scene_text('[spikes]\nrectify = "components"\n'))
    with pytest.raises(SceneError, match=re.escape("[spikes] 'slow_tau_s' needs 'slow_gain_s'")):
        parse_scene(_scene_text('[afferent]\nclass = "SA-I"\n[spikes]\nslow_tau_s = 0.2\n'))


def test_static_part_is_measured_from_the_current_of_unloaded_skin():
    # the study's sigmoid gives 0.2 alpha at zero SED: as a sustained input it would fire SA-I afferents at rest
    from afferent.receptors import ReceptorLayout
    from afferent.sampling import ReceptorSED
    from afferent.transduction import STUDY_PARAMS, sigmoid, transduce

    params = STUDY_PARAMS["start"]
    layout = ReceptorLayout(np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0]]))
    t = np.arange(0, 0.2, 1e-3)
    sed = np.outer(np.interp(t, [0, 0.02, 0.07, 0.2], [0, 0, 1, 1]), [200.0, 400.0])  # J/m^3: rest, ramp, hold
    cur = transduce(ReceptorSED(sed, t, layout, "linear", np.zeros(2, bool)), params)
    out = adapting_input(cur, gain=0.2, tau=8e-3, mode="static-plus-rate")
    rest = float(sigmoid(np.zeros(1), params)[0])
    assert rest == pytest.approx(0.2 * params.alpha, rel=0.01)
    np.testing.assert_array_equal(out.values[:19], 0.0)  # unloaded skin: no input
    np.testing.assert_allclose(out.values[-1], cur.values[-1] - rest, rtol=1e-6)  # rate decayed to exp(-16)
    assert any("zero SED" in n for n in out.notes)
    one = adapting_input(transduce(ReceptorSED(sed[-1:], t[-1:], layout, "linear", np.zeros(2, bool)), params), gain=0.2,
                         mode="static-plus-rate")  # a static export: the held state, rate 0
    np.testing.assert_allclose(one.values[0], cur.values[-1] - rest, rtol=1e-12)


def test_adaptation_modes_refuse_the_other_modes_gains():
    cur = _current(np.linspace(0, 1e-9, 50))
    with pytest.raises(ValueError, match=re.escape("'off_gain' applies to mode='rectified-rate', not "
                                                   "'static-plus-rate'")):
        adapting_input(cur, gain=0.1, off_gain=0.05, mode="static-plus-rate")
    with pytest.raises(ValueError, match=re.escape("'static_gain' applies to mode='static-plus-rate', not "
                                                   "'rectified-rate'; got static_gain=1.0 instead.")):
        adapting_input(cur, gain=0.1, static_gain=1.0)
    with pytest.raises(ValueError, match=re.escape("'static_gain' must be >= 0; got -1 instead.")):
        adapting_input(cur, gain=0.1, static_gain=-1, mode="static-plus-rate")
    # default static gain 1: the static current itself is the sustained input
    assert adapting_input(cur, gain=0.0, mode="static-plus-rate").values[-1, 0] == pytest.approx(1e-9)


# ------------------------------------------------------------------ the presets
def parse_scene(text):
    return resolve(_parse(text))


def test_ra_i_preset_is_the_schema_defaults_so_default_runs_are_unchanged():
    preset = AFFERENT_CLASSES[DEFAULT_CLASS].spikes_defaults()
    defaults = {f.name: f.metadata["default"] for f in fields(SpikesSpec)}
    assert DEFAULT_CLASS == "RA-I" and preset and all(defaults[k] == v for k, v in preset.items())
    sa1 = afferent_class("SA-I")
    assert (sa1.input, sa1.lif_preset, sa1.tau_s, sa1.drive, sa1.branching) == ("slowly-adapting", "sa1", 8e-3,
                                                                                "rheobase", "sum")
    from afferent.cli._run import CLASSES

    assert CLASSES == tuple(AFFERENT_CLASSES)  # the command line's choices, kept without importing the package
    with pytest.raises(ValueError, match=re.escape("Allowed values are 'RA-I' and 'SA-I', but got 'SA-X' instead.")):
        afferent_class("SA-X")


def _scene_text(extra: str) -> str:
    return textwrap.dedent(f"""
        [export]
        file = {str(BLOCK / "indent_0p88mm.vtu")!r}
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        file = {str(BLOCK / "receptors.csv")!r}
        [outputs]
        want = ["spikes"]
        """) + textwrap.dedent(extra)


def test_scene_class_fills_what_the_scene_leaves_out_and_records_it():
    from afferent.scene.defaults import class_overrides

    sa = parse_scene(_scene_text('[afferent]\nclass = "SA-I"\n[spikes]\ntau_ms = 20\n'))
    sp = sa.spikes
    assert (sp.input, sp.lif_preset, sp.gain_s, sp.static_gain, sp.drive, sp.rheobase_multiple) == (
        "slowly-adapting", "sa1", 0.2, 1.0, "rheobase", 10.0)
    assert sp.tau_s == pytest.approx(0.02) and class_overrides(sa) == ["tau_s"]  # the scene's key wins, and is said
    # another input than the class's: the class's rate parameters do not apply
    other = parse_scene(_scene_text('[afferent]\nclass = "SA-I"\n[spikes]\ninput = "static"\n')).spikes
    assert (other.input, other.gain_s, other.tau_s, other.static_gain, other.lif_preset) == ("static", None, None,
                                                                                             None, "sa1")
    ra = parse_scene(_scene_text(""))
    assert ra.afferent.afferent_class == "RA-I" and ra.spikes == parse_scene(
        _scene_text('[afferent]\nclass = "RA-I"\n')).spikes
    with pytest.raises(SceneError, match=re.escape("[afferent] 'class' must be one of 'RA-I', 'SA-I'; got 'SA1' "
                                                   "instead.")) as err:
        parse_scene(_scene_text('[afferent]\nclass = "SA1"\n'))
    assert err.value.line is not None
    with pytest.raises(SceneError, match=re.escape("[spikes] 'static_gain' applies to input = 'slowly-adapting', "
                                                   "not 'static'.")):
        parse_scene(_scene_text("[spikes]\nstatic_gain = 2.0\n"))


# ------------------------------------------------------------------ on the sample
def _phase_spikes(trains, lo, hi):
    return [int(np.count_nonzero((t >= lo) & (t < hi))) for t in trains.spike_times]


@pytest.mark.slow  # 3.7 s: two ramp-and-hold runs, the SA-I one sampling a ridge-base grid on the interface
@needs_sample
def test_sa1_fires_through_the_hold_and_ra1_does_not(tmp_path):
    """The published contrast (Knibestöl 1973; Maksimovic et al. 2014; docs/classes.md): under the study's
    ramp-and-hold (ramp 0-0.1 s, hold to 2.1 s, release to 2.2 s), SA-I afferents fire through the hold,
    faster during the ramp, and not at release; RA-I afferents fire at onset and release only."""
    def run(name):
        scene = load_scene(SCENES / name)
        scene = replace(scene, outputs=replace(scene.outputs, want=("spikes",)))
        return run_scene(scene.with_output(tmp_path / name), cache_dir=tmp_path / "cache")

    sa, ra = run("sa1_ramp.toml"), run("spikes_ramp.toml")
    assert sa.record["afferent_class"]["name"] == "SA-I" and sa.record["spikes"]["input"] == "slowly-adapting"
    assert sa.record["receptors"]["site"] == "SA-I" and sa.spikes.n_afferents == 2  # the ridge-base rows under the punch
    assert not [w for w in sa.record["warnings"] if "[afferent] class" in w["message"]]
    assert ra.record["afferent_class"] == {**ra.record["afferent_class"], "name": "RA-I", "overridden": ["input"]}
    late_hold = _phase_spikes(sa.spikes, 1.6, 2.1)
    assert min(late_hold) >= 4  # every SA-I afferent fires in the last 0.5 s of the hold (>= 8 Hz)
    assert _phase_spikes(sa.spikes, 0.0, 0.05) == [0] * sa.spikes.n_afferents  # not before the skin is loaded
    assert _phase_spikes(sa.spikes, 2.12, 2.3) == [0] * sa.spikes.n_afferents  # no offset burst
    for t in sa.spikes.spike_times:  # dynamic > static: instantaneous rate in the ramp above that of the late hold
        ramp_rate = 1 / np.diff(t[t < 0.1]).mean()
        hold_rate = 1 / np.diff(t[(t >= 1.6) & (t < 2.1)]).mean()
        assert ramp_rate > 1.5 * hold_rate
    assert _phase_spikes(ra.spikes, 0.3, 2.1) == [0] * ra.spikes.n_afferents  # RA-I: silent through the hold
    assert min(_phase_spikes(ra.spikes, 0.0, 0.15)) > 0 and min(_phase_spikes(ra.spikes, 2.1, 2.3)) > 0


@pytest.mark.slow  # 4 s: two SA-I ramp-and-hold runs
@needs_sample
def test_sa1_silence_at_release_comes_from_rectifying_the_sum(tmp_path):
    """docs/classes.md: "no SA-I spike follows the release" is the package's choice of rectifying the sum of the
    generator's terms; the cited code rectifies each one (rectify = "components"), and its static term then fires
    the afferents during the release when the hold's last spike falls early enough: hold 2.04 s (release
    2.14-2.24 s) on sa1_ramp.toml, one spike per afferent at 2.160 s."""
    def run(rectify):
        scene = load_scene(SCENES / "sa1_ramp.toml")
        scene = replace(scene, outputs=replace(scene.outputs, want=("spikes",)),
                        stimulus=replace(scene.stimulus, hold_s=2.04),
                        spikes=replace(scene.spikes, rectify=rectify))
        return run_scene(scene.with_output(tmp_path / str(rectify)), cache_dir=tmp_path / "cache")

    summed, each = run(None), run("components")
    assert summed.record["spikes"]["input_params"]["rectify"] == "sum"
    assert each.record["spikes"]["input_params"]["rectify"] == "components"
    assert _phase_spikes(summed.spikes, 2.14, 2.35) == [0, 0]
    assert _phase_spikes(each.spikes, 2.14, 2.24) == [1, 1]
    assert _phase_spikes(each.spikes, 0.0, 2.14) == _phase_spikes(summed.spikes, 0.0, 2.14)  # the same until release


def test_sites_of_another_class_are_said():
    assert afferent_class("SA-I").sites_warning("SA-I") is None and afferent_class("SA-I").sites_warning("file") is None
    assert afferent_class("SA-I").sites_warning("RA-I") == (
        "[afferent] class = 'SA-I' with receptors at the RA-I sites (papilla tips of the epidermis-dermis interface), "
        "not at this class's (bases of the intermediate ridges); give [afferent] class = 'RA-I', or place the "
        "receptors at the SA-I sites.")


@needs_sample
def test_sweep_selects_the_class_and_its_table_says_which(tmp_path):
    from afferent import sweep

    text = (SCENES / "sa1_ramp.toml").read_text().replace('"../block4', f'"{BLOCK}')
    text = text.replace("hold_s = 2.0", "hold_s = 0.3").replace('want = ["spikes", "plots"]', 'want = ["spikes"]')
    (tmp_path / "sw.toml").write_text(text + '\n[sweep]\n"afferent.class" = ["RA-I", "SA-I"]\n')
    table = sweep(tmp_path / "sw.toml", tmp_path / "out", scheduler="serial", use_cache=False).table
    by = table.groupby("afferent.class")["n_spikes"].sum()
    assert set(by.index) == {"RA-I", "SA-I"} and by["RA-I"] > 5 * by["SA-I"] > 0  # RA-I class: static 'ra' input


@needs_sample
def test_cli_class_option_selects_the_preset_and_refuses_what_does_not_apply(capsys, tmp_path):
    base = ["run", str(BLOCK / "indent_0p88mm.vtu"), "--receptors", str(BLOCK / "receptors.csv"), "--length-unit",
            "mm", "--sed-unit", "MPa", "--params", "start", "--spikes", "--no-plots", "--no-cache", "-q"]
    assert main(base + ["--class", "SA-I", "--duration-s", "0.2", "-o", str(tmp_path / "sa")]) == 0
    rec = json.loads((tmp_path / "sa" / "run.json").read_text())
    assert rec["scene"]["afferent"]["afferent_class"] == "SA-I" and rec["afferent_class"]["overridden"] == []
    assert rec["spikes"]["lif"]["r_m"] == 5e9 and rec["spikes"]["drive"]["mapping"] == "rheobase"
    capsys.readouterr()
    assert main(base + ["--static-gain", "2", "-o", str(tmp_path / "bad")]) == 2
    assert capsys.readouterr().err.strip() == ("afferent: error: --static-gain applies to input = 'slowly-adapting', "
                                               "not 'static'.")
