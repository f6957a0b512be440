"""Spikes grouped by afferent in time order (numpy, or numba when installed), shared by every engine."""

from __future__ import annotations

import numpy as np


def _group_by_col(steps, cols, out, counts):
    """Counting sort of spikes by column, keeping time order (plain Python, run by numba).

    Fills ``out`` (steps grouped by column) and ``counts`` (zeroed, one per column); both are
    allocated by the caller so that Python's memory tools see them.
    """
    n = counts.shape[0]
    for k in range(cols.shape[0]):
        counts[cols[k]] += 1
    start = np.empty(n, np.int64)
    acc = 0
    for j in range(n):
        start[j] = acc
        acc += counts[j]
    for k in range(cols.shape[0]):
        c = cols[k]
        out[start[c]] = steps[k]
        start[c] += 1


_NUMBA_LOOP = None
_NUMBA_GROUP = None


def _numba_available() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True



def _numba_group():
    global _NUMBA_GROUP
    if _NUMBA_GROUP is None:
        import numba

        _NUMBA_GROUP = numba.njit(cache=True, nogil=True)(_group_by_col)
    return _NUMBA_GROUP


def _group_numpy(steps: np.ndarray, cols: np.ndarray, n: int):
    """Spikes grouped by column in time order: (steps sorted by column, count per column)."""
    # numpy's stable sort is a radix sort for 16-bit keys: O(n), several times faster than on int64
    order = np.argsort(cols.astype(np.uint16) if n <= 2**16 else cols, kind="stable")
    return steps[order], np.bincount(cols, minlength=n).astype(np.int64)

