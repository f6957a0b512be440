"""Papilla tips found on an FE mesh: the dermis-epidermis interface and its local maxima (:func:`interface_tips`).

:func:`tips_from_export` reads the mesh from an FE export first. Positions in m.
"""

from __future__ import annotations

import numbers
import os

import numpy as np

from .._validation import check_finite_array, check_positive, plain, suggest
from ..exceptions import SEDFormatError
from ..units import length_factor
from ._grid import PAPILLA_PITCH_M, RIDGE_PITCH_M, _check_range, _grid_ids
from ._layout import SECTION_TOLERANCE_M, ReceptorLayout, group_coordinates

#: Default coordinate noise in m tolerated by :func:`interface_tips` (exported coordinates
#: rounded to a few digits, jittered node positions): 1 um, 1/220 of the papilla pitch.
COORDINATE_NOISE_M = 1e-6
#: Default smallest height in m by which a papilla tip must rise above the lowest interface
#: node of its window: 10 um, a tenth of a 0.1 mm papilla and ten times the default noise.
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
        Bad shapes, types or ranges; materials absent or not touching; an interface that does
        not face up in y or an ``upper`` material below ``lower`` (``check_facing_up``); no
        tip found (the message gives the interface's extent, to spot points in mm instead of m).

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
    check_facing_up(points, cells, cell_material, nodes, upper=upper, lower=lower)
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
    from ..exceptions import UnitError
    from ..io import read_raw

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
