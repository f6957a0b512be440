"""Turn a format reader's :class:`RawExport` into an :class:`~afferent.field.SEDField`.

Done once here for every format: pick the coordinate columns and the SED array (or the
stress and strain tensors), apply the declared or stated units, compute SED from tensors
when asked, and validate what the FE export holds.

The parts: ``_read_options.py`` (:class:`ReadOptions`, default tolerances), ``_find_arrays.py``
(which arrays are the coordinates, SED, tensors), ``_export_checks.py`` (checks of the values),
and here the units and :func:`assemble`, one named step per stage. The names of those modules
stay importable from here.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from .._plausibility import sed_warning, span_warning
from ..exceptions import AfferentWarning, SEDFormatError, UnitError
from ..field import Provenance, SEDField
from ..strain_energy import sed_equivalent, sed_exact
from ..units import length_factor, parse_unit, sed_factor, time_factor
from ._export_checks import (  # noqa: F401 (importable from here, as before the split)
    _check_values,
    _merge_duplicate_points,
    _percent,
    _tensor_checks,
    negative_sed_report,
    shear_consistency,
    tensor_sed_crosscheck,
)
from ._find_arrays import (
    FULL_TENSORS,
    _convention,
    _undecided,
    abaqus_coordinates,
    abaqus_reference_frame,
    _where,
    average_per_element,
    drop_nan_rows,
    find_coordinates,
    find_material_array,
    find_sed_array,
    find_tensor,
    find_tensors,
    integration_point_groups,
    join_coordinates,
)
from ._coincident import COINCIDENT_WARN_RTOL, merge_coincident
from . import _columns as C
from ._raw import RawExport
from ._read_options import (  # noqa: F401 (importable from here, as before the split)
    CROSSCHECK_RTOL,
    NEGATIVE_SED_RTOL,
    SED_FROM,
    SED_SCALE_BAND,
    SHEAR_RATIO_BAND,
    ReadOptions,
)

__all__ = ["ReadOptions", "assemble", "find_sed_array", "find_tensors", "find_coordinates"]


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
        elif opts.sed_from == "stress":
            found = find_tensor(raw, replace(opts, location=other), "stress")[2]
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


def _coordinates(raw: RawExport, opts: ReadOptions, rec: _Record, *, checked: bool = False):
    """Coordinates in file units, and the length unit: (xyz, factor to m, unit, where the unit came from).

    ``checked``: the same points object passed the value check at an earlier step of the series.
    """
    xyz, coord_names = find_coordinates(raw, opts)
    rec.columns["coordinates"] = list(coord_names)
    if not checked and abaqus_reference_frame(raw, coord_names):
        rec.notes.append("Coordinates: Abaqus' COORD of the first frame (time 0: the undeformed model), for every frame "
                         "(a later frame's COORD is the deformed position when the step ran with NLGEOM).")
    elif not checked and abaqus_coordinates(coord_names):
        msg = (f"SED file {_where(raw)!r}: the coordinates are Abaqus' COORD output ({', '.join(map(repr, coord_names))}): "
               "the nodes' current (deformed) positions when the step ran with NLGEOM, where receptor sites given in the "
               "undeformed model fall beside the points they mean. Report the step's first frame (increment 0, time 0) "
               "with the others, whose COORD then stands for every frame, or give the reference positions with "
               "coordinates= (node labels and x, y, z).")
        rec.notes.append(msg)
        warnings.warn(msg, AfferentWarning, stacklevel=5)
    if not checked:
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
    _energy_named(raw, opts, arrays[0], rec)
    _is_sed(raw, opts, arrays, rec)
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


def _energy_named(raw: RawExport, opts: ReadOptions, arr, rec: _Record) -> None:
    """Record why an array named like an energy (Kratos' STRAIN_ENERGY) is read as a density:
    its values (against the tensors), or the user's sed_column= confirmation."""
    from ._export_checks import density_by_values

    reason = C.ENERGY_NOT_DENSITY.get(C.canonical(arr.name))
    if not reason:
        return
    check = density_by_values(raw, arr)
    if check is not None:
        rec.checks["density_by_values"] = {k: check[k] for k in ("relative_difference", "scale", "best_preset", "density")}
    if check is not None and check["density"]:
        rec.notes.append(check["note"])
    else:
        msg = (f"{arr.name!r} is named like an energy ({reason}); read as a density because sed_column= says so"
               + (f", although its values are {check['scale']:.3g} x 1/2 sigma:eps of the file's tensors." if check else
                  f" ({_undecided(raw)})."))
        rec.notes.append(msg)
        if check is not None:
            warnings.warn(msg, AfferentWarning, stacklevel=5)


def _confirmed(name: str, opts: ReadOptions, said: str, error, rec: _Record, stacklevel: int) -> None:
    """:func:`afferent._validation.refuse_unless`: refuse ``said`` (what is wrong, its likely cause and the fix) as
    ``error`` unless ``opts.accept`` holds ``name``; confirmed, it is also a note (``stacklevel``: the caller's)."""
    from .._validation import refuse_unless

    refuse_unless(name, opts.accept, said, cls=error, stacklevel=stacklevel + 1)
    rec.notes.append(f"{said} (confirmed: accept='{name}').")


def _is_sed(raw: RawExport, opts: ReadOptions, arrays, rec: _Record) -> None:
    """Refuse an SED array that is a stress measure (by its name, or its values against the stress tensor) or, where
    the export has stress and strain at its location, one that is not 1/2 sigma:eps of them in some unit (its scale
    over it outside :data:`SED_SCALE_BAND` up to a power of 1000); unless ``accept='sed-column'``."""
    from ._unit_physics import stress_measure_named, stress_measure_values

    arr = arrays[0]
    named = stress_measure_named(arr.name)
    reasons = [f"{arr.name!r} is named like {named}"] if named else []
    equal = stress_measure_values(raw, arr, opts)
    if equal is not None:
        times = f"{equal['factor']:g} x " if equal["factor"] != 1 else ""
        reasons.append(f"its values are {times}{equal['measure']} of the stress tensor {equal['stress']!r} (median relative "
                       f"difference {equal['relative_difference']:.1g})")
    check = tensor_sed_crosscheck(raw, replace(opts, sed_column=arr.name, location=arr.location))
    if check is not None and check["checkable"] and check["sed_array"] == arr.name:
        scale = abs(check["scale"])
        power = 1000.0 ** round(np.log10(scale) / 3) if scale > 0 and np.isfinite(scale) else 1.0
        ok = bool(scale > 0 and SED_SCALE_BAND[0] <= scale / power <= SED_SCALE_BAND[1])
        rec.checks["tensor_sed_vs_export_sed"] = dict(check, scale_band=list(SED_SCALE_BAND), unit_factor=power,
                                                      scale_consistent=ok)
        if not ok and equal is None:
            reasons.append(f"its values are {check['scale']:.3g} x 1/2 sigma:eps of the file's tensors at step "
                           f"{check['step']}, not 1/2 sigma:eps in some unit ({SED_SCALE_BAND[0]:g}..{SED_SCALE_BAND[1]:g} "
                           "x a power of 1000), as a stress measure is about 1/eps x it")
    if not reasons:
        return
    rec.checks["sed_array_is_sed"] = {"array": arr.name, "reasons": reasons, "accepted": "sed-column" in opts.accept}
    try:
        other = find_sed_array(raw, replace(opts, sed_column=None))[0].name
    except SEDFormatError:
        other = None
    way = (f"the file's SED array looks like {other!r} (sed_column={other!r})" if other
           and other != arr.name else "compute SED from stress and strain (sed_from='exact')" if _tensors_at(raw, arr)
           else "export the strain-energy density")
    _confirmed("sed-column", opts, f"SED file {_where(raw)!r}: SED column {arr.name!r} is not a strain-energy density: "
               f"{'; '.join(reasons)}; {way}", SEDFormatError, rec, stacklevel=5)


def _tensors_at(raw: RawExport, arr) -> bool:
    """Whether the export has stress and strain tensors at ``arr``'s location."""
    try:
        find_tensors(raw, ReadOptions(sed_from="exact", location=arr.location), need_convention=False)
    except (SEDFormatError, ValueError):
        return False
    return True


def _stiffness(raw: RawExport, opts: ReadOptions, sed: np.ndarray, location: str, rec: _Record, memo: dict) -> None:
    """Units from physics: the elastic stiffness the SED (J/m^3) implies (:mod:`afferent.io._unit_physics`),
    recorded as ``checks['implied_modulus']``; a unit that puts it outside soft tissue's band where another unit would
    not is refused unless ``accept='modulus'``. A series (``memo``) is judged at its first loaded step."""
    from ._unit_physics import implied_modulus, modulus_message, modulus_verdict

    if opts.sed_from == "stress":  # Hooke's law of the file's strain under the declared constants checks the units
        return
    key = "sed" if opts.sed_from == "field" else "stress"
    record = memo.get("modulus")
    if record is None:
        record = modulus_verdict(implied_modulus(raw, opts, sed, location), unit=rec.units[key], factor=rec.factors[key])
        record["unit_source"] = rec.units[f"{key}_source"]
        if record.get("checkable"):
            memo["modulus"] = record
    rec.checks["implied_modulus"] = dict(record, accepted="modulus" in opts.accept) if record.get("verdict") == "unit" \
        else record
    said = modulus_message(_where(raw), record, param=f"{key}_unit")
    if said is None:
        return
    kind, text = said
    if kind == "unit":
        _confirmed("modulus", opts, text, UnitError, rec, stacklevel=4)
    else:
        rec.notes.append(text)
        warnings.warn(text, AfferentWarning, stacklevel=4)


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
        f"{', implied by the file format' if opts.preset is None and raw.preset else ''})"
        + (f": {conv.note}, so no preset or shear is needed." if conv.note == FULL_TENSORS else ".")
    )
    sed = sed_exact(s, e) if opts.sed_from == "exact" else sed_equivalent(s, e, opts.poisson)
    for msg in _tensor_checks(raw, opts, s, e, location, rec.checks, strain_name=e_name):
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
        if n_times > 1 and np.array_equal(times, np.arange(n_times)) and not opts.time_unit:
            rec.notes.append(f"The step times 0, 1, ..., {n_times - 1} the export states are its step numbers (NGSolve's "
                             "VTKOutput.Do() writes its step counter when given no time); read as s: pass times= "
                             "if they are not.")
    else:
        times = np.arange(n_times, dtype=float)  # step numbers, not seconds: the unit says so
        tu, tf, tsrc = "step", 1.0, "none in the file: steps numbered 0, 1, ..."
        if n_times > 1:
            rec.notes.append("The export states no step times; steps are numbered 0, 1, ... (step numbers, not "
                             "seconds; pass times= to set them).")
    if not np.all(np.isfinite(times)):
        k = int(np.flatnonzero(~np.isfinite(times))[0])
        whose = "'times'" if opts.times is not None else f"SED file {_where(raw)!r}: the step times it states"
        raise SEDFormatError(f"{whose} must be finite numbers; got {float(times[k])!r} at step {k} instead.")
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


def _plausibility(raw: RawExport, opts: ReadOptions, sed: np.ndarray, xyz_m: np.ndarray, length: str, rec: _Record,
                  span: str | None | bool = False):
    """Warn when the SED or the span of the coordinates (m) is implausible for skin: a wrong unit, most likely.

    ``span``: the span's warning (or None) already found for these coordinates at an earlier step; False: find it.
    Returns the span's warning.
    """
    units = rec.units
    unit_key = "sed_unit" if opts.sed_from == "field" else "stress_unit"
    if span is False:
        span = span_warning(xyz_m, what=f"SED file {_where(raw)!r} (length unit {length})", unit_hint="'length_unit'")
    for msg in (
        sed_warning(sed, what=f"SED file {_where(raw)!r} ({units.get('sed', units.get('stress'))} {units.get('sed_source', units.get('stress_source'))})",
                    unit_hint=repr(unit_key)),
        span,
    ):
        if msg:
            rec.notes.append(msg)
            warnings.warn(msg, AfferentWarning, stacklevel=4)  # the caller of assemble's caller, as before the cut
    return span


def _mesh(raw: RawExport, xyz: np.ndarray, sed: np.ndarray, location: str, rec: _Record, memo: dict,
          material_array: str | None = None):
    """Material ids onto the cells, coincident points merged into nodes: (xyz, sed, cells, report, sides).

    ``memo`` (a series' steps on one mesh): the cells with the same material ids are the same object
    from step to step, and the coincident points' search is not repeated.
    """
    cells = raw.cells
    if cells is None:
        return xyz, sed, None, None, None
    material = find_material_array(raw, name=material_array)
    if material is None and material_array is not None:  # named by the user: never silently no materials
        held = ", ".join(repr(a.name) for a in raw.arrays.values() if a.location == "cell") or "none"
        raise SEDFormatError(f"SED file {_where(raw)!r} has no cell array {material_array!r} of whole-number material "
                             f"ids (material_array, --material-array); its cell arrays: {held}.")
    if material is not None:
        same = memo.get("same") and memo.get("materials") is not None and np.array_equal(memo["materials"].materials,
                                                                                           material[2])
        cells = memo["materials"] if same else cells.with_materials(material[2])
        memo["materials"] = cells
        rec.columns["material"] = material[0]
        rec.columns["material_location"] = material[1]
    xyz, sed, cells, report, sides = merge_coincident(xyz, sed, location, cells, same_mesh=memo.get("same", False))
    if report is None:
        return xyz, sed, cells, None, None
    lf = rec.factors["length"]
    report["tolerance"] *= lf
    msg = (f"SED file {_where(raw)!r}: {report['n_points']} points are {report['n_nodes']} nodes (up to "
           f"{report['max_copies']} coincident copies each, as in discontinuous output: one patch per cell); merged, "
           f"{'SED = ' + report['rule'] if location == 'point' else 'cell SED kept'}.")
    if location == "point" and report["max_relative"] > COINCIDENT_WARN_RTOL:
        msg += (f" The copies differ from their node's mean by a median {report['median_relative']:.2g} and up to "
                f"{report['max_relative']:.2g} x it (step {report['step']}, {report['nodes_compared']} nodes"
                + (f"; within one material a median {report['within_material']['median_relative']:.2g}, up to "
                   f"{report['within_material']['max_relative']:.2g}" if "within_material" in report else "")
                + f"; warned above "
                f"{COINCIDENT_WARN_RTOL:g}): values near material interfaces and steep gradients are averages across cells "
                "that disagree (see 'afferent info --receptors' and the sampling option side=).")
        warnings.warn(msg, AfferentWarning, stacklevel=4)
    rec.notes.append(msg)
    return xyz, sed, cells, report, sides


def assemble(raw: RawExport, opts: ReadOptions, memo: dict | None = None) -> SEDField:
    """Build the SI :class:`SEDField` from a reader's raw export and the user's declarations.

    The steps, in order: coordinates, SED (from the field or from the tensors), integration
    points averaged per element, negative SED, step times, duplicate points, material ids and
    coincident points (:mod:`afferent.io._coincident`), plausibility.

    ``memo``: a dict kept by :func:`afferent.io.iter_sed` over a series. A step whose points and
    cells are the very objects of the step before (the readers decode a series' mesh once) reuses
    what depends on the mesh alone: the coordinates' check, the coordinates in m, the span's
    plausibility, the cells with their material ids and the coincident points' search. The
    numbers are those of a fresh assemble (tests/test_streaming.py).
    """
    memo = {} if memo is None else memo
    same = memo.get("points") is raw.points and memo.get("cells") is raw.cells and raw.points is not None
    memo.update(same=same, points=raw.points, cells=raw.cells)
    raw = _prepared(raw, opts)
    rec = _Record(notes=list(raw.notes))
    xyz, lf, lu, lsrc = _coordinates(raw, opts, rec, checked=same)
    if opts.sed_from == "field":
        sed, location = _sed_from_field(raw, opts, rec)
    elif opts.sed_from == "stress":
        from ._elastic import sed_from_stress_field

        sed, location = sed_from_stress_field(raw, opts, rec, _unit)
    else:
        sed, location = _sed_from_tensors(raw, opts, rec)
    _stiffness(raw, opts, sed, location, rec, memo)
    sed, xyz = _integration_points(raw, opts, sed, xyz, rec.notes)
    sed, negative = _negatives(raw, opts, sed, rec)
    times = _times(raw, opts, sed.shape[0], rec)
    if location == "cell" and raw.cells is None:
        raise SEDFormatError(f"SED file {_where(raw)!r}: SED is cell data but the file has no volume cells.")
    if raw.cells is None:
        xyz, sed, merged = _merge_duplicate_points(raw, xyz, sed)
        if merged:
            rec.notes.append(f"{merged} point(s) listed twice with the same SED merged (a table written per element?).")
    xyz, sed, cells, coincident, sides = _mesh(raw, xyz, sed, location, rec, memo, opts.material_array)
    reuse = same and memo.get("xyz_key") == (lf, f"{lu} {lsrc}")
    xyz_m = memo["xyz_m"] if reuse else xyz * lf
    memo["span"] = _plausibility(raw, opts, sed, xyz_m, f"{lu} {lsrc}", rec, span=memo["span"] if reuse else False)
    memo.update(xyz_key=(lf, f"{lu} {lsrc}"), xyz_m=xyz_m)
    prov = Provenance(
        files=raw.files + ((opts.materials,) if opts.materials else ()), format=raw.format, sed_from=opts.sed_from, columns=rec.columns, units=rec.units,
        factors=rec.factors, notes=tuple(rec.notes), negative_sed=negative, checks=rec.checks,
        location=location, location_source=_location_source(raw, opts, location), coincident=coincident,
    )
    try:
        return SEDField(xyz_m, sed, times, location=location, cells=cells, provenance=prov, sides=sides)
    except ValueError as err:
        raise SEDFormatError(f"SED file {_where(raw)!r}: {err}") from err
