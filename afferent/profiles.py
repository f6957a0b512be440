"""Comparison of predicted afferent profiles with recorded responses (:ref:`method-comparison`).

::

    AfferentCurrent --compare_profiles(predicted, observed)--> ProfileFit
    observed CSV --read_observed--> ObservedProfile --observed_on(positions)--> values at afferents

A *profile* is one value per afferent, plotted against the afferent's position (x for
longitudinal sections, z for cross-sections). Profiles are compared after min-max
normalisation, ``e_i = (A_i - min A) / (max A - min A)``, with

- :func:`r2_study`, the study's goodness of fit ``1 - sum (d - e)^2 / sum d^2`` (no mean
  subtracted; it is *not* the usual coefficient of determination),
- :func:`r2`, the usual ``1 - SS_res / SS_tot`` (:func:`sklearn.metrics.r2_score`),
- :func:`ssd`, ``sum (d - e)^2``, the calibration objective.

``d`` is always the observation (recording) and ``e`` the prediction.

Size: just over 600 lines (285 of them docstrings), kept whole: the metrics, the observed
profile and the comparison are used together by calibration and the pipeline, and each is short.
"""

from __future__ import annotations

from .synthesis import AfferentCurrent

from ._typing import ArrayLike, PathLike

import os
import warnings
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from ._plausibility import scale_ratio
from ._validation import check_option, suggest
from .exceptions import AfferentWarning, SEDFormatError
from .sampling import OnOutside
from .units import length_factor

__all__ = [
    "minmax_normalise",
    "r2_study",
    "r2",
    "ssd",
    "ObservedProfile",
    "read_observed",
    "observed_on",
    "ProfileFit",
    "compare_profiles",
    "peak_step",
    "NEARLY_CONSTANT_RTOL",
    "TINY_MODULATION_RTOL",
]

#: A slice whose range (max - min) is positive but at most this fraction of its largest
#: magnitude is "nearly constant": its min-max normalised shape is made of rounding (float64
#: resolves a shape to about 2.2e-16 / (range / magnitude): 2e-4 at this threshold), e.g. the
#: currents of receptors saturated by the study's longitudinal parameters (1e-15 of their level).
#: :func:`minmax_normalise` still normalises it but warns; calibration sets such runs aside.
NEARLY_CONSTANT_RTOL = 1e-12
#: Above :data:`NEARLY_CONSTANT_RTOL` and up to this fraction, a slice is a tiny but resolved
#: modulation (e.g. SED deep in the sigmoid's exponential tail: a range of 1e-10 of the level
#: is resolved to ~2e-6 of the shape and matches the analytic tail): warned as such, kept.
TINY_MODULATION_RTOL = 1e-6

#: Relative slack (of the observed span) within which a position counts as inside the observed
#: range: float round-off between a computed section position and one read from a CSV.
POSITION_RTOL = 1e-9

Normalise = Literal["both", "prediction", "observation", "neither"]
_NORMALISE: tuple[str, ...] = get_args(Normalise)


def _finite(name: str, a, *, ndim: int | None = None) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name!r} must be a real-valued array; got {type(a).__name__} instead.") from err
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name!r} must be a {ndim}-D array; got shape {arr.shape} instead.")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{name!r} must be finite; got {int(bad.sum())} non-finite value(s) (first: {float(arr[idx])!r} at index {idx}) instead."
        )
    return arr


def minmax_normalise(a: ArrayLike, *, axis: int | None = -1) -> np.ndarray:
    """Min-max normalise ``a`` to [0, 1]: ``(a - min a) / (max a - min a)`` along ``axis``.

    Parameters
    ----------
    a : array_like
        Values in any unit (the result is dimensionless); finite.
    axis : int or None, default=-1
        Axis along which min and max are taken; -1 (the default) normalises each profile of
        an (n_times, n_afferents) array across afferents; ``None`` uses the whole array.

    Returns
    -------
    ndarray of float64, same shape as ``a``
        Values in [0, 1]; each slice has min 0 and max 1, except constant slices, which
        become all zeros (never NaN).

    Raises
    ------
    ValueError
        If ``a`` is empty along ``axis`` or holds NaN / inf.

    Warns
    -----
    AfferentWarning
        If a slice is constant (it is mapped to zeros: it carries no shape), nearly
        constant, ``0 < max - min <= NEARLY_CONSTANT_RTOL * max(|min|, |max|)`` (1e-12: its
        normalised shape is then dominated by rounding), or a tiny modulation, up to
        ``TINY_MODULATION_RTOL`` (1e-6: resolved, but the normalisation hides how small it is).

    Examples
    --------
    >>> minmax_normalise([2.0, 4.0, 3.0]).tolist()
    [0.0, 1.0, 0.5]
    """
    arr = _finite("a", a)
    if arr.size == 0 or (axis is not None and arr.ndim and arr.shape[axis] == 0):
        raise ValueError(f"'a' must not be empty along the normalisation axis; got shape {arr.shape} instead.")
    if arr.ndim == 0:
        arr = arr.reshape(1)
        squeeze = True
    else:
        squeeze = False
    lo = arr.min(axis=axis, keepdims=True)
    hi = arr.max(axis=axis, keepdims=True)
    with np.errstate(over="ignore"):
        span = hi - lo
    if not np.all(np.isfinite(span)):
        # max - min overflowed (values near +-1.8e308): halving is exact for such magnitudes.
        arr, lo, hi = arr / 2, lo / 2, hi / 2
        span = hi - lo
    scale = np.maximum(np.abs(lo), np.abs(hi))
    constant = span == 0
    nearly = (span > 0) & (span <= NEARLY_CONSTANT_RTOL * scale)
    tiny = (span > NEARLY_CONSTANT_RTOL * scale) & (span <= TINY_MODULATION_RTOL * scale)
    if constant.any():
        warnings.warn(
            f"{int(constant.sum())} of {constant.size} profile(s) are constant; min-max normalisation maps "
            "them to zeros (they carry no shape).",
            AfferentWarning,
            stacklevel=2,
        )
    if nearly.any():
        warnings.warn(
            f"{int(nearly.sum())} of {nearly.size} profile(s) are nearly constant (max - min <= "
            f"{NEARLY_CONSTANT_RTOL:g} of their magnitude); their normalised shape is dominated by rounding.",
            AfferentWarning,
            stacklevel=2,
        )
    if tiny.any():
        rel = float(np.max(np.where(tiny, span / np.where(scale > 0, scale, 1.0), 0.0)))
        warnings.warn(
            f"{int(tiny.sum())} of {tiny.size} profile(s) vary by only up to {rel:.2g} of their level (<= "
            f"{TINY_MODULATION_RTOL:g}): a tiny modulation (e.g. SED in the sigmoid's exponential tail), resolved in "
            f"float64 to about {2.2e-16 / rel:.1g} of the normalised shape, not rounding noise; the normalised "
            "profile hides how small it is.",
            AfferentWarning,
            stacklevel=2,
        )
    safe = np.where(constant, 1.0, span)
    out = np.where(constant, 0.0, (arr - lo) / safe)
    return out[0] if squeeze else out


def _pair(d, e) -> tuple[np.ndarray, np.ndarray]:
    d = _finite("d", d)
    e = _finite("e", e)
    if d.shape != e.shape:
        raise ValueError(f"'d' and 'e' must have the same shape; got {d.shape} and {e.shape} instead.")
    if d.size == 0:
        raise ValueError("'d' and 'e' must not be empty; got 0 samples.")
    return d.ravel(), e.ravel()


def r2_study(d: ArrayLike, e: ArrayLike) -> float:
    """The study's goodness of fit, ``1 - sum (d - e)^2 / sum d^2`` (:ref:`method-comparison`).

    Unlike the usual coefficient of determination (:func:`r2`), no mean is subtracted from
    ``d``; with min-max normalised profiles it is higher than :func:`r2` in general.

    Parameters
    ----------
    d : array_like
        Observed (recorded) profile, normalised as the comparison requires.
    e : array_like, same shape as ``d``
        Predicted profile.

    Returns
    -------
    float
        Dimensionless; 1 for a perfect fit, unbounded below.

    Raises
    ------
    ValueError
        If the shapes differ, a value is not finite, or ``d`` is all zeros.

    Examples
    --------
    >>> r2_study([0.0, 1.0, 0.5], [0.0, 1.0, 0.25])
    0.95
    """
    d, e = _pair(d, e)
    denom = float(np.sum(d * d))
    if denom == 0.0:
        raise ValueError("'d' must not be all zeros: r2_study divides by sum(d**2); got an all-zero 'd' instead.")
    return 1.0 - float(np.sum((d - e) ** 2)) / denom


def r2(d: ArrayLike, e: ArrayLike) -> float:
    """The usual coefficient of determination ``1 - SS_res / SS_tot`` (:func:`sklearn.metrics.r2_score`).

    Parameters
    ----------
    d : array_like
        Observed profile (``y_true``), at least 2 samples.
    e : array_like, same shape as ``d``
        Predicted profile (``y_pred``).

    Returns
    -------
    float
        Dimensionless. For a constant ``d``, scikit-learn's convention applies: 1.0 for a
        perfect prediction, 0.0 otherwise.

    Raises
    ------
    ValueError
        If the shapes differ, a value is not finite, or there are fewer than 2 samples.

    Examples
    --------
    >>> r2([0.0, 1.0, 0.5], [0.0, 1.0, 0.5])
    1.0
    """
    d, e = _pair(d, e)
    if d.size < 2:
        raise ValueError(f"r2 needs at least 2 samples; got {d.size} instead.")
    # scikit-learn's arithmetic, operation for operation (one output column, uniform weights), so the
    # value is its bit for bit (tests/test_profiles.py) without its checks: 0.4 ms a call, and 1 s to import
    t, p = d.astype(float).reshape(-1, 1), e.astype(float).reshape(-1, 1)
    numerator = np.sum(1.0 * (t - p) ** 2, axis=0)
    denominator = np.sum(1.0 * (t - np.average(t, axis=0)) ** 2, axis=0)
    score = np.ones(1)
    valid = (numerator != 0) & (denominator != 0)
    score[valid] = 1 - numerator[valid] / denominator[valid]
    score[(numerator != 0) & (denominator == 0)] = 0.0
    return float(np.average(score))


def ssd(d: ArrayLike, e: ArrayLike) -> float:
    """Sum of squared differences ``sum (d - e)^2``, the calibration objective.

    Parameters
    ----------
    d, e : array_like of the same shape
        Observed and predicted profiles (normalised as the comparison requires).

    Returns
    -------
    float
        In the square of the profiles' unit (dimensionless for normalised profiles).

    Examples
    --------
    >>> ssd([0.0, 1.0], [0.5, 1.0])
    0.25
    """
    d, e = _pair(d, e)
    return float(np.sum((d - e) ** 2))


@dataclass(frozen=True)
class ObservedProfile:
    """A recorded response profile: one response per position, sorted by position.

    Parameters
    ----------
    positions : ndarray of shape (n_observed,)
        Positions in m, strictly increasing, finite.
    response : ndarray of shape (n_observed,)
        Recorded response in the recording's own unit (e.g. spikes/s or already
        normalised); only its shape matters once normalised.
    source : str, default=''
        File it was read from, if any.
    """

    positions: np.ndarray
    response: np.ndarray
    source: str = ""

    def __post_init__(self):
        pos = _finite("positions", self.positions, ndim=1)
        resp = _finite("response", self.response, ndim=1)
        if pos.shape != resp.shape:
            raise ValueError(
                f"'positions' and 'response' must have the same length; got {pos.size} and {resp.size} instead."
            )
        if pos.size < 2:
            raise ValueError(f"An observed profile needs at least 2 points; got {pos.size} instead.")
        if not np.all(np.diff(pos) > 0):
            k = int(np.argmin(np.diff(pos) > 0))
            raise ValueError(
                f"'positions' must be strictly increasing, in m; got {float(pos[k])!r} followed by {float(pos[k + 1])!r} "
                f"(points {k} and {k + 1}) instead."
            )
        pos, resp = pos.copy(), resp.copy()
        pos.setflags(write=False)
        resp.setflags(write=False)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "response", resp)


def read_observed(path: PathLike, *, length_unit: str, position_column: str = "position",
                  response_column: str = "response") -> ObservedProfile:
    """Read a recorded profile from a CSV with a position column and a response column.

    Parameters
    ----------
    path : str or path-like
        CSV file (comma, semicolon, tab or whitespace separated; ``#`` comments allowed).
    length_unit : str
        Unit of the positions (``'m'``, ``'mm'``, ``'um'``, ...); required, never guessed.
    position_column, response_column : str, default='position', 'response'
        Column names, matched case-insensitively.

    Returns
    -------
    ObservedProfile
        Positions in m, sorted increasing (rows are reordered if needed); response as read.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SEDFormatError
        If the file cannot be parsed, lacks a column, holds non-numeric values, has fewer
        than 2 rows or repeats a position.
    UnitError
        If ``length_unit`` is unknown.
    """

    from ._tables import numeric_columns, read_table

    path = os.fspath(path)
    factor = length_factor(length_unit)
    # Read as text so that an error can quote the cell as written ('n/a', '').
    df, cols = read_table(path, what="Observed profile file", expected="position, response", as_text=True)
    picked = []
    for kw, name in (("position_column", position_column), ("response_column", response_column)):
        if str(name).lower() not in cols:
            found = ", ".join(repr(str(c)) for c in df.columns) or "none"
            raise SEDFormatError(
                f"Observed profile file {path!r} has no column {name!r}. Found columns {found}."
                f"{suggest(name, [str(c) for c in df.columns])} Pass {kw}=... to choose another column."
            )
        picked.append(cols[str(name).lower()])
    data = numeric_columns(df, picked, what="Observed profile file", path=path)
    order = np.argsort(data[:, 0], kind="stable")
    try:
        return ObservedProfile(data[order, 0] * factor, data[order, 1], source=path)
    except ValueError as err:
        raise SEDFormatError(f"Observed profile file {path!r}: {err}") from err


def _as_observed(observed) -> ObservedProfile:
    if isinstance(observed, ObservedProfile):
        return observed
    if isinstance(observed, tuple) and len(observed) == 2:
        pos, resp = (np.asarray(v, dtype=float) for v in observed)
        order = np.argsort(pos, kind="stable")
        return ObservedProfile(pos[order], resp[order])
    raise TypeError(
        f"'observed' must be an ObservedProfile (see read_observed) or a (positions_m, response) tuple; "
        f"got {type(observed).__name__} instead."
    )


#: Afferent and observed positions whose extents differ by more than this factor were
#: probably declared in different length units (mm vs m is 1e3).
UNIT_MISMATCH_RATIO = 30.0


def _source(obs) -> str:
    return f" of {obs.source!r}" if getattr(obs, "source", None) else ""


def observed_on(positions: ArrayLike, observed: ObservedProfile | tuple, *, on_outside: OnOutside = "raise", _remedy: str = "on_outside='nan'") -> np.ndarray:
    """Interpolate an observed profile onto afferent positions.

    Linear interpolation between neighbouring observed points (:func:`numpy.interp`); no
    extrapolation: a position outside [first, last] observed position raises, or gives NaN
    with ``on_outside='nan'``.

    Parameters
    ----------
    positions : array_like of shape (n_afferents,)
        Afferent positions in m.
    observed : ObservedProfile or tuple (positions, response)
        Observed positions in m and responses (any unit).
    on_outside : {'raise', 'nan'}, default='raise'
        What to do with positions outside the observed range.

    Returns
    -------
    ndarray of shape (n_afferents,)
        Observed response at each position, in the response's unit (NaN outside the range
        with ``on_outside='nan'``).

    Raises
    ------
    ValueError
        If a position lies outside the observed range and ``on_outside='raise'``.

    Examples
    --------
    >>> observed_on([1e-3, 1.5e-3], ([1e-3, 2e-3], [0.0, 10.0])).tolist()
    [0.0, 5.0]
    """
    check_option("on_outside", on_outside, ("raise", "nan"))
    obs = _as_observed(observed)
    pos = _finite("positions", positions, ndim=1)
    lo, hi = obs.positions[0], obs.positions[-1]
    # Positions are compared with a slack of POSITION_RTOL of the observed span, so that the
    # same coordinate computed two ways (a section mean vs a number printed in a CSV) matches.
    slack = POSITION_RTOL * max(hi - lo, abs(hi), abs(lo))
    outside = (pos < lo - slack) | (pos > hi + slack)
    ratio = scale_ratio(pos, obs.positions)
    units = ""
    if np.isfinite(ratio) and not (1 / UNIT_MISMATCH_RATIO <= ratio <= UNIT_MISMATCH_RATIO):
        units = (f" The afferent positions span {ratio:.3g} x the observed ones{_source(obs)}: check the length unit "
                 "declared for the observed positions (mm vs m is a factor 1e3).")
    if outside.any() and on_outside == "raise":
        k = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"{int(outside.sum())} of {pos.size} positions lie outside the observed range "
            f"[{lo:.6g}, {hi:.6g}] m (first: position {k} at {pos[k]:.6g} m); the observation is not "
            f"extrapolated. Pass {_remedy} to skip them."
            + units
        )
    if units:
        warnings.warn(units.strip(), AfferentWarning, stacklevel=2)
    out = np.interp(np.clip(pos, lo, hi), obs.positions, obs.response)
    out[outside] = np.nan
    return out


@dataclass(frozen=True)
class ProfileFit:
    """Goodness of fit of a predicted profile against an observed one.

    Parameters
    ----------
    r2_study : float
        The study's ``1 - sum (d - e)^2 / sum d^2`` (see :func:`r2_study`).
    r2 : float
        The usual coefficient of determination (see :func:`r2`).
    ssd : float
        ``sum (d - e)^2`` (see :func:`ssd`).
    predicted : ndarray of shape (n_compared,)
        The prediction ``e`` as compared (min-max normalised when ``normalise`` is
        ``'both'`` or ``'prediction'``; else in A).
    observed : ndarray of shape (n_compared,)
        The observation ``d`` on the same positions, as compared.
    positions : ndarray of shape (n_compared,) or None
        Positions in m of the compared points; ``None`` if neither input carried positions.
    normalise : {'both', 'prediction', 'observation', 'neither'}
        Which profiles were min-max normalised.
    time_index : int or None
        Time step of the prediction that was compared (None for a 1-D prediction).
    time : float or None
        Its time in s, when known.
    dropped : int
        Number of afferents left out because they lie outside the observed range.
    variation : tuple of float or None
        ``(predicted, observed)`` before normalising: ``(max - min) / max |v|`` over the compared
        points (dimensionless). Min-max normalising a profile that varies by a few % stretches
        that few % to 0..1 (and R^2 with it): :func:`afferent.plotting.plot_fit` says so.
    """

    r2_study: float
    r2: float
    ssd: float
    predicted: np.ndarray
    observed: np.ndarray
    positions: np.ndarray | None
    normalise: Normalise
    time_index: int | None = None
    time: float | None = None
    dropped: int = 0
    variation: tuple[float, float] | None = None


def peak_step(afferent: AfferentCurrent) -> int:
    """The time step whose profile the static outputs show: the largest total afferent current.

    A stimulus that indents and releases ends at zero: its last step is an empty profile, so
    figures, the receptor VTU, the profile table and the fit all use this step instead, and the
    run record names it.

    Parameters
    ----------
    afferent : AfferentCurrent
        Afferent currents of shape (n_times, n_afferents) in A.

    Returns
    -------
    int
        A non-negative step index (the first of equal maxima; 0 for a single step).
    """
    values = np.asarray(afferent.values, dtype=float)
    if values.ndim != 2 or values.shape[0] == 0:
        return 0
    return int(np.argmax(np.nansum(values, axis=1)))


def compare_profiles(predicted: AfferentCurrent | ArrayLike, observed: ObservedProfile | tuple | ArrayLike, *, normalise: Normalise = "both", time_index: int = -1,
                     positions: ArrayLike | None=None, on_outside: OnOutside = "raise") -> ProfileFit:
    """Compare a predicted afferent profile with a recorded one (:ref:`method-comparison`).

    The prediction's profile is taken at one time step: ``time_index`` (default -1, the last
    step, e.g. the end of the indentation or hold). The observation is interpolated onto
    the afferent positions (:func:`observed_on`), then each profile chosen by ``normalise``
    is min-max normalised, and :func:`r2_study`, :func:`r2` and :func:`ssd` are computed
    with the observation as ``d`` and the prediction as ``e``.

    With ``normalise='both'`` or ``'prediction'`` the prediction's scale (alpha) cancels
    out: only its shape is compared.

    Parameters
    ----------
    predicted : AfferentCurrent or array_like of shape (n_afferents,)
        Predicted afferent currents in A. An AfferentCurrent supplies its positions (m) and
        its time series; a plain 1-D array needs ``positions`` unless ``observed`` is an
        array of the same length.
    observed : ObservedProfile, tuple (positions_m, response) or array_like of shape (n_afferents,)
        The recording. A 1-D array is taken as already on the afferent positions.
    normalise : {'both', 'prediction', 'observation', 'neither'}, default='both'
        Which profiles to min-max normalise before comparing (the study: both).
    time_index : int, default=-1
        Time step of an AfferentCurrent to compare (Python indexing).
    positions : array_like of shape (n_afferents,), optional
        Afferent positions in m for a plain-array prediction.
    on_outside : {'raise', 'drop'}, default='raise'
        Afferents outside the observed range: raise, or leave them out of the comparison
        (the number left out is in ``ProfileFit.dropped``).

    Returns
    -------
    ProfileFit

    Raises
    ------
    TypeError
        If ``predicted`` or ``observed`` has an unsupported type.
    ValueError
        If lengths disagree, positions are missing, afferents lie outside the observed
        range with ``on_outside='raise'``, fewer than 2 points remain, or the normalised
        observation is all zeros (``r2_study`` undefined).

    Warns
    -----
    AfferentWarning
        If a normalised profile is constant or nearly so (see :func:`minmax_normalise`).

    Examples
    --------
    >>> fit = compare_profiles([1.0, 3.0, 2.0], ([0.0, 2e-3], [0.0, 4.0]), positions=[0.0, 1e-3, 2e-3])
    >>> round(fit.ssd, 6)
    0.5
    """
    check_option("normalise", normalise, _NORMALISE)
    check_option("on_outside", on_outside, ("raise", "drop"))
    t_idx = time = None
    if hasattr(predicted, "values") and hasattr(predicted, "positions") and not isinstance(predicted, np.ndarray):
        from .synthesis import _check_time_index

        values = _finite("predicted", predicted.values, ndim=2)
        t_idx = _check_time_index(time_index, values.shape[0])
        pred = values[t_idx]
        times = getattr(predicted, "times", None)
        time = None if times is None else float(np.asarray(times)[t_idx])
        if positions is not None:
            raise ValueError("'positions' must only be given with a plain-array prediction; the AfferentCurrent has its own.")
        pos = _finite("positions", predicted.positions, ndim=1)
    else:
        pred = _finite("predicted", predicted, ndim=1)
        pos = None if positions is None else _finite("positions", positions, ndim=1)
    if pos is not None and pos.shape != pred.shape:
        raise ValueError(f"'positions' must have one entry per afferent ({pred.size}); got shape {pos.shape} instead.")
    dropped = 0
    if isinstance(observed, (ObservedProfile, tuple)):
        if pos is None:
            raise ValueError(
                "'positions' (m) are needed to interpolate the observed profile onto a plain-array prediction; "
                "got positions=None."
            )
        obs = observed_on(pos, observed, on_outside="raise" if on_outside == "raise" else "nan",
                          _remedy="on_outside='drop'")  # compare_profiles' own keyword (calibrate --on-outside drop)
        keep = np.isfinite(obs)
        dropped = int((~keep).sum())
        pred, obs, pos = pred[keep], obs[keep], pos[keep]
    else:
        obs = _finite("observed", observed, ndim=1)
        if obs.shape != pred.shape:
            raise ValueError(
                f"'observed' as an array must have one entry per afferent ({pred.size}); got shape {obs.shape} instead."
            )
    if pred.size < 2:
        raise ValueError(f"A profile comparison needs at least 2 afferents; got {pred.size} instead.")
    e = minmax_normalise(pred) if normalise in ("both", "prediction") else pred
    d = minmax_normalise(obs) if normalise in ("both", "observation") else obs
    if not np.any(d):
        raise ValueError(
            "The observed profile (as compared) is all zeros, so r2_study is undefined; "
            "a constant recording carries no shape."
        )
    # Copies: never change the flags of (or keep a reference to) the caller's arrays.
    e, d = np.array(e, copy=True), np.array(d, copy=True)
    pos = None if pos is None else np.array(pos, copy=True)
    for arr in (e, d) + ((pos,) if pos is not None else ()):
        arr.setflags(write=False)
    return ProfileFit(
        r2_study=r2_study(d, e), r2=r2(d, e), ssd=ssd(d, e), predicted=e, observed=d, positions=pos,
        normalise=normalise, time_index=t_idx, time=time, dropped=dropped, variation=(_variation(pred), _variation(obs)),
    )


#: A min-max normalised profile varying by less than this fraction (of its largest magnitude) before normalising
#: is stretched from a few-% ripple to 0..1, and R^2 with it: :func:`stretched` names it, the fit figure and the
#: run say so.
SMALL_VARIATION = 0.1


def stretched(fit: ProfileFit) -> dict[str, float]:
    """The min-max normalised profiles of ``fit`` that varied by less than :data:`SMALL_VARIATION` before
    normalising: ``{'predicted' | 'observed': variation}`` (dimensionless), empty when none did."""
    if fit.variation is None or fit.normalise == "neither":
        return {}
    which = {"both": (0, 1), "prediction": (0,), "observation": (1,)}[fit.normalise]
    names = ("predicted", "observed")
    return {names[i]: fit.variation[i] for i in which if fit.variation[i] < SMALL_VARIATION}


def _variation(v) -> float:
    """``(max - min) / max |v|`` of a profile (dimensionless; 0 for an all-zero one)."""
    top = float(np.max(np.abs(v)))
    return float(np.ptp(v)) / top if top > 0 else 0.0
