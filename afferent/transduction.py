"""Stage 3, transduction: receptor SED -> receptor current (:ref:`method-transduction`).

::

    ReceptorSED --transduce(sed, params)--> ReceptorCurrent --synthesize--> AfferentCurrent

Input: a :class:`~afferent.sampling.ReceptorSED` (any object with attributes ``values`` of
shape (n_times, n_receptors) in Pa = J/m^3, ``times`` of shape (n_times,) in s and ``layout``,
a :class:`~afferent.receptors.ReceptorLayout`) or a plain ndarray of shape
(n_times, n_receptors) in Pa.
Output: a :class:`ReceptorCurrent`, values of shape (n_times, n_receptors) in A.

Every receptor obeys the study's sigmoid

    I(SED) = alpha / (1 + exp(gamma * (lambda - SED)))

with alpha the saturation current (A), gamma the slope (1/Pa) and lambda the midpoint (Pa).
It is evaluated as ``alpha * expit(gamma * (SED - lambda))`` with ``expit(x) = 1 / (1 + exp(-x))``
in numpy (``_expit``, scipy.special.expit's formula: the same values to a few units in the last
place, without importing scipy), which stays finite, monotone and within [0, alpha] over the whole
real line.

:func:`saturation_report` says how many receptor samples sit in the sigmoid's sensitive
range: the study's own longitudinal-section parameters saturate every receptor
(:ref:`method-saturation`), so the current no longer depends on SED.

Size: just over 600 lines (269 of them docstrings), kept whole: the sigmoid, the
:class:`ReceptorCurrent` it produces and the saturation report on the same parameters form one stage.
"""

from __future__ import annotations

from .sampling import ReceptorSED

from ._typing import ArrayLike

import numbers
import warnings
from dataclasses import dataclass
from decimal import Decimal

import numpy as np

from ._validation import check_positive
from ._validation import plain as _plain
from .exceptions import AfferentWarning

__all__ = [
    "SigmoidParams",
    "STUDY_PARAMS",
    "sigmoid",
    "transduce",
    "ReceptorCurrent",
    "SaturationReport",
    "saturation_report",
    "MIN_MODULATION",
]


@dataclass(frozen=True)
class SigmoidParams:
    """Parameters of the receptor sigmoid ``I = alpha / (1 + exp(gamma * (lambda - SED)))``.

    The field names are the study's symbols (``lambda_`` because ``lambda`` is a Python
    keyword). All values are SI; use :meth:`from_study` to enter the study's table, which
    quotes alpha in mA.

    Parameters
    ----------
    alpha : float
        Saturation current in A (the current for SED -> +inf); >= 0.
    gamma : float
        Slope in 1/Pa (= m^3/J); >= 0. ``gamma = 0`` gives ``alpha / 2`` for every SED.
    lambda_ : float
        Midpoint in Pa (= J/m^3), the SED at which ``I = alpha / 2``; any finite real
        (the study's longitudinal fit has -705 Pa).

    Raises
    ------
    TypeError
        If a field is not a real number.
    ValueError
        If ``alpha`` or ``gamma`` is negative, or any field is not finite.

    See Also
    --------
    sigmoid, transduce, STUDY_PARAMS

    Examples
    --------
    >>> p = SigmoidParams(alpha=2.46e-8, gamma=4.6e-3, lambda_=300.0)
    >>> p.alpha
    2.46e-08
    """

    alpha: float
    gamma: float
    lambda_: float

    def __post_init__(self):
        alpha = check_positive("alpha", self.alpha, unit="A", strict=False, owner="SigmoidParams")
        gamma = check_positive("gamma", self.gamma, unit="1/Pa", strict=False, owner="SigmoidParams")
        lam = self.lambda_
        if isinstance(lam, bool) or not isinstance(lam, numbers.Real):
            raise TypeError(f"The 'lambda_' field of SigmoidParams must be a real number in Pa; got {_plain(lam)!r} instead.")
        if not np.isfinite(float(lam)):
            raise ValueError(f"The 'lambda_' field of SigmoidParams must be a finite number in Pa; got {_plain(lam)!r} instead.")
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "gamma", gamma)
        object.__setattr__(self, "lambda_", float(lam))

    @classmethod
    def from_study(cls, alpha_ma: float, gamma_per_pa: float, lambda_pa: float) -> "SigmoidParams":
        """Build parameters from the study's table units (alpha in mA, gamma in 1/Pa, lambda in Pa).

        The mA -> A conversion is a decimal shift done on the number as written
        (``Decimal(repr(alpha_ma)).scaleb(-3)``), so ``from_study(2.46e-05, ...).alpha``
        is exactly the float ``2.46e-08``; a float division by 1000 is not
        (``2.46e-05 / 1000 != 2.46e-08``).

        Parameters
        ----------
        alpha_ma : float
            Saturation current in mA.
        gamma_per_pa : float
            Slope in 1/Pa.
        lambda_pa : float
            Midpoint in Pa.

        Returns
        -------
        SigmoidParams
            The same parameters in SI units.

        Raises
        ------
        TypeError, ValueError
            As :class:`SigmoidParams`; the message names the field in SI.

        Examples
        --------
        >>> SigmoidParams.from_study(2.46e-05, 4.6e-03, 300).alpha
        2.46e-08
        """
        if isinstance(alpha_ma, bool) or not isinstance(alpha_ma, numbers.Real):
            raise TypeError(f"'alpha_ma' must be a real number in mA; got {_plain(alpha_ma)!r} instead.")
        if not np.isfinite(float(alpha_ma)):
            raise ValueError(f"'alpha_ma' must be a finite number in mA; got {_plain(alpha_ma)!r} instead.")
        alpha_a = float(Decimal(repr(float(alpha_ma))).scaleb(-3))
        return cls(alpha=alpha_a, gamma=gamma_per_pa, lambda_=lambda_pa)

    def __repr__(self) -> str:
        return f"SigmoidParams(alpha={self.alpha!r} A, gamma={self.gamma!r} 1/Pa, lambda_={self.lambda_!r} Pa)"


#: The three parameter sets of the study's RSM calibration table (:ref:`method-transduction`),
#: converted to SI with :meth:`SigmoidParams.from_study`. Keys: ``'start'`` (first iteration,
#: ssd 0.70), ``'longitudinal'`` (fit on longitudinal sections, ssd 0.24; saturates every
#: receptor for SED >= 0, see :func:`saturation_report`) and ``'cross'`` (fit on
#: cross-sections, ssd 0.45). Values as printed in the study: alpha (mA), gamma (1/Pa), lambda (Pa).
STUDY_PARAMS: dict[str, SigmoidParams] = {
    "start": SigmoidParams.from_study(2.46e-05, 4.6e-03, 300),
    "longitudinal": SigmoidParams.from_study(9.29e-04, 2.95e-02, -705),
    "cross": SigmoidParams.from_study(2.21e-05, 9.66e-03, 209),
}


def _check_params(params) -> SigmoidParams:
    if not isinstance(params, SigmoidParams):
        raise TypeError(
            f"'params' must be a SigmoidParams(alpha=..., gamma=..., lambda_=...); "
            f"got {type(params).__name__} instead."
        )
    return params


def _as_float_array(name: str, a) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name!r} must be a real-valued array in Pa; got {type(a).__name__} instead.") from err
    nan = np.isnan(arr)
    if nan.any():
        idx = tuple(int(i) for i in np.argwhere(nan)[0])
        raise ValueError(
            f"{name!r} must not contain NaN; got {int(nan.sum())} NaN value(s) (first at index {idx}) instead."
        )
    return arr


def _expit(x) -> np.ndarray:
    """The logistic function ``1 / (1 + exp(-x))`` (dimensionless), elementwise, in [0, 1].

    scipy.special.expit's formula in numpy (scipy is not imported: 0.2 s of CPU less for a
    spikes-only run). The ends as scipy's: 1 exactly for x > 36.7 (``1 + exp(-x)`` rounds to 1),
    0 for x < -709.78 (``exp(-x)`` overflows to inf; the true value is below 1.7e-308), 1 / 0 at
    +-inf, 0.5 at 0, NaN for NaN. Elsewhere it differs from scipy's only by numpy's ``exp``
    against the C library's (numpy's own SIMD ``exp`` on AVX-512 machines): at most 4 units in
    the last place (tests/test_transduction.py).
    """
    with np.errstate(over="ignore"):  # exp(-x) = inf for x < -709.78: 1 / inf = 0, the exact limit
        return 1.0 / (1.0 + np.exp(-np.asarray(x, dtype=np.float64)))


def _relative(sed: np.ndarray, params: SigmoidParams) -> np.ndarray:
    """``I / alpha`` = expit(gamma * (SED - lambda)) for a NaN-free float array; in [0, 1]."""
    if params.gamma == 0.0:
        # 0 * inf would be NaN when SED - lambda overflows: the limit is 1/2 everywhere.
        return np.full(sed.shape, 0.5)
    # SED - lambda and gamma * (SED - lambda) may overflow to +-inf for |SED| near the float
    # maximum; expit(+-inf) is exactly 1 / 0, so the overflow is harmless and kept local.
    with np.errstate(over="ignore"):
        x = params.gamma * (sed - params.lambda_)
    return _expit(x)


def sigmoid(sed: ArrayLike, params: SigmoidParams) -> np.ndarray:
    """Receptor current of the study's sigmoid, ``alpha / (1 + exp(gamma * (lambda - SED)))``.

    Evaluated as ``alpha * expit(gamma * (SED - lambda))``: finite, monotone non-decreasing
    in SED and within [0, alpha] for every real SED (including 0, +-1e308 and a negative
    lambda), for ``gamma = 0`` (``alpha / 2`` everywhere) and for huge gamma, without
    overflow warnings. ``sigmoid(lambda) == alpha / 2`` exactly. SED = +-inf gives the
    limits alpha and 0.

    Parameters
    ----------
    sed : array_like of any shape
        Strain-energy density in Pa (= J/m^3).
    params : SigmoidParams
        alpha (A), gamma (1/Pa), ``lambda_`` (Pa).

    Returns
    -------
    ndarray of float64, same shape as ``sed``
        Receptor current in A.

    Raises
    ------
    TypeError
        If ``params`` is not a :class:`SigmoidParams` or ``sed`` is not real-valued.
    ValueError
        If ``sed`` contains NaN; the message gives the index of the first one.

    See Also
    --------
    transduce : the same on a ReceptorSED, returning a ReceptorCurrent.

    Examples
    --------
    >>> p = SigmoidParams(alpha=1e-8, gamma=0.01, lambda_=100.0)
    >>> float(sigmoid(100.0, p))
    5e-09
    >>> sigmoid([-1e308, 1e308], p).tolist()
    [0.0, 1e-08]
    """
    params = _check_params(params)
    arr = _as_float_array("sed", sed)
    return params.alpha * _relative(arr, params)


@dataclass(frozen=True)
class ReceptorCurrent:
    """Current of every receptor at every time: the output of :func:`transduce`.

    Parameters
    ----------
    values : ndarray of shape (n_times, n_receptors)
        Receptor current in A.
    times : ndarray of shape (n_times,) or None
        Time of each row in s, strictly increasing; ``None`` when the SED came as a plain
        array without times.
    layout : ReceptorLayout or None
        The receptor sites, in column order; ``None`` for plain-array input.
    params : SigmoidParams or None
        The transduction parameters that produced the current.

    Notes
    -----
    Arrays are read-only. ``np.asarray(current)`` gives ``values``.
    """

    values: np.ndarray
    times: np.ndarray | None = None
    layout: object | None = None
    params: SigmoidParams | None = None

    def __post_init__(self):
        values, times = _check_values_times(self.values, self.times, what="values", unit="A", cols="n_receptors")
        if self.layout is not None and getattr(self.layout, "n_receptors", values.shape[1]) != values.shape[1]:
            raise ValueError(
                f"'layout' must have one receptor per column of 'values' (n_receptors = {values.shape[1]}); "
                f"got a layout of {self.layout.n_receptors} receptors instead."
            )
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "times", times)

    @property
    def n_times(self) -> int:
        """Number of time steps."""
        return self.values.shape[0]

    @property
    def n_receptors(self) -> int:
        """Number of receptors."""
        return self.values.shape[1]

    def __array__(self, dtype=None, copy=None):
        if copy:
            return np.array(self.values, dtype=dtype, copy=True)
        return np.asarray(self.values, dtype=dtype)

    def __repr__(self) -> str:
        t = "no times" if self.times is None else f"t [{self.times[0]:g}..{self.times[-1]:g}] s"
        return (
            f"<ReceptorCurrent: {self.n_times} time step(s) x {self.n_receptors} receptors, {t}, "
            f"I in [{self.values.min():.4g}, {self.values.max():.4g}] A>"
        )


def _check_values_times(values, times, *, what: str, unit: str, cols: str):
    """Validate a time-first 2-D array and its optional times; return read-only copies."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 2:
        raise ValueError(
            f"{what!r} must be an array of shape (n_times, {cols}) in {unit}; got shape {arr.shape} instead."
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        t, j = (int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{what!r} must be finite; got {int(bad.sum())} non-finite value(s) "
            f"(first: {float(arr[t, j])!r} at time step {t}, column {j}) instead."
        )
    arr = np.array(arr, copy=True)
    arr.setflags(write=False)
    if times is not None:
        times = np.array(times, dtype=np.float64, copy=True)
        if times.shape != (arr.shape[0],):
            raise ValueError(
                f"'times' must have one entry per row of {what!r} (n_times = {arr.shape[0]}); "
                f"got shape {times.shape} instead."
            )
        if not np.all(np.isfinite(times)):
            raise ValueError("'times' must be finite, in s; got non-finite values instead.")
        if times.size > 1 and not np.all(np.diff(times) > 0):
            k = int(np.argmin(np.diff(times) > 0))
            raise ValueError(
                f"'times' must be strictly increasing; got {float(times[k])!r} s followed by {float(times[k + 1])!r} s "
                f"(steps {k} and {k + 1}) instead."
            )
        times.setflags(write=False)
    return arr, times


def _unwrap_sed(sed, times=None):
    """Split a ReceptorSED-like object or a plain array into (values, times, layout)."""
    if isinstance(sed, ReceptorCurrent):
        raise TypeError("'sed' must be receptor SED in Pa; got a ReceptorCurrent (in A) instead.")
    if hasattr(sed, "values") and hasattr(sed, "times") and not isinstance(sed, np.ndarray):
        if times is not None:
            raise ValueError(
                f"'times' must only be given with a plain array; got a {type(sed).__name__}, "
                "which carries its own times."
            )
        return sed.values, sed.times, getattr(sed, "layout", None)
    return sed, times, None


def _nan_message(arr: np.ndarray, layout) -> str | None:
    nan = np.isnan(arr)
    if not nan.any():
        return None
    t, j = (int(i) for i in np.argwhere(nan)[0])
    rid = f" (id {str(layout.ids[j])!r})" if layout is not None and hasattr(layout, "ids") else ""
    return (
        f"'sed' must not contain NaN; got {int(nan.sum())} NaN value(s), first at time step {t}, "
        f"receptor {j}{rid} instead. Receptors sampled outside the FE field (on_outside='nan') "
        "must be dropped before transduction."
    )


def transduce(sed: ReceptorSED | ArrayLike, params: SigmoidParams, *, times: ArrayLike | None=None) -> ReceptorCurrent:
    """Turn receptor SED into receptor current with the sigmoid of :func:`sigmoid`.

    Parameters
    ----------
    sed : ReceptorSED or array_like of shape (n_times, n_receptors)
        SED at the receptor sites in Pa (= J/m^3). A ReceptorSED (any object with
        ``values``, ``times`` and ``layout``) passes its times and layout on.
    params : SigmoidParams
        alpha (A), gamma (1/Pa), ``lambda_`` (Pa).
    times : array_like of shape (n_times,), optional
        Time of each row in s, only for a plain-array ``sed``; without it the result's
        ``times`` is ``None``.

    Returns
    -------
    ReceptorCurrent
        Values of shape (n_times, n_receptors) in A.

    Raises
    ------
    TypeError
        If ``params`` is not a :class:`SigmoidParams`, or ``sed`` is a ReceptorCurrent.
    ValueError
        If ``sed`` is not 2-D, holds NaN (the message names the time step and receptor),
        or ``times`` does not match.

    Warns
    -----
    AfferentWarning
        If no receptor sample lies in the sigmoid's sensitive range
        0.05 < I/alpha < 0.95 (all saturated or all near zero): the current then hardly
        depends on SED. See :func:`saturation_report`.

    See Also
    --------
    sigmoid : the element-wise function.
    afferent.synthesis.synthesize : the next stage.

    Examples
    --------
    >>> import numpy as np
    >>> cur = transduce(np.array([[0.0, 150.0, 300.0]]), STUDY_PARAMS["start"])
    >>> cur.values.shape
    (1, 3)
    """
    params = _check_params(params)
    values, times, layout = _unwrap_sed(sed, times)
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"'sed' must be a real-valued array in Pa; got {type(values).__name__} instead.") from err
    if arr.ndim != 2:
        hint = " For a single time step pass sed[np.newaxis, :]." if arr.ndim == 1 else ""
        raise ValueError(
            f"'sed' must be an array of shape (n_times, n_receptors) in Pa; got shape {arr.shape} instead.{hint}"
        )
    msg = _nan_message(arr, layout)
    if msg:
        raise ValueError(msg)
    rel = _relative(arr, params)
    report = _report_from_relative(rel, params, low=0.05, high=0.95, sed=arr)
    if report.n_samples and report.unmodulated:
        warnings.warn(report.message, AfferentWarning, stacklevel=2)
    return ReceptorCurrent(params.alpha * rel, times, layout, params)


@dataclass(frozen=True)
class SaturationReport:
    """Where receptor samples sit on the sigmoid (:ref:`method-saturation`).

    Parameters
    ----------
    fraction_sensitive : float
        Fraction of receptor samples (all times x receptors) with ``low < I/alpha < high``.
    fraction_high : float
        Fraction with ``I/alpha >= high`` (saturated).
    fraction_low : float
        Fraction with ``I/alpha <= low`` (near zero).
    relative_min, relative_max : float
        Smallest and largest ``I/alpha`` over the samples (dimensionless, in [0, 1]).
    n_samples : int
        Number of receptor samples, n_times * n_receptors.
    low, high : float
        The thresholds used, as fractions of alpha.
    message : str
        One-sentence verdict, suitable for a warning or a log.
    modulation : float
        How much the current varies across the receptors: ``(max I - min I) / mean I`` over the
        receptors, at the time step where it is largest (dimensionless; NaN without receptors,
        0 when every current is 0). The position on the sigmoid alone cannot tell this: with
        gamma = 0 or 1e-9 /Pa every sample sits mid-sigmoid (100 % "sensitive") while the
        currents differ by 1e-6 or less.
    gamma_sed_range : float
        ``gamma x (max SED - min SED)`` over the receptors at the step of the largest SED range
        (dimensionless): how far along the sigmoid the receptors' SEDs spread.
    """

    fraction_sensitive: float
    fraction_high: float
    fraction_low: float
    relative_min: float
    relative_max: float
    n_samples: int
    low: float
    high: float
    message: str
    modulation: float = float("nan")
    gamma_sed_range: float = float("nan")

    @property
    def saturated(self) -> bool:
        """True if no sample is in the sensitive range (the current is insensitive to SED)."""
        return self.n_samples > 0 and self.fraction_sensitive == 0.0

    @property
    def unmodulated(self) -> bool:
        """True if the currents differ across receptors by at most :data:`MIN_MODULATION` of
        their mean: the profile carries (almost) no information about the SED pattern."""
        return self.saturated or (np.isfinite(self.modulation) and self.modulation <= MIN_MODULATION)

    def summary(self) -> str:
        """One line for a command's output: the sensitive fraction and the modulation."""
        return (f"transduction: {self.fraction_sensitive:.1%} of receptor samples in the sigmoid's sensitive range, "
                f"currents vary by {self.modulation:.3g} of their mean across receptors "
                f"(gamma x SED range {self.gamma_sed_range:.3g})")


#: A current that varies across receptors by at most this fraction of its mean is reported as
#: unmodulated (the profile it gives carries almost no information about the SED pattern).
MIN_MODULATION = 1e-3


def _fmt_rel(r: float) -> str:
    """Format I/alpha so that values next to 1 stay readable (``1 - 9.28e-10``)."""
    return f"1 - {1.0 - r:.3g}" if r > 0.999 else f"{r:.4g}"


def _modulation(rel: np.ndarray, sed: np.ndarray, params: SigmoidParams) -> tuple[float, float]:
    """(max over steps of ptp(I)/mean(I) across receptors, gamma x max over steps of ptp(SED))."""
    r = rel.reshape(-1, rel.shape[-1]) if rel.ndim else rel.reshape(1, 1)
    x = np.asarray(sed, dtype=float).reshape(r.shape)
    if r.shape[1] == 0:
        return float("nan"), float("nan")
    mean = r.mean(axis=1)
    ptp = r.max(axis=1) - r.min(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mod = np.where(mean > 0, ptp / np.where(mean > 0, mean, 1.0), 0.0)
    with np.errstate(over="ignore"):  # SED +-1e300 or gamma 1e12: the range (or its product) is inf, and says so
        spread = np.max(x.max(axis=1) - x.min(axis=1))
        return float(mod.max()), 0.0 if params.gamma == 0.0 else float(params.gamma * spread)  # gamma 0: flat, not 0 x inf


def _report_from_relative(rel: np.ndarray, params: SigmoidParams, *, low: float, high: float, sed=None) -> SaturationReport:
    n = int(rel.size)
    if n == 0:
        return SaturationReport(0.0, 0.0, 0.0, float("nan"), float("nan"), 0, low, high, "No receptor samples.")
    mod, gs = _modulation(rel, sed, params) if sed is not None else (float("nan"), float("nan"))
    f_high = float(np.count_nonzero(rel >= high)) / n
    f_low = float(np.count_nonzero(rel <= low)) / n
    f_sens = float(np.count_nonzero((rel > low) & (rel < high))) / n
    rmin, rmax = float(rel.min()), float(rel.max())
    rng_txt = f"I/alpha in [{_fmt_rel(rmin)}, {_fmt_rel(rmax)}]"
    if f_high == 1.0:
        msg = (
            f"All {n} receptor samples are saturated (I/alpha >= {high:g}; {rng_txt}) with {params!r}: "
            "the receptor current practically does not depend on SED."
        )
    elif f_low == 1.0:
        msg = (
            f"All {n} receptor samples are near zero (I/alpha <= {low:g}; {rng_txt}) with {params!r}: "
            "the receptor current barely depends on SED."
        )
    elif f_sens == 0.0:
        msg = (
            f"No receptor sample is in the sensitive range {low:g} < I/alpha < {high:g} with {params!r}: "
            f"{f_high:.1%} saturated, {f_low:.1%} near zero ({rng_txt})."
        )
    else:
        msg = (
            f"{f_sens:.1%} of {n} receptor samples are in the sensitive range {low:g} < I/alpha < {high:g} "
            f"({f_high:.1%} saturated, {f_low:.1%} near zero; {rng_txt})."
        )
    if np.isfinite(mod) and mod <= MIN_MODULATION and f_sens > 0:
        msg = (f"The receptor currents differ by only {mod:.3g} of their mean across receptors (gamma x SED range = "
               f"{gs:.3g}) with {params!r}: although {f_sens:.1%} of the samples sit in the sigmoid's sensitive range, "
               "the profile carries almost no information about the SED pattern.")
    if params.gamma == 0.0:
        msg += " gamma = 0: I = alpha/2 whatever the SED."
    if params.alpha == 0.0:
        msg += " alpha = 0: every current is 0 A."
    return SaturationReport(f_sens, f_high, f_low, rmin, rmax, n, low, high, msg, mod, gs)


def saturation_report(sed: ReceptorSED | ArrayLike, params: SigmoidParams, *, low: float = 0.05, high: float = 0.95) -> SaturationReport:
    """Fraction of receptor samples in the sigmoid's sensitive range ``low < I/alpha < high``.

    :ref:`method-saturation`: with SED >= 0 Pa, the study's longitudinal-section parameters
    (gamma 2.95e-2 /Pa, lambda -705 Pa) put every receptor at I/alpha >= 1 - 1e-9, so the
    current no longer depends on SED. This report makes such a parameter set visible.
    ``I/alpha`` is computed directly (``expit``), so it is defined even for ``alpha = 0``.

    Parameters
    ----------
    sed : ReceptorSED or array_like
        SED at the receptor sites in Pa; any shape (every element is one sample).
    params : SigmoidParams
        alpha (A), gamma (1/Pa), ``lambda_`` (Pa).
    low, high : float, default=0.05, 0.95
        Thresholds as fractions of alpha, ``0 <= low < high <= 1``.

    Returns
    -------
    SaturationReport

    Raises
    ------
    TypeError
        If ``params`` is not a :class:`SigmoidParams`.
    ValueError
        If ``sed`` contains NaN or the thresholds are not ``0 <= low < high <= 1``.

    See Also
    --------
    transduce : warns when no sample is in the sensitive range.

    Examples
    --------
    >>> import numpy as np
    >>> sed = np.linspace(0.0, 190.0, 20)
    >>> saturation_report(sed, STUDY_PARAMS["longitudinal"]).fraction_sensitive
    0.0
    >>> saturation_report(sed, STUDY_PARAMS["start"]).fraction_sensitive
    1.0
    """
    params = _check_params(params)
    for name, v in (("low", low), ("high", high)):
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise TypeError(f"{name!r} must be a real number (a fraction of alpha); got {_plain(v)!r} instead.")
    if not (0.0 <= low < high <= 1.0):
        raise ValueError(f"'low' and 'high' must satisfy 0 <= low < high <= 1; got low={_plain(low)!r}, high={_plain(high)!r} instead.")
    values, _, layout = _unwrap_sed(sed)
    arr = _as_float_array("sed", values)
    if arr.ndim == 1:
        arr = arr[np.newaxis, :]
    return _report_from_relative(_relative(arr, params), params, low=float(low), high=float(high), sed=arr)
