"""Geometry behind :mod:`afferent.sampling`: points located in tetrahedra (barycentric weights),
cell volumes, cell-to-node averaging, and the Delaunay triangulation of a point table. Lengths in m.

:func:`node_average` and :func:`cell_volumes` are importable from :mod:`afferent.sampling`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .field import Cells

if TYPE_CHECKING:  # scipy loads when a sampler is built, not for a cached ReceptorSED
    import scipy.sparse as sp

#: Barycentric slack: a receptor within this (relative) distance outside a tetrahedron's
#: face still counts as inside it (receptors on faces, float noise in exported coordinates).
BARY_TOL = 1e-6


def _barycentric(points: np.ndarray, tet_xyz: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of points (m, 3) in tets (m, 4, 3) -> (m, 4); NaN for degenerate tets.

    A tetrahedron is degenerate (flat) when its volume is below 1e-12 of the product of its
    three edge lengths from the first vertex: scale-free, so flat cells of a mesh in m are
    skipped whatever their size (a fixed threshold let their round-off determinants through
    to a singular solve).
    """
    t = tet_xyz[:, 1:, :] - tet_xyz[:, :1, :]  # (m, 3, 3) rows = edges
    rhs = points - tet_xyz[:, 0, :]
    det = np.linalg.det(t)
    ok = np.abs(det) > 1e-12 * np.prod(np.linalg.norm(t, axis=2), axis=1)
    lam = np.full((points.shape[0], 3), np.nan)
    if ok.any():
        lam[ok] = np.linalg.solve(np.transpose(t[ok], (0, 2, 1)), rhs[ok][..., None])[..., 0]
    return np.column_stack([1.0 - lam.sum(axis=1), lam])


def locate_in_tets(points: np.ndarray, xyz: np.ndarray, tetra, *, k: int = 24):
    """Find, for each point, a tetrahedron that contains it and its barycentric weights.

    Candidate tetrahedra are those with the nearest centroids (KD-tree); points not found
    among ``k`` candidates are retried with more, then against every tetrahedron whose
    bounding box holds them. ``tetra``: an (n_tetra, 4) array, or :class:`~afferent.field.Cells`,
    whose tetrahedra near the points are then split alone when the cells are not yet
    (:meth:`~afferent.field.Cells.split`; every one only for a point not found among them).

    Returns
    -------
    tet_index : ndarray of shape (n,), int (-1 where outside)
    bary : ndarray of shape (n, 4)
    """
    from scipy.spatial import cKDTree

    cells = tetra if isinstance(tetra, Cells) else None
    n, n_tetra = points.shape[0], cells.n_tetra if cells is not None else tetra.shape[0]
    tet_index = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 4))
    if n == 0 or n_tetra == 0:
        return tet_index, bary
    if cells is not None and (cells.split_done or n_tetra <= NEAR_NODES_FROM or not cells.nodes):
        tetra, cells = cells.tetra, None
    if n_tetra > NEAR_NODES_FROM:
        # A large mesh and (usually) few receptors: search first among the tetrahedra that touch
        # the receptors' nearest nodes (a KD-tree over the nodes, not over millions of
        # tetrahedra); the points not found there go through the full search below.
        # built for a few queries: unbalanced, not compacted (2M nodes: 0.5 instead of 1.8 s; the same neighbours)
        _, near = cKDTree(xyz, balanced_tree=False, compact_nodes=False).query(points, k=min(8, xyz.shape[0]))
        touched = np.zeros(xyz.shape[0], bool)
        near = np.asarray(near).ravel()
        touched[near[near < xyz.shape[0]]] = True  # scipy's index n_points: no neighbour (distance overflowed)
        if cells is None:
            subset = np.flatnonzero(touched[tetra].any(axis=1))
            near_tetra = tetra[subset]
        else:  # the tetrahedra of the cells with a touched node, of these those with a touched corner: the same subset
            hit = np.concatenate([touched[c].any(axis=1) for c in cells.nodes])
            subset = cells.tetra_rows(np.flatnonzero(hit))
            near_tetra = cells.rows(subset)[0]
            keep = touched[near_tetra].any(axis=1)
            subset, near_tetra = subset[keep], near_tetra[keep]
        sub_index, sub_bary = _locate(points, xyz, near_tetra, k)
        found = sub_index >= 0
        tet_index[found], bary[found] = subset[sub_index[found]], sub_bary[found]
        if found.all():
            return tet_index, bary
        rest = np.flatnonzero(~found)
        tet_index[rest], bary[rest] = _locate(points[rest], xyz, tetra if cells is None else cells.tetra, k)
        return tet_index, bary
    return _locate(points, xyz, tetra, k)


#: Meshes with more tetrahedra than this are searched first near the receptors' nearest nodes
#: (:func:`locate_in_tets`); measured on a 970,299-hex (5.8M-tet) block: 11.6 s -> see
#: ``benchmarks/bench_large_series.py``.
NEAR_NODES_FROM = 200_000


#: Points searched at once by :func:`_locate` (their candidate lists and barycentric coordinates, ~0.6 kB a point):
#: memory that does not grow with the number of receptors (1e6 receptors at once: 1.2 GB).
LOCATE_CHUNK = 1 << 16


def _locate(points: np.ndarray, xyz: np.ndarray, tetra: np.ndarray, k: int):
    """:func:`locate_in_tets` over every given tetrahedron (candidates by nearest centroids), :data:`LOCATE_CHUNK`
    points at a time (each point's search is its own: the result does not depend on the chunks)."""
    from scipy.spatial import cKDTree

    n = points.shape[0]
    tet_index = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 4))
    if n == 0 or tetra.shape[0] == 0:
        return tet_index, bary
    tree = cKDTree(xyz[tetra].mean(axis=1))  # over the centroids
    boxes: list = []  # the tetrahedra's bounding boxes, computed once if a point needs them
    for a in range(0, n, LOCATE_CHUNK):
        todo = _locate_near(points[a:a + LOCATE_CHUNK], xyz, tetra, tree, k, tet_index[a:a + LOCATE_CHUNK],
                            bary[a:a + LOCATE_CHUNK])
        if todo.size and not boxes:
            boxes.extend((xyz[tetra].min(axis=1), xyz[tetra].max(axis=1)))
        for i in todo + a:  # few points: brute force over bounding boxes
            tet_index[i], bary[i] = _locate_in_boxes(points[i], xyz, tetra, *boxes)
    return tet_index, bary


def _locate_near(points, xyz, tetra, tree, k: int, tet_index, bary) -> np.ndarray:
    """Fill ``tet_index``/``bary`` (views) for the points found among the ``k``, then ``8 k``, tetrahedra of
    nearest centroids; returns the indices of the points not found."""
    n = points.shape[0]
    todo = np.arange(n)
    for kk in (k, 8 * k):
        kk = min(kk, tetra.shape[0])
        _, cand = tree.query(points[todo], k=kk)
        cand = cand.reshape(len(todo), kk)
        for j in range(kk):
            # scipy marks a neighbour it could not place (distance overflowing to inf: points
            # 1e160 m away) with the index n_tetra: no candidate
            valid = cand[:, j] < tetra.shape[0]
            c = np.where(valid, cand[:, j], 0)
            with np.errstate(over="ignore", invalid="ignore"):
                b = _barycentric(points[todo], xyz[tetra[c]])
            inside = valid & np.all(b >= -BARY_TOL, axis=1)
            tet_index[todo[inside]] = c[inside]
            bary[todo[inside]] = b[inside]
            todo = todo[~inside]
            cand = cand[~inside]
            if not todo.size:
                return todo
    return todo


def _locate_in_boxes(point, xyz, tetra, lo, hi) -> tuple:
    """(tetrahedron, barycentric weights) of the first tetrahedron whose bounding box, then whose
    barycentric coordinates, hold ``point``; (-1, zeros) when none does."""
    span = np.abs(hi - lo).max()
    box = np.all((point >= lo - BARY_TOL * span) & (point <= hi + BARY_TOL * span), axis=1)
    c = np.flatnonzero(box)
    if c.size:
        b = _barycentric(np.repeat(point[None], c.size, 0), xyz[tetra[c]])
        hit = np.flatnonzero(np.all(b >= -BARY_TOL, axis=1))
        if hit.size:
            return c[hit[0]], b[hit[0]]
    return -1, np.zeros(4)


def cell_volumes(cells: Cells, xyz: np.ndarray) -> np.ndarray:
    """Volume of each original FE cell, ndarray of shape (n_cells,), in the unit of ``xyz`` cubed.

    The sum of the volumes of the cell's tetrahedra (exact for cells with planar faces; for a
    hexahedron with warped faces, the volume of its tetrahedral split).
    """
    t = xyz[cells.tetra]
    vol = np.abs(np.linalg.det(t[:, 1:] - t[:, :1])) / 6.0
    return np.bincount(cells.parent, weights=vol, minlength=cells.n_cells)


def node_average(cells: Cells, xyz: np.ndarray, n_points: int) -> sp.csr_matrix:
    """Matrix of shape (n_points, n_cells) averaging cell values to nodes, weighted by cell volume.

    Each cell gives its whole volume (:func:`cell_volumes`) as weight to each of its corner
    nodes (the nodes of its tetrahedra), once: a node's value is
    ``sum_c V_c s_c / sum_c V_c`` over the cells ``c`` that have it as a corner. Nodes of no
    cell (mid-side nodes of quadratic cells, stray points) get an all-zero row.

    Parameters
    ----------
    cells : Cells
    xyz : ndarray of shape (n_points, 3)
        Node coordinates (any length unit: only volume ratios matter).
    n_points : int

    Returns
    -------
    scipy.sparse.csr_matrix
        Rows sum to 1 (or 0 for nodes of no cell); ``node_values = matrix @ cell_values``.
    """
    import scipy.sparse as sp

    corners = sp.csr_matrix(
        (np.ones(cells.tetra.size), (cells.tetra.reshape(-1), np.repeat(cells.parent, 4))), shape=(n_points, cells.n_cells)
    )
    corners.sum_duplicates()
    corners.data[:] = 1.0  # node-cell incidence: a corner shared by several of a cell's tetrahedra counts once
    m = corners @ sp.diags(cell_volumes(cells, xyz))
    norm = np.asarray(m.sum(axis=1)).ravel()
    norm[norm == 0] = 1.0
    return sp.diags(1.0 / norm) @ m


#: on a structured grid have co-spherical subsets whose Delaunay tetrahedralisation holds
#: zero-volume simplices; scipy's ``find_simplex`` cannot walk through those and falls back to a
#: brute-force search (1.2 ms per receptor on the bundled 22,099-point COMSOL table). Joggling
#: the points (seeded), as Qhull's ``QJ`` option does, gives every simplex a volume; the
#: weights are those of the joggled simplex, so a value moves by at most this fraction of the
#: extent times the SED gradient.
JOGGLE = 1e-9


def _triangulate(points: np.ndarray):
    """scipy ``Delaunay`` of points normalised to extent ~1, joggled by :data:`JOGGLE` (seeded)."""
    from scipy.spatial import Delaunay

    return Delaunay(points + np.random.default_rng(0).uniform(-JOGGLE, JOGGLE, points.shape))


def _find(tri, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Simplex of ``tri`` holding each point of ``x`` (-1 where none) and its barycentric weights.

    ``find_simplex`` walks from the simplex it found last, so the points are visited in a
    spatial order (rows of a coarse grid); the walk stops at the hull, so points it misses
    (those exactly on the hull, such as a corner node) are searched again over every simplex:
    callers pass only points inside the hull. The weights come from ``tri.transform``, in the
    order of ``tri.simplices``.
    """
    simplex = np.full(len(x), -1, dtype=np.int64)
    weights = np.zeros((len(x), tri.ndim + 1))
    if not len(x):
        return simplex, weights
    if tri.ndim == 3:
        # scipy's walk often fails in a Delaunay of a structured mesh's nodes (near-flat
        # tetrahedra) and then tests every simplex, ~15 ms per point for 22k points: candidates
        # by nearest centroids first; find_simplex only for the points they miss
        simplex[:], weights[:] = _locate(x, tri.points, tri.simplices, 24)
        rest = np.flatnonzero(simplex < 0)
        if not rest.size:
            return simplex, weights
        simplex[rest], weights[rest] = _find_simplex(tri, x[rest])
        return simplex, weights
    return _find_simplex(tri, x)


def _find_simplex(tri, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_find` by scipy's ``find_simplex`` alone."""
    simplex = np.full(len(x), -1, dtype=np.int64)
    weights = np.zeros((len(x), tri.ndim + 1))
    span = np.ptp(x, axis=0)
    bins = max(1, round(len(x) ** (1 / 3)))
    cell = np.floor((x - x.min(axis=0)) / np.where(span > 0, span, 1.0) * bins)
    order = np.lexsort(cell.T[::-1])
    simplex[order] = tri.find_simplex(x[order], tol=BARY_TOL)
    miss = np.flatnonzero(simplex < 0)
    if miss.size:  # the directed walk gives up on points exactly on the hull (a corner node): search them all
        simplex[miss] = tri.find_simplex(x[miss], tol=BARY_TOL, bruteforce=True)
    hit = np.flatnonzero(simplex >= 0)
    t = tri.transform[simplex[hit]]
    b = np.einsum("mij,mj->mi", t[:, :tri.ndim], x[hit] - t[:, tri.ndim])
    weights[hit] = np.column_stack([b, 1.0 - b.sum(axis=1)])
    bad = hit[~np.all(np.isfinite(weights[hit]), axis=1)]
    simplex[bad], weights[bad] = -1, 0.0
    return simplex, weights


def _inside_hull(points: np.ndarray, equations: np.ndarray, tol: float) -> np.ndarray:
    """Points within ``tol`` of the convex hull whose facets are ``equations`` (scipy ConvexHull)."""
    inside = np.empty(points.shape[0], dtype=bool)
    step = max(1, 4_000_000 // max(1, equations.shape[0]))  # bounded memory: (step, n_facets) at a time
    for a in range(0, points.shape[0], step):
        with np.errstate(over="ignore", invalid="ignore"):  # receptors at +-inf (beyond 1e305 m): NaN/inf, not inside
            d = points[a:a + step] @ equations[:, :-1].T + equations[:, -1]
        inside[a:a + step] = np.all(d <= tol, axis=1)
    return inside
