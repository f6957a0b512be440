"""Stage 4, synthesis: receptor currents -> afferent currents (:ref:`method-synthesis`).

::

    ReceptorCurrent --synthesize(current, branching)--> AfferentCurrent --simulate_lif--> spikes

Input: a :class:`~afferent.transduction.ReceptorCurrent` (any object with ``values`` of shape
(n_times, n_receptors) in A, ``times`` in s and ``layout``) or a plain ndarray of shape
(n_times, n_receptors) in A, and a :class:`Branching` saying which receptors feed which afferent.
Output: an :class:`AfferentCurrent`, values of shape (n_times, n_afferents) in A.

The receptors of one afferent act as parallel current sources, so

    I_A = sum_i w_i I_i        over the receptors i of afferent A (w_i = 1 in the study).

The study compares two groupings: longitudinal sections (receptors on one line parallel to
the ridges, i.e. same x; profile against x) and cross-sections (same z; profile against z).

Size: about 680 lines (280 of them docstrings), kept whole: one stage with one data model,
the four branching kinds of :class:`Branching` (and :func:`make_branching`, which picks one by its
spelling) and the :class:`AfferentCurrent` that :func:`synthesize` builds from it.
"""

from __future__ import annotations

from .receptors._layout import ReceptorLayout
from .transduction import ReceptorCurrent

from ._typing import ArrayLike, PathLike, RngLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

import numbers
import os
import warnings
from dataclasses import dataclass

import numpy as np

from ._csr import CSRWeights, as_csr
from ._validation import check_option, check_rng
from ._validation import plain as _plain
from .exceptions import AfferentWarning, SEDFormatError
from .receptors._layout import label_means
from .transduction import _check_values_times

__all__ = ["Branching", "AfferentCurrent", "synthesize", "make_branching", "parse_synthesis", "SYNTHESES"]

_KINDS = ("longitudinal", "cross", "map", "random")
_AXES = ("x", "z")
_AXIS_INDEX = {"x": 0, "z": 2}


def _preview(items, k: int = 5) -> str:
    items = list(items)
    shown = ", ".join(repr(str(i)) for i in items[:k])
    return shown + (", ..." if len(items) > k else "")


@dataclass(frozen=True)
class Branching:
    """Which receptors feed which afferent, and with what weight.

    Use the constructors :meth:`longitudinal`, :meth:`cross`, :meth:`from_map` and
    :meth:`random` rather than building the matrix by hand.

    Parameters
    ----------
    weights : scipy.sparse array, CSRWeights or array_like of shape (n_afferents, n_receptors)
        Dimensionless weight of receptor j in afferent i (1 in the study; 0 = not connected);
        finite and >= 0. Stored as a read-only ``afferent._csr.CSRWeights`` of float64: scipy's
        CSR arrays ``data``, ``indices``, ``indptr`` and ``shape`` in numpy, ``weights @ x``
        bit for bit scipy's, ``weights.to_scipy()`` a ``scipy.sparse.csr_array``, ``weights.toarray()``.
    positions : array_like of shape (n_afferents,)
        Coordinate of each afferent along ``axis`` in m, used to plot and compare profiles:
        for ``'longitudinal'`` the section's x, for ``'cross'`` the section's z, for
        ``'map'`` and ``'random'`` the (unweighted) mean coordinate of its receptors along
        ``axis`` (x unless asked otherwise).
    axis : {'x', 'z'}
        The coordinate ``positions`` is measured along.
    kind : {'longitudinal', 'cross', 'map', 'random'}
        How the grouping was made.
    afferent_ids : array_like of shape (n_afferents,) of str
        Unique afferent names (``'L<section>'``, ``'C<section>'``, the map's names, ``'R<k>'``).
    receptor_ids : array_like of shape (n_receptors,) of str, optional
        Receptor ids in column order (the layout's ``ids``); when given, :func:`synthesize`
        checks that the current's layout lists the same receptors in the same order.

    Raises
    ------
    ValueError
        If shapes disagree, weights are negative or non-finite, ids repeat, or ``axis`` /
        ``kind`` is not one of the allowed values.
    """

    weights: CSRWeights
    positions: np.ndarray
    axis: str
    kind: str
    afferent_ids: np.ndarray
    receptor_ids: np.ndarray | None = None

    def __post_init__(self):
        check_option("axis", self.axis, _AXES)
        check_option("kind", self.kind, _KINDS)
        w = as_csr(self.weights)  # repeated positions summed, columns sorted
        if not np.all(np.isfinite(w.data)) or np.any(w.data < 0):
            bad = np.flatnonzero(~np.isfinite(w.data) | (w.data < 0))[0]
            row = int(np.searchsorted(w.indptr, bad, side="right") - 1)
            raise ValueError(
                f"'weights' must be finite and >= 0 (dimensionless); got {float(w.data[bad])!r} for afferent {row}, "
                f"receptor {int(w.indices[bad])} instead."
            )
        w = w.eliminate_zeros()
        n_aff, n_rec = w.shape
        pos = np.array(self.positions, dtype=np.float64, copy=True)
        if pos.shape != (n_aff,) or not np.all(np.isfinite(pos)):
            raise ValueError(
                f"'positions' must be finite, of shape (n_afferents,) = ({n_aff},), in m; "
                f"got shape {pos.shape} instead."
            )
        ids = np.asarray(self.afferent_ids).astype(str)
        if ids.shape != (n_aff,):
            raise ValueError(f"'afferent_ids' must have one entry per afferent ({n_aff}); got shape {ids.shape} instead.")
        if len(set(ids.tolist())) != n_aff:
            dup = next(i for i in ids.tolist() if (ids == i).sum() > 1)
            raise ValueError(f"Afferent ids must be unique; got {dup!r} more than once.")
        rids = None
        if self.receptor_ids is not None:
            rids = np.asarray(self.receptor_ids).astype(str)
            if rids.shape != (n_rec,):
                raise ValueError(
                    f"'receptor_ids' must have one entry per receptor column ({n_rec}); got shape {rids.shape} instead."
                )
            rids.setflags(write=False)
        for arr in (pos, ids):  # w's arrays are read-only already
            arr.setflags(write=False)
        for name, value in (("weights", w), ("positions", pos), ("afferent_ids", ids), ("receptor_ids", rids)):
            object.__setattr__(self, name, value)

    # ----------------------------------------------------------------- constructors
    @classmethod
    def _from_labels(cls, layout, labels, *, kind: str, axis: str, prefix: str) -> "Branching":
        pos_all = layout.positions[:, _AXIS_INDEX[axis]]
        uniq, inverse = np.unique(np.asarray(labels), return_inverse=True)
        centres = label_means(inverse, pos_all)
        order = np.argsort(centres, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        n = layout.n_receptors
        w = CSRWeights.from_coo(np.ones(n), rank[inverse], np.arange(n), (uniq.size, n))
        ids = np.array([f"{prefix}{u}" for u in uniq[order]])
        return cls(w, centres[order], axis, kind, ids, layout.ids)

    @classmethod
    def longitudinal(cls, layout: ReceptorLayout) -> "Branching":
        """One afferent per longitudinal section: receptors on a line parallel to the ridges.

        Each receptor belongs to exactly one afferent (a partition; weight 1), so the summed
        current is conserved.

        Parameters
        ----------
        layout : ReceptorLayout
            Receptor sites; its ``longitudinal`` labels define the sections.

        Returns
        -------
        Branching
            ``kind='longitudinal'``, ``axis='x'``; afferents ordered by increasing x, named
            ``'L<section label>'``; ``positions`` the mean x of each section in m.

        Examples
        --------
        >>> import numpy as np
        >>> from afferent.receptors import ReceptorLayout
        >>> xyz = np.array([[0, 0, 0], [0, 0, 2e-4], [4e-4, 0, 0], [4e-4, 0, 2e-4]])
        >>> Branching.longitudinal(ReceptorLayout(xyz)).afferent_ids.tolist()
        ['L0', 'L1']
        """
        layout = _check_layout(layout)
        return cls._from_labels(layout, layout.longitudinal, kind="longitudinal", axis="x", prefix="L")

    @classmethod
    def cross(cls, layout: ReceptorLayout) -> "Branching":
        """One afferent per cross-section: receptors on a line across the ridges (same z).

        A partition with weight 1, like :meth:`longitudinal`.

        Parameters
        ----------
        layout : ReceptorLayout
            Receptor sites; its ``cross`` labels define the sections.

        Returns
        -------
        Branching
            ``kind='cross'``, ``axis='z'``; afferents ordered by increasing z, named
            ``'C<section label>'``; ``positions`` the mean z of each section in m.
        """
        layout = _check_layout(layout)
        return cls._from_labels(layout, layout.cross, kind="cross", axis="z", prefix="C")

    @classmethod
    def from_map(cls, source: PathLike | DataFrame, layout: ReceptorLayout, *, axis: str = "x") -> "Branching":
        """Branching from an explicit receptor -> afferent table.

        Parameters
        ----------
        source : str, path-like or pandas.DataFrame
            A CSV file (comma, semicolon, tab or whitespace separated; ``#`` comments allowed)
            or a DataFrame with columns ``receptor`` and ``afferent`` and optionally
            ``weight`` (dimensionless, >= 0, default 1); column names are case-insensitive.
            One row per connection; a receptor may appear under several afferents (shared),
            but a (receptor, afferent) pair only once.
        layout : ReceptorLayout
            Receptor sites; ``receptor`` entries are matched to ``layout.ids`` as strings.
        axis : {'x', 'z'}, default='x'
            Coordinate for the afferents' ``positions``: the mean of their receptors' x (or z), in m.

        Returns
        -------
        Branching
            ``kind='map'``; afferents ordered by position, named as in the map.

        Raises
        ------
        FileNotFoundError
            If ``source`` is a path that does not exist.
        SEDFormatError
            If the file cannot be parsed or lacks the ``receptor`` / ``afferent`` columns.
        ValueError
            If a receptor id is not in the layout (the message names them), a pair repeats
            or a weight is negative or not a number.

        Warns
        -----
        AfferentWarning
            If some receptors of the layout are not in the map (they feed no afferent);
            the message counts and names them. See also :attr:`unassigned`.
        """
        import pandas as pd

        layout = _check_layout(layout)
        check_option("axis", axis, _AXES)
        if isinstance(source, pd.DataFrame):
            df, where = source, "Branching map"
        else:
            from ._tables import read_table

            path = os.fspath(source)
            where = f"Branching map {path!r}"
            df, _ = read_table(path, what="Branching map file", expected="receptor, afferent[, weight]", as_text=True)
        cols = {str(c).strip().lower(): c for c in df.columns}
        missing = [c for c in ("receptor", "afferent") if c not in cols]
        if missing:
            found = ", ".join(repr(str(c)) for c in df.columns) or "none"
            err_type = SEDFormatError if not isinstance(source, pd.DataFrame) else ValueError
            raise err_type(
                f"{where} must have columns 'receptor' and 'afferent'; missing "
                f"{', '.join(map(repr, missing))}. Found columns {found}."
            )
        rec = df[cols["receptor"]].astype(str).str.strip().to_numpy()
        aff = df[cols["afferent"]].astype(str).str.strip().to_numpy()
        if "weight" in cols:
            wcol = pd.to_numeric(df[cols["weight"]], errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(wcol) | (wcol < 0)
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                raise ValueError(
                    f"{where}: 'weight' must be a finite number >= 0 (dimensionless); "
                    f"got {_plain(df[cols['weight']].iloc[row])!r} on data row {row + 1} instead."
                )
        else:
            wcol = np.ones(len(df))
        index = {rid: j for j, rid in enumerate(layout.ids.tolist())}
        unknown = [r for r in dict.fromkeys(rec.tolist()) if r not in index]
        if unknown:
            raise ValueError(
                f"{where}: {len(unknown)} receptor id(s) are not in the layout: {_preview(unknown)}. "
                f"Layout ids are {_preview(layout.ids.tolist(), 3)}."
            )
        if len(rec) == 0:
            raise ValueError(f"{where} must list at least one receptor -> afferent connection; got none.")
        pairs = list(zip(rec.tolist(), aff.tolist()))
        if len(set(pairs)) != len(pairs):
            seen = set()
            dup = next(p for p in pairs if p in seen or seen.add(p))
            raise ValueError(f"{where}: receptor {dup[0]!r} is listed twice for afferent {dup[1]!r}.")
        names, rows = np.unique(aff, return_inverse=True)
        first_seen = {}
        for k, a in enumerate(aff.tolist()):
            first_seen.setdefault(a, k)
        cols_idx = np.array([index[r] for r in rec.tolist()], dtype=np.int64)
        pos_all = layout.positions[:, _AXIS_INDEX[axis]]
        centres = label_means(rows, pos_all[cols_idx])
        # Order by position; ties keep the map's order of first appearance.
        order = np.lexsort((np.array([first_seen[n] for n in names]), centres))
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        w = CSRWeights.from_coo(wcol, rank[rows], cols_idx, (names.size, layout.n_receptors))
        out = cls(w, centres[order], axis, "map", names[order], layout.ids)
        unassigned = out.unassigned
        if unassigned.size:
            warnings.warn(
                f"{unassigned.size} of {layout.n_receptors} receptors are not in the branching map and feed no "
                f"afferent: {_preview(layout.ids[unassigned].tolist())}.",
                AfferentWarning,
                stacklevel=2,
            )
        return out

    @classmethod
    def random(cls, layout: ReceptorLayout, receptors_per_afferent: int, rng: RngLike=None, *, n_afferents: int | None = None,
               axis: str = "x") -> "Branching":
        """Random compact receptive fields: each afferent takes the receptors nearest a random seed.

        Each afferent picks a distinct seed receptor at random and innervates the
        ``receptors_per_afferent`` receptors nearest to it in the skin plane (distance in
        x and z; the seed itself included), with weight 1. An RA-I afferent branches to a
        cluster of neighbouring Meissner corpuscles, so its receptive field is a compact
        patch; neighbouring fields overlap, and a corpuscle can be innervated by more than
        one afferent (Meissner corpuscles are multi-afferented: Paré et al. 2001, J. Neurosci. 21:7236). Hence
        **a receptor may be shared** by several afferents, and a receptor may belong to
        none: this grouping is not a partition and does not conserve the summed current.
        The human fingertip range is 9-17 receptors per afferent (:ref:`method-synthesis`).

        Parameters
        ----------
        layout : ReceptorLayout
            Receptor sites.
        receptors_per_afferent : int
            Receptors per afferent, 1 <= k <= n_receptors (9-17 in the human fingertip).
        rng : None, int or numpy.random.Generator, optional
            Source of randomness; an int seed makes the branching reproducible.
        n_afferents : int, optional
            Number of afferents, 1 <= n_afferents <= n_receptors. Default
            ``round(n_receptors / receptors_per_afferent)`` (at least 1): each receptor is
            innervated once on average.
        axis : {'x', 'z'}, default='x'
            Coordinate for ``positions``: the mean of each afferent's receptors' x (or z), in m.

        Returns
        -------
        Branching
            ``kind='random'``; afferents ordered by position, named ``'R0'``, ``'R1'``, ...
            in that order.

        Raises
        ------
        TypeError
            If ``receptors_per_afferent`` or ``n_afferents`` is not an int, or ``rng`` is invalid.
        ValueError
            If they are out of range.

        Examples
        --------
        >>> import numpy as np
        >>> from afferent.receptors import ReceptorLayout
        >>> g = np.stack(np.meshgrid(np.arange(6) * 4.4e-4, [0.0], np.arange(6) * 2.2e-4), -1).reshape(-1, 3)
        >>> b = Branching.random(ReceptorLayout(g), 9, rng=0)
        >>> b.n_afferents, int(b.receptor_counts.min())
        (4, 9)
        """
        from scipy.spatial import cKDTree

        layout = _check_layout(layout)
        check_option("axis", axis, _AXES)
        n = layout.n_receptors
        k = _check_count("receptors_per_afferent", receptors_per_afferent, n)
        n_aff = max(1, int(round(n / k))) if n_afferents is None else _check_count("n_afferents", n_afferents, n)
        gen = check_rng(rng)
        seeds = gen.choice(n, size=n_aff, replace=False)
        plane = layout.positions[:, [0, 2]]
        _, members = cKDTree(plane).query(plane[seeds], k=k)
        members = np.asarray(members, dtype=np.int64).reshape(n_aff, k)
        centres = layout.positions[members, _AXIS_INDEX[axis]].mean(axis=1)
        order = np.argsort(centres, kind="stable")
        members, centres = members[order], centres[order]
        rows = np.repeat(np.arange(n_aff), k)
        w = CSRWeights.from_coo(np.ones(n_aff * k), rows, members.ravel(), (n_aff, n))
        ids = np.array([f"R{i}" for i in range(n_aff)])
        return cls(w, centres, axis, "random", ids, layout.ids)

    # ----------------------------------------------------------------- properties
    @property
    def n_afferents(self) -> int:
        """Number of afferents (rows of ``weights``)."""
        return self.weights.shape[0]

    @property
    def n_receptors(self) -> int:
        """Number of receptors (columns of ``weights``)."""
        return self.weights.shape[1]

    @property
    def receptor_counts(self) -> np.ndarray:
        """Receptors per afferent, ndarray of shape (n_afferents,), int."""
        return np.diff(self.weights.indptr)

    @property
    def afferent_counts(self) -> np.ndarray:
        """Afferents per receptor, ndarray of shape (n_receptors,), int (0 = unassigned, > 1 = shared)."""
        return np.bincount(self.weights.indices, minlength=self.n_receptors)

    @property
    def unassigned(self) -> np.ndarray:
        """Indices of receptors that feed no afferent, ndarray of int."""
        return np.flatnonzero(self.afferent_counts == 0)

    @property
    def is_partition(self) -> bool:
        """True if every receptor feeds exactly one afferent with weight 1 (the summed current is conserved)."""
        return bool(np.all(self.afferent_counts == 1) and np.all(self.weights.data == 1.0))

    def to_dataframe(self) -> DataFrame:
        """Long table of connections with columns ``afferent``, ``receptor``, ``weight``.

        ``receptor`` holds the receptor ids (or column indices as strings when the
        branching has no ``receptor_ids``); the table can be passed back to :meth:`from_map`.
        """
        import pandas as pd

        w = self.weights
        rids = self.receptor_ids if self.receptor_ids is not None else np.arange(self.n_receptors).astype(str)
        return pd.DataFrame(
            {"afferent": np.repeat(self.afferent_ids, np.diff(w.indptr)), "receptor": rids[w.indices], "weight": w.data}
        )

    def __repr__(self) -> str:
        counts = self.receptor_counts
        span = f"{counts.min()}-{counts.max()}" if counts.size else "0"
        return (
            f"<Branching {self.kind!r}: {self.n_afferents} afferents x {self.n_receptors} receptors, "
            f"{span} receptors per afferent, positions along {self.axis}>"
        )


#: The spellings of a synthesis (:func:`make_branching`).
SYNTHESES = ("longitudinal", "cross", "map:FILE", "random:N")


def parse_synthesis(spec: str) -> tuple[str, int | None]:
    """Split a synthesis spelling into its kind and, for ``'random:N'``, N.

    Parameters
    ----------
    spec : str
        ``'longitudinal'``, ``'cross'``, ``'map:FILE'`` or ``'random:N'``.

    Returns
    -------
    (str, int or None)
        The kind (``'longitudinal'``, ``'cross'``, ``'map'``, ``'random'``) and N (None but for random).

    Raises
    ------
    ValueError
        An unknown kind, or N not a whole number.
    """
    kind, _, arg = str(spec).partition(":")
    check_option("synthesis", kind if not arg else f"{kind}:", ("longitudinal", "cross", "map:", "random:"))
    if kind != "random":
        return kind, None
    try:
        return kind, int(arg)
    except ValueError as err:
        raise ValueError(f"'synthesis' random:N needs a whole number of receptors per afferent; got {arg!r} instead.") from err


def make_branching(spec: str | Branching, layout: ReceptorLayout, *, rng: RngLike=None) -> Branching:
    """A :class:`Branching` from its spelling in a scene or on the command line.

    Parameters
    ----------
    spec : str or Branching
        ``'longitudinal'`` (sections parallel to the ridges, profile vs x), ``'cross'``
        (sections across the ridges, profile vs z), ``'map:FILE'`` (CSV receptor,
        afferent[,weight]) or ``'random:N'`` (N receptors per afferent, seeded by ``rng``).
    layout : ReceptorLayout
    rng : None, int or numpy.random.Generator
        Seed for ``'random:N'``.
    """
    if isinstance(spec, Branching):
        return spec
    kind, n = parse_synthesis(spec)
    if kind == "longitudinal":
        return Branching.longitudinal(layout)
    if kind == "cross":
        return Branching.cross(layout)
    if kind == "map":
        return Branching.from_map(str(spec).partition(":")[2], layout)
    return Branching.random(layout, n, rng=rng)


def _check_layout(layout):
    if not (hasattr(layout, "positions") and hasattr(layout, "ids") and hasattr(layout, "n_receptors")):
        raise TypeError(f"'layout' must be a ReceptorLayout; got {type(layout).__name__} instead.")
    return layout


def _check_count(name: str, value, n: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name!r} must be an int; got {_plain(value)!r} instead.")
    if not 1 <= value <= n:
        raise ValueError(f"{name!r} must be between 1 and the number of receptors ({n}); got {_plain(value)!r} instead.")
    return int(value)


@dataclass(frozen=True)
class AfferentCurrent:
    """Current of every afferent at every time: the output of :func:`synthesize`.

    Parameters
    ----------
    values : ndarray of shape (n_times, n_afferents)
        Afferent current in A.
    times : ndarray of shape (n_times,) or None
        Time of each row in s; ``None`` when unknown (plain-array input without times).
    positions : ndarray of shape (n_afferents,)
        Afferent coordinate along ``axis`` in m (see :class:`Branching`).
    afferent_ids : ndarray of shape (n_afferents,) of str
        Afferent names.
    kind : {'longitudinal', 'cross', 'map', 'random'}
        The branching that produced the current.
    axis : {'x', 'z'}, default='x'
        The coordinate ``positions`` is measured along.

    Notes
    -----
    Arrays are read-only. ``np.asarray(current)`` gives ``values``.
    """

    values: np.ndarray
    times: np.ndarray | None
    positions: np.ndarray
    afferent_ids: np.ndarray
    kind: str
    axis: str = "x"

    def __post_init__(self):
        values, times = _check_values_times(self.values, self.times, what="values", unit="A", cols="n_afferents")
        n_aff = values.shape[1]
        pos = np.array(self.positions, dtype=np.float64, copy=True)
        if pos.shape != (n_aff,) or not np.all(np.isfinite(pos)):
            raise ValueError(
                f"'positions' must be finite, of shape (n_afferents,) = ({n_aff},), in m; got shape {pos.shape} instead."
            )
        ids = np.asarray(self.afferent_ids).astype(str)
        if ids.shape != (n_aff,):
            raise ValueError(f"'afferent_ids' must have one entry per afferent ({n_aff}); got shape {ids.shape} instead.")
        check_option("kind", self.kind, _KINDS)
        check_option("axis", self.axis, _AXES)
        pos.setflags(write=False)
        ids.setflags(write=False)
        for name, value in (("values", values), ("times", times), ("positions", pos), ("afferent_ids", ids)):
            object.__setattr__(self, name, value)

    @property
    def n_times(self) -> int:
        """Number of time steps."""
        return self.values.shape[0]

    @property
    def n_afferents(self) -> int:
        """Number of afferents."""
        return self.values.shape[1]

    def profile(self, time_index: int = -1) -> np.ndarray:
        """Currents of all afferents at one time step, ndarray of shape (n_afferents,) in A.

        ``time_index`` follows Python indexing; the default -1 is the last step.
        """
        return self.values[_check_time_index(time_index, self.n_times)]

    def __array__(self, dtype=None, copy=None):
        if copy:
            return np.array(self.values, dtype=dtype, copy=True)
        return np.asarray(self.values, dtype=dtype)

    def to_dataframe(self) -> DataFrame:
        """Long table with columns ``afferent``, ``position_m``, ``step``, ``time_s``, ``current_a``.

        One row per (time step, afferent), time-major. ``step`` is the row index of
        ``values``; ``time_s`` is NaN when ``times`` is ``None``.
        """
        import pandas as pd

        n_t, n_a = self.values.shape
        times = self.times if self.times is not None else np.full(n_t, np.nan)
        return pd.DataFrame(
            {
                "afferent": np.tile(self.afferent_ids, n_t),
                "position_m": np.tile(self.positions, n_t),
                "step": np.repeat(np.arange(n_t), n_a),
                "time_s": np.repeat(times, n_a),
                "current_a": self.values.ravel(),
            }
        )

    def __repr__(self) -> str:
        t = "no times" if self.times is None else f"t [{self.times[0]:g}..{self.times[-1]:g}] s"
        return (
            f"<AfferentCurrent {self.kind!r}: {self.n_times} time step(s) x {self.n_afferents} afferents, {t}, "
            f"I in [{self.values.min():.4g}, {self.values.max():.4g}] A>"
        )


def _check_time_index(time_index, n_times: int) -> int:
    if isinstance(time_index, bool) or not isinstance(time_index, numbers.Integral):
        raise TypeError(f"'time_index' must be an int; got {_plain(time_index)!r} instead.")
    if not -n_times <= time_index < n_times:
        raise ValueError(
            f"'time_index' must be in [{-n_times}, {n_times - 1}] for {n_times} time step(s); "
            f"got {_plain(time_index)!r} instead."
        )
    return int(time_index)


def synthesize(current: ReceptorCurrent | ArrayLike, branching: Branching) -> AfferentCurrent:
    """Sum receptor currents into afferent currents: ``I_A = sum_i w_i I_i``.

    Parameters
    ----------
    current : ReceptorCurrent or array_like of shape (n_times, n_receptors)
        Receptor currents in A. A ReceptorCurrent (any object with ``values``, ``times``
        and ``layout``) passes its times on, and its layout's receptor ids are checked
        against ``branching.receptor_ids``.
    branching : Branching
        Receptor -> afferent weights (dimensionless), built from the same layout.

    Returns
    -------
    AfferentCurrent
        Values of shape (n_times, n_afferents) in A, with the branching's positions, ids,
        kind and axis.

    Raises
    ------
    TypeError
        If ``branching`` is not a :class:`Branching`.
    ValueError
        If the current is not 2-D and finite, its number of receptors differs from the
        branching's, or its receptor ids differ (in value or order) from the branching's.

    See Also
    --------
    afferent.transduction.transduce : the previous stage.
    afferent.profiles.compare_profiles : compare a profile with recordings.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> xyz = np.array([[0, 0, 0], [0, 0, 2e-4], [4e-4, 0, 0], [4e-4, 0, 2e-4]])
    >>> b = Branching.longitudinal(ReceptorLayout(xyz))
    >>> synthesize(np.array([[1.0, 2.0, 3.0, 4.0]]) * 1e-9, b).values * 1e9
    array([[3., 7.]])
    """
    if not isinstance(branching, Branching):
        raise TypeError(f"'branching' must be a Branching; got {type(branching).__name__} instead.")
    layout = None
    times = None
    values = current
    if hasattr(current, "values") and hasattr(current, "times") and not isinstance(current, np.ndarray):
        values, times, layout = current.values, current.times, getattr(current, "layout", None)
    values, times = _check_values_times(values, times, what="current", unit="A", cols="n_receptors")
    if values.shape[1] != branching.n_receptors:
        raise ValueError(
            f"'current' must have one column per receptor of the branching (n_receptors = "
            f"{branching.n_receptors}); got shape {values.shape} instead."
        )
    if layout is not None and branching.receptor_ids is not None and hasattr(layout, "ids"):
        ids = np.asarray(layout.ids).astype(str)
        if not np.array_equal(ids, branching.receptor_ids):
            j = int(np.flatnonzero(ids != branching.receptor_ids)[0])
            raise ValueError(
                f"The current's receptors must match the branching's, in order; receptor column {j} is "
                f"{str(ids[j])!r} in the current but {str(branching.receptor_ids[j])!r} in the branching. "
                "Build the Branching from the layout the SED was sampled on."
            )
    out = np.ascontiguousarray((branching.weights @ values.T).T)
    return AfferentCurrent(out, times, branching.positions, branching.afferent_ids, branching.kind, branching.axis)
