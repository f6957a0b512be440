"""The calibration entry point, :func:`~afferent.calibration.calibrate`: checks the arguments, builds the objective, runs a method.

::

    ReceptorSED + ObservedProfile --calibrate(method=...)--> CalibrationResult
        rsm1 / rsm2 -> .rsm.rsm          least_squares -> .reference.least_squares_reference
"""

from __future__ import annotations

from ..profiles import ObservedProfile
from ..receptors._layout import ReceptorLayout
from ..sampling import ReceptorSED

from .._typing import ArrayLike, RngLike

import numbers
from typing import get_args

import numpy as np

from .._validation import check_option, check_rng
from .._validation import plain as _plain
from ..profiles import _NORMALISE, Normalise, _as_observed
from ..sampling import OnOutside
from ..synthesis import Branching, make_branching
from ..transduction import STUDY_PARAMS, SigmoidParams
from .design import DEFAULT_INCREMENT, DesignName, vector_to_params
from .objective import Objective
from .reference import DEFAULT_N_STARTS, JACOBIANS, RESTARTS, Jacobian, Restarts, least_squares_reference
from .result import CalibrationMethod, CalibrationResult, finish
from .rsm import DEFAULT_MAX_ITER, DEFAULT_MAX_STEPS, DEFAULT_TOL, rsm

__all__ = ["METHODS", "calibrate"]

METHODS: tuple[str, ...] = get_args(CalibrationMethod)


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


def calibrate(
    sed: ReceptorSED | ArrayLike,
    observed: ObservedProfile | tuple,
    *,
    layout: ReceptorLayout | None=None,
    synthesis: str | Branching="longitudinal",
    start: SigmoidParams | tuple=STUDY_PARAMS["start"],
    increment: float = DEFAULT_INCREMENT,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
    max_steps: int = DEFAULT_MAX_STEPS,
    refine: int = 0,
    normalise: Normalise = "both",
    method: CalibrationMethod = "rsm1",
    design: DesignName | None = None,
    n_starts: int = DEFAULT_N_STARTS,
    restarts: Restarts = "on_failure",
    jac: Jacobian = "analytic",
    time_index: int = -1,
    on_outside: OnOutside = "raise",
    rng: RngLike=None,
    progress: bool = False,
) -> CalibrationResult:
    """Calibrate the sigmoid (alpha, gamma, lambda) against a recorded afferent profile.

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
    vector ``d - e`` with its closed-form Jacobian, from ``start``; only if that start fails,
    from ``n_starts - 1`` seeded random starts too, and the best is kept.

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
        Receptor -> afferent grouping (:func:`afferent.synthesis.make_branching`). To compare
        groupings (the study: longitudinal vs cross) use :func:`~afferent.calibration.compare_syntheses`.
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
        Starts of the least-squares reference at most: ``start`` first, then ``n_starts - 1``
        seeded random ones, run only if the first fails (see ``restarts``).
    restarts : {'on_failure', 'always'}, default='on_failure'
        Least squares: run the random starts only when the first start fails (scipy stopped
        at its evaluation budget, the end point predicts a constant profile, or its R^2 is
        below :data:`~afferent.calibration.reference.FALLBACK_R2` = 0.9), or always.
    jac : {'analytic', '2-point', '3-point'}, default='analytic'
        Least squares: the residuals' Jacobian in closed form (one Jacobian evaluation per
        step, counted in ``n_jacobian_evaluations``), or scipy's finite differences (1 or 2
        extra model evaluations per free parameter and step; for cross-checks).
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
        ``status`` says how it ended, one of :data:`~afferent.calibration.result.STATUSES`
        ('converged', 'flat', 'max_iter'; ``success`` is True for 'converged' only), and
        ``message`` why, in words. ``n_evaluations`` and ``n_jacobian_evaluations`` are the
        model and Jacobian evaluations spent.

    Raises
    ------
    TypeError
        Bad argument types (``synthesis`` given as a tuple: use :func:`~afferent.calibration.compare_syntheses`).
    ValueError
        Bad options, NaN SED at the compared step, a zero start value, afferents outside
        the observed range with ``on_outside='raise'``, or an all-zero normalised observation.

    Warns
    -----
    AfferentWarning
        If no receptor is in the sigmoid's sensitive range at the final parameters.

    See Also
    --------
    afferent.calibration.compare_methods : rsm1, least_squares and rsm2 on the same data.
    afferent.calibration.compare_syntheses : the same calibration for several groupings.

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
    check_option("restarts", restarts, RESTARTS)
    check_option("jac", jac, JACOBIANS)
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
    _check_spans(branching.positions, observed)

    from .._progress import progress_bar

    with progress_bar(enabled=progress, desc=f"calibrate {method}", unit="eval", leave=False) as bar:
        obj = Objective(sed_row, times_row, branching, observed, normalise, on_outside, bar)
        if method == "least_squares":
            out = least_squares_reference(obj, start, inc, max_iter, n_starts, gen, jac=jac, restarts=restarts)
        else:
            out = rsm(obj, start, inc, tol, max_iter, max_steps, method, design, refine)
    return finish(out, obj, method, _synthesis_label(synthesis), normalise, start)


def _check_spans(positions, observed) -> None:
    """Refuse observed positions whose span is orders of magnitude from the afferents' (m), either way.

    Observed positions in mm declared as m (or the reverse) put the afferents in a sliver of
    the profile (or the profile in a sliver of the afferents): the fit "converges" to nonsense.
    """
    from .._plausibility import extent, scale_ratio
    from ..exceptions import UnitError
    from ..profiles import UNIT_MISMATCH_RATIO

    ratio = scale_ratio(positions, observed.positions)
    if np.isfinite(ratio) and not (1 / UNIT_MISMATCH_RATIO <= ratio <= UNIT_MISMATCH_RATIO):
        src = getattr(observed, "source", None)
        of = f" of {src!r}" if src else ""
        raise UnitError(
            f"The afferent positions span {extent(positions):.3g} m, the observed positions{of} "
            f"{extent(observed.positions):.3g} m ({ratio:.3g} x): the unit declared for the observed positions is "
            "probably wrong (mm vs m is a factor 1e3). Declare the unit they are written in (--observed-unit; "
            "read_observed's length_unit in Python).")
