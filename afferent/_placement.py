"""Receptors where receptors are: where a run's receptor sites sit in the FE model (issue 34).

Tactile receptors sit at the epidermis/dermis interface: Meissner corpuscles (RA-I) in the dermal
papillae at its tips, Merkel cells (SA-I) at the bases of the intermediate ridges. A receptor file
whose y holds a depth below the surface instead of a height (0.7 mm for 2.43 mm), or whose columns
are swapped, samples the subcutis and gives plausible but wrong SED (in the bundled 0.88 mm sample, y =
0.7 mm gives 294 Pa at the most loaded receptor instead of the tips' 1192 Pa). So:

* :func:`placement_record` (geometry only; stored with the sampled SED in the cache) says which
  materials the receptors touch and how far they lie from the epidermis/dermis interface (the
  material at the top of the block and the one it meets below), or, without material ids, where
  they sit in the block's height; and which common mistake would put them back on the interface.
* :func:`judge_placement` refuses an RA-I or SA-I run whose receptors lie mostly away from that
  interface, or none in their class's layer (the dermis for RA-I, the epidermis for SA-I), unless
  the run accepts ``'placement'``; it warns about a few away, and about receptors in the lower half of
  a block without material ids, more than 1 mm below its top.
* :func:`swap_hint` names the swap (y and z, x and y, a depth for a height, mm for m) that would put
  receptors found outside the field inside its bounds.

Lengths in m; the block's y axis points up, towards the skin surface (the convention of the site
finder, :func:`afferent.receptors.interface_sites`).
"""

from __future__ import annotations

import warnings

import numpy as np

from .exceptions import AfferentWarning

__all__ = ["NEAR_INTERFACE_M", "placement_record", "judge_placement", "swap_hint"]

#: Distance in m from the epidermis/dermis interface within which a receptor is "at" it: twice the
#: height of the bundled sample's papillae (0.1 mm), half the ridge pitch (0.44 mm); a depth given for a
#: height, or y and z swapped, put the receptors of that sample 0.7 mm and more away. A receptor inside a
#: cell that touches the interface also counts as at it (coarse meshes).
NEAR_INTERFACE_M = 0.2e-3

#: The layer each class's receptors lie in (a receptor on the interface touches both).
CLASS_LAYER = {"RA-I": ("lower", "dermis", "Meissner corpuscles lie in the dermal papillae"),
               "SA-I": ("upper", "epidermis", "Merkel cells lie in the basal epidermis at the ridge bases")}


def _candidates(pos: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """(name, positions) of the common mistakes, each undone (positions in m)."""
    top = hi[1]
    yield (f"y given as a depth below the surface (the top of the block is at y = {top * 1e3:.4g} mm; the heights "
           f"are {top * 1e3:.4g} mm minus the depths)"), np.column_stack([pos[:, 0], top - pos[:, 1], pos[:, 2]])
    yield "y and z swapped (the file's y column holds z)", pos[:, [0, 2, 1]]
    yield "x and y swapped (the file's x column holds y)", pos[:, [1, 0, 2]]
    yield "positions in mm read as m (x 1e-3)", pos * 1e-3
    yield "positions in m read as mm (x 1e3)", pos * 1e3


def _fits(moved: np.ndarray, field, name: str) -> bool:
    """Whether the receptors ``moved`` lie inside the field's bounds, and, rescaled, span a plausible part of it."""
    lo, hi = field.bounds
    if not _inside_box(moved, lo, hi).all():
        return False
    if "read as" not in name or len(moved) < 2:
        return True
    from ._plausibility import scale_ratio
    from .sampling import RECEPTOR_SPAN_BAND

    return bool(RECEPTOR_SPAN_BAND[0] <= scale_ratio(moved, field.points) <= RECEPTOR_SPAN_BAND[1])


def _inside_box(pos: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    tol = 1e-6 * float(np.max(hi - lo) or 1.0)
    with np.errstate(invalid="ignore"):
        return np.all((pos >= lo - tol) & (pos <= hi + tol), axis=1)


def swap_hint(layout, field) -> str:
    """A sentence naming the common mistake that would put every receptor inside the field's bounds, or ''.

    Tried in order: y given as a depth below the top of the block, y and z swapped, x and y swapped,
    positions in mm read as m and the reverse (:func:`_candidates`). Only called when receptors lie outside.
    """
    lo, hi = field.bounds
    pos = np.asarray(layout.positions, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):  # receptors 1e305 m away: inf, outside
        if not np.isfinite(pos).all() or _inside_box(pos, lo, hi).all():
            return ""
        for name, moved in _candidates(pos, lo, hi):
            if _fits(moved, field, name):
                return f"All {len(pos)} receptors fit inside the field's bounds with {name}: check the receptor file."
    return ""


def _skin_layers(field):
    """(upper, lower, interface nodes): the material at the top of the block (the epidermis), the one it meets
    below (the dermis, first among the others by height that shares interface nodes with it), the nodes they
    share; None without material ids, with one material, or when the top material meets none; 'tilted' when
    they are not layers one above the other in y or their interface does not face up along y (a model with
    another thickness axis: where "up" is, is not known)."""
    from .receptors import interface_nodes

    cells = field.cells
    if cells is None or cells.materials is None:
        return None
    mat_of_tet = cells.materials[cells.parent]
    mats = np.unique(mat_of_tet)
    if mats.size < 2:
        return None
    y = field.points[:, 1]
    top = {int(m): float(y[cells.tetra[mat_of_tet == m]].max()) for m in mats}
    order = sorted(top, key=top.get, reverse=True)
    upper = order[0]
    for lower in order[1:]:
        try:
            nodes = interface_nodes(field.points, cells, cells.materials, upper=upper, lower=lower)
        except ValueError:
            continue
        layered = _layered(field, mat_of_tet, upper, lower, nodes)
        return (upper, lower, nodes) if layered and _faces_up(field.points[nodes]) else "tilted"
    return None


def _layered(field, mat_of_tet: np.ndarray, upper: int, lower: int, nodes: np.ndarray) -> bool:
    """Whether ``upper`` lies above ``lower`` as layers do: their mean heights apart by more than the
    spread in y of the interface between them (materials mixed cell by cell meet everywhere, at every height)."""
    y = field.points[:, 1]
    mean = [float(y[np.unique(field.cells.tetra[mat_of_tet == m])].mean()) for m in (upper, lower)]
    return mean[0] - mean[1] > float(np.std(y[nodes]))


def _faces_up(iface: np.ndarray) -> bool:
    """Whether an interface's mean plane faces up along y (within the site finder's
    :data:`afferent.receptors._tips.MAX_TILT_DEG`): only then is the top of the block the skin surface."""
    from .receptors._tips import MAX_TILT_DEG

    if iface.shape[0] < 3:
        return False
    normal = np.linalg.svd(iface - iface.mean(axis=0), full_matrices=False)[2][-1]
    return bool(np.degrees(np.arccos(min(1.0, abs(normal[1])))) <= MAX_TILT_DEG)


def _touching_cells(field, positions: np.ndarray, on_interface: np.ndarray) -> tuple:
    """(materials of the cells holding each receptor (several on an interface, none outside), whether one of
    them has a node on the interface), from :func:`afferent._interfaces._touching`."""
    from ._interfaces import _touching

    out = [[] for _ in range(positions.shape[0])]
    near_cell = np.zeros(positions.shape[0], bool)
    for _start, _stop, r, t, _bary in _touching(field, positions):  # receptor chunk by receptor chunk
        pairs = np.unique(np.column_stack([r, field.cells.materials[field.cells.parent[t]]]), axis=0)
        for i, m in pairs.tolist():
            out[i].append(int(m))
        near_cell[r[on_interface[field.cells.tetra[t]].any(axis=1)]] = True
    return tuple(tuple(sorted(m)) for m in out), near_cell


def _interface_distance(positions: np.ndarray, points: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    return cKDTree(points[nodes]).query(positions)[0]


def placement_record(field, layout, outside=None) -> dict:
    """Where the receptors sit in ``field`` (its first step's geometry): a JSON-ready dict for run.json.

    With material ids meeting at an interface: ``materials`` (receptors per material or pair of
    materials touched, e.g. ``{'2': 100, '1/2': 19}``), ``upper`` / ``lower`` (epidermis / dermis ids),
    ``material_array``, ``interface_distance_m`` (median and largest), ``n_away`` (receptors farther than
    :data:`NEAR_INTERFACE_M` from the interface and not in a cell touching it), ``first_away``,
    ``n_in_upper`` / ``n_in_lower`` and ``cause`` (the mistake that would put them at the interface, or
    None). Without: ``median_y_m``, ``block_y_m`` and ``cause``. ``n`` receptors judged (inside the field).
    """
    pos = np.asarray(layout.positions, dtype=float)
    inside = np.ones(len(pos), bool) if outside is None else ~np.asarray(outside, dtype=bool)
    lo, hi = (np.asarray(b, dtype=float) for b in field.bounds)
    rec = {"n": int(inside.sum()), "source": layout.source}
    if not inside.any():
        return rec
    layers = _skin_layers(field)
    if layers == "tilted":
        rec["note"] = ("not judged: the materials are not layers one above the other in y (another thickness axis, "
                       "or materials mixed cell by cell)")
        return rec
    if layers is None:
        y = float(np.median(pos[inside, 1]))
        rec.update(median_y_m=y, block_y_m=[float(lo[1]), float(hi[1])], cause=None)
        if _deep(y, lo[1], hi[1]):
            name, moved = next(_candidates(pos[inside], lo, hi))
            if np.median(moved[:, 1]) >= (lo[1] + hi[1]) / 2:
                rec["cause"] = name
        return rec
    upper, lower, nodes = layers
    on = np.zeros(field.n_points, bool)
    on[nodes] = True
    touched, near_cell = _touching_cells(field, pos, on)
    dist = _interface_distance(pos, field.points, nodes)
    away = inside & (dist > NEAR_INTERFACE_M) & ~near_cell
    counts: dict = {}
    for i in np.flatnonzero(inside):
        key = "/".join(map(str, touched[i])) or "none"
        counts[key] = counts.get(key, 0) + 1
    rec.update(materials=dict(sorted(counts.items())), upper=upper, lower=lower,
               material_array=(field.provenance.columns or {}).get("material"),
               interface_distance_m={"median": float(np.median(dist[inside])), "max": float(np.max(dist[inside]))},
               n_away=int(away.sum()), first_away=None if not away.any() else str(layout.ids[np.flatnonzero(away)[0]]),
               n_in_upper=int(sum(upper in touched[i] for i in np.flatnonzero(inside))),
               n_in_lower=int(sum(lower in touched[i] for i in np.flatnonzero(inside))), cause=None)
    if away.any():
        for name, moved in _candidates(pos[inside], lo, hi):
            if _fits(moved, field, name) and np.median(_interface_distance(moved, field.points, nodes)) <= \
                    NEAR_INTERFACE_M:
                rec["cause"] = name
                break
    return rec


#: Depth in m below the top of a block without material ids beyond which receptors in its lower half are warned
#: about: the epidermis/dermis interface lies 0.4-1 mm below the skin surface (0.68-0.78 mm in the bundled sample);
#: a block cut to a band around the interface (the vibration exports: 0.52 mm tall) is never warned about.
INTERFACE_DEPTH_MAX_M = 1e-3


def _deep(y: float, lo: float, hi: float) -> bool:
    """Receptors at height ``y`` (m) in the lower half of a block spanning ``lo``..``hi`` in y and more than
    :data:`INTERFACE_DEPTH_MAX_M` below its top."""
    return y < (lo + hi) / 2 and hi - y > INTERFACE_DEPTH_MAX_M


def _materials_text(rec: dict) -> str:
    parts = [f"{n} in {'materials' if '/' in k else 'material'} {k.replace('/', ' and ')}" if k != "none" else
             f"{n} in no cell" for k, n in rec["materials"].items()]
    return ", ".join(parts)


def judge_placement(rec: dict | None, afferent_class: str, accept=None, *, stacklevel: int = 2) -> None:
    """Refuse (unless ``accept`` names 'placement') or warn about receptors away from where ``afferent_class``'s
    receptors sit, from a :func:`placement_record`.

    Refused: more than half of the receptors away from the epidermis/dermis interface, or none in the
    class's layer (:data:`CLASS_LAYER`). Warned: fewer away; without material ids, receptors whose
    median height lies in the lower half of the block and more than :data:`INTERFACE_DEPTH_MAX_M` below its top.
    """
    from ._validation import refuse_unless

    if not rec or not rec.get("n") or rec.get("note"):
        return
    of = f" of receptor file {rec['source']!r}" if rec.get("source") else ""
    cause = f"the likely cause {rec['cause']}" if rec.get("cause") else (
        "the likely cause a depth given for a height, or swapped columns")
    if "materials" not in rec:
        lo, hi = rec["block_y_m"]
        y = rec["median_y_m"]
        if _deep(y, lo, hi):
            warnings.warn(f"The receptors{of} sit in the lower half of the block, {(hi - y) * 1e3:.3g} mm below its top "
                          f"(median y = {y * 1e3:.4g} mm of {lo * 1e3:.4g} .. {hi * 1e3:.4g} mm; the skin surface at the "
                          f"top), far below where {afferent_class} receptors sit (the epidermis/dermis interface, under "
                          f"a millimetre beneath the surface): {cause}.", AfferentWarning, stacklevel=stacklevel + 1)
        return
    where = (f"the epidermis/dermis interface (materials {rec['upper']} above and {rec['lower']} below"
             + (f" in cell array {rec['material_array']!r}" if rec.get("material_array") else "") + ")")
    sit = (f"{_materials_text(rec)}, {rec['interface_distance_m']['median'] * 1e3:.3g} mm from the interface at "
           f"the median")
    if 2 * rec["n_away"] > rec["n"]:
        refuse_unless("placement", accept, (
            f"{rec['n_away']} of the {rec['n']} receptors{of} lie more than {NEAR_INTERFACE_M * 1e3:g} mm from "
            f"{where}, where {afferent_class} receptors sit: {sit}; {cause}; place them at the interface (x, z in "
            f"the skin plane, y the height towards the surface, in the declared unit)"), stacklevel=stacklevel + 1)
        return
    side, layer, why = CLASS_LAYER.get(afferent_class, (None, None, None))
    if side is not None and not rec[f"n_in_{side}"]:
        refuse_unless("placement", accept, (
            f"None of the {rec['n']} receptors{of} lies in the {layer} (material {rec[side]}), where {afferent_class} "
            f"receptors sit ({why}): {sit}; {cause}; place them at {where} or just inside the {layer}"),
            stacklevel=stacklevel + 1)
        return
    if rec["n_away"]:
        warnings.warn(f"{rec['n_away']} of the {rec['n']} receptors{of} (first: {rec['first_away']!r}) lie more than "
                      f"{NEAR_INTERFACE_M * 1e3:g} mm from {where}, where {afferent_class} receptors sit.",
                      AfferentWarning, stacklevel=stacklevel + 1)
