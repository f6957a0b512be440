"""Turn a format reader's :class:`RawExport` into an :class:`~afferent.field.SEDField`.

Done once here for every format: pick the coordinate columns and the SED array (or the
stress and strain tensors), apply the declared or stated units, compute SED from tensors
when asked, and validate what the FE export holds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._validation import check_option, suggest
from ..exceptions import SEDFormatError, UnitError
from ..field import Provenance, SEDField
from ..strain_energy import PRESETS, Convention, sed_equivalent, sed_exact, to_canonical
from ..units import length_factor, parse_unit, sed_factor, time_factor
from . import _columns as C
from ._raw import RawArray, RawExport

__all__ = ["ReadOptions", "assemble", "find_sed_array", "find_tensors", "find_coordinates"]

#: Relative size of a negative SED value, against the largest |SED|, tolerated as round-off
#: (clipped to 0 and noted). Anything more negative is an error: SED >= 0 for elastic solids.
NEGATIVE_SED_RTOL = 1e-9

SED_FROM = ("field", "exact", "equivalent")


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

    def __post_init__(self):
        check_option("sed_from", self.sed_from, SED_FROM)
        if self.preset is not None:
            check_option("preset", self.preset, tuple(PRESETS))
        if self.shear is not None:
            check_option("shear", self.shear, ("tensor", "engineering"))
        if self.location is not None:
            check_option("location", self.location, ("point", "cell"))
        check_option("on_nan", self.on_nan, ("raise", "drop"))
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


def join_coordinates(raw: RawExport, path: str) -> RawExport:
    """Attach coordinates from a node (or element-centroid) table ``id, x, y, z`` to a table
    keyed by node/element label (an Abaqus report, a FEBio logfile, a CalculiX .dat)."""
    from ._csv import read_csv

    table = read_csv(path)
    xyz, names = find_coordinates(table, ReadOptions())
    tid = _id_array(table)
    if tid is None:
        raise SEDFormatError(
            f"Coordinates file {path!r} must have an id column (e.g. 'Node Label', 'node', 'id') and x, y, z; "
            f"found {_names(table)}."
        )
    rid = _id_array(raw)
    if rid is None:
        raise SEDFormatError(
            f"SED file {_where(raw)!r} has no node/element id column to join coordinates on; found {_names(raw)}."
        )
    t_ids, r_ids = tid.values[0], rid.values[0]
    if len(np.unique(t_ids)) != t_ids.size:
        raise SEDFormatError(f"Coordinates file {path!r}: ids in column {tid.name!r} must be unique.")
    if len(np.unique(r_ids)) != r_ids.size:
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: ids in column {rid.name!r} repeat (integration-point rows?); export one value "
            "per node or per element (centroid or averaged) to place it at one coordinate."
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
        cells=None, length_unit=table.length_unit, time_unit=raw.time_unit,
        notes=raw.notes + (f"coordinates joined from {path!r} on {rid.name!r} = {tid.name!r} ({', '.join(names)}).",),
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


def find_sed_array(raw: RawExport, opts: ReadOptions) -> list[RawArray]:
    """The SED array(s) to use: one array, or one per step when ``sed_column`` lists several."""
    if opts.sed_column is not None:
        names = (opts.sed_column,) if isinstance(opts.sed_column, str) else tuple(opts.sed_column)
        return [_by_name(raw, n, "the SED", opts.location) for n in names]
    arrays = list(raw.arrays.values())
    for alias in C.SED_ALIASES:
        hits = [a for a in arrays if C.canonical(a.name) == alias or C.canonical(a.name).startswith(alias + "@")]
        hits = [a for a in hits if opts.location is None or a.location == opts.location]
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
        tensor_arrays = [
            a for a in raw.arrays.values()
            if a.values.ndim == 3 and C.canonical(a.name) in C.TENSOR_ARRAY_NAMES[kind]
            and (opts.location is None or a.location == opts.location)
        ]
        if tensor_arrays:
            arr = tensor_arrays[0]
            out.append((arr.name, _tensor_from_array(arr, kind, conv or PRESETS["vtk"], raw), arr.location))
            continue
        found, missing = [], []
        for comp in ("xx", "yy", "zz", "xy", "yz", "xz"):
            hits = [a for a in raw.arrays.values() if a.values.ndim == 2 and C.canonical(a.name) in comp_table[comp]]
            (found if hits else missing).append(hits[0] if hits else comp)
        if missing:
            have = f" (found {', '.join(repr(a.name) for a in found)})" if found else ""
            raise SEDFormatError(
                f"SED file {_where(raw)!r} has no complete {kind} tensor{have}; missing component(s) "
                f"{', '.join(missing)}. Found {_names(raw)}. Pass {kind}_columns=(6 names, xx yy zz xy yz xz)."
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
            f"{', '.join(map(repr, PRESETS))}, or shear='tensor'|'engineering'."
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
            + (" Pass on_nan='drop' (--on-nan drop) to leave such rows out." if raw.cells is None else "")
        )


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


def assemble(raw: RawExport, opts: ReadOptions) -> SEDField:
    """Build the SI :class:`SEDField` from a reader's raw export and the user's declarations."""
    if opts.coordinates is not None:
        raw = join_coordinates(raw, opts.coordinates)
    if opts.on_nan == "drop":
        if raw.cells is not None:
            raise ValueError("on_nan='drop' applies to point tables (CSV); a mesh export cannot lose points.")
        raw = drop_nan_rows(raw, list(raw.arrays))
    notes = list(raw.notes)
    columns: dict = {}
    units: dict = {}
    factors: dict = {}

    xyz, coord_names = find_coordinates(raw, opts)
    columns["coordinates"] = list(coord_names)
    _check_values(raw, xyz[None], f"coordinates ({', '.join(coord_names)})")
    lu, lf, lsrc = _unit(raw, opts.length_unit, raw.length_unit, "length", "length_unit", "the coordinates")
    units.update(length=lu, length_source=lsrc)
    factors["length"] = lf

    if opts.sed_from == "field":
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
        columns["sed"] = label
        stated = {a.unit for a in arrays}
        if len(stated) > 1:
            raise UnitError(f"SED file {_where(raw)!r}: SED columns {label} state different units {sorted(map(str, stated))}.")
        _check_values(raw, sed, f"SED column {label!r}")
        su, sf, ssrc = _unit(raw, opts.sed_unit, stated.pop(), "sed", "sed_unit", f"SED column {label!r}")
        units.update(sed=su, sed_source=ssrc)
        factors["sed"] = sf
        sed = sed * sf
        if opts.stress_unit is not None:
            notes.append(f"stress_unit={opts.stress_unit!r} ignored: SED read from the field, not computed from stress.")
    else:
        if opts.sed_unit is not None:
            raise ValueError(
                f"sed_unit={opts.sed_unit!r} does not apply with sed_from={opts.sed_from!r}: SED is computed from "
                "stress, so declare stress_unit= instead."
            )
        (s_name, s, location), (e_name, e, _) = find_tensors(raw, opts)
        conv = _convention(opts, raw)
        columns.update(stress=s_name, strain=e_name)
        _check_values(raw, s, f"stress ({s_name})")
        _check_values(raw, e, f"strain ({e_name})")
        stated = {a.unit for a in raw.arrays.values() if a.name in s_name.split(", ") or a.name == s_name}
        stated.discard(None)
        su, sf, ssrc = _unit(
            raw, opts.stress_unit, stated.pop() if len(stated) == 1 else None, "stress", "stress_unit", f"stress ({s_name})"
        )
        units.update(stress=su, stress_source=ssrc, strain="1")
        factors["stress"] = sf
        s = s * sf
        notes.append(
            f"SED computed from tensors: {'1/2 sigma:eps' if opts.sed_from == 'exact' else '1/2 sigma_e eps_e (nu=%g)' % opts.poisson}; "
            f"shear strain read as {conv.shear} (preset={opts.preset or raw.preset!r}"
            f"{', implied by the file format' if opts.preset is None and raw.preset else ''})."
        )
        sed = sed_exact(s, e) if opts.sed_from == "exact" else sed_equivalent(s, e, opts.poisson)

    # SED >= 0 for an elastic solid; tolerate round-off only.
    scale = float(np.max(np.abs(sed))) if sed.size else 0.0
    neg = sed < -NEGATIVE_SED_RTOL * scale
    if neg.any():
        t, i = np.argwhere(neg)[0]
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: SED must be >= 0 J/m^3; got {int(neg.sum())} negative value(s) "
            f"(first: {float(sed[t, i] / factors.get('sed', factors.get('stress', 1.0)))!r} in file units at row {int(i)}) instead. "
            "Check the column, the sign convention and the shear convention."
        )
    if (sed < 0).any():
        notes.append(f"{int((sed < 0).sum())} round-off negative SED value(s) (>= -{NEGATIVE_SED_RTOL:g} x max) set to 0.")
        sed = np.maximum(sed, 0.0)

    n_times = sed.shape[0]
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
            notes.append("The export states no step times; steps are numbered 0, 1, ... (pass times= to set them).")
    units.update(time=tu, time_source=tsrc)
    factors["time"] = tf
    times = times * tf
    if times.size > 1 and not np.all(np.diff(times) > 0):
        k = int(np.argmin(np.diff(times) > 0))
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: time steps must be strictly increasing; got {float(times[k] / tf)!r} followed by "
            f"{float(times[k + 1] / tf)!r} (steps {k} and {k + 1}) instead."
        )
    if location == "cell" and raw.cells is None:
        raise SEDFormatError(f"SED file {_where(raw)!r}: SED is cell data but the file has no volume cells.")
    prov = Provenance(
        files=raw.files, format=raw.format, sed_from=opts.sed_from, columns=columns, units=units,
        factors=factors, notes=tuple(notes), location=location, location_source=_location_source(raw, opts, location),
    )
    try:
        return SEDField(xyz * lf, sed, times, location=location, cells=raw.cells, provenance=prov)
    except ValueError as err:
        raise SEDFormatError(f"SED file {_where(raw)!r}: {err}") from err
