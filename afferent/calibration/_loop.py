"""The calibration loop: RSM (the study's), a second-order RSM, and a least-squares reference."""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass

import numpy as np

from .._validation import check_option, check_rng
from .._validation import plain as _plain
from ..exceptions import AfferentWarning
from ..pipeline import make_branching
from ..profiles import NEARLY_CONSTANT_RTOL, ProfileFit, _as_observed, compare_profiles
from ..synthesis import Branching, synthesize
from ..transduction import STUDY_PARAMS, SaturationReport, SigmoidParams, saturation_report, transduce
from .design import DEFAULT_INCREMENT, PARAMETERS, UNITS, decode, encode, increments, make_design
from .design import params_to_vector, vector_to_params
from .surface import NO_EFFECT_RTOL, canonical_analysis, fit_first_order, make_response_surface
from .surface import steepest_descent, surface_minimum

__all__ = [
    "METHODS",
    "DEFAULT_TOL",
    "DEFAULT_MAX_ITER",
    "DEFAULT_MAX_STEPS",
    "DEFAULT_N_STARTS",
    "CalibrationResult",
    "calibrate",
    "compare_methods",
    "SynthesisComparison",
    "compare_syntheses",
]

METHODS = ("rsm1", "rsm2", "least_squares")
_NORMALISE = ("both", "prediction", "observation", "neither")

#: Relative tolerance: an RSM iteration that lowers the best ssd by at most ``tol`` x the
#: ssd it started from ends the loop (converged). 1e-3 = 0.1 %: the study quotes ssd to two
#: significant digits (0.70 -> 0.24), so a smaller gain is invisible in its table, and on
#: noisy data later gains only fit the noise. Relative, so the same default serves
#: normalised profiles (ssd ~ 0.01-1) and ``normalise='neither'`` (ssd in A^2, ~1e-16).
DEFAULT_TOL = 1e-3
#: Iteration budget, not the stopping rule (``tol`` is). The study reports stopping after 3
#: iterations without saying why; a fixed 3 would cut off data that still improve, so the
#: budget is generous and ``success=False`` says when it ran out. On the synthetic data of
#: tests/test_calibration.py the study's procedure stops by itself after 2 iterations (31
#: evaluations); each iteration costs 8 new design runs plus its descent steps.
DEFAULT_MAX_ITER = 50
#: Largest number of steepest-descent steps per iteration. Steps are one coded unit (5 % of
#: the iteration's base value) on the steepest parameter: if that is lambda, moving it from
#: the study's start (300 Pa) to its longitudinal fit (-705 Pa) takes 67 steps.
DEFAULT_MAX_STEPS = 100
#: Starts of the least-squares reference: the given start plus 3 seeded random ones.
DEFAULT_N_STARTS = 4
#: ftol, xtol and gtol of the least-squares reference (scipy's defaults): the reference is
#: converged tightly whatever ``tol`` the RSM uses.
LS_TOL = 1e-8
#: A design whose ssd spread is at most this fraction of its largest ssd is flat.
FLAT_RTOL = 1e-12
#: Lower bounds of (alpha, gamma, lambda): alpha >= 0 A, gamma >= 0 1/Pa, lambda free.
LOWER_BOUNDS = np.array([0.0, 0.0, -np.inf])
#: The coding step never falls below ``increment x |start| / 10`` (lambda may cross zero).
STEP_FLOOR_FRACTION = 0.1


# ---------------------------------------------------------------------------- result object
@dataclass(frozen=True)
class CalibrationResult:
    """Outcome of :func:`calibrate` (scipy.optimize's result object, as a frozen dataclass).

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
    message : str
        Why it stopped, plus notes on no-effect parameters, clipping and saturation.
    n_evaluations : int
        Model evaluations (transduce -> synthesize -> compare) spent.
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
    message: str
    n_evaluations: int
    method: str
    synthesis: str
    normalise: str
    start: SigmoidParams
    fit: ProfileFit
    clipped: tuple = ()
    canonical: object = None
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
            "message": self.message,
            "n_evaluations": self.n_evaluations,
            "n_iterations": self.n_iterations,
            "identifiability": self.identifiability,
        }

    def __repr__(self) -> str:
        p = self.params
        return (
            f"<CalibrationResult {self.method} ({self.synthesis}, normalise={self.normalise!r}): "
            f"success={self.success}, ssd {self.ssd:.4g}, R2(study) {self.r2_study:.3f}, "
            f"alpha {p.alpha:.4g} A, gamma {p.gamma:.4g} 1/Pa, lambda {p.lambda_:.4g} Pa, "
            f"{self.n_iterations} iteration(s), {self.n_evaluations} evaluations"
            f"{', no effect: ' + ', '.join(self.no_effect) if self.no_effect else ''}>"
        )


def _params_dict(p: SigmoidParams) -> dict:
    return {"alpha_a": p.alpha, "gamma_per_pa": p.gamma, "lambda_pa": p.lambda_}


# ------------------------------------------------------------------------------ objective
class _Objective:
    """ssd (and the whole ProfileFit) of one parameter vector; caches repeated points."""

    def __init__(self, sed_row, times_row, branching, observed, normalise, on_outside, bar):
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
        self.best = math.inf

    def __call__(self, vec) -> tuple[int, ProfileFit, bool]:
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
        self.bar.update(1)
        if math.isfinite(self.best):
            self.bar.set_postfix(ssd=f"{self.best:.4g}", refresh=False)
        return out


class _Runs:
    """Collects design_runs rows."""

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

        cols = ["iteration", "kind", "run", "chi_alpha", "chi_gamma", "chi_lambda", "alpha", "gamma", "lambda",
                "ssd", "evaluation", "clipped", "degenerate"]
        return pd.DataFrame(self.rows, columns=cols)


def _clip(vec) -> tuple[np.ndarray, np.ndarray]:
    vec = np.asarray(vec, dtype=float)
    low = vec < LOWER_BOUNDS
    return np.where(low, LOWER_BOUNDS, vec), low


def _pair_no_effect(chis, ssd, ok) -> np.ndarray:
    """Per factor: True if every pair of usable runs differing only in that factor has the same ssd.

    "The same" is ``|ssd_i - ssd_j| <= NO_EFFECT_RTOL x (max - min ssd over the runs)``.
    A factor without such a pair is False (no evidence of no effect).
    """
    X, y = chis[ok], ssd[ok]
    spread = float(y.max() - y.min()) if y.size else 0.0
    n = X.shape[1]
    out = np.zeros(n, bool)
    for k in range(n):
        others = np.delete(X, k, axis=1)
        worst, found = 0.0, False
        for i in range(len(X)):
            same = np.all(others == others[i], axis=1) & (X[:, k] != X[i, k])
            if same.any():
                found = True
                worst = max(worst, float(np.max(np.abs(y[same] - y[i]))))
        out[k] = found and worst <= NO_EFFECT_RTOL * spread
    return out


# --------------------------------------------------------------------------- validation
def _check_start(start) -> SigmoidParams:
    if isinstance(start, SigmoidParams):
        p = start
    elif isinstance(start, (tuple, list, np.ndarray)) and len(start) == 3:
        p = vector_to_params(start)
    else:
        raise TypeError(
            f"'start' must be a SigmoidParams or a tuple (alpha A, gamma 1/Pa, lambda Pa); got {start!r} instead."
        )
    for name, value, unit in (("alpha", p.alpha, "A"), ("gamma", p.gamma, "1/Pa")):
        if not value > 0:
            raise ValueError(
                f"The start {name} must be > 0 {unit}: the increments are a fraction of each start value; "
                f"got {value!r} instead."
            )
    if p.lambda_ == 0.0:
        raise ValueError(
            "The start lambda must be non-zero (Pa): the increments are a fraction of each start value; "
            "got 0.0 instead. Start from e.g. lambda_=1.0."
        )
    return p


def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name!r} must be an int; got {_plain(value)!r} instead.")
    if value < minimum:
        raise ValueError(f"{name!r} must be >= {minimum}; got {_plain(value)!r} instead.")
    return int(value)


def _check_tol(tol) -> float:
    if isinstance(tol, bool) or not isinstance(tol, numbers.Real) or not (0.0 <= float(tol) < 1.0):
        raise ValueError(f"'tol' must be a relative tolerance in [0, 1), e.g. 1e-3; got {_plain(tol)!r} instead.")
    return float(tol)


def _split_sed(sed, layout, time_index):
    """(sed_row (1, n_receptors) Pa, times_row or None, layout)."""
    from ..synthesis import _check_time_index

    if hasattr(sed, "values") and hasattr(sed, "times") and hasattr(sed, "layout") and not isinstance(sed, np.ndarray):
        if layout is not None:
            raise ValueError("'layout' must only be given with a plain-array 'sed'; the ReceptorSED carries its own.")
        values, times, layout = np.asarray(sed.values, dtype=float), sed.times, sed.layout
    else:
        if layout is None:
            raise TypeError(
                "'layout' (a ReceptorLayout) is required with a plain-array 'sed': the synthesis groups "
                "receptors by their positions."
            )
        try:
            values = np.asarray(sed, dtype=float)
        except (TypeError, ValueError) as err:
            raise TypeError(f"'sed' must be a ReceptorSED or a real array in Pa; got {type(sed).__name__} instead.") from err
        times = None
    if values.ndim != 2:
        raise ValueError(f"'sed' must be an array of shape (n_times, n_receptors) in Pa; got shape {values.shape} instead.")
    if values.shape[1] != layout.n_receptors:
        raise ValueError(
            f"'sed' must have one column per receptor of the layout ({layout.n_receptors}); "
            f"got shape {values.shape} instead."
        )
    t = _check_time_index(time_index, values.shape[0])
    row = values[[t]]
    nan = np.isnan(row[0])
    if nan.any():
        j = int(np.flatnonzero(nan)[0])
        raise ValueError(
            f"'sed' must be finite at the compared time step {t}; got {int(nan.sum())} NaN receptor(s) "
            f"(first: {str(layout.ids[j])!r}) instead. Drop receptors outside the FE field first, "
            "e.g. with layout.subset(~sed.outside)."
        )
    times_row = None if times is None else np.asarray(times, dtype=float)[[t]]
    return row, times_row, layout


def _synthesis_label(spec) -> str:
    if isinstance(spec, Branching):
        return spec.kind
    return str(spec).partition(":")[0]


# ----------------------------------------------------------------------------- public API
def calibrate(
    sed,
    observed,
    *,
    layout=None,
    synthesis="longitudinal",
    start=STUDY_PARAMS["start"],
    increment: float = DEFAULT_INCREMENT,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
    max_steps: int = DEFAULT_MAX_STEPS,
    refine: int = 0,
    normalise: str = "both",
    method: str = "rsm1",
    design: str | None = None,
    n_starts: int = DEFAULT_N_STARTS,
    time_index: int = -1,
    on_outside: str = "raise",
    rng=None,
    progress: bool = False,
) -> CalibrationResult:
    """Calibrate the sigmoid (alpha, gamma, lambda) against a recorded profile (METHOD.md section 6).

    Objective, for a parameter set: :func:`~afferent.transduction.transduce` the SED at the
    compared time step -> :func:`~afferent.synthesis.synthesize` along ``synthesis`` ->
    :func:`~afferent.profiles.compare_profiles` with ``observed`` -> ``ssd = sum (d - e)^2``.

    ``method='rsm1'`` (default) is the study's procedure:

    1. code each parameter, ``chi_k = (xi_k - xi_k,base) / dxi_k``, ``dxi_k = increment x
       |xi_k,base|`` (5 %; never below ``increment x |xi_k,start| / 10``, so lambda can cross 0);
    2. evaluate the two-level full factorial + centre design (9 runs, ``pydoe.ff2n``);
    3. fit ``ssd ~ b0 + sum b_k chi_k`` (``LinearRegression``);
    4. step ``n x dchi``, ``dchi_k = -b_k / |b_max|``, n = 1, 2, ... while the ssd decreases
       (at most ``max_steps``); a parameter with no effect (``|b_k| <= 1e-6 |b_max|``) is not moved;
    5. re-centre on the best point evaluated and repeat, until an iteration lowers the ssd by
       at most ``tol`` x the ssd it started from (success) or ``max_iter`` iterations ran.

    ``method='rsm2'``: the same loop with a second-order surface (central composite design,
    15 runs, or ``design='bbd'``, 13 runs) whose minimum inside the design region
    (canonical analysis; box-constrained when the stationary point is not a minimum inside)
    gives the step direction. ``method='least_squares'``: the reference,
    :func:`scipy.optimize.least_squares` (trf, bounds alpha >= 0, gamma >= 0) on the residual
    vector ``d - e``, from ``start`` and ``n_starts - 1`` seeded random starts; the best is kept.

    Parameters alpha and gamma are clipped at 0 when a design point or step would make them
    negative (reported in ``clipped`` and ``design_runs.clipped``). With ``normalise='both'``
    or ``'prediction'`` alpha cancels out of the ssd: the result reports it in ``no_effect``
    and leaves it at its start value (the study reports alpha moving; it cannot have
    mattered). Use ``normalise='neither'`` with an observation in A to fit alpha.

    Parameters
    ----------
    sed : ReceptorSED or array_like of shape (n_times, n_receptors)
        SED at the receptor sites in Pa (= J/m^3); a plain array needs ``layout``.
    observed : ObservedProfile or tuple (positions_m, response)
        The recorded profile (positions in m along the synthesis axis: x for longitudinal
        sections, z for cross-sections).
    layout : ReceptorLayout, optional
        Receptor sites (m), only with a plain-array ``sed``.
    synthesis : {'longitudinal', 'cross', 'map:FILE', 'random:N'} or Branching, default='longitudinal'
        Receptor -> afferent grouping (:func:`afferent.pipeline.make_branching`). To compare
        groupings (the study: longitudinal vs cross) use :func:`compare_syntheses`.
    start : SigmoidParams or tuple, default=STUDY_PARAMS['start']
        Start point, alpha (A) > 0, gamma (1/Pa) > 0, lambda (Pa) != 0; the default is the
        study's first iteration (2.46e-8 A, 4.6e-3 1/Pa, 300 Pa).
    increment : float, default=0.05
        Coding step as a fraction of the base value (the study: 5 %).
    tol : float, default=1e-3
        RSM: an iteration that lowers the ssd by at most ``tol`` x the ssd it started from
        ends the loop (see :data:`DEFAULT_TOL`). The least-squares reference always uses
        scipy's tolerances (1e-8).
    max_iter : int, default=50
        RSM iteration budget; least squares: ``max_nfev = max(100, 10 x max_iter)`` per start.
    max_steps : int, default=100
        Largest number of descent steps per RSM iteration.
    refine : int, default=0
        RSM: when an iteration ends the loop (ssd decrease <= ``tol``), halve the increments
        and go on, up to ``refine`` times. 0 is the study's procedure; a first-order model
        can stall in a curved valley at 5 % increments (the message says so), and
        ``refine=4, tol=1e-5`` reaches the noise floor on the synthetic data of
        tests/test_calibration.py at ~45x the evaluations.
    normalise : {'both', 'prediction', 'observation', 'neither'}, default='both'
        Which profiles are min-max normalised before comparing (the study: both).
    method : {'rsm1', 'rsm2', 'least_squares'}, default='rsm1'
    design : {'factorial', 'ccd', 'bbd'}, optional
        Coded design per RSM iteration; default 'factorial' (9 runs) for 'rsm1' and 'ccd'
        (15 runs) for 'rsm2' ('factorial' cannot fit a second-order surface).
    n_starts : int, default=4
        Starts of the least-squares reference.
    time_index : int, default=-1
        Time step of the SED that is compared (Python indexing; the last step by default).
    on_outside : {'raise', 'drop'}, default='raise'
        Afferents outside the observed positions: raise, or leave them out.
    rng : None, int or numpy.random.Generator, default=None
        Seeds the random starts of 'least_squares' and ``synthesis='random:N'``; None
        means seed 0, so that every method is deterministic by default.
    progress : bool, default=False
        Show a tqdm progress bar (model evaluations) on stderr.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    TypeError
        Bad argument types (``synthesis`` given as a tuple: use :func:`compare_syntheses`).
    ValueError
        Bad options, NaN SED at the compared step, a zero start value, afferents outside
        the observed range with ``on_outside='raise'``, or an all-zero normalised observation.

    Warns
    -----
    AfferentWarning
        If no receptor is in the sigmoid's sensitive range at the final parameters.

    See Also
    --------
    compare_methods : rsm1, least_squares and rsm2 on the same data.
    compare_syntheses : the same calibration for several groupings.

    Examples
    --------
    >>> res = calibrate(sed, observed)  # doctest: +SKIP
    >>> res.iterations  # doctest: +SKIP
    """
    check_option("method", method, METHODS)
    check_option("normalise", normalise, _NORMALISE)
    check_option("on_outside", on_outside, ("raise", "drop"))
    if isinstance(synthesis, (tuple, list)):
        raise TypeError(
            f"'synthesis' must be one grouping; got {synthesis!r} instead. "
            "Use compare_syntheses(sed, observed, synthesis=(...)) to calibrate several."
        )
    start = _check_start(start)
    inc = float(increment) if isinstance(increment, numbers.Real) and not isinstance(increment, bool) else increment
    if not isinstance(inc, float) or not (0.0 < inc < 1.0):
        raise ValueError(f"'increment' must be a fraction in (0, 1), e.g. 0.05 for 5 %; got {_plain(increment)!r} instead.")
    tol = _check_tol(tol)
    max_iter = _check_int("max_iter", max_iter, 1)
    max_steps = _check_int("max_steps", max_steps, 1)
    n_starts = _check_int("n_starts", n_starts, 1)
    refine = _check_int("refine", refine, 0)
    if design is None:
        design = "ccd" if method == "rsm2" else "factorial"
    check_option("design", design, ("factorial", "ccd", "bbd"))
    if method == "rsm2" and design == "factorial":
        raise ValueError(
            "A second-order surface (method='rsm2') needs design='ccd' or 'bbd'; "
            "got design='factorial' (9 runs for 10 coefficients) instead."
        )
    observed = _as_observed(observed)
    sed_row, times_row, layout = _split_sed(sed, layout, time_index)
    seed = 0 if rng is None else rng
    gen = check_rng(seed)
    branching = make_branching(synthesis, layout, rng=seed if not isinstance(seed, np.random.Generator) else gen)

    from tqdm.auto import tqdm

    with tqdm(desc=f"calibrate {method}", unit="eval", disable=not progress, leave=False) as bar:
        obj = _Objective(sed_row, times_row, branching, observed, normalise, on_outside, bar)
        if method == "least_squares":
            out = _least_squares(obj, start, inc, max_iter, n_starts, gen)
        else:
            out = _rsm(obj, start, inc, tol, max_iter, max_steps, method, design, refine)
    return _finish(out, obj, method, _synthesis_label(synthesis), normalise, start)


# --------------------------------------------------------------------------------- RSM
def _rsm(obj, start, inc, tol, max_iter, max_steps, method, design_name, refine):
    import pandas as pd

    runs = _Runs()
    x0 = params_to_vector(start)
    floor = STEP_FLOOR_FRACTION * np.abs(x0)
    coded = make_design(design_name)
    n_fac = coded.shape[1]
    centre_row = int(np.flatnonzero(np.all(coded == 0, axis=1))[0])
    radius = float(np.max(np.abs(coded)))
    ev, fit, degen = obj(x0)
    runs.add(0, "start", 0, np.zeros(n_fac), x0, ev, fit, degen, False)
    base, base_ssd = x0, fit.ssd
    iters = [_iter_row(0, base, base_ssd, obj.n_evaluations)]
    coef_rows = []
    clipped_any = np.zeros(n_fac, bool)
    no_effect_all = np.ones(n_fac, bool)
    n_fits = 0
    status = None
    success = False
    canonical = None
    last_decrease = math.nan
    level, inc_it = 0, inc
    # With a min-max normalised prediction alpha cancels out of the ssd exactly: it is never
    # moved (its measured coefficient is still reported, as evidence).
    frozen = np.array([obj.norm_pred] + [False] * (n_fac - 1))
    for it in range(1, max_iter + 1):
        dxi = increments(base, inc_it, floor=floor)
        pts, low = _clip(decode(coded, base, dxi))
        chis = np.where(low, encode(pts, base, dxi), coded)  # as evaluated: clipped points re-encoded
        ssd = np.empty(len(pts))
        deg = np.zeros(len(pts), bool)
        for r, (chi, vec, lo) in enumerate(zip(chis, pts, low)):
            ev, f, d = obj(vec)
            ssd[r], deg[r] = f.ssd, d
            clipped_any |= lo
            runs.add(it, "design", r, chi, vec, ev, f, d, lo.any())
        ok = ~deg
        spread = float(ssd[ok].max() - ssd[ok].min()) if ok.any() else 0.0
        scale = float(np.max(np.abs(ssd[ok]))) if ok.any() else 0.0
        if ok.sum() < n_fac + 1 or spread <= FLAT_RTOL * max(scale, np.finfo(float).tiny):
            status = _flat_message(it, ssd, deg, base, obj)
            iters.append(_iter_row(it, base, base_ssd, obj.n_evaluations))
            break
        row = {"iteration": it, "increment": inc_it,
               **{f"base_{p}": float(v) for p, v in zip(PARAMETERS, base)},
               **{f"dxi_{p}": float(v) for p, v in zip(PARAMETERS, dxi)}}
        pair_none = _pair_no_effect(chis, ssd, ok)
        if method == "rsm1":
            lin = fit_first_order(chis[ok], ssd[ok])
            # ~0 coefficient relative to the largest, and no pair of runs that differ only in
            # this parameter differs in ssd (a symmetric effect would also give b_k ~ 0).
            no_eff = lin.no_effect & pair_none
            fixed = no_eff | frozen
            direction = steepest_descent(lin.coef, no_effect=fixed)
            corners = ok & np.all(np.abs(chis) == 1.0, axis=1)
            # Curvature check: mean of the factorial corners minus the centre run (> 0: a bowl
            # the plane cannot follow; the first-order model is then only a local guide).
            curv = float(ssd[corners].mean() - ssd[centre_row]) if corners.any() and ok[centre_row] else 0.0
            row.update({"b0": lin.intercept, **{f"b_{p}": float(c) for p, c in zip(PARAMETERS, lin.coef)},
                        "fit_r2": lin.r2, "curvature": curv})
        else:
            no_eff = pair_none
            fixed = no_eff | frozen
            eff = np.flatnonzero(~fixed)
            if eff.size == 0:
                status = _flat_message(it, ssd, deg, base, obj)
                iters.append(_iter_row(it, base, base_ssd, obj.n_evaluations))
                break
            # The surface is fitted on the parameters that act on the ssd only: a no-effect
            # parameter's quadratic column would soak up lack of fit (fake curvature).
            surface = make_response_surface(2).fit(chis[ok][:, eff], ssd[ok])
            canonical = _embed_canonical(canonical_analysis(surface), eff, n_fac)
            names = [PARAMETERS[k] for k in eff]
            terms = surface.named_steps["poly"].get_feature_names_out(names)
            coefs = np.asarray(surface.named_steps["ols"].coef_, dtype=float)
            direction = np.zeros(n_fac)
            direction[eff] = surface_minimum(surface, radius=radius)
            pred = surface.predict(chis[ok][:, eff])
            ss_tot = float(np.sum((ssd[ok] - ssd[ok].mean()) ** 2))
            all_terms = make_response_surface(2).named_steps["poly"].fit(np.zeros((1, n_fac))).get_feature_names_out(
                list(PARAMETERS))
            row.update({"b0": float(canonical.b0), **{_term_name(t): 0.0 for t in all_terms},
                        **{_term_name(t): float(c) for t, c in zip(terms, coefs)},
                        "fit_r2": 1.0 - float(np.sum((ssd[ok] - pred) ** 2)) / ss_tot if ss_tot > 0 else 1.0,
                        "kind": canonical.kind,
                        **{f"chi_s_{p}": float(v) for p, v in zip(PARAMETERS, canonical.stationary_point)},
                        **{f"eig_{i}": float(v) for i, v in enumerate(canonical.eigenvalues)}})
        n_fits += 1
        no_effect_all &= no_eff
        # Steps n x direction, n = 1, 2, ..., while the ssd decreases.
        prev = ssd[centre_row] if not deg[centre_row] else math.inf
        prev_vec = pts[centre_row]
        n_steps = 0
        path_ssd, path_vec = [], []
        if np.any(direction != 0):
            for n in range(1, max_steps + 1):
                vec, lo = _clip(decode(n * direction, base, dxi))
                if np.array_equal(vec, prev_vec):
                    break  # pinned at a bound: no further move
                ev, f, d = obj(vec)
                clipped_any |= lo
                runs.add(it, "path", n, encode(vec, base, dxi), vec, ev, f, d, lo.any())
                n_steps = n
                if d or not f.ssd < prev:
                    break
                prev, prev_vec = f.ssd, vec
                path_ssd.append(f.ssd)
                path_vec.append(vec)
        row.update({**{f"step_{p}": float(v) for p, v in zip(PARAMETERS, direction)}, "n_steps": n_steps,
                    "no_effect": ",".join(p for p, e in zip(PARAMETERS, no_eff) if e)})
        coef_rows.append(row)
        cand_ssd = list(ssd[ok]) + path_ssd
        cand_vec = list(pts[ok]) + path_vec
        k = int(np.argmin(cand_ssd))  # the first minimum: deterministic
        best_vec, best_ssd = np.asarray(cand_vec[k]), float(cand_ssd[k])
        if fixed.any() and not np.array_equal(best_vec[fixed], base[fixed]):
            # A no-effect parameter only changes the ssd by rounding: never let it move the base.
            best_vec = np.where(fixed, base, best_vec)
            ev, f, d = obj(best_vec)
            runs.add(it, "projected", 0, encode(best_vec, base, dxi), best_vec, ev, f, d, False)
            best_ssd = math.inf if d else f.ssd
        start_ssd = base_ssd
        if best_ssd < base_ssd:
            base, base_ssd = best_vec, best_ssd
        last_decrease = start_ssd - base_ssd
        iters.append(_iter_row(it, base, base_ssd, obj.n_evaluations))
        if last_decrease <= tol * abs(start_ssd):
            if level < refine:
                level += 1
                inc_it *= 0.5
                continue
            success = True
            res_txt = f"{inc_it:.3g} of the base value" + (f" after {level} refinement(s)" if level else "")
            status = (
                f"Converged after {it} iteration(s): the last one lowered the ssd by {last_decrease:.3g} "
                f"(<= tol {tol:g} x {start_ssd:.4g}) at increments of {res_txt}."
            )
            if method == "rsm1" and refine == 0 and last_decrease == 0.0:
                status += (
                    " No design or descent point improved on the centre at this resolution; a first-order model "
                    "can stall in a curved valley before the optimum: refine=N (halve the increments up to N "
                    "times) or method='rsm2' may go further."
                )
            break
    else:
        if level and last_decrease <= tol * abs(iters[-2]["ssd"]):
            status = (f"Stopped at max_iter={max_iter} iterations while refining the increments (now {inc_it:.3g} of "
                      "the base value); raise max_iter.")
        else:
            status = (
                f"Stopped at max_iter={max_iter} iterations with the ssd still decreasing (by {last_decrease:.3g} in "
                f"the last one, > tol {tol:g} relative); raise max_iter or start closer."
            )
    measured = no_effect_all if n_fits else np.zeros(n_fac, bool)
    no_effect = tuple(p for p, e, fz in zip(PARAMETERS, measured, frozen) if e or fz)
    return dict(base=base, iterations=pd.DataFrame(iters), runs=runs.frame(), coefficients=pd.DataFrame(coef_rows),
                no_effect=no_effect, clipped=tuple(p for p, c in zip(PARAMETERS, clipped_any) if c),
                success=success, status=status, canonical=canonical)


def _embed_canonical(can, eff, n):
    """A CanonicalAnalysis of the effective factors, embedded in all n factors (0 along the others)."""
    from .surface import CanonicalAnalysis

    if eff.size == n:
        return can
    xs = np.zeros(n)
    xs[eff] = can.stationary_point
    b = np.zeros(n)
    b[eff] = can.b
    B = np.zeros((n, n))
    B[np.ix_(eff, eff)] = can.B
    vec = np.zeros((n, n))
    rest = np.setdiff1d(np.arange(n), eff)
    vec[np.ix_(eff, np.arange(eff.size))] = can.eigenvectors
    vec[rest, eff.size + np.arange(rest.size)] = 1.0
    vals = np.concatenate([can.eigenvalues, np.zeros(rest.size)])
    return CanonicalAnalysis(xs, can.stationary_value, vals, vec, can.kind, can.b0, b, B)


def _term_name(term: str) -> str:
    """sklearn's 'alpha^2' / 'alpha gamma' -> 'b_alpha^2' / 'b_alpha*gamma'."""
    return "b_" + term.replace(" ", "*")


def _iter_row(it, vec, ssd, evaluations):
    return {"iteration": it, "alpha": float(vec[0]), "gamma": float(vec[1]), "lambda": float(vec[2]),
            "ssd": float(ssd), "evaluations": int(evaluations)}


def _flat_message(it, ssd, deg, base, obj) -> str:
    p = vector_to_params(base)
    sat = saturation_report(obj.sed_row, p)
    n = len(ssd)
    if deg.all():
        what = (f"all {n} design runs give a constant or nearly constant predicted profile, whose min-max "
                "normalised shape is rounding noise")
    elif (~deg).sum() < 4:
        what = (f"{int(deg.sum())} of {n} design runs give a constant or nearly constant predicted profile, "
                "too few remain to fit a surface")
    else:
        vals = ssd[~deg]
        what = f"all {int((~deg).sum())} usable design runs give the same ssd {float(vals[0]):.6g}"
    return (
        f"The objective is flat around {p!r} (iteration {it}): {what}. {sat.message} "
        "No descent direction exists; start where the receptors are in the sigmoid's sensitive range "
        "(a lambda inside the SED range at the receptors, gamma ~ 4 / that range)."
    )


# ----------------------------------------------------------------------- least squares
def _least_squares(obj, start, inc, max_iter, n_starts, gen):
    import pandas as pd
    from scipy.optimize import least_squares

    runs = _Runs()
    x0 = params_to_vector(start)
    dxi0 = increments(x0, inc)
    free = np.array([not obj.norm_pred, True, True])  # alpha cancels out of a normalised prediction
    scale = np.abs(x0)
    ev, fit0, d0 = obj(x0)
    runs.add(0, "start", 0, np.zeros(3), x0, ev, fit0, d0, False)
    dscale = float(np.max(np.abs(fit0.observed))) or 1.0
    iters = [_iter_row(0, x0, fit0.ssd, obj.n_evaluations)]
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
        return _clip(vec)

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
        iters.append(_iter_row(k, vec, f.ssd, obj.n_evaluations))
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
#: Largest condition number (of the residuals' Jacobian in scaled parameters) for which the
#: fitted parameters count as identified: beyond it one combination is determined over 100x less
#: well than the best one, and the fit slides along a ridge (gamma-lambda trade-off).
IDENTIFIABLE_COND = 100.0
#: Scaled steps along the ridge direction at which ssd is evaluated (units: see identifiability).
RIDGE_STEPS = (-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0)


def identifiability(obj, vec, no_effect=()) -> dict:
    """Which parameter combinations the compared profiles determine at ``vec``.

    The residuals r = predicted - observed (as compared) are differentiated by central finite
    differences with respect to scaled parameters: ``ln gamma`` (relative change of gamma) and
    ``gamma x lambda`` (lambda in units of the sigmoid's width 1/gamma); alpha too unless it has
    no effect (min-max normalisation cancels it). The singular values of that Jacobian say how
    well each combination is determined; the right singular vector of the smallest is the ridge
    along which the ssd barely changes.

    Returns
    -------
    dict
        ``parameters`` and their ``scales``, ``singular_values``, ``condition_number``,
        ``ridge_direction`` (unit vector in the scaled parameters), ``ssd_along_ridge``
        (``{step: ssd}`` for :data:`RIDGE_STEPS`), ``identifiable``, ``out_of_range`` (list of
        texts), ``n_evaluations`` spent.
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

    def residual(u):
        _, fit, _ = obj(to_vec(u))
        return np.asarray(fit.predicted, float) - np.asarray(fit.observed, float)

    h = 1e-4
    cols = []
    for k in range(len(names)):
        e = np.zeros(len(names))
        e[k] = h
        cols.append((residual(e) - residual(-e)) / (2 * h))
    jac = np.column_stack(cols) if cols else np.zeros((0, 0))
    out_of_range = []
    if lam < 0:
        out_of_range.append(f"lambda = {lam:.4g} Pa < 0: the sigmoid's midpoint lies below zero SED, so every receptor "
                            "is above half-height even unloaded; the fit uses the sigmoid's exponential tail")
    if gamma <= 0:
        out_of_range.append(f"gamma = {gamma:.4g} /Pa <= 0: the current does not increase with SED")
    if jac.size == 0 or not np.all(np.isfinite(jac)):
        return {"parameters": names, "singular_values": [], "condition_number": float("nan"), "identifiable": False,
                "ridge_direction": [], "ssd_along_ridge": {}, "out_of_range": out_of_range,
                "n_evaluations": obj.n_evaluations - n_before}
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
        "n_evaluations": obj.n_evaluations - n_before,
    }


def _finish(out, obj, method, synthesis, normalise, start) -> CalibrationResult:
    vec = out["base"]
    params = vector_to_params(vec)
    _, fit, _ = obj(vec)
    sat = saturation_report(obj.sed_row, params)
    n_evaluations = int(obj.n_evaluations)  # the method's own; the identifiability check counts its own
    ident = identifiability(obj, vec, out["no_effect"])
    notes = [out["status"]]
    if not ident["identifiable"] and np.isfinite(ident["condition_number"]):
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
    if ident["out_of_range"] or (not ident["identifiable"] and np.isfinite(ident["condition_number"])):
        warnings.warn(" ".join(notes[1:]), AfferentWarning, stacklevel=3)
    if out["no_effect"]:
        notes.append(_no_effect_note(out, vec, normalise, method))
    if out["clipped"]:
        notes.append(f"Clipped at the lower bound 0 at some evaluated point: {', '.join(out['clipped'])}.")
    at_bound = [p for p, v in zip(PARAMETERS[:2], vec[:2]) if v <= 0.0]
    if at_bound:
        notes.append(f"The final {', '.join(at_bound)} sits at its bound 0.")
    if (sat.saturated or sat.fraction_sensitive < 0.5) and sat.message not in out["status"]:
        notes.append(sat.message)
    if sat.saturated:
        warnings.warn(
            f"The calibrated parameters leave no receptor in the sigmoid's sensitive range: {sat.message}",
            AfferentWarning, stacklevel=3,
        )
    return CalibrationResult(
        params=params, ssd=float(fit.ssd), r2_study=float(fit.r2_study), r2=float(fit.r2),
        iterations=out["iterations"], design_runs=out["runs"], coefficients=out["coefficients"],
        no_effect=tuple(out["no_effect"]), saturation=sat, success=bool(out["success"]), message=" ".join(notes),
        n_evaluations=n_evaluations, method=method, synthesis=synthesis, normalise=normalise,
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


# ------------------------------------------------------------------------ conveniences
def compare_methods(sed, observed, *, methods=("rsm1", "least_squares", "rsm2"), **kwargs):
    """Run several calibration methods on the same data and tabulate them.

    Parameters
    ----------
    sed, observed
        As :func:`calibrate` (SED in Pa; observed positions in m).
    methods : sequence of {'rsm1', 'rsm2', 'least_squares'}, default=('rsm1', 'least_squares', 'rsm2')
    **kwargs
        Passed to :func:`calibrate` (``synthesis``, ``start``, ``normalise``, ``rng``, ...).

    Returns
    -------
    pandas.DataFrame
        One row per method: ``method``, ``ssd``, ``r2_study``, ``r2``, ``evaluations``,
        ``params`` (SigmoidParams), ``alpha`` (A), ``gamma`` (1/Pa), ``lambda`` (Pa),
        ``success``, ``no_effect``, ``message``.
    """
    return _methods_table(_run_methods(sed, observed, methods=methods, **kwargs))


def _run_methods(sed, observed, *, methods, **kwargs) -> dict:
    if "method" in kwargs:
        raise TypeError("'method' cannot be passed to compare_methods; use methods=(...).")
    for m in methods:
        check_option("method", m, METHODS)
    return {m: calibrate(sed, observed, method=m, **kwargs) for m in methods}


def _methods_table(results: dict):
    import pandas as pd

    return pd.DataFrame([
        {"method": m, "ssd": r.ssd, "r2_study": r.r2_study, "r2": r.r2, "evaluations": r.n_evaluations,
         "params": r.params, "alpha": r.params.alpha, "gamma": r.params.gamma, "lambda": r.params.lambda_,
         "success": r.success, "no_effect": ",".join(r.no_effect), "message": r.message}
        for m, r in results.items()
    ])


@dataclass(frozen=True)
class SynthesisComparison:
    """The same calibration for several receptor -> afferent groupings (the study: longitudinal vs cross).

    Parameters
    ----------
    results : dict of str -> CalibrationResult
        One result per grouping, keyed by its spelling ('longitudinal', 'cross', ...).
    table : pandas.DataFrame
        One row per grouping: ``synthesis``, ``ssd``, ``r2_study``, ``r2``, ``alpha`` (A),
        ``gamma`` (1/Pa), ``lambda`` (Pa), ``evaluations``, ``success``,
        ``fraction_sensitive``; sorted as given. ``best`` names the lowest ssd.
    best : str
        The grouping with the lowest ssd.
    """

    results: dict
    table: object
    best: str

    def __repr__(self) -> str:
        rows = ", ".join(f"{k}: ssd {r.ssd:.4g}" for k, r in self.results.items())
        return f"<SynthesisComparison {rows}; best {self.best!r}>"


def compare_syntheses(sed, observed, *, synthesis=("longitudinal", "cross"), **kwargs) -> SynthesisComparison:
    """Calibrate once per receptor -> afferent grouping and compare the fits (METHOD.md section 4).

    The study calibrated longitudinal sections (profile vs x) and cross-sections (profile
    vs z) against the same recording: longitudinal fitted better (R^2 0.95 vs 0.90).

    Parameters
    ----------
    sed : ReceptorSED or array_like of shape (n_times, n_receptors)
        SED at the receptors in Pa.
    observed : ObservedProfile, tuple, or dict of str -> ObservedProfile
        The recording (positions in m along each grouping's axis); a dict gives one
        recording per grouping.
    synthesis : sequence of str or Branching, default=('longitudinal', 'cross')
    **kwargs
        Passed to :func:`calibrate` (``method``, ``start``, ``normalise``, ...).

    Returns
    -------
    SynthesisComparison
    """
    import pandas as pd

    if isinstance(synthesis, (str, Branching)):
        synthesis = (synthesis,)
    results = {}
    for spec in synthesis:
        key = spec.kind if isinstance(spec, Branching) else str(spec)
        obs = observed[key] if isinstance(observed, dict) else observed
        results[key] = calibrate(sed, obs, synthesis=spec, **kwargs)
    table = pd.DataFrame([
        {"synthesis": k, "method": r.method, "ssd": r.ssd, "r2_study": r.r2_study, "r2": r.r2,
         "alpha": r.params.alpha, "gamma": r.params.gamma, "lambda": r.params.lambda_,
         "evaluations": r.n_evaluations, "success": r.success, "fraction_sensitive": r.saturation.fraction_sensitive}
        for k, r in results.items()
    ])
    best = min(results, key=lambda k: results[k].ssd)
    return SynthesisComparison(results, table, best)
