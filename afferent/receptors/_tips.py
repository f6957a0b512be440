"""Receptor sites found on an FE mesh: the epidermis/dermis interface and its local extremes (:func:`interface_sites`).

Papilla tips (RA-I) are its local maxima, intermediate-ridge bases (SA-I) its local minima:
one window search with a direction (``kind``). :func:`sites_from_export` reads the mesh from an
FE export first; :func:`interface_tips` and :func:`tips_from_export` are the ``kind='tips'``
forms. Positions in m.

Size: about 650 lines (half of them docstrings), kept whole: one search, its two kinds of site,
and the checks that refuse a mesh it cannot read (materials, orientation, flat stretches) belong
together.
"""

from __future__ import annotations

from ..field import Cells

from .._typing import ArrayLike, PathLike
from collections.abc import Sequence
from typing import Any

import numbers
import os

import numpy as np

from .._validation import check_finite_array, check_positive, plain, suggest
from ..exceptions import SEDFormatError
from ..units import length_factor
from ._grid import PAPILLA_PITCH_M, RIDGE_PITCH_M, _check_range, _grid_ids
from ._layout import SECTION_TOLERANCE_M, SITE_OF_KIND, ReceptorLayout, group_coordinates

#: Default coordinate noise in m tolerated by :func:`interface_tips` (exported coordinates
#: rounded to a few digits, jittered node positions): 1 um, 1/220 of the papilla pitch.
COORDINATE_NOISE_M = 1e-6
#: Default smallest height in m by which a papilla tip must rise above the lowest interface
#: node of its window (a ridge base sink below the highest): 10 um, a tenth of a 0.1 mm
#: papilla and ten times the default noise.
MIN_PROMINENCE_M = 10e-6


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
    from ..field import Cells

    if isinstance(cells, Cells):
        if not cells.nodes:
            return cells.tetra, cells.parent, cells.n_cells
        width = max(n.shape[1] for n in cells.nodes)  # full connectivity: quadratic cells' midside nodes count
        rows = np.vstack([np.pad(n, ((0, 0), (0, width - n.shape[1])), constant_values=-1) for n in cells.nodes])
        return rows, np.arange(cells.n_cells), cells.n_cells
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


def interface_nodes(points: np.ndarray, cells: Cells | np.ndarray, cell_material: ArrayLike, *, upper: int | Sequence[int], lower: int | Sequence[int], noise: float = COORDINATE_NOISE_M) -> np.ndarray:
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


#: Largest angle in degrees between the interface's mean normal and the y axis for which a search for
#: highs in y (papilla tips) makes sense; beyond it the model's thickness axis is another one.
MAX_TILT_DEG = 45.0


def check_facing_up(points, cells, cell_material, nodes, *, upper, lower) -> None:
    """Refuse an interface that does not face up in y, the thickness axis the site finders assume.

    Tips and bases are highs and lows in y (x across the ridges, y up towards the skin surface,
    z along the ridges). A model with z up (common in FE tools) or with y pointing into the
    finger would give sites on a side face or at the papillae's feet, with plausible-looking
    SED: so two checks, in m. *Facing:* the interface's mean plane (least-squares, from the
    principal axes of its ``nodes``) must have its normal within :data:`MAX_TILT_DEG` of y.
    *Up:* the ``upper`` material's nodes must lie higher in y, on average, than the ``lower``
    material's.

    Raises
    ------
    ValueError
        Naming the materials, the normal's direction and angle, or the two mean heights.
    """
    pts = np.asarray(points, dtype=float)
    iface = pts[nodes]
    if nodes.size >= 3:
        normal = np.linalg.svd(iface - iface.mean(axis=0), full_matrices=False)[2][-1]
        tilt = float(np.degrees(np.arccos(min(1.0, abs(normal[1])))))
        if tilt > MAX_TILT_DEG:
            axis = "xyz"[int(np.argmax(np.abs(normal)))]
            raise ValueError(
                f"The interface between materials upper={upper!r} and lower={lower!r} must face up along y (x across "
                f"the ridges, y the thickness axis towards the skin surface, z along the ridges); got a mean normal "
                f"along {axis} ({tilt:.0f} degrees from y) instead. Export the model with y up (rotate it in the FE "
                f"tool or its post-processor); tips and bases are highs and lows in y.")
    rows, owner, _ = _cell_nodes(cells, pts.shape[0])
    mat = np.asarray(cell_material, dtype=float)
    heights = []
    for ids in (_material_ids("upper", upper), _material_ids("lower", lower)):
        sel = rows[np.isin(mat[owner], ids)].ravel()
        heights.append(float(pts[np.unique(sel[sel >= 0]), 1].mean()))
    if heights[0] <= heights[1]:
        raise ValueError(
            f"Material upper={upper!r} must lie above lower={lower!r} in y (y up, towards the skin surface); got mean "
            f"heights {heights[0]:.4g} m (upper) and {heights[1]:.4g} m (lower) instead. Either the ids are swapped "
            f"(upper: the epidermis, lower: the dermis) or y points into the skin (then export with y pointing out of "
            f"it: highs in y would be the papillae's feet).")


#: The two kinds of site :func:`interface_sites` finds, and the extreme each is.
SITE_KINDS_ON_MESH = {"tips": "papilla tips", "bases": "intermediate-ridge bases"}


def _interface_graph(rows, nodes: np.ndarray, n_points: int):
    """Sparse symmetric adjacency of the interface nodes (local indices): two nodes are linked when a cell holds both."""
    from scipy.sparse import coo_matrix

    local = np.full(n_points + 1, -1)
    local[nodes] = np.arange(nodes.size)
    loc = local[np.where(rows >= 0, rows, n_points)]
    loc = loc[(loc >= 0).sum(axis=1) >= 2]
    i, j = np.triu_indices(loc.shape[1], 1)
    a, b = loc[:, i].ravel(), loc[:, j].ravel()
    ok = (a >= 0) & (b >= 0) & (a != b)
    a, b = a[ok], b[ok]
    m = nodes.size
    return coo_matrix((np.ones(2 * a.size, bool), (np.r_[a, b], np.r_[b, a])), shape=(m, m)).tocsr()


#: Samples per half ridge pitch along each cross-section of :func:`_flat_widths` (resolution 5.5 um at 0.44 mm).
_SECTION_SAMPLES = 40


def _flat_widths(cand: np.ndarray, x, h, z, pitch_x: float, noise: float, drop: float, sides: int = 2) -> np.ndarray:
    """Width across x (m) of the flat stretch each candidate sits on, in its own cross-section of the ridges.

    The interface, a surface h(x, z) (h = y for tips, -y for bases, m) interpolated linearly
    between its nodes (a Delaunay triangulation in x-z), is sampled along x at the candidate's
    z, ``pitch_x / 2`` each way. The stretch runs from the candidate while h stays within
    ``noise`` of its value; its width is inf unless h falls by ``drop`` on both sides within
    the half pitch (on one side with ``sides=1``: ``keep_edge``, cut papillae and ridges).
    """
    from matplotlib.tri import LinearTriInterpolator, Triangulation
    from scipy.spatial import Delaunay, QhullError

    if cand.size == 0:
        return np.zeros(0)
    try:
        tri = Delaunay(np.column_stack([x, z]))
    except QhullError:  # all interface nodes on one line in x-z: no cross-section to take
        return np.full(cand.size, np.inf)
    # matplotlib's trapezoid-map point location: fast for queries outside the triangulation too (qhull's own
    # search falls back to trying every triangle for those, e.g. beyond a cropped mesh's boundary)
    interpolate = LinearTriInterpolator(Triangulation(x, z, triangles=tri.simplices), h)

    def surface(qx, qz):  # linear interpolation of h (m); NaN outside the triangulation
        return np.ma.filled(interpolate(qx, qz).astype(float), np.nan)

    t = np.arange(1, _SECTION_SAMPLES + 1) * (0.5 * pitch_x / _SECTION_SAMPLES)
    widths, flanks = np.zeros(cand.size), np.zeros(cand.size, int)
    for sign in (-1.0, 1.0):
        xs = x[cand][:, None] + sign * t
        inside = (xs >= x.min()) & (xs <= x.max())  # beyond the interface's x extent: NaN
        along = np.full(xs.shape, np.nan)
        along[inside] = surface(xs[inside], np.broadcast_to(z[cand][:, None], xs.shape)[inside])
        off = ~(np.abs(along - h[cand][:, None]) <= noise)  # NaN (outside the mesh) ends the stretch too
        first = np.where(off.any(axis=1), off.argmax(axis=1), t.size)
        widths += np.where(first > 0, t[np.maximum(first - 1, 0)], 0.0)
        flanks += (along <= h[cand][:, None] - drop).any(axis=1)
    return np.where(flanks >= sides, widths, np.inf)


def _apexes(cand: np.ndarray, width: np.ndarray, h: np.ndarray, max_flat: float, noise: float):
    """(narrow, wide): the candidates on apexes at most ``max_flat`` (m) wide across x, and the mask of those on
    flanked flat stretches wider than that (floors). Where there is such a floor, narrow candidates at its
    height (within ``noise``) are floor too: a coarse mesh that cannot show the floor's width."""
    wide = np.isfinite(width) & (width > max_flat + noise)
    narrow = width <= max_flat + noise
    if wide.any() and narrow.any():
        levels = np.sort(h[cand[wide]])
        k = np.clip(np.searchsorted(levels, h[cand]), 1, levels.size - 1) if levels.size > 1 else np.zeros(cand.size, int)
        near = np.minimum(np.abs(levels[k] - h[cand]), np.abs(levels[np.maximum(k - 1, 0)] - h[cand]))
        narrow &= near > noise
    return cand[narrow], wide


def _segments(graph, sites: np.ndarray, h: np.ndarray, noise: float) -> list[np.ndarray]:
    """``sites`` (local indices) grouped into pieces linked through mesh cells with heights within ``noise``."""
    from scipy.sparse.csgraph import connected_components

    sub = graph[sites][:, sites].tocoo()
    level = np.abs(h[sites[sub.row]] - h[sites[sub.col]]) <= noise
    flat = graph.__class__((np.ones(level.sum(), bool), (sub.row[level], sub.col[level])), shape=sub.shape)
    _, label = connected_components(flat, directed=False)
    order = np.argsort(label, kind="stable")
    return np.split(sites[order], np.flatnonzero(np.diff(label[order])) + 1)


def _sites_on_top(top: np.ndarray, x, z, pitch_z: float, noise: float) -> np.ndarray:
    """Site nodes on one flat piece (local indices): its centre across x; along z one site, or one per ``pitch_z``
    (m) centred on the piece's length when it is a ridge line; each the piece's node nearest the aimed point."""
    xc = 0.5 * (x[top].min() + x[top].max())
    z0, z1 = z[top].min(), z[top].max()
    n = int(np.floor((z1 - z0) / pitch_z + 1e-9)) + 1
    aims = 0.5 * (z0 + z1) + (np.arange(n) - 0.5 * (n - 1)) * pitch_z
    picked = []
    for zt in aims:
        dist = np.hypot(x[top] - xc, z[top] - zt)
        near = top[dist <= dist.min() + noise]
        picked.append(near[np.lexsort((z[near], x[near]))[0]])  # ties: smaller x, then z
    return np.unique(picked)


def _interior(sites: np.ndarray, x, z, pitch_x: float, pitch_z: float, noise: float) -> np.ndarray:
    """``sites`` with an interface node on each side (x below, x above, z below, z above) within one pitch."""
    from scipy.spatial import cKDTree

    if sites.size == 0:
        return sites
    reach = np.column_stack([x / (pitch_x + noise), z / (pitch_z + noise)])
    near = cKDTree(reach).query_ball_point(reach[sites], 1.0, p=np.inf)
    keep = np.ones(sites.size, bool)
    for k, (n, nb) in enumerate(zip(sites, near)):
        dx, dz = x[nb] - x[n], z[nb] - z[n]
        keep[k] = (dx < -noise).any() and (dx > noise).any() and (dz < -noise).any() and (dz > noise).any()
    return sites[keep]


def _no_sites_error(kind, upper, lower, min_prominence, pitch_x, pitch_z, ranges, pts, wide) -> ValueError:
    """The error for an interface without sites: what was asked, the interface's extent, the flat tops refused."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    what = "highs rising" if kind == "tips" else "lows sinking"
    msg = (
        f"The interface between materials upper={upper!r} and lower={lower!r} must have {SITE_KINDS_ON_MESH[kind]} "
        f"({what} >= {min_prominence!r} m within pitch {pitch_x!r} x {pitch_z!r} m windows"
        f"{' inside the given ranges' if any(r is not None for r in ranges) else ''}); got none on its "
        f"{pts.shape[0]} nodes, spanning x [{lo[0]:.4g}, {hi[0]:.4g}], y [{lo[1]:.4g}, {hi[1]:.4g}], "
        f"z [{lo[2]:.4g}, {hi[2]:.4g}] m, instead."
    )
    if wide is not None:
        n, width, y, max_flat = wide
        side = ("highs", "top") if kind == "tips" else ("lows", "base")
        msg += (
            f" Its {n} local {side[0]} lie on flat stretches wider across x than max_flat = {max_flat!r} m (the "
            f"narrowest {width:.4g} m, at y = {y:.4g} m): a flat {side[1]}, not {SITE_KINDS_ON_MESH[kind]}."
        )
    return ValueError(msg + " Points must be in m.")


def interface_sites(
    points: np.ndarray,
    cells: Cells | np.ndarray,
    cell_material: ArrayLike,
    *,
    upper: int | Sequence[int],
    lower: int | Sequence[int],
    kind: str = "tips",
    pitch_x: float = RIDGE_PITCH_M,
    pitch_z: float = PAPILLA_PITCH_M,
    x_range: tuple[float, float] | None=None,
    z_range: tuple[float, float] | None=None,
    noise: float = COORDINATE_NOISE_M,
    min_prominence: float = MIN_PROMINENCE_M,
    max_flat: float | None = None,
    keep_edge: bool = False,
    tol: float = SECTION_TOLERANCE_M,
) -> ReceptorLayout:
    """Find receptor sites on the epidermis/dermis interface of an FE mesh: papilla tips or ridge bases.

    The interface is the set of nodes shared by an ``upper`` (epidermis) cell and a
    ``lower`` (dermis) cell (see :func:`interface_nodes`). ``kind`` says which extreme of
    that surface is sought (see :ref:`method-receptor-sites`):

    * ``'tips'``: the dermal-papilla tips, local highs (largest y), the RA-I (Meissner) sites;
    * ``'bases'``: the bases of the intermediate ridges, local lows (smallest y; the epidermis
      reaching deepest into the dermis under each fingerprint ridge), the SA-I (Merkel) sites.

    Below, "height" is y for tips and -y for bases; the search is otherwise the same:

    1. *Window.* Every interface node n gets the window ``|x - x_n| <= pitch_x / 2 + noise``,
       ``|z - z_n| <= pitch_z / 2 + noise`` of half the pitch each way.
    2. *Local extreme.* n is a candidate when no interface node in its window is higher than
       its height + ``noise`` and n rises at least ``min_prominence`` above the lowest node of
       its window (isolated nodes, and flat stretches far from any relief, are not extremes).
    3. *Narrow apexes across the ridges only.* Each candidate's cross-section of the ridges
       (the interface interpolated linearly between its nodes, sampled along x at the
       candidate's z, half a ridge pitch each way) must fall by ``min_prominence`` on both
       sides (papillae and intermediate ridges run along z, side by side), and the flat stretch
       the candidate sits on (where the section stays within ``noise`` of its height) must be
       at most ``max_flat`` wide. Otherwise the candidate sits on a flat floor (or ceiling), or
       on a stretch cut by the mesh's boundary, not on an apex, and gives no site. Where the
       interface has such a floor flanked on both sides, candidates at the floor's height
       (within ``noise``) give none either: they are the same floor, shown as a V by a mesh too
       coarse to resolve its width. This refuses a flat base between papilla rows (every node
       an equally low "base", half a ridge pitch wide), keeps a trapezoid apex, and cuts a
       waffle-like lowest level (intermediate ridges along z joined by flat gaps between
       papillae, unflanked across x) into the ridge pieces beside each papilla.
    4. *Sites on a piece.* The narrow candidates linked through mesh cells with heights within
       ``noise`` of each other form pieces. A piece's site is its node nearest the piece's
       centre (middle of its x and z extents; ties to smaller x, then z). A piece longer along
       z than one ``pitch_z`` (a ridge that runs along z unbroken, e.g. the intermediate ridges
       and the papilla ridges of a 2-D ridged model) gets one site per ``pitch_z``, centred on
       its length.
    5. *Edges.* Unless ``keep_edge``, a site is dropped when there is no interface node on
       one of its sides (x below, x above, z below or z above) within one pitch: it lies on
       the boundary of the interface (a papilla or ridge cut by the block's side face).
    6. *One site per window.* Sites are taken from the highest down; one is kept unless an
       already-kept site lies in its window (noise-level ties of separate tops).
    7. *Ranges.* Sites outside ``x_range`` / ``z_range`` are dropped last, so windows near
       the range ends still see their whole neighbourhood.

    A window search, not fixed grid cells: no grid phase to guess, no extreme on the flank of
    a papilla cut by a cell boundary, and papillae and ridges off the nominal grid are found.

    Parameters
    ----------
    points : ndarray of shape (n_points, 3)
        Node coordinates in m; x across the ridges, y up (towards the skin surface), z along
        the ridges.
    cells : Cells or ndarray of shape (n_cells, n_nodes_per_cell), int
        The mesh's volume cells: an :class:`afferent.field.Cells` (the cells of a read
        export; its full connectivity, midside nodes included, when it has one) or a plain
        connectivity array with one row of point indices per FE cell (negative entries are
        padding, for mixed cell types).
    cell_material : array_like of shape (n_cells,)
        Material (layer) id of each FE cell.
    upper, lower : int or sequence of int
        Material id(s) above the interface (epidermis) and below it (dermis).
    kind : {'tips', 'bases'}, default='tips'
        Papilla tips (RA-I sites) or intermediate-ridge bases (SA-I sites).
    pitch_x : float, default=0.44e-3
        Ridge pitch along x in m (one papilla row and one intermediate ridge per fingerprint ridge).
    pitch_z : float, default=0.22e-3
        Papilla pitch along z in m; also the spacing of sites along a ridge line.
    x_range, z_range : tuple of float, optional
        ``(min, max)`` in m: keep only sites inside (ends included, to ``noise``).
    noise : float, default=1e-6
        Coordinate noise in m: heights within ``noise`` are ties, window edges are widened by
        it, duplicated interface nodes within it are merged.
    min_prominence : float, default=10e-6
        Smallest height in m by which a site must stand out from the opposite extreme of its
        window; keep it above the height noise and below the papilla or ridge height.
    max_flat : float, optional
        Widest flat apex across x in m that still holds a site. Default: ``pitch_x / 2`` for
        tips (a papilla top 0.16 mm wide across the ridges still counts; a floor stretching
        between papilla rows does not) and ``pitch_x / 4`` for bases (an intermediate ridge's
        trapezoid apex is narrow; a flat base half a ridge pitch wide between papilla rows,
        as in a model without intermediate ridges, is not a ridge base).
    keep_edge : bool, default=False
        Keep extremes on the boundary of the interface (cut papillae and ridges).
    tol : float, default=20e-6
        Section-grouping tolerance in m (:func:`group_coordinates`).

    Returns
    -------
    ReceptorLayout
        Site positions (the interface nodes' coordinates, m), ordered by longitudinal section
        then cross-section, with ``site`` 'RA-I' (tips) or 'SA-I' (bases). Sections are grouped
        from the coordinates with ``tol`` (longitudinal by x, cross by z, numbered from 0 in
        increasing coordinate); ids are ``'L{longitudinal}C{cross}'`` as in :func:`grid_layout`
        (a second site with the same pair, possible only for irregular sites, gets ``'.1'``).

    Raises
    ------
    TypeError, ValueError
        Bad shapes, types, ``kind`` or ranges; materials absent or not touching; an interface that
        does not face up in y or an ``upper`` material below ``lower`` (``check_facing_up``); no
        site found (the message gives the interface's extent, to spot points in mm instead of m,
        and the flat stretches refused, with ``max_flat``).

    See Also
    --------
    interface_tips : the same with ``kind='tips'``.
    sites_from_export : the same, reading the mesh and its material ids from an export file.
    grid_layout : a regular grid of receptors, without a mesh.

    Examples
    --------
    >>> bases = interface_sites(field_points, raw.cells, layer, upper=1, lower=2, kind="bases")  # doctest: +SKIP
    >>> bases.site  # doctest: +SKIP
    'SA-I'
    """
    from scipy.sparse import coo_matrix
    from scipy.spatial import cKDTree

    if kind not in SITE_OF_KIND:
        raise ValueError(f"'kind' must be 'tips' or 'bases'; got {kind!r} instead.")
    pitch_x = check_positive("pitch_x", pitch_x, unit="m")
    pitch_z = check_positive("pitch_z", pitch_z, unit="m")
    noise = check_positive("noise", noise, unit="m", strict=False)
    min_prominence = check_positive("min_prominence", min_prominence, unit="m", strict=False)
    tol = check_positive("tol", tol, unit="m")
    if max_flat is None:
        max_flat = pitch_x * (0.5 if kind == "tips" else 0.25)
    max_flat = check_positive("max_flat", max_flat, unit="m", strict=False)
    ranges = [None if r is None else _check_range(name, r) for name, r in (("x_range", x_range), ("z_range", z_range))]
    nodes = interface_nodes(points, cells, cell_material, upper=upper, lower=lower, noise=noise)
    check_facing_up(points, cells, cell_material, nodes, upper=upper, lower=lower)
    pts_all = np.asarray(points, dtype=float)
    pts = pts_all[nodes]
    x, y, z = pts.T
    h = y if kind == "tips" else -y
    # Chebyshev distance 1 in these scaled coordinates = the window's edge.
    scaled = np.column_stack([x / (0.5 * pitch_x + noise), z / (0.5 * pitch_z + noise)])
    pairs = cKDTree(scaled).query_pairs(1.0, p=np.inf, output_type="ndarray")
    a = np.concatenate([pairs[:, 0], pairs[:, 1]])
    b = np.concatenate([pairs[:, 1], pairs[:, 0]])  # b is in the window of a
    m = nodes.size
    w_max, w_min = np.full(m, -np.inf), np.full(m, np.inf)
    np.maximum.at(w_max, a, h[b])
    np.minimum.at(w_min, a, h[b])
    candidate = (h >= w_max - noise) & (h - w_min >= max(min_prominence, np.finfo(float).tiny))
    cand = np.flatnonzero(candidate)
    width = _flat_widths(cand, x, h, z, pitch_x, noise, max(min_prominence, np.finfo(float).tiny),
                         sides=1 if keep_edge else 2)
    narrow, wide = _apexes(cand, width, h, max_flat, noise)
    refused = None if narrow.size or not wide.any() else (
        cand.size, float(width[wide].min()), float(y[cand[wide][np.argmin(width[wide])]]), max_flat)
    sites = []
    if narrow.size:
        graph = _interface_graph(_cell_nodes(cells, pts_all.shape[0])[0], nodes, pts_all.shape[0])
        sites = [_sites_on_top(piece, x, z, pitch_z, noise) for piece in _segments(graph, narrow, h, noise)]
    sites = np.concatenate(sites) if sites else np.zeros(0, int)
    if not keep_edge:
        sites = _interior(sites, x, z, pitch_x, pitch_z, noise)
    sites = sites[np.lexsort((z[sites], x[sites], -h[sites]))]  # highest first; ties by x, then z
    window = coo_matrix((np.ones(a.size, bool), (a, b)), shape=(m, m)).tocsr()
    kept = np.zeros(m, bool)
    for n in sites:
        if not kept[window.indices[window.indptr[n]:window.indptr[n + 1]]].any():
            kept[n] = True
    found = np.flatnonzero(kept)
    for axis, rng in zip((0, 2), ranges):
        if rng is not None:
            c = pts[found, axis]
            found = found[(c >= rng[0] - noise) & (c <= rng[1] + noise)]
    if found.size == 0:
        raise _no_sites_error(kind, upper, lower, min_prominence, pitch_x, pitch_z, ranges, pts, refused)
    site_pts = pts[found]
    lon, _ = group_coordinates(site_pts[:, 0], tol)
    crs, _ = group_coordinates(site_pts[:, 2], tol)
    order = np.lexsort((site_pts[:, 2], site_pts[:, 0], crs, lon))
    lon, crs, site_pts = lon[order], crs[order], site_pts[order]
    return ReceptorLayout(site_pts, _grid_ids(lon, crs), longitudinal=lon, cross=crs, tol=tol, site=SITE_OF_KIND[kind])


def interface_tips(points: np.ndarray, cells: Cells | np.ndarray, cell_material: ArrayLike, *, upper: int | Sequence[int], lower: int | Sequence[int], **kwargs: Any) -> ReceptorLayout:
    """The dermal-papilla tips (RA-I sites) of an FE mesh: :func:`interface_sites` with ``kind='tips'``.

    Parameters and result as :func:`interface_sites` (positions in m; ``site`` is 'RA-I').

    Examples
    --------
    >>> layout = interface_tips(field_points, raw.cells, layer, upper=1, lower=2)  # doctest: +SKIP
    """
    return interface_sites(points, cells, cell_material, upper=upper, lower=lower, kind="tips", **kwargs)


def sites_from_export(
    path: PathLike,
    *,
    length_unit: str,
    material_array: str = "layer",
    upper: int | Sequence[int],
    lower: int | Sequence[int],
    kind: str = "tips",
    allow_outside_files: bool = False,
    **kwargs: Any,
) -> ReceptorLayout:
    """Papilla tips (RA-I) or intermediate-ridge bases (SA-I) of an FE export whose cells carry material ids.

    Reads the mesh with :func:`afferent.io.read_raw`, converts its points to m and calls
    :func:`interface_sites`; a ``ValueError`` from it (no site found, materials absent) names the file.

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
    kind : {'tips', 'bases'}, default='tips'
        Papilla tips (RA-I sites) or intermediate-ridge bases (SA-I sites).
    allow_outside_files : bool, default=False
        Read the files the export points to even outside its folder (see :func:`afferent.read_sed`).
    **kwargs
        Passed to :func:`interface_sites`: ``pitch_x``, ``pitch_z``, ``x_range``, ``z_range``,
        ``noise``, ``min_prominence``, ``max_flat``, ``keep_edge``, ``tol`` (lengths in m).

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
        See :func:`interface_sites`; the message starts with ``Export '<path>':``.

    Examples
    --------
    >>> tips = sites_from_export("sample_sed/block4/indent_0p88mm.vtu", length_unit="mm",
    ...                         upper=1, lower=2)  # doctest: +SKIP
    >>> tips.n_receptors  # doctest: +SKIP
    153
    >>> sites_from_export("ridged.vtu", length_unit="mm", upper=1, lower=2, kind="bases")  # doctest: +SKIP
    """
    from ..io import read_raw

    path = os.fspath(path)
    length_factor(length_unit)  # an unknown unit refused before the file is read
    raw = read_raw(path, allow_outside_files=allow_outside_files)
    return sites_from_raw(raw, path, length_unit=length_unit, material_array=material_array, upper=upper, lower=lower,
                          kind=kind, **kwargs)


def sites_from_raw(raw, path, *, length_unit: str, material_array: str = "layer", upper, lower, kind: str = "tips",
                   **kwargs) -> ReceptorLayout:
    """:func:`sites_from_export` on an export already read: ``raw`` (a :class:`~afferent.io._raw.RawExport`, the
    first step's, or the whole export's, as :func:`afferent.io.iter_sed` hands it to ``on_first_raw``), named
    ``path`` in the messages. The sites of a command that samples the same export come from its one read.

    Parameters, result and errors as :func:`sites_from_export` (positions in m; ``length_unit`` the
    coordinates' unit, checked against the unit the file states).
    """
    from ..exceptions import UnitError

    factor = length_factor(length_unit)
    path = os.fspath(path)
    if raw.length_unit is not None and not np.isclose(length_factor(raw.length_unit), factor):
        raise UnitError(
            f"'length_unit' must agree with the unit {raw.length_unit!r} that {path!r} states; "
            f"got {length_unit!r} instead."
        )
    if raw.cells is None or raw.points is None:
        raise SEDFormatError(
            f"Export {path!r} must have volume cells to find {SITE_KINDS_ON_MESH.get(kind, 'receptor sites')} on; "
            "got none (a point table?) instead."
        )
    cell_arrays = {arr.name: arr for arr in raw.arrays.values() if arr.location == "cell"}
    if material_array not in cell_arrays:
        raise SEDFormatError(missing_material_array(path, material_array, list(cell_arrays)))
    values = cell_arrays[material_array].values
    if values.ndim != 2:
        raise SEDFormatError(
            f"Export {path!r}: cell array {material_array!r} must hold one material id per cell; "
            f"got {values.shape[2:]} components instead."
        )
    if values.shape[0] > 1 and not np.all(values == values[:1]):
        raise SEDFormatError(f"Export {path!r}: cell array {material_array!r} must not change between time steps.")
    try:
        return interface_sites(raw.points * factor, raw.cells, values[0], upper=upper, lower=lower, kind=kind, **kwargs)
    except ValueError as err:
        raise ValueError(f"Export {path!r}: {err}") from err


def missing_material_array(path, material_array: str, cell_arrays) -> str:
    """The sentence refusing an export ``path`` without the cell array ``material_array`` (its cell arrays
    ``cell_arrays``; the nearest named)."""
    found = f"cell arrays {', '.join(repr(n) for n in cell_arrays)}" if cell_arrays else "no cell arrays"
    return (f"Export {os.fspath(path)!r} must have a cell array {material_array!r} of material ids; found {found} "
            f"instead.{suggest(material_array, list(cell_arrays))}")


def tips_from_export(path: PathLike, *, length_unit: str, material_array: str = "layer", upper: int | Sequence[int], lower: int | Sequence[int], **kwargs: Any) -> ReceptorLayout:
    """Papilla tips (RA-I sites) of an FE export: :func:`sites_from_export` with ``kind='tips'``.

    Parameters and result as :func:`sites_from_export` (positions in m).

    Examples
    --------
    >>> tips = tips_from_export("sample_sed/block4/indent_0p88mm.vtu", length_unit="mm",
    ...                         upper=1, lower=2)  # doctest: +SKIP
    """
    return sites_from_export(path, length_unit=length_unit, material_array=material_array, upper=upper,
                             lower=lower, kind="tips", **kwargs)
