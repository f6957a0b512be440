"""Stage 3: SED -> receptor current (afferent.transduction)."""

from __future__ import annotations

import dataclasses
import re
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from afferent.exceptions import AfferentWarning
from afferent.receptors import ReceptorLayout
from afferent.transduction import (
    STUDY_PARAMS,
    ReceptorCurrent,
    SigmoidParams,
    saturation_report,
    sigmoid,
    transduce,
)

FLOAT_MAX = np.finfo(np.float64).max  # 1.797...e308


def naive(sed, p: SigmoidParams):
    """The study's formula written literally; only valid where exp() does not overflow."""
    return p.alpha / (1.0 + np.exp(p.gamma * (p.lambda_ - np.asarray(sed, dtype=float))))


@pytest.fixture
def layout():
    # 3 x 2 papilla tips, x pitch 0.44 mm, z pitch 0.22 mm; 1/3 offsets so rounding shows.
    x, z = np.meshgrid(np.arange(3) * 4.4e-4 + 1e-5 / 3, np.arange(2) * 2.2e-4, indexing="ij")
    return ReceptorLayout(np.column_stack([x.ravel(), np.full(6, 7.5e-4), z.ravel()]))


# --------------------------------------------------------------------- SigmoidParams
def test_study_table_converted_exactly():
    # The mA -> A conversion is a decimal shift of the printed number, so equality is exact
    # (a float division would give 2.4600000000000003e-08 for the first row).
    expected = {
        "start": (2.46e-08, 4.6e-03, 300.0),
        "longitudinal": (9.29e-07, 2.95e-02, -705.0),
        "cross": (2.21e-08, 9.66e-03, 209.0),
    }
    assert set(STUDY_PARAMS) == set(expected)
    for key, (alpha, gamma, lam) in expected.items():
        p = STUDY_PARAMS[key]
        assert (p.alpha, p.gamma, p.lambda_) == (alpha, gamma, lam), key


@pytest.mark.parametrize(
    "alpha_ma, alpha_a",
    [(2.46e-05, 2.46e-08), (9.29e-04, 9.29e-07), (2.21e-05, 2.21e-08), (1.0, 1e-3), (3e-7, 3e-10), (0.1 + 0.2, 3.0000000000000004e-4)],
)
def test_from_study_is_a_decimal_shift(alpha_ma, alpha_a):
    # Exact: the printed mA value shifted by three decimal places, then rounded once.
    assert SigmoidParams.from_study(alpha_ma, 1e-3, 0.0).alpha == alpha_a


def test_params_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        STUDY_PARAMS["start"].alpha = 1.0


@pytest.mark.parametrize(
    "kwargs, err, msg",
    [
        ({"alpha": -1e-9, "gamma": 1e-3, "lambda_": 0.0}, ValueError,
         "The 'alpha' field of SigmoidParams must be >= 0 A; got -1e-09 instead."),
        ({"alpha": float("inf"), "gamma": 1e-3, "lambda_": 0.0}, ValueError,
         "The 'alpha' field of SigmoidParams must be >= 0 A; got inf instead."),
        ({"alpha": True, "gamma": 1e-3, "lambda_": 0.0}, TypeError,
         "The 'alpha' field of SigmoidParams must be a real number in A; got True instead."),
        ({"alpha": 1e-9, "gamma": -0.5, "lambda_": 0.0}, ValueError,
         "The 'gamma' field of SigmoidParams must be >= 0 1/Pa; got -0.5 instead."),
        ({"alpha": 1e-9, "gamma": 1e-3, "lambda_": float("nan")}, ValueError,
         "The 'lambda_' field of SigmoidParams must be a finite number in Pa; got nan instead."),
        ({"alpha": 1e-9, "gamma": 1e-3, "lambda_": "300"}, TypeError,
         "The 'lambda_' field of SigmoidParams must be a real number in Pa; got '300' instead."),
    ],
)
def test_params_validation_messages(kwargs, err, msg):
    with pytest.raises(err, match=re.escape(msg)):
        SigmoidParams(**kwargs)


def test_from_study_validation_message():
    with pytest.raises(ValueError, match=re.escape("'alpha_ma' must be a finite number in mA; got nan instead.")):
        SigmoidParams.from_study(float("nan"), 1e-3, 0.0)
    with pytest.raises(TypeError, match=re.escape("'alpha_ma' must be a real number in mA; got '1' instead.")):
        SigmoidParams.from_study("1", 1e-3, 0.0)


def test_params_accept_numpy_scalars_and_store_floats():
    p = SigmoidParams(np.float32(1e-8), np.int64(0), np.float64(-705.0))
    assert type(p.alpha) is float and type(p.gamma) is float and type(p.lambda_) is float


# --------------------------------------------------------------------- sigmoid
@pytest.mark.parametrize("p", [*STUDY_PARAMS.values(), SigmoidParams(3.3e-9, 1e12, -1e-3 / 3)])
def test_sigmoid_at_midpoint_is_half_alpha(p):
    # expit(0) is exactly 0.5, so this holds exactly.
    assert sigmoid(p.lambda_, p) == p.alpha / 2


@pytest.mark.parametrize("p", list(STUDY_PARAMS.values()))
def test_sigmoid_matches_the_study_formula(p):
    sed = np.linspace(0.0, 190.0, 77)
    # expit and the literal formula differ only by rounding in this safe range.
    np.testing.assert_allclose(sigmoid(sed, p), naive(sed, p), rtol=1e-13, atol=0)


def test_sigmoid_keeps_shape_and_returns_float64():
    p = STUDY_PARAMS["start"]
    out = sigmoid(np.zeros((2, 3, 4), dtype=np.int32), p)
    assert out.shape == (2, 3, 4) and out.dtype == np.float64
    assert np.ndim(sigmoid(0, p)) == 0


def test_expit_is_scipys_to_4_ulp_over_the_whole_real_line_and_exact_at_the_ends():
    from scipy.special import expit

    from afferent.transduction import _expit

    rng = np.random.default_rng(23)
    mag = np.logspace(-320, 308.2, 200_001)  # |x| from subnormal to the float maximum
    x = np.concatenate([-mag, mag, rng.normal(0.0, 3.0, 100_000), rng.uniform(-800.0, 800.0, 100_000),
                        [0.0, -0.0, 709.78, -709.78, 709.79, -709.79, 745.2, -745.2, FLOAT_MAX, -FLOAT_MAX]])
    ours, ref = _expit(x), expit(x)
    np.testing.assert_array_max_ulp(ours, ref, maxulp=4)
    ends = (ref == 0.0) | (ref == 1.0)
    assert ends.sum() > 200_000 and np.array_equal(ours[ends], ref[ends])  # the saturated ends bit for bit
    np.testing.assert_array_equal(_expit([np.inf, -np.inf, np.nan, 0.0]), [1.0, 0.0, np.nan, 0.5])
    assert np.all(np.diff(_expit(np.sort(x))) >= 0)  # monotone


EXTREME_SED = [0.0, 1e300, -1e300, 1.7e308, -1.7e308, FLOAT_MAX, -FLOAT_MAX]
EXTREME_PARAMS = [
    SigmoidParams(1e-8, 0.0, 300.0),  # gamma 0: alpha/2 everywhere
    SigmoidParams(1e-8, 0.0, -1.7e308),  # gamma 0 with lambda - SED = +-inf
    SigmoidParams(1e-8, 1e12, 300.0),  # step function
    SigmoidParams(1e-8, 1e12, -705.0),
    SigmoidParams(9.29e-7, 2.95e-2, -705.0),  # the study's longitudinal fit
    SigmoidParams(1e-8, 4.6e-3, 1.7e308),  # lambda - SED overflows for SED = -1.7e308
    SigmoidParams(1e-8, 4.6e-3, -1.7e308),  # and for SED = +1.7e308
    SigmoidParams(1e-8, 5e-324, 0.0),  # subnormal slope
    SigmoidParams(0.0, 1e-3, 0.0),  # alpha 0
]


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("p", EXTREME_PARAMS, ids=repr)
def test_sigmoid_extremes_finite_bounded_monotone_silent(p):
    sed = np.sort(np.array(EXTREME_SED))
    out = sigmoid(sed, p)
    assert np.all(np.isfinite(out))
    assert np.all((out >= 0) & (out <= p.alpha))
    assert np.all(np.diff(out) >= 0)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("sed", EXTREME_SED)
def test_gamma_zero_is_half_alpha_everywhere(sed):
    for lam in (300.0, -705.0, 1.7e308, -1.7e308):
        assert sigmoid(sed, SigmoidParams(2e-8, 0.0, lam)) == 1e-8


@pytest.mark.filterwarnings("error")
def test_huge_gamma_is_a_step_and_infinite_sed_gives_the_limits():
    p = SigmoidParams(1e-8, 1e12, 300.0)
    out = sigmoid([-1e300, 0.0, 299.999, 300.001, 1e300, 1.7e308], p)
    np.testing.assert_array_equal(out, [0.0, 0.0, 0.0, 1e-8, 1e-8, 1e-8])
    np.testing.assert_array_equal(sigmoid([-np.inf, np.inf], STUDY_PARAMS["start"]), [0.0, 2.46e-8])


def test_sigmoid_no_warning_for_overflowing_difference():
    # SED - lambda overflows to +inf (first case) and -inf (second case).
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        up = sigmoid(np.array([1.7e308, -1.7e308, -FLOAT_MAX]), SigmoidParams(1e-8, 4.6e-3, -1.7e308))
        down = sigmoid(np.array([-1.7e308, 1.7e308, FLOAT_MAX]), SigmoidParams(1e-8, 4.6e-3, 1.7e308))
    np.testing.assert_array_equal(up, [1e-8, 5e-9, 0.0])
    np.testing.assert_array_equal(down, [0.0, 5e-9, 1e-8])


finite_floats = st.floats(allow_nan=False, allow_infinity=False)
params_st = st.builds(
    SigmoidParams,
    alpha=st.floats(0.0, 1.0),
    gamma=st.one_of(st.just(0.0), st.floats(0.0, 1e300), st.sampled_from([1e12, 2.95e-2, 4.6e-3])),
    lambda_=st.one_of(finite_floats, st.sampled_from([-705.0, 209.0, 300.0])),
)


@settings(max_examples=300, deadline=None)
@given(a=finite_floats, b=finite_floats, p=params_st)
@example(a=0.0, b=1e300, p=SigmoidParams(1.0, 0.0, 300.0))
@example(a=-1e300, b=1e300, p=SigmoidParams(1.0, 1e12, 300.0))
@example(a=-FLOAT_MAX, b=FLOAT_MAX, p=SigmoidParams(1.0, 4.6e-3, -FLOAT_MAX))
@example(a=0.0, b=190.0, p=SigmoidParams(9.29e-7, 2.95e-2, -705.0))
def test_sigmoid_property_finite_bounded_monotone(a, b, p):
    lo, hi = min(a, b), max(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        i_lo, i_hi = sigmoid(np.array([lo, hi]), p)
    assert np.isfinite(i_lo) and np.isfinite(i_hi)
    assert 0.0 <= i_lo <= i_hi <= p.alpha


@pytest.mark.parametrize(
    "sed, msg",
    [
        ([0.0, np.nan], "'sed' must not contain NaN; got 1 NaN value(s) (first at index (1,)) instead."),
        ([[0.0, 1.0], [np.nan, np.nan]], "'sed' must not contain NaN; got 2 NaN value(s) (first at index (1, 0)) instead."),
    ],
)
def test_sigmoid_nan_raises_with_index(sed, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        sigmoid(sed, STUDY_PARAMS["start"])


def test_sigmoid_params_type_error():
    msg = "'params' must be a SigmoidParams(alpha=..., gamma=..., lambda_=...); got tuple instead."
    with pytest.raises(TypeError, match=re.escape(msg)):
        sigmoid(0.0, (1e-8, 1e-3, 0.0))


# --------------------------------------------------------------------- transduce
def test_transduce_receptor_sed_object(layout):
    times = np.array([0.0, 0.05, 0.1])
    values = np.linspace(0.0, 190.0, 18).reshape(3, 6)
    rsed = SimpleNamespace(values=values, times=times, layout=layout)
    cur = transduce(rsed, STUDY_PARAMS["start"])
    assert isinstance(cur, ReceptorCurrent)
    assert cur.layout is layout and cur.params is STUDY_PARAMS["start"]
    np.testing.assert_array_equal(cur.times, times)
    np.testing.assert_array_equal(np.asarray(cur), sigmoid(values, STUDY_PARAMS["start"]))
    assert (cur.n_times, cur.n_receptors) == (3, 6)
    assert not cur.values.flags.writeable


def test_transduce_plain_array_with_and_without_times():
    sed = np.full((2, 4), 300.0)
    cur = transduce(sed, STUDY_PARAMS["start"])
    assert cur.times is None and cur.layout is None
    np.testing.assert_array_equal(cur.values, np.full((2, 4), 2.46e-8 / 2))
    cur = transduce(sed, STUDY_PARAMS["start"], times=[0.0, 0.1])
    np.testing.assert_array_equal(cur.times, [0.0, 0.1])


def test_transduce_one_time_one_receptor():
    cur = transduce([[209.0]], STUDY_PARAMS["cross"])
    assert cur.values.shape == (1, 1) and cur.values[0, 0] == 2.21e-8 / 2


def test_transduce_errors(layout):
    p = STUDY_PARAMS["start"]
    with pytest.raises(ValueError, match=re.escape(
        "'sed' must be an array of shape (n_times, n_receptors) in Pa; got shape (6,) instead. "
        "For a single time step pass sed[np.newaxis, :]."
    )):
        transduce(np.zeros(6), p)
    values = np.zeros((2, 6))
    values[1, 4] = np.nan
    with pytest.raises(ValueError, match=re.escape(
        "'sed' must not contain NaN; got 1 NaN value(s), first at time step 1, receptor 4 (id '4') instead."
    )):
        transduce(SimpleNamespace(values=values, times=[0.0, 1.0], layout=layout), p)
    with pytest.raises(ValueError, match=re.escape(
        "'times' must only be given with a plain array; got a SimpleNamespace, which carries its own times."
    )):
        transduce(SimpleNamespace(values=np.zeros((2, 6)), times=[0.0, 1.0], layout=layout), p, times=[0, 1])
    with pytest.raises(ValueError, match=re.escape(
        "'times' must have one entry per row of 'values' (n_times = 2); got shape (3,) instead."
    )):
        transduce(np.zeros((2, 6)), p, times=[0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match=re.escape(
        "'times' must be strictly increasing; got 1.0 s followed by 1.0 s (steps 0 and 1) instead."
    )):
        transduce(np.zeros((2, 6)), p, times=[1.0, 1.0])
    with pytest.raises(ValueError, match=re.escape(
        "'layout' must have one receptor per column of 'values' (n_receptors = 5); got a layout of 6 receptors instead."
    )):
        transduce(SimpleNamespace(values=np.zeros((1, 5)), times=[0.0], layout=layout), p)
    with pytest.raises(TypeError, match=re.escape("'sed' must be receptor SED in Pa; got a ReceptorCurrent (in A) instead.")):
        transduce(transduce(np.zeros((1, 5)), p), p)


def test_transduce_warns_when_every_receptor_is_saturated():
    sed = np.linspace(0.0, 190.0, 40).reshape(4, 10)
    with pytest.warns(AfferentWarning, match=re.escape("All 40 receptor samples are saturated (I/alpha >= 0.95")):
        transduce(sed, STUDY_PARAMS["longitudinal"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        transduce(sed, STUDY_PARAMS["start"])
        transduce(sed, STUDY_PARAMS["cross"])


# --------------------------------------------------------------------- saturation_report
SED_RANGE = np.linspace(0.0, 190.0, 191)  # the study's SED range, 0-190 Pa (docs/method.md, "Saturation")


@pytest.mark.parametrize(
    "key, lo2, hi2",
    [("start", 0.20, 0.38), ("cross", 0.12, 0.45)],
)
def test_saturation_report_reproduces_method_numbers(key, lo2, hi2):
    p = STUDY_PARAMS[key]
    rep = saturation_report(SED_RANGE, p)
    # Closed form: I/alpha is expit(gamma * (SED - lambda)), increasing in SED.
    np.testing.assert_allclose(rep.relative_min, 1 / (1 + np.exp(p.gamma * p.lambda_)), rtol=1e-14)
    np.testing.assert_allclose(rep.relative_max, 1 / (1 + np.exp(p.gamma * (p.lambda_ - 190.0))), rtol=1e-14)
    # docs/method.md ("Saturation") quotes these to two decimals.
    assert (round(rep.relative_min, 2), round(rep.relative_max, 2)) == (lo2, hi2)
    assert rep.fraction_sensitive == 1.0 and rep.fraction_high == 0.0 and rep.fraction_low == 0.0
    assert not rep.saturated
    assert rep.n_samples == 191


def test_saturation_report_longitudinal_is_saturated():
    rep = saturation_report(SED_RANGE, STUDY_PARAMS["longitudinal"])
    assert rep.relative_min >= 1 - 1e-9
    assert rep.fraction_sensitive == 0.0 and rep.fraction_high == 1.0 and rep.saturated
    assert rep.message.startswith("All 191 receptor samples are saturated (I/alpha >= 0.95; I/alpha in [1 - 9.")
    assert rep.message.endswith("the receptor current practically does not depend on SED.")


def test_saturation_report_mixed_low_and_alpha_zero(layout):
    p = SigmoidParams(0.0, 1.0, 100.0)  # alpha 0: I/alpha is still defined
    sed = SimpleNamespace(values=np.array([[0.0, 50.0, 99.0, 100.0, 101.0, 300.0]]), times=[0.0], layout=layout)
    rep = saturation_report(sed, p)
    np.testing.assert_allclose(
        [rep.fraction_low, rep.fraction_sensitive, rep.fraction_high], [2 / 6, 3 / 6, 1 / 6], rtol=1e-15
    )
    assert rep.message.endswith("alpha = 0: every current is 0 A.")
    rep = saturation_report(np.zeros(5), SigmoidParams(1e-8, 1.0, 100.0))
    assert rep.fraction_low == 1.0 and rep.message.startswith("All 5 receptor samples are near zero")


def test_saturation_report_custom_thresholds_and_errors():
    rep = saturation_report([0.0, 300.0], STUDY_PARAMS["start"], low=0.25, high=0.5)
    assert (rep.fraction_low, rep.fraction_sensitive, rep.fraction_high) == (0.5, 0.0, 0.5)
    with pytest.raises(ValueError, match=re.escape(
        "'low' and 'high' must satisfy 0 <= low < high <= 1; got low=0.9, high=0.1 instead."
    )):
        saturation_report([0.0], STUDY_PARAMS["start"], low=0.9, high=0.1)
    with pytest.raises(ValueError, match=re.escape("'sed' must not contain NaN")):
        saturation_report([np.nan], STUDY_PARAMS["start"])


@pytest.mark.parametrize("gamma", [0.0, 1e-9])
def test_mid_sigmoid_but_unmodulated_currents_are_reported(gamma):
    """gamma 0 or 1e-9 /Pa puts every sample mid-sigmoid ('100 % sensitive') while the currents
    differ by 1e-6 or less: the report measures the modulation itself."""
    import warnings as _w

    from afferent.transduction import MIN_MODULATION, SigmoidParams, saturation_report, transduce

    sed = np.linspace(0.0, 1000.0, 20)[np.newaxis, :]
    p = SigmoidParams(alpha=2e-8, gamma=gamma, lambda_=300.0)
    rep = saturation_report(sed, p)
    assert rep.fraction_sensitive == 1.0 and rep.unmodulated
    assert rep.modulation == pytest.approx(gamma * 1000 / 2, rel=1e-6, abs=1e-15)  # ptp(I)/mean(I) ~ gamma x range / 2
    assert rep.gamma_sed_range == pytest.approx(gamma * 1000)
    assert rep.message.startswith(f"The receptor currents differ by only {rep.modulation:.3g} of their mean")
    with pytest.warns(AfferentWarning, match="differ by only"):
        transduce(sed, p)
    ok = saturation_report(sed, SigmoidParams(alpha=2e-8, gamma=4.6e-3, lambda_=300.0))
    assert not ok.unmodulated and ok.modulation > MIN_MODULATION
    with _w.catch_warnings():
        _w.simplefilter("error")
        transduce(sed, SigmoidParams(alpha=2e-8, gamma=4.6e-3, lambda_=300.0))


def test_every_cli_run_prints_the_sensitive_fraction_and_warns_once(capsys, tmp_path):
    from conftest import SAMPLE_DIR

    from afferent.cli import main

    export, receptors = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu", SAMPLE_DIR / "block4" / "receptors.csv"
    if not export.is_file():
        pytest.skip("bundled sample not generated")
    base = ["run", str(export), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa", "--no-plots"]
    assert main(base + ["--params", "start", "-o", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "transduction: " in err and "of receptor samples in the sigmoid's sensitive range" in err
    assert "afferent: warning" not in err
    assert main(base + ["--params", "longitudinal", "-o", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "transduction: 0.0% of receptor samples in the sigmoid's sensitive range" in err
    assert len([line for line in err.splitlines() if "saturated" in line and line.startswith("afferent: warning")]) == 1
