"""Comparison of afferent profiles with recordings (afferent.profiles; docs/method.md, "5. Comparing with recordings")."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from afferent.exceptions import AfferentWarning, SEDFormatError, UnitError
from afferent.profiles import (
    ObservedProfile,
    ProfileFit,
    compare_profiles,
    minmax_normalise,
    observed_on,
    r2,
    r2_study,
    read_observed,
    ssd,
)
from afferent.synthesis import AfferentCurrent

THIRD = 1.0 / 3.0


# --------------------------------------------------------------------- minmax_normalise
def test_minmax_closed_form_1d():
    a = np.array([2.0 * THIRD, 5.0 * THIRD, THIRD, 1.0])
    np.testing.assert_allclose(minmax_normalise(a), [0.25, 1.0, 0.0, 0.5], rtol=1e-15, atol=1e-16)


def test_minmax_axis():
    a = np.array([[1.0, 3.0, 2.0], [10.0, 0.0, 5.0]])
    np.testing.assert_allclose(minmax_normalise(a), [[0.0, 1.0, 0.5], [1.0, 0.0, 0.5]], rtol=1e-15)
    np.testing.assert_allclose(minmax_normalise(a, axis=0), [[0.0, 1.0, 0.0], [1.0, 0.0, 1.0]], rtol=1e-15)
    np.testing.assert_allclose(minmax_normalise(a, axis=None), a / 10.0, rtol=1e-15)


def test_minmax_constant_gives_zeros_and_warns():
    msg = "1 of 2 profile(s) are constant; min-max normalisation maps them to zeros (they carry no shape)."
    with pytest.warns(AfferentWarning, match=re.escape(msg)):
        out = minmax_normalise(np.array([[7e-9, 7e-9, 7e-9], [0.0, 1.0, 2.0]]))
    np.testing.assert_array_equal(out, [[0.0, 0.0, 0.0], [0.0, 0.5, 1.0]])
    assert not np.isnan(out).any()


def test_minmax_nearly_constant_warns():
    # Saturated receptors: currents equal up to rounding.
    a = 9.29e-7 * np.array([1.0, 1.0 - 1e-15, 1.0 - 2e-15])
    with pytest.warns(AfferentWarning, match=re.escape("1 of 1 profile(s) are nearly constant")):
        out = minmax_normalise(a)
    assert out.min() == 0.0 and out.max() == 1.0


@pytest.mark.filterwarnings("error")
def test_minmax_extremes_do_not_overflow():
    out = minmax_normalise(np.array([-1.7e308, 0.0, 1.7e308]))
    np.testing.assert_allclose(out, [0.0, 0.5, 1.0], rtol=1e-15)


def test_minmax_errors():
    with pytest.raises(ValueError, match=re.escape(
        "'a' must not be empty along the normalisation axis; got shape (0,) instead."
    )):
        minmax_normalise([])
    with pytest.raises(ValueError, match=re.escape(
        "'a' must be finite; got 1 non-finite value(s) (first: nan at index (1,)) instead."
    )):
        minmax_normalise([0.0, np.nan])


# --------------------------------------------------------------------- metrics
def test_r2_study_closed_form_and_difference_from_r2():
    d = np.array([0.0, 0.5, 1.0, 0.25])
    e = np.array([0.1, 0.4, 1.0, 0.25])
    res = 0.01 + 0.01
    assert ssd(d, e) == pytest.approx(res, rel=1e-14)
    assert r2_study(d, e) == pytest.approx(1 - res / np.sum(d**2), rel=1e-14)
    assert r2(d, e) == pytest.approx(1 - res / np.sum((d - d.mean()) ** 2), rel=1e-14)
    # No mean subtracted: the study's R^2 is the larger one here.
    assert r2_study(d, e) > r2(d, e)


def test_perfect_fit():
    d = np.array([0.0, 0.3, 1.0])
    assert (r2_study(d, d), r2(d, d), ssd(d, d)) == (1.0, 1.0, 0.0)


@settings(max_examples=300, deadline=None)
@given(st.integers(2, 60), st.floats(-12, 12), st.floats(-9, 1), st.sampled_from(["noise", "constant d", "e = d", "thirds"]),
       st.integers(0, 2**32 - 1))
def test_r2_is_scikit_learns_bit_for_bit(n, log_scale, log_noise, kind, seed):
    """r2 no longer calls sklearn.metrics.r2_score (0.4 ms a call, thousands of calls in a calibration) but
    must give its value exactly, constant profiles and perfect predictions included."""
    from sklearn.metrics import r2_score

    rng = np.random.default_rng(seed)
    d = rng.normal(size=n) * 10.0 ** log_scale
    e = d + rng.normal(size=n) * 10.0 ** (log_scale + log_noise)
    if kind == "constant d":
        d[:] = d[0]
    elif kind == "e = d":
        e = d.copy()
    elif kind == "thirds":
        d, e = np.round(d * 3) / 3, np.round(e * 3) / 3
    assert r2(d, e) == r2_score(d, e)
    assert r2(d.reshape(-1, 1), e.reshape(-1, 1)) == r2_score(d, e)


def test_r2_imports_no_scikit_learn():
    """A fit in 'afferent run --observed' paid scikit-learn's import (~1 s) for one R^2."""
    import subprocess
    import sys

    code = ("import sys; from afferent.profiles import r2; v = r2([0.0, 1.0, 0.5], [0.1, 0.9, 0.5]); "
            "print(round(v, 12), 'sklearn' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["0.96", "False"]


def test_metric_errors():
    with pytest.raises(ValueError, match=re.escape("'d' and 'e' must have the same shape; got (2,) and (3,) instead.")):
        ssd([0.0, 1.0], [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match=re.escape(
        "'d' must not be all zeros: r2_study divides by sum(d**2); got an all-zero 'd' instead."
    )):
        r2_study([0.0, 0.0], [0.0, 1.0])
    with pytest.raises(ValueError, match=re.escape("r2 needs at least 2 samples; got 1 instead.")):
        r2([1.0], [1.0])
    with pytest.raises(ValueError, match=re.escape("'e' must be finite; got 1 non-finite value(s)")):
        ssd([0.0, 1.0], [0.0, np.inf])


# --------------------------------------------------------------------- observed profiles
def test_read_observed_converts_to_metres_and_sorts(tmp_path):
    path = tmp_path / "obs.csv"
    path.write_text("# RA-I response vs position\nPosition; Response\n1.5;20\n0.5;10\n1.0;40\n")
    obs = read_observed(path, length_unit="mm")
    np.testing.assert_allclose(obs.positions, [0.5e-3, 1.0e-3, 1.5e-3], rtol=1e-15)
    np.testing.assert_array_equal(obs.response, [10.0, 40.0, 20.0])
    assert obs.source == str(path)


def test_read_observed_custom_columns(tmp_path):
    path = tmp_path / "obs.csv"
    path.write_text("x_um,rate\n0,1\n100,3\n")
    obs = read_observed(path, length_unit="um", position_column="x_um", response_column="rate")
    np.testing.assert_allclose(obs.positions, [0.0, 1e-4], rtol=1e-15)


def test_read_observed_errors(tmp_path):
    path = tmp_path / "obs.csv"
    path.write_text("positon,response\n0,1\n1,2\n")
    with pytest.raises(SEDFormatError, match=re.escape(
        f"Observed profile file {str(path)!r} has no column 'position'. Found columns 'positon', 'response'. "
        "Did you mean 'positon'? Pass position_column=... to choose another column."
    )):
        read_observed(path, length_unit="mm")
    path.write_text("position,response\n0,1\n1,n/a\n")
    with pytest.raises(SEDFormatError, match=re.escape(
        f"Observed profile file {str(path)!r}: column 'response' must hold finite numbers; got 'n/a' on data row 2 instead."
    )):
        read_observed(path, length_unit="mm")
    path.write_text("position,response\n1,1\n1,2\n")
    with pytest.raises(SEDFormatError, match=re.escape(
        f"Observed profile file {str(path)!r}: 'positions' must be strictly increasing, in m; got 0.001 followed by 0.001"
    )):
        read_observed(path, length_unit="mm")
    with pytest.raises(UnitError, match=re.escape("'length_unit' must be a length unit")):
        read_observed(path, length_unit="inch")
    with pytest.raises(FileNotFoundError, match=re.escape(f"Observed profile file {str(tmp_path / 'x.csv')!r} not found.")):
        read_observed(tmp_path / "x.csv", length_unit="mm")


def test_observed_on_is_linear_interpolation():
    obs = ObservedProfile(np.array([0.0, 1e-3, 3e-3]), np.array([0.0, 2.0, 0.0]))
    got = observed_on([0.0, 0.5e-3, 1e-3, 2e-3, 3e-3], obs)
    np.testing.assert_allclose(got, [0.0, 1.0, 2.0, 1.0, 0.0], rtol=1e-15)


def test_observed_on_outside_range():
    obs = ([1e-3, 2e-3], [0.0, 1.0])
    msg = (
        "2 of 3 positions lie outside the observed range [0.001, 0.002] m (first: position 0 at 0.0005 m); "
        "the observation is not extrapolated. Pass on_outside='nan' to skip them."
    )
    with pytest.raises(ValueError, match=re.escape(msg)):
        observed_on([0.5e-3, 1.5e-3, 2.5e-3], obs)
    got = observed_on([0.5e-3, 1.5e-3, 2.5e-3], obs, on_outside="nan")
    assert np.isnan(got[[0, 2]]).all() and got[1] == pytest.approx(0.5, rel=1e-14)


# --------------------------------------------------------------------- compare_profiles
def make_current(profiles, positions, times=None):
    profiles = np.atleast_2d(profiles)
    ids = [f"L{i}" for i in range(profiles.shape[1])]
    return AfferentCurrent(profiles, times, positions, ids, "longitudinal", "x")


def test_compare_profiles_perfect_and_alpha_cancels():
    pos = np.arange(5) * 4.4e-4 + 1e-5 * THIRD
    shape = np.array([0.1, 0.7, 1.0, 0.6, 0.2])
    obs = (pos, 30.0 * shape + 5.0)  # spikes/s: an affine image of the prediction
    for scale in (1e-9, 7e-7):
        fit = compare_profiles(make_current(scale * shape, pos), obs)
        assert isinstance(fit, ProfileFit)
        np.testing.assert_allclose([fit.r2_study, fit.r2, fit.ssd], [1.0, 1.0, 0.0], atol=1e-12)
        assert (fit.normalise, fit.time_index, fit.dropped) == ("both", -1, 0)
        np.testing.assert_array_equal(fit.positions, pos)


def test_compare_profiles_time_index_and_times():
    pos = np.array([0.0, 1e-3, 2e-3])
    cur = make_current([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]], pos, times=[0.05, 0.1])
    obs = (pos, np.array([0.0, 1.0, 0.0]))
    last = compare_profiles(cur, obs)
    first = compare_profiles(cur, obs, time_index=0)
    assert last.ssd == 0.0 and last.time == 0.1
    assert first.ssd == 2.0 and first.time == 0.05 and first.time_index == 0
    # d = (0, 1, 0), e = (0, 0, 1): r2_study = 1 - 2 / 1
    assert first.r2_study == -1.0


def test_compare_profiles_normalise_options():
    pred = np.array([1.0, 3.0, 2.0])
    obs = np.array([0.0, 1.0, 0.5])
    assert compare_profiles(pred, obs, normalise="prediction").ssd == 0.0
    np.testing.assert_array_equal(compare_profiles(pred, obs, normalise="neither").predicted, pred)
    fit = compare_profiles(pred, 2 * obs, normalise="observation")
    np.testing.assert_array_equal(fit.observed, obs)
    assert fit.ssd == pytest.approx(np.sum((obs - pred) ** 2), rel=1e-14)
    assert fit.positions is None and fit.time_index is None
    with pytest.raises(ValueError, match=re.escape(
        "Invalid value for the 'normalise' parameter. Allowed values are 'both', 'prediction', 'observation' and "
        "'neither', but got 'none' instead."
    )):
        compare_profiles(pred, obs, normalise="none")


def test_compare_profiles_does_not_touch_inputs():
    pred = np.array([1.0, 3.0, 2.0])
    compare_profiles(pred, pred.copy(), normalise="neither")
    assert pred.flags.writeable


def test_compare_profiles_drop_outside():
    pos = np.array([0.0, 1e-3, 2e-3, 3e-3])
    cur = make_current([0.0, 1.0, 0.5, 9.0], pos)
    obs = ([0.0, 2e-3], [0.0, 2.0])
    with pytest.raises(ValueError, match=re.escape("1 of 4 positions lie outside the observed range")):
        compare_profiles(cur, obs)
    fit = compare_profiles(cur, obs, on_outside="drop")
    assert fit.dropped == 1 and fit.positions.tolist() == [0.0, 1e-3, 2e-3]
    np.testing.assert_allclose(fit.observed, [0.0, 0.5, 1.0], rtol=1e-15)


def test_compare_profiles_errors():
    with pytest.raises(ValueError, match=re.escape(
        "'positions' (m) are needed to interpolate the observed profile onto a plain-array prediction; got positions=None."
    )):
        compare_profiles([1.0, 2.0], ([0.0, 1e-3], [0.0, 1.0]))
    with pytest.raises(ValueError, match=re.escape(
        "'observed' as an array must have one entry per afferent (3); got shape (2,) instead."
    )):
        compare_profiles([1.0, 2.0, 3.0], [1.0, 2.0])
    with pytest.raises(ValueError, match=re.escape("A profile comparison needs at least 2 afferents; got 1 instead.")):
        compare_profiles([1.0], [1.0])
    with pytest.raises(ValueError, match=re.escape(
        "The observed profile (as compared) is all zeros, so r2_study is undefined; a constant recording carries no shape."
    )):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AfferentWarning)
            compare_profiles([1.0, 2.0], [3.0, 3.0])
    with pytest.raises(ValueError, match=re.escape(
        "'time_index' must be in [-1, 0] for 1 time step(s); got 1 instead."
    )):
        compare_profiles(make_current([1.0, 2.0], [0.0, 1e-3]), [0.0, 1.0], time_index=1)
    with pytest.raises(TypeError, match=re.escape(
        "'observed' must be an ObservedProfile (see read_observed) or a (positions_m, response) tuple; got dict instead."
    )):
        observed_on([0.0], {"x": 1})


def test_observed_on_tolerates_round_off_at_the_ends():
    """A section position computed as a mean (3.3200000000000005e-3) matches an observed 3.32e-3."""
    from afferent.profiles import ObservedProfile, observed_on

    obs = ObservedProfile(np.array([0.68e-3, 3.32e-3]), np.array([1.0, 2.0]))
    out = observed_on(np.array([0.68e-3, (0.68e-3 + 5.96e-3) / 2, 3.32e-3 * (1 + 4e-16)]), obs)
    np.testing.assert_allclose(out, [1.0, 2.0, 2.0], rtol=1e-12)
    with pytest.raises(ValueError, match=re.escape("1 of 1 positions lie outside the observed range [0.00068, 0.00332] m (first: position 0 at 0.00333 m)")):
        observed_on(np.array([3.33e-3]), obs)


def test_observed_positions_in_another_unit_are_named_as_such():
    # afferents at 0.5..3.5 mm; the observed file's positions were declared m instead of mm
    afferents = np.linspace(0.5e-3, 3.5e-3, 7)
    wrong = ObservedProfile(np.linspace(0.4, 4.0, 9), np.arange(9.0), source="obs.csv")  # mm read as m
    with pytest.raises(ValueError, match=re.escape(
            "The afferent positions span 0.000833 x the observed ones of 'obs.csv': check the length unit declared "
            "for the observed positions (mm vs m is a factor 1e3).")):
        observed_on(afferents, wrong)
    with pytest.warns(AfferentWarning, match="span 0.000833 x the observed ones"):
        observed_on(afferents, wrong, on_outside="nan")
    right = ObservedProfile(np.linspace(0.0, 4e-3, 9), np.arange(9.0), source="obs.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        observed_on(afferents, right)


def test_a_tiny_but_resolved_modulation_is_named_as_such_and_kept():
    """Currents deep in the sigmoid's exponential tail: a range of 1e-10 of their level is
    resolved in float64 (the normalised shape matches the analytic tail to ~1e-6), so it is called
    a tiny modulation, not rounding noise (which begins near 1e-12)."""
    from afferent.transduction import SigmoidParams, transduce

    sed = np.linspace(0.0, 100.0, 6)  # Pa
    p = SigmoidParams(alpha=1e-8, gamma=1e-12, lambda_=0.0)  # gamma x SED range = 1e-10
    current = np.asarray(transduce(sed[np.newaxis, :], p))[0]
    with pytest.warns(AfferentWarning, match=re.escape("1 of 1 profile(s) vary by only up to 5e-11 of their level")) as rec:
        shape = minmax_normalise(current)
    assert "not rounding noise" in str(rec[0].message)
    np.testing.assert_allclose(shape, sed / 100.0, atol=1e-5)  # linear tail: the analytic shape
