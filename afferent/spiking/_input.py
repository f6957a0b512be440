"""Reading the current the LIF engines are given: values (A) per sample and afferent, sample times (s), afferent ids."""

from __future__ import annotations

import numpy as np

from .._validation import describe_array


def _as_current(current, times):
    """Split ``current`` into (values, times or None, afferent_ids or None).

    An object with ``values`` and ``times`` (an AfferentCurrent) brings its own times; when
    those are ``None`` (unknown) it is treated like an ndarray, and ``times`` may be passed.
    """
    if isinstance(current, np.ndarray) or not (hasattr(current, "values") and hasattr(current, "times")):
        return current, times, None
    own = current.times
    if times is not None and own is not None:
        raise ValueError(
            "Pass 'times' only with an ndarray current; the "
            f"{type(current).__name__} carries its own times. Got times={describe_array(times)} instead."
        )
    return current.values, (own if own is not None else times), getattr(current, "afferent_ids", None)


def _extremes(arr: np.ndarray) -> tuple:
    """(smallest, largest) value of each column; the two passes on two threads for a large
    array (numpy releases the GIL: 100 MB, 18 -> 10 ms wall on two cores)."""
    if arr.nbytes < 1 << 23 or arr.shape[0] == 0:
        return arr.min(axis=0), arr.max(axis=0)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(1) as pool:
        lo = pool.submit(np.min, arr, axis=0)
        hi = arr.max(axis=0)
        return lo.result(), hi


def _read_input(current, times):
    """Validated (values (n_times, n_afferents) float64, times (n_times,) or None, afferent ids,
    (smallest, largest) value of each afferent in A: one pass each, reused by the engines)."""
    values, times, ids = _as_current(current, times)
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"'current' must be a numeric array in A; got {type(values).__name__} instead.") from err
    if arr.ndim != 2:
        hint = " For one afferent pass current[:, None]." if arr.ndim == 1 else ""
        raise ValueError(
            f"'current' must be an array of shape (n_times, n_afferents) in A; got shape {arr.shape} instead.{hint}"
        )
    if arr.shape[0] == 0:
        raise ValueError(f"'current' must have at least one time step; got shape {arr.shape} instead.")
    # max/min propagate NaN and inf: a cheap, temporary-free test before locating any culprit
    extremes = _extremes(arr)
    if arr.size and not (np.isfinite(extremes[0]).all() and np.isfinite(extremes[1]).all()):
        bad = ~np.isfinite(arr)
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        kind = "NaN" if np.isnan(arr[first]) else "infinite"
        raise ValueError(
            f"'current' must be finite; got {int(bad.sum())} non-finite value(s) (first: {kind} at index {first}) "
            "instead."
        )
    n_times = arr.shape[0]
    t = None
    if times is not None:
        t = np.asarray(times, dtype=np.float64)
        if t.shape != (n_times,):
            raise ValueError(
                f"'times' must be an array of shape (n_times,) = ({n_times},) in s to match 'current'; "
                f"got shape {t.shape} instead."
            )
        if not np.all(np.isfinite(t)):
            raise ValueError("'times' must be finite; got non-finite values instead.")
        steps_back = np.flatnonzero(np.diff(t) <= 0)
        if steps_back.size:
            k = int(steps_back[0]) + 1
            raise ValueError(
                f"'times' must be strictly increasing in s; got times[{k}] = {float(t[k])!r} <= times[{k - 1}] = "
                f"{float(t[k - 1])!r} instead."
            )
    if ids is None:
        ids = np.arange(arr.shape[1])
    else:
        ids = np.asarray(ids)
        if ids.shape != (arr.shape[1],):
            raise ValueError(
                f"'afferent_ids' of the current must have shape (n_afferents,) = ({arr.shape[1]},); "
                f"got shape {ids.shape} instead."
            )
    return arr, t, ids, extremes

