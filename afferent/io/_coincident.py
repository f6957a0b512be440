"""Coincident points of a mesh export (discontinuous output) merged into nodes: the one element-node rule.

deal.II's ``DataOut`` writes every cell as its own patch, DOLFINx writes DG fields per cell
and FreeFEM's P1dc does the same: each mesh node is then 4-8 points at one place, one per
cell around it, with different values. Sampling such a mesh takes one copy (the one of the
cell the receptor is found in first), so the value at a receptor depends on an arbitrary
choice. Here the copies are found (a KD-tree, tolerance relative to the mesh's shortest cell
edge) and merged into one node.

**The element-node rule** (:func:`element_node_mean`, the one function every reader of
element-node values uses: this merge, MED ``_ELNO``, FEBio's per-element-node variables, Gmsh's
``$ElementNodeData`` and ``.pos`` views): a node's value is the **mean of the values the elements
around it give it, each element once** (unweighted). It is what the tools' own post-processors
show as nodal values: code_aster builds ``_NOEU`` from ``_ELNO`` so (the file's ``ENEL_NOEU``
equals it, tests/test_io_med.py), FEBio's VTK export averages its element-node values so, Gmsh's
``Plugin(Smooth)`` takes the plain mean of the values at a vertex, and VTK's
``vtkCellDataToPointData`` (ParaView's "Cell Data to Point Data") the unweighted mean of the
cells around a point (docs/fe-export.md, "Discontinuous output and material interfaces"). A
point several cells use (copies only where materials meet) counts once per cell using it. The
merge, the number of copies and how far they disagree are recorded
(:attr:`afferent.field.Provenance.coincident`).

Used by :mod:`afferent.io._assemble` (reading) and :mod:`afferent.io._describe` (``afferent info``).
"""

from __future__ import annotations

import numpy as np

from ..field import Cells, NodeSides

__all__ = ["COINCIDENT_RTOL", "COINCIDENT_WARN_RTOL", "coincident_labels", "element_node_mean", "merge_coincident"]

#: The element-node rule, as the coincident report states it.
RULE = "mean of the copies, each element's copy once (the element-node rule)"

#: Points closer than this fraction of the mesh's shortest cell edge are copies of one node.
#: Coordinates written with 6 significant digits are off by up to 5e-6 of their magnitude; a
#: cell edge is rarely below 1e-3 of the model's extent, so copies written in single precision
#: (6e-8 relative) are found, and distinct nodes (one edge apart) never are.
COINCIDENT_RTOL = 1e-6

#: Copies of a node whose SED differs from their mean by more than this fraction of it (at the
#: most loaded step, largest over the nodes) are reported with a warning: the merged value is
#: then an average over cells that disagree (a material interface, a steep gradient on a coarse
#: mesh), not a value any cell had. On the deal.II export of tests/data/dealii (Q1 hexahedra,
#: two materials, 8 x 6 x 8 cells) the copies differ from their node's mean by a median 28 % and
#: up to 1.06 x it: a coarse mesh warns, as it should (its receptor SED depends on the merge).
COINCIDENT_WARN_RTOL = 0.25

#: Nodes whose mean SED is below this fraction of the largest node mean are left out of the
#: disagreement statistics (relative differences of near-zero values say nothing).
SPREAD_FLOOR = 1e-3

_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def shortest_edge(xyz: np.ndarray, tetra: np.ndarray) -> float:
    """Length of the shortest non-zero edge of the tetrahedra, in the unit of ``xyz`` (inf when none).

    :func:`merge_coincident` passes each cell's first tetrahedron, which holds at least two of
    the cell's own edges (hexahedra, wedges, pyramids split as in :mod:`afferent.io._meshio`).
    """
    if not tetra.size:
        return float("inf")
    # one gather of the corners, coordinate by coordinate (contiguous rows), instead of two per edge:
    # 6.6 -> 3.1 ms for the 37,352 cells of sample_sed/block4, the same float (the squares summed x, y, z in turn)
    if 4 * tetra.shape[0] >= xyz.shape[0]:
        corner = np.ascontiguousarray(xyz.T)[:, tetra.T]  # (3, 4, n_tetra)
    else:  # a few tetrahedra (a sample): their corners first, not every point transposed
        corner = np.moveaxis(xyz[tetra.T], 2, 0)
    best = np.inf
    for a, b in _EDGES:
        d = corner[:, a] - corner[:, b]
        sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        best = min(best, float(np.where(sq > 0, sq, np.inf).min()))
    return float(np.sqrt(best))


def _any_in_one_bin(xyz: np.ndarray, tol: float) -> bool:
    """Whether two points fall in one cube of side ``tol`` of a grid: a quick test before the KD-tree.

    Copies of a node written identically always do; copies a round-off apart straddle a cube
    face with a probability of about their distance over ``tol`` each, so an export with many
    copies always has some in one cube. Most exports have none, and skip the KD-tree
    (0.03 s instead of 0.25 s for the 89,739 nodes of sample_sed/block8).
    """
    # coordinate by coordinate, one column at a time: no transposed copy of the points, and memory of two
    # columns (2M points: +0.06 instead of +0.15 GB); the same floats as on the transposed (3, n) array
    xyz = np.asarray(xyz, dtype=float)
    key = None
    for axis, mix in enumerate((np.int64(-7046029254386353131), np.int64(-4417276706812531889), None)):
        col = xyz[:, axis]
        q = col - col.min()
        with np.errstate(invalid="ignore"):  # a cube index beyond int64 (tol ~1e-19 of the extent) casts to one value
            q /= tol
            q = np.floor(q, out=q).astype(np.int64)
        # One integer per cube (wrapping products: two cubes may share one, never one cube two), sorted:
        # 2.2 instead of 5.2 ms for the 41,595 nodes of sample_sed/block4 against a lexsort of the three
        # indices. A shared integer of two cubes only sends the export on to the KD-tree, which decides.
        if mix is not None:
            q *= mix
        key = q if key is None else np.bitwise_xor(key, q, out=key)
    key.sort()
    return bool(np.any(key[1:] == key[:-1]))


def coincident_labels(xyz: np.ndarray, tetra: np.ndarray, rtol: float = COINCIDENT_RTOL):
    """Which points are copies of one node: (labels of shape (n_points,), n_nodes, tolerance) or None.

    ``labels[p]`` is the node of point ``p``; nodes are numbered in the order of their first
    copy. The tolerance (unit of ``xyz``) is ``rtol`` x the shortest cell edge, so the copies of
    a node are all within it of one another and far from every other node: each point joins
    the lowest-numbered point within the tolerance. None when no two points are that close.
    """
    tol = rtol * shortest_edge(xyz, tetra)
    if not np.isfinite(tol) or xyz.shape[0] < 2 or not _any_in_one_bin(xyz, tol):
        return None
    if np.abs(xyz).max() > 1e150:  # no mesh's coordinates: scipy's k-d tree overflows; left to the readers' checks
        return None
    from scipy.spatial import cKDTree

    pairs = cKDTree(xyz).query_pairs(tol, output_type="ndarray")  # rows i < j
    if not len(pairs):
        return None
    first = np.arange(xyz.shape[0])
    np.minimum.at(first, pairs[:, 1], pairs[:, 0])
    uniq, labels = np.unique(first, return_inverse=True)  # first copies are numbered in point order
    return labels.ravel(), int(uniq.size), float(tol)


#: The last search: [(weak reference to its Cells, rtol, weak reference to its coordinates when they are read-only
#: (else None), BLAKE2 digest of the coordinates when they are writable (else None), result, what
#: merge_coincident derived from that mesh)].
_LAST: list = []


def _digest(xyz: np.ndarray) -> tuple:
    import hashlib

    data = np.ascontiguousarray(xyz)
    return data.shape, data.dtype.str, hashlib.blake2b(memoryview(data).cast("B"), digest_size=16).digest()


def _same_coordinates(last, xyz: np.ndarray) -> bool:
    """Whether ``xyz`` holds the coordinates the search ``last`` was made on."""
    old = last[2]() if last[2] is not None else None
    if old is not None:  # read-only, so unchanged since: compared as they are (the same array: no pass at all)
        return old is xyz or (old.shape == xyz.shape and old.dtype == xyz.dtype and np.array_equal(old, xyz))
    return last[3] is not None and last[3] == _digest(xyz)


#: Cells whose shortest edge sizes the quick test's cubes (spread over the mesh).
_SAMPLE_CELLS = 4096


def _may_have_copies(xyz: np.ndarray, cells: Cells, rtol: float) -> bool:
    """:func:`_any_in_one_bin` with cubes of ``rtol`` x the shortest edge of up to :data:`_SAMPLE_CELLS`
    cells spread over the mesh, before the shortest edge of every cell is measured.

    That edge is no shorter than the mesh's shortest, so the cubes are no smaller than the
    tolerance: copies of a node written identically share one as before, copies a round-off
    apart straddle a face less often, and an export that may hold copies goes on to
    :func:`coincident_labels`, which measures every cell and decides. Most exports hold none
    and skip that measure: 3.5 of the 10 ms of sample_sed/block4's assembly (41,595 nodes).
    """
    if xyz.shape[0] < 2 or not cells.n_tetra:
        return False
    step = max(1, cells.n_cells // _SAMPLE_CELLS)
    if not cells.split_done:  # Cells.split: the sampled cells' first tetrahedra alone, the others not split
        cube = rtol * shortest_edge(xyz, cells.rows(cells.tetra_rows(np.arange(0, cells.n_cells, step), first=True))[0])
        return bool(np.isfinite(cube)) and _any_in_one_bin(xyz, cube)
    parent = cells.parent
    if parent[0] == 0 and np.all(parent[1:] >= parent[:-1]):  # the readers' order: first tetrahedra found by bisection
        first = np.searchsorted(parent, np.arange(0, int(parent[-1]) + 1, step))
    else:
        first = _first_of_each(parent)[::step]
    cube = rtol * shortest_edge(xyz, cells.tetra[first])
    return bool(np.isfinite(cube)) and _any_in_one_bin(xyz, cube)


def _labels_of(xyz: np.ndarray, cells: Cells, rtol: float, *, same_mesh: bool = False):
    """:func:`coincident_labels` of each cell's first tetrahedron, remembered for the same Cells and coordinates.

    :func:`afferent.io.iter_sed` gives every step of a series the first step's Cells object
    (the mesh read once): the search (0.03 s for 100,000 points, most of it the shortest edge)
    then runs once per series instead of once per step. Read-only coordinates (the mesh
    readers': :func:`afferent.io._meshio.raw_from_mesh`) are remembered by a weak reference
    and compared as they are; writable ones by a BLAKE2 digest of their bytes (~1 ms for
    100,000 points); ``same_mesh`` (the caller knows they are those of the last call: a series'
    next step) skips the comparison. Only weak references are kept, so nothing outlives the
    series. Returns ``(found, mesh)``: ``mesh`` is a dict kept beside the result, where
    :func:`merge_coincident` keeps what it derives from the mesh alone (merged cells, copy
    operators, material groups) for the next step.
    """
    import weakref

    last = _LAST[0] if _LAST else None  # read once: another thread may replace it meanwhile
    if last is not None and last[0]() is cells and last[1] == rtol and (same_mesh or _same_coordinates(last, xyz)):
        return last[4], last[5]
    found = None
    if _may_have_copies(xyz, cells, rtol):
        found = coincident_labels(xyz, cells.tetra[_first_of_each(cells.parent)], rtol)
    frozen = not xyz.flags.writeable
    mesh: dict = {}
    _LAST[:] = [(weakref.ref(cells), rtol, weakref.ref(xyz) if frozen else None, None if frozen else _digest(xyz), found,
                 mesh)]
    return found, mesh


def _point_cells(cells: Cells):
    """(point, cell) for each point and each cell using it as a corner (once), sorted by point, then cell: the
    element-node copies of the mesh.

    The pairs as one int64 key ``point * n_cells + cell``: a 1-D unique, ~20x faster than the
    row-wise ``np.unique(axis=0)`` of the pairs (0.076 -> 0.004 s for 125,000 points), the same order.
    """
    n = max(int(cells.n_cells), 1)
    key = np.unique(cells.tetra.reshape(-1) * n + np.repeat(cells.parent, 4))
    return np.divmod(key, n)


def _sides_operator(labels: np.ndarray, cells: Cells, pairs, n_points: int):
    """What the material sides need of the mesh alone: (averaging operator of shape (n_node_materials, n_points),
    node of each row, material of each row, rows of nodes where several materials meet), or None when no node
    has several (or there are no material ids). ``pairs``: :func:`_point_cells`; the element-node rule within
    each material."""
    if cells.materials is None:
        return None
    point, cell = pairs
    mats, mat_of = np.unique(cells.materials[cell], return_inverse=True)
    key = labels[point] * mats.size + mat_of.ravel()
    uniq, col = np.unique(key, return_inverse=True)
    node, mat = uniq // mats.size, uniq % mats.size
    several = np.bincount(node, minlength=int(labels.max()) + 1)[node] > 1
    if not several.any():
        return None
    return element_node_operator(col.ravel(), uniq.size, point, n_points), node[several], mats[mat[several]], several


def _node_sides(sed: np.ndarray, operator) -> NodeSides | None:
    """Per node and material, the mean of the node's copies in cells of that material (the element-node rule), kept only
    for nodes where several materials meet; ``sed`` point data (n_times, n_points), any unit; ``operator``:
    :func:`_sides_operator` (None: no sides)."""
    if operator is None:
        return None
    m, nodes, materials, several = operator
    return NodeSides(nodes, materials, np.asarray((m @ sed.T).T)[:, several])


def element_node_operator(node: np.ndarray, n_nodes: int, source: np.ndarray | None = None,
                          n_sources: int | None = None):
    """The element-node rule as a sparse (n_nodes, n_sources) operator: row ``i`` is the mean of the copies of
    node ``i``, each copy (one element's value at the node) weighing 1.

    ``node[c]``: the node of copy ``c``; ``source[c]``: the column holding its value (default ``c``;
    a column listed twice, a point two cells use, counts twice). Rows of nodes without a copy are empty.
    """
    import scipy.sparse as sp

    node = np.asarray(node, dtype=np.int64).ravel()
    source = np.arange(node.size) if source is None else np.asarray(source, dtype=np.int64).ravel()
    count = np.bincount(node, minlength=n_nodes)
    return sp.csr_matrix((1.0 / count[node], (node, source)),
                         shape=(n_nodes, node.size if n_sources is None else n_sources))


def element_node_mean(node: np.ndarray, values: np.ndarray, n_nodes: int) -> np.ndarray:
    """Element-node values (each element's own value at each of its nodes) at the nodes: the element-node rule.

    Parameters
    ----------
    node : ndarray of int, shape (n_copies,)
        The node (0 .. n_nodes - 1) of each copy: an element's connectivity, flattened.
    values : ndarray of shape (n_copies, ...)
        Each copy's value (any unit); copies with a non-finite value (an element the field does not
        cover) are left out.
    n_nodes : int

    Returns
    -------
    ndarray of shape (n_nodes, ...)
        The mean of each node's copies, each element once; NaN at nodes without a copy.
    """
    node = np.asarray(node, dtype=np.int64).ravel()
    values = np.asarray(values, dtype=float)
    flat = values.reshape(node.size, -1)
    ok = np.isfinite(flat).all(axis=1)
    out = np.asarray(element_node_operator(node[ok], n_nodes) @ flat[ok])
    out[np.bincount(node[ok], minlength=n_nodes) == 0] = np.nan
    return out.reshape((n_nodes,) + values.shape[1:])


def _copies(labels: np.ndarray, pairs, n_nodes: int):
    """(node, point) of each copy of the mesh: each (point, cell using it) pair, and each point no cell uses
    where its node has no other copy (its value then stands alone)."""
    point = pairs[0]
    orphan = np.setdiff1d(np.arange(labels.size), point)
    orphan = orphan[np.bincount(labels[point], minlength=n_nodes)[labels[orphan]] == 0]
    point = np.concatenate([point, orphan])
    return labels[point], point


def _disagreement(sed: np.ndarray, labels: np.ndarray, mean: np.ndarray, counts: np.ndarray) -> dict:
    """How far copies differ from their node's mean, at the most loaded step (relative to the mean)."""
    step = int(np.argmax(sed.sum(axis=1))) if sed.size else 0
    dev = np.zeros(mean.shape[1])
    np.maximum.at(dev, labels, np.abs(sed[step] - mean[step, labels]))
    m = mean[step]
    top = float(m.max(initial=0.0))
    ok = (counts > 1) & (m > SPREAD_FLOOR * top) if top > 0 else np.zeros_like(counts, bool)
    rel = dev[ok] / m[ok]
    node = int(np.flatnonzero(ok)[np.argmax(rel)]) if rel.size else -1
    return {"step": step, "nodes_compared": int(ok.sum()),
            "median_relative": float(np.median(rel)) if rel.size else 0.0,
            "max_relative": float(rel.max()) if rel.size else 0.0, "max_node": node}


def _first_of_each(parent: np.ndarray) -> np.ndarray:
    """Index of the first tetrahedron of each cell: where ``parent`` changes when it is sorted (as
    the readers build it: 0.4 instead of 3.4 ms for sample_sed/block4's 224,112), else np.unique's."""
    if parent.size and np.all(parent[1:] >= parent[:-1]):
        return np.flatnonzero(np.concatenate([[True], parent[1:] != parent[:-1]]))
    return np.unique(parent, return_index=True)[1]


def merge_coincident(xyz: np.ndarray, sed: np.ndarray, location: str, cells: Cells, rtol: float = COINCIDENT_RTOL, *,
                     same_mesh: bool = False):
    """Merge coincident points into nodes: (xyz, sed, cells, report) or the inputs and None when there are none.

    Parameters
    ----------
    xyz : ndarray of shape (n_points, 3)
        Coordinates (any length unit).
    sed : ndarray of shape (n_times, n_values)
        SED (any unit); point values are merged, cell values are kept.
    location : {'point', 'cell'}
    cells : Cells
        The mesh; its tetrahedra are renumbered onto the nodes.

    Returns
    -------
    xyz, sed, cells, report, sides
        Node coordinates (those of each node's first copy), SED (point data: the element-node
        rule, the mean of the copies each element once, see the module docstring), the renumbered cells, and ``report``
        (dict): ``n_points`` (before), ``n_nodes``, ``n_copies_merged`` (points removed),
        ``max_copies`` (copies of the most copied node), ``tolerance`` (unit of ``xyz``),
        ``rule``, and for point data ``step``, ``nodes_compared``, ``median_relative``,
        ``max_relative`` (copies' largest difference from their node's mean over that mean),
        ``max_node`` and, with material ids, ``within_material`` (the same among the copies of
        one material: the mesh's own discontinuity, apart from the interface's jump); ``sides`` (:class:`~afferent.field.NodeSides` or None): for point data
        on cells with material ids, the mean of each material's copies where materials meet.

    ``same_mesh``: ``xyz`` are the coordinates of the last call with these ``cells`` (a series' next
    step, :func:`afferent.io._assemble.assemble`): the coincident points are not searched again.
    """
    found, mesh = _labels_of(xyz, cells, rtol, same_mesh=same_mesh)
    if found is None:
        return xyz, sed, cells, None, None
    labels, n_nodes, tol = found
    n = xyz.shape[0]
    if "merged" not in mesh:  # what depends on the mesh alone: once per mesh (a series' steps share it)
        counts = np.bincount(labels, minlength=n_nodes)
        first = np.full(n_nodes, n, dtype=np.int64)
        np.minimum.at(first, labels, np.arange(n))
        mesh.update(counts=counts, xyz=xyz[first], merged=Cells(
            labels[cells.tetra], cells.parent, cells.n_cells, cells.cell_types, materials=cells.materials,
            nodes=cells.renumbered_nodes(labels)))
    counts, nodes_xyz, merged = mesh["counts"], mesh["xyz"], mesh["merged"]
    report = {"n_points": int(n), "n_nodes": int(n_nodes), "n_copies_merged": int(n - n_nodes),
              "max_copies": int(counts.max()), "tolerance": tol,
              "rule": RULE}
    if location == "point":
        if "mean" not in mesh:
            mesh["pairs"] = _point_cells(cells)
            node, point = _copies(labels, mesh["pairs"], n_nodes)
            mesh["mean"] = element_node_operator(node, n_nodes, point, n)
            mesh["sides"] = _sides_operator(labels, cells, mesh["pairs"], n)
        mean = np.asarray((mesh["mean"] @ sed.T).T)
        report.update(_disagreement(sed, labels, mean, counts))
        if cells.materials is not None:  # copies of one material: the mesh's own discontinuity, not the interface's
            if "groups" not in mesh:
                point, cell = mesh["pairs"]
                mat = np.zeros(n, dtype=np.int64)
                mat[point] = cells.materials[cell]
                groups, group = np.unique(labels * (int(mat.max()) + 1) + (mat - mat.min()), return_inverse=True)
                group = group.ravel()
                node, point = _copies(group, mesh["pairs"], groups.size)
                mesh["groups"] = (group, np.bincount(group, minlength=groups.size),
                                  element_node_operator(node, groups.size, point, n))
            group, group_counts, group_mean = mesh["groups"]
            within = _disagreement(sed, group, np.asarray((group_mean @ sed.T).T), group_counts)
            report["within_material"] = {k: within[k] for k in ("median_relative", "max_relative", "nodes_compared")}
        return nodes_xyz, mean, merged, report, _node_sides(sed, mesh["sides"])
    return nodes_xyz, sed, merged, report, None
