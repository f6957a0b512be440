"""What a compared profile determines: the residuals' Jacobian at the fitted parameters.

::

    Objective + fitted (alpha, gamma, lambda) --identifiability--> singular values, condition number, ridge

A min-max normalised profile often constrains one combination of gamma and lambda much better
than the other (a ridge in the ssd along which other (gamma, lambda) fit as well); this module
measures that, so a result can say so instead of presenting one point of the ridge as "the" fit.
"""

from __future__ import annotations

from .objective import Objective

from .._typing import ArrayLike
from collections.abc import Sequence

import numpy as np

from .design import PARAMETERS

__all__ = ["IDENTIFIABLE_COND", "RIDGE_STEPS", "identifiability"]

#: Largest condition number (of the residuals' Jacobian in scaled parameters) for which the
#: fitted parameters count as identified: beyond it one combination is determined over 100x less
#: well than the best one, and the fit slides along a ridge (gamma-lambda trade-off).
IDENTIFIABLE_COND = 100.0
#: Scaled steps along the ridge direction at which ssd is evaluated (units: see identifiability).
RIDGE_STEPS = (-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0)


def identifiability(obj: Objective, vec: ArrayLike, no_effect: Sequence[str]=()) -> dict:
    """Which parameter combinations the compared profiles determine at ``vec``.

    The residuals r = predicted - observed (as compared) are differentiated in closed form
    (:meth:`~afferent.calibration.objective.Objective.jacobian`, chain rule) with respect to
    scaled parameters: ``ln gamma`` (relative change of gamma) and
    ``gamma x lambda`` (lambda in units of the sigmoid's width 1/gamma); alpha too unless it has
    no effect (min-max normalisation cancels it). The singular values of that Jacobian say how
    well each combination is determined; the right singular vector of the smallest is the ridge
    along which the ssd barely changes.

    Parameters
    ----------
    obj : Objective
        The calibration objective (:class:`~afferent.calibration.objective.Objective`); its
        evaluations here are counted in its ``n_evaluations`` and reported apart.
    vec : array_like of shape (3,)
        The fitted alpha (A), gamma (1/Pa), lambda (Pa).
    no_effect : sequence of str, default=()
        Parameters left out (no effect on the ssd).

    Returns
    -------
    dict
        ``parameters`` and their ``scales``, ``singular_values``, ``condition_number``,
        ``ridge_direction`` (unit vector in the scaled parameters), ``ssd_along_ridge``
        (``{step: ssd}`` for :data:`~afferent.calibration.conditioning.RIDGE_STEPS`), ``identifiable``, ``out_of_range`` (list of
        texts), ``n_evaluations`` (model evaluations, along the ridge) and
        ``n_jacobian_evaluations`` spent.
    """
    vec = np.asarray(vec, dtype=float)
    alpha, gamma, lam = vec
    names = [p for p in PARAMETERS if p not in no_effect]
    n_before = obj.n_evaluations

    def to_vec(u):
        v = vec.copy()
        for name, x in zip(names, u):
            if name == "alpha":
                v[0] = alpha * np.exp(x)
            elif name == "gamma":
                v[1] = gamma * np.exp(x)
            else:
                v[2] = lam + x / gamma if gamma > 0 else lam + x
        return v

    jac_params = obj.jacobian(vec)  # d(predicted)/d(alpha, gamma, lambda)
    chain = {"alpha": alpha, "gamma": gamma, "lambda": 1.0 / gamma if gamma > 0 else 1.0}
    jac = np.column_stack([jac_params[:, PARAMETERS.index(n)] * chain[n] for n in names]) if names else np.zeros((0, 0))
    out_of_range = []
    if lam < 0:
        out_of_range.append(f"lambda = {lam:.4g} Pa < 0: the sigmoid's midpoint lies below zero SED, so every receptor "
                            "is above half-height even unloaded; the fit uses the sigmoid's exponential tail")
    if gamma <= 0:
        out_of_range.append(f"gamma = {gamma:.4g} /Pa <= 0: the current does not increase with SED")
    if jac.size == 0 or not np.all(np.isfinite(jac)):
        return {"parameters": names, "singular_values": [], "condition_number": float("nan"), "identifiable": False,
                "ridge_direction": [], "ssd_along_ridge": {}, "out_of_range": out_of_range,
                "n_evaluations": obj.n_evaluations - n_before, "n_jacobian_evaluations": 1}
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    ridge = vt[-1] * np.sign(vt[-1][np.argmax(np.abs(vt[-1]))])
    along = {float(t): float(obj(to_vec(t * ridge))[1].ssd) for t in RIDGE_STEPS}
    return {
        "parameters": names,
        "scales": {"alpha": "ln alpha", "gamma": "ln gamma", "lambda": "gamma x lambda (sigmoid widths)"},
        "singular_values": [float(v) for v in sv], "condition_number": cond,
        "ridge_direction": {n: float(v) for n, v in zip(names, ridge)}, "ssd_along_ridge": along,
        "identifiable": bool(cond <= IDENTIFIABLE_COND), "out_of_range": out_of_range,
        "n_evaluations": obj.n_evaluations - n_before, "n_jacobian_evaluations": 1,
    }
