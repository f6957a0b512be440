"""Describing an FE export as read (``afferent info``): what it holds and how afferent would read it."""

from __future__ import annotations

from ..io._raw import RawExport

import numpy as np

from .._plausibility import robust_level
from ..exceptions import SEDFormatError
from ..strain_energy import sed_exact
from ..units import LENGTH_UNITS, SED_UNITS, parse_unit
from ._assemble import ReadOptions, _percent, find_coordinates, find_sed_array, find_tensor, find_tensors, \
    negative_sed_report, tensor_sed_crosscheck

__all__ = ["describe_raw"]

#: Plausible ranges used only for hints (never to choose a unit): a fingertip FE block spans
#: 0.5-50 mm; the SED level (99th percentile) of skin under touch is about 1 to 1e5 J/m^3
#: (the study's peak: ~190 Pa). Warnings use the wider bands of :mod:`afferent._plausibility`.
PLAUSIBLE_SPAN_M = (0.5e-3, 50e-3)
PLAUSIBLE_SED_PA = (1.0, 1e5)



def _unit_hint(value: float, table: dict, plausible: tuple[float, float], units: tuple[str, ...]) -> str:
    fits = [u for u in units if plausible[0] <= value * table[u] <= plausible[1]]
    return ", ".join(fits) if fits else "none of " + ", ".join(units)


def describe_raw(raw: RawExport) -> list[str]:
    """What an FE export holds, and how :func:`afferent.read_sed` would read it, as lines of text.

    Points, cells, arrays with their components (and their names, when the file gives them) and ranges, time steps, bounds (file units),
    the SED array and tensors afferent recognises, negative SED artefacts, the units stated in
    the file (or a hint of the plausible ones when not), and the reader's notes.
    ``afferent info`` prints these lines.

    Parameters
    ----------
    raw : RawExport
        From :func:`afferent.io.read_raw`.

    Returns
    -------
    list of str
        One line per item, the first naming the file.
    """
    lines = [f"{raw.files[0]}" + (f" (+{len(raw.files) - 1} files)" if len(raw.files) > 1 else "")]
    add = lambda k, v: lines.append(f"  {k:<12} {v}")  # noqa: E731
    add("format", raw.format)
    if raw.reader:
        add("reader", raw.reader)
    opts = ReadOptions()
    try:
        xyz, coord_names = find_coordinates(raw, opts)
    except SEDFormatError as err:
        xyz, coord_names = None, None
        add("coordinates", f"not recognised: {err}")
    if xyz is not None:
        lo, hi = np.nanmin(xyz, axis=0), np.nanmax(xyz, axis=0)
        add("points", f"{xyz.shape[0]:,}" + ("" if coord_names == ("points",) else f" (columns {', '.join(coord_names)})"))
        add("bounds", "  ".join(f"{a} [{l:.6g}, {h:.6g}]" for a, l, h in zip("xyz", lo, hi)) + " (file units)")
    if raw.cells is not None:
        from .._shape_functions import shaped_types

        types = ", ".join(dict.fromkeys(raw.cells.cell_types))  # each once: NGSolve's subdivision alternates blocks
        add("cells", f"{raw.cells.n_cells:,} volume cells ({types}), "
                     f"{raw.cells.n_tetra:,} tetrahedra for sampling"
                     + ("; 'linear' sampling interpolates with each cell's own shape functions"
                        if shaped_types(raw.cells, "point") else ""))
    else:
        add("cells", "none (a table of points: 'linear' sampling triangulates around the receptors)")
    n_t = raw.n_times
    add("time steps", f"{n_t}" + (f", t = {raw.times[0]:g} .. {raw.times[-1]:g}" + (f" {raw.time_unit}" if raw.time_unit else "")
                                  if raw.times is not None else " (no times stated)"))
    lines.append("  arrays")
    for arr in raw.arrays.values():
        ncomp = arr.values.shape[2] if arr.values.ndim == 3 else 1
        comp = f"{ncomp} components" if ncomp > 1 else "scalar"
        unit = f" [{arr.unit}]" if arr.unit else ""
        with np.errstate(all="ignore"):
            rng = f"{np.nanmin(arr.values):.4g} .. {np.nanmax(arr.values):.4g}" if arr.values.size else "empty"
        names = f"  ({' '.join(arr.components)})" if arr.components else ""
        lines.append(f"    {arr.name!r:<28} {arr.location:<5} {comp:<13} {rng}{unit}{names}")
    _sed_lines(raw, opts, add)
    _mesh_lines(raw, opts, add)
    _tensor_lines(raw, add)
    if xyz is not None:
        span = float(np.nanmax(np.nanmax(xyz, 0) - np.nanmin(xyz, 0)))
        if raw.length_unit:
            add("length unit", f"{raw.length_unit} (stated in the file)")
        else:
            add("length unit", "not stated: declare --length-unit")
            if span > 0:
                add("hint", f"a span of {span:.3g} is plausible for a fingertip block (0.5..50 mm) in: "
                            f"{_unit_hint(span, LENGTH_UNITS, PLAUSIBLE_SPAN_M, ('m', 'mm', 'um'))}")
    for note in raw.notes:
        add("note", note)
    return lines


def _sed_lines(raw, opts, add) -> None:
    """The SED array recognised, its range, negative values and unit."""
    try:
        sed_arrays = find_sed_array(raw, opts)
        sed = np.concatenate([a.values.reshape(a.values.shape[0], -1) for a in sed_arrays])
        add("SED", f"{', '.join(repr(a.name) for a in sed_arrays)} ({sed_arrays[0].location} data)")
        _density_line(raw, sed_arrays[0], add)
        others = [a for a in raw.arrays.values() if a.name == sed_arrays[0].name and a.location != sed_arrays[0].location]
        if others:
            add("", f"{others[0].location} data of the same name also present: --location {others[0].location} to use it")
        stated = sed_arrays[0].unit
        smax = float(np.nanmax(sed)) if sed.size else float("nan")
        add("SED range", f"{np.nanmin(sed):.6g} .. {smax:.6g} (file units)")
        neg = negative_sed_report(np.where(np.isfinite(sed), sed, 0.0))  # NaN rows are reported by read_sed
        if neg is not None:
            rel = (f"down to {neg['min_relative']:.2g} x the largest, summing to {neg['negative_share']:.2g} x the positives"
                   if np.isfinite(neg["min_relative"]) else "no value is positive")
            verdict = (f"within the tolerance {neg['tolerance']:g}: nodal-extrapolation artefacts, read as 0"
                       if neg["within_tolerance"] else
                       f"beyond the tolerance {neg['tolerance']:g}: refused unless --negative-tolerance allows it")
            add("negative SED", f"{neg['count']:,} of {neg['n_values']:,} values ({rel}); {verdict}")
        if stated and parse_unit(stated):
            add("SED unit", f"{stated} (stated in the file)")
        else:
            add("SED unit", "not stated: declare --sed-unit")
            level = robust_level(sed)
            if level > 0:
                add("hint", f"an SED level of {level:.3g} (99th percentile of the nonzero values) is plausible for skin "
                            f"(1..1e5 J/m^3) in: {_unit_hint(level, SED_UNITS, PLAUSIBLE_SED_PA, ('Pa', 'kPa', 'MPa'))}")
        _physics_line(raw, sed, sed_arrays[0].location, "SED", parse_unit(stated) if stated else None, add)
    except SEDFormatError as err:
        add("SED", f"no SED array: {str(err).split('. Found')[0].split(': ', 1)[-1]}")


def _physics_line(raw, values, location: str, what: str, stated: str | None, add) -> None:
    """Which unit the physics implies (:mod:`afferent.io._unit_physics`): the stiffness 2 SED / eps:eps in the
    file's unit of ``values`` (the SED array, or 1/2 sigma:eps of the stress) and the units that make it soft tissue's."""
    from ._unit_physics import MODULUS_BAND_PA, implied_modulus, unit_hint

    record = implied_modulus(raw, ReadOptions(), values, location)
    if not record["checkable"]:
        add("physics", f"cannot tell the {what} unit: {record['note']}")
        return
    m, fits = record["modulus_pa"], unit_hint(record["modulus_pa"])
    lo, hi = MODULUS_BAND_PA
    verdict = ""
    if stated:
        verdict = (f"; the stated {stated} agrees" if stated in fits or any(SED_UNITS.get(stated) == SED_UNITS[u]
                                                                             for u in fits)
                   else f"; the stated {stated} does not (read_sed refuses it unless --accept modulus)")
    add("physics", f"an elastic stiffness 2 SED / eps:eps of {m:.3g} x the {what} unit (strain from the "
                   f"{record['strain_from']}): soft tissue ({lo / 1e3:g} kPa..{hi / 1e6:g} MPa) in: "
                   f"{', '.join(fits) if fits else 'none of Pa, kPa, MPa, GPa'}{verdict}")


def _density_line(raw, arr, add) -> None:
    """For an array named like an energy and read as a density: why (its values against the tensors)."""
    from . import _columns as C
    from ._export_checks import density_by_values

    if C.ENERGY_NOT_DENSITY.get(C.canonical(arr.name)):
        check = density_by_values(raw, arr)
        if check is not None:
            add("", check["note"])


def _mesh_lines(raw, opts, add) -> None:
    """Coincident points (discontinuous output) and the cells' material ids."""
    from ._coincident import merge_coincident
    from ._find_arrays import MATERIAL_ARRAY_NAMES, find_material_array

    if raw.cells is None or raw.points is None:
        return
    material = find_material_array(raw)
    cells = raw.cells if material is None else raw.cells.with_materials(material[2])
    try:
        arr = find_sed_array(raw, opts)[0]
        sed = arr.values.reshape(arr.values.shape[0], -1)
        location = arr.location if np.all(np.isfinite(sed)) else "cell"
    except SEDFormatError:
        sed, location = np.zeros((1, raw.cells.n_cells)), "cell"
    _, _, _, rep, sides = merge_coincident(raw.points, sed, location, cells)
    if rep is None:
        add("coincident", "none: every point is its own node")
    else:
        text = (f"{rep['n_points']:,} points are {rep['n_nodes']:,} nodes (up to {rep['max_copies']} copies at one place: "
                "discontinuous output, one patch per cell); read_sed merges them")
        if "median_relative" in rep:
            text += (f"; the SED copies differ from their node's mean by a median {_percent(rep['median_relative'])}, "
                     f"up to {_percent(rep['max_relative'])} ({rep['nodes_compared']:,} nodes)"
                     + (f", within one material a median {_percent(rep['within_material']['median_relative'])}, up to "
                        f"{_percent(rep['within_material']['max_relative'])}" if "within_material" in rep else "")
                     + f"; merged value: {rep['rule']}")
        add("coincident", text)
    if material is None:
        add("materials", f"no material-id array (cell data named like {', '.join(MATERIAL_ARRAY_NAMES[:6])}, ...)")
        return
    ids, counts = np.unique(material[2], return_counts=True)
    add("materials", f"{material[0]!r} ({material[1]}): " + ", ".join(f"{i} ({c:,} cells)" for i, c in zip(ids, counts))
        + ("; discontinuous copies keep each material's SED at the nodes where they meet" if sides is not None else ""))


def _tensor_lines(raw, add) -> None:
    """Stress and strain tensors, and 1/2 sigma:eps against the SED array under each preset."""
    try:
        (s_name, s, s_loc), (e_name, e, _) = find_tensors(raw, ReadOptions(sed_from="exact"), need_convention=False)
        how = f"(preset {raw.preset!r} implied by the format)" if raw.preset else "with --preset"
        add("tensors", f"stress {s_name}; strain {e_name} ({s_loc} data): --sed-from exact|equivalent {how}")
        stated = {a.unit for a in raw.arrays.values() if a.name in s_name.split(", ")} - {None}
        _physics_line(raw, sed_exact(s, e), s_loc, "stress", parse_unit(stated.pop()) if len(stated) == 1 else None, add)
    except (SEDFormatError, ValueError):
        try:
            s_name, _, s_loc = find_tensor(raw, ReadOptions(), "stress")
            add("tensors", f"stress {s_name} ({s_loc} data), no strain: --sed-from stress with --elastic E,NU "
                           "--modulus-unit U or --materials TABLE (linear elastic, small strain)")
        except (SEDFormatError, ValueError):
            add("tensors", "no complete stress and strain tensors")
    check = tensor_sed_crosscheck(raw, ReadOptions())
    if check is not None and not check["checkable"]:
        add("cross-check", f"1/2 sigma:eps from the tensors vs the SED array {check['sed_array']!r}: {check['note']}")
    elif check is not None:
        groups: dict = {}
        for name, rel in check["by_preset"].items():
            groups.setdefault(_percent(rel), []).append(name)
        ranked = sorted(groups.items(), key=lambda kv: check["by_preset"][kv[1][0]])
        add("cross-check", f"1/2 sigma:eps from the tensors vs the SED array {check['sed_array']!r} (step {check['step']}, "
                           f"relative L2 after the best scale, {check['scale']:.4g} for {check['best_preset']!r}): "
                           + "; ".join(f"{'/'.join(names)} {pct}" for pct, names in ranked))
