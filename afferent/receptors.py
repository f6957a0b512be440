"""Receptor sites (RA-I Meissner corpuscles at dermal-papilla tips) and their sections.

::

    receptors CSV         --read_receptors-->  ReceptorLayout --sample_sed(field, layout)--> ReceptorSED
    ranges + pitches      --grid_layout----->  ReceptorLayout
    FE mesh + layer ids   --interface_tips-->  ReceptorLayout   (tips_from_export: from a file)

All positions are in m.

Axes follow the study: x runs across the fingerprint ridges, z along them, y is the thickness
direction (up, towards the skin surface).
A *longitudinal section* is a line of receptors parallel to the ridges (same x, varying z);
a *cross-section* is a line across them (same z, varying x).
"""

from __future__ import annotations

import numbers
import os
import warnings
from dataclasses import dataclass

import numpy as np

from ._validation import check_finite_array, check_positive, plain, suggest
from .exceptions import AfferentWarning, SEDFormatError
from .io._columns import canonical
from .units import length_factor

__all__ = [
    "ReceptorLayout",
    "central_line",
    "read_receptors",
    "group_coordinates",
    "grid_layout",
    "interface_nodes",
    "interface_tips",
    "tips_from_export",
]

#: Default tolerance (m) when grouping receptors into sections: coordinates closer than
#: this along the grouping axis fall into one section. 20 um is a tenth of the papilla
#: pitch (0.22 mm) and far above FE coordinate noise.
SECTION_TOLERANCE_M = 20e-6


def group_coordinates(values, tol: float = SECTION_TOLERANCE_M) -> tuple[np.ndarray, np.ndarray]:
    """Group 1-D coordinates that lie within ``tol`` of their neighbours (single linkage).

    Parameters
    ----------
    values : array_like of shape (n,)
        Coordinates in m.
    tol : float
        Largest gap in m inside one group.

    Returns
    -------
    labels : ndarray of shape (n,), int
        Group index of each value, numbered in increasing coordinate order from 0.
    centres : ndarray of shape (n_groups,)
        Mean coordinate of each group in m.

    Examples
    --------
    >>> labels, centres = group_coordinates([0.0, 1e-3, 1e-7, 1.0000001e-3])
    >>> labels.tolist()
    [0, 1, 0, 1]
    """
    values = np.asarray(values, dtype=float)
    tol = check_positive("tol", tol, unit="m")
    if values.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    order = np.argsort(values, kind="stable")
    gaps = np.diff(values[order]) > tol
    sorted_labels = np.concatenate([[0], np.cumsum(gaps)])
    labels = np.empty_like(sorted_labels)
    labels[order] = sorted_labels
    centres = np.bincount(labels, weights=values) / np.bincount(labels)
    return labels.astype(np.int64), centres


@dataclass(frozen=True)
class ReceptorLayout:
    """Positions of receptor sites and the sections they belong to.

    Parameters
    ----------
    positions : ndarray of shape (n_receptors, 3)
        Receptor coordinates in m.
    ids : ndarray of shape (n_receptors,) of str, optional
        Receptor names; default ``'0'``, ``'1'``, ...
    longitudinal : ndarray of shape (n_receptors,), int, optional
        Longitudinal-section index (lines parallel to the ridges, grouped by x); computed
        with :func:`group_coordinates` when not given.
    cross : ndarray of shape (n_receptors,), int, optional
        Cross-section index (lines across the ridges, grouped by z); computed when not given.
    tol : float, default=20e-6
        Grouping tolerance in m used when sections are computed.
    source : str, optional
        The receptor file the sites were read from (named in error messages), or None.
    """

    positions: np.ndarray
    ids: np.ndarray | None = None
    longitudinal: np.ndarray | None = None
    cross: np.ndarray | None = None
    tol: float = SECTION_TOLERANCE_M
    source: str | None = None

    def __post_init__(self):
        pos = check_finite_array("positions", self.positions, ndim=2, shape_doc="(n_receptors, 3) in metres")
        if pos.shape[1] != 3:
            raise ValueError(
                f"'positions' must be an array of shape (n_receptors, 3) in metres; got shape {pos.shape} instead."
            )
        n = pos.shape[0]
        ids = np.arange(n).astype(str) if self.ids is None else np.asarray(self.ids).astype(str)
        if ids.shape != (n,):
            raise ValueError(f"'ids' must have one entry per receptor ({n}); got shape {ids.shape} instead.")
        if len(set(ids.tolist())) != n:
            dup = next(i for i in ids.tolist() if (ids == i).sum() > 1)
            raise ValueError(f"Receptor ids must be unique; got {dup!r} more than once.")
        sections = {}
        for name, axis in (("longitudinal", 0), ("cross", 2)):
            given = getattr(self, name)
            if given is None:
                lab, _ = group_coordinates(pos[:, axis], self.tol)
            else:
                lab = np.asarray(given)
                if lab.shape != (n,) or not np.issubdtype(lab.dtype, np.integer):
                    raise ValueError(
                        f"'{name}' must be integer section labels of shape ({n},); got {lab.dtype} of shape {lab.shape} instead."
                    )
            sections[name] = lab.astype(np.int64)
        for name, arr in (("positions", pos), ("ids", ids), *sections.items()):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_receptors(self) -> int:
        """Number of receptor sites."""
        return self.positions.shape[0]

    def section_positions(self, kind: str) -> np.ndarray:
        """Mean coordinate (m) of each section: x for ``'longitudinal'``, z for ``'cross'``.

        Returns an ndarray of shape (max_label + 1,), indexed by section label; NaN for a
        label no receptor carries (after :meth:`subset`).
        """
        labels = self.longitudinal if kind == "longitudinal" else self.cross
        axis = 0 if kind == "longitudinal" else 2
        n = int(labels.max()) + 1 if labels.size else 0
        counts = np.bincount(labels, minlength=n)
        sums = np.bincount(labels, weights=self.positions[:, axis], minlength=n)
        with np.errstate(invalid="ignore"):
            return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)

    def subset(self, mask) -> "ReceptorLayout":
        """The layout restricted to ``mask`` (bool array or indices); section labels are kept."""
        idx = np.arange(self.n_receptors)[mask]
        return ReceptorLayout(
            self.positions[idx], self.ids[idx], self.longitudinal[idx], self.cross[idx], tol=self.tol, source=self.source
        )

    def __len__(self) -> int:
        return self.n_receptors

    def __repr__(self) -> str:
        return (
            f"<ReceptorLayout: {self.n_receptors} receptors, "
            f"{len(np.unique(self.longitudinal))} longitudinal sections, {len(np.unique(self.cross))} cross-sections>"
        )


#: Receptor-id columns, compared after :func:`afferent.io._columns.canonical` (case, spaces,
#: underscores, dots and dashes ignored): ``id``, ``receptor_id``, ``Receptor ID``, ``site``...
_ID_COLUMNS = ("id", "receptor", "receptorid", "receptorname", "receptorlabel", "name", "label", "site", "siteid",
               "rid", "meissner", "meissnerid", "corpuscle", "corpuscleid", "tip", "tipid")
_SECTION_COLUMNS = {"longitudinal": ("longitudinal", "longitudinal_section"), "cross": ("cross", "cross_section")}


def read_receptors(path, *, length_unit: str, tol: float = SECTION_TOLERANCE_M) -> ReceptorLayout:
    """Read receptor sites from a CSV with columns x, y, z (optional id and section labels).

    Parameters
    ----------
    path : str or path-like
        CSV file; comma, semicolon, tab or whitespace separated; ``#`` comment lines allowed.
        Column names are case-insensitive: ``x, y, z`` (required), a receptor id (optional:
        ``id``, ``receptor_id``, ``Receptor ID``, ``receptor``, ``name``, ``label``, ``site``,
        ... the first found), ``longitudinal`` / ``cross`` (optional integer section labels).
        Any other column is reported with an :class:`~afferent.exceptions.AfferentWarning`.
    length_unit : str
        Unit of x, y, z: ``'m'``, ``'mm'`` or ``'um'``. Required: never guessed.
    tol : float, default=20e-6
        Section-grouping tolerance in m.

    Returns
    -------
    ReceptorLayout

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SEDFormatError
        If the file is empty, lacks x/y/z, or holds non-numeric or non-finite coordinates.
    """

    from ._tables import numeric_columns, read_table

    path = os.fspath(path)
    factor = length_factor(length_unit)
    # as text, so that an error quotes a cell as written ('n/a', '')
    df, cols = read_table(path, what="Receptor file", expected="x, y, z (optional id, longitudinal, cross)", as_text=True)
    missing = [c for c in ("x", "y", "z") if c not in cols]
    if missing:
        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise SEDFormatError(
            f"Receptor file {path!r} must have columns 'x', 'y', 'z'; missing {', '.join(map(repr, missing))}. "
            f"Found columns {found}."
        )
    if len(df) == 0:
        raise SEDFormatError(f"Receptor file {path!r} has a header but no receptor rows.")
    xyz = numeric_columns(df, [cols["x"], cols["y"], cols["z"]], what="Receptor file", path=path)
    by_canonical = {canonical(c): df_col for c, df_col in cols.items()}
    id_col = next((by_canonical[c] for c in _ID_COLUMNS if c in by_canonical), None)  # first in the order above
    ids = df[id_col].astype(str).str.strip().to_numpy() if id_col is not None else None
    sections = {}
    used = {cols["x"], cols["y"], cols["z"], id_col}
    for name, aliases in _SECTION_COLUMNS.items():
        col = next((cols[c] for c in aliases if c in cols), None)
        if col is not None:
            labels = numeric_columns(df, [col], what="Receptor file", path=path)[:, 0]
            if not np.all(labels == np.round(labels)):
                k = int(np.flatnonzero(labels != np.round(labels))[0])
                raise SEDFormatError(
                    f"Receptor file {path!r}: column {str(col)!r} must hold whole-number section labels; got "
                    f"{labels[k]!r} on data row {k + 1} instead."
                )
            sections[name] = labels.astype(np.int64)
            used.add(col)
    ignored = [str(c) for c in df.columns if c not in used]
    if ignored:
        warnings.warn(
            f"Receptor file {path!r}: column(s) {', '.join(map(repr, ignored))} not used (afferent reads x, y, z, "
            f"a receptor id such as 'id' or 'receptor_id', 'longitudinal' and 'cross'); "
            + (f"receptor ids from {str(id_col)!r}." if id_col is not None else "receptors numbered 0, 1, ..."),
            AfferentWarning, stacklevel=2,
        )
    try:
        return ReceptorLayout(xyz * factor, ids, tol=tol, source=path, **sections)
    except ValueError as err:
        raise SEDFormatError(f"Receptor file {path!r}: {err}") from err


# --------------------------------------------------------------------------------------
# Layout generators: a regular ridge/papilla grid, and papilla tips found on an FE mesh
# --------------------------------------------------------------------------------------

#: Fingerprint-ridge pitch along x in m (:ref:`method-fe-model`): one papilla row per ridge.
RIDGE_PITCH_M = 0.44e-3
#: Dermal-papilla pitch along z (along a ridge) in m (:ref:`method-fe-model`).
PAPILLA_PITCH_M = 0.22e-3
#: Default coordinate noise in m tolerated by :func:`interface_tips` (exported coordinates
#: rounded to a few digits, jittered node positions): 1 um, 1/220 of the papilla pitch.
COORDINATE_NOISE_M = 1e-6
#: Default smallest height in m by which a papilla tip must rise above the lowest interface
#: node of its window: 10 um, a tenth of a 0.1 mm papilla and ten times the default noise.
MIN_PROMINENCE_M = 10e-6
#: A grid line within this fraction of a pitch outside a range end still counts as inside
#: (float round-off of ``x0 + i * pitch``).
_GRID_EPS = 1e-9
#: Largest layout :func:`grid_layout` builds; far above a whole fingertip (~ 5e3 tips), far
#: below what a range given in mm instead of m produces.
_MAX_GRID_RECEPTORS = 1_000_000


def _check_length(name: str, value) -> float:
    value = plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise TypeError(f"{name!r} must be a finite length in m; got {value!r} instead.")
    return float(value)


def _check_range(name: str, value) -> tuple[float, float]:
    try:
        lo, hi = (plain(v) for v in value)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name!r} must be a pair (min, max) in m; got {value!r} instead.") from err
    ok = all(not isinstance(v, bool) and isinstance(v, numbers.Real) and np.isfinite(v) for v in (lo, hi))
    if not ok:
        raise TypeError(f"{name!r} must be a pair (min, max) of finite lengths in m; got {value!r} instead.")
    if lo > hi:
        raise ValueError(f"{name!r} must be a pair (min, max) in m with min <= max; got {value!r} instead.")
    return float(lo), float(hi)


def _grid_ids(i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``'L{i}C{j}'`` with i, j zero-padded to the width of their largest value; duplicates get ``'.1'``, ``'.2'``."""
    wi = len(str(int(i.max()))) if i.size else 1
    wj = len(str(int(j.max()))) if j.size else 1
    ids = [f"L{a:0{wi}d}C{b:0{wj}d}" for a, b in zip(i.tolist(), j.tolist())]
    seen: dict[str, int] = {}
    for k, name in enumerate(ids):
        if name in seen:
            seen[name] += 1
            ids[k] = f"{name}.{seen[name]}"
        else:
            seen[name] = 0
    return np.array(ids, dtype=str)


def _axis_lines(axis: str, lo: float, hi: float, pitch: float, start: float | None) -> np.ndarray:
    """Grid coordinates ``start + k * pitch`` (m) inside [lo, hi]; centred on the range when ``start`` is None."""
    if start is None:
        n = int(np.floor((hi - lo) / pitch + _GRID_EPS)) + 1
        return 0.5 * (lo + hi) + (np.arange(n) - 0.5 * (n - 1)) * pitch
    k0 = int(np.ceil((lo - start) / pitch - _GRID_EPS))
    k1 = int(np.floor((hi - start) / pitch + _GRID_EPS))
    if k1 < k0:
        raise ValueError(
            f"'{axis}_range' must contain at least one grid line {axis} = {start!r} + k * {pitch!r} m "
            f"(from 'origin' and 'pitch_{axis}'); got ({lo!r}, {hi!r}) m instead."
        )
    return start + np.arange(k0, k1 + 1) * pitch


def grid_layout(
    *,
    x_range,
    z_range,
    y,
    pitch_x: float = RIDGE_PITCH_M,
    pitch_z: float = PAPILLA_PITCH_M,
    origin=None,
) -> ReceptorLayout:
    """Receptors on the study's regular ridge/papilla grid (:ref:`method-fe-model`).

    Receptor (i, j) sits at ``x = x0 + i * pitch_x`` (i-th papilla row, one per fingerprint
    ridge) and ``z = z0 + j * pitch_z`` (j-th papilla along the ridge), for every grid point
    inside ``x_range`` x ``z_range``, at height ``y``.

    Parameters
    ----------
    x_range : tuple of float
        ``(x_min, x_max)`` in m, across the ridges; ends included (to 1e-9 of a pitch).
    z_range : tuple of float
        ``(z_min, z_max)`` in m, along the ridges; ends included.
    y : float or callable
        Height of the receptors in m: a float for a flat surface, or a callable
        ``y(x, z) -> height`` taking two ndarrays of shape (n_receptors,) in m and returning
        heights in m of shape (n_receptors,) (or a scalar), e.g. the papilla-tip surface of
        the FE model.
    pitch_x : float, default=0.44e-3
        Grid pitch along x in m (fingerprint-ridge pitch).
    pitch_z : float, default=0.22e-3
        Grid pitch along z in m (papilla pitch along a ridge).
    origin : tuple of float, optional
        ``(x0, z0)`` in m: a point of the grid, which fixes its phase. Default: the grid is
        centred on the ranges (as many points as fit, with equal margins at both ends).

    Returns
    -------
    ReceptorLayout
        Receptors ordered by i (x) then j (z). Section labels are the grid indices:
        ``longitudinal = i`` (the line at one x, parallel to the ridges) and ``cross = j``,
        both counted from 0 at the smallest x and z inside the ranges. Ids are
        ``'L{i}C{j}'`` with i and j zero-padded to a common width, e.g. ``'L3C07'`` is the
        receptor of longitudinal section 3 and cross-section 7.

    Raises
    ------
    TypeError
        If a range is not a pair of finite numbers, ``y`` is neither a number nor a callable,
        or a pitch is not a number.
    ValueError
        If a range has min > max, a pitch is not > 0, no grid line falls in a range (with
        ``origin``), ``y(x, z)`` returns the wrong shape or non-finite heights, or the grid
        would exceed 1,000,000 receptors (ranges given in mm instead of m).

    See Also
    --------
    interface_tips : the papilla tips of an FE mesh, where the model put them.
    read_receptors : receptor sites from a CSV file.

    Examples
    --------
    >>> layout = grid_layout(x_range=(0.0, 0.88e-3), z_range=(0.0, 0.44e-3), y=2.45e-3)
    >>> layout.n_receptors
    9
    >>> layout.ids[:4].tolist()
    ['L0C0', 'L0C1', 'L0C2', 'L1C0']
    >>> layout.positions[4] * 1e3  # mm
    array([0.44, 2.45, 0.22])
    """
    xlo, xhi = _check_range("x_range", x_range)
    zlo, zhi = _check_range("z_range", z_range)
    pitch_x = check_positive("pitch_x", pitch_x, unit="m")
    pitch_z = check_positive("pitch_z", pitch_z, unit="m")
    if origin is None:
        x0 = z0 = None
    else:
        try:
            x0, z0 = origin
        except (TypeError, ValueError) as err:
            raise TypeError(f"'origin' must be a pair (x0, z0) in m; got {origin!r} instead.") from err
        x0, z0 = _check_length("origin[0]", x0), _check_length("origin[1]", z0)
    if not callable(y):
        y = plain(y)
        if isinstance(y, bool) or not isinstance(y, numbers.Real) or not np.isfinite(y):
            raise TypeError(
                f"'y' must be a height in m (a finite float) or a callable y(x, z) returning heights in m; "
                f"got {y!r} instead."
            )
    n_x = np.floor((xhi - xlo) / pitch_x + _GRID_EPS) + 1
    n_z = np.floor((zhi - zlo) / pitch_z + _GRID_EPS) + 1
    if n_x * n_z > _MAX_GRID_RECEPTORS:
        raise ValueError(
            f"'x_range' and 'z_range' must span at most {_MAX_GRID_RECEPTORS:,} grid points; got "
            f"{x_range!r} x {z_range!r} m with pitches {pitch_x!r} x {pitch_z!r} m, about {n_x * n_z:.3g} points, "
            "instead. Ranges and pitches are in m: pass 4e-3, not 4, for 4 mm."
        )
    xs = _axis_lines("x", xlo, xhi, pitch_x, x0)
    zs = _axis_lines("z", zlo, zhi, pitch_z, z0)
    ii, jj = (a.ravel() for a in np.meshgrid(np.arange(xs.size), np.arange(zs.size), indexing="ij"))
    x, z = xs[ii], zs[jj]
    if callable(y):
        heights = np.asarray(y(x, z), dtype=float)
        if heights.ndim == 0:
            heights = np.full(x.shape, float(heights))
        if heights.shape != x.shape:
            raise ValueError(
                f"'y' must return one height in m per grid point, an array of shape ({x.size},); "
                f"got shape {heights.shape} instead."
            )
        if not np.all(np.isfinite(heights)):
            k = int(np.argmin(np.isfinite(heights)))
            raise ValueError(
                f"'y' must return finite heights in m; got {heights[k]!r} at x = {x[k]!r} m, z = {z[k]!r} m instead."
            )
    else:
        heights = np.full(x.shape, float(y))
    positions = np.column_stack([x, heights, z])
    return ReceptorLayout(positions, _grid_ids(ii, jj), longitudinal=ii, cross=jj)


def _material_ids(name: str, value) -> np.ndarray:
    """``upper`` / ``lower``: one material id or a sequence of them, as a float array."""
    vals = np.atleast_1d(np.asarray(value, dtype=object))
    ok = vals.ndim == 1 and vals.size > 0 and all(
        not isinstance(v, bool) and isinstance(plain(v), numbers.Real) and np.isfinite(plain(v)) for v in vals
    )
    if not ok:
        raise TypeError(f"{name!r} must be a material id (a number) or a list of them; got {value!r} instead.")
    return vals.astype(float)


def _cell_nodes(cells, n_points: int):
    """(rows, owner): node-index rows and the FE cell each row belongs to, from ``Cells`` or a connectivity array."""
    from .field import Cells

    if isinstance(cells, Cells):
        return cells.tetra, cells.parent, cells.n_cells
    conn = np.asarray(cells)
    if conn.ndim != 2 or conn.shape[0] == 0 or not np.issubdtype(conn.dtype, np.integer):
        raise TypeError(
            "'cells' must be a Cells object (afferent.field.Cells) or an integer connectivity array of shape "
            f"(n_cells, n_nodes_per_cell); got {type(cells).__name__} of shape {np.shape(cells)} instead."
        )
    if conn.max() >= n_points:
        raise ValueError(
            f"'cells' must refer to points 0..{n_points - 1} (n_points = {n_points}); "
            f"got point index {int(conn.max())} instead."
        )
    return conn, np.arange(conn.shape[0]), conn.shape[0]


def interface_nodes(points, cells, cell_material, *, upper, lower, noise: float = COORDINATE_NOISE_M) -> np.ndarray:
    """Indices of the nodes on the interface between two materials of an FE mesh.

    A node is on the interface when it belongs to a cell of material ``upper`` and to a cell
    of material ``lower``; for meshes whose layers are tied with duplicated nodes, an
    ``upper`` node within ``noise`` of a ``lower`` node counts too (the ``upper`` copy is kept).

    Parameters
    ----------
    points : ndarray of shape (n_points, 3)
        Node coordinates in m.
    cells : Cells or ndarray of shape (n_cells, n_nodes_per_cell), int
        The mesh's volume cells: an :class:`afferent.field.Cells` (tetrahedra and the FE cell
        each came from; ``raw.cells`` of :func:`afferent.io.read_raw`) or a plain
        connectivity array, one row of point indices per FE cell (negative entries are padding).
    cell_material : array_like of shape (n_cells,)
        Material (layer) id of each FE cell, e.g. the study's 1 epidermis, 2 dermis, 3 subcutis.
    upper, lower : int or sequence of int
        Material id(s) above the interface (epidermis) and below it (dermis).
    noise : float, default=1e-6
        Distance in m within which duplicated interface nodes are merged.

    Returns
    -------
    ndarray of shape (n_interface,), int
        Sorted point indices.

    Raises
    ------
    TypeError, ValueError
        Bad shapes or types; ``upper`` or ``lower`` absent from ``cell_material`` or shared
        by both; no node on the interface.
    """
    pts = check_finite_array("points", points, ndim=2, shape_doc="(n_points, 3) in m")
    if pts.shape[1] != 3:
        raise ValueError(f"'points' must be an array of shape (n_points, 3) in m; got shape {pts.shape} instead.")
    noise = check_positive("noise", noise, unit="m", strict=False)
    rows, owner, n_cells = _cell_nodes(cells, pts.shape[0])
    mat = np.asarray(cell_material)
    if mat.shape != (n_cells,):
        raise ValueError(
            f"'cell_material' must have one id per FE cell, shape ({n_cells},); got shape {mat.shape} instead."
        )
    try:
        mat = mat.astype(float)
    except (TypeError, ValueError) as err:
        raise TypeError(f"'cell_material' must hold numeric material ids; got dtype {mat.dtype} instead.") from err
    up, low = _material_ids("upper", upper), _material_ids("lower", lower)
    found = np.unique(mat[np.isfinite(mat)])
    found_txt = ", ".join(f"{v:g}" for v in found[:20]) + (", ..." if found.size > 20 else "")
    for name, ids, given in (("upper", up, upper), ("lower", low, lower)):
        missing = ids[~np.isin(ids, found)]
        if missing.size:
            raise ValueError(
                f"{name!r} must be material id(s) present in 'cell_material'; got {given!r} instead. "
                f"Found ids {found_txt}."
            )
    if np.isin(up, low).any():
        raise ValueError(f"'upper' and 'lower' must be different materials; got upper={upper!r}, lower={lower!r} instead.")
    in_up = np.zeros(pts.shape[0], bool)
    in_low = np.zeros(pts.shape[0], bool)
    for flag, ids in ((in_up, up), (in_low, low)):
        sel = rows[np.isin(mat[owner], ids)].ravel()
        flag[sel[sel >= 0]] = True
    shared = in_up & in_low
    up_only, low_only = np.flatnonzero(in_up & ~in_low), np.flatnonzero(in_low & ~in_up)
    if noise > 0 and up_only.size and low_only.size:
        from scipy.spatial import cKDTree

        dist, _ = cKDTree(pts[low_only]).query(pts[up_only], distance_upper_bound=noise)
        shared[up_only[np.isfinite(dist)]] = True
    nodes = np.flatnonzero(shared)
    if nodes.size == 0:
        raise ValueError(
            f"Materials upper={upper!r} and lower={lower!r} must touch; got no node shared by their cells "
            f"(nor any pair of nodes within noise = {noise!r} m) instead."
        )
    return nodes


def interface_tips(
    points,
    cells,
    cell_material,
    *,
    upper,
    lower,
    pitch_x: float = RIDGE_PITCH_M,
    pitch_z: float = PAPILLA_PITCH_M,
    x_range=None,
    z_range=None,
    noise: float = COORDINATE_NOISE_M,
    min_prominence: float = MIN_PROMINENCE_M,
    keep_edge: bool = False,
    tol: float = SECTION_TOLERANCE_M,
) -> ReceptorLayout:
    """Find the dermal-papilla tips (RA-I sites) on the epidermis/dermis interface of an FE mesh.

    The interface is the set of nodes shared by an ``upper`` (epidermis) cell and a
    ``lower`` (dermis) cell (see :func:`interface_nodes`). A papilla tip is a local high
    (largest y) of that surface:

    1. *Window.* Every interface node n gets the window ``|x - x_n| <= pitch_x / 2 + noise``,
       ``|z - z_n| <= pitch_z / 2 + noise`` of half the papilla pitch each way.
    2. *Local high.* n is a candidate when no interface node in its window is higher than
       ``y_n + noise`` and n rises at least ``min_prominence`` above the lowest node of its
       window (flat stretches and isolated nodes are not highs).
    3. *One tip per papilla.* Candidates are taken from the highest down; one is kept unless
       an already-kept tip lies in its window (non-maximum suppression), which merges a
       flat-topped papilla or noise-level ties into a single node.
    4. *Edges.* Unless ``keep_edge``, a tip is dropped when there is no interface node on
       one of its sides (x below, x above, z below or z above) within one pitch: it lies on
       the boundary of the interface, and is the high of a papilla cut by the block's side
       face, not an apex. (One pitch, not half: a coarse mesh may have no node within half a
       pitch on one side of an interior tip.)
    5. *Ranges.* Tips outside ``x_range`` / ``z_range`` are dropped last, so windows near
       the range ends still see their whole neighbourhood.

    Why a window search and not fixed grid cells: it needs no grid phase (origin), does not
    return a "high" on the flank of a papilla cut by a cell boundary, finds papillae that
    are off the nominal grid, and returns nothing where the interface is flat. With tips on
    a grid of the given pitches, a window of half a pitch is the smallest that contains,
    for every node, the apex of its own papilla, and the largest that never contains two
    apexes; so the result is exactly the apexes.

    Parameters
    ----------
    points : ndarray of shape (n_points, 3)
        Node coordinates in m; x across the ridges, y up (towards the skin surface), z along
        the ridges.
    cells : Cells or ndarray of shape (n_cells, n_nodes_per_cell), int
        The mesh's volume cells: an :class:`afferent.field.Cells` (the cells of a read
        export: the nodes of FE cell c are those of the tetrahedra whose ``parent`` is c) or a
        plain connectivity array with one row of point indices per FE cell (negative entries
        are padding, for mixed cell types).
    cell_material : array_like of shape (n_cells,)
        Material (layer) id of each FE cell.
    upper, lower : int or sequence of int
        Material id(s) above the interface (epidermis) and below it (dermis).
    pitch_x : float, default=0.44e-3
        Papilla pitch along x in m (one row per fingerprint ridge).
    pitch_z : float, default=0.22e-3
        Papilla pitch along z in m.
    x_range, z_range : tuple of float, optional
        ``(min, max)`` in m: keep only tips inside (ends included, to ``noise``).
    noise : float, default=1e-6
        Coordinate noise in m: heights within ``noise`` are ties, window edges are widened by
        it, duplicated interface nodes within it are merged.
    min_prominence : float, default=10e-6
        Smallest height in m by which a tip must rise above the lowest interface node of its
        window; keep it above the height noise and below the papilla height.
    keep_edge : bool, default=False
        Keep highs on the boundary of the interface (cut papillae).
    tol : float, default=20e-6
        Section-grouping tolerance in m (:func:`group_coordinates`).

    Returns
    -------
    ReceptorLayout
        Tip positions (the interface nodes' coordinates, m), ordered by longitudinal section
        then cross-section. Sections are grouped from the coordinates with ``tol``
        (longitudinal by x, cross by z, numbered from 0 in increasing coordinate); ids are
        ``'L{longitudinal}C{cross}'`` as in :func:`grid_layout` (a second tip with the same pair,
        possible only for irregular tips, gets ``'.1'``).

    Raises
    ------
    TypeError, ValueError
        Bad shapes, types or ranges; materials absent or not touching; no tip found (the
        message gives the interface's extent, to spot points in mm instead of m).

    See Also
    --------
    tips_from_export : the same, reading the mesh and its material ids from an export file.
    grid_layout : a regular grid of receptors, without a mesh.

    Examples
    --------
    >>> layout = interface_tips(field_points, raw.cells, layer, upper=1, lower=2)  # doctest: +SKIP
    """
    from scipy.sparse import coo_matrix
    from scipy.spatial import cKDTree

    pitch_x = check_positive("pitch_x", pitch_x, unit="m")
    pitch_z = check_positive("pitch_z", pitch_z, unit="m")
    noise = check_positive("noise", noise, unit="m", strict=False)
    min_prominence = check_positive("min_prominence", min_prominence, unit="m", strict=False)
    tol = check_positive("tol", tol, unit="m")
    ranges = [None if r is None else _check_range(name, r) for name, r in (("x_range", x_range), ("z_range", z_range))]
    nodes = interface_nodes(points, cells, cell_material, upper=upper, lower=lower, noise=noise)
    pts = np.asarray(points, dtype=float)[nodes]
    x, y, z = pts.T
    # Chebyshev distance 1 in these scaled coordinates = the window's edge.
    scaled = np.column_stack([x / (0.5 * pitch_x + noise), z / (0.5 * pitch_z + noise)])
    pairs = cKDTree(scaled).query_pairs(1.0, p=np.inf, output_type="ndarray")
    a = np.concatenate([pairs[:, 0], pairs[:, 1]])
    b = np.concatenate([pairs[:, 1], pairs[:, 0]])  # b is in the window of a
    m = nodes.size
    w_max = np.full(m, -np.inf)
    w_min = np.full(m, np.inf)
    np.maximum.at(w_max, a, y[b])
    np.minimum.at(w_min, a, y[b])
    candidate = (y >= w_max - noise) & (y - w_min >= max(min_prominence, np.finfo(float).tiny))
    cand = np.flatnonzero(candidate)
    if not keep_edge and cand.size:
        # On the boundary of the interface: no interface node on one side within one pitch.
        reach = np.column_stack([x / (pitch_x + noise), z / (pitch_z + noise)])
        near = cKDTree(reach).query_ball_point(reach[cand], 1.0, p=np.inf)
        interior = np.ones(cand.size, bool)
        for k, (n, nb) in enumerate(zip(cand, near)):
            dx, dz = x[nb] - x[n], z[nb] - z[n]
            interior[k] = (dx < -noise).any() and (dx > noise).any() and (dz < -noise).any() and (dz > noise).any()
        cand = cand[interior]
    cand = cand[np.lexsort((z[cand], x[cand], -y[cand]))]  # highest first; ties by x, then z
    window = coo_matrix((np.ones(a.size, bool), (a, b)), shape=(m, m)).tocsr()
    kept = np.zeros(m, bool)
    for n in cand:
        if not kept[window.indices[window.indptr[n]:window.indptr[n + 1]]].any():
            kept[n] = True
    tips = np.flatnonzero(kept)
    for axis, rng in zip((0, 2), ranges):
        if rng is not None:
            c = pts[tips, axis]
            tips = tips[(c >= rng[0] - noise) & (c <= rng[1] + noise)]
    if tips.size == 0:
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        raise ValueError(
            f"The interface between materials upper={upper!r} and lower={lower!r} must have papilla tips "
            f"(highs rising >= {min_prominence!r} m within pitch {pitch_x!r} x {pitch_z!r} m windows"
            f"{' inside the given ranges' if any(r is not None for r in ranges) else ''}); got none on its "
            f"{nodes.size} nodes, spanning x [{lo[0]:.4g}, {hi[0]:.4g}], y [{lo[1]:.4g}, {hi[1]:.4g}], "
            f"z [{lo[2]:.4g}, {hi[2]:.4g}] m, instead. Points must be in m."
        )
    tip_pts = pts[tips]
    lon, _ = group_coordinates(tip_pts[:, 0], tol)
    crs, _ = group_coordinates(tip_pts[:, 2], tol)
    order = np.lexsort((tip_pts[:, 2], tip_pts[:, 0], crs, lon))
    lon, crs, tip_pts = lon[order], crs[order], tip_pts[order]
    return ReceptorLayout(tip_pts, _grid_ids(lon, crs), longitudinal=lon, cross=crs, tol=tol)


def tips_from_export(
    path,
    *,
    length_unit: str,
    material_array: str = "layer",
    upper,
    lower,
    **kwargs,
) -> ReceptorLayout:
    """Papilla tips (RA-I sites) of an FE export whose cells carry material (layer) ids.

    Reads the mesh with :func:`afferent.io.read_raw`, converts its points to m and calls
    :func:`interface_tips`.

    Parameters
    ----------
    path : str or path-like
        A mesh export with volume cells (``.vtu``, ``.vtk``, ``.xdmf``, ``.pvd``: the first
        step's mesh and material ids are used).
    length_unit : {'m', 'mm', 'um', 'cm'}
        Unit of the file's coordinates. Required: never guessed.
    material_array : str, default='layer'
        Name of the cell-data array holding the material id of each cell.
    upper, lower : int or sequence of int
        Material id(s) above (epidermis) and below (dermis) the interface, e.g. ``upper=1,
        lower=2`` for the sample exports (1 epidermis, 2 dermis, 3 subcutis).
    **kwargs
        Passed to :func:`interface_tips`: ``pitch_x``, ``pitch_z``, ``x_range``, ``z_range``,
        ``noise``, ``min_prominence``, ``keep_edge``, ``tol`` (lengths in m).

    Returns
    -------
    ReceptorLayout
        Tip positions in m.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SEDFormatError
        If the file cannot be read, has no volume cells, or lacks the cell array
        ``material_array``.
    UnitError
        If ``length_unit`` is unknown or contradicts the unit the file states.
    ValueError
        See :func:`interface_tips`.

    Examples
    --------
    >>> tips = tips_from_export("sample_sed/block4/indent_0p88mm.vtu", length_unit="mm",
    ...                         upper=1, lower=2)  # doctest: +SKIP
    >>> tips.n_receptors  # doctest: +SKIP
    153
    """
    from .exceptions import UnitError
    from .io import read_raw

    factor = length_factor(length_unit)
    path = os.fspath(path)
    raw = read_raw(path)
    if raw.length_unit is not None and not np.isclose(length_factor(raw.length_unit), factor):
        raise UnitError(
            f"'length_unit' must agree with the unit {raw.length_unit!r} that {path!r} states; "
            f"got {length_unit!r} instead."
        )
    if raw.cells is None or raw.points is None:
        raise SEDFormatError(
            f"Export {path!r} must have volume cells to find papilla tips on; got none (a point table?) instead."
        )
    cell_arrays = {arr.name: arr for arr in raw.arrays.values() if arr.location == "cell"}
    if material_array not in cell_arrays:
        found = f"cell arrays {', '.join(repr(n) for n in cell_arrays)}" if cell_arrays else "no cell arrays"
        hint = suggest(material_array, list(cell_arrays))
        raise SEDFormatError(
            f"Export {path!r} must have a cell array {material_array!r} of material ids; found {found} instead.{hint}"
        )
    values = cell_arrays[material_array].values
    if values.ndim != 2:
        raise SEDFormatError(
            f"Export {path!r}: cell array {material_array!r} must hold one material id per cell; "
            f"got {values.shape[2:]} components instead."
        )
    if values.shape[0] > 1 and not np.all(values == values[:1]):
        raise SEDFormatError(f"Export {path!r}: cell array {material_array!r} must not change between time steps.")
    return interface_tips(raw.points * factor, raw.cells, values[0], upper=upper, lower=lower, **kwargs)


def central_line(layout: ReceptorLayout, axis: str):
    """The receptors on the section line through the middle of the layout, along ``axis``.

    Along x: the cross section (constant z) whose centre is nearest the middle of the z extent;
    along z: the longitudinal section nearest the middle of the x extent.

    Parameters
    ----------
    layout : ReceptorLayout
        Receptor sites in m, with section labels.
    axis : {'x', 'z'}
        The direction of the line.

    Returns
    -------
    idx : ndarray of int
        Receptor indices on the line, sorted by their coordinate along ``axis``.
    coord : ndarray of float
        Their coordinate along ``axis``, m.
    at : float
        The section's position on the other axis, m.
    """
    other = 2 if axis == "x" else 0
    labels = layout.cross if axis == "x" else layout.longitudinal
    kind = "cross" if axis == "x" else "longitudinal"
    centres = layout.section_positions(kind)
    mid = 0.5 * (layout.positions[:, other].min() + layout.positions[:, other].max())
    best = int(np.nanargmin(np.abs(centres - mid)))
    idx = np.flatnonzero(labels == best)
    coord = layout.positions[idx, 0 if axis == "x" else 2]
    order = np.argsort(coord)
    return idx[order], coord[order], centres[best]
