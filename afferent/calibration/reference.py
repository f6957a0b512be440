"""The least-squares reference: :func:`scipy.optimize.least_squares` on the residual vector.

::

    start --least_squares(trf, bounds alpha >= 0, gamma >= 0)--> outcome for finish()

The residuals are ``d - e`` (observed minus predicted, as compared), divided by the largest
|observed| so that they are O(1) whatever the unit; the variables are the free parameters
divided by their start values. Their Jacobian is closed form (the model is: see
:meth:`.objective.Objective.jacobian`): a trust-region step costs one model and one Jacobian
evaluation (about two model evaluations) instead of 1 + (number of free parameters) with
finite differences, and exact derivatives take fewer steps. On noise-free profiles of the
bundled FE sample one start converges in 7 + 7 to 18 + 14 evaluations (model + Jacobian),
where finite differences from 4 starts took 144-212 (benchmarks/bench_calibration.py).

One start first: the given one. Only when it *fails* (:func:`start_failed`: scipy stopped at
its evaluation budget, the end point's predicted profile is constant, or the fit explains less
than :data:`FALLBACK_R2` of the observed profile's variance) are the seeded random starts run
(``restarts='always'`` runs them all regardless), and the best end point is kept.
"""

from __future__ import annotations

from .objective import Objective
from ..profiles import ProfileFit
from ..transduction import SigmoidParams

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from scipy.optimize import OptimizeResult

import math
from typing import Literal, get_args

import numpy as np

from ..transduction import saturation_report
from .design import PARAMETERS, encode, increments, params_to_vector
from .objective import LOWER_BOUNDS, Runs, clip, iter_row
from .surface import NO_EFFECT_RTOL

__all__ = ["DEFAULT_N_STARTS", "LS_TOL", "FALLBACK_R2", "JACOBIANS", "RESTARTS", "start_failed", "least_squares_reference"]

#: Starts of the least-squares reference at most: the given start, then (only when it fails,
#: or with ``restarts='always'``) 3 seeded random ones.
DEFAULT_N_STARTS = 4
#: ftol, xtol and gtol of the least-squares reference (scipy's defaults): the reference is
#: converged tightly whatever ``tol`` the RSM uses.
LS_TOL = 1e-8
#: A start whose end point explains less than this fraction of the observed profile's variance
#: (the usual coefficient of determination R^2, as compared) has failed: the profile's shape
#: is not followed, a sign of a local minimum or of a slide into the saturated tail, and the
#: random starts are tried. A good fit of a noisy recording stays well above it (R^2 0.98 for
#: 2 % noise on the bundled sample's synthetic profile).
FALLBACK_R2 = 0.9
#: How the residuals' Jacobian is obtained: closed form, or scipy's finite differences (the
#: method before the closed form existed; kept for cross-checks and benchmarks).
Jacobian = Literal["analytic", "2-point", "3-point"]
JACOBIANS: tuple[str, ...] = get_args(Jacobian)
#: When the random starts are run: only when the first start fails, or always.
Restarts = Literal["on_failure", "always"]
RESTARTS: tuple[str, ...] = get_args(Restarts)


class _Problem:
    """The scaled least-squares problem: variables z = free parameters / |start|, residuals (d - e) / max|d|."""

    def __init__(self, obj, start, inc):
        self.obj, self.runs, self.k = obj, Runs(), 0
        self.x0 = params_to_vector(start)
        self.dxi0 = increments(self.x0, inc)
        self.free = np.array([not obj.norm_pred, True, True])  # alpha cancels out of a normalised prediction
        self.scale = np.abs(self.x0)
        ev, fit0, d0 = obj(self.x0)
        self.runs.add(0, "start", 0, np.zeros(3), self.x0, ev, fit0, d0, False)
        self.fit0 = fit0
        self.dscale = float(np.max(np.abs(fit0.observed))) or 1.0
        safe = np.where(self.scale > 0, self.scale, 1.0)
        self.lower = np.where(np.isfinite(LOWER_BOUNDS), LOWER_BOUNDS / safe, -np.inf)[self.free]

    def full(self, z):
        vec = self.x0.copy()
        vec[self.free] = np.asarray(z, dtype=float) * self.scale[self.free]
        return clip(vec)

    def residuals(self, z):
        vec, lo = self.full(z)
        ev, f, d = self.obj(vec)
        self.runs.add(self.k, "least_squares", ev, encode(vec, self.x0, self.dxi0), vec, ev, f, d, lo.any())
        return (f.observed - f.predicted) / self.dscale

    def jacobian(self, z):
        """d residuals / dz, closed form: -(de/dparams)[:, free] x |start| / max|d|; 0 for a clipped parameter."""
        vec, lo = self.full(z)
        jac = -self.obj.jacobian(vec) * (self.scale / self.dscale)
        jac[:, lo] = 0.0
        return jac[:, self.free]

    def random_starts(self, n_starts, gen) -> list:
        """The given start, then ``n_starts - 1`` seeded random ones (alpha x/ 2, gamma x/ 3, lambda +- its SED span)."""
        x0, span = self.x0, float(np.ptp(self.obj.sed_row)) or abs(self.x0[2])
        starts = [x0]
        for _ in range(n_starts - 1):
            s = x0.copy()
            if self.free[0]:
                s[0] = x0[0] * math.exp(gen.uniform(-math.log(2.0), math.log(2.0)))
            s[1] = x0[1] * math.exp(gen.uniform(-math.log(3.0), math.log(3.0)))
            s[2] = x0[2] + gen.uniform(-1.0, 1.0) * max(abs(x0[2]), span)
            starts.append(s)
        return starts

    def solve(self, k, s, max_nfev, jac):
        from scipy.optimize import least_squares

        self.k = k
        z0 = np.maximum(s[self.free] / self.scale[self.free], self.lower)
        res = least_squares(self.residuals, z0, jac=self.jacobian if jac == "analytic" else jac,
                            bounds=(self.lower, np.full(self.lower.shape, np.inf)), method="trf",
                            ftol=LS_TOL, xtol=LS_TOL, gtol=LS_TOL, max_nfev=max_nfev)
        vec, _ = self.full(res.x)
        return res, vec, self.obj(vec)


def start_failed(res: OptimizeResult, fit: ProfileFit, degenerate: bool) -> str:
    """Why a least-squares start counts as failed, or '' when it did not fail.

    Parameters
    ----------
    res : scipy.optimize.OptimizeResult
        scipy's result of the start.
    fit : ProfileFit
        The comparison at its end point.
    degenerate : bool
        The end point's predicted profile is constant or nearly so (no shape).

    Returns
    -------
    str
        '' if the start succeeded; otherwise a sentence: scipy's ``status <= 0`` (trf's only
        such status is 0, the evaluation budget ``max_nfev`` ran out), a degenerate end
        point, or ``R^2 < FALLBACK_R2`` (0.9) at the end point.
    """
    if res.status <= 0:
        return f"scipy stopped without converging (status {res.status}: {res.message})"
    if degenerate:
        return "its end point predicts a constant profile"
    if not fit.r2 >= FALLBACK_R2:
        return f"its end point explains only R^2 = {fit.r2:.3g} < {FALLBACK_R2:g} of the observed profile"
    return ""


def least_squares_reference(obj: Objective, start: SigmoidParams, inc: float, max_iter: int, n_starts: int, gen: np.random.Generator, *, jac: Jacobian="analytic",
                            restarts: Restarts="on_failure") -> dict:
    """The least-squares reference from ``start`` (and seeded random starts when it fails).

    Parameters
    ----------
    obj : Objective
    start : SigmoidParams
        alpha (A), gamma (1/Pa), lambda (Pa); alpha and gamma > 0, lambda != 0 (the scales).
    inc : float
        Coding step fraction, only to express the evaluated points in coded units (design_runs).
    max_iter : int
        ``max_nfev = max(100, 10 x max_iter)`` per start.
    n_starts : int
        Starts at most (the given one first).
    gen : numpy.random.Generator
        Draws the random starts.
    jac : {'analytic', '2-point', '3-point'}, default='analytic'
    restarts : {'on_failure', 'always'}, default='on_failure'

    Returns
    -------
    dict
        The outcome for :func:`.result.finish`; ``status`` is 'converged', 'flat' or
        'max_iter'.
    """
    import pandas as pd

    prob = _Problem(obj, start, inc)
    iters = [iter_row(0, prob.x0, prob.fit0.ssd, obj.n_evaluations)]
    starts = prob.random_starts(n_starts, gen)
    best, first_failure, n_run = None, "", 0
    for k, s in enumerate(starts, start=1):
        res, vec, (_, f, d) = prob.solve(k, s, max(100, 10 * max_iter), jac)
        n_run = k
        iters.append(iter_row(k, vec, f.ssd, obj.n_evaluations))
        if not d and (best is None or f.ssd < best[1]):
            best = (vec, f.ssd, res, k)
        why = start_failed(res, f, d) if k == 1 else ""
        first_failure = first_failure or why
        if k == 1 and not why and restarts == "on_failure":
            break
    frame = prob.runs.frame()
    out = dict(iterations=pd.DataFrame(iters), runs=frame, coefficients=pd.DataFrame(), canonical=None,
               clipped=tuple(p for p in PARAMETERS[:2] if bool(((frame[p] == 0.0) & frame["clipped"]).any())))
    if best is None:  # every start ended degenerate
        note = ("The objective is flat or degenerate from every start: every least-squares run ended with a "
                "constant predicted profile. " + saturation_report(obj.sed_row, start).message)
        no_effect = tuple(p for p, fr in zip(PARAMETERS, prob.free) if not fr)
        return dict(out, base=prob.x0, success=False, status="flat", note=note, no_effect=no_effect)
    vec, _, res, k = best
    how = "closed-form Jacobian" if jac == "analytic" else f"Jacobian by finite differences ({jac})"
    plan = (f"the first start failed ({first_failure}), so {n_run - 1} seeded random start(s) followed; "
            if first_failure else "")
    note = (f"least_squares (trf, bounds alpha >= 0, gamma >= 0, {how}): {plan}best is start {k} of {n_run} run "
            f"(at most {n_starts}; scipy nfev {res.nfev}, njev {res.njev}); {obj.n_evaluations} model evaluations and "
            f"{obj.n_jacobians} Jacobian evaluations over all starts; scipy: {res.message}")
    # No effect: a Jacobian column ~0 relative to the largest (scaled variables) at a parameter that
    # never moved from its start. One that moved and ends where it no longer acts (deep in the
    # sigmoid's tail) was fitted, not left alone: the identifiability check reports that ridge.
    norms = np.linalg.norm(res.jac, axis=0) if res.jac.size else np.zeros(prob.free.sum())
    no_effect_j = np.zeros(3, bool)
    if norms.size and norms.max() > 0:
        no_effect_j[prob.free] = (norms <= NO_EFFECT_RTOL * norms.max()) & (vec[prob.free] == prob.x0[prob.free])
    no_effect = tuple(p for p, j, fr in zip(PARAMETERS, no_effect_j, prob.free) if j or not fr)
    converged = bool(res.status > 0)
    return dict(out, base=vec, success=converged, status="converged" if converged else "max_iter", note=note,
                no_effect=no_effect)
