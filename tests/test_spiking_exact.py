"""Tests of the exact (event-driven) engine of :mod:`afferent.spiking`.

References: spike times derived by hand from the closed-form membrane potential between
samples (``u = V - v_rest``, drive ``D = r_m I``)::

    u(t) = D + (u0 - D) exp(-(t - t0) / tau_m),   T(u0, D) = tau_m ln((D - u0) / (D - theta))

checked to 1e-9 s; the grid engines' documented bounds (``grid_isi_bounds``); and properties
that hold for every input (no spike below the rheobase, intervals >= t_ref, ...).
"""

from __future__ import annotations

import re
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from afferent import spiking
from afferent.spiking import LIF_PRESETS, LIFParams, grid_isi_bounds, simulate_lif

RA = LIF_PRESETS["ra"]
# Non-round values, v_reset != v_rest, t_ref not a multiple of anything used here.
ODD = LIFParams(tau_m=0.0123, r_m=1.7e6, v_rest=-0.0651, v_thresh=-0.0487, v_reset=-0.0552, t_ref=0.00237)
TOL = 1e-9  # s, hand-derived spike times
BACKENDS = ["exact-numpy", pytest.param("exact-numba", marks=pytest.mark.skipif(
    not spiking._numba_available(), reason="numba not installed"))]


def T(p: LIFParams, u0: float, drive: float) -> float:
    """Time from u0 (V above rest) to threshold under a constant drive r_m I (V), in s."""
    return p.tau_m * np.log((drive - u0) / (drive - p.theta))


def decay(p: LIFParams, u0: float, drive: float, dt: float) -> float:
    """u after dt under a constant drive, from u0 (both V above rest)."""
    return drive + (u0 - drive) * np.exp(-dt / p.tau_m)


def u_reset(p: LIFParams) -> float:
    return p.v_reset - p.v_rest


def regular_train(p: LIFParams, current: float, t0: float, t_end: float) -> np.ndarray:
    """Closed form for a constant current from rest at t0: t1 = t0 + T(0), then every t_ref + T(u_reset)."""
    d = p.r_m * current
    first, isi = t0 + T(p, 0.0, d), p.t_ref + T(p, u_reset(p), d)
    n = int(np.floor((t_end - first) / isi)) + 1 if first < t_end else 0
    return first + isi * np.arange(max(n, 0))


def constant(values, n_times):
    return np.repeat(np.atleast_2d(np.asarray(values, dtype=float)), n_times, axis=0)


# ---------------------------------------------------------------------------------------------
# Hand-derived spike times
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", BACKENDS)
@pytest.mark.parametrize("params", [RA, ODD], ids=["ra", "odd"])
@pytest.mark.parametrize("sampling", ["one-sample", "every-1ms", "irregular"])
def test_constant_current_first_spike_and_every_interval(engine, params, sampling):
    """t1 = T(v_rest); ISI = t_ref + T(v_reset), however the constant current is sampled."""
    multiples = np.array([1.05, 1.5, 3.0, 10.0, 100.0])
    current = multiples * params.rheobase
    duration = 0.2
    if sampling == "one-sample":
        kw = dict(times=np.array([0.0]), duration=duration)
        values = constant(current, 1)
    elif sampling == "every-1ms":
        kw = dict(times=np.arange(200) * 1e-3)
        values = constant(current, 200)
    else:
        t = np.cumsum(np.random.default_rng(3).uniform(1e-5, 3e-3, 400))
        t = np.concatenate([[0.0], t[t < duration]])
        kw = dict(times=t, duration=duration)
        values = constant(current, t.size)
    trains = simulate_lif(values, params, engine=engine, **kw)
    assert trains.engine == "exact" and trains.dt == 0.0 and trains.duration == pytest.approx(duration)
    for k, train in enumerate(trains.spike_times):
        expected = regular_train(params, current[k], 0.0, duration)
        assert expected.size >= 3
        assert train.size == expected.size, (k, train.size, expected.size)
        np.testing.assert_allclose(train, expected, rtol=0, atol=TOL)
    # the same closed forms as LIFParams
    np.testing.assert_allclose([t[0] for t in trains.spike_times], params.first_spike_latency(current), atol=TOL)
    np.testing.assert_allclose([np.diff(t).mean() for t in trains.spike_times], params.steady_isi(current), atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_step_change_mid_approach(engine):
    """3 x rheobase, then at t_s (between spikes, not refractory) 7 x: from the state at t_s."""
    p = ODD
    d1, d2 = 3 * p.theta, 7 * p.theta
    first = regular_train(p, d1 / p.r_m, 0.0, 1.0)
    t_last = first[1]
    t_s = t_last + p.t_ref + 0.4 * T(p, u_reset(p), d1)  # 40 % of the way to the next spike
    u_s = decay(p, u_reset(p), d1, t_s - t_last - p.t_ref)
    t_next = t_s + T(p, u_s, d2)
    isi2 = p.t_ref + T(p, u_reset(p), d2)
    expected = np.concatenate([first[:2], t_next + isi2 * np.arange(4)])
    times = np.array([0.0, t_s])
    trains = simulate_lif(np.array([[d1], [d2]]) / p.r_m, p, engine=engine, times=times, duration=expected[-1] + 1e-4)
    np.testing.assert_allclose(trains.spike_times[0], expected, rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_step_change_during_refractoriness_is_ignored_until_it_ends(engine):
    """A change while refractory takes effect at the end of t_ref, from v_reset."""
    p = ODD
    d1, d2 = 3 * p.theta, 1.2 * p.theta
    t1 = T(p, 0.0, d1)
    t_s = t1 + 0.5 * p.t_ref
    t2 = t1 + p.t_ref + T(p, u_reset(p), d2)
    trains = simulate_lif(np.array([[d1], [d2]]) / p.r_m, p, engine=engine, times=np.array([0.0, t_s]),
                          duration=t2 + 1e-4)
    np.testing.assert_allclose(trains.spike_times[0], [t1, t2], rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_drop_below_rheobase_mid_approach_no_spike(engine):
    """3 x rheobase, then 0.9 x before the next crossing: u tends to 0.9 theta, never fires again."""
    p = RA
    d1 = 3 * p.theta
    first = regular_train(p, d1 / p.r_m, 0.0, 1.0)
    t_s = first[2] + p.t_ref + 0.9 * T(p, u_reset(p), d1)
    trains = simulate_lif(np.array([[d1], [0.9 * p.theta]]) / p.r_m, p, engine=engine, times=np.array([0.0, t_s]),
                          duration=2.0)
    np.testing.assert_allclose(trains.spike_times[0], first[:3], rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_refractory_period_spanning_several_samples(engine):
    """t_ref = 3.5 ms over 1 ms samples: what arrives while refractory (+-1000 x rheobase) is ignored;
    integration resumes at t1 + t_ref mid-sample from v_reset and crosses in a later sample."""
    p = replace(RA, t_ref=3.5e-3)
    th = p.theta
    drives = np.array([20, 1000, -1000, 2, 4, 4, 4, 4, 4, 4]) * th
    times = np.arange(drives.size) * 1e-3
    t1 = T(p, 0.0, drives[0])
    tr = t1 + p.t_ref  # in [3, 4) ms
    assert 3e-3 < tr < 4e-3
    u4 = decay(p, u_reset(p), drives[3], 4e-3 - tr)
    t2 = 4e-3 + T(p, u4, drives[4])
    assert 4e-3 < t2 < 5e-3 + p.t_ref
    expected = [t1, t2, t2 + p.t_ref + T(p, u_reset(p), drives[4])]
    trains = simulate_lif(drives[:, None] / p.r_m, p, engine=engine, times=times, duration=10e-3)
    np.testing.assert_allclose(trains.spike_times[0], expected, rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_zero_negative_and_negative_then_positive(engine):
    """Zero and negative currents never fire (skipped); after a negative pulse V starts below rest."""
    p = ODD
    t_neg = 2e-3
    d_neg, d_pos = -4 * p.theta, 2.5 * p.theta
    u1 = decay(p, 0.0, d_neg, t_neg)
    t1 = t_neg + T(p, u1, d_pos)
    values = np.array([[0.0, d_neg, d_neg], [0.0, d_neg, d_pos]]) / p.r_m
    trains = simulate_lif(values, p, engine=engine, times=np.array([0.0, t_neg]), duration=t1 + 1e-4)
    assert trains.silent_skipped.tolist() == [0, 1]
    assert trains.n_spikes.tolist() == [0, 0, 1]
    assert trains.spike_times[2][0] == pytest.approx(t1, abs=TOL)
    assert trains.spike_times[2][0] > t_neg + T(p, 0.0, d_pos)  # later than from rest


@pytest.mark.parametrize("engine", BACKENDS)
def test_threshold_reachable_only_asymptotically(engine):
    """D = theta exactly: V tends to threshold and never reaches it, even over 1e4 tau_m; D a hair above
    theta crosses at the (late) closed-form time."""
    p = RA
    i_exact = p.theta / p.r_m
    assert p.r_m * i_exact == p.theta  # the drive is theta in floating point too
    # a short supra-threshold pulse (too short to fire) keeps the afferent from being skipped as silent
    pulse = 0.5 * T(p, 0.0, 3 * p.theta)
    values = np.array([[3 * i_exact, 3 * i_exact], [i_exact, i_exact * (1 + 1e-9)]])
    duration = 1e4 * p.tau_m
    trains = simulate_lif(values, p, engine=engine, times=np.array([0.0, pulse]), duration=duration)
    assert trains.silent_skipped.size == 0
    assert trains.n_spikes[0] == 0
    d = p.r_m * values[1, 1]
    u_p = decay(p, 0.0, 3 * p.theta, pulse)
    np.testing.assert_allclose(trains.spike_times[1][:1], [pulse + T(p, u_p, d)], rtol=0, atol=1e-8)
    assert trains.spike_times[1][0] > 10 * p.tau_m


@pytest.mark.parametrize("engine", BACKENDS)
def test_t_ref_of_a_thousand_tau_m_and_pieces_longer_than_the_decay_underflow(engine):
    """tau_m = 1 ms, t_ref = 1 s (exp(t_ref / tau_m) overflows), samples 0.7 s apart (the decay over a
    piece underflows to 0): still the closed form, spike after spike, to 1e-9 s."""
    p = LIFParams(tau_m=1e-3, r_m=1e6, v_rest=-0.07, v_thresh=-0.05, v_reset=-0.06, t_ref=1.0)
    current = np.array([1.5, 40.0]) * p.rheobase
    times = np.arange(8) * 0.7
    trains = simulate_lif(constant(current, 8), p, engine=engine, times=times, duration=5.6)
    for k, train in enumerate(trains.spike_times):
        expected = regular_train(p, current[k], 0.0, 5.6)
        assert expected.size == 6
        np.testing.assert_allclose(train, expected, rtol=0, atol=TOL)


@pytest.mark.parametrize("engine", BACKENDS)
def test_window_start_end_and_duration(engine):
    """Spikes lie in [t_start, t_start + duration): a crossing at or after the end is not reported;
    shorter and longer durations agree with the full run (the last sample is held)."""
    p = RA
    cur = constant([3 * p.rheobase], 10)
    t0 = 0.5
    times = t0 + np.arange(10) * 1e-3
    full = simulate_lif(cur, p, engine=engine, times=times, duration=0.05)
    expected = t0 + regular_train(p, 3 * p.rheobase, 0.0, 0.05)
    np.testing.assert_allclose(full.spike_times[0], expected, rtol=0, atol=TOL)
    assert full.t_start == t0 and full.duration == pytest.approx(0.05)
    cut = expected[2] - t0  # a window ending exactly at the third crossing time
    short = simulate_lif(cur, p, engine=engine, times=times, duration=cut)
    assert short.n_spikes[0] == 2
    np.testing.assert_allclose(short.spike_times[0], expected[:2], rtol=0, atol=TOL)
    default = simulate_lif(cur, p, engine=engine, times=times)  # up to one interval past the last sample
    assert default.duration == pytest.approx(0.01)


def test_dt_is_ignored_with_times_and_the_sample_interval_without():
    p = ODD
    rng = np.random.default_rng(0)
    cur = rng.uniform(0, 4, (300, 6)) * p.rheobase
    times = np.arange(300) * 1e-3
    a = simulate_lif(cur, p, engine="exact", times=times)
    for dt in (1e-4, 0.37e-3):
        b = simulate_lif(cur, p, engine="exact", times=times, dt=dt)
        assert all(np.array_equal(x, y) for x, y in zip(a.spike_times, b.spike_times))
    c = simulate_lif(cur, p, engine="exact", dt=1e-3)  # ndarray without times: sample k at k dt
    assert all(np.array_equal(x, y) for x, y in zip(a.spike_times, c.spike_times))
    assert repr(a).endswith("engine 'exact' (" + a.backend + "), no grid>")


# ---------------------------------------------------------------------------------------------
# Linear input between samples
# ---------------------------------------------------------------------------------------------


def u_linear(p, u0, d0, s, y):
    """u at y after t0 under the drive d0 + s y (closed form)."""
    return d0 + s * y - s * p.tau_m + (u0 - d0 + s * p.tau_m) * np.exp(-y / p.tau_m)


@pytest.mark.parametrize("engine", BACKENDS)
def test_linear_ramp_from_rest_crosses_where_the_closed_form_says(engine):
    """A ramp 0 -> 10 x rheobase over 20 ms: u(t_s) = theta at the reported time and u < theta before."""
    p = RA
    slope = 10 * p.theta / 20e-3  # V/s of drive
    values = np.array([[0.0], [10 * p.rheobase]])
    trains = simulate_lif(values, p, engine=engine, times=np.array([0.0, 20e-3]), duration=20e-3,
                          input_hold="linear")
    ts = trains.spike_times[0]
    assert ts.size >= 2 and any("linearly" in n for n in trains.notes)
    np.testing.assert_allclose(u_linear(p, 0.0, 0.0, slope, ts[0]), p.theta, rtol=1e-12)
    y = np.linspace(0, ts[0], 1000)[:-1]
    assert np.all(u_linear(p, 0.0, 0.0, slope, y) < p.theta)
    # after the first spike: from u_reset at ts[0] + t_ref, drive continuing along the ramp
    tr = ts[0] + p.t_ref
    d_tr = slope * tr
    np.testing.assert_allclose(u_linear(p, u_reset(p), d_tr, slope, ts[1] - tr), p.theta, rtol=1e-12)


@pytest.mark.parametrize("engine", BACKENDS)
def test_linear_falling_drive_peak_just_below_and_just_above_threshold(engine):
    """A falling drive from the start: V rises, peaks and falls (concave). The peak is found in closed
    form: a peak a hair below threshold gives no spike, a hair above gives one before the peak."""
    p = RA
    tau = p.tau_m
    d0, h = 3 * p.theta, 10e-3
    results = {}
    for name, d1 in (("below", None), ("above", None)):
        # bisect d1 (drive at the piece's end) so the peak sits at theta (1 -/+ 1e-6)
        target = p.theta * (1 - 1e-6 if name == "below" else 1 + 1e-6)

        def peak(d_end):
            s = (d_end - d0) / h
            c = 0.0 - d0 + s * tau
            ystar = tau * np.log(c / (s * tau))
            return d0 + s * ystar if 0 < ystar < h else -np.inf

        lo, hi = -50 * p.theta, 2.9 * p.theta
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if peak(mid) < target else (lo, mid)
        d1 = lo if name == "below" else hi
        values = np.array([[d0], [d1]]) / p.r_m
        trains = simulate_lif(values, p, engine=engine, times=np.array([0.0, h]), duration=h, input_hold="linear")
        results[name] = (trains, d1)
    assert results["below"][0].n_spikes[0] == 0
    trains, d1 = results["above"]
    assert trains.n_spikes[0] == 1
    s = (d1 - d0) / h
    ts = trains.spike_times[0][0]
    np.testing.assert_allclose(u_linear(p, 0.0, d0, s, ts), p.theta, rtol=1e-12)
    assert ts < tau * np.log((0.0 - d0 + s * tau) / (s * tau))  # before the peak


@pytest.mark.parametrize("engine", BACKENDS)
def test_linear_converges_to_finely_held_samples(engine):
    """The linear input against the held engine on the same current resampled every 1 us (an
    independent code path): spike times within a few us."""
    p = ODD
    rng = np.random.default_rng(11)
    times = np.arange(21) * 5e-3
    cur = rng.uniform(0.0, 5.0, (21, 5)) * p.rheobase
    lin = simulate_lif(cur, p, engine=engine, times=times, input_hold="linear", duration=0.1)
    fine_t = np.arange(100_000) * 1e-6
    fine = np.stack([np.interp(fine_t, times, cur[:, k]) for k in range(5)], axis=1)
    held = simulate_lif(fine, p, engine=engine, times=fine_t, duration=0.1)
    assert int(lin.n_spikes.sum()) > 20
    for a, b in zip(lin.spike_times, held.spike_times):
        assert a.size == b.size
        np.testing.assert_allclose(a, b, rtol=0, atol=5e-6)


def test_linear_with_equal_samples_is_the_held_result():
    p = ODD
    cur = constant([2.0 * p.rheobase, 7 * p.rheobase], 40)
    times = np.arange(40) * 1e-3
    a = simulate_lif(cur, p, engine="exact", times=times, input_hold="linear")
    b = simulate_lif(cur, p, engine="exact", times=times)
    assert all(np.array_equal(x, y) for x, y in zip(a.spike_times, b.spike_times))


# ---------------------------------------------------------------------------------------------
# Grid engines converge to the exact one
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("params", [RA, ODD], ids=["ra", "odd"])
def test_grid_engines_converge_to_exact_within_their_bounds(params):
    """Constant currents: the exact ISI is the closed form, the grid ISI obeys grid_isi_bounds, so
    |ISI_grid - ISI_exact| < 2 dt, and first spikes are stamped up to dt early."""
    current = np.array([1.05, 1.5, 3.0, 10.0, 100.0]) * params.rheobase
    exact = simulate_lif(constant(current, 1), params, engine="exact", times=[0.0], duration=0.2)
    isi_exact = np.array([np.diff(t).mean() for t in exact.spike_times])
    errors = []
    for dt in (1e-3, 1e-4, 1e-5):
        grid = simulate_lif(constant(current, 1), params, engine="fast", dt=dt, duration=0.2)
        lo, hi = grid_isi_bounds(params, current, dt=dt)
        isi_grid = np.array([np.diff(t).mean() for t in grid.spike_times])
        assert np.all((isi_grid >= lo - TOL) & (isi_grid < hi + TOL))
        assert np.all(np.abs(isi_grid - isi_exact) < 2 * dt + TOL)
        first_exact = np.array([t[0] for t in exact.spike_times])
        first_grid = np.array([t[0] for t in grid.spike_times])
        assert np.all((first_grid <= first_exact + TOL) & (first_grid > first_exact - dt - TOL))
        errors.append(np.max(np.abs(isi_grid - isi_exact)))
    assert errors[0] > errors[1] > errors[2]


def test_grid_rates_converge_to_exact_on_a_ramp_and_hold():
    """Time-varying input (ramp-and-hold, 1 ms samples): spike-count error against exact shrinks with dt;
    where dt is small against the shortest interval (t_ref + T(v_reset) at the peak) it is within the
    per-interval grid bound: each interval short by < 2 dt, so n_grid - n_exact <= n_exact 2 dt / (ISI_min - 2 dt) + 2."""
    p = RA
    times = np.arange(301) * 1e-3
    amp = np.array([1.3, 3.0, 10.0, 60.0]) * p.rheobase
    shape = np.clip(times / 0.05, 0, 1) - np.clip((times - 0.2) / 0.05, 0, 1)
    cur = shape[:, None] * amp
    exact = simulate_lif(cur, p, engine="exact", times=times)
    n_exact = exact.n_spikes
    prev = np.inf
    for dt in (1e-3, 1e-4, 1e-5):
        grid = simulate_lif(cur, p, engine="fast", dt=dt, times=times)
        err = np.abs(grid.n_spikes - n_exact)
        isi_min = p.steady_isi(amp)
        if dt <= 1e-4:
            assert np.all(err <= n_exact * 2 * dt / (isi_min - 2 * dt) + 2), (dt, err)
        total = err.sum() / n_exact.sum()
        assert total <= prev
        prev = total
    assert prev < 0.01


# ---------------------------------------------------------------------------------------------
# Back ends, buffers, errors
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("hold", ["previous", "linear"])
@pytest.mark.parametrize("spacing", [2e-3, 20e-3], ids=["samples-below-t_ref", "several-spikes-per-sample"])
def test_numba_and_numpy_backends_agree_including_buffer_regrowth(monkeypatch, hold, spacing):
    pytest.importorskip("numba")
    rng = np.random.default_rng(5)
    p = ODD
    cur = rng.uniform(-1.0, 6.0, (400, 30)) * p.rheobase
    times = np.cumsum(rng.uniform(0.1 * spacing, spacing, 400))
    a = simulate_lif(cur, p, engine="exact-numpy", times=times, input_hold=hold)
    b = simulate_lif(cur, p, engine="exact-numba", times=times, input_hold=hold)
    assert (a.backend, b.backend) == ("numpy", "numba") and int(a.n_spikes.sum()) > 500
    for x, y in zip(a.spike_times, b.spike_times):
        assert x.size == y.size
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)
    monkeypatch.setattr(spiking._exact, "_exact_capacity", lambda peak, pc, params: 1)  # resume after every spike
    c = simulate_lif(cur, p, engine="exact-numba", times=times, input_hold=hold)
    assert all(np.array_equal(x, y) for x, y in zip(b.spike_times, c.spike_times))
    assert spiking._exact._exact_threads(1999) == 1  # small runs stay on one thread
    monkeypatch.setattr(spiking._exact, "_exact_threads", lambda n: 3)  # afferents split over 3 threads
    d = simulate_lif(cur, p, engine="exact-numba", times=times, input_hold=hold)
    assert all(np.array_equal(x, y) for x, y in zip(b.spike_times, d.spike_times))


def test_exact_numba_without_numba_raises(monkeypatch):
    monkeypatch.setattr(spiking, "_numba_available", lambda: False)
    msg = (
        "engine='exact-numba' needs numba, which is not installed. "
        "Install it with pip install 'afferent-skin[fast]', or use engine='exact'."
    )
    with pytest.raises(ImportError, match=re.escape(msg)):
        simulate_lif(constant([1e-6], 5), RA, dt=1e-4, engine="exact-numba")
    assert simulate_lif(constant([1e-6], 5), RA, dt=1e-4).backend == "numpy"


def test_auto_takes_numba_only_when_it_repays_its_import(monkeypatch):
    """'exact' runs small simulations on numpy (importing numba costs 0.4-1 s, more than a small
    scene's whole simulation), large ones on numba: by the workload alone, never by whether numba
    happens to be imported (before: it was, and a scene's spike times differed in their last bits
    between a fresh process and one that had imported numba)."""
    import sys

    monkeypatch.delitem(sys.modules, "numba", raising=False)
    assert not spiking._numba_repays(23_000, 3)          # the bundled ramp scene: ~0.24 s on numpy
    import importlib.util

    assert spiking._numba_repays(100_000, 12_500) == (importlib.util.find_spec("numba") is not None)  # ~31 s on numpy
    # bench_spiking's workload: 0.64 s on numpy, 0.17 s on numba + 0.54 s to load it (issue 23)
    assert spiking._numba_repays(1_001, 12_500) == (importlib.util.find_spec("numba") is not None)
    monkeypatch.setitem(sys.modules, "numba", object())   # imported already: the same choice
    assert not spiking._numba_repays(10, 1) and not spiking._numba_repays(23_000, 3)


def test_auto_is_exact():
    trains = simulate_lif(constant([3 * RA.rheobase], 5), RA, dt=1e-3)
    assert trains.engine == "exact" and trains.dt == 0.0


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        (
            {"engine": "exact"},
            "'dt' must be given with engine='exact' for an ndarray current without 'times': it is the sample "
            "interval in s (sample k at k dt); got None instead. Or pass 'times'.",
        ),
        (
            {"engine": "exact", "times": [0.0]},
            "'duration' must be given with engine='exact' for a current of a single sample (or 'dt', its sample "
            "interval); got None instead.",
        ),
        ({"engine": "fast"}, "'dt' must be given with engine='fast': it is the time step in s; got None instead."),
        (
            {"times": [1e10], "duration": 1e-10},
            "'duration' must be large enough to change t_start = 10000000000.0 s in double precision; got 1e-10 s "
            "instead.",
        ),
        (
            {"engine": "brian2", "dt": 1e-4, "input_hold": "linear"},
            "input_hold='linear' needs engine='exact': the grid engines hold each sample, as brian2's TimedArray "
            "does; got engine='brian2' instead.",
        ),
        (
            {"input_hold": "nearest", "dt": 1e-4},
            "Invalid value for the 'input_hold' parameter. Allowed values are 'previous' and 'linear', but got "
            "'nearest' instead.",
        ),
        (
            {"engine": "exact", "dt": 1e-3, "params": replace(RA, t_ref=0.0), "current": np.array([[1e250]])},
            "The exact engine cannot resolve the inter-spike interval: t_ref + the time from v_reset to threshold at "
            "the peak drive is 4.47e-260 s, at or below the time resolution 1.73e-18 s of the window [0.0, 0.001] s; "
            "got t_ref = 0.0 s. Give t_ref > 0 or a smaller current.",
        ),
    ],
)
def test_errors(kwargs, msg):
    call = {"current": np.zeros((1, 2)), "params": RA, **kwargs}
    current, params = call.pop("current"), call.pop("params")
    with pytest.raises(ValueError, match=re.escape(msg)):
        simulate_lif(current, params, **call)


# ---------------------------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    fraction=st.floats(min_value=0.0, max_value=1.0, exclude_max=True),
    u_frac=st.floats(min_value=1e-3, max_value=0.999),
    preset=st.sampled_from(["ra", "sa1"]),
    engine=st.sampled_from(["exact-numpy", "exact"]),
)
def test_property_no_spike_below_rheobase(fraction, u_frac, preset, engine):
    """Any constant current below theta / r_m never fires, from any V below threshold. The afferent is
    first brought to u_frac theta by a pulse too short to fire (so it is simulated, not skipped)."""
    p = LIF_PRESETS[preset]
    big = 2.0 * p.theta
    pulse = -p.tau_m * np.log1p(-u_frac / 2.0)  # u = big (1 - exp(-pulse / tau)) = u_frac theta
    values = np.array([[big], [fraction * p.theta]]) / p.r_m
    trains = simulate_lif(values, p, engine=engine, times=np.array([0.0, pulse]), duration=pulse + 50 * p.tau_m)
    assert trains.n_spikes[0] == 0
    skipped = simulate_lif(values[1:], p, engine=engine, times=[0.0], duration=1.0)
    assert skipped.silent_skipped.tolist() == [0] and skipped.n_spikes[0] == 0


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    low=st.floats(min_value=-12.0, max_value=-6.0),
    high=st.floats(min_value=-7.0, max_value=2.0),
    hold=st.sampled_from(["previous", "linear"]),
    preset=st.sampled_from(["ra", "sa1", "odd"]),
)
# numpy and numba 3.6e-12 s apart (found by hypothesis; the same before issue 23's kernel): a drive
# just above threshold turns the back ends' 1-ulp differences in u into picoseconds
@example(seed=65629, low=-10.408105282836404, high=0.0, hold="previous", preset="sa1")
def test_property_intervals_at_least_t_ref_and_rate_bounded(seed, low, high, hold, preset):
    """Random sample times and currents over 14 decades (10 % negative): spike times increasing, in the
    window, separated by >= t_ref + T(v_reset) at the peak drive (>= t_ref), so the rate <= 1 / t_ref;
    numba and numpy agree; no floating-point warning."""
    p = ODD if preset == "odd" else LIF_PRESETS[preset]
    rng = np.random.default_rng(seed)
    n = 80
    times = 0.3 + np.cumsum(rng.uniform(1e-5, 4e-3, n))
    exponents = rng.uniform(min(low, high), max(low, high), (n, 6))
    cur = rng.choice([-1.0, 1.0], (n, 6), p=[0.1, 0.9]) * 10.0**exponents
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        trains = simulate_lif(cur, p, engine="exact-numpy", times=times, input_hold=hold)
    duration = trains.duration
    peak = cur.max(axis=0)
    isi_min = p.steady_isi(peak)
    for k, t in enumerate(trains.spike_times):
        assert np.all((t >= trains.t_start) & (t < trains.t_start + duration))
        d = np.diff(t)
        assert np.all(d > 0)
        assert np.all(d >= p.t_ref - 1e-12) and np.all(d >= isi_min[k] * (1 - 1e-9) - 1e-12)
        assert t.size <= duration / p.t_ref + 1
        if p.r_m * peak[k] <= p.theta:
            assert t.size == 0 and k in trains.silent_skipped
    if spiking._numba_available():
        other = simulate_lif(cur, p, engine="exact-numba", times=times, input_hold=hold)
        for a, b in zip(trains.spike_times, other.spike_times):
            assert a.size == b.size
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-11)


# ---------------------------------------------------------------------------------------------
# Speed (issue 23): the afferent-by-afferent kernel keeps the spikes bit for bit; flat spikes
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("hold, n", [("previous", 95301), ("linear", 95581)])
def test_exact_numba_spikes_as_before_the_afferent_by_afferent_kernel(hold, n):
    """bench_spiking --quick's workload (1,250 afferents x 0.2 s) against its stored reference
    (tests/data/golden/exact_quick.npz; its script states the origin): every afferent's count
    exactly (the totals are the sample-by-sample kernel's before issue 23) and the spike times of
    every 10th afferent to 1e-12 relative. Not bits: the bits of exp/log differ between CPUs
    (an sha256 of the times failed on every CPU without AVX-512, issue 32); the tolerance is
    1,000 x the numpy back end's distance (7.8e-15), and a kernel whose t_ref is off by 1 ns
    (1e-6 relative) fails it. The numpy back end agrees in the same process."""
    pytest.importorskip("numba")
    from afferent.report import synthetic_afferent_current

    ref = np.load(Path(__file__).parent / "data" / "golden" / "exact_quick.npz")
    times, cur = synthetic_afferent_current(1250, duration=0.2)
    res = simulate_lif(cur, RA, engine="exact-numba", times=times, duration=0.2, input_hold=hold)
    assert int(res.counts.sum()) == n
    np.testing.assert_array_equal(res.counts, ref[f"{hold}_counts"])
    np.testing.assert_allclose(np.concatenate(res.spike_times[::10]), ref[f"{hold}_times"], rtol=1e-12, atol=0)
    other = simulate_lif(cur, RA, engine="exact-numpy", times=times, duration=0.2, input_hold=hold)
    np.testing.assert_array_equal(other.counts, res.counts)
    np.testing.assert_allclose(other.t, res.t, rtol=1e-12, atol=0)


def test_spikes_are_flat_arrays_with_per_afferent_views():
    """As brian2's SpikeMonitor: t (s) and i (afferent) flat; here grouped by afferent, each in
    time order; spike_times and train(k) are views into t; statistics from the flat arrays agree
    with the per-afferent definitions."""
    rng = np.random.default_rng(3)
    cur = rng.uniform(-1.0, 4.0, (300, 40)) * ODD.rheobase
    res = simulate_lif(cur, ODD, dt=1e-3, engine="exact")
    assert res.t.shape == res.i.shape == (int(res.counts.sum()),) and res.counts.shape == (40,)
    assert np.array_equal(np.bincount(res.i, minlength=40), res.counts)
    for k in range(40):
        train = res.train(k)
        assert np.shares_memory(train, res.t) or train.size == 0
        assert np.array_equal(train, res.spike_times[k]) and np.all(np.diff(train) > 0)
        assert np.array_equal(res.t[res.i == k], train)
    assert not res.t.flags.writeable and not res.spike_times[3].flags.writeable
    peak = [1.0 / np.diff(t).min() if t.size >= 2 else 0.0 for t in res.spike_times]
    np.testing.assert_array_equal(res.peak_rate(), peak)
    first = [t[0] - res.t_start if t.size else np.nan for t in res.spike_times]
    np.testing.assert_array_equal(res.first_spike_latency(), first)
    inside = [np.count_nonzero((t >= 0.05) & (t < 0.2)) / 0.15 for t in res.spike_times]
    np.testing.assert_allclose(res.rates_between(0.05, 0.2), inside, rtol=1e-15)
    rebuilt = spiking.SpikeTrains.from_trains(res.spike_times, afferent_ids=res.afferent_ids, duration=res.duration,
                                             dt=res.dt, engine=res.engine, backend=res.backend,
                                             silent_skipped=res.silent_skipped, params=res.params)
    assert np.array_equal(rebuilt.t, res.t) and np.array_equal(rebuilt.counts, res.counts)
    with pytest.raises(ValueError, match=r"'counts' must be one spike count per afferent summing to the number of "
                                         r"spike times 3; got shape \(2,\) summing to 2 instead\."):
        spiking.SpikeTrains(t=[0.1, 0.2, 0.3], counts=[1, 1], afferent_ids=[0, 1], duration=1.0, dt=0.0,
                            engine="exact", backend="numpy", silent_skipped=[], params=ODD)


@pytest.mark.slow
def test_the_compiled_exact_kernel_is_cached_on_disk_for_the_next_process(tmp_path):
    """numba compiles the exact kernel once; a fresh process loads it from the cache (issue 23:
    the first run of a process must not pay the compile, 3-8 s on the development machine)."""
    import os
    import subprocess
    import sys

    pytest.importorskip("numba")
    code = (
        "import numpy as np; from afferent.spiking import simulate_lif, LIF_PRESETS; from afferent.spiking import _exact\n"
        "simulate_lif(np.full((3, 2), 1e-4), LIF_PRESETS['ra'], dt=1e-3, engine='exact-numba')\n"
        "s = _exact._numba_exact().stats; print(len(s.cache_hits), len(s.cache_misses))"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout.split()
            for _ in range(2)]
    assert runs == [["0", "1"], ["1", "0"]]  # compiled and saved, then loaded
    assert any(name.endswith(".nbi") for _, _, files in os.walk(tmp_path) for name in files)


def test_used_peak_is_the_max_over_the_used_samples_without_a_second_pass():
    """issue 23: the exact engine's peak per afferent (over the samples its pieces use) comes from
    the input's extremes and the unused last samples; it equals the plain max over the used rows."""
    from afferent.spiking._exact import _pieces, _used_peak

    rng = np.random.default_rng(23)
    n_times, n_aff = 41, 64
    times = np.arange(n_times) * 1e-3
    for k in range(12):
        current = rng.uniform(0.0, 1e-6, (n_times, n_aff))
        hot = rng.choice(n_aff, k * 5 % n_aff, replace=False)
        current[-1, hot] = 2e-6  # the largest value in the last sample only
        current[-3:, :3] = 3e-6  # ... or also in a used one
        current[:, 5] = 1e-7  # constant: the largest value everywhere
        for duration, hold in ((0.041, "previous"), (0.040, "previous"), (0.0385, "previous"),
                               (0.040, "linear"), (0.0385, "linear"), (0.041, "linear")):
            pc = _pieces(current, None, duration, times, 1e-2, hold)
            used = int(pc.nxt[-1]) + 1 if hold == "linear" else pc.starts.size
            np.testing.assert_array_equal(_used_peak(pc, hold), current[:used].max(axis=0), err_msg=f"{k} {duration} {hold}")
