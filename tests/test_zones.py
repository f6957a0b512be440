"""Tests of the ``zones`` branching model: spike-initiation zones (:mod:`afferent.zones`,
``simulate_lif(..., zones=)``).

References, derived by hand from the closed-form membrane potential of a zone between events
(``u = V - v_rest``, drive ``D = r_m I``, ``theta = v_thresh - v_rest``)::

    u(t) = D + (u0 - D) exp(-(t - t0) / tau_m),   T(u0, D) = tau_m ln((D - u0) / (D - theta))

Two zones of one afferent under constant currents start at rest together and are reset
together after every spike, so the zone with the larger drive reaches threshold first every
time: the afferent's train is that zone's own regular train, ``t_1 = T(0, D)``, then every
``t_ref + T(u_reset, D)``, and the slower zone never fires. A zone whose drive jumps later
fires the afferent when its own time to threshold, from the value it has decayed to since
the last common reset, ends before the faster zone's next crossing.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from afferent import spiking
from afferent.receptors import ReceptorLayout
from afferent.spiking import LIF_PRESETS, LIFParams, grid_isi_bounds, simulate_lif
from afferent.synthesis import Branching, synthesize
from afferent.zones import Zones, split_zones

RA = LIF_PRESETS["ra"]
# Non-round values, v_reset != v_rest (a reset zone decays), t_ref not a multiple of anything used.
ODD = LIFParams(tau_m=0.0123, r_m=1.7e6, v_rest=-0.0651, v_thresh=-0.0487, v_reset=-0.0552, t_ref=0.00237)
TOL = 1e-9  # s
EXACT = ["exact-numpy", pytest.param("exact-numba", marks=pytest.mark.skipif(
    not spiking._numba_available(), reason="numba not installed"))]


def T(p: LIFParams, u0: float, drive: float) -> float:
    """Time (s) from u0 to threshold under a constant drive (V above rest)."""
    return p.tau_m * np.log((drive - u0) / (drive - p.theta))


def regular_train(p: LIFParams, current: float, t_end: float, t0: float = 0.0, u0: float = 0.0) -> np.ndarray:
    """Constant current (A) from u0 at t0: first spike after T(u0), then every t_ref + T(u_reset)."""
    d = p.r_m * current
    first, isi = t0 + T(p, u0, d), p.t_ref + T(p, p.v_reset - p.v_rest, d)
    n = int(np.floor((t_end - first) / isi)) + 1 if first < t_end else 0
    return first + isi * np.arange(max(n, 0))


def constant(values, n_times: int) -> np.ndarray:
    return np.repeat(np.atleast_2d(np.asarray(values, dtype=float)), n_times, axis=0)


def rheo(p: LIFParams, k: float) -> float:
    """k rheobases, A."""
    return k * p.rheobase


# --------------------------------------------------------------- closed forms, two zones
@pytest.mark.parametrize("engine", EXACT)
def test_zone_a_alone_gives_a_rate(engine):
    """Zone B silent (0 A): the afferent's train is zone A's regular train, to 1e-9 s."""
    cur = constant([rheo(ODD, 1.7), 0.0], 100)
    tr = simulate_lif(cur, ODD, dt=1e-3, engine=engine, zones=[0, 0])
    np.testing.assert_allclose(tr.spike_times[0], regular_train(ODD, rheo(ODD, 1.7), 0.1), rtol=0, atol=TOL)
    assert tr.spike_times[0].size == 12


@pytest.mark.parametrize("engine", EXACT)
def test_two_equal_zones_are_one_zone(engine):
    """Both zones at the same current: the train of one zone alone (not of the doubled current)."""
    i = rheo(ODD, 2.3)
    tr = simulate_lif(constant([i, i], 80), ODD, dt=1e-3, engine=engine, zones=[0, 0])
    np.testing.assert_allclose(tr.spike_times[0], regular_train(ODD, i, 0.08), rtol=0, atol=TOL)
    summed = simulate_lif(constant([2 * i], 80), ODD, dt=1e-3, engine=engine)
    assert summed.spike_times[0].size > tr.spike_times[0].size  # the sum model fires faster


@pytest.mark.parametrize("engine", EXACT)
def test_slower_zone_is_reset_by_the_faster(engine):
    """A at 3 rheobases, B at 1.5 (fires alone at its own rate): the afferent follows A only."""
    a, b = rheo(ODD, 3.0), rheo(ODD, 1.5)
    tr = simulate_lif(constant([b, a], 200), ODD, dt=1e-3, engine=engine, zones=[0, 0])
    np.testing.assert_allclose(tr.spike_times[0], regular_train(ODD, a, 0.2), rtol=0, atol=TOL)
    alone_b = simulate_lif(constant([b], 200), ODD, dt=1e-3, engine=engine).spike_times[0]
    assert alone_b.size > 0 and not np.isin(np.round(alone_b, 9), np.round(tr.spike_times[0], 9)).any()


@pytest.mark.parametrize("engine", EXACT)
def test_slow_zone_fires_when_its_own_time_to_threshold_is_shorter(engine):
    """A at 1.6 rheobases throughout; B silent until t_b, then 20 rheobases. B fires the afferent
    at t_b + T(u_B(t_b), D_B), u_B decayed from u_reset since A's last spike ended its refractory
    period, before A's next crossing; from there both restart from u_reset and B, faster, leads."""
    p = ODD
    ia, ib, t_b = rheo(p, 1.6), rheo(p, 20.0), 0.033
    dt, n = 5e-4, 160  # t_b = sample 66, inside A's third interval, after its refractory period
    cur = np.zeros((n, 2))
    cur[:, 0] = ia
    cur[int(round(t_b / dt)):, 1] = ib
    tr = simulate_lif(cur, p, dt=dt, engine=engine, zones=[0, 0])
    a_train = regular_train(p, ia, 1.0)
    before = a_train[a_train < t_b]
    s_k = before[-1]
    u_r = p.v_reset - p.v_rest
    u_b = u_r * np.exp(-(t_b - (s_k + p.t_ref)) / p.tau_m)  # B decays from u_reset towards 0 after refractory
    first_b = t_b + T(p, u_b, p.r_m * ib)
    assert first_b < a_train[a_train > t_b][0]  # the scenario: B before A's next crossing
    assert s_k + p.t_ref < t_b
    expected = np.concatenate([before, first_b + (p.t_ref + T(p, u_r, p.r_m * ib)) * np.arange(200)])
    expected = expected[expected < n * dt]
    np.testing.assert_allclose(tr.spike_times[0], expected, rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", EXACT)
def test_afferents_are_independent(engine):
    """Zones of afferent 0 do not reset afferent 1: each follows its own fastest zone."""
    a0, a1 = rheo(ODD, 2.0), rheo(ODD, 4.0)
    cur = constant([a0, 0.5 * a0, 0.0, a1, a1], 100)
    tr = simulate_lif(cur, ODD, dt=1e-3, engine=engine, zones=[0, 0, 1, 1, 1])
    np.testing.assert_allclose(tr.spike_times[0], regular_train(ODD, a0, 0.1), rtol=0, atol=TOL)
    np.testing.assert_allclose(tr.spike_times[1], regular_train(ODD, a1, 0.1), rtol=0, atol=TOL)


# ------------------------------------------------------------------------- properties
@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 30.0), min_size=1, max_size=5), st.sampled_from(["exact-numpy", "exact"]))
def test_constant_zones_follow_the_fastest(multiples, engine):
    """Any number of zones at constant currents (0-30 rheobases): the train of the largest alone."""
    cur = constant([rheo(ODD, k) for k in multiples], 50)
    tr = simulate_lif(cur, ODD, dt=1e-3, engine=engine, zones=np.zeros(len(multiples), int))
    top = max(multiples)
    expected = regular_train(ODD, rheo(ODD, top), 0.05) if top > 1.0 else np.zeros(0)
    np.testing.assert_allclose(tr.spike_times[0], expected, rtol=0, atol=TOL)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["previous", "linear"]))
def test_one_zone_per_afferent_is_the_sum_model(seed, hold):
    """One zone per afferent: the same spikes as the sum model on the same current (to 1e-12 s)."""
    rng = np.random.default_rng(seed)
    cur = rng.uniform(0, 4, size=(30, 3)) * RA.rheobase
    ref = simulate_lif(cur, RA, dt=1e-3, input_hold=hold)
    for engine in ("exact-numpy", "exact"):
        tr = simulate_lif(cur, RA, dt=1e-3, input_hold=hold, engine=engine, zones=[0, 1, 2])
        assert tr.counts.tolist() == ref.counts.tolist()
        np.testing.assert_allclose(tr.t, ref.t, rtol=0, atol=1e-12)


def test_zero_current_never_fires_and_huge_current_is_capped_by_t_ref():
    tr = simulate_lif(np.zeros((20, 3)), ODD, dt=1e-3, zones=[0, 0, 0])
    assert tr.n_spikes.tolist() == [0] and tr.silent_skipped.tolist() == [0]
    huge = simulate_lif(constant([rheo(ODD, 1e6), rheo(ODD, 1e5)], 20), ODD, dt=1e-3, zones=[0, 0])
    isi = np.diff(huge.spike_times[0])
    assert np.all(isi > ODD.t_ref) and np.all(isi < ODD.t_ref * (1 + 1e-4))
    np.testing.assert_allclose(huge.spike_times[0], regular_train(ODD, rheo(ODD, 1e6), 0.02), rtol=0, atol=TOL)


def test_numba_and_python_agree_on_random_input():
    if not spiking._numba_available():
        pytest.skip("numba not installed")
    rng = np.random.default_rng(5)
    cur = rng.uniform(0, 3, size=(200, 12)) * RA.rheobase
    zones = np.repeat(np.arange(4), 3)
    for hold in ("previous", "linear"):
        a = simulate_lif(cur, RA, dt=1e-3, engine="exact-numpy", zones=zones, input_hold=hold)
        b = simulate_lif(cur, RA, dt=1e-3, engine="exact-numba", zones=zones, input_hold=hold)
        assert (a.backend, b.backend) == ("python", "numba")
        assert a.counts.tolist() == b.counts.tolist() and a.n_spikes.sum() > 20
        np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------- grid engine
def test_fast_engine_one_zone_per_afferent_matches_the_grid_sum_model_step_for_step():
    rng = np.random.default_rng(2)
    cur = rng.uniform(0, 4, size=(40, 5)) * RA.rheobase
    ref = simulate_lif(cur, RA, dt=1e-4, engine="fast-numpy", times=np.arange(40) * 1e-3)
    tr = simulate_lif(cur, RA, dt=1e-4, engine="fast", times=np.arange(40) * 1e-3, zones=np.arange(5))
    assert tr.engine == "fast" and tr.backend == "numpy"
    np.testing.assert_array_equal(tr.t, ref.t)
    np.testing.assert_array_equal(tr.counts, ref.counts)


def test_fast_engine_zones_within_the_grid_bounds_of_the_closed_form():
    """Two zones, constant: every grid interval lies within grid_isi_bounds of the faster zone."""
    a, b = rheo(ODD, 2.5), rheo(ODD, 1.4)
    dt = 1e-4
    tr = simulate_lif(constant([b, a], 200), ODD, dt=dt, engine="fast", times=np.arange(200) * 1e-3, zones=[0, 0])
    lo, hi = grid_isi_bounds(ODD, a, dt=dt)
    isi = np.diff(tr.spike_times[0])
    assert isi.size > 10 and np.all(isi >= float(lo) - 1e-12) and np.all(isi <= float(hi) + 1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("dt", [1e-4, 5e-5, 2e-5, 1e-5])
def test_brian2_zones_give_the_fast_engines_spikes_step_for_step(dt):
    """brian2: a neuron per zone, a delay-free Synapses resetting the afferent's other zones; the fast
    engine's spikes, step for step (two equal zones crossing in one step are one spike), at the
    docs' recommended steps below 0.1 ms too: the Synapses ran on brian2's default 0.1 ms clock
    until issue 32 (up to 15 of 18 spikes 1-5 steps late at dt <= 70 us)."""
    pytest.importorskip("brian2")
    rng = np.random.default_rng(1)
    cur = np.concatenate([rng.uniform(0, 3, size=(40, 7)), np.full((40, 2), 2.5)], axis=1) * RA.rheobase
    zones = [0, 0, 0, 1, 1, 2, 2, 3, 3]
    kw = dict(dt=dt, times=np.arange(40) * 1e-3, zones=zones)
    fast = simulate_lif(cur, RA, engine="fast", **kw)
    b2 = simulate_lif(cur, RA, engine="brian2", **kw)
    assert (b2.engine, b2.backend) == ("brian2", "brian2-numpy") and fast.n_spikes.min() > 3
    np.testing.assert_array_equal(b2.counts, fast.counts)
    np.testing.assert_array_equal(np.rint(b2.t / dt), np.rint(fast.t / dt))  # the same steps
    np.testing.assert_array_equal(fast.spike_times[3], simulate_lif(cur[:, [7]], RA, engine="fast", dt=dt,
                                                                    times=np.arange(40) * 1e-3).spike_times[0])


def test_exact_zones_are_the_limit_of_the_grid_on_time_varying_input():
    """Piecewise-constant random zone currents (1-4 rheobases, 1 ms samples): the fast engine at
    dt = 2 us fires the same number of spikes, each within 25 steps (50 us) of the exact one (a grid
    spike is stamped up to a step early and t_ref counts from there, so the gaps add up over a
    train; intervals here are 2-4 ms)."""
    rng = np.random.default_rng(11)
    cur = rng.uniform(1.0, 4.0, size=(30, 5)) * RA.rheobase
    zones = [0, 0, 0, 1, 1]
    exact = simulate_lif(cur, RA, dt=1e-3, zones=zones)
    dt = 2e-6
    grid = simulate_lif(cur, RA, dt=dt, engine="fast", times=np.arange(30) * 1e-3, zones=zones)
    assert exact.counts.tolist() == grid.counts.tolist() and exact.n_spikes.min() > 5
    for te, tg in zip(exact.spike_times, grid.spike_times):
        assert np.abs(te - tg).max() <= 25 * dt


# ------------------------------------------------------------------------- errors
def test_zones_errors_are_named():
    cur = constant([1e-6, 1e-6], 5)
    with pytest.raises(ValueError, match=r"'zones' must give one afferent index \(int\) per column of the current \(2\)"):
        simulate_lif(cur, RA, dt=1e-3, zones=[0, 0, 1])
    with pytest.raises(ValueError, match=r"'zones' must be non-decreasing afferent indices >= 0"):
        simulate_lif(cur, RA, dt=1e-3, zones=[1, 0])
    with pytest.raises(ValueError, match=r"input_hold='linear' needs engine='exact'"):
        simulate_lif(cur, RA, dt=1e-3, engine="fast", zones=[0, 0], input_hold="linear")


# ------------------------------------------------------------------------- forming zones
def _strip(n_x: int = 2, n_z: int = 7) -> ReceptorLayout:
    """Receptors on a 0.44 mm x 0.22 mm grid, n_x longitudinal sections of n_z."""
    g = np.stack(np.meshgrid(np.arange(n_x) * 4.4e-4, [0.0], np.arange(n_z) * 2.2e-4, indexing="ij"), -1)
    return ReceptorLayout(g.reshape(-1, 3)[::-1].copy())  # reversed: the split must sort by position


def test_split_zones_partitions_each_afferent_along_it():
    layout = _strip()
    b = Branching.longitudinal(layout)
    z = split_zones(b, layout, 3)
    assert isinstance(z, Zones) and z.rule == "split:3 along z"
    assert z.branching.afferent_ids.tolist() == ["L0/z0", "L0/z1", "L0/z2", "L1/z0", "L1/z1", "L1/z2"]
    assert z.branching.receptor_counts.tolist() == [3, 2, 2, 3, 2, 2]
    assert z.afferent.tolist() == [0, 0, 0, 1, 1, 1]
    for row in range(z.n_zones):  # contiguous along z, z0 at the smallest z
        w = z.branching.weights
        zs = layout.positions[w.indices[w.indptr[row]:w.indptr[row + 1]], 2]
        assert np.ptp(zs) <= 2.2e-4 * 2 + 1e-12
    first = layout.positions[w.indices[w.indptr[0]:w.indptr[1]], 2]
    np.testing.assert_allclose(np.sort(first), [0.0, 2.2e-4, 4.4e-4])
    # every connection in exactly one zone of its afferent: zone currents sum to the afferent's
    cur = np.random.default_rng(0).uniform(size=(4, layout.n_receptors)) * 1e-8
    zc = synthesize(cur, z.branching).values
    ac = synthesize(cur, b).values
    np.testing.assert_allclose(zc[:, :3].sum(1), ac[:, 0], rtol=1e-14)
    np.testing.assert_allclose(zc[:, 3:].sum(1), ac[:, 1], rtol=1e-14)
    assert z.record() == {"rule": "split:3 along z", "n_zones": 6, "zones_per_afferent": [3, 3],
                          "receptors_per_zone": [2, 3]}


def test_split_zones_cross_sections_split_along_x_and_more_zones_than_receptors():
    layout = _strip(3, 2)
    z = split_zones(Branching.cross(layout), layout, 5)
    assert z.rule == "split:5 along x" and z.zones_per_afferent.tolist() == [3, 3]
    assert z.branching.receptor_counts.tolist() == [1] * 6
    one = split_zones(Branching.cross(layout), layout, 1)
    np.testing.assert_array_equal(one.branching.weights.toarray(), Branching.cross(layout).weights.toarray())


def test_split_zones_errors():
    layout = _strip()
    b = Branching.longitudinal(layout)
    with pytest.raises(ValueError, match=r"'zones_per_afferent' must be >= 1; got 0 instead"):
        split_zones(b, layout, 0)
    with pytest.raises(TypeError, match=r"'zones_per_afferent' must be an int; got 2.5 instead"):
        split_zones(b, layout, 2.5)
    with pytest.raises(TypeError, match=r"'branching' must be a Branching; got ndarray instead"):
        split_zones(np.zeros(3), layout, 2)
    with pytest.raises(ValueError, match=r"'layout' must have the branching's 14 receptors; got 4 instead"):
        split_zones(b, _strip(2, 2), 2)


# ------------------------------------------------------------------------- scene and CLI
def test_cli_branching_zones_is_recorded_and_sum_stays_the_default(tmp_path, capsys):
    from afferent.cli import main
    from afferent.cli._demo import packaged_sample_dir

    b4 = packaged_sample_dir() / "block4"
    base = ["run", str(b4 / "indent_0p88mm.vtu"), "--receptors", str(b4 / "receptors.csv"),
            "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start", "--spikes", "--no-plots", "--no-cache",
            "--drive", "rheobase", "--rheobase-multiple", "4", "--duration-s", "0.05"]
    assert main(base + ["-q", "-o", str(tmp_path / "sum")]) == 0
    assert main(base + ["--branching", "zones", "--zones-per-afferent", "2", "-o", str(tmp_path / "zones")]) == 0
    assert "input, zones: 14 zones, 2 per afferent)" in capsys.readouterr().err  # the one-screen summary
    rs = json.loads((tmp_path / "sum" / "run.json").read_text())
    rz = json.loads((tmp_path / "zones" / "run.json").read_text())
    assert rs["spikes"]["branching"] == "sum" and "zones" not in rs["spikes"]
    assert rz["spikes"]["branching"] == "zones" and rz["scene"]["spikes"]["zones_per_afferent"] == 2
    assert rz["spikes"]["zones"] == {"rule": "split:2 along z", "n_zones": 14, "zones_per_afferent": [2, 2],
                                     "receptors_per_zone": [8, 9]}
    # one scale for both models: the reference is the largest afferent (summed) current
    assert rz["spikes"]["drive"]["reference_current_a"] == pytest.approx(rs["spikes"]["drive"]["reference_current_a"],
                                                                        rel=1e-12)
    assert sum(rz["spikes"]["drive"]["rate_hz"]) < sum(rs["spikes"]["drive"]["rate_hz"])
    assert main(base + ["--zones-per-afferent", "2", "-o", str(tmp_path / "bad")]) == 2
    assert "afferent: error: --zones-per-afferent applies to --branching zones" in capsys.readouterr().err


def test_scene_zones_per_afferent_checked_and_defaulted(tmp_path):
    from afferent.scene import SceneError, parse_scene, resolve

    text = ('[export]\nfile = "x.vtu"\nlength_unit = "mm"\nsed_unit = "MPa"\n[receptors]\nfile = "r.csv"\n'
            '[outputs]\nwant = ["spikes"]\n[spikes]\nbranching = "zones"\n')
    sp = resolve(parse_scene(text, base_dir=str(tmp_path))).spikes
    assert (sp.branching, sp.zones_per_afferent) == ("zones", 4)
    assert resolve(parse_scene(text.replace('branching = "zones"', ""), base_dir=str(tmp_path))).spikes.branching == "sum"
    with pytest.raises(SceneError, match=r"\[spikes\] 'zones_per_afferent' must be >= 1 .*got 0 instead"):
        resolve(parse_scene(text + "zones_per_afferent = 0\n", base_dir=str(tmp_path)))
    with pytest.raises(SceneError, match=r"'branching'.*one of 'sum', 'zones'"):
        resolve(parse_scene(text.replace('"zones"', '"max"'), base_dir=str(tmp_path)))


def test_sweep_sweeps_the_branching_model_like_any_key(tmp_path):
    """"spikes.branching" = ["sum", "zones"] in a sweep: one column, each task run as its scene would."""
    from pathlib import Path

    import pandas as pd

    from afferent._sweep import sweep

    scenes = Path(__file__).resolve().parents[1] / "sample_sed" / "scenes"
    base = (scenes / "sweep_gamma.toml").read_text().split("[sweep]")[0].replace('"../', f'"{scenes.parent.as_posix()}/')
    base = base.replace("hold_s = 2.0", "hold_s = 0.1").replace("tau_ms = 5.0", "tau_ms = 5.0\nzones_per_afferent = 2")
    src = tmp_path / "s.toml"
    src.write_text(base + '[sweep]\n"spikes.branching" = ["sum", "zones"]\n')
    res = sweep(src, tmp_path / "out", scheduler="serial", use_cache=False)
    t = res.table
    assert sorted(t["spikes.branching"].unique()) == ["sum", "zones"] and res.n_failed == 0
    by = {m: t[t["spikes.branching"] == m].n_spikes.to_numpy() for m in ("sum", "zones")}
    assert by["sum"].sum() > 0 and not np.array_equal(by["sum"], by["zones"])
    one = tmp_path / "one.toml"
    one.write_text(base.replace("tau_ms = 5.0", 'tau_ms = 5.0\nbranching = "zones"'))
    from afferent.cli import main

    assert main(["run", str(one), "-o", str(tmp_path / "one"), "--quiet", "--no-cache"]) == 0
    ref = pd.read_csv(tmp_path / "one" / "spike_summary.csv")
    np.testing.assert_array_equal(by["zones"], ref.n_spikes.to_numpy())


def test_python_api_run_spikes_with_zones_records_them(tmp_path, sample_sed_dir):
    """run_pipeline -> split_zones -> run_spikes(zones=): the result carries its zones and their record."""
    from afferent import read_sed
    from afferent.pipeline import run_pipeline, run_spikes
    from afferent.receptors import read_receptors
    from afferent.transduction import STUDY_PARAMS

    b4 = sample_sed_dir / "block4"
    layout = read_receptors(b4 / "receptors.csv", length_unit="mm")
    res = run_pipeline(read_sed(b4 / "indent_1p32mm.vtu", length_unit="mm", sed_unit="MPa"), layout,
                       STUDY_PARAMS["start"])
    zones = split_zones(res.branching, layout, 4)
    out = run_spikes(res, RA, dt=1e-4, duration=0.05, drive="rheobase", rheobase_multiple=8, zones=zones)
    assert out.zones is zones and out.input.values.shape == (1, 28) and out.spikes.n_afferents == 7
    # the rheobase scale is taken from the summed afferent current: the sum model's own scale
    ref = run_spikes(res, RA, dt=1e-4, duration=0.05, drive="rheobase", rheobase_multiple=8)
    assert out.drive["scale"] == pytest.approx(ref.drive["scale"], rel=1e-12)
    assert np.all(out.spikes.n_spikes <= ref.spikes.n_spikes) and out.spikes.n_spikes.sum() > 0
    assert out.zones.record()["n_zones"] == 28
    other = split_zones(Branching.cross(layout), layout, 2)
    with pytest.raises(ValueError, match=r"'zones' must divide the afferents of the result's branching"):
        run_spikes(res, RA, dt=1e-4, duration=0.05, zones=other)


def test_zones_from_map_groups_each_afferents_receptors_by_label(tmp_path):
    from afferent.zones import zones_from_map

    layout = _strip(2, 4)  # ids '0'..'7'; L0: the x = 0 line
    b = Branching.longitudinal(layout)
    ids = layout.ids.tolist()
    labels = {r: ("tip" if layout.positions[j, 2] < 3e-4 else "base") for j, r in enumerate(ids)}
    path = tmp_path / "zones.csv"
    path.write_text("receptor,zone\n" + "".join(f"{r},{labels[r]}\n" for r in ids) + "99,tip\n")
    z = zones_from_map(b, path)
    # zones in the order their labels first appear in the map (receptor '0' is at the largest z: 'base')
    assert z.rule == "map" and z.branching.afferent_ids.tolist() == ["L0/base", "L0/tip", "L1/base", "L1/tip"]
    assert z.record()["map_rows_unused"] == 1 and z.branching.receptor_counts.tolist() == [2, 2, 2, 2]
    cur = np.random.default_rng(3).uniform(size=(2, 8)) * 1e-8
    zc, ac = synthesize(cur, z.branching).values, synthesize(cur, b).values
    np.testing.assert_allclose(zc[:, :2].sum(1), ac[:, 0], rtol=1e-14)
    for j, rid in enumerate(ids):  # every receptor in the zone of its label
        w = z.branching.weights
        row = next(k for k in range(z.n_zones) if j in w.indices[w.indptr[k]:w.indptr[k + 1]])
        assert z.branching.afferent_ids[row].endswith("/" + labels[rid])
    path.write_text("receptor,zone\n0,a\n1,a\n")
    with pytest.raises(ValueError, match=r"Zone map '.*zones.csv': 6 receptor\(s\) of the branching have no zone: "
                                         r"'2', '3', '4', '5', '6', \.\.\."):
        zones_from_map(b, path)
    path.write_text("receptor,zone\n0,a\n0,b\n")
    with pytest.raises(ValueError, match=r"receptor '0' is listed more than once"):
        zones_from_map(b, path)
    path.write_text("receptor,group\n0,a\n")
    from afferent.exceptions import SEDFormatError

    with pytest.raises(SEDFormatError, match=r"must have columns 'receptor' and 'zone'; missing 'zone'"):
        zones_from_map(b, path)


def test_cli_zone_map_runs_and_conflicts_are_errors(tmp_path, capsys):
    from afferent.cli import main
    from afferent.cli._demo import packaged_sample_dir
    from afferent.receptors import read_receptors

    b4 = packaged_sample_dir() / "block4"
    layout = read_receptors(b4 / "receptors.csv", length_unit="mm")
    zmap = tmp_path / "zones.csv"
    zmap.write_text("receptor,zone\n" + "".join(f"{r},{'near' if abs(z - 1.9e-3) < 0.5e-3 else 'far'}\n"
                                                for r, z in zip(layout.ids, layout.positions[:, 2])))
    base = ["run", str(b4 / "indent_0p88mm.vtu"), "--receptors", str(b4 / "receptors.csv"), "--length-unit", "mm",
            "--sed-unit", "MPa", "--params", "start", "--spikes", "--no-plots", "--no-cache", "-q", "--drive",
            "rheobase", "--rheobase-multiple", "4", "--duration-s", "0.05", "--branching", "zones"]
    assert main(base + ["--zone-map", str(zmap), "-o", str(tmp_path / "m")]) == 0
    rec = json.loads((tmp_path / "m" / "run.json").read_text())
    assert rec["spikes"]["zones"]["rule"] == "map" and rec["spikes"]["zones"]["n_zones"] == 14
    assert str(zmap) in rec["inputs"]
    capsys.readouterr()
    assert main(base + ["--zone-map", str(zmap), "--zones-per-afferent", "2", "-o", str(tmp_path / "bad")]) == 2
    assert "give --zone-map (each receptor's zone) or --zones-per-afferent" in capsys.readouterr().err


@pytest.mark.parametrize("text, message", [
    ("receptor,zone\n0,a\n1,\n2,b\n", "Zone map '{path}': 1 row(s) have an empty 'zone' cell (the first on data row 2, "
                                      "receptor '1'); give every receptor its id and a zone label."),
    ("receptor,zone\n0,a\n,b\n", "Zone map '{path}': 1 row(s) have an empty 'receptor' cell (the first on data row 2); "
                                 "give every receptor its id and a zone label."),
])
def test_an_empty_zone_cell_is_not_a_zone_of_its_own(tmp_path, text, message):
    """Issue 33, item 13. Before: the receptors with an empty zone cell made one more zone (labelled ''): 5 zones
    instead of 4, and other spikes, without a word. A DataFrame's missing value (NaN) was the zone 'nan'."""
    import pandas as pd

    from afferent.zones import zones_from_map

    b = Branching.longitudinal(_strip(2, 4))
    path = tmp_path / "zones.csv"
    path.write_text(text + "".join(f"{r},a\n" for r in range(3, 8)))
    with pytest.raises(ValueError, match=re.escape(message.format(path=path))):
        zones_from_map(b, path)
    frame = pd.DataFrame({"receptor": [str(r) for r in range(8)], "zone": ["a", None] + ["b"] * 6})
    with pytest.raises(ValueError, match=re.escape("Zone map: 1 row(s) have an empty 'zone' cell (the first on data "
                                                   "row 2, receptor '1')")):
        zones_from_map(b, frame)
