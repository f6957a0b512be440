"""Read-only compressed sparse row (CSR) weights in numpy: the receptor -> afferent matrix of a
:class:`~afferent.synthesis.Branching`, without importing scipy.

A spikes-only run synthesizes a few hundred receptors into a few afferents; importing
scipy.sparse for that cost 0.16 s of CPU, more than the rest of the run's numerical work
(docs/performance.md, "What a spikes-only scene imports"). :class:`CSRWeights` holds scipy's CSR arrays
(``data``, ``indices``, ``indptr``) and multiplies a dense array (``W @ x``) with the same
floating-point operations in the same order as scipy's ``csr_array @ x``: each row's sum
starts at 0 and adds ``data[k] * x[indices[k]]`` in column order, so results are bit for bit
scipy's. :meth:`CSRWeights.to_scipy` gives a ``scipy.sparse.csr_array`` for anything else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class CSRWeights:
    """A read-only sparse matrix of float64 weights in CSR form (scipy's layout).

    Row ``i`` holds ``data[indptr[i]:indptr[i + 1]]`` in the columns
    ``indices[indptr[i]:indptr[i + 1]]``, sorted, no column twice, no stored zero. Build it
    with :meth:`from_coo` or :func:`as_csr`.

    Attributes
    ----------
    data : ndarray of shape (nnz,), float64
    indices : ndarray of shape (nnz,), int64
    indptr : ndarray of shape (n_rows + 1,), int64
    shape : tuple of int
        (n_rows, n_cols).
    """

    data: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    shape: tuple

    ndim = 2

    @classmethod
    def from_coo(cls, data, rows, cols, shape) -> "CSRWeights":
        """Entries ``(rows[k], cols[k]) = data[k]`` (repeated positions summed, in the order given); zeros kept."""
        n_rows, n_cols = (int(n) for n in shape)
        data = np.asarray(data, dtype=np.float64).reshape(-1)
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        cols = np.asarray(cols, dtype=np.int64).reshape(-1)
        if not data.size == rows.size == cols.size:
            raise ValueError(f"data, rows and cols must have one entry each per weight; got {data.size}, "
                             f"{rows.size} and {cols.size}.")
        if data.size and (rows.min() < 0 or rows.max() >= n_rows or cols.min() < 0 or cols.max() >= n_cols):
            raise ValueError(f"weight positions must lie inside the shape {(n_rows, n_cols)}; got rows "
                             f"{rows.min()}..{rows.max()}, columns {cols.min()}..{cols.max()}.")
        order = np.lexsort((cols, rows))  # stable: repeated positions keep their order
        rows, cols, data = rows[order], cols[order], data[order]
        first = np.ones(data.size, dtype=bool)
        first[1:] = (rows[1:] != rows[:-1]) | (cols[1:] != cols[:-1])
        starts = np.flatnonzero(first)
        if starts.size < data.size:
            data = np.add.reduceat(data, starts)  # sums of repeated positions (scipy's sum_duplicates)
        rows, cols = rows[starts], cols[starts]
        indptr = np.zeros(n_rows + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=n_rows), out=indptr[1:])
        return cls._frozen(data, cols, indptr, (n_rows, n_cols))

    @classmethod
    def _frozen(cls, data, indices, indptr, shape) -> "CSRWeights":
        arrays = [np.array(a, dtype=dt, copy=True) for a, dt in ((data, np.float64), (indices, np.int64),
                                                                   (indptr, np.int64))]
        for a in arrays:
            a.setflags(write=False)
        return cls(*arrays, tuple(int(n) for n in shape))

    @property
    def nnz(self) -> int:
        """Number of stored weights."""
        return int(self.data.size)

    def eliminate_zeros(self) -> "CSRWeights":
        """The same matrix without stored zeros."""
        keep = self.data != 0
        if keep.all():
            return self
        row_of = np.repeat(np.arange(self.shape[0]), np.diff(self.indptr))
        indptr = np.concatenate([[0], np.cumsum(np.bincount(row_of[keep], minlength=self.shape[0]))])
        return self._frozen(self.data[keep], self.indices[keep], indptr, self.shape)

    def __matmul__(self, x) -> np.ndarray:
        """``W @ x`` for a dense ``x`` of shape (n_cols, ...): ndarray of shape (n_rows, ...), float64.

        Bit for bit scipy's ``csr_array @ x``: row i is ``0 + data[k0] * x[j0] + data[k1] * x[j1] + ...``
        summed left to right; one numpy operation per position in the rows (the longest row's length).
        """
        x = np.asarray(x)
        if x.ndim == 0 or x.shape[0] != self.shape[1]:
            raise ValueError(f"W @ x needs x of shape ({self.shape[1]}, ...); got shape {x.shape} instead.")
        out = np.zeros((self.shape[0],) + x.shape[1:], dtype=np.result_type(x.dtype, np.float64))
        lengths = np.diff(self.indptr)
        tail = (1,) * (x.ndim - 1)
        for p in range(int(lengths.max(initial=0))):
            rows = np.flatnonzero(lengths > p)
            k = self.indptr[rows] + p
            out[rows] += self.data[k].reshape(-1, *tail) * x[self.indices[k]]
        return out

    def toarray(self) -> np.ndarray:
        """The dense matrix, ndarray of shape ``shape``, float64."""
        out = np.zeros(self.shape)
        out[np.repeat(np.arange(self.shape[0]), np.diff(self.indptr)), self.indices] = self.data
        return out

    def to_scipy(self):
        """A ``scipy.sparse.csr_array`` copy (imports scipy)."""
        from scipy import sparse

        return sparse.csr_array((self.data.copy(), self.indices.copy(), self.indptr.copy()), shape=self.shape)

    def __repr__(self) -> str:
        return f"<CSRWeights {self.shape[0]} x {self.shape[1]}, {self.nnz} stored weights>"


def as_csr(weights) -> CSRWeights:
    """``weights`` as :class:`CSRWeights` (repeated positions summed, zeros kept): from a CSRWeights,
    a scipy sparse matrix or array (anything with ``tocoo``; scipy is not imported here) or a
    dense 2-D array_like.

    Raises
    ------
    ValueError
        If ``weights`` is not 2-D.
    """
    if isinstance(weights, CSRWeights):  # rebuilt: one made by hand may be unsorted or writable
        rows = np.repeat(np.arange(weights.shape[0]), np.diff(weights.indptr))
        return CSRWeights.from_coo(weights.data, rows, weights.indices, weights.shape)
    if hasattr(weights, "tocoo") and hasattr(weights, "shape"):
        if len(weights.shape) != 2:
            raise ValueError(f"'weights' must be a 2-D array of shape (n_afferents, n_receptors); "
                             f"got {len(weights.shape)}-D.")
        coo = weights.tocoo()
        return CSRWeights.from_coo(coo.data, coo.row, coo.col, weights.shape)
    dense = np.asarray(weights, dtype=np.float64)
    if dense.ndim != 2:
        raise ValueError(f"'weights' must be a 2-D array of shape (n_afferents, n_receptors); got {dense.ndim}-D.")
    rows, cols = np.nonzero(dense)
    return CSRWeights.from_coo(dense[rows, cols], rows, cols, dense.shape)
