"""Properties: the RSM ends with a clear status on flat, noisy and ill-conditioned objectives.

Whatever the SED, the recording and the start (within their documented domains), ``calibrate``
with ``method='rsm1'`` or ``'rsm2'`` returns a result whose ``status`` is one of the documented
:data:`~afferent.calibration.result.STATUSES`, with ``success`` true exactly when it is
'converged', a non-empty message, and finite parameters and ssd; it raises nothing (warnings
only, AfferentWarning). The only documented error on valid types, a recording without shape
(constant: its normalised form is all zeros), is pinned separately.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from afferent.calibration import STATUSES, calibrate
from afferent.exceptions import AfferentWarning
from afferent.profiles import ObservedProfile
from afferent.receptors import grid_layout
from afferent.sampling import ReceptorSED
from afferent.synthesis import Branching

#: 6 sections x 4 papillae = 24 receptors; longitudinal sections give 6 afferents along x.
LAYOUT = grid_layout(x_range=(0.0, 2.2e-3), z_range=(0.0, 0.66e-3), y=-0.75e-3)
N = LAYOUT.n_receptors
POSITIONS = Branching.longitudinal(LAYOUT).positions
#: Small budgets keep each example fast; running out of them must be reported as 'max_iter'.
BUDGET = dict(max_iter=4, max_steps=15)


def _sed(values) -> ReceptorSED:
    values = np.asarray(values, float).reshape(1, N)
    return ReceptorSED(values, np.array([0.1]), LAYOUT, "linear", np.zeros(N, bool))


sed_level = st.floats(0.0, 1e5)
flat_sed = sed_level.map(lambda c: np.full(N, c))
noisy_sed = st.lists(st.floats(0.0, 1e5), min_size=N, max_size=N).map(np.array)
#: A level with a modulation of 1e-15 .. 1e-6 of it (nearly constant: rounding or a tiny shape),
#: or a single spike 1e4-1e8 times the rest (one receptor dominates).
ill_sed = st.one_of(
    st.tuples(st.floats(1.0, 1e5), st.floats(-15.0, -6.0), st.integers(0, 2**32 - 1)).map(
        lambda t: t[0] * (1.0 + 10.0 ** t[1] * np.random.default_rng(t[2]).standard_normal(N))),
    st.tuples(st.floats(1e-4, 1.0), st.floats(4.0, 8.0), st.integers(0, N - 1)).map(
        lambda t: np.where(np.arange(N) == t[2], t[0] * 10.0 ** t[1], t[0])),
)
#: A recording with a shape: random responses (nA-scale, in A) whose range is not negligible.
observed = st.lists(st.floats(0.0, 1e-7), min_size=POSITIONS.size, max_size=POSITIONS.size).filter(
    lambda r: np.ptp(r) > 1e-6 * max(max(r), 1e-300)).map(lambda r: ObservedProfile(POSITIONS, np.array(r)))
start = st.tuples(st.floats(1e-10, 1e-6), st.floats(-6.0, 1.0), st.floats(1.0, 1e4), st.booleans()).map(
    lambda t: (t[0], 10.0 ** t[1], t[2] if t[3] else -t[2]))
method = st.sampled_from(["rsm1", "rsm2"])
normalise = st.sampled_from(["both", "neither"])


def _check_clear_status(res):
    event(f"status {res.status}")  # pytest --hypothesis-show-statistics: which statuses were reached
    assert res.status in STATUSES
    assert res.success == (res.status == "converged")
    assert isinstance(res.message, str) and res.message.strip()
    p = res.params
    assert np.all(np.isfinite([p.alpha, p.gamma, p.lambda_, res.ssd]))
    assert p.alpha >= 0.0 and p.gamma >= 0.0
    assert not res.iterations[["alpha", "gamma", "lambda", "ssd"]].isna().any().any()
    if res.status == "max_iter":
        assert res.message.startswith("Stopped at max_iter=4 iterations")
    if res.status == "flat":
        assert res.message.startswith("The objective is flat")


def _run(sed_values, obs, start_, method_, normalise_):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)  # saturation, ridge, range: warned, by design
        return calibrate(_sed(sed_values), obs, start=start_, method=method_, normalise=normalise_, **BUDGET)


PROPERTY = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@PROPERTY
@given(sed_values=flat_sed, obs=observed, start_=start, method_=method)
def test_a_flat_objective_ends_flat(sed_values, obs, start_, method_):
    """Every receptor has the same SED: the normalised prediction has no shape, there is no descent."""
    res = _run(sed_values, obs, start_, method_, "both")
    _check_clear_status(res)
    assert res.status == "flat" and not res.success


@PROPERTY
@given(sed_values=noisy_sed, obs=observed, start_=start, method_=method, normalise_=normalise)
def test_a_noisy_objective_ends_with_a_clear_status(sed_values, obs, start_, method_, normalise_):
    _check_clear_status(_run(sed_values, obs, start_, method_, normalise_))


@PROPERTY
@given(sed_values=ill_sed, obs=observed, start_=start, method_=method, normalise_=normalise)
def test_an_ill_conditioned_objective_ends_with_a_clear_status(sed_values, obs, start_, method_, normalise_):
    _check_clear_status(_run(sed_values, obs, start_, method_, normalise_))


def test_the_documented_error_a_recording_without_shape():
    flat_recording = ObservedProfile(POSITIONS, np.full(POSITIONS.size, 3e-8))
    with pytest.raises(ValueError, match=re.escape(
            "The observed profile (as compared) is all zeros, so r2_study is undefined; a constant recording "
            "carries no shape.")):
        calibrate(_sed(np.linspace(0.0, 200.0, N)), flat_recording)
