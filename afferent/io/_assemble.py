"""Turn a format reader's :class:`RawExport` into an :class:`~afferent.field.SEDField`.

Done once here for every format: pick the coordinate columns and the SED array (or the
stress and strain tensors), apply the declared or stated units, compute SED from tensors
when asked, and validate what the FE export holds.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from .._plausibility import sed_warning, span_warning
from .._validation import check_option, suggest
from ..exceptions import AfferentWarning, SEDFormatError, UnitError
from ..field import Provenance, SEDField
from ..strain_energy import PRESETS, Convention, sed_equivalent, sed_exact, to_canonical
from ..units import length_factor, parse_unit, sed_factor, time_factor
from . import _columns as C
from ._raw import RawArray, RawExport

__all__ = ["ReadOptions", "assemble", "find_sed_array", "find_tensors", "find_coordinates"]

#: Default tolerance for negative SED. FE tools compute SED at integration points and
#: extrapolate/average it to the nodes (CalculiX ENER in the .frd, Abaqus unique-nodal
#: averaging, ANSYS PowerGraphics); near steep gradients the extrapolation overshoots below
#: zero. Measured on real CalculiX 2.20 indentation models (tests/data/calculix and finer
#: versions of them): the most negative nodal ENER is -0.02 x the largest for C3D8 meshes at
#: every resolution tried (the punch edge is a singularity: refining does not remove it) and
#: -0.10 to -0.16 x for quadratic C3D20R/C3D10 meshes; the negative values sum to at most 0.093
#: x the positive ones. A wrong column (a stress or displacement component, a flipped sign)
#: is negative over a large share of the field. So negatives are accepted when both the most
#: negative value and the sum of the negatives are at most this fraction of, respectively, the
#: largest SED and the sum of the positive values; they are then counted, reported and set to 0
#: (SED >= 0 for an elastic solid). Anything else is refused.
NEGATIVE_SED_RTOL = 0.25

SED_FROM = ("field", "exact", "equivalent")

#: Relative L2 difference (at the most loaded step, after the best scale factor) above which
#: the SED computed from an export's tensors and the export's own SED array are said to
#: disagree. They agree to the file's precision only where both are values at the same points
#: (CalculiX .dat integration points: 6e-7; DOLFINx DG0 interpolations and the bundled
#: scikit-fem sample at cell centroids: round-off). Wherever either is an average they cannot:
#: 1/2 sigma:eps of averaged tensors is not the average of 1/2 sigma:eps. Measured on real
#: files: CalculiX nodal ENER vs nodal tensors 8-40 % (tests/data/calculix), SfePy element
#: averages ('el_avg' tensors vs its element-average energy) 9 % (tests/data/sfepy) - as large
#: as what a wrong shear convention does (15-40 %). So this comparison flags only gross errors
#: (a wrong column, a mismatched unit shows in the recorded scale); the shear convention is
#: checked by :func:`shear_consistency`, which averaging does not disturb.
CROSSCHECK_RTOL = {"cell": 0.5, "point": 0.5}

#: Accepted range of the shear-to-normal stiffness ratio of :func:`shear_consistency`: 1 when the
#: strain's shear is read with the right convention, 0.5 when engineering shear is read as
#: tensor shear, 2 for the reverse; the band's edges are the geometric midpoints.
SHEAR_RATIO_BAND = (2 ** -0.5, 2 ** 0.5)


@dataclass(frozen=True)
class ReadOptions:
    """Everything a user may declare when reading an export (see :func:`afferent.read_sed`)."""

    length_unit: str | None = None
    sed_unit: str | None = None
    stress_unit: str | None = None
    time_unit: str | None = None
    sed_from: str = "field"
    poisson: float | None = None
    preset: str | None = None
    shear: str | None = None
    location: str | None = None
    sed_column: str | tuple[str, ...] | None = None
    stress_columns: str | tuple[str, ...] | None = None
    strain_columns: str | tuple[str, ...] | None = None
    coord_columns: tuple[str, str, str] | None = None
    times: tuple[float, ...] | None = None
    coordinates: str | None = None
    on_nan: str = "raise"
    negative_tolerance: float = NEGATIVE_SED_RTOL

    def __post_init__(self):
        check_option("sed_from", self.sed_from, SED_FROM)
        if self.preset is not None:
            check_option("preset", self.preset, tuple(PRESETS))
        if self.shear is not None:
            check_option("shear", self.shear, ("tensor", "engineering"))
        if self.location is not None:
            check_option("location", self.location, ("point", "cell"))
        check_option("on_nan", self.on_nan, ("raise", "drop"))
        tol = self.negative_tolerance
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 <= tol < 1):
            raise ValueError(f"'negative_tolerance' must be a number in [0, 1) (a fraction of the largest SED); got {tol!r} instead.")
        if self.sed_from == "equivalent" and self.poisson is None:
            raise ValueError(
                "sed_from='equivalent' needs Poisson's ratio: pass poisson=NU (the study's skin model uses 0.48)."
            )
        if self.poisson is not None and not (-1 < float(self.poisson) <= 0.5):
            raise ValueError(f"'poisson' must be in (-1, 0.5]; got {self.poisson!r} instead.")


def _where(raw: RawExport) -> str:
    return raw.files[0] if len(raw.files) == 1 else f"{raw.files[0]} (+{len(raw.files) - 1} more files)"


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
        if a.values.ndim == 2 and C.canonical(a.name) in C.ID_ALIASES:
            return a
    return None


_ELEMENT_IDS = frozenset(C.canonical(n) for n in ("element", "elementlabel", "elementnumber", "elementid", "elem", "eid"))
_POINT_IDS = frozenset(C.canonical(n) for n in ("ip", "intpt", "integrationpoint", "integ.pnt.", "integpnt", "int pt"))


def integration_point_groups(raw: RawExport) -> np.ndarray | None:
    """For an integration-point table (element ids repeat, an integration-point column such as
    CalculiX's ``integ.pnt.`` or Abaqus' ``Int Pt``), the element of each row as an index into
    the unique element ids; None for any other table."""
    rid = _id_array(raw)
    ip = next((a for a in raw.arrays.values() if a.values.ndim == 2 and C.canonical(a.name) in _POINT_IDS), None)
    if rid is None or ip is None or C.canonical(rid.name) not in _ELEMENT_IDS:
        return None
    ids = rid.values[0]
    if np.unique(ids).size == ids.size:
        return None
    return np.unique(ids, return_inverse=True)[1].ravel()


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
            for eid, etype, nodes in elements:
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
    return tid.values[0], xyz, table.length_unit, f"{tid.name!r} ({', '.join(names)})"


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
            f"Coordinates file {path!r} lacks {int((~found).sum())} id(s) of SED file {_where(raw)!r} "
            f"(first: {', '.join(f'{v:g}' for v in missing)})."
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
    bad = np.zeros(next(iter(raw.arrays.values())).values.shape[1], dtype=bool)
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
                raise SEDFormatError(
                    f"SED file {_where(raw)!r} must have one {axis} coordinate column "
                    f"(e.g. '{axis}', '{axis.upper()}', 'COORD{'xyz'.index(axis) + 1}', '{axis.upper()} Location'); "
                    f"found {what}. Found columns {_names(raw)}. Pass coord_columns=('X', 'Y', 'Z') to name them."
                )
            cols.append(hit[0])
    xyz = np.stack([c.values for c in cols], axis=-1)  # (n_times, n, 3)
    if xyz.shape[0] > 1 and not np.array_equal(xyz, np.broadcast_to(xyz[:1], xyz.shape), equal_nan=True):
        step = int(np.argmax([not np.array_equal(xyz[k], xyz[0], equal_nan=True) for k in range(xyz.shape[0])]))
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: the coordinates of time step {step} differ from those of step 0; "
            "every step must list the same points in the same order."
        )
    return xyz[0], tuple(c.name for c in cols)


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
        if reason:
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: column {a.name!r} holds an energy, not an energy density ({reason}). "
                "Export the density, or divide by the element volume first."
            )
    tensors = _tensor_summary(raw)
    hint = (
        f" It has stress and strain tensors ({tensors}): pass sed_from='exact' (1/2 sigma:eps) or "
        "sed_from='equivalent' (the study's equivalent SED) with the tool's preset."
        if tensors
        else " Pass sed_column='NAME' to name it."
    )
    raise SEDFormatError(
        f"SED file {_where(raw)!r} has no strain-energy-density array or column "
        f"(looked for SED, SENER, ESEDEN, SEND, solid.Ws, ENER, 'strain energy density', ...). "
        f"Found {_names(raw)}.{hint}"
    )


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


def find_tensors(raw: RawExport, opts: ReadOptions, *, need_convention: bool = True):
    """Locate stress and strain: returns ((stress_desc, stress (n_t, n, 6)), (strain_desc, strain (n_t, n, 6))).

    Components come back in the canonical order with tensor shear (engineering shear strain,
    as the convention declares it, is halved here; full 3x3 arrays are tensor already).
    """
    conv = _convention(opts, raw) if need_convention else None
    out = []
    for kind, comp_table, override in (
        ("stress", C.STRESS_COMPONENTS, opts.stress_columns),
        ("strain", C.STRAIN_COMPONENTS, opts.strain_columns),
    ):
        if isinstance(override, str):
            arr = _by_name(raw, override, f"the {kind} tensor", opts.location)
            out.append((arr.name, _tensor_from_array(arr, kind, conv or PRESETS["vtk"], raw), arr.location))
            continue
        if override is not None:
            if len(override) != 6:
                raise ValueError(
                    f"'{kind}_columns' must name 6 columns in the order xx yy zz xy yz xz; got {len(override)} instead."
                )
            cols = [_by_name(raw, n, f"the {kind} component", opts.location) for n in override]
            values = np.stack([c.values for c in cols], -1)
            out.append((", ".join(c.name for c in cols), _halve_shear(values, kind, conv), cols[0].location))
            continue
        named = [a for a in raw.arrays.values() if a.values.ndim == 3 and C.canonical(a.name) in C.TENSOR_ARRAY_NAMES[kind]]
        tensor_arrays = [a for a in named if opts.location is None or a.location == opts.location]
        if named and not tensor_arrays:
            _wrong_location(raw, named[0], f"{kind} tensor", opts.location)
        if tensor_arrays:
            arr = tensor_arrays[0]
            out.append((arr.name, _tensor_from_array(arr, kind, conv or PRESETS["vtk"], raw), arr.location))
            continue
        attempts = []
        for loc in ((opts.location,) if opts.location else ("point", "cell")):  # all six at one location
            found, missing = [], []
            for comp in ("xx", "yy", "zz", "xy", "yz", "xz"):
                hits = [a for a in raw.arrays.values() if a.values.ndim == 2 and a.location == loc
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
        if len({a.values.shape for a in found}) > 1:
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: the {kind} components {', '.join(repr(a.name) for a in found)} must have one "
                f"value per point at every step alike; got shapes {', '.join(str(a.values.shape) for a in found)}."
            )
        values = np.stack([a.values for a in found], -1)
        out.append((", ".join(a.name for a in found), _halve_shear(values, kind, conv), found[0].location))
    (s_name, s, s_loc), (e_name, e, e_loc) = out
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


def _convention(opts: ReadOptions, raw: RawExport | None = None) -> Convention:
    """The tensors' convention: the user's preset/shear, else the one the file's format implies."""
    implied = raw.preset if raw is not None else None
    if implied is not None and opts.preset is not None and opts.preset != implied:
        raise ValueError(
            f"preset={opts.preset!r} contradicts SED file {_where(raw)!r}, which only {implied!r} writes; "
            "drop preset (the file's own convention is used)."
        )
    preset = opts.preset or implied
    if preset is None and opts.shear is None:
        raise ValueError(
            "Computing SED from tensors needs the tool's shear convention: pass preset=one of "
            f"{', '.join(map(repr, PRESETS))}, or shear='tensor' or shear='engineering'."
        )
    base = PRESETS[preset] if preset else PRESETS["vtk"]
    return Convention(base.order, opts.shear or base.shear, base.note)


def _unit(raw: RawExport, declared: str | None, stated: str | None, kind: str, param: str, columns: str):
    """Resolve a unit: declared by the user or stated in the file; both must agree; never guessed."""
    factor_of = {"length": length_factor, "sed": sed_factor, "stress": sed_factor, "time": time_factor}[kind]
    if stated is not None and parse_unit(stated) is None:
        raise UnitError(
            f"SED file {_where(raw)!r} states the unit {stated!r} for {columns}, which afferent does not know; "
            f"pass {param}= with one of the supported units."
        )
    if declared is not None:
        f = factor_of(declared, name=f"{param!r}")
        if stated is not None and not np.isclose(factor_of(parse_unit(stated)), f, rtol=1e-12):
            raise UnitError(
                f"{param!r} is {declared!r} but SED file {_where(raw)!r} states {stated!r} for {columns}; "
                f"drop {param} or make it agree with the file."
            )
        return declared, f, "declared"
    if stated is not None:
        return parse_unit(stated), factor_of(parse_unit(stated)), "file"
    raise UnitError(
        f"The {kind} unit of {columns} in SED file {_where(raw)!r} is neither stated in the file nor declared; "
        f"pass {param}= (e.g. {param}={'mm' if kind == 'length' else 'MPa' if kind != 'time' else 's'!r})."
    )


def _check_values(raw: RawExport, values: np.ndarray, what: str) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        t, i = np.argwhere(bad.reshape(values.shape[0], values.shape[1], -1).any(-1))[0]
        kind = "NaN" if np.isnan(values[t, i]).any() else "infinite"
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: {what} must be finite; got {int(bad.sum())} non-finite value(s) "
            f"(first: {kind} at row {int(i)}{f', step {int(t)}' if values.shape[0] > 1 else ''}) instead."
            + (" Pass on_nan='drop' to leave such rows out." if raw.cells is None else "")
        )


def _merge_duplicate_points(raw: RawExport, xyz: np.ndarray, sed: np.ndarray):
    """A point table listing a point twice: merged if the values agree, refused if not.

    Tables written per element (element-nodal values) repeat shared nodes; where the values
    agree the copies carry nothing, where they differ the table holds unaveraged element-nodal
    values and no single SED belongs to the point.
    """
    _, first, inverse, counts = np.unique(xyz, axis=0, return_index=True, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    if counts.max(initial=1) == 1:
        return xyz, sed, 0
    ref = sed[:, first[inverse]]  # each row's group's first value
    scale = float(np.max(np.abs(sed))) or 1.0
    differ = np.abs(sed - ref).max(axis=0) > 1e-12 * scale
    if differ.any():
        j = int(np.flatnonzero(differ)[0])
        i = int(first[inverse[j]])
        t = int(np.argmax(np.abs(sed[:, j] - sed[:, i])))
        raise SEDFormatError(
            f"SED file {_where(raw)!r} lists the point ({', '.join(f'{v:g}' for v in xyz[j])}) more than once with "
            f"different SED (rows {i} and {j}: {sed[t, i]:.6g} and {sed[t, j]:.6g} J/m^3); {int(np.sum(counts > 1))} point(s) "
            "repeat. These look like unaveraged element-nodal values: export one value per node (averaged, 'unique "
            "nodal') or per element (centroid)."
        )
    keep = np.sort(first)
    return xyz[keep], sed[:, keep], int(xyz.shape[0] - keep.size)


def _scaled_difference(ref: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """(relative L2 difference of ``ref`` and ``scale * u``, scale) for the least-squares scale."""
    ok = np.isfinite(ref) & np.isfinite(u)
    ref, u = ref[ok], u[ok]
    nref, uu = float(np.linalg.norm(ref)), float(u @ u)
    if nref == 0.0:
        return (0.0 if uu == 0.0 else float("inf")), 1.0
    if uu == 0.0:
        return float("inf"), float("nan")
    scale = float(ref @ u) / uu
    return float(np.linalg.norm(ref - scale * u)) / nref, scale


def _percent(rel: float) -> str:
    return f"{100 * rel:.3g} %" if rel > 1e-9 else "< 1e-7 % (round-off)"


def _presets_like(check: dict, name: str) -> str:
    """The presets whose difference equals that of ``name`` up to round-off, as 'preset(s) ...'."""
    ref = check["by_preset"][name]
    same = [p for p, r in check["by_preset"].items() if abs(r - ref) <= 1e-9 + 1e-6 * ref]
    return ("presets " if len(same) > 1 else "preset ") + ", ".join(map(repr, same)) + (" give" if len(same) > 1 else " gives")


def tensor_sed_crosscheck(raw: RawExport, opts: ReadOptions) -> dict | None:
    """Compare SED computed from the export's tensors with the export's own SED array.

    Many tools write an SED array beside stress and strain. For linear elasticity the two
    agree when the component order and shear convention are right, whatever the units (a
    least-squares scale factor absorbs a unit difference and is reported). The comparison is
    made at the step with the largest total SED, under the convention in use and under every
    preset of :data:`afferent.strain_energy.PRESETS`.

    What it can tell: the shear convention (engineering shear read as tensor shear doubles the
    shear terms). What it cannot: the order of the shear components, since relabelling yz and
    xz in both tensors leaves 1/2 sigma:eps unchanged - and the 'equivalent' SED too (its von
    Mises forms depend on the sum of the squared shear components). So a mix-up among the shear
    components cannot change any SED afferent computes; the order comes from the component
    names or the preset.

    Returns
    -------
    dict or None
        None when the export lacks an SED array or tensors at the same location. Otherwise
        ``sed_array``, ``step``, ``convention`` (the preset or shear in use), ``relative_difference``
        and ``scale`` (SED array ~ scale x SED from the tensors, both in the file's units: 1 when
        the SED array is in the stress unit; for the best preset when no convention is declared), ``by_preset`` (relative difference per
        preset), ``best_preset``, ``tolerance`` (:data:`CROSSCHECK_RTOL`) and ``agree`` (bool).
    """
    try:
        (_, _, tloc), _ = find_tensors(raw, replace(opts, sed_from="exact"), need_convention=False)
        arr = find_sed_array(raw, ReadOptions(location=tloc))[0]
    except (SEDFormatError, ValueError):
        return None
    if arr.location != tloc or (arr.values.ndim == 3 and arr.values.shape[2] != 1):
        return None
    ref = arr.values.reshape(arr.values.shape[0], -1)
    step = int(np.argmax(np.nansum(np.abs(ref), axis=1)))
    one = replace(raw, arrays={k: replace(a, values=a.values[step:step + 1]) for k, a in raw.arrays.items()}, times=None)
    columns = dict(location=tloc, stress_columns=opts.stress_columns, strain_columns=opts.strain_columns)

    def difference(raw_k, options):
        (_, s, _), (_, e, _) = find_tensors(raw_k, options)
        return _scaled_difference(ref[step], sed_exact(s, e)[0])

    free = replace(one, preset=None)
    by_preset, scales = {}, {}
    for name in PRESETS:
        by_preset[name], scales[name] = difference(free, ReadOptions(sed_from="exact", preset=name, **columns))
    best = min(by_preset, key=by_preset.get)
    in_use = opts.preset or raw.preset
    if in_use or opts.shear:
        rel, scale = difference(one, ReadOptions(sed_from="exact", preset=opts.preset, shear=opts.shear, **columns))
    else:  # no convention declared (afferent info): report the presets only
        rel, scale = by_preset[best], scales[best]
    return {
        "sed_array": arr.name, "step": step,
        "convention": (f"preset={in_use!r}" if in_use else "") + (f" shear={opts.shear!r}" if opts.shear else ""),
        "relative_difference": rel, "scale": scale, "by_preset": by_preset, "best_preset": best,
        "location": tloc, "tolerance": CROSSCHECK_RTOL[tloc], "agree": bool(rel <= CROSSCHECK_RTOL[tloc]),
    }


def shear_consistency(stress, strain) -> dict | None:
    """Is the strain's shear convention right? A check that needs no material data.

    For an isotropic linear-elastic solid the deviatoric stress is 2G times the deviatoric
    strain, for the normal (xx - mean) and the shear (xy, yz, xz) components alike. Fitting
    ``sigma_dev = k_n eps_dev`` on the normal components and ``sigma_ij = k_s eps_ij`` on the
    shear components over all points and steps gives ``k_s / k_n = 1`` when the shear strain is
    read with the right convention, 0.5 when engineering shear is read as tensor shear and 2 for
    the reverse. Averaging to the nodes is linear, so nodal data obey it too (CalculiX nodal
    STRESS/TOSTRAIN: to 3e-6); several materials or mild nonlinearity move it a little, never
    by a factor 2.

    Parameters
    ----------
    stress, strain : ndarray of shape (..., 6)
        Canonical components (xx yy zz xy yz xz); strain with the shear as read (tensor).

    Returns
    -------
    dict or None
        ``ratio`` (k_s / k_n), ``k_normal``, ``k_shear`` (Pa per unit strain, 2G for an
        isotropic solid), ``band`` and ``consistent``; None when the data hold too little shear
        or deviatoric strain to tell.
    """
    s = np.asarray(stress, dtype=float).reshape(-1, 6)
    e = np.asarray(strain, dtype=float).reshape(-1, 6)
    ok = np.isfinite(s).all(axis=1) & np.isfinite(e).all(axis=1)
    s, e = s[ok], e[ok]
    sd = s[:, :3] - s[:, :3].mean(axis=1, keepdims=True)
    ed = e[:, :3] - e[:, :3].mean(axis=1, keepdims=True)
    en, es = float(np.sum(ed * ed)), float(np.sum(e[:, 3:] ** 2))
    if en == 0.0 or es <= 1e-6 * en or es == 0.0:
        return None
    k_n, k_s = float(np.sum(sd * ed)) / en, float(np.sum(s[:, 3:] * e[:, 3:])) / es
    if k_n <= 0.0:
        return None
    ratio = k_s / k_n
    return {"ratio": ratio, "k_normal": k_n, "k_shear": k_s, "band": list(SHEAR_RATIO_BAND),
            "consistent": bool(SHEAR_RATIO_BAND[0] <= ratio <= SHEAR_RATIO_BAND[1])}


def _tensor_checks(raw: RawExport, opts: ReadOptions, s: np.ndarray, e: np.ndarray, location: str, checks: dict):
    """Run the tensor cross-checks, record them in ``checks``; return the warning texts."""
    messages = []
    conv = _convention(opts, raw)
    in_use = (f"preset={opts.preset or raw.preset!r}" if (opts.preset or raw.preset) else "") + (
        f" shear={opts.shear!r}" if opts.shear else "")
    shear = shear_consistency(s, e)
    if shear is not None:
        checks["shear_convention"] = shear
        if not shear["consistent"]:
            other = "tensor" if conv.shear == "engineering" else "engineering"
            messages.append(
                f"SED file {_where(raw)!r}: with the shear strain read as {conv.shear} ({in_use.strip()}), the shear "
                f"components of stress and strain are {shear['ratio']:.3g} x as stiff as the normal ones (1 for an "
                f"isotropic solid): the file's shear strain looks {other}. Check the preset or pass shear={other!r}."
            )
    check = tensor_sed_crosscheck(raw, opts)
    if check is not None:
        checks["tensor_sed_vs_export_sed"] = check
        if not check["agree"]:
            best = check["best_preset"]
            messages.append(
                f"SED file {_where(raw)!r}: 1/2 sigma:eps from the tensors ({check['convention'].strip()}) differs from "
                f"the file's own SED array {check['sed_array']!r} by {_percent(check['relative_difference'])} "
                f"(relative L2 at step {check['step']}, after a scale of {check['scale']:.4g}; expected below "
                f"{_percent(check['tolerance'])} for {check['location']} data); {_presets_like(check, best)} "
                f"{_percent(check['by_preset'][best])}. Check the preset and the columns."
            )
    return messages


def negative_sed_report(sed: np.ndarray, tolerance: float = NEGATIVE_SED_RTOL) -> dict | None:
    """Count and size the negative values of an SED array; None when there are none.

    Parameters
    ----------
    sed : ndarray of shape (n_times, n_values)
        SED in any unit (the report's ``min_pa`` is in the same unit).
    tolerance : float
        Accepted size of the negatives: the most negative value at most ``tolerance`` x the
        largest SED, and the negatives' sum at most ``tolerance`` x the positives' sum.

    Returns
    -------
    dict or None
        ``count``, ``n_values``, ``min_pa`` (most negative value), ``min_relative`` (that value
        over the largest SED; -inf when no value is positive), ``negative_share`` (sum of the
        negatives' magnitudes over the sum of the positive values), ``tolerance``,
        ``within_tolerance``, ``action`` ('set to 0' or 'refused'), ``first_step``, ``first_row``.
    """
    neg = sed < 0
    if not neg.any():
        return None
    smax = float(np.max(sed))
    smin = float(np.min(sed))
    pos_sum = float(np.sum(sed[sed > 0]))
    rel = smin / smax if smax > 0 else -np.inf
    share = float(-np.sum(sed[neg])) / pos_sum if pos_sum > 0 else np.inf
    ok = bool(-rel <= tolerance and share <= tolerance)
    t, i = np.argwhere(neg)[0]
    return {
        "count": int(neg.sum()), "n_values": int(sed.size), "min_pa": smin, "min_relative": rel,
        "negative_share": share, "tolerance": float(tolerance), "within_tolerance": ok,
        "action": "set to 0" if ok else "refused", "first_step": int(t), "first_row": int(i),
    }
def _location_source(raw: RawExport, opts: ReadOptions, location: str) -> str:
    """How the location of the values used was chosen, for the provenance: ``'declared'``,
    ``'only point data'`` / ``'only cell data'``, or ``'point preferred over cell'`` when the
    export holds the same quantity (SED, or stress and strain) at both locations."""
    if opts.location is not None:
        return "declared"
    other = "cell" if location == "point" else "point"
    try:
        if opts.sed_from == "field":
            found = find_sed_array(raw, replace(opts, location=other))[0].location
        else:
            found = find_tensors(raw, replace(opts, location=other), need_convention=False)[0][2]
    except SEDFormatError:
        found = None
    return f"{location} preferred over {other}" if found == other else f"only {location} data"


@dataclass
class _Record:
    """What :func:`assemble` learns on the way, for the provenance: notes, checks, columns, units, factors."""

    notes: list
    checks: dict = field(default_factory=dict)
    columns: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    factors: dict = field(default_factory=dict)


def _prepared(raw: RawExport, opts: ReadOptions) -> RawExport:
    """The export with the declared coordinate file joined and, if asked, rows holding NaN dropped."""
    if opts.coordinates is not None:
        raw = join_coordinates(raw, opts.coordinates)
    if opts.on_nan == "drop":
        if raw.cells is not None:
            raise ValueError("on_nan='drop' applies to point tables (CSV); a mesh export cannot lose points.")
        raw = drop_nan_rows(raw, list(raw.arrays))
    return raw


def _coordinates(raw: RawExport, opts: ReadOptions, rec: _Record):
    """Coordinates in file units, and the length unit: (xyz, factor to m, unit, where the unit came from)."""
    xyz, coord_names = find_coordinates(raw, opts)
    rec.columns["coordinates"] = list(coord_names)
    _check_values(raw, xyz[None], f"coordinates ({', '.join(coord_names)})")
    lu, lf, lsrc = _unit(raw, opts.length_unit, raw.length_unit, "length", "length_unit", "the coordinates")
    rec.units.update(length=lu, length_source=lsrc)
    rec.factors["length"] = lf
    return xyz, lf, lu, lsrc


def _sed_from_field(raw: RawExport, opts: ReadOptions, rec: _Record) -> tuple[np.ndarray, str]:
    """SED read from the export's SED array(s), in J/m^3: (sed (n_times, n_values), location)."""
    arrays = find_sed_array(raw, opts)
    if len(arrays) > 1:
        sed = np.concatenate([a.values for a in arrays], axis=0)
    else:
        sed = arrays[0].values
    if sed.ndim == 3:
        if sed.shape[2] != 1:
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: SED array {arrays[0].name!r} must be scalar; "
                f"got {sed.shape[2]} components instead."
            )
        sed = sed[..., 0]
    location = arrays[0].location
    label = ", ".join(a.name for a in arrays)
    rec.columns["sed"] = label
    stated = {a.unit for a in arrays}
    if len(stated) > 1:
        raise UnitError(f"SED file {_where(raw)!r}: SED columns {label} state different units {sorted(map(str, stated))}.")
    _check_values(raw, sed, f"SED column {label!r}")
    su, sf, ssrc = _unit(raw, opts.sed_unit, stated.pop(), "sed", "sed_unit", f"SED column {label!r}")
    rec.units.update(sed=su, sed_source=ssrc)
    rec.factors["sed"] = sf
    sed = sed * sf
    if opts.stress_unit is not None:
        rec.notes.append(f"stress_unit={opts.stress_unit!r} ignored: SED read from the field, not computed from stress.")
    return sed, location


def _sed_from_tensors(raw: RawExport, opts: ReadOptions, rec: _Record) -> tuple[np.ndarray, str]:
    """SED computed from the stress and strain tensors, in J/m^3, after their checks (which warn)."""
    if opts.sed_unit is not None:
        raise ValueError(
            f"sed_unit={opts.sed_unit!r} does not apply with sed_from={opts.sed_from!r}: SED is computed from "
            "stress, so declare stress_unit= instead."
        )
    (s_name, s, location), (e_name, e, _) = find_tensors(raw, opts)
    conv = _convention(opts, raw)
    rec.columns.update(stress=s_name, strain=e_name)
    _check_values(raw, s, f"stress ({s_name})")
    _check_values(raw, e, f"strain ({e_name})")
    stated = {a.unit for a in raw.arrays.values() if a.name in s_name.split(", ") or a.name == s_name}
    stated.discard(None)
    su, sf, ssrc = _unit(
        raw, opts.stress_unit, stated.pop() if len(stated) == 1 else None, "stress", "stress_unit", f"stress ({s_name})"
    )
    rec.units.update(stress=su, stress_source=ssrc, strain="1")
    rec.factors["stress"] = sf
    s = s * sf
    rec.notes.append(
        f"SED computed from tensors: {'1/2 sigma:eps' if opts.sed_from == 'exact' else '1/2 sigma_e eps_e (nu=%g)' % opts.poisson}; "
        f"shear strain read as {conv.shear} (preset={opts.preset or raw.preset!r}"
        f"{', implied by the file format' if opts.preset is None and raw.preset else ''})."
    )
    sed = sed_exact(s, e) if opts.sed_from == "exact" else sed_equivalent(s, e, opts.poisson)
    for msg in _tensor_checks(raw, opts, s, e, location, rec.checks):
        rec.notes.append(msg)
        warnings.warn(msg, AfferentWarning, stacklevel=4)  # the caller of assemble's caller, as before the cut
    return sed, location


def _integration_points(raw: RawExport, opts: ReadOptions, sed: np.ndarray, xyz: np.ndarray, notes: list):
    """SED at integration points (a joined coordinate file) averaged per element: (sed, xyz)."""
    groups = integration_point_groups(raw) if opts.coordinates is not None else None
    if groups is None:
        return sed, xyz
    sed, first = average_per_element(sed, groups)
    counts = np.unique(np.bincount(groups))
    notes.append(f"SED at {groups.size} integration points averaged per element ({sed.shape[1]} elements, "
                 f"{', '.join(map(str, counts))} point(s) each, equal weights: the Gauss average for C3D8, C3D20R, "
                 "C3D10, C3D4, C3D8R; not for C3D20 or wedges) and placed at the element's coordinates.")
    return sed, xyz[first]


def _negatives(raw: RawExport, opts: ReadOptions, sed: np.ndarray, rec: _Record):
    """Negative SED: refused beyond the tolerance, else set to 0 with a warning: (sed, report or None)."""
    negative = negative_sed_report(sed, opts.negative_tolerance)
    if negative is None:
        return sed, None
    unit_factor = rec.factors.get("sed", rec.factors.get("stress", 1.0))
    where = f"row {negative['first_row']}" + (f", step {negative['first_step']}" if sed.shape[0] > 1 else "")
    if not negative["within_tolerance"]:
        rel = negative["min_relative"]
        relative = (f"{rel:.3g} x the largest SED; the negatives sum to {negative['negative_share']:.3g} x the "
                    "positives" if np.isfinite(rel) else "and no value is positive")
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: SED must be >= 0 J/m^3 up to the nodal-extrapolation artefacts of FE tools; got "
            f"{negative['count']} negative value(s) down to {negative['min_pa'] / unit_factor:.6g} in file units "
            f"({relative}; first at {where}), beyond the tolerance {opts.negative_tolerance:g}. Check the column, the "
            "sign convention and the shear convention; if the tool's extrapolation really is that coarse, raise "
            "negative_tolerance."
        )
    msg = (
        f"SED file {_where(raw)!r}: {negative['count']} of {sed.size} SED value(s) are negative (down to "
        f"{negative['min_relative']:.2g} x the largest SED; they sum to {negative['negative_share']:.2g} x the positive "
        f"values; tolerance {opts.negative_tolerance:g}), as FE tools write where they extrapolate integration-point "
        "values to the nodes near steep gradients; set to 0. SED near those nodes is unreliable (a finer mesh or "
        "integration-point output tells how much)."
    )
    rec.notes.append(msg)
    warnings.warn(msg, AfferentWarning, stacklevel=4)  # the caller of assemble's caller, as before the cut
    return np.maximum(sed, 0.0), negative


def _times(raw: RawExport, opts: ReadOptions, n_times: int, rec: _Record) -> np.ndarray:
    """Step times in s: declared, else the export's, else 0, 1, ...; strictly increasing."""
    if opts.times is not None:
        times = np.asarray(opts.times, dtype=float)
        tu, tf, tsrc = (opts.time_unit or "s"), time_factor(opts.time_unit or "s"), "declared"
        if times.shape != (n_times,):
            raise ValueError(
                f"'times' must have one entry per time step ({n_times}); got {times.shape[0] if times.ndim else 1} instead."
            )
    elif raw.times is not None:
        times = np.asarray(raw.times, dtype=float)
        tu, tf, tsrc = _unit(raw, opts.time_unit, raw.time_unit, "time", "time_unit", "the step times") if (
            opts.time_unit or raw.time_unit) else ("s", 1.0, "assumed: no unit stated; FE step times are in s")
    else:
        times = np.arange(n_times, dtype=float)
        tu, tf, tsrc = "s", 1.0, "none in the file: steps numbered 0, 1, ..."
        if n_times > 1:
            rec.notes.append("The export states no step times; steps are numbered 0, 1, ... (pass times= to set them).")
    rec.units.update(time=tu, time_source=tsrc)
    rec.factors["time"] = tf
    times = times * tf
    if times.size > 1 and not np.all(np.diff(times) > 0):
        k = int(np.argmin(np.diff(times) > 0))
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: time steps must be strictly increasing; got {float(times[k] / tf)!r} followed by "
            f"{float(times[k + 1] / tf)!r} (steps {k} and {k + 1}) instead."
        )
    return times


def _plausibility(raw: RawExport, opts: ReadOptions, sed: np.ndarray, xyz_m: np.ndarray, length: str, rec: _Record):
    """Warn when the SED or the span of the coordinates (m) is implausible for skin: a wrong unit, most likely."""
    units = rec.units
    unit_key = "sed_unit" if opts.sed_from == "field" else "stress_unit"
    for msg in (
        sed_warning(sed, what=f"SED file {_where(raw)!r} ({units.get('sed', units.get('stress'))} {units.get('sed_source', units.get('stress_source'))})",
                    unit_hint=repr(unit_key)),
        span_warning(xyz_m, what=f"SED file {_where(raw)!r} (length unit {length})", unit_hint="'length_unit'"),
    ):
        if msg:
            rec.notes.append(msg)
            warnings.warn(msg, AfferentWarning, stacklevel=4)  # the caller of assemble's caller, as before the cut


def assemble(raw: RawExport, opts: ReadOptions) -> SEDField:
    """Build the SI :class:`SEDField` from a reader's raw export and the user's declarations.

    The steps, in order: coordinates, SED (from the field or from the tensors), integration
    points averaged per element, negative SED, step times, duplicate points, plausibility.
    """
    raw = _prepared(raw, opts)
    rec = _Record(notes=list(raw.notes))
    xyz, lf, lu, lsrc = _coordinates(raw, opts, rec)
    if opts.sed_from == "field":
        sed, location = _sed_from_field(raw, opts, rec)
    else:
        sed, location = _sed_from_tensors(raw, opts, rec)
    sed, xyz = _integration_points(raw, opts, sed, xyz, rec.notes)
    sed, negative = _negatives(raw, opts, sed, rec)
    times = _times(raw, opts, sed.shape[0], rec)
    if location == "cell" and raw.cells is None:
        raise SEDFormatError(f"SED file {_where(raw)!r}: SED is cell data but the file has no volume cells.")
    if raw.cells is None:
        xyz, sed, merged = _merge_duplicate_points(raw, xyz, sed)
        if merged:
            rec.notes.append(f"{merged} point(s) listed twice with the same SED merged (a table written per element?).")
    _plausibility(raw, opts, sed, xyz * lf, f"{lu} {lsrc}", rec)
    prov = Provenance(
        files=raw.files, format=raw.format, sed_from=opts.sed_from, columns=rec.columns, units=rec.units,
        factors=rec.factors, notes=tuple(rec.notes), negative_sed=negative, checks=rec.checks,
        location=location, location_source=_location_source(raw, opts, location),
    )
    try:
        return SEDField(xyz * lf, sed, times, location=location, cells=raw.cells, provenance=prov)
    except ValueError as err:
        raise SEDFormatError(f"SED file {_where(raw)!r}: {err}") from err
