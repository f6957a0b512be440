"""The result of a calibration, and how a method's outcome becomes one.

::

    method outcome (base point, tables, status) + Objective --finish--> CalibrationResult

:func:`finish` evaluates the end point once more, measures what the profile determines
(:func:`~afferent.calibration.conditioning.identifiability`), and writes every caveat into
the result's message: parameters with no effect on the ssd (left at their start value, never
"fitted"), clipping at the lower bounds, saturated receptors, an unidentifiable ridge, and
parameters outside their physical range.
"""

from __future__ import annotations

from .objective import Objective



import warnings
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from ..exceptions import AfferentWarning
from ..profiles import Normalise, ProfileFit
from ..transduction import SaturationReport, SigmoidParams, saturation_report
from .design import PARAMETERS, UNITS, vector_to_params
from .conditioning import IDENTIFIABLE_COND, identifiability

__all__ = ["STATUSES", "CalibrationResult", "finish"]

#: The calibration methods (:data:`afferent.calibration.METHODS`, documented there).
CalibrationMethod = Literal["rsm1", "rsm2", "least_squares"]
#: How a calibration can end (:data:`STATUSES`).
Status = Literal["converged", "flat", "max_iter"]

#: How a calibration can end (``CalibrationResult.status``), and what each means:
#:
#: - ``'converged'``: RSM - an iteration lowered the ssd by at most ``tol`` (relative); least
#:   squares - scipy met ftol, xtol or gtol. The only status with ``success=True``.
#: - ``'flat'``: no descent direction exists around the base point (every design run gives the
#:   same ssd or a constant predicted profile, or no parameter acts on the ssd); least
#:   squares: every start ended at a constant predicted profile. The parameters reported are
#:   the last base point (finite), not a fit.
#: - ``'max_iter'``: the budget ran out (RSM: ``max_iter`` iterations; least squares: scipy's
#:   ``max_nfev`` evaluations) while the ssd was still decreasing.
STATUSES: tuple[str, ...] = get_args(Status)


@dataclass(frozen=True)
class CalibrationResult:
    """Outcome of :func:`~afferent.calibration.calibrate` (scipy.optimize's result object, as a frozen dataclass).

    Parameters
    ----------
    params : SigmoidParams
        Calibrated alpha (A), gamma (1/Pa), lambda_ (Pa). A parameter listed in
        ``no_effect`` was *not* fitted: it keeps its start value.
    ssd : float
        Final objective ``sum (d - e)^2`` (dimensionless for normalised profiles; in the
        square of the compared unit otherwise).
    r2_study, r2 : float
        The study's ``1 - ssd / sum d^2`` and the usual coefficient of determination at ``params``.
    iterations : pandas.DataFrame
        One row per iteration (row 0: the start), columns ``iteration``, ``alpha`` (A),
        ``gamma`` (1/Pa), ``lambda`` (Pa), ``ssd``, ``evaluations`` (cumulative model
        evaluations): the study's table 5.2 for this data. For ``'least_squares'`` a row per
        start (its converged point).
    design_runs : pandas.DataFrame
        Every point asked for, in order: ``iteration``, ``kind`` ('start', 'design', 'path',
        'least_squares'), ``run``, coded ``chi_alpha``, ``chi_gamma``, ``chi_lambda`` (around the
        iteration's base; least squares: around the start with the start's steps),
        ``alpha``, ``gamma``, ``lambda``, ``ssd``, ``evaluation`` (the model evaluation that
        computed it: repeated points are not re-evaluated), ``clipped`` (a parameter was
        raised to its bound), ``degenerate`` (constant or nearly constant normalised
        prediction: its shape is rounding noise, never accepted as the best point).
    coefficients : pandas.DataFrame
        One row per iteration: the fitted surface (``b0``, ``b_alpha``, ... and for 'rsm2' the
        quadratic terms ``b_alpha^2``, ``b_alpha*gamma``, ..., the stationary point ``chi_s_*``,
        eigenvalues ``eig_*`` and ``kind``), ``fit_r2``, the base point ``base_*``, the coding
        steps ``dxi_*`` (parameter units), the step direction ``step_*`` (coded), ``n_steps``
        and the iteration's ``no_effect``. Empty for 'least_squares'.
    no_effect : tuple of str
        Parameters whose effect on the ssd was ~0 relative to the largest
        (``|b_k| <= 1e-6 max|b|``) in every fitted iteration, or which cancel out
        analytically. With min-max normalisation of the prediction, alpha cancels out of the
        objective: it is reported here and left at its start value, never "fitted".
    saturation : SaturationReport
        Where the receptors sit on the sigmoid with ``params`` at the compared time step
        (fraction in the sensitive range 0.05 < I/alpha < 0.95).
    success : bool
        True if the loop converged (an iteration improved the ssd by at most ``tol``
        relative); False on a flat or degenerate objective or when ``max_iter`` ran out.
        Always ``status == 'converged'``.
    status : {'converged', 'flat', 'max_iter'}
        How it ended (:data:`STATUSES` says what each means).
    message : str
        Why it stopped, plus notes on no-effect parameters, clipping and saturation.
    n_evaluations : int
        Model evaluations (transduce -> synthesize -> compare) spent by the method (the
        identifiability check counts its own, in ``identifiability['n_evaluations']``).
    method : {'rsm1', 'rsm2', 'least_squares'}
    synthesis : str
        The grouping used ('longitudinal', 'cross', 'map', 'random').
    normalise : {'both', 'prediction', 'observation', 'neither'}
    start : SigmoidParams
        The start point.
    fit : ProfileFit
        The comparison at ``params`` (predicted and observed profiles as compared, positions in m).
    clipped : tuple of str
        Parameters that were clipped at their lower bound (alpha >= 0, gamma >= 0) at some
        evaluated point.
    canonical : CanonicalAnalysis or None
        Last iteration's canonical analysis ('rsm2' only).
    n_jacobian_evaluations : int, default=0
        Evaluations of the closed-form Jacobian of the compared profile (least squares only;
        each costs about one model evaluation). The method's total cost is
        ``n_evaluations + n_jacobian_evaluations``.
    identifiability : dict or None
        What the data determine at ``params`` (:func:`identifiability`): the singular values of
        the residuals' Jacobian in scaled parameters, the condition number, the ridge direction
        (the combination the data leave free), ssd along that ridge, the verdict
        ``identifiable`` (condition number <= :data:`IDENTIFIABLE_COND`), and the parameters
        outside their physical range (``out_of_range``: lambda < 0 Pa, gamma <= 0 /Pa).
    """

    params: SigmoidParams
    ssd: float
    r2_study: float
    r2: float
    iterations: object
    design_runs: object
    coefficients: object
    no_effect: tuple
    saturation: SaturationReport
    success: bool
    status: Status
    message: str
    n_evaluations: int
    method: CalibrationMethod
    synthesis: str
    normalise: Normalise
    start: SigmoidParams
    fit: ProfileFit
    clipped: tuple = ()
    canonical: object = None
    n_jacobian_evaluations: int = 0
    identifiability: dict | None = None

    @property
    def n_iterations(self) -> int:
        """Iterations run (rows of ``iterations`` after the start row)."""
        return int(len(self.iterations) - 1)

    def to_dict(self) -> dict:
        """A JSON-ready summary (SI units; keys carry the unit)."""
        p, s = self.params, self.saturation
        return {
            "method": self.method,
            "synthesis": self.synthesis,
            "normalise": self.normalise,
            "start": _params_dict(self.start),
            "params": _params_dict(p),
            "ssd": self.ssd,
            "r2_study": self.r2_study,
            "r2": self.r2,
            "no_effect": list(self.no_effect),
            "clipped": list(self.clipped),
            "saturation": {
                "fraction_sensitive": s.fraction_sensitive,
                "fraction_saturated": s.fraction_high,
                "fraction_near_zero": s.fraction_low,
                "relative_min": s.relative_min,
                "relative_max": s.relative_max,
                "n_receptors": s.n_samples,
                "message": s.message,
            },
            "success": self.success,
            "status": self.status,
            "message": self.message,
            "n_evaluations": self.n_evaluations,
            "n_jacobian_evaluations": self.n_jacobian_evaluations,
            "n_iterations": self.n_iterations,
            "identifiability": self.identifiability,
        }

    def __repr__(self) -> str:
        p = self.params
        return (
            f"<CalibrationResult {self.method} ({self.synthesis}, normalise={self.normalise!r}): "
            f"success={self.success} ({self.status}), ssd {self.ssd:.4g}, R2(study) {self.r2_study:.3f}, "
            f"alpha {p.alpha:.4g} A, gamma {p.gamma:.4g} 1/Pa, lambda {p.lambda_:.4g} Pa, "
            f"{self.n_iterations} iteration(s), {self.n_evaluations} evaluations"
            f"{f' + {self.n_jacobian_evaluations} Jacobian' if self.n_jacobian_evaluations else ''}"
            f"{', no effect: ' + ', '.join(self.no_effect) if self.no_effect else ''}>"
        )


def _params_dict(p: SigmoidParams) -> dict:
    return {"alpha_a": p.alpha, "gamma_per_pa": p.gamma, "lambda_pa": p.lambda_}


def finish(out: dict, obj: Objective, method: CalibrationMethod, synthesis: str, normalise: Normalise, start: SigmoidParams) -> CalibrationResult:
    """Build the :class:`CalibrationResult` of a method's outcome, with every caveat in its message.

    Parameters
    ----------
    out : dict
        The method's outcome (:func:`.rsm.rsm`, :func:`.reference.least_squares_reference`).
    obj : Objective
        The objective it ran on (its evaluation counts are the method's cost).
    method, synthesis, normalise : str
        As given to :func:`~afferent.calibration.calibrate`.
    start : SigmoidParams
        The start point (A, 1/Pa, Pa).

    Returns
    -------
    CalibrationResult

    Warns
    -----
    AfferentWarning
        If the end point saturates every receptor, lies outside the physical range, or sits on
        a ridge the profile does not resolve.
    """
    vec = out["base"]
    params = vector_to_params(vec)
    _, fit, _ = obj(vec)
    sat = saturation_report(obj.sed_row, params)
    n_evaluations = int(obj.n_evaluations)  # the method's own; the identifiability check counts its own
    n_jacobians = int(obj.n_jacobians)
    ident = identifiability(obj, vec, out["no_effect"])
    notes = [out["note"]]
    # An infinite condition number (a combination the profile does not see at all) is a ridge too;
    # NaN means the check could not run.
    ridge = not ident["identifiable"] and not np.isnan(ident["condition_number"])
    if ridge:
        d = ", ".join(f"{v:+.2f} {k}" for k, v in ident["ridge_direction"].items())
        ssd_r = ident["ssd_along_ridge"]
        notes.append(
            f"The profile does not determine the parameters separately: the condition number of the residuals' Jacobian "
            f"is {ident['condition_number']:.3g} (> {IDENTIFIABLE_COND:g}); along the ridge ({d}, scaled: ln gamma, "
            f"gamma x lambda) the ssd goes {ssd_r[-1.0]:.4g} / {ssd_r[0.0]:.4g} / {ssd_r[1.0]:.4g} at -1 / 0 / +1: "
            "other (gamma, lambda) on it fit as well."
        )
    for text in ident["out_of_range"]:
        notes.append(f"Outside the physical range: {text}.")
    if ident["out_of_range"] or ridge:
        warnings.warn(" ".join(notes[1:]), AfferentWarning, stacklevel=3)
    if out["no_effect"]:
        notes.append(_no_effect_note(out, vec, normalise, method))
    if out["clipped"]:
        notes.append(f"Clipped at the lower bound 0 at some evaluated point: {', '.join(out['clipped'])}.")
    at_bound = [p for p, v in zip(PARAMETERS[:2], vec[:2]) if v <= 0.0]
    if at_bound:
        notes.append(f"The final {', '.join(at_bound)} sits at its bound 0.")
    if (sat.saturated or sat.fraction_sensitive < 0.5) and sat.message not in out["note"]:
        notes.append(sat.message)
    if sat.saturated:
        warnings.warn(
            f"The calibrated parameters leave no receptor in the sigmoid's sensitive range: {sat.message}",
            AfferentWarning, stacklevel=3,
        )
    return CalibrationResult(
        params=params, ssd=float(fit.ssd), r2_study=float(fit.r2_study), r2=float(fit.r2),
        iterations=out["iterations"], design_runs=out["runs"], coefficients=out["coefficients"],
        no_effect=tuple(out["no_effect"]), saturation=sat, success=bool(out["success"]),
        status=out["status"], message=" ".join(notes), n_evaluations=n_evaluations, n_jacobian_evaluations=n_jacobians, method=method, synthesis=synthesis, normalise=normalise,
        start=start, fit=fit, clipped=tuple(out["clipped"]), canonical=out["canonical"], identifiability=ident,
    )


def _no_effect_note(out, vec, normalise, method) -> str:
    """Say aloud which parameters did not act on the ssd, with the evidence and the reason."""
    parts = []
    coef = out["coefficients"]
    for p in out["no_effect"]:
        evidence = ""
        cols = [f"b_{q}" for q in PARAMETERS]
        if method == "rsm1" and len(coef) and all(c in coef for c in cols):
            b = coef[cols].to_numpy(float)
            bmax = np.max(np.abs(b), axis=1)
            ratio = np.abs(b[:, PARAMETERS.index(p)]) / np.where(bmax > 0, bmax, 1.0)
            evidence = f"; measured |b_{p}| / |b_max| <= {float(ratio.max()):.1e} over {len(coef)} iteration(s)"
        why = ""
        if p == "alpha" and normalise in ("both", "prediction"):
            why = (f": with normalise={normalise!r} the prediction is min-max normalised, so alpha cancels out of "
                   "the ssd exactly")
        value = float(vec[PARAMETERS.index(p)])
        parts.append(f"{p} has no effect on the ssd{why}{evidence}. It was NOT fitted: it stays at its start value "
                     f"{value:.6g} {UNITS[p]}.")
    if "alpha" in out["no_effect"] and normalise in ("both", "prediction"):
        parts.append("(The study's table reports alpha moving under this objective; the data cannot have moved it. "
                     "Use normalise='neither' with a recording in A to fit alpha.)")
    return " ".join(parts)
