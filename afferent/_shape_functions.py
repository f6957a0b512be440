"""Shape functions of the volume cells, in VTK/meshio node order, and the natural coordinates of
points in them (Newton on the isoparametric map): 'linear' sampling interpolates in each cell with
its own shape functions (trilinear in a hexahedron, not linear in tetrahedra cut from it).

Each cell type's shape functions are the Lagrange basis of its polynomial space on its nodes:
the coefficients over a monomial basis come from inverting the (n_nodes x n_nodes) matrix of
the monomials at the nodes' natural coordinates, once. The natural coordinates are VTK's
parametric coordinates (``vtkCell.GetParametricCoords``): tetrahedra in the unit simplex,
hexahedra in the unit cube [0, 1]^3, wedges as a triangle (r, s >= 0, r + s <= 1) times
t in [0, 1]. ``tests/test_quadratic.py`` checks every basis against VTK's own
``InterpolationFunctions``.

====================  =====  ============================================================
meshio type           nodes  polynomial space
====================  =====  ============================================================
``tetra10``           10     complete quadratic
``hexahedron20``      20     serendipity (quadratic + r^2 s, ..., r^2 s t, ...: 20 terms)
``hexahedron27``      27     triquadratic (r^a s^b t^c, a, b, c <= 2)
``wedge15``           15     quadratic triangle x linear in t, plus t^2, r t^2, s t^2
``wedge18``           18     quadratic triangle x quadratic in t
``hexahedron``        8      trilinear (r^a s^b t^c, a, b, c <= 1)
``wedge``             6      linear triangle x linear in t
``pyramid``           5      VTK's (``vtkPyramid``): the hexahedron's trilinear functions with the
                             top face collapsed to the apex, (1-r)(1-s)(1-t), r(1-s)(1-t),
                             rs(1-t), (1-r)s(1-t), t; linear on the triangular faces, bilinear on
                             the base; r, s, t in [0, 1]
====================  =====  ============================================================

Tetrahedra need no Newton: their barycentric weights (``afferent/_mesh_geometry.py``) are their
shape functions. Every basis sums to 1 and interpolates the node coordinates, so a field linear
in x, y, z is reproduced exactly in any cell whose map is not singular.

Lengths in the unit of the node coordinates (m in the package); natural coordinates have none.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["QUADRATIC", "LINEAR_SHAPED", "SHAPED", "shape_functions", "natural_coordinates", "inside_reference",
           "node_offsets", "shape_weights", "ShapeHits", "shaped_types"]

_H = 0.5
_HEX_CORNERS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
_HEX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
_TET_CORNERS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
_TET_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
_WEDGE_CORNERS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1)]
_WEDGE_EDGES = [(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)]

#: Mid-edge node k of each quadratic type sits on the edge between corners EDGES[type][k];
#: the mid-edge nodes follow the corners (VTK order).
EDGES = {"tetra10": _TET_EDGES, "hexahedron20": _HEX_EDGES, "hexahedron27": _HEX_EDGES,
         "wedge15": _WEDGE_EDGES, "wedge18": _WEDGE_EDGES}
_CORNERS = {"tetra10": _TET_CORNERS, "hexahedron20": _HEX_CORNERS, "hexahedron27": _HEX_CORNERS,
            "wedge15": _WEDGE_CORNERS, "wedge18": _WEDGE_CORNERS}
#: Nodes after the mid-edge nodes: face centres (VTK: -x, +x, -y, +y, -z, +z), then the body centre.
_EXTRA = {
    "hexahedron27": [(0, _H, _H), (1, _H, _H), (_H, 0, _H), (_H, 1, _H), (_H, _H, 0), (_H, _H, 1), (_H, _H, _H)],
    "wedge18": [(_H, 0, _H), (_H, _H, _H), (0, _H, _H)],
}
#: Monomial exponents (a, b, c) of r^a s^b t^c spanning each type's space.
_TRI2 = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
_MONOMIALS = {
    "tetra10": [(a, b, c) for a in range(3) for b in range(3) for c in range(3) if a + b + c <= 2],
    "hexahedron20": [(a, b, c) for a in range(3) for b in range(3) for c in range(3)
                     if a + b + c <= 2 or (sorted((a, b, c)) in ([0, 1, 2], [1, 1, 1], [1, 1, 2]))],
    "hexahedron27": [(a, b, c) for a in range(3) for b in range(3) for c in range(3)],
    "wedge15": [(a, b, c) for a, b in _TRI2 for c in range(2)] + [(0, 0, 2), (1, 0, 2), (0, 1, 2)],
    "wedge18": [(a, b, c) for a, b in _TRI2 for c in range(3)],
    # the linear cells (their corners), for the corner-only map of a quadratic cell
    "tetra": [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)],
    "hexahedron": [(a, b, c) for a in range(2) for b in range(2) for c in range(2)],
    "wedge": [(a, b, c) for a, b in _TRI2[:3] for c in range(2)],
}
_LINEAR = {"tetra10": "tetra", "hexahedron20": "hexahedron", "hexahedron27": "hexahedron",
           "wedge15": "wedge", "wedge18": "wedge"}

#: The quadratic meshio cell types interpolated with their own shape functions.
QUADRATIC = tuple(_LINEAR)
#: The linear cell types other than the tetrahedron, interpolated with their own shape functions
#: (before: in the tetrahedra of their split, whose diagonals changed the answer).
LINEAR_SHAPED = ("hexahedron", "wedge", "pyramid")
#: Every cell type located by Newton and interpolated with its own shape functions.
SHAPED = QUADRATIC + LINEAR_SHAPED


_PYRAMID_CORNERS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1)]  # the apex: VTK puts it at (0, 0, 1)


def _nodes(ctype: str) -> np.ndarray:
    """Natural coordinates of a type's nodes, (n_nodes, 3), VTK order."""
    if ctype == "pyramid":
        return np.asarray(_PYRAMID_CORNERS, float)
    if ctype not in _LINEAR:  # a linear cell: the corners of its quadratic kin
        return np.asarray(_CORNERS[next(q for q, lin in _LINEAR.items() if lin == ctype)], float)
    corners = np.asarray(_CORNERS[ctype], float)
    mids = np.array([(corners[a] + corners[b]) / 2 for a, b in EDGES[ctype]])
    return np.vstack([corners, mids] + ([np.asarray(_EXTRA[ctype], float)] if ctype in _EXTRA else []))


@lru_cache(maxsize=None)
def _basis(ctype: str) -> tuple[np.ndarray, np.ndarray]:
    """(exponents (n, 3), coefficients (n_monomials, n_nodes)): N_j(x) = sum_i x^e_i C[i, j]."""
    exps = np.asarray(_MONOMIALS[ctype])
    vander = np.prod(_nodes(ctype)[:, None, :] ** exps[None], axis=2)  # (n_nodes, n_monomials)
    coef = np.linalg.inv(vander)
    coef[np.abs(coef) < 1e-12] = 0.0
    coef.setflags(write=False)
    return exps, coef


def shape_functions(ctype: str, xi: np.ndarray, *, derivatives: bool = False):
    """Shape functions of ``ctype`` at natural coordinates ``xi`` (m, 3) -> (m, n_nodes).

    With ``derivatives=True`` also their derivatives with respect to the natural coordinates,
    (m, n_nodes, 3). The functions sum to 1 and reproduce the type's polynomial space exactly.
    """
    xi = np.asarray(xi, float)
    if ctype == "pyramid":
        return _pyramid(xi, derivatives)
    exps, coef = _basis(ctype)
    powers = np.stack([np.ones_like(xi), xi, xi * xi], axis=2)  # (m, 3 axes, exponent 0..2)
    per_axis = [powers[:, d, exps[:, d]] for d in range(3)]  # (m, n_monomials) each
    n = (per_axis[0] * per_axis[1] * per_axis[2]) @ coef
    if not derivatives:
        return n
    slopes = np.stack([np.zeros_like(xi), np.ones_like(xi), 2 * xi], axis=2)  # d/dxi of xi^e, e = 0..2
    dn = np.empty(n.shape + (3,))
    for d in range(3):
        factors = [slopes[:, d, exps[:, d]] if k == d else per_axis[k] for k in range(3)]
        dn[:, :, d] = (factors[0] * factors[1] * factors[2]) @ coef
    return n, dn


def _pyramid(xi: np.ndarray, derivatives: bool):
    """VTK's pyramid functions (``vtkPyramid::InterpolationFunctions``/``InterpolationDerivs``) at ``xi`` (m, 3)."""
    r, s, t = xi.T
    rm, sm, tm = 1 - r, 1 - s, 1 - t
    n = np.stack([rm * sm * tm, r * sm * tm, r * s * tm, rm * s * tm, t], axis=1)
    if not derivatives:
        return n
    zero, one = np.zeros_like(r), np.ones_like(r)
    dn = np.stack([np.stack([-sm * tm, sm * tm, s * tm, -s * tm, zero], axis=1),
                   np.stack([-rm * tm, -r * tm, r * tm, rm * tm, zero], axis=1),
                   np.stack([-rm * sm, -r * sm, -r * s, -rm * s, one], axis=1)], axis=2)
    return n, dn


#: Centre of each reference cell: the Newton start.
_CENTRE = {"tetra10": (0.25, 0.25, 0.25), "hexahedron20": (_H, _H, _H), "hexahedron27": (_H, _H, _H),
           "wedge15": (1 / 3, 1 / 3, _H), "wedge18": (1 / 3, 1 / 3, _H), "hexahedron": (_H, _H, _H),
           "wedge": (1 / 3, 1 / 3, _H), "pyramid": (_H, _H, 0.25)}
#: Newton steps at most, and the step (in natural coordinates) below which it has converged.
NEWTON_STEPS, NEWTON_TOL = 25, 1e-12


def natural_coordinates(ctype: str, points: np.ndarray, nodes_xyz: np.ndarray):
    """Natural coordinates of ``points`` (m, 3) in cells with node coordinates ``nodes_xyz`` (m, n_nodes, 3).

    Newton's method on the isoparametric map x(xi) = sum_j N_j(xi) x_j, from the cell's centre,
    vectorised over the points; exact in one step for a straight-sided tetrahedron, a few for
    a curved cell. Converged when the step is below :data:`NEWTON_TOL`; where the Jacobian is
    singular (a pyramid's apex, where r and s are free) or the steps do not settle (near the apex),
    when x(xi) is the point within :data:`NEWTON_TOL` x the cell's size. Returns ``(xi (m, 3),
    converged (m,) bool)``; a point that is not converged has xi NaN. Lengths in any one unit.
    """
    m = points.shape[0]
    xi = np.tile(np.asarray(_CENTRE[ctype], float), (m, 1))
    done = np.zeros(m, bool)
    there = np.zeros(m, bool)  # x(xi) within NEWTON_TOL x the cell's size of the point, at the last step
    tol = NEWTON_TOL * (np.ptp(nodes_xyz, axis=1).max(axis=1) if m else np.zeros(0))
    active = np.arange(m)
    for _ in range(NEWTON_STEPS):
        if not active.size:
            break
        n, dn = shape_functions(ctype, xi[active], derivatives=True)
        nodes = nodes_xyz[active]
        miss = points[active] - np.matmul(n[:, None, :], nodes)[:, 0]
        there[active] = np.linalg.norm(miss, axis=1) <= tol[active]
        jac = np.matmul(nodes.transpose(0, 2, 1), dn)  # dx_d / dxi_e
        ok = np.abs(np.linalg.det(jac)) > 1e-300
        step = np.full((active.size, 3), np.nan)
        if ok.any():
            step[ok] = np.linalg.solve(jac[ok], miss[ok][..., None])[..., 0]
        step[~ok & there[active]] = 0.0  # a singular point of the map (a pyramid's apex), reached
        xi[active] += step
        small = np.all(np.abs(step) < NEWTON_TOL, axis=1)
        done[active[small]] = True
        bad = ~np.all(np.isfinite(xi[active]), axis=1) | (np.abs(xi[active]) > 1e3).any(axis=1)
        active = active[~small & ~bad]
    done |= there & np.all(np.isfinite(xi), axis=1)
    xi[~done] = np.nan
    return xi, done


def inside_reference(ctype: str, xi: np.ndarray, tol: float) -> np.ndarray:
    """Whether natural coordinates ``xi`` (m, 3) lie in the reference cell, within ``tol``."""
    r, s, t = np.asarray(xi, float).T
    with np.errstate(invalid="ignore"):
        if ctype.startswith("tetra"):
            return (r >= -tol) & (s >= -tol) & (t >= -tol) & (r + s + t <= 1 + tol)
        if ctype.startswith("wedge"):
            return (r >= -tol) & (s >= -tol) & (r + s <= 1 + tol) & (t >= -tol) & (t <= 1 + tol)
        # hexahedra and pyramids: the unit cube (a pyramid's is the hexahedron's with its top collapsed)
        return np.all((xi >= -tol) & (xi <= 1 + tol), axis=1)


def node_offsets(ctype: str, conn: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """Per cell, how far its non-corner nodes lie from where its corners alone put them, over its longest edge.

    Each mid-edge, face and centre node is compared with the corner-only (linear) map at the
    node's natural coordinates: 0 for a straight-sided cell with centred nodes; a curved edge of a
    usable cell stays well below 0.3, while a node order mixed up between tools (the top and
    vertical mid-edge nodes of a 20-node brick swapped, face nodes in another order) puts a node
    about 0.5-0.7 edge lengths off. ``conn`` (n_cells, n_nodes) in VTK order; shape (n_cells,).
    """
    n_c = len(_CORNERS[ctype])
    lin = shape_functions(_LINEAR[ctype], _nodes(ctype)[n_c:])  # (n_extra, n_c)
    corners = xyz[conn[:, :n_c]]
    expected = np.einsum("kc,mcd->mkd", lin, corners)
    edges = np.asarray(EDGES[ctype])
    longest = np.linalg.norm(corners[:, edges[:, 1]] - corners[:, edges[:, 0]], axis=2).max(axis=1)
    off = np.linalg.norm(xyz[conn[:, n_c:]] - expected, axis=2).max(axis=1)
    return off / np.where(longest > 0, longest, np.inf)


#: Natural-coordinate slack of "inside a cell" (as ``BARY_TOL`` for the tetrahedra of linear cells).
INSIDE_TOL = 1e-6
#: :func:`node_offsets` above which a cell's nodes are taken to be in another tool's order: the cell
#: is then interpolated from its corners, with a warning.
ORDER_SUSPECT = 0.3
#: Nearest nodes whose cells are tried for a point not in the cell its corner tetrahedra gave.
NEIGHBOUR_NODES = 8


@dataclass(frozen=True)
class ShapeHits:
    """Points placed in cells by their own shape functions (:func:`shape_weights`).

    ``points`` (k,) indices of the points placed; ``rows``, ``cols``, ``vals``: the sparse weights
    (row = point index, col = node index); ``cells`` (k,) the cell holding each; ``corner_only``:
    points in such a cell left to the tetrahedra of its corners, by reason (``'node without
    values'``, ``'node order'``, ``'not found'``).
    """

    points: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    cells: np.ndarray
    corner_only: dict


def _blocks(cells):
    """(type of each block, first cell of each block, connectivity of each block)."""
    starts = np.cumsum([0] + [n.shape[0] for n in cells.nodes])[:-1]
    return list(cells.cell_types), starts, list(cells.nodes)


def _try_cells(ctype, conn, xyz, points, cand):
    """Newton for points (m, 3) in cells ``cand`` (m,) of one block: (xi (m, 3), inside (m,))."""
    xi, ok = natural_coordinates(ctype, points, xyz[conn[cand]])
    return xi, ok & inside_reference(ctype, xi, INSIDE_TOL)


def _usable(ctype, conn, xyz, cand):
    """Per candidate cell: 'ok', or why it is left to its corners ('node without values', 'node order')."""
    out = np.full(cand.size, "ok", dtype=object)
    rows = conn[cand]
    missing = (rows < 0).any(axis=1)
    out[missing] = "node without values"
    if ctype in QUADRATIC and (~missing).any():  # a linear cell has only corners: no order to suspect
        bad = node_offsets(ctype, rows[~missing], xyz) > ORDER_SUSPECT
        out[np.flatnonzero(~missing)[bad]] = "node order"
    return out


def shape_weights(points: np.ndarray, xyz: np.ndarray, cells, guess: np.ndarray, types: tuple = SHAPED) -> ShapeHits:
    """Weights of the points that lie in cells of ``types``, from those cells' own shape functions.

    Parameters
    ----------
    points : ndarray of shape (n, 3)
        Positions (m).
    xyz : ndarray of shape (n_points, 3)
        Node coordinates (m).
    cells : afferent.field.Cells
        With :attr:`~afferent.field.Cells.nodes` (VTK node order).
    guess : ndarray of shape (n,), int
        The cell each point's corner tetrahedra put it in (-1: none).
    types : tuple of str, default :data:`SHAPED`
        The cell types interpolated with their own shape functions (the others keep their tetrahedra).

    Each point whose guessed cell is of ``types`` is located in it by Newton on the isoparametric
    map; a point not inside it (a curved cell, a warped face), or in no cell's corner tetrahedra
    while such cells exist, is tried in the cells of ``types`` around its nearest nodes.
    Cells with a node left out (no values there) or whose mid-nodes sit far from where their
    corners put them (:data:`ORDER_SUSPECT`) are left to the tetrahedra of their corners.
    """
    mesh = _blocks(cells)
    block_types, starts, conns = mesh
    quad = [k for k, t in enumerate(block_types) if t in types]
    empty = np.zeros(0, np.int64)
    if not quad or not points.shape[0]:
        return ShapeHits(empty, empty, empty, np.zeros(0), empty, {})
    guess = np.asarray(guess)
    block = np.searchsorted(starts, guess, side="right") - 1
    found = np.full(points.shape[0], -1, np.int64)
    xi_all = np.full((points.shape[0], 3), np.nan)
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    in_box = np.all((points >= lo - 1e-9 * (hi - lo).max()) & (points <= hi + 1e-9 * (hi - lo).max()), axis=1)
    retry = [np.flatnonzero((guess < 0) & in_box)]  # outside the nodes' box no cell can hold a point
    reasons: dict[str, int] = {}
    for k in quad:
        idx = np.flatnonzero((guess >= 0) & (block == k))
        if not idx.size:
            continue
        local = guess[idx] - starts[k]
        why = _usable(block_types[k], conns[k], xyz, local)
        for r in sorted(set(why) - {"ok"}):
            reasons[r] = int(np.sum(why == r)) + reasons.get(r, 0)
        idx, local = idx[why == "ok"], local[why == "ok"]
        xi, inside = _try_cells(block_types[k], conns[k], xyz, points[idx], local)
        found[idx[inside]], xi_all[idx[inside]] = guess[idx[inside]], xi[inside]
        retry.append(idx[~inside])
    retry = np.sort(np.concatenate(retry))
    if retry.size:
        _search_near(points, xyz, mesh, quad, retry, found, xi_all)
    lost = int(np.sum((found[retry] < 0) & (guess[retry] >= 0)))
    if lost:
        reasons["not found"] = lost
    return _hits(found, xi_all, mesh, reasons)


def _search_near(points, xyz, mesh, quad, retry, found, xi_all) -> None:
    """Try the points ``retry`` in the usable cells of blocks ``quad`` around their nearest nodes (fills ``found``,
    ``xi_all``)."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    types, starts, conns = mesh
    k_near = min(NEIGHBOUR_NODES, xyz.shape[0])
    near = cKDTree(xyz).query(points[retry], k=k_near)[1].reshape(retry.size, k_near)
    wanted = np.unique(near)
    cb, cl, node_rows, cand_cols = [], [], [], []  # block and local index of each candidate cell; incidence
    for k in quad:
        local = np.flatnonzero(np.isin(conns[k], wanted).any(axis=1))
        local = local[_usable(types[k], conns[k], xyz, local) == "ok"]
        rows = conns[k][local]
        node_rows.append(rows.ravel())
        cand_cols.append(np.repeat(np.arange(len(cb), len(cb) + local.size), rows.shape[1]))
        cb += [k] * local.size
        cl += local.tolist()
    if not cb:
        return
    cb, cl = np.asarray(cb), np.asarray(cl, np.int64)
    node_rows, cand_cols = np.concatenate(node_rows), np.concatenate(cand_cols)
    incidence = sp.csr_matrix((np.ones(node_rows.size), (node_rows, cand_cols)), shape=(xyz.shape[0], cb.size))
    for j, p in enumerate(retry):
        touch = np.unique(incidence[near[j]].indices)
        for k in quad:
            sel = touch[cb[touch] == k]
            if not sel.size:
                continue
            xi, inside = _try_cells(types[k], conns[k], xyz, np.repeat(points[p][None], sel.size, 0), cl[sel])
            if inside.any():
                first = int(np.argmax(inside))
                found[p], xi_all[p] = starts[k] + cl[sel[first]], xi[first]
                break


def _hits(found, xi_all, mesh, reasons) -> ShapeHits:
    """The sparse weights of the points placed in cells by their own shape functions."""
    types, starts, conns = mesh
    placed = np.flatnonzero(found >= 0)
    block = np.searchsorted(starts, found[placed], side="right") - 1
    rows, cols, vals = [], [], []
    for k in np.unique(block):
        sel = placed[block == k]
        nodes = conns[k][found[sel] - starts[k]]
        w = shape_functions(types[k], xi_all[sel])
        rows.append(np.repeat(sel, nodes.shape[1]))
        cols.append(nodes.ravel())
        vals.append(w.ravel())
    cat = (lambda parts, dtype: np.concatenate(parts) if parts else np.zeros(0, dtype))
    return ShapeHits(placed, cat(rows, np.int64), cat(cols, np.int64), cat(vals, float), found[placed], reasons)


def shaped_types(cells, location: str) -> tuple:
    """The cell types of ``cells`` that 'linear' sampling interpolates with their own shape functions: for point
    data every type of :data:`SHAPED`; for cell data (averaged to the corner nodes, which alone get values)
    the linear ones, :data:`LINEAR_SHAPED`. Empty without the full connectivity (:attr:`Cells.nodes`)."""
    if cells is None or not cells.nodes:
        return ()
    own = SHAPED if location == "point" else LINEAR_SHAPED
    return tuple(t for t in dict.fromkeys(cells.cell_types) if t in own)


def with_shape_functions(weights, outside: np.ndarray, points: np.ndarray, xyz: np.ndarray, cells, guess: np.ndarray,
                         placement: str, types: tuple = SHAPED):
    """Corner-tetrahedra weights (n, n_points) with the rows of points in cells of ``types`` replaced by
    those cells' own shape functions.

    ``weights``: scipy sparse (n_receptors, n_points) from the corner tetrahedra; ``outside``
    (n,) bool; ``points`` (n, 3) m; ``guess`` (n,) the cell of each point's tetrahedron (-1:
    none); ``placement``: how the values are placed. Returns ``(weights (csr), outside,
    placement)``: a point outside every corner tetrahedron but inside a curved cell is inside;
    the placement gets a note on the points left to their cell's corner tetrahedra and why (and an
    :class:`~afferent.exceptions.AfferentWarning` is issued when the reason is a suspect node order).
    """
    import warnings

    import scipy.sparse as sp

    from .exceptions import AfferentWarning

    hits = shape_weights(points, xyz, cells, guess, types)
    keep = sp.diags((~np.isin(np.arange(points.shape[0]), hits.points)).astype(float))
    quad = sp.csr_matrix((hits.vals, (hits.rows, hits.cols)), shape=weights.shape)
    out = (keep @ weights + quad).tocsr()
    outside = outside.copy()
    outside[hits.points] = False
    if hits.corner_only:
        why = ", ".join(f"{n} with a {r}" if r != "not found" else f"{n} not found by Newton inside a cell"
                        for r, n in hits.corner_only.items())
        placement += (f"; {sum(hits.corner_only.values())} receptor(s) interpolated linearly in the tetrahedra of "
                      f"their cell's corners ({why})")
        if "node order" in hits.corner_only:
            warnings.warn(f"{hits.corner_only['node order']} receptor(s) lie in quadratic cells whose nodes sit more "
                          f"than {ORDER_SUSPECT} of the longest edge from where the corners put them: a node order "
                          "other than VTK's? They are interpolated between the cell's corners.",
                          AfferentWarning, stacklevel=4)
    return out, outside, placement


def clip_overshoot(values: np.ndarray, weights, field_values: np.ndarray) -> int:
    """Set to 0, in place, the negative values that negative weights made from non-negative nodes.

    Quadratic shape functions dip below 0 inside a cell (a corner's between its mid-edge nodes),
    so SED interpolated between non-negative nodal values can come out negative near a steep
    gradient (0.1-0.4 % of the values at 20,000 random points of the CalculiX test blocks
    ``tests/data/calculix/block_c3d*.frd``, down to -0.022 x the largest SED). A row with a negative weight whose contributing field values are
    all >= 0 at a step, and whose value is negative, gets 0 there; a field that is negative at a
    node is left as it is. ``values`` (n_times, n_rows), ``weights`` csr (n_rows, n_values),
    ``field_values`` (n_times, n_values). Returns how many values were set to 0.
    """
    if not weights.nnz or weights.data.min() >= 0:
        return 0  # barycentric weights: nothing to clip (the linear path pays one min())
    t, r = np.nonzero(values < 0)  # few: look only at them
    if not t.size:
        return 0
    has_negative = np.zeros(weights.shape[0], bool)
    has_negative[np.repeat(np.arange(weights.shape[0]), np.diff(weights.indptr))[weights.data < 0]] = True
    t, r = t[has_negative[r]], r[has_negative[r]]
    counts = weights.indptr[r + 1] - weights.indptr[r]
    first = np.cumsum(counts) - counts
    stored = np.repeat(weights.indptr[r] - first, counts) + np.arange(counts.sum())  # each pair's weights
    lowest = np.minimum.reduceat(np.asarray(field_values, float)[np.repeat(t, counts), weights.indices[stored]], first)
    clip = lowest >= 0
    values[t[clip], r[clip]] = 0.0
    return int(clip.sum())
