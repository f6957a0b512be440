"""The least-squares reference: :func:`scipy.optimize.least_squares` on the residual vector.

::

    start --least_squares(trf, bounds alpha >= 0, gamma >= 0)--> outcome for finish()

The residuals are ``d - e`` (observed minus predicted, as compared), divided by the largest
|observed| so that they are O(1) whatever the unit; the variables are the free parameters
divided by their start values.
"""

from __future__ import annotations

import math

import numpy as np

from ..transduction import saturation_report
from .design import PARAMETERS, encode, increments, params_to_vector
from .objective import LOWER_BOUNDS, Runs, clip, iter_row
from .surface import NO_EFFECT_RTOL

__all__ = ["DEFAULT_N_STARTS", "LS_TOL", "least_squares_reference"]

#: Starts of the least-squares reference: the given start plus 3 seeded random ones.
DEFAULT_N_STARTS = 4
#: ftol, xtol and gtol of the least-squares reference (scipy's defaults): the reference is
#: converged tightly whatever ``tol`` the RSM uses.
LS_TOL = 1e-8


def least_squares_reference(obj, start, inc, max_iter, n_starts, gen):
    import pandas as pd
    from scipy.optimize import least_squares

    runs = Runs()
    x0 = params_to_vector(start)
    dxi0 = increments(x0, inc)
    free = np.array([not obj.norm_pred, True, True])  # alpha cancels out of a normalised prediction
    scale = np.abs(x0)
    ev, fit0, d0 = obj(x0)
    runs.add(0, "start", 0, np.zeros(3), x0, ev, fit0, d0, False)
    dscale = float(np.max(np.abs(fit0.observed))) or 1.0
    iters = [iter_row(0, x0, fit0.ssd, obj.n_evaluations)]
    span = float(np.ptp(obj.sed_row)) or abs(x0[2])
    starts = [x0]
    for _ in range(n_starts - 1):
        s = x0.copy()
        if free[0]:
            s[0] = x0[0] * math.exp(gen.uniform(-math.log(2.0), math.log(2.0)))
        s[1] = x0[1] * math.exp(gen.uniform(-math.log(3.0), math.log(3.0)))
        s[2] = x0[2] + gen.uniform(-1.0, 1.0) * max(abs(x0[2]), span)
        starts.append(s)
    lower = np.where(np.isfinite(LOWER_BOUNDS), LOWER_BOUNDS / np.where(scale > 0, scale, 1.0), -np.inf)[free]
    state = {"k": 0}

    def full(z):
        vec = x0.copy()
        vec[free] = np.asarray(z, dtype=float) * scale[free]
        return clip(vec)

    def resid(z):
        vec, lo = full(z)
        ev, f, d = obj(vec)
        runs.add(state["k"], "least_squares", ev, encode(vec, x0, dxi0), vec, ev, f, d, lo.any())
        return (f.observed - f.predicted) / dscale

    best = None
    max_nfev = max(100, 10 * max_iter)
    for k, s in enumerate(starts, start=1):
        state["k"] = k
        z0 = np.maximum(s[free] / scale[free], lower)
        res = least_squares(resid, z0, bounds=(lower, np.full(lower.shape, np.inf)), method="trf",
                            ftol=LS_TOL, xtol=LS_TOL, gtol=LS_TOL, max_nfev=max_nfev)
        vec, _ = full(res.x)
        _, f, d = obj(vec)
        iters.append(iter_row(k, vec, f.ssd, obj.n_evaluations))
        if not d and (best is None or f.ssd < best[1]):
            best = (vec, f.ssd, res, k)
    if best is None:  # every start ended degenerate
        vec = x0
        status = ("The objective is flat or degenerate from every start: every least-squares run ended with a "
                  "constant predicted profile. " + saturation_report(obj.sed_row, start).message)
        success = False
        no_effect_j = np.zeros(3, bool)
    else:
        vec, _, res, k = best
        success = bool(res.status > 0)
        status = (f"least_squares (trf, bounds alpha >= 0, gamma >= 0) from {n_starts} start(s): best is start {k} "
                  f"(scipy nfev {res.nfev}, Jacobian by finite differences; {obj.n_evaluations} model evaluations "
                  f"over all starts); scipy: {res.message}")
        # No effect: a Jacobian column ~0 relative to the largest (scaled variables).
        norms = np.linalg.norm(res.jac, axis=0) if res.jac.size else np.zeros(free.sum())
        no_effect_j = np.zeros(3, bool)
        if norms.size and norms.max() > 0:
            no_effect_j[free] = norms <= NO_EFFECT_RTOL * norms.max()
    no_effect = tuple(p for p, j, fr in zip(PARAMETERS, no_effect_j, free) if j or not fr)
    frame = runs.frame()
    clipped = tuple(p for p in PARAMETERS[:2] if bool(((frame[p] == 0.0) & frame["clipped"]).any()))
    return dict(base=vec, iterations=pd.DataFrame(iters), runs=frame, coefficients=pd.DataFrame(),
                no_effect=no_effect, clipped=clipped, success=success, status=status, canonical=None)


# ------------------------------------------------------------------------------- finish
