"""Tests of stage 6, :mod:`afferent.spiking` (LIF neuron): the grid engines (brian2, fast) and shared parts.

The exact engine has its own file, ``test_spiking_exact.py``.

brian2 runs here use its ``numpy`` code-generation target (nothing is compiled), so each
takes well under 5 s and none is marked ``slow``.
"""

from __future__ import annotations

import re
import subprocess
import sys
import warnings
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from afferent import spiking
from afferent.exceptions import AfferentWarning
from afferent.spiking import LIF_PRESETS, LIFParams, SpikeTrains, grid_isi_bounds, simulate_lif

# brian2 2.9 calls pyparsing's camelCase API, deprecated in pyparsing 3.3: not ours to fix.
pytestmark = pytest.mark.filterwarnings(
    "ignore:.*deprecated - use:DeprecationWarning", "ignore:.*argument is deprecated, use:DeprecationWarning"
)

RA = LIF_PRESETS["ra"]
# Non-round values, v_reset != v_rest and a t_ref that is not a multiple of 0.1 ms or 1 ms.
ODD = LIFParams(tau_m=0.0123, r_m=1.7e6, v_rest=-0.0651, v_thresh=-0.0487, v_reset=-0.0552, t_ref=0.00237)
ENGINES_ALL = ["fast-numpy", "fast", "brian2"]
DTS = [1e-3, 1e-4, 1e-5]
# Floating-point slack on times that are whole multiples of dt (t = k dt exactly, compared to
# closed forms evaluated once in double precision).
TIME_SLACK = 1e-9


def constant(values, n_times):
    """(n_times, n_afferents) array holding each value of ``values`` constant."""
    return np.repeat(np.atleast_2d(np.asarray(values, dtype=float)), n_times, axis=0)


def n_eff(params, dt):
    return max(spiking._refractory_steps(params.t_ref, dt), 1)


def same_spikes(a: SpikeTrains, b: SpikeTrains) -> bool:
    return len(a.spike_times) == len(b.spike_times) and all(
        np.array_equal(x, y) for x, y in zip(a.spike_times, b.spike_times)
    )


# ---------------------------------------------------------------------------------------------
# Closed form within the derived grid bound
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("dt", DTS)
@pytest.mark.parametrize(
    "params, engine",
    [(RA, e) for e in ENGINES_ALL] + [(ODD, "fast-numpy"), (ODD, "fast")],  # brian2 on ODD: see agreement tests
    ids=[f"ra-{e}" for e in ENGINES_ALL] + ["odd-fast-numpy", "odd-fast"],
)
def test_constant_current_matches_closed_form_within_grid_bound(params, engine, dt):
    """First spike and every ISI against the closed forms, within the derived dt bounds.

    Bounds (module docstring of afferent.spiking): T0 - dt <= t_1 < T0;
    (n_eff - 1) dt + T_r <= ISI_grid < (n_eff - 1) dt + T_r + dt; ISI - 2dt < ISI_grid < ISI + dt.
    """
    multiples = np.array([1.05, 1.5, 3.0, 10.0, 100.0])
    current = multiples * params.rheobase
    duration = 0.1
    trains = simulate_lif(constant(current, 1), params, dt=dt, engine=engine, duration=duration)
    assert trains.silent_skipped.size == 0

    t0 = params.first_spike_latency(current)
    isi = params.steady_isi(current)
    lo, hi = grid_isi_bounds(params, current, dt=dt)
    for k, train in enumerate(trains.spike_times):
        assert train.size >= 3, f"afferent {k}: too few spikes to test"
        assert t0[k] - dt - TIME_SLACK <= train[0] < t0[k] + TIME_SLACK
        intervals = np.diff(train)
        assert np.all((intervals >= lo[k] - TIME_SLACK) & (intervals < hi[k] + TIME_SLACK)), (k, intervals, lo[k])
        assert np.all((intervals > isi[k] - 2 * dt - TIME_SLACK) & (intervals < isi[k] + dt + TIME_SLACK))
        # constant current, reset to the same V: every interval is the same whole number of steps
        np.testing.assert_allclose(intervals, intervals[0], rtol=0, atol=TIME_SLACK)
        rate = 1.0 / intervals.mean()
        assert 1.0 / (isi[k] + dt) - 1e-6 < rate
        if isi[k] > 2 * dt:
            assert rate < 1.0 / (isi[k] - 2 * dt) + 1e-6


def test_closed_form_rate_values():
    """The closed form itself: 1 / (t_ref + tau ln(RI / (RI - theta))) with reset to rest."""
    p = LIFParams(tau_m=0.01, r_m=1e7, v_rest=-0.07, v_thresh=-0.05, v_reset=-0.07, t_ref=0.002)
    i = np.array([0.0, 1e-9, 2e-9, 4e-9, 1e-6])
    expected = np.array([0.0, 0.0, 0.0, 1.0 / (0.002 + 0.01 * np.log(2.0)), 1.0 / (0.002 + 0.01 * np.log(10 / 9.98))])
    np.testing.assert_allclose(p.steady_rate(i), expected, rtol=1e-12)
    assert p.rheobase == pytest.approx(2e-9, rel=1e-12)
    assert np.isinf(p.first_spike_latency(2e-9))


def test_sa1_preset_closed_form_fast_engine():
    """The SA-I set (tau 150 ms, rheobase 6 pA) follows the same closed form."""
    p = LIF_PRESETS["sa1"]
    assert p.tau_m == pytest.approx(0.15)
    assert p.rheobase == pytest.approx(6e-12)
    current = np.array([1.5, 4.0]) * p.rheobase
    dt = 1e-4
    trains = simulate_lif(constant(current, 1), p, dt=dt, duration=1.0, engine="fast")
    lo, hi = grid_isi_bounds(p, current, dt=dt)
    for k, train in enumerate(trains.spike_times):
        d = np.diff(train)
        assert d.size >= 2 and np.all((d >= lo[k] - TIME_SLACK) & (d < hi[k] + TIME_SLACK))


# ---------------------------------------------------------------------------------------------
# brian2 (reference) vs fast engine: spike for spike
# ---------------------------------------------------------------------------------------------


def _random_case(mode: str, params: LIFParams, dt: float, seed: int):
    rng = np.random.default_rng(seed)
    n_times, n_aff = 1200, 40
    top = 40.0 if params.tau_m > 0.05 else 4.0  # slow membranes need more drive to fire often
    scale = params.rheobase * rng.uniform(0.3, top, (1, n_aff))
    current = rng.uniform(0.0, 1.0, (n_times, n_aff)) * scale
    kwargs = {}
    if mode == "coarse":  # FE-like samples every 7 steps, not starting at 0
        kwargs["times"] = 0.25 + np.arange(n_times) * 7 * dt
    elif mode == "irregular":
        kwargs["times"] = 0.01 + np.cumsum(rng.uniform(0.5, 3.0, n_times)) * dt
    return current, kwargs


@pytest.mark.parametrize(
    "mode, params, dt",
    [
        ("per-step", RA, 1e-4),
        ("per-step", ODD, 1e-4),
        ("coarse", replace(ODD, t_ref=0.0), 2.5e-4),
        ("irregular", LIF_PRESETS["sa1"], 1e-4),
        ("per-step", RA, 1e-3),
    ],
    ids=["ra-per-step", "odd-per-step", "tref0-coarse", "sa1-irregular", "ra-dt1ms"],
)
def test_brian2_and_fast_engines_agree_spike_for_spike(mode, params, dt):
    current, kwargs = _random_case(mode, params, dt, seed=20240611)
    ref = simulate_lif(current, params, dt=dt, engine="brian2", **kwargs)
    assert ref.engine == "brian2" and ref.backend == "brian2-numpy"
    assert int(ref.n_spikes.sum()) > 50
    for engine in ("fast", "fast-numpy"):
        fast = simulate_lif(current, params, dt=dt, engine=engine, **kwargs)
        assert same_spikes(fast, ref), engine
        np.testing.assert_array_equal(fast.silent_skipped, ref.silent_skipped)
        assert fast.duration == ref.duration and fast.t_start == ref.t_start


def test_brian2_leaves_global_codegen_target_alone():
    from afferent.spiking._brian2 import import_brian2

    brian2 = import_brian2()
    before = brian2.prefs.codegen.target
    simulate_lif(constant([3 * RA.rheobase], 50), RA, dt=1e-4, engine="brian2")
    assert brian2.prefs.codegen.target == before


def test_import_does_not_import_brian2():
    """One subprocess smoke test: ``import afferent.spiking`` must not pull in brian2 (or numba)."""
    code = "import sys, afferent.spiking; print('brian2' in sys.modules, 'numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


# ---------------------------------------------------------------------------------------------
# Fast engine: numba and numpy back ends are identical
# ---------------------------------------------------------------------------------------------


def test_numba_and_numpy_backends_identical_including_buffer_regrowth(monkeypatch):
    pytest.importorskip("numba")
    current, kwargs = _random_case("per-step", RA, 1e-4, seed=5)
    a = simulate_lif(current, RA, dt=1e-4, engine="fast-numpy")
    b = simulate_lif(current, RA, dt=1e-4, engine="fast-numba")
    assert (a.backend, b.backend) == ("numpy", "numba")
    assert same_spikes(a, b)
    # Smallest spike buffer allowed: forces the numba loop to stop and resume many times.
    monkeypatch.setattr(spiking._grid, "_capacity_guess", lambda peak, plan, params, n_ref: peak.size)
    c = simulate_lif(current, RA, dt=1e-4, engine="fast-numba")
    assert same_spikes(a, c)


def test_fast_numba_without_numba_raises(monkeypatch):
    monkeypatch.setattr(spiking, "_numba_available", lambda: False)
    msg = (
        "engine='fast-numba' needs numba, which is not installed. "
        "Install it with pip install 'afferent-skin[fast]', or use engine='fast'."
    )
    with pytest.raises(ImportError, match=re.escape(msg)):
        simulate_lif(constant([1e-6], 5), RA, dt=1e-4, engine="fast-numba")
    assert simulate_lif(constant([1e-6], 5), RA, dt=1e-4, engine="fast").backend == "numpy"


# ---------------------------------------------------------------------------------------------
# Silence, saturation, degenerate shapes
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ["exact", "fast", "brian2"])
def test_below_rheobase_is_silent_and_skipped(engine):
    current = np.array([0.0, -5e-7, 0.999 * RA.rheobase, (1 - 1e-9) * RA.rheobase, 2 * RA.rheobase])
    trains = simulate_lif(constant(current, 400), RA, dt=1e-4, engine=engine)
    assert trains.silent_skipped.tolist() == [0, 1, 2, 3]
    assert trains.n_spikes[:4].tolist() == [0, 0, 0, 0] and trains.n_spikes[4] > 0
    table = trains.summary()
    assert table["simulated"].tolist() == [False, False, False, False, True]
    assert table["first_spike_latency_s"].isna().tolist() == [True, True, True, True, False]


def test_silent_skip_uses_only_the_simulated_window():
    """A pulse after ``duration`` does not make an afferent 'not silent'."""
    current = np.zeros((100, 1))
    current[80:] = 5 * RA.rheobase
    assert simulate_lif(current, RA, dt=1e-4, duration=50e-4).silent_skipped.tolist() == [0]
    assert simulate_lif(current, RA, dt=1e-4).silent_skipped.tolist() == []


@pytest.mark.parametrize("engine", ["fast-numpy", "fast", "brian2"])
@pytest.mark.parametrize("dt", [1e-3, 1e-4])
def test_huge_current_rate_bounded_by_refractory_no_overflow(engine, dt):
    # numpy floating-point errors raise (np.errstate) and RuntimeWarnings are errors; brian2's
    # own pyparsing DeprecationWarnings are not what this test is about.
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error", RuntimeWarning)
        trains = simulate_lif(constant([1e3, 1e3], 300), RA, dt=dt, engine=engine)
    steps = n_eff(RA, dt)
    for train in trains.spike_times:
        np.testing.assert_allclose(np.diff(train), steps * dt, rtol=0, atol=TIME_SLACK)
        assert train[0] == 0.0
    # 1 / t_ref is the ceiling when t_ref is a whole number of steps (dt = 0.1 ms); at 1 ms
    # brian2's rounding makes the refractory period 1 step, so the ceiling is 1 / dt.
    ceiling = 1.0 / (steps * dt)
    assert np.all(trains.rates() <= ceiling * (1 + 1e-9))
    if dt == 1e-4:
        assert np.all(trains.rates() <= 1.0 / RA.t_ref * (1 + 1e-9))


def test_zero_current_everything_empty():
    trains = simulate_lif(np.zeros((50, 3)), RA, dt=1e-4)
    assert trains.n_spikes.tolist() == [0, 0, 0]
    assert trains.silent_skipped.tolist() == [0, 1, 2]
    np.testing.assert_array_equal(trains.rates(), 0.0)
    assert np.all(np.isnan(trains.first_spike_latency()))
    rate, edges = trains.psth(1e-3)
    np.testing.assert_array_equal(rate, 0.0)
    assert edges[0] == 0.0 and edges[-1] == pytest.approx(50e-4)
    assert trains.to_dataframe().shape == (0, 2)


def test_one_afferent():
    trains = simulate_lif(constant([2 * RA.rheobase], 300), RA, dt=1e-4)
    assert trains.n_afferents == 1 and trains.afferent_ids.tolist() == [0]
    assert trains.n_spikes[0] == len(trains.spike_times[0]) > 0


@pytest.mark.parametrize("engine", ["fast", "fast-numpy", "brian2"])
def test_n_times_one(engine):
    trains = simulate_lif(np.array([[0.0, 1e3, 0.5 * RA.rheobase]]), RA, dt=1e-4, engine=engine)
    assert trains.duration == pytest.approx(1e-4)
    assert [t.tolist() for t in trains.spike_times] == [[], [0.0], []]
    assert trains.silent_skipped.tolist() == [0, 2]


def test_dt_much_longer_than_tau_m_no_underflow_warning():
    """exp(-dt / tau_m) underflows to 0 for dt >> tau_m: V jumps to v_rest + r_m I in a step."""
    p = replace(RA, t_ref=0.0)
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        trains = simulate_lif(constant([2 * p.rheobase, 0.5 * p.rheobase], 5), p, dt=10.0, engine="fast")
    assert trains.n_spikes.tolist() == [5, 0]


def test_no_afferents():
    trains = simulate_lif(np.zeros((10, 0)), RA, dt=1e-4)
    assert trains.n_afferents == 0 and trains.rates().shape == (0,)
    assert trains.psth(1e-3)[0].shape == (1,)


# ---------------------------------------------------------------------------------------------
# Input handling: AfferentCurrent, times, duration
# ---------------------------------------------------------------------------------------------


def test_afferent_current_duck_typed_with_own_times_and_ids():
    values = constant([0.0, 3 * RA.rheobase], 20)
    times = 0.5 + np.arange(20) * 1e-3
    current = SimpleNamespace(values=values, times=times, afferent_ids=np.array([7, 9]))
    trains = simulate_lif(current, RA, dt=1e-4)
    assert trains.t_start == 0.5
    assert trains.duration == pytest.approx(0.02)
    assert trains.afferent_ids.tolist() == [7, 9]
    assert trains.spike_times[1][0] >= 0.5
    # same spikes as the equivalent per-step ndarray, shifted by t_start
    flat = simulate_lif(np.repeat(values, 10, axis=0), RA, dt=1e-4)
    np.testing.assert_allclose(trains.spike_times[1] - 0.5, flat.spike_times[1], rtol=0, atol=TIME_SLACK)
    df = trains.to_dataframe()
    assert list(df.columns) == ["afferent", "spike_time_s"] and set(df["afferent"]) == {9}


@pytest.mark.parametrize("has_times", [True, False])
def test_real_afferent_current_from_synthesis(has_times):
    """Integration with stage 5's AfferentCurrent (string ids; times may be None)."""
    synthesis = pytest.importorskip("afferent.synthesis")
    values = constant([0.0, 3 * RA.rheobase], 50)
    current = synthesis.AfferentCurrent(
        values=values,
        times=np.arange(50) * 1e-3 if has_times else None,
        positions=np.array([0.0, 0.44e-3]),
        afferent_ids=np.array(["L0", "L1"]),
        kind="longitudinal",
    )
    trains = simulate_lif(current, RA, dt=1e-4)
    assert trains.afferent_ids.tolist() == ["L0", "L1"]
    assert trains.duration == pytest.approx(0.05 if has_times else 0.005)
    assert trains.summary().loc["L0", "simulated"] == False  # noqa: E712 (numpy bool)
    assert trains.n_spikes[1] > 0
    if not has_times:  # unknown times: like an ndarray, so 'times' may be given here
        timed = simulate_lif(current, RA, dt=1e-4, times=np.arange(50) * 1e-3)
        assert timed.duration == pytest.approx(0.05)


def test_duration_shorter_and_longer_than_input():
    current = constant([3 * RA.rheobase], 100)  # 10 ms
    full = simulate_lif(current, RA, dt=1e-4, duration=0.03, engine="fast")  # beyond: last sample held
    padded = simulate_lif(constant([3 * RA.rheobase], 300), RA, dt=1e-4, engine="fast")
    assert same_spikes(full, padded)
    short = simulate_lif(current, RA, dt=1e-4, duration=0.005, engine="fast")
    assert short.duration == pytest.approx(0.005)
    assert np.all(short.spike_times[0] < 0.005)
    np.testing.assert_array_equal(short.spike_times[0], padded.spike_times[0][padded.spike_times[0] < 0.005])


def test_odd_duration_rounds_up_with_a_note():
    trains = simulate_lif(constant([3 * RA.rheobase], 100), RA, dt=1e-4, duration=0.00525, engine="fast")
    assert trains.duration == pytest.approx(0.0053)
    assert any("not a whole number of steps" in n for n in trains.notes)


# ---------------------------------------------------------------------------------------------
# Result object
# ---------------------------------------------------------------------------------------------


def test_result_methods_on_a_known_train():
    current = constant([0.0, 1.5 * RA.rheobase, 20 * RA.rheobase], 1000)  # 100 ms
    trains = simulate_lif(current, RA, dt=1e-4)
    n = trains.n_spikes
    np.testing.assert_allclose(trains.rates(), n / 0.1)
    isis = trains.isi()
    assert [d.size for d in isis] == [0, n[1] - 1, n[2] - 1]
    table = trains.summary()
    assert list(table.columns) == ["n_spikes", "rate_hz", "first_spike_latency_s", "mean_isi_s", "cv_isi", "simulated"]
    assert table.index.name == "afferent"
    np.testing.assert_allclose(table["mean_isi_s"].iloc[1:], [isis[1].mean(), isis[2].mean()])
    np.testing.assert_allclose(table["cv_isi"].iloc[1:], 0.0, atol=1e-9)  # constant current: regular
    rate, edges = trains.psth(7e-3)  # last bin is partial
    assert edges[-1] == pytest.approx(0.1) and rate.size == 15
    assert np.sum(rate * np.diff(edges)) * trains.n_afferents == pytest.approx(n.sum())
    assert trains.spike_times[1].flags.writeable is False
    assert repr(trains).startswith("<SpikeTrains: 3 afferents (1 skipped as silent),")


def test_presets_and_from_preset():
    assert LIFParams.from_preset("ra") is LIF_PRESETS["ra"]
    assert RA.rheobase == pytest.approx(1e-7)
    msg = "Invalid value for the 'name' parameter. Allowed values are 'ra' and 'sa1', but got 'RA-I' instead."
    with pytest.raises(ValueError, match=re.escape(msg)):
        LIFParams.from_preset("RA-I")


# ---------------------------------------------------------------------------------------------
# Error messages (pinned)
# ---------------------------------------------------------------------------------------------

GOOD = dict(tau_m=0.01, r_m=1e7, v_rest=-0.07, v_thresh=-0.05, v_reset=-0.07, t_ref=0.002)


@pytest.mark.parametrize(
    "change, exc, msg",
    [
        ({"tau_m": -0.01}, ValueError, "The 'tau_m' field of LIFParams must be > 0 s; got -0.01 instead."),
        ({"r_m": 0}, ValueError, "The 'r_m' field of LIFParams must be > 0 Ohm; got 0 instead."),
        ({"t_ref": -1e-3}, ValueError, "The 't_ref' field of LIFParams must be >= 0 s; got -0.001 instead."),
        (
            {"tau_m": "10 ms"},
            TypeError,
            "The 'tau_m' field of LIFParams must be a real number in s; got '10 ms' instead.",
        ),
        (
            {"v_reset": "-70 mV"},
            TypeError,
            "The 'v_reset' field of LIFParams must be a real number in V; got '-70 mV' instead.",
        ),
        (
            {"v_rest": float("nan")},
            ValueError,
            "The 'v_rest' field of LIFParams must be a finite real number in V; got nan instead.",
        ),
        (
            {"v_thresh": -0.08},
            ValueError,
            "The 'v_thresh' field of LIFParams must be > v_rest = -0.07 V; got -0.08 instead.",
        ),
        (
            {"v_reset": -0.04},
            ValueError,
            "The 'v_reset' field of LIFParams must be < v_thresh = -0.05 V; got -0.04 instead.",
        ),
    ],
)
def test_lifparams_errors(change, exc, msg):
    with pytest.raises(exc, match=re.escape(msg)):
        LIFParams(**{**GOOD, **change})


@pytest.mark.parametrize(
    "kwargs, exc, msg",
    [
        (
            {"engine": "brain2"},
            ValueError,
            "Invalid value for the 'engine' parameter. Allowed values are 'auto', 'exact', 'exact-numba', "
            "'exact-numpy', 'fast', 'fast-numba', 'fast-numpy' and 'brian2', but got 'brain2' instead. "
            "Did you mean 'brian2'?",
        ),
        ({"dt": 0.0}, ValueError, "'dt' must be > 0 s; got 0.0 instead."),
        ({"duration": -1.0}, ValueError, "'duration' must be > 0 s; got -1.0 instead."),
        (
            {"current": np.ones(5)},
            ValueError,
            "'current' must be an array of shape (n_times, n_afferents) in A; got shape (5,) instead. "
            "For one afferent pass current[:, None].",
        ),
        (
            {"current": np.zeros((0, 2))},
            ValueError,
            "'current' must have at least one time step; got shape (0, 2) instead.",
        ),
        (
            {"current": np.array([[0.0, 1.0], [np.nan, 2.0]])},
            ValueError,
            "'current' must be finite; got 1 non-finite value(s) (first: NaN at index (1, 0)) instead.",
        ),
        (
            {"current": [["a"]]},
            TypeError,
            "'current' must be a numeric array in A; got list instead.",
        ),
        (
            {"times": np.arange(3.0)},
            ValueError,
            "'times' must be an array of shape (n_times,) = (4,) in s to match 'current'; got shape (3,) instead.",
        ),
        (
            {"times": np.array([0.0, 1e-3, 1e-3, 2e-3])},
            ValueError,
            "'times' must be strictly increasing in s; got times[2] = 0.001 <= times[1] = 0.001 instead.",
        ),
        (
            {"current": np.full((4, 1), 1e296)},
            ValueError,
            "r_m * max|current| must be < 1e+300 V for the update to stay finite; got 1e+303 V instead.",
        ),
        ({"params": {"tau_m": 0.01}}, TypeError, "'params' must be a LIFParams; got dict instead."),
        (
            {"dt": 1e-12, "duration": 1.0, "engine": "fast"},
            ValueError,
            "duration / dt must be below 2147483647 steps; got 1e+12 steps (duration 1.0 s, dt 1e-12 s) instead.",
        ),
    ],
)
def test_simulate_lif_errors(kwargs, exc, msg):
    call = {"current": np.zeros((4, 2)), "params": LIFParams(**{**GOOD, "r_m": 1e7}), "dt": 1e-4, **kwargs}
    current, params = call.pop("current"), call.pop("params")
    with pytest.raises(exc, match=re.escape(msg)):
        simulate_lif(current, params, **call)


def test_times_with_afferent_current_rejected():
    current = SimpleNamespace(values=np.zeros((3, 1)), times=np.arange(3) * 1e-3)
    msg = (
        "Pass 'times' only with an ndarray current; the SimpleNamespace carries its own times. "
        "Got times=array of shape (3,) and dtype float64 instead."
    )
    with pytest.raises(ValueError, match=re.escape(msg)):
        simulate_lif(current, RA, dt=1e-4, times=np.arange(3) * 1e-3)


def test_psth_bin_width_error():
    trains = simulate_lif(np.zeros((5, 1)), RA, dt=1e-4)
    with pytest.raises(ValueError, match=re.escape("'bin_width' must be > 0 s; got -0.001 instead.")):
        trains.psth(-1e-3)


# ---------------------------------------------------------------------------------------------
# Hypothesis: numerical extremes on the fast engine
# ---------------------------------------------------------------------------------------------

_magnitudes = st.floats(min_value=-30.0, max_value=3.0).map(lambda e: 10.0**e)  # 1e-30 .. 1e3 A


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    amps=st.lists(_magnitudes, min_size=1, max_size=6),
    sign=st.sampled_from([1.0, -1.0]),
    dt=st.sampled_from(DTS),
    preset=st.sampled_from(["ra", "sa1"]),
)
def test_property_constant_currents_extremes(amps, sign, dt, preset):
    params = LIF_PRESETS[preset]
    current = sign * np.array(amps)
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message="The grid engine at dt", category=AfferentWarning)  # at 1/t_ref: expected
        trains = simulate_lif(constant(current, 1), params, dt=dt, duration=200 * dt, engine="fast")
        lo, hi = grid_isi_bounds(params, current, dt=dt)
    max_spikes = 200 // n_eff(params, dt) + 1
    for k, train in enumerate(trains.spike_times):
        assert train.size <= max_spikes
        assert np.all(np.isfinite(train)) and np.all(np.diff(train) > 0)
        assert np.all((train >= 0) & (train < trains.duration))
        if params.r_m * current[k] <= params.theta * (1 - 1e-9):
            assert k in trains.silent_skipped and train.size == 0
        elif train.size >= 2:
            d = np.diff(train)
            assert np.all((d >= lo[k] - TIME_SLACK) & (d < hi[k] + TIME_SLACK))


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    low=st.floats(min_value=-30.0, max_value=0.0),
    high=st.floats(min_value=-9.0, max_value=3.0),
)
def test_property_time_varying_extremes_backends_agree(seed, low, high):
    pytest.importorskip("numba")
    rng = np.random.default_rng(seed)
    exponents = rng.uniform(min(low, high), max(low, high), (120, 8))
    current = rng.choice([-1.0, 1.0], (120, 8), p=[0.1, 0.9]) * 10.0**exponents
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message="The grid engine at dt", category=AfferentWarning)  # at 1/t_ref: expected
        a = simulate_lif(current, RA, dt=1e-4, engine="fast-numba")
        b = simulate_lif(current, RA, dt=1e-4, engine="fast-numpy")
    assert same_spikes(a, b)
    assert np.all(a.rates() <= 1.0 / (n_eff(RA, 1e-4) * 1e-4) * (1 + 1e-9))


def test_rate_table_splits_the_window_by_stimulus_phase():
    """Hand-built trains on a ramp-and-hold (load 0-0.1 s, hold to 0.3 s, unload to 0.4 s, off to
    0.5 s): afferent 0 bursts 4 spikes 2.5 ms apart at onset and 2 at release; afferent 1 fires
    once in the hold. The table must give the phase rates and the burst's peak rate, which the
    window mean (12 Hz) hides."""
    from afferent.plotting import rate_table
    from afferent.spiking import LIFParams, SpikeTrains
    from afferent.stimulus import ramp_and_hold

    w = ramp_and_hold(0.5e-3, 5e-3, 0.2, dt=1e-3, post=0.1)
    assert [p[0] for p in w.phases()] == ["loading", "hold", "unloading", "off"]
    np.testing.assert_allclose([p[1:] for p in w.phases()], [[0, 0.1], [0.1, 0.3], [0.3, 0.4], [0.4, 0.5]], atol=1e-9)
    trains = SpikeTrains.from_trains((np.array([0.010, 0.0125, 0.015, 0.0175, 0.31, 0.32]), np.array([0.2])),
                         afferent_ids=np.array(["a", "b"]), duration=0.5, dt=1e-4, engine="fast", backend="numpy",
                         silent_skipped=np.array([], dtype=int), params=LIFParams.from_preset("ra"))
    df = rate_table(trains, w, positions=np.array([1e-3, 2e-3]))
    np.testing.assert_allclose(df["loading_hz"], [40.0, 0.0])
    np.testing.assert_allclose(df["hold_hz"], [0.0, 5.0])
    np.testing.assert_allclose(df["unloading_hz"], [20.0, 0.0])
    np.testing.assert_allclose(df["off_hz"], [0.0, 0.0])
    np.testing.assert_allclose(df["mean_hz"], [12.0, 2.0])
    np.testing.assert_allclose(df["peak_instantaneous_hz"], [400.0, 0.0])
    assert list(df["position_m"]) == [1e-3, 2e-3]


def test_drive_mapping_and_the_ceiling_and_silence_warnings(tmp_path, capsys):
    """The study's longitudinal fit drives every afferent of the bundled sample at 158 x the 'ra'
    rheobase (815 Hz with the exact engine, near the 833 Hz 1/t_ref ceiling): warned; drive='rheobase' maps the largest current to
    2 x the rheobase, whose rate is the closed form 1 / (t_ref + tau_m ln 2)."""
    from conftest import SAMPLE_DIR

    from afferent import read_receptors, read_sed
    from afferent.cli import main
    from afferent.exceptions import AfferentWarning
    from afferent.pipeline import run_pipeline, run_spikes
    from afferent.spiking import LIFParams, rheobase_scale
    from afferent.transduction import STUDY_PARAMS

    export = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu"
    if not export.is_file():
        pytest.skip("bundled sample not generated")
    field = read_sed(export, length_unit="mm", sed_unit="MPa")
    layout = read_receptors(SAMPLE_DIR / "block4" / "receptors.csv", length_unit="mm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)  # the saturated sigmoid
        res = run_pipeline(field, layout, STUDY_PARAMS["longitudinal"])
    ra = LIFParams.from_preset("ra")
    with pytest.warns(AfferentWarning, match=re.escape("All 7 afferents fire at >= 90% of 1/t_ref (833.3 Hz): their drive is 158-158 x the rheobase")):
        hot = run_spikes(res, ra, dt=1e-4, duration=0.5)
    assert hot.drive["all_at_ceiling"] and hot.drive["mapping"] == "resistance"
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)
        mapped = run_spikes(res, ra, dt=1e-5, duration=0.5, drive="rheobase", rheobase_multiple=2.0)
    d = mapped.drive
    np.testing.assert_allclose(d["drive_over_rheobase"], 2.0, rtol=1e-9)
    expected = 1.0 / (ra.t_ref + ra.tau_m * np.log(2.0))  # V from v_reset = v_rest to theta under 2 x rheobase
    np.testing.assert_allclose(d["predicted_rate_hz"], expected, rtol=1e-6)  # the 7 currents differ by ~1e-9
    np.testing.assert_allclose(d["rate_hz"], expected, rtol=0.02)  # simulated, on a 0.01 ms grid over 0.5 s
    scale, ref = rheobase_scale(np.array([[1e-6, 3e-6]]), ra, multiple=4.0)
    assert ref == 3e-6 and scale * ref == pytest.approx(4 * ra.rheobase)
    with pytest.warns(AfferentWarning, match="All 7 afferents are silent: their drive peaks at 0.5 x the rheobase"):
        run_spikes(res, ra, dt=1e-4, duration=0.2, drive="rheobase", rheobase_multiple=0.5)
    out = tmp_path / "run"
    code = main(["run", str(export), "--receptors", str(SAMPLE_DIR / "block4" / "receptors.csv"), "--length-unit", "mm",
                 "--sed-unit", "MPa", "--params", "longitudinal", "--spikes", "--duration-s", "0.2", "--no-plots",
                 "--drive", "rheobase", "--rheobase-multiple", "3", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    import json

    rec = json.loads((out / "run.json").read_text())["spikes"]["drive"]
    assert rec["mapping"] == "rheobase" and rec["rheobase_multiple"] == 3.0
    np.testing.assert_allclose(rec["drive_over_rheobase"], 3.0, rtol=1e-9)


@pytest.mark.parametrize("engine", ["fast-numpy", "fast"])
def test_grid_engine_warns_at_the_refractory_ceiling(engine):
    """ra at 158 x the rheobase (the study's longitudinal fit, docs/method.md): the continuous ISI is
    t_ref + tau ln(158/157) = 1.228 ms (814 Hz), but at the default dt = 0.1 ms the grid rounds the
    28 us climb up to one step and fires every 12 steps = t_ref exactly, 1/t_ref = 833 Hz: warned and
    noted. The exact engine stays below the ceiling and does not warn."""
    current = constant(np.array([158.0 * RA.rheobase, 2.0 * RA.rheobase]), 1)
    with pytest.warns(AfferentWarning, match=r"fired at up to 833\.3 Hz, at or above the 1/t_ref ceiling of 833\.3 Hz"):
        trains = simulate_lif(current, RA, dt=1e-4, engine=engine, duration=0.05)
    assert trains.peak_rate()[0] >= 1.0 / RA.t_ref * (1 - 1e-9)
    assert any("1/t_ref" in n for n in trains.notes)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)
        exact = simulate_lif(current, RA, dt=1e-4, engine="exact", duration=0.05)
        low = simulate_lif(current[:, 1:], RA, dt=1e-4, engine=engine, duration=0.05)  # 2 x rheobase: far below
    assert exact.peak_rate()[0] == pytest.approx(RA.steady_rate(158.0 * RA.rheobase), rel=1e-9)
    assert exact.peak_rate()[0] < 815.0  # 814.07 Hz
    assert low.n_spikes[0] > 3


# ------------------------------------------------------------- issue 33, item 13: a grid of one step
@pytest.mark.parametrize("engine", ["fast", "fast-numpy", "brian2"])
@pytest.mark.parametrize("dt, kwargs", [
    (1.0, {"duration": 1.0}),
    (2.0, {"duration": 1.0}),
    (1.5, {"times": np.arange(5) * 0.25}),  # the samples span 1.25 s
])
def test_a_grid_step_at_or_above_the_duration_is_refused(engine, dt, kwargs):
    """Before: exit 0 with every spike stamped at t = 0, their count set by dt (afferent run --engine fast --dt-ms
    1000 on a 1 s static input: 5 spikes, all at t = 0; --dt-ms 500: 10)."""
    n = len(kwargs.get("times", [0]))
    duration = kwargs.get("duration", 1.25)
    with pytest.raises(ValueError, match=re.escape(
            f"'dt' must be below the simulated duration of {duration:g} s, so that the grid has more than one step; "
            f"got {dt!r} s instead. Use a smaller dt, or engine='exact' (no time step).")):
        simulate_lif(constant([2 * RA.rheobase], n), RA, dt=dt, engine=engine, **kwargs)
