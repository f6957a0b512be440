"""The least-squares reference with the closed-form Jacobian: derivatives, recovery, cost, fallback.

References: the Jacobian against scipy's finite differences (:func:`scipy.optimize.approx_fprime`,
forward differences with a relative step of 1e-7, so agreement to ~1e-5 is expected where the
function is smooth); parameter recovery against the known parameters a noise-free synthetic
profile was built from, on a real FE field (the bundled sample_sed/block4 export, 1.32 mm
indenter, 119 receptors).
"""

from __future__ import annotations

import re
import types
import warnings

import numpy as np
import pytest
from conftest import SAMPLE_DIR
from scipy.optimize import approx_fprime
from test_calibration import TRUE, make_observed, make_sed

from afferent.calibration import calibrate, methods_table
from afferent.calibration.objective import Objective
from afferent.calibration.reference import FALLBACK_R2, start_failed
from afferent.profiles import ObservedProfile
from afferent.synthesis import Branching, synthesize
from afferent.transduction import STUDY_PARAMS, SigmoidParams, transduce

#: Largest model cost (function + Jacobian evaluations) allowed for a noise-free recovery.
MAX_COST = 60
#: Recovery tolerance on a noise-free profile (relative).
RECOVERY_RTOL = 0.01


@pytest.fixture(scope="module")
def sed():
    return make_sed()


@pytest.fixture(scope="module")
def sample():
    """SED (Pa) at the 119 receptors of the bundled FE sample, 1.32 mm indentation (22-2374 Pa)."""
    from afferent import read_receptors, read_sed, sample_sed

    vtu = SAMPLE_DIR / "block4" / "indent_1p32mm.vtu"
    if not vtu.is_file():
        pytest.skip("bundled sample not generated")
    return sample_sed(read_sed(vtu, length_unit="mm", sed_unit="MPa"),
                      read_receptors(SAMPLE_DIR / "block4" / "receptors.csv", length_unit="mm"))


def _clean_profile(sed, params, kind="longitudinal") -> ObservedProfile:
    b = Branching.longitudinal(sed.layout) if kind == "longitudinal" else Branching.cross(sed.layout)
    aff = synthesize(transduce(sed, params), b)
    return ObservedProfile(aff.positions, aff.values[-1])


def _objective(sed, observed, normalise):
    return Objective(np.asarray(sed.values, float)[[-1]], None, Branching.longitudinal(sed.layout), observed,
                     normalise)


# ------------------------------------------------------------------------- the Jacobian
@pytest.mark.parametrize("normalise", ["both", "neither"])
@pytest.mark.parametrize("params", [
    TRUE,  # every receptor in the sensitive range
    SigmoidParams(3e-8, 10.0, 100.0),  # steep: exp(gamma (lambda - SED)) overflows for SED < 29 Pa
    SigmoidParams(3e-8, 0.05, 160.0),  # most receptors near zero, a few saturating
], ids=["sensitive", "overflow", "mixed"])
def test_jacobian_matches_finite_differences(sed, params, normalise):
    obj = _objective(sed, make_observed(sed, noise=0.0), normalise)
    vec = np.array([params.alpha, params.gamma, params.lambda_])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no overflow, no invalid value
        jac = obj.jacobian(vec)
    assert jac.shape == (13, 3) and np.all(np.isfinite(jac))
    fd = approx_fprime(vec, lambda v: np.asarray(obj(v)[1].predicted), 1e-7 * np.abs(vec))
    cols = [0, 1, 2]
    if normalise == "both":
        # alpha cancels out of a normalised prediction: the closed form gives 0 up to rounding
        # (relative to alpha x the other columns), finite differences only rounding noise.
        assert np.max(np.abs(jac[:, 0])) * vec[0] <= 1e-6 * np.max(np.abs(jac[:, 1:] * vec[1:]))
        cols = [1, 2]
    scale = np.max(np.abs(fd[:, cols]), axis=0)  # per column: the derivatives' size
    assert np.all(scale > 0)
    np.testing.assert_allclose(jac[:, cols] / scale, fd[:, cols] / scale, rtol=1e-4, atol=1e-4)


def test_jacobian_in_the_overflow_regime_is_exact_zero_where_saturated(sed):
    """gamma 10 /Pa, lambda 100 Pa: the naive exp overflows; expit(u) expit(-u) underflows to 0 instead."""
    p = SigmoidParams(3e-8, 10.0, 100.0)
    s = np.asarray(sed.values)[-1]
    with np.errstate(over="raise"), pytest.raises(FloatingPointError):
        np.exp(p.gamma * (p.lambda_ - s))
    obj = _objective(sed, make_observed(sed, noise=0.0), "neither")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        jac = obj.jacobian([p.alpha, p.gamma, p.lambda_])
    assert np.all(np.isfinite(jac))
    # An afferent whose receptors all sit > 750 sigmoid widths from lambda (exp(-750) underflows to 0)
    # has exactly zero gamma and lambda derivatives; the others do not.
    w = Branching.longitudinal(sed.layout).weights.toarray()
    far = np.all((w == 0) | (np.abs(s - p.lambda_)[None, :] * p.gamma > 750), axis=1)
    assert far.any() and (~far).any()
    assert np.all(jac[far, 1:] == 0.0) and np.all(np.abs(jac[~far, 1:]).max(axis=1) > 0)


def test_a_constant_prediction_has_a_zero_jacobian(sed):
    obj = _objective(sed, make_observed(sed, noise=0.0), "both")
    jac = obj.jacobian([3e-8, 1.0, -5000.0])  # every receptor saturated: the shape is undefined
    assert np.all(jac == 0.0)
    assert obj.n_jacobians == 1


# ------------------------------------------------------------------ recovery and its cost
@pytest.mark.parametrize("normalise", ["both", "neither"])
@pytest.mark.parametrize("truth", [SigmoidParams(3e-8, 5e-3, 600.0), SigmoidParams(3e-8, 2e-3, 900.0)],
                         ids=["g5e-3_l600", "g2e-3_l900"])
def test_noise_free_recovery_on_the_fe_sample_within_1_percent_in_few_evaluations(sample, truth, normalise):
    """From the study's start (2.46e-8 A, 4.6e-3 /Pa, 300 Pa); the SED spans 22-2374 Pa.

    Measured: 17 + 13, 18 + 14 (both) and 7 + 7, 8 + 8 (neither) function + Jacobian evaluations;
    before the closed form (finite differences, 4 starts always) 144, 212, 153, 165 evaluations.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gamma-lambda ridge warnings of the normalised profile
        res = calibrate(sample, _clean_profile(sample, truth), method="least_squares", normalise=normalise)
    assert res.status == "converged" and res.success
    np.testing.assert_allclose(res.params.gamma, truth.gamma, rtol=RECOVERY_RTOL)
    np.testing.assert_allclose(res.params.lambda_, truth.lambda_, rtol=RECOVERY_RTOL)
    if normalise == "neither":
        np.testing.assert_allclose(res.params.alpha, truth.alpha, rtol=RECOVERY_RTOL)
    else:
        assert res.no_effect == ("alpha",)
    assert res.n_jacobian_evaluations > 0
    assert res.n_evaluations + res.n_jacobian_evaluations <= MAX_COST
    assert "best is start 1 of 1 run" in res.message  # one start sufficed
    assert (f"{res.n_evaluations} model evaluations and {res.n_jacobian_evaluations} Jacobian evaluations"
            in res.message)


def test_finite_differences_reach_the_same_optimum_at_a_higher_cost(sed):
    observed = make_observed(sed)
    exact = calibrate(sed, observed, method="least_squares", normalise="neither")
    fd = calibrate(sed, observed, method="least_squares", normalise="neither", jac="2-point")
    assert fd.n_jacobian_evaluations == 0 and exact.n_jacobian_evaluations > 0
    for name in ("alpha", "gamma", "lambda_"):
        np.testing.assert_allclose(getattr(exact.params, name), getattr(fd.params, name), rtol=1e-4)
    assert exact.ssd <= fd.ssd * (1 + 1e-9)
    assert exact.n_evaluations + exact.n_jacobian_evaluations < fd.n_evaluations
    assert "Jacobian by finite differences (2-point)" in fd.message and "closed-form Jacobian" in exact.message


# ------------------------------------------------------------------------------ fallback
def test_start_failed_says_why():
    ok = types.SimpleNamespace(status=1, message="`gtol` termination condition is satisfied.")
    fit = types.SimpleNamespace(r2=0.97)
    assert start_failed(ok, fit, False) == ""
    budget = types.SimpleNamespace(status=0, message="The maximum number of function evaluations is exceeded.")
    assert start_failed(budget, fit, False) == (
        "scipy stopped without converging (status 0: The maximum number of function evaluations is exceeded.)")
    assert start_failed(ok, fit, True) == "its end point predicts a constant profile"
    poor = types.SimpleNamespace(r2=0.5)
    assert start_failed(ok, poor, False) == (
        f"its end point explains only R^2 = 0.5 < {FALLBACK_R2:g} of the observed profile")
    assert start_failed(ok, types.SimpleNamespace(r2=float("nan")), False).startswith("its end point explains only")


def test_a_failed_first_start_falls_back_to_the_seeded_random_starts(sed):
    """A recording in nA compared un-normalised with a prediction in A: the first start cannot follow it."""
    obs = make_observed(sed, noise=0.0)
    in_na = ObservedProfile(obs.positions, obs.response * 1e9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = calibrate(sed, in_na, method="least_squares", normalise="neither")
    assert re.search(r"the first start failed \(its end point explains only R\^2 = [-0-9.e+]+ < 0\.9 of the observed "
                     r"profile\), so 3 seeded random start\(s\) followed; best is start \d of 4 run", res.message)
    assert res.iterations["iteration"].tolist() == [0, 1, 2, 3, 4]


def test_restarts_always_runs_every_start(sed):
    observed = make_observed(sed)
    once = calibrate(sed, observed, method="least_squares")
    always = calibrate(sed, observed, method="least_squares", restarts="always", n_starts=3)
    assert once.iterations["iteration"].tolist() == [0, 1]
    assert always.iterations["iteration"].tolist() == [0, 1, 2, 3]
    assert "of 3 run (at most 3;" in always.message
    assert always.ssd <= once.ssd * (1 + 1e-9)
    assert always.n_evaluations > once.n_evaluations


# --------------------------------------------------------------------- what is recorded
def test_counts_and_status_are_recorded(sed):
    observed = make_observed(sed)
    ls = calibrate(sed, observed, method="least_squares")
    rsm = calibrate(sed, observed, start=STUDY_PARAMS["start"])
    assert rsm.n_jacobian_evaluations == 0 and ls.n_jacobian_evaluations > 0
    d = ls.to_dict()
    assert (d["status"], d["n_evaluations"], d["n_jacobian_evaluations"]) == (
        "converged", ls.n_evaluations, ls.n_jacobian_evaluations)
    assert d["identifiability"]["n_jacobian_evaluations"] == 1
    table = methods_table({"rsm1": rsm, "least_squares": ls})
    assert table["jacobian_evaluations"].tolist() == [0, ls.n_jacobian_evaluations]
    assert table["status"].tolist() == ["converged", "converged"]
    assert f"{ls.n_evaluations} evaluations + {ls.n_jacobian_evaluations} Jacobian, no effect: alpha>" in repr(ls)


@pytest.mark.parametrize("kwargs, message", [
    (dict(jac="exact"), "Invalid value for the 'jac' parameter. Allowed values are 'analytic', '2-point' and "
                        "'3-point', but got 'exact' instead."),
    (dict(restarts="never"), "Invalid value for the 'restarts' parameter. Allowed values are 'on_failure' and "
                             "'always', but got 'never' instead."),
])
def test_option_errors(sed, kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        calibrate(sed, make_observed(sed), method="least_squares", **kwargs)
