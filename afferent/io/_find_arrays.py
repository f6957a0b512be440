"""Which arrays of a raw export are the coordinates, the SED, the stress and strain tensors.

Also a separate coordinate file joined to a table of element values, integration points
grouped per element, and rows holding NaN dropped. Used by :mod:`afferent.io._assemble`.
"""

from __future__ import annotations

import numpy as np

from .._validation import suggest
from ..exceptions import SEDFormatError
from ..strain_energy import PRESETS, Convention, to_canonical
from . import _columns as C
from ._raw import RawArray, RawExport
from ._read_options import SMALL_STRAIN_BOUND, ReadOptions


def _where(raw: RawExport) -> str:
    """The file messages name: the export the user gave (the first of :attr:`RawExport.files`; the rest are
    the files it names, such as a .pvd's steps or an XDMF's HDF5 files)."""
    return raw.files[0]


def _names(raw: RawExport) -> str:
    return ", ".join(repr(a.name) + (" (cell)" if a.location == "cell" else "") for a in raw.arrays.values())


def _by_name(raw: RawExport, name: str, what: str, location: str | None = None) -> RawArray:
    matches = [a for a in raw.arrays.values() if a.name == name and (location is None or a.location == location)]
    if not matches:
        matches = [a for a in raw.arrays.values() if C.canonical(a.name) == C.canonical(name)]
    if not matches:
        hint = suggest(name, [a.name for a in raw.arrays.values()])
        raise SEDFormatError(
            f"SED file {_where(raw)!r} has no array or column {name!r} (asked for as {what}). "
            f"Found {_names(raw)}.{hint}"
        )
    if len(matches) > 1:
        matches = _pick_location(raw, matches, name, location)
    return matches[0]


def _pick_location(raw, matches, name, location):
    if location is not None:
        return [m for m in matches if m.location == location]
    point = [m for m in matches if m.location == "point"]
    if point and len(point) < len(matches):
        return point
    raise SEDFormatError(
        f"SED file {_where(raw)!r} has several arrays named {name!r}; pass location='point' or 'cell'."
    )


def _id_array(raw: RawExport) -> RawArray | None:
    for a in raw.arrays.values():
        if a.ndim == 2 and C.canonical(a.name) in C.ID_ALIASES:
            return a
    return None


_ELEMENT_IDS = frozenset(C.canonical(n) for n in ("element", "elementlabel", "elementnumber", "elementid", "elem", "eid"))
_POINT_IDS = frozenset(C.canonical(n) for n in ("ip", "intpt", "integrationpoint", "integ.pnt.", "integpnt", "int pt"))


def integration_point_groups(raw: RawExport) -> np.ndarray | None:
    """For an integration-point table (element ids repeat, an integration-point column such as
    CalculiX's ``integ.pnt.`` or Abaqus' ``Int Pt``), the element of each row as an index into
    the unique element ids (of (part, element) pairs when the rows name their part instances); None for any other
    table."""
    rid = _id_array(raw)
    ip = next((a for a in raw.arrays.values() if a.ndim == 2 and C.canonical(a.name) in _POINT_IDS), None)
    if rid is None or ip is None or C.canonical(rid.name) not in _ELEMENT_IDS:
        return None
    ids = rid.values[0][:, None]
    parts = C.part_names(raw.notes)
    if parts is not None and parts[0] in raw.arrays:  # element labels repeat across part instances: (part, label)
        ids = np.column_stack([raw.arrays[parts[0]].values[0], ids])
    if np.unique(ids, axis=0).shape[0] == ids.shape[0]:
        return None
    return np.unique(ids, axis=0, return_inverse=True)[1].ravel()


def average_per_element(values: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Average (n_times, n_rows) values over the rows of each element; returns (means, first row).

    Equal weights: for the standard rules of C3D8 (2x2x2), C3D20R (2x2x2), C3D10 (4 points) and
    C3D4/C3D8R (1 point) all Gauss weights are equal, so this is the element's Gauss average
    (its volume average when the element is a parallelepiped); for C3D20 (3x3x3) and wedges it is
    not. SED is averaged after it is computed at each integration point (1/2 sigma:eps is
    quadratic: averaging the tensors first would underestimate it).
    """
    n = int(groups.max()) + 1
    counts = np.bincount(groups, minlength=n)
    sums = np.zeros((values.shape[0], n))
    np.add.at(sums, (slice(None), groups), values)
    first = np.full(n, values.shape[1])
    np.minimum.at(first, groups, np.arange(values.shape[1]))
    return sums / counts, first


def _coordinate_table(path: str, rid: RawArray):
    """(ids, xyz, length unit, what) from a node/element table (CSV) or a CalculiX .frd mesh."""
    if path.lower().endswith((".frd", ".frd.gz")):
        from ._frd import frd_mesh

        node_ids, coords, elements = frd_mesh(path)
        if C.canonical(rid.name) in _ELEMENT_IDS:
            index = {int(i): k for k, i in enumerate(node_ids)}
            from ._frd import FRD_ELEMENTS

            corners = {"hexahedron": 8, "hexahedron20": 8, "wedge": 6, "wedge15": 6, "tetra": 4, "tetra10": 4}
            ids, xyz = [], []
            for eid, etype, nodes, _material in elements:
                k = corners.get(FRD_ELEMENTS[etype][0])
                if k:
                    ids.append(eid)
                    xyz.append(coords[[index[n] for n in nodes[:k]]].mean(axis=0))
            return np.asarray(ids, float), np.asarray(xyz), None, "element centroids (mean of the corner nodes)"
        return node_ids.astype(float), coords, None, "node coordinates"
    from ._csv import read_csv

    table = read_csv(path)
    xyz, names = find_coordinates(table, ReadOptions())
    tid = _id_array(table)
    if tid is None:
        raise SEDFormatError(
            f"Coordinates file {path!r} must have an id column (e.g. 'Node Label', 'node', 'id') and x, y, z; "
            f"found {_names(table)}."
        )
    ids = tid.values[0]
    parts = C.part_names(table.notes)
    if parts is not None:  # (part, label) keys: the labels as text behind the part name
        code = table.arrays[parts[0]].values[0].astype(int)
        ids = np.asarray([f"{parts[1][c]}\0{i:g}" for c, i in zip(code, ids)])
    return ids, xyz, table.length_unit, f"{tid.name!r} ({', '.join(names)})" + (f" keyed by part instance (column {parts[0]!r}) and label" if parts else "")


def _part_keys(raw: RawExport, path: str, rid: RawArray, t_ids: np.ndarray) -> np.ndarray:
    """The report's ids as (part, label) keys when its labels repeat across its part instances and the coordinates
    table ``path`` names the parts; refuses when it does not."""
    col, names = C.part_names(raw.notes)
    code = raw.arrays[col].values[0].astype(int)
    if t_ids.dtype.kind != "U":
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: its node labels ({rid.name!r}) repeat across its part instances "
            f"({', '.join(map(repr, names))}: each numbers its nodes from 1), so coordinates file {path!r} must name "
            "the part of each row: give it a 'Part' (or 'Instance') column, e.g. 'Part,Node Label,X,Y,Z' with rows "
            f"'{names[0]},1,...' (Abaqus: report the reference node coordinates of every part instance)."
        )
    return np.asarray([f"{names[c]}\0{i:g}" for c, i in zip(code, rid.values[0])])




def _one_part(raw: RawExport, path: str, t_ids: np.ndarray, xyz: np.ndarray, what: str):
    """The coordinates of a table that names parts, for a report of one part (labels unique): its labels alone."""
    parts, labels = zip(*(k.split("\0") for k in t_ids))
    ids = np.asarray(labels, dtype=np.float64)
    if len(np.unique(ids)) != ids.size:
        raise SEDFormatError(
            f"Coordinates file {path!r} names the part instances {', '.join(map(repr, dict.fromkeys(parts)))}, whose "
            f"labels repeat, but SED file {_where(raw)!r} names none (a report of one part): keep the rows of its part "
            "only."
        )
    return ids, xyz, what


def join_coordinates(raw: RawExport, path: str) -> RawExport:
    """Attach coordinates to a table keyed by node/element label (an Abaqus report, a FEBio
    logfile, a CalculiX .dat): from a node (or element-centroid) table ``id, x, y, z``, or from
    the CalculiX ``.frd`` of the same run (node coordinates, or element centroids for a table
    keyed by element). Rows of an integration-point table all get their element's coordinates;
    :func:`assemble` averages their SED per element."""
    rid = _id_array(raw)
    if rid is None:
        raise SEDFormatError(
            f"SED file {_where(raw)!r} has no node/element id column to join coordinates on; found {_names(raw)}."
        )
    t_ids, xyz, length_unit, what = _coordinate_table(path, rid)
    r_ids = rid.values[0]
    if len(np.unique(r_ids)) != r_ids.size and C.part_names(raw.notes) is not None:
        r_ids = _part_keys(raw, path, rid, t_ids)
    elif t_ids.dtype.kind == "U":  # a report of one part: the table's labels of that part
        t_ids, xyz, what = _one_part(raw, path, t_ids, xyz, what)
    if len(np.unique(t_ids)) != t_ids.size:
        raise SEDFormatError(f"Coordinates file {path!r}: the ids of its {what} must be unique.")
    if len(np.unique(r_ids)) != r_ids.size and integration_point_groups(raw) is None:
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: ids in column {rid.name!r} repeat (integration-point rows without an "
            "integration-point column?); export one value per node or per element (centroid or averaged) to place it "
            "at one coordinate."
        )
    order = np.argsort(t_ids)
    pos = np.searchsorted(t_ids[order], r_ids)
    pos = np.clip(pos, 0, t_ids.size - 1)
    found = t_ids[order][pos] == r_ids
    if not found.all():
        missing = r_ids[~found][:5]
        raise SEDFormatError(
            f"Coordinates file {path!r} lacks {int((~found).sum())} id(s) of SED file {_where(raw)!r} (first: "
            + ", ".join(f"{v:g}" if r_ids.dtype.kind != "U" else "label {1} of part {0}".format(*v.split("\0"))
                        for v in missing) + ")."
        )
    points = xyz[order][pos]
    return RawExport(
        files=raw.files + (path,), format=raw.format, points=points, arrays=raw.arrays, times=raw.times,
        cells=None, length_unit=length_unit, time_unit=raw.time_unit,
        notes=raw.notes + (f"coordinates joined from {path!r} on {rid.name!r}: {what}.",), preset=raw.preset,
    )


def drop_nan_rows(raw: RawExport, arrays_used: list[str]) -> RawExport:
    """Drop the points (rows) with a NaN in any column at any step (COMSOL writes NaN for points
    where an expression is not evaluated). Only for tables without cells."""
    bad = np.zeros(next(iter(raw.arrays.values())).shape[1], dtype=bool)
    for name in arrays_used:
        v = raw.arrays[name].values
        bad |= ~np.isfinite(v.reshape(v.shape[0], v.shape[1], -1)).all(axis=(0, 2))
    if raw.points is not None:
        bad |= ~np.isfinite(raw.points).all(axis=1)
    if not bad.any():
        return raw
    keep = ~bad
    arrays = {k: RawArray(a.name, a.values[:, keep], a.location, a.unit, a.components) for k, a in raw.arrays.items()}
    return RawExport(
        files=raw.files, format=raw.format, points=None if raw.points is None else raw.points[keep], arrays=arrays,
        times=raw.times, cells=None, length_unit=raw.length_unit, time_unit=raw.time_unit,
        notes=raw.notes + (f"{int(bad.sum())} of {bad.size} rows with NaN dropped (on_nan='drop').",),
    )


def find_coordinates(raw: RawExport, opts: ReadOptions) -> tuple[np.ndarray, tuple[str, ...]]:
    """Coordinates (n_points, 3) in file units, and the column names used."""
    if raw.points is not None:
        return np.asarray(raw.points, dtype=float), ("points",)
    if opts.coord_columns is not None:
        cols = [_by_name(raw, c, f"the {ax} coordinate") for c, ax in zip(opts.coord_columns, "xyz")]
    else:
        cols = []
        for axis in "xyz":
            hit = [a for a in raw.arrays.values() if C.canonical(a.name) in C.COORD_ALIASES[axis]]
            exact = [a for a in hit if C.canonical(a.name) == axis]
            hit = exact or hit
            if len(hit) != 1:
                what = "no" if not hit else f"{len(hit)} ({', '.join(repr(a.name) for a in hit)})"
                rid = _id_array(raw) if not hit else None
                join = ("" if rid is None else f" or coordinates='NODES' (an id,x,y,z table, an ANSYS NLIST listing, "
                        f"the run's CalculiX .frd) to join them on {rid.name!r}")
                raise SEDFormatError(
                    f"SED file {_where(raw)!r} must have one {axis} coordinate column "
                    f"(e.g. '{axis}', '{axis.upper()}', 'COORD{'xyz'.index(axis) + 1}', '{axis.upper()} Location'); "
                    f"found {what}. Found columns {_names(raw)}. Pass coord_columns=('X', 'Y', 'Z') to name them"
                    f"{join}."
                )
            cols.append(hit[0])
    xyz = np.stack([c.values for c in cols], axis=-1)  # (n_times, n, 3)
    if xyz.shape[0] > 1 and abaqus_reference_frame(raw, [c.name for c in cols]):
        return xyz[0], tuple(c.name for c in cols)  # the undeformed model's positions, for every frame
    if xyz.shape[0] > 1 and not np.array_equal(xyz, np.broadcast_to(xyz[:1], xyz.shape), equal_nan=True):
        step = int(np.argmax([not np.array_equal(xyz[k], xyz[0], equal_nan=True) for k in range(xyz.shape[0])]))
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: the coordinates of time step {step} differ from those of step 0; "
            "every step must list the same points in the same order."
        )
    return xyz[0], tuple(c.name for c in cols)


#: Abaqus' COORD components as a report names them (docs/fe-export.md, Abaqus): the nodes' current
#: positions, which move from frame to frame when the step runs with NLGEOM.
ABAQUS_COORD = frozenset(C.canonical(f"COORD.COOR{k}") for k in (1, 2, 3))


def abaqus_coordinates(names) -> bool:
    """Whether coordinate columns ``names`` are Abaqus' COORD output."""
    return bool({C.canonical(n) for n in names} & ABAQUS_COORD)


def abaqus_reference_frame(raw: RawExport, names) -> bool:
    """Whether the coordinates ``names`` are Abaqus' COORD and the export's first step is a frame at
    time 0 (increment 0 of a report's one analysis step: the undeformed model), whose positions
    then stand for every frame."""
    return abaqus_coordinates(names) and raw.times is not None and len(raw.times) > 0 and float(raw.times[0]) == 0.0


def _wrong_location(raw: RawExport, arr: RawArray, what: str, asked: str) -> None:
    raise SEDFormatError(
        f"SED file {_where(raw)!r}: the {what} {arr.name!r} is {arr.location} data, not {asked} data as "
        f"location={asked!r} asks; drop location= or pass location={arr.location!r}."
    )


def find_sed_array(raw: RawExport, opts: ReadOptions) -> list[RawArray]:
    """The SED array(s) to use: one array, or one per step when ``sed_column`` lists several."""
    if opts.sed_column is not None:
        names = (opts.sed_column,) if isinstance(opts.sed_column, str) else tuple(opts.sed_column)
        return [_by_name(raw, n, "the SED", opts.location) for n in names]
    arrays = list(raw.arrays.values())
    for alias in C.SED_ALIASES:
        named = [a for a in arrays if C.canonical(a.name) == alias or C.canonical(a.name).startswith(alias + "@")]
        hits = [a for a in named if opts.location is None or a.location == opts.location]
        if named and not hits:
            _wrong_location(raw, named[0], "SED array", opts.location)
        if hits:
            return _pick_location(raw, hits, hits[0].name, opts.location)[:1] if len(hits) > 1 else hits
    for a in arrays:
        reason = C.ENERGY_NOT_DENSITY.get(C.canonical(a.name))
        if reason and (opts.location is None or a.location == opts.location):
            from ._export_checks import density_by_values  # values decide where tensors are present

            check = density_by_values(raw, a)
            if check is not None and check["density"]:
                return [a]
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: column {a.name!r} holds an energy, not an energy density ({reason}); "
                + (f"its values are {check['scale']:.3g} x 1/2 sigma:eps of the file's tensors (relative difference "
                   f"{check['relative_difference']:.2g}), as an element energy is the density x the element volume. "
                   if check is not None else f"so its name says, and {_undecided(raw)}. ")
                + f"Export the density, or divide by the element volume first; if it is a density after all, confirm "
                f"with sed_column={a.name!r} (--sed-column {a.name})."
            )
    tensors = _tensor_summary(raw)
    hint = (
        f" It has stress and strain tensors ({tensors}): pass sed_from='exact' (1/2 sigma:eps) or "
        "sed_from='equivalent' (the study's equivalent SED) with the tool's preset."
        if tensors
        else " Pass sed_column='NAME' to name it" + _stress_only(raw) + "."
    )
    raise SEDFormatError(
        f"SED file {_where(raw)!r} has no strain-energy-density array or column "
        f"(looked for SED, SENER, ESEDEN, SEND, solid.Ws, ENER, 'strain energy density', ...). "
        f"Found {_names(raw)}.{hint}"
    )


def _stress_only(raw: RawExport) -> str:
    """The clause for an export with a stress tensor and no strain: SED from the stress alone."""
    try:
        name, _, loc = find_tensor(raw, ReadOptions(), "stress")
    except (SEDFormatError, ValueError):
        return ""
    return (f"; it has a stress tensor ({name}, {loc} data) without strain: sed_from='stress' computes the linear-elastic "
            "SED from it with the elastic constants, elastic=(E, nu) and modulus_unit= or materials='TABLE.csv'")


def _undecided(raw: RawExport) -> str:
    """Why the values cannot tell a density from an energy (:func:`density_by_values` gave None), as a clause."""
    if not _tensor_summary(raw):
        return "the file has no stress and strain tensors to decide from the values"
    return ("the file's stress and strain tensors cannot decide it from the values (none at the array's location, or "
            f"strains beyond the small-strain bound {SMALL_STRAIN_BOUND:g} at every step)")


def _tensor_summary(raw: RawExport) -> str:
    try:
        s, e = find_tensors(raw, ReadOptions(sed_from="exact"), need_convention=False)
    except SEDFormatError:
        return ""
    return f"stress {s[0]}, strain {e[0]}"


def _order_from_names(components: tuple[str, ...]) -> tuple[str, ...] | None:
    """Component order from a 6-component array's own names (``SXX``, ``S_YZ``, ``ZX``...), or None."""
    if len(components) != 6:
        return None
    order = []
    for name in components:
        tail = C.canonical(name)[-2:]
        comp = {"zx": "xz", "zy": "yz", "yx": "xy"}.get(tail, tail)
        if comp not in ("xx", "yy", "zz", "xy", "yz", "xz"):
            return None
        order.append(comp)
    return tuple(order) if len(set(order)) == 6 else None


def _tensor_from_array(arr: RawArray, kind: str, conv: Convention | None, raw: RawExport) -> np.ndarray:
    """A tensor array -> (n_t, n, 6) canonical components, **tensor** shear.

    A 9-component array is a full 3x3 tensor (row-major): its off-diagonals are tensor
    components whatever the tool's 6-component shear convention. A 6-component array is
    ordered by its component names when it has them, else by the convention; engineering
    shear strain is halved here.
    """
    v = arr.values
    ncomp = v.shape[2] if v.ndim == 3 else 1
    if ncomp == 9:
        m = v.reshape(v.shape[:2] + (3, 3))
        return np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2], m[..., 0, 1], m[..., 1, 2], m[..., 0, 2]], -1)
    if ncomp == 6:
        named = _order_from_names(arr.components)
        if named is None and conv is None:
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: the 6-component {kind} array {arr.name!r} has no component names, "
                f"so its order must be declared: pass preset=one of {', '.join(map(repr, PRESETS))}."
            )
        if named is not None:
            conv = Convention(named, conv.shear if conv is not None else "tensor", "component names of the file")
        return to_canonical(v, conv, is_strain=(kind == "strain"))
    raise SEDFormatError(
        f"SED file {_where(raw)!r}: {kind} array {arr.name!r} must have 6 or 9 components; got {ncomp} instead."
    )


def find_tensor(raw: RawExport, opts: ReadOptions, kind: str, conv: Convention | None = None):
    """Locate one tensor, ``kind`` 'stress' or 'strain': (description, values (n_t, n, 6), location).

    Components come back in the canonical order with tensor shear (engineering shear strain, as
    ``conv`` declares it, is halved here; full 3x3 arrays are tensor already). ``conv`` None: a
    6-component array without component names is read in VTK's order with tensor shear.
    """
    comp_table, override = ((C.STRESS_COMPONENTS, opts.stress_columns) if kind == "stress"
                            else (C.STRAIN_COMPONENTS, opts.strain_columns))
    if isinstance(override, str):
        arr = _by_name(raw, override, f"the {kind} tensor", opts.location)
        return arr.name, _tensor_from_array(arr, kind, conv or PRESETS["vtk"], raw), arr.location
    if override is not None:
        if len(override) != 6:
            raise ValueError(
                f"'{kind}_columns' must name 6 columns in the order xx yy zz xy yz xz; got {len(override)} instead."
            )
        cols = [_by_name(raw, n, f"the {kind} component", opts.location) for n in override]
        values = np.stack([c.values for c in cols], -1)
        return ", ".join(c.name for c in cols), _halve_shear(values, kind, conv), cols[0].location
    named = [a for a in raw.arrays.values() if a.ndim == 3 and C.canonical(a.name) in C.TENSOR_ARRAY_NAMES[kind]]
    tensor_arrays = [a for a in named if opts.location is None or a.location == opts.location]
    if named and not tensor_arrays:
        _wrong_location(raw, named[0], f"{kind} tensor", opts.location)
    if tensor_arrays:
        arr = tensor_arrays[0]
        return arr.name, _tensor_from_array(arr, kind, conv or PRESETS["vtk"], raw), arr.location
    attempts = []
    for loc in ((opts.location,) if opts.location else ("point", "cell")):  # all six at one location
        found, missing = [], []
        for comp in ("xx", "yy", "zz", "xy", "yz", "xz"):
            hits = [a for a in raw.arrays.values() if a.ndim == 2 and a.location == loc
                    and C.canonical(a.name) in comp_table[comp]]
            (found if hits else missing).append(hits[0] if hits else comp)
        attempts.append((found, missing))
    found, missing = max(attempts, key=lambda fm: len(fm[0]))  # the location holding the most components
    if missing:
        have = f" (found {', '.join(repr(a.name) for a in found)})" if found else ""
        raise SEDFormatError(
            f"SED file {_where(raw)!r} has no complete {kind} tensor{have}; missing component(s) "
            f"{', '.join(missing)}. Found {_names(raw)}. Pass {kind}_columns=(6 names, xx yy zz xy yz xz)."
        )
    if len({a.shape for a in found}) > 1:
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: the {kind} components {', '.join(repr(a.name) for a in found)} must have one "
            f"value per point at every step alike; got shapes {', '.join(str(a.shape) for a in found)}."
        )
    values = np.stack([a.values for a in found], -1)
    return ", ".join(a.name for a in found), _halve_shear(values, kind, conv), found[0].location


def find_tensors(raw: RawExport, opts: ReadOptions, *, need_convention: bool = True):
    """Locate stress and strain: returns ((stress_desc, stress (n_t, n, 6)), (strain_desc, strain (n_t, n, 6))).

    Components come back in the canonical order with tensor shear (engineering shear strain,
    as the convention declares it, is halved here; full 3x3 arrays are tensor already).
    """
    conv = _convention(opts, raw) if need_convention else None
    (s_name, s, s_loc), (e_name, e, e_loc) = (find_tensor(raw, opts, kind, conv) for kind in ("stress", "strain"))
    if s.shape != e.shape or s_loc != e_loc:
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: stress ({s_name}, {s_loc}, {s.shape[1]} values) and strain "
            f"({e_name}, {e_loc}, {e.shape[1]} values) must live at the same points."
        )
    return (s_name, s, s_loc), (e_name, e, e_loc)


def _halve_shear(values: np.ndarray, kind: str, conv: Convention | None) -> np.ndarray:
    """Named component columns (canonical order) -> tensor shear, by the declared convention."""
    if kind == "strain" and conv is not None and conv.shear == "engineering":
        values = values.copy()
        values[..., 3:] *= 0.5
    return values


#: The convention's note when stress and strain are both full 3x3 arrays (no preset or shear needed).
FULL_TENSORS = "stress and strain are full 3x3 tensors (9 components): their off-diagonals are tensor components"


def _full_tensors(raw: RawExport, opts: ReadOptions) -> bool:
    """Whether the stress and strain found are both 9-component arrays (then no shear convention applies)."""
    try:
        (s_name, _, s_loc), (e_name, _, _) = find_tensors(raw, opts, need_convention=False)
    except (SEDFormatError, ValueError):
        return False
    full = {a.name for a in raw.arrays.values() if a.location == s_loc and a.ndim == 3 and a.shape[2] == 9}
    return s_name in full and e_name in full


def _convention(opts: ReadOptions, raw: RawExport | None = None) -> Convention:
    """The tensors' convention: the user's preset/shear, else the one the file's format implies."""
    implied = raw.preset if raw is not None else None
    if implied is not None and opts.preset is not None and opts.preset != implied:
        raise ValueError(
            f"preset={opts.preset!r} contradicts SED file {_where(raw)!r}, which only {implied!r} writes; "
            "drop preset (the file's own convention is used)."
        )
    preset = opts.preset or implied
    if preset is None and opts.shear is None and raw is not None and _full_tensors(raw, opts):
        return Convention(PRESETS["vtk"].order, "tensor", FULL_TENSORS)
    if preset is None and opts.shear is None:
        raise ValueError(
            "Computing SED from tensors needs the tool's shear convention: pass preset=one of "
            f"{', '.join(map(repr, PRESETS))}, or shear='tensor' or shear='engineering'."
        )
    base = PRESETS[preset] if preset else PRESETS["vtk"]
    return Convention(base.order, opts.shear or base.shear, base.note)


#: Names of material-id arrays (compared lower case, letters and digits only): deal.II
#: ``material_id``, VTK ``MaterialIds``, SfePy ``mat_id``, gmsh ``gmsh:physical``, medit
#: ``medit:ref``, DOLFINx/VTK ``CellEntityIds``, Exodus/ParaView ``ElementBlockIds`` and
#: ``ObjectId``, the bundled sample's ``layer``, MFEM's ``attribute`` (``ParaViewDataCollection``
#: writes each element's attribute as cell data).
MATERIAL_ARRAY_NAMES = ("material_id", "materialids", "material", "materials", "mat_id", "matid", "layer",
                        "gmsh:physical", "medit:ref", "cellentityids", "elementblockids", "blockid", "block_id",
                        "objectid", "subdomain", "domain", "region", "attribute", "material_index",
                        "materialindex", "cell_tag", "cell_tags", "celltags", "physicalids", "physical_id",
                        "physicaltag", "physical_tag", "elem_set", "elset", "element_set", "subdomain_id",
                        "domain_id", "region_id", "regionid")


def _key(name: str) -> str:
    return "".join(ch for ch in name.lower() if ch.isalnum())


def find_material_array(raw: RawExport, cells=None, *, name: str | None = None) -> tuple[str, str, np.ndarray] | None:
    """The material id of each cell: (array name, where it was found, ids of shape (n_cells,)) or None.

    A cell array named like :data:`MATERIAL_ARRAY_NAMES` holding whole numbers; or a point array
    of such a name that is constant over each cell's corners (deal.II's ``DataOut`` writes cell
    data that way: one patch per cell, the cell's value at each of its copies of the nodes).
    ``where`` is ``'cell data'`` or ``'point data constant per cell'``. The first time step is
    used. ``cells`` defaults to ``raw.cells``. ``name``: that array only (the user's ``material_array``).
    """
    cells = raw.cells if cells is None else cells
    if cells is None:
        return None
    wanted = {_key(n) for n in MATERIAL_ARRAY_NAMES} if name is None else {_key(name)}
    for loc in ("cell", "point"):
        for arr in raw.arrays.values():
            scalar = arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] == 1)  # NumberOfComponents="1": NGSolve
            if arr.location != loc or _key(arr.name) not in wanted or not scalar or not arr.shape[0]:
                continue
            v = arr.values[0].reshape(arr.shape[1])
            if not np.all(np.isfinite(v)) or not np.all(v == np.round(v)):
                continue
            if loc == "cell":
                return arr.name, "cell data", v.astype(np.int64)
            corners = v[cells.tetra]
            if not np.all(corners == corners[:, :1]):
                continue
            per_cell = np.zeros(cells.n_cells)
            per_cell[cells.parent] = corners[:, 0]
            seen = np.zeros(cells.n_cells, bool)
            seen[cells.parent] = True
            if np.all(np.bincount(cells.parent, weights=(corners[:, 0] != per_cell[cells.parent]), minlength=cells.n_cells) == 0) and seen.all():
                return arr.name, "point data constant per cell", per_cell.astype(np.int64)
    return None
