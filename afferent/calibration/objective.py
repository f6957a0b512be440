"""The calibration objective: one parameter vector -> the compared profiles and their ssd.

::

    (alpha A, gamma 1/Pa, lambda Pa) --transduce--> receptor current (A) --synthesize--> afferent current (A)
        --compare_profiles(observed)--> ProfileFit (ssd, predicted and observed as compared)

The model is closed form: receptor i carries ``I_i = alpha * expit(gamma (s_i - lambda))``
(``s_i`` its SED in Pa), afferent j the weighted sum ``A_j = sum_i w_ji I_i``, and the
compared prediction is ``A`` itself or its min-max normalised shape. So the derivative of the
compared prediction with respect to (alpha, gamma, lambda) is closed form too
(:meth:`Objective.jacobian`); the least-squares reference uses it instead of finite
differences.

Every evaluation is counted and cached (a repeated point is not evaluated again), so the
evaluation counts a result reports are the model evaluations actually spent.
"""

from __future__ import annotations

from ..profiles import Normalise, ObservedProfile
from ..sampling import OnOutside
from ..synthesis import Branching

from .._typing import ArrayLike
from typing import Any

import math
import warnings

import numpy as np

from ..exceptions import AfferentWarning
from ..profiles import NEARLY_CONSTANT_RTOL, ProfileFit, compare_profiles, observed_on
from ..synthesis import synthesize
from ..transduction import _expit as expit  # the one sigmoid of the package (scipy.special.expit's formula)
from ..transduction import transduce
from .design import vector_to_params

__all__ = ["LOWER_BOUNDS", "Objective"]

#: Lower bounds of (alpha, gamma, lambda): alpha >= 0 A, gamma >= 0 1/Pa, lambda free.
LOWER_BOUNDS = np.array([0.0, 0.0, -np.inf])


class Objective:
    """ssd (and the whole ProfileFit) of one parameter vector; caches repeated points.

    Parameters
    ----------
    sed_row : ndarray of shape (1, n_receptors)
        SED at the receptors at the compared time step, in Pa.
    times_row : ndarray of shape (1,) or None
        Its time in s.
    branching : Branching
        Receptor -> afferent weights.
    observed : ObservedProfile
        The recording (positions in m).
    normalise : {'both', 'prediction', 'observation', 'neither'}
    on_outside : {'raise', 'drop'}
    bar : tqdm progress bar, optional
        Updated once per model evaluation.

    Attributes
    ----------
    n_evaluations : int
        Model evaluations (transduce -> synthesize -> compare) spent so far.
    n_jacobians : int
        Evaluations of the closed-form Jacobian spent so far (each costs about one model
        evaluation: one sigmoid and one synthesis of three columns).
    """

    def __init__(self, sed_row: np.ndarray, times_row: np.ndarray | None, branching: Branching, observed: ObservedProfile, normalise: Normalise="both", on_outside: OnOutside="raise", bar: Any=None) -> None:
        self.sed_row = sed_row  # (1, n_receptors) Pa
        self.times_row = times_row
        self.branching = branching
        self.observed = observed
        self.normalise = normalise
        self.on_outside = on_outside
        self.norm_pred = normalise in ("both", "prediction")
        self.bar = bar
        self.cache: dict[tuple, tuple[int, ProfileFit, bool]] = {}
        self.n_evaluations = 0
        self.n_jacobians = 0
        self.best = math.inf
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AfferentWarning)
            # The afferents compare_profiles keeps (all, unless on_outside='drop' leaves some out).
            self.keep = np.isfinite(observed_on(branching.positions, observed, on_outside="nan"))

    def __call__(self, vec) -> tuple[int, ProfileFit, bool]:
        """``(evaluation number, ProfileFit, degenerate)`` at ``vec`` = (alpha A, gamma 1/Pa, lambda Pa)."""
        key = tuple(float(v) for v in vec)
        hit = self.cache.get(key)
        if hit is not None:
            return hit
        params = vector_to_params(key)
        with warnings.catch_warnings():
            # Saturated sigmoids and constant profiles warn on every call; they are recorded
            # per run (``degenerate``) and summarised once in the result instead.
            warnings.simplefilter("ignore", AfferentWarning)
            current = transduce(self.sed_row, params, times=self.times_row)
            aff = synthesize(current, self.branching)
            fit = compare_profiles(aff, self.observed, normalise=self.normalise, time_index=0,
                                   on_outside=self.on_outside)
        degenerate = False
        if self.norm_pred:
            pred = aff.values[0]
            lo, hi = float(pred.min()), float(pred.max())
            degenerate = (hi - lo) <= NEARLY_CONSTANT_RTOL * max(abs(lo), abs(hi))
        self.n_evaluations += 1
        out = (self.n_evaluations, fit, bool(degenerate))
        self.cache[key] = out
        if not degenerate and fit.ssd < self.best:
            self.best = fit.ssd
        if self.bar is not None:
            self.bar.update(1)
            if math.isfinite(self.best):
                self.bar.set_postfix(ssd=f"{self.best:.4g}", refresh=False)
        return out

    def jacobian(self, vec: ArrayLike) -> np.ndarray:
        """Closed-form derivative of the compared prediction with respect to (alpha, gamma, lambda).

        With ``u_i = gamma (s_i - lambda)``, ``p_i = expit(u_i)`` and ``p_i (1 - p_i)`` taken
        as ``expit(u_i) expit(-u_i)`` (finite and exactly 0 where ``exp(u_i)`` overflows: the
        saturated regime),

            dI_i/dalpha = p_i,   dI_i/dgamma = alpha p_i (1 - p_i) (s_i - lambda),
            dI_i/dlambda = -alpha gamma p_i (1 - p_i),

        the afferents' derivatives are ``W dI`` (``W`` the branching weights), and with
        min-max normalisation ``e = (A - A_min) / (A_max - A_min)``,

            de = (dA - dA_min - e (dA_max - dA_min)) / (A_max - A_min),

        the argmin and argmax held fixed (the normalisation is differentiable wherever they
        are unique). A constant prediction (the shape is undefined) gives zeros.

        Parameters
        ----------
        vec : array_like of shape (3,)
            alpha (A), gamma (1/Pa), lambda (Pa).

        Returns
        -------
        ndarray of shape (n_compared, 3)
            Columns in (compared unit)/A, (compared unit)/(1/Pa), (compared unit)/Pa: the
            compared unit is 1 for a normalised prediction, A otherwise.
        """
        alpha, gamma, lam = (float(v) for v in np.asarray(vec, dtype=float).reshape(3))
        s = self.sed_row[0]
        with np.errstate(over="ignore"):
            dev = s - lam
            u = gamma * dev
        p = expit(u)
        pq = p * expit(-u)  # p (1 - p) without cancellation or overflow
        d_rec = np.column_stack([p, alpha * pq * dev, -alpha * gamma * pq])
        w = self.branching.weights
        d_aff = np.asarray(w @ d_rec)[self.keep]
        self.n_jacobians += 1
        if not self.norm_pred:
            return d_aff
        a = np.asarray(w @ (alpha * p))[self.keep]
        i_min, i_max = int(np.argmin(a)), int(np.argmax(a))
        span = a[i_max] - a[i_min]
        if not span > 0:
            return np.zeros_like(d_aff)
        e = (a - a[i_min]) / span
        return (d_aff - d_aff[i_min] - e[:, None] * (d_aff[i_max] - d_aff[i_min])) / span


class Runs:
    """Collects the rows of ``CalibrationResult.design_runs``: every point asked for, in order."""

    COLUMNS = ["iteration", "kind", "run", "chi_alpha", "chi_gamma", "chi_lambda", "alpha", "gamma", "lambda",
               "ssd", "evaluation", "clipped", "degenerate"]

    def __init__(self):
        self.rows = []

    def add(self, iteration, kind, run, chi, vec, ev, fit, degenerate, clipped):
        self.rows.append({
            "iteration": iteration, "kind": kind, "run": run,
            "chi_alpha": float(chi[0]), "chi_gamma": float(chi[1]), "chi_lambda": float(chi[2]),
            "alpha": float(vec[0]), "gamma": float(vec[1]), "lambda": float(vec[2]),
            "ssd": float(fit.ssd), "evaluation": ev, "clipped": bool(clipped), "degenerate": bool(degenerate),
        })

    def frame(self):
        import pandas as pd

        return pd.DataFrame(self.rows, columns=self.COLUMNS)


def clip(vec) -> tuple[np.ndarray, np.ndarray]:
    """``vec`` raised to :data:`LOWER_BOUNDS`, and which entries were raised."""
    vec = np.asarray(vec, dtype=float)
    low = vec < LOWER_BOUNDS
    return np.where(low, LOWER_BOUNDS, vec), low


def iter_row(it, vec, ssd, evaluations) -> dict:
    """One row of ``CalibrationResult.iterations``."""
    return {"iteration": it, "alpha": float(vec[0]), "gamma": float(vec[1]), "lambda": float(vec[2]),
            "ssd": float(ssd), "evaluations": int(evaluations)}
