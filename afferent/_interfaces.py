"""Receptors on a material interface: which materials meet there, the SED on each side, the side used.

Receptor sites (papilla tips, ridge bases) lie on the epidermis/dermis interface, where
stress, strain and SED jump. What a receptor gets there depends on a choice that used to be
silent: ``'nearest'`` on cell data takes whichever adjacent cell the point search meets
first, nodal values from a tool are averages across the materials. Here the choice is
explicit (``side``):

* ``'average'`` (the default): the value the sampling method gives, which for a receptor on an
  interface is an average across the materials that meet there (cell data averaged to the
  nodes by volume, a tool's nodal average, or the mean of discontinuous copies). The default
  because an FE receptor site on the interface is, at the mesh's resolution, on both sides, and
  because it is continuous: a receptor moved by a round-off does not jump between materials.
* a material id (e.g. the dermis: Meissner corpuscles lie in the dermal papillae): for
  receptors whose neighbourhood holds that material, the SED of that material alone (cell
  data: its adjacent cells averaged by volume; point data: linear in a tetrahedron of that
  material, with the material's own copies of the interface nodes when the export was
  discontinuous). Receptors away from the interface, or on an interface without that
  material, keep the default.

The spread between the sides is reported per receptor and a warning is given when it exceeds
:data:`INTERFACE_SPREAD_WARN`. Lengths in m, SED in J/m^3.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ._mesh_geometry import BARY_TOL, _barycentric
from .exceptions import AfferentWarning

__all__ = ["SIDE_AVERAGE", "INTERFACE_SPREAD_WARN", "check_side", "InterfaceSampler", "build_interface",
           "interface_report", "apply_side", "sided"]

SIDE_AVERAGE = "average"

#: Spread between the sides of an interface at a receptor ((largest - smallest side SED) over
#: their mean, at the receptor's most loaded step) above which a warning is given: the choice
#: of side then changes that receptor's SED by more than a quarter. Measured at the papilla tips
#: of the bundled sample (scikit-fem hexahedra, cell SED): a median 16 %, up to 27 %; at the
#: interface receptors of the deal.II export of tests/data/dealii: a median 26 %, up to 39 %.
INTERFACE_SPREAD_WARN = 0.25


def check_side(side) -> str | int:
    """``'average'`` or a material id (an int, or a string of one): the side option, checked."""
    if isinstance(side, str) and side.strip().lower() == SIDE_AVERAGE:
        return SIDE_AVERAGE
    try:
        if isinstance(side, bool) or float(side) != int(float(side)):
            raise ValueError
        return int(float(side))
    except (TypeError, ValueError):
        raise ValueError(f"'side' must be 'average' or a material id (a whole number); got {side!r} instead.") from None


@dataclass(frozen=True)
class InterfaceSampler:
    """Weights giving, for each receptor on an interface and each material there, that material's SED.

    ``side values = w_values @ field values + w_sides @ field.sides.sed`` (per step).

    Parameters
    ----------
    receptor : ndarray of shape (p,), int
        Receptor index of each (receptor, material) row.
    material : ndarray of shape (p,), int
    w_values : scipy.sparse.csr_matrix of shape (p, n_values)
    w_sides : scipy.sparse.csr_matrix of shape (p, k) or None
        Weights on the field's :class:`~afferent.field.NodeSides`, when it has them.
    materials_at : tuple of tuple of int
        Materials of the cells touching each receptor (empty outside the mesh).
    w_average : scipy.sparse.csr_matrix of shape (n_on_interface, n_cells) or None
        Cell data: every adjacent cell of the receptors on an interface (``np.unique(receptor)``),
        by volume: side ``'average'`` (``'nearest'`` would take one adjacent cell, whichever the
        point search meets first). None for point data.
    """

    receptor: np.ndarray
    material: np.ndarray
    w_values: object
    w_sides: object
    materials_at: tuple
    w_average: object = None

    def values(self, field) -> np.ndarray:
        """Side SED of shape (n_times, p), J/m^3, for one field on the sampler's mesh."""
        out = np.asarray((self.w_values @ np.asarray(field.sed, dtype=float).T).T)
        if self.w_sides is not None and field.sides is not None:
            out = out + np.asarray((self.w_sides @ field.sides.sed.T).T)
        return out

    def step_values(self, field) -> tuple:
        """(:meth:`values`, :meth:`average`) for one field."""
        return self.values(field), self.average(field)

    def average(self, field) -> np.ndarray | None:
        """Side ``'average'`` of shape (n_times, n_on_interface), J/m^3, for cell data; None for point data."""
        if self.w_average is None:
            return None
        return np.asarray((self.w_average @ np.asarray(field.sed, dtype=float).T).T)


#: Receptor-tetrahedron candidate pairs examined at once by :func:`_touching` (~150 bytes each): the
#: receptors are taken in chunks of about this many candidates, so that memory does not grow with
#: their number (before: every pair at once, ~30 kB a receptor, 3 GB for 1e5 receptors).
PAIRS_PER_CHUNK = 1 << 20


def _touching(field, positions: np.ndarray, k: int = 4, pairs_per_chunk: int = PAIRS_PER_CHUNK):
    """Every (receptor, tetrahedron) pair where the tetrahedron holds the receptor, receptor chunk by
    chunk: yields ``(start, stop, receptor, tet, bary)`` for the receptors ``start:stop`` in turn
    (receptor indices into ``positions``; the pairs in receptor order).

    Candidates: the tetrahedra touching the receptor's ``k`` nearest nodes (a receptor at a node
    has that node first; a tetrahedron holding a point nearly always has a corner among its 4
    nearest nodes - only badly shaped cells escape); those whose bounding box, widened by 1e-3
    of its size (a thousand times the barycentric tolerance), misses the receptor are dropped
    before the barycentric coordinates are solved. A chunk holds at most ``pairs_per_chunk``
    candidates (one receptor with more is a chunk of its own).
    """
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    xyz, tetra = field.points, field.cells.tetra
    n = positions.shape[0]
    _, near = cKDTree(xyz).query(positions, k=min(k, xyz.shape[0]))
    near = np.asarray(near).reshape(n, -1)
    touched = np.zeros(xyz.shape[0], bool)
    touched[near.ravel()] = True
    subset = np.flatnonzero(touched[tetra].any(axis=1))
    inc = sp.csr_matrix((np.ones(4 * subset.size), (tetra[subset].ravel(), np.repeat(np.arange(subset.size), 4))),
                        shape=(xyz.shape[0], subset.size))
    lo, hi = np.empty((subset.size, 3)), np.empty((subset.size, 3))
    for a in range(0, subset.size, PAIRS_PER_CHUNK):  # the subset's bounding boxes, a chunk of corners at a time
        corners = xyz[tetra[subset[a:a + PAIRS_PER_CHUNK]]]
        lo[a:a + PAIRS_PER_CHUNK], hi[a:a + PAIRS_PER_CHUNK] = corners.min(axis=1), corners.max(axis=1)
    pad = 1e-3 * (hi - lo).max(axis=1, keepdims=True)
    boxes = [(np.ascontiguousarray(positions[:, a]), lo[:, a] - pad[:, 0], hi[:, a] + pad[:, 0]) for a in range(3)]
    candidates = np.diff(inc.indptr)[near].sum(axis=1)  # per receptor, at most (a tetrahedron met at several nodes once)
    cuts = np.searchsorted(np.cumsum(candidates), np.arange(pairs_per_chunk, candidates.sum(), pairs_per_chunk), "right")
    bounds = np.unique(np.concatenate([[0], cuts, [n]]))
    for start, stop in zip(bounds[:-1], bounds[1:]):
        nn = np.sort(near[start:stop], axis=1)  # node order, as a sparse matrix built from pairs holds them
        rec = sp.csr_matrix((np.ones(nn.size), nn.ravel(), np.arange(0, nn.size + 1, nn.shape[1])),
                            shape=(stop - start, xyz.shape[0]))
        pairs = (rec @ inc).tocoo()
        r, c = pairs.row.astype(np.int64) + start, pairs.col
        for at, low, high in boxes:  # axis by axis, on the pairs left (3x quicker than the three at once)
            x = at[r]
            inside = (x >= low[c]) & (x <= high[c])
            r, c = r[inside], c[inside]
        t = subset[c]
        bary = _barycentric(positions[r], xyz[tetra[t]])
        ok = np.all(bary >= -BARY_TOL, axis=1)
        yield int(start), int(stop), r[ok], t[ok], bary[ok]


def build_interface(field, layout, pairs_per_chunk: int = PAIRS_PER_CHUNK) -> InterfaceSampler | None:
    """The per-material weights at the receptors that touch cells of several materials; None without material ids.

    The receptors are taken in chunks (:func:`_touching`, ``pairs_per_chunk``): memory is the
    chunk's and the result's, whatever their number; the result does not depend on the chunks.
    """
    import scipy.sparse as sp

    from ._mesh_geometry import cell_volumes

    cells = field.cells
    if cells is None or cells.materials is None:
        return None
    vol = cell_volumes(cells, field.points) if field.location == "cell" else None
    materials_at, parts = [], []
    for start, stop, r, t, bary in _touching(field, layout.positions, pairs_per_chunk=pairs_per_chunk):
        parts.append(_chunk_rows(cells, start, stop, r, t, bary, vol, materials_at))
    materials_at = tuple(materials_at)
    rows = np.concatenate([part[0] for part in parts]) if parts else np.zeros((0, 2), np.int64)
    p = rows.shape[0]
    if vol is not None:  # adjacent cells of the material, by volume (each cell once)
        pc, ra = _offset_pairs([part[1] for part in parts]), _offset_pairs([part[2] for part in parts])
        w = sp.csr_matrix((vol[pc[:, 1]], (pc[:, 0], pc[:, 1])), shape=(p, cells.n_cells))
        n_on = int(sum(part[3] for part in parts))
        w_avg = sp.csr_matrix((vol[ra[:, 1]], (ra[:, 0], ra[:, 1])), shape=(n_on, cells.n_cells))
        return InterfaceSampler(rows[:, 0], rows[:, 1], _normalised(w), None, materials_at, _normalised(w_avg))
    nodes = np.concatenate([part[1] for part in parts]).ravel() if parts else np.zeros(0, np.int64)
    wts = np.concatenate([part[2] for part in parts]).ravel() if parts else np.zeros(0)
    if field.sides is None:
        return InterfaceSampler(rows[:, 0], rows[:, 1], _csr_rows(p, nodes, wts, None, field.n_points), None, materials_at)
    side_col = _side_columns(field, nodes, np.repeat(rows[:, 1], 4))
    on_side = side_col >= 0
    w_values = _csr_rows(p, nodes, wts, ~on_side, field.n_points)
    w_sides = _csr_rows(p, side_col, wts, on_side, field.sides.nodes.size)
    return InterfaceSampler(rows[:, 0], rows[:, 1], w_values, w_sides, materials_at)


def _csr_rows(p: int, columns: np.ndarray, weights: np.ndarray, keep: np.ndarray | None, n_columns: int):
    """The (p, n_columns) sparse matrix whose row i holds ``weights[4i:4i+4]`` at ``columns[4i:4i+4]`` (those
    ``keep`` says, all when None), built as CSR directly (not through (row, column) pairs: half the memory),
    indices sorted in each row as a matrix built from pairs holds them."""
    import scipy.sparse as sp

    if keep is None:
        indptr = np.arange(0, 4 * p + 1, 4)
    else:
        indptr = np.concatenate([[0], np.cumsum(keep.reshape(p, 4).sum(axis=1))])
        columns, weights = columns[keep], weights[keep]
    out = sp.csr_matrix((weights, columns, indptr), shape=(p, n_columns))
    out.sort_indices()
    return out


def _chunk_rows(cells, start: int, stop: int, r, t, bary, vol, materials_at: list) -> tuple:
    """What :func:`build_interface` keeps of one chunk of receptors (``start:stop``; their touching pairs
    ``r, t, bary``), the chunk's materials per receptor appended to ``materials_at``: the (receptor,
    material) rows of the receptors touching several materials, sorted; then, for cell data, the
    (row, cell) and (receptor on an interface, cell) pairs (indices within the chunk) and the number of
    those receptors; for point data, one tetrahedron of the material per row (its corners and weights)."""
    cell = cells.parent[t]
    mat = cells.materials[cell]
    rm = np.unique(np.column_stack([r, mat]), axis=0)  # (receptor, material) pairs, sorted
    bounds = np.searchsorted(rm[:, 0], np.arange(start, stop + 1))
    materials_at.extend(tuple(rm[a:b, 1].tolist()) for a, b in zip(bounds[:-1], bounds[1:]))
    several = np.diff(bounds) > 1
    keep = several[r - start]
    r, t, bary, cell, mat = r[keep], t[keep], bary[keep], cell[keep], mat[keep]
    rows, inverse = np.unique(np.column_stack([r, mat]), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    if vol is not None:
        pc = np.unique(np.column_stack([inverse, cell]), axis=0)
        on, at = np.unique(r, return_inverse=True)
        ra = np.unique(np.column_stack([at.ravel(), cell]), axis=0)
        return rows, (pc, rows.shape[0]), (ra, on.size), on.size
    first = np.unique(inverse, return_index=True)[1]  # one tetrahedron of the material per row
    return rows, cells.tetra[t[first]], bary[first]


def _offset_pairs(parts: list) -> np.ndarray:
    """(row, column) pairs of the chunks, each chunk's rows shifted past the rows of the chunks before it
    (``parts``: (pairs, number of rows) per chunk)."""
    out, offset = [], 0
    for pairs, n_rows in parts:
        out.append(pairs + np.array([offset, 0]))
        offset += n_rows
    return np.concatenate(out) if out else np.zeros((0, 2), np.int64)


def _normalised(w):
    import scipy.sparse as sp

    norm = np.asarray(w.sum(axis=1)).ravel()
    norm[norm == 0] = 1.0
    return (sp.diags(1.0 / norm) @ w).tocsr()


def _side_columns(field, nodes: np.ndarray, materials: np.ndarray) -> np.ndarray:
    """Column of (node, material) in ``field.sides`` (-1 where it has none)."""
    if field.sides is None or not nodes.size or not field.sides.nodes.size:
        return np.full(nodes.shape, -1, dtype=np.int64)
    have_n, have_m = np.asarray(field.sides.nodes, np.int64), np.asarray(field.sides.materials).astype(np.int64)
    want_n, want_m = np.asarray(nodes, np.int64), np.asarray(materials).astype(np.int64)
    low = min(have_m.min(), want_m.min())
    span = max(have_m.max(), want_m.max()) - low + 1
    keys = have_n * span + (have_m - low)  # one integer per (node, material)
    order = np.argsort(keys, kind="stable")
    at = np.searchsorted(keys[order], want_n * span + (want_m - low), side="right") - 1  # a pair listed twice: its last
    found = (at >= 0) & (keys[order][np.maximum(at, 0)] == want_n * span + (want_m - low))
    return np.where(found, order[np.maximum(at, 0)], -1)


def _check_material(field, side: int) -> None:
    """A material side needs material ids, and that material among them."""
    from .io._find_arrays import MATERIAL_ARRAY_NAMES

    files = field.provenance.files
    of = f" of SED file {files[0]!r}" if files else ""
    if field.cells is None or field.cells.materials is None:
        raise ValueError(f"side={side!r} needs the material id of each cell; the field{of} has none (no cell array "
                         f"named like {', '.join(MATERIAL_ARRAY_NAMES[:7])}, ...). Use side='average'.")
    present = sorted(int(m) for m in np.unique(field.cells.materials))
    if side not in present:
        raise ValueError(f"side={side!r} must be one of the materials{of} (array "
                         f"{field.provenance.columns.get('material', '')!r}: {', '.join(map(str, present))}) or 'average'.")


def _separable(field) -> bool:
    """Whether the field holds each material's own SED at an interface: cell data, or per-material node copies."""
    return field.location == "cell" or field.sides is not None


def _refuse_inseparable(field, side: int, n_on: int) -> None:
    """A material's side asked of point data with one value per node: the tool averaged the sides before export."""
    files = field.provenance.files
    of = f" of SED file {files[0]!r}" if files else ""
    array = field.provenance.columns.get("sed", "")
    raise ValueError(
        f"side={side!r} asks for material {side}'s SED at the {n_on} receptors on an interface between materials, but "
        f"the SED{of}{f' (array {array!r})' if array else ''} is point data with one value per node, shared by the "
        "materials that meet there (the FE tool averaged them before export): the sides cannot be told apart. Read "
        "cell data (location='cell'; a scene: [export] location = \"cell\") or per-element node output, or use "
        "side='average'.")


def apply_side(values: np.ndarray, isamp: InterfaceSampler | None, side_values: np.ndarray, side,
               average: np.ndarray | None = None) -> np.ndarray:
    """``values`` (n_times, n_receptors) with the side's SED at the receptors on an interface.

    ``side`` a material id: that material's SED where it meets others; ``'average'``: ``average``
    (n_times, n_on_interface; cell data: every adjacent cell by volume) when given, else unchanged.
    """
    if isamp is None or (side == SIDE_AVERAGE and average is None):
        return values
    out = np.array(values, dtype=float)
    if side == SIDE_AVERAGE:
        out[:, np.unique(isamp.receptor)] = average
        return out
    pick = isamp.material == side
    out[:, isamp.receptor[pick]] = side_values[:, pick]
    return out


def interface_report(field, layout, isamp: InterfaceSampler | None, values: np.ndarray, side_values: np.ndarray,
                     side, *, warn: bool = True) -> dict | None:
    """What the interface does to the receptors' SED, for the run record; warns when the sides differ a lot and no
    side was chosen (``side='average'``).

    Parameters
    ----------
    field : SEDField
        The (first) field sampled: its material array and location are named in the report.
    values : ndarray of shape (n_times, n_receptors)
        SED with ``side='average'`` (J/m^3).
    side_values : ndarray of shape (n_times, p)
        :meth:`InterfaceSampler.values` over the same steps.

    Returns
    -------
    dict or None
        None without material ids. Else ``side``, ``material_array``, ``materials`` (ids present),
        ``n_on_interface``, ``n_changed`` (receptors whose SED is the chosen material's),
        ``interfaces`` (receptor count per set of materials), ``separable`` (False for point data
        without per-material copies: the sides then share the tool's nodal values), ``median_spread``,
        ``max_spread``, ``warn_above`` and ``receptors``: per receptor on an interface, its id,
        ``materials``, the ``step`` compared (its most loaded), ``sed_pa`` per material, ``average_pa``
        and ``spread`` ((largest - smallest side) over their mean).
    """
    if isamp is None:
        return None
    separable = _separable(field)
    order = np.argsort(isamp.receptor, kind="stable")
    receptors, starts = np.unique(isamp.receptor[order], return_index=True)
    counts = np.diff(np.append(starts, order.size))
    steps = _loaded_steps(values, receptors)
    sides = side_values[np.repeat(steps, counts), order] if order.size else np.zeros(0)
    means = np.add.reduceat(sides, starts) / counts if order.size else np.zeros(0)
    widths = np.maximum.reduceat(sides, starts) - np.minimum.reduceat(sides, starts) if order.size else np.zeros(0)
    with np.errstate(divide="ignore", invalid="ignore"):
        spreads = np.where(means > 0, widths / means, 0.0)
    ids, names = layout.ids.tolist(), [str(m) for m in isamp.material[order].tolist()]
    side_list, averages, bounds = sides.tolist(), values[steps, receptors].tolist(), np.append(starts, order.size).tolist()
    per, interfaces, keys = [], {}, {}  # keys: materials -> 'm1/m2', joined once per set of materials
    for k, (i, step, spread) in enumerate(zip(receptors.tolist(), steps.tolist(), spreads.tolist())):
        mats, a, b = isamp.materials_at[i], bounds[k], bounds[k + 1]
        key = keys.get(mats) or keys.setdefault(mats, "/".join(str(m) for m in mats))
        interfaces[key] = interfaces.get(key, 0) + 1
        per.append({"receptor": ids[i], "materials": list(mats), "step": step, "sed_pa": dict(zip(names[a:b], side_list[a:b])),
                    "average_pa": averages[k], "spread": spread})
    report = {
        "side": side, "default": SIDE_AVERAGE, "material_array": field.provenance.columns.get("material", ""),
        "materials": sorted({int(m) for m in np.unique(field.cells.materials)}),
        "n_on_interface": len(per), "n_changed": 0 if side == SIDE_AVERAGE else int(np.sum(isamp.material == side)),
        "interfaces": interfaces, "separable": bool(separable),
        "median_spread": float(np.median(spreads)) if per else 0.0, "max_spread": float(spreads.max()) if per else 0.0,
        "warn_above": INTERFACE_SPREAD_WARN, "receptors": per,
    }
    if warn and per and report["max_spread"] > INTERFACE_SPREAD_WARN and side == SIDE_AVERAGE:  # a chosen side: no news
        worst = per[int(np.argmax(spreads))]
        warnings.warn(
            f"{len(per)} of {layout.n_receptors} receptors lie on an interface between materials "
            f"({', '.join(f'{k}: {v}' for k, v in interfaces.items())}; array {report['material_array']!r}), where the SED of "
            f"the sides differs by a median {report['median_spread']:.2g} and up to {report['max_spread']:.2g} x their mean "
            f"(receptor {worst['receptor']!r}: {', '.join(f'material {m} {v:.4g}' for m, v in worst['sed_pa'].items())} J/m^3; "
            f"warned above {INTERFACE_SPREAD_WARN:g}). Using side={side!r} (the average across the materials); choose a "
            "material with side=ID where the ending sits on one side (Meissner corpuscles: the dermis).",
            AfferentWarning, stacklevel=3)
    return report


def _loaded_steps(values: np.ndarray, receptors: np.ndarray) -> np.ndarray:
    """Each receptor's most loaded step (its largest value, NaN left out; 0 when none is finite), as ``np.nanargmax``."""
    if not receptors.size:
        return np.zeros(0, dtype=np.int64)
    v = values[:, receptors]
    return np.where(np.isfinite(v).any(axis=0), np.where(np.isnan(v), -np.inf, v).argmax(axis=0), 0)


def sided(sed, first, isamp, steps: list, side, *, stacklevel: int = 3):
    """A :class:`~afferent.sampling.ReceptorSED` with the side chosen at the receptors on a material interface.

    ``sed`` holds what the sampling method gave; ``steps`` is, per field sampled, the pair
    (:meth:`InterfaceSampler.values`, :meth:`InterfaceSampler.average`). The interface report
    (:func:`interface_report`) goes to ``sed.interface``; its warning points ``stacklevel``
    frames up.
    """
    from dataclasses import replace

    if side != SIDE_AVERAGE:
        _check_material(first, side)
    if isamp is None:
        return sed
    if side != SIDE_AVERAGE and isamp.receptor.size and not _separable(first):
        _refuse_inseparable(first, side, np.unique(isamp.receptor).size)
    side_values = np.concatenate([v for v, _ in steps])
    average = None if steps[0][1] is None else np.concatenate([a for _, a in steps])
    values = apply_side(sed.values, isamp, side_values, SIDE_AVERAGE, average)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = interface_report(first, sed.layout, isamp, values, side_values, side)
    for w in caught:
        warnings.warn(w.message, w.category, stacklevel=stacklevel + 1)
    return replace(sed, values=apply_side(values, isamp, side_values, side), interface=report)


def interface_lines(field, layout, *, method: str = "linear") -> list[str]:
    """``afferent info --receptors``: which materials meet at the receptors and what the side does, as text lines.

    The receptors are sampled with ``side='average'`` and with each material met; the changes
    are compared at each receptor's most loaded step (SED in J/m^3).
    """
    from .sampling import sample_sed

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = sample_sed(field, layout, method=method, on_outside="nan")
        rep = base.interface
        lines = [f"  {'receptors':<12} {layout.n_receptors}" + (f" from {layout.source}" if layout.source else "")]
        if rep is None:
            return lines + [f"  {'interface':<12} no material ids in the export: the side cannot be told (side='average')"]
        where = ", ".join(f"materials {k}: {v}" for k, v in rep["interfaces"].items()) or "none"
        lines[0] += f": {rep['n_on_interface']} on an interface ({where}), {layout.n_receptors - rep['n_on_interface']} not"
        if not rep["n_on_interface"]:
            return lines
        lines.append(f"  {'sides':<12} the sides' SED differs by a median {100 * rep['median_spread']:.3g} %, up to "
                     f"{100 * rep['max_spread']:.3g} % of their mean (warned above {100 * INTERFACE_SPREAD_WARN:g} %)")
        lines.append(f"  {'side':<12} 'average' (default): {method} sampling, averaged across the materials at the interface")
        if not rep["separable"]:
            return lines + [f"  {'':<12} point data: the materials share the tool's nodal values (averaged across them), so "
                            "a material's side cannot be told (--side ID is refused); read cell data (--location cell) "
                            "to tell the sides apart"]
        on = np.flatnonzero([len(m) > 1 for m in _materials_at(rep, layout)])
        steps = np.array([p["step"] for p in rep["receptors"]])
        for m in rep["materials"]:
            if not any(str(m) in p["sed_pa"] for p in rep["receptors"]):
                continue
            vals = sample_sed(field, layout, method=method, on_outside="nan", side=m).values
            change = vals[steps, on] / base.values[steps, on] - 1
            lines.append(f"  {'':<12} --side {m}: {int(np.sum(np.abs(change) > 1e-9))} receptors change, by a median "
                         f"{100 * np.median(change):+.3g} % (from {100 * change.min():+.3g} to {100 * change.max():+.3g} %)")
    return lines


def _materials_at(rep: dict, layout) -> list:
    """Materials per receptor (in layout order) from an interface report; () for receptors not on an interface."""
    by_id = {p["receptor"]: p["materials"] for p in rep["receptors"]}
    return [tuple(by_id.get(str(i), ())) for i in layout.ids]
