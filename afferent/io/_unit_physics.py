"""Units from physics: the elastic stiffness an SED level implies, and scalars that are stress measures, not SED.

A unit slip (kPa declared for MPa) moves the SED by a factor 1e3 that a level check alone may
not see: 2 Pa and 2 kPa are both plausible SED levels of skin. The physics sees it. For a
linear-elastic solid SED = 1/2 sigma:eps and sigma ~ 2G eps, so

    M = 2 SED / (eps:eps)

is a stiffness (2G, about 2/3 of Young's modulus for nearly incompressible skin) whatever the
load. The strain is dimensionless: from the export's strain tensor, or from the gradient of its
displacements in its cells. So the declared SED (or stress) unit sets M's unit, and soft tissue
(:data:`MODULUS_BAND_PA`) tells a unit 1e3 or 1e6 off. :func:`implied_modulus` measures M;
:func:`modulus_verdict` refuses a unit that puts it outside the band when another unit would put
it inside (the likely unit, named), unless the user confirms with ``accept='modulus'``.

And a scalar passed as the SED may be a stress measure: a von Mises array is ~10x an MPa
export's SED and reads as a plausible level. :func:`stress_measure_named` and
:func:`stress_measure_values` say which one it is, by its name or by its values against the
file's stress tensor.
"""

from __future__ import annotations

import math

import numpy as np

from ..exceptions import SEDFormatError
from ..units import SED_UNITS
from . import _columns as C
from ._export_checks import strain_magnitude
from ._raw import RawExport

__all__ = ["MODULUS_BAND_PA", "implied_modulus", "modulus_verdict", "unit_hint", "stress_measure_named",
           "stress_measure_values", "find_displacement"]

#: Elastic stiffness of soft tissue, in Pa: skin and its layers 1 kPa (subcutaneous fat) .. 10 MPa
#: (stratum corneum); the FE skin models of tests/data and sample_sed use E = 34 kPa .. 0.8 MPa. The
#: stiffness :func:`implied_modulus` measures (2 SED / eps:eps ~ 2G) on each of the 47 real exports
#: there that can tell, in its own unit: 51 kPa .. 0.68 MPa, so a slip of 1e3 either way leaves the band
#: by 20 x or more (``benchmarks/check_unit_physics.py``; docs/fe-export.md, "Units from physics").
MODULUS_BAND_PA = (1e3, 1e7)
#: Units a slip may have confused, with their factor to Pa (the SED and stress units of :data:`afferent.units.SED_UNITS`).
CANDIDATE_UNITS = ("Pa", "kPa", "MPa", "GPa")
#: Share of the values (the most loaded ones: highest SED) whose stiffness is measured.
TOP_SHARE = 0.1
#: At most this many values measured (evenly spaced among the most loaded), chosen among at most
#: :data:`PRESAMPLE` values or tetrahedra evenly spread over the export: the check's cost is bounded
#: (under 30 ms for 117,649 nodes, 663,552 tetrahedra, besides decoding the displacements).
MAX_VALUES = 2_000
PRESAMPLE = 40_000
#: Fewer measurable values than this: cannot tell.
MIN_VALUES = 4

#: Displacement vectors (point data, 3 components), canonical names.
DISPLACEMENT_NAMES = frozenset(C.canonical(n) for n in (
    "U", "u", "disp", "displ", "displacement", "displacements", "DISPLACEMENT", "DEPL", "RESU____DEPL", "solid.u"))
#: Displacement components (point data, one scalar each): a name of :data:`DISPLACEMENT_NAMES` with an axis suffix.
_AXIS_SUFFIXES = (("x", "y", "z"), ("1", "2", "3"))


def find_displacement(raw: RawExport) -> tuple[str, np.ndarray] | None:
    """The export's displacements: (name, values (n_t, n_points, 3)) in its length unit, or None.

    A 3-component point array named like :data:`DISPLACEMENT_NAMES` (``U``, ``DISP``,
    ``displacement``, ``DEPL``...), else three point scalars of such a name with suffixes x, y, z
    or 1, 2, 3 (Exodus' ``displacement_x``, ``ux``).
    """
    if raw.cells is None or raw.points is None:
        return None
    point = [a for a in raw.arrays.values() if a.location == "point"]
    for a in point:
        if a.ndim == 3 and a.shape[2] == 3 and C.canonical(a.name) in DISPLACEMENT_NAMES:
            return a.name, a.values
    scalars = {C.canonical(a.name): a for a in point if a.ndim == 2}
    for base in DISPLACEMENT_NAMES:
        for axes in _AXIS_SUFFIXES:
            parts = [scalars.get(base + ax) for ax in axes]
            if all(p is not None for p in parts):
                return ", ".join(p.name for p in parts), np.stack([p.values for p in parts], axis=-1)
    return None


def _strain_at(raw: RawExport, opts, location: str, n_values: int):
    """The strain tensor at ``location`` with ``n_values`` values: (name, (n_t, n, 6) tensor shear) or None."""
    from dataclasses import replace

    from ._find_arrays import _convention, find_tensor

    try:
        conv = _convention(opts, raw)
    except (SEDFormatError, ValueError):
        conv = None  # no convention known: the strain as written (tensor shear unless it says otherwise)
    try:
        name, e, loc = find_tensor(raw, replace(opts, location=location), "strain", conv)
    except (SEDFormatError, ValueError):
        return None
    return (name, e) if loc == location and e.shape[1] == n_values else None


def _spread(n: int) -> np.ndarray:
    """At most :data:`PRESAMPLE` of ``range(n)``, evenly spread."""
    return np.arange(0, n, max(1, -(-n // PRESAMPLE)))


def _most_loaded(values: np.ndarray, share: float = TOP_SHARE) -> np.ndarray:
    """Indices of the largest ``share`` of the positive finite ``values`` (at most :data:`MAX_VALUES`, evenly spread)."""
    ok = np.flatnonzero(np.isfinite(values) & (values > 0))
    if ok.size == 0:
        return ok
    keep = max(int(math.ceil(share * ok.size)), min(ok.size, MIN_VALUES))
    top = ok[np.argpartition(values[ok], ok.size - keep)[ok.size - keep:]] if keep < ok.size else ok
    if top.size > MAX_VALUES:
        top = np.sort(top)[np.linspace(0, top.size - 1, MAX_VALUES).astype(np.int64)]
    return top


def _gradient_strain(xyz: np.ndarray, u: np.ndarray, tetra: np.ndarray) -> np.ndarray:
    """eps:eps of the small strain sym(grad u) in linear tetrahedra ``tetra`` (m, 4), (m,); NaN for flat ones."""
    x = xyz[tetra]
    edges = x[:, 1:] - x[:, :1]  # (m, 3, 3): rows are edges
    du = u[tetra][:, 1:] - u[tetra][:, :1]
    det = np.linalg.det(edges)
    scale = np.max(np.abs(edges), axis=(1, 2)) ** 3
    flat = ~(np.abs(det) > 1e-9 * scale)
    edges[flat] = np.eye(3)
    grad = np.swapaxes(np.linalg.solve(edges, du), 1, 2)  # du_i/dx_j
    eps = 0.5 * (grad + np.swapaxes(grad, 1, 2))
    out = np.einsum("mij,mij->m", eps, eps)
    out[flat] = np.nan
    return out


def implied_modulus(raw: RawExport, opts, sed_pa: np.ndarray, location: str) -> dict:
    """The stiffness M = 2 SED / (eps:eps) the SED implies, in Pa when ``sed_pa`` is in Pa (any unit: that unit).

    Measured at the most loaded step (largest total SED) on the most loaded values (the
    :data:`TOP_SHARE` with the highest SED, at most :data:`MAX_VALUES`), as the median of each
    value's M. The strain comes from the export's strain tensor at the SED's location, else from
    the displacement gradient in the tetrahedra that tile its cells (:func:`find_displacement`;
    SED at points averaged over each tetrahedron's corners). For linear elasticity M is 2G
    (2/3 of Young's modulus for a nearly incompressible solid); several materials give a value
    between theirs.

    Parameters
    ----------
    raw : RawExport
        The export (its strain tensor, or its displacements and cells).
    opts : ReadOptions
        The declarations (the strain's convention, column names).
    sed_pa : ndarray of shape (n_times, n_values)
        SED at ``location``, in Pa (or in any unit: M comes back in it).
    location : {'point', 'cell'}

    Returns
    -------
    dict
        ``checkable`` True: ``modulus_pa`` (Pa), ``strain_from`` (what the strain was taken from),
        ``step``, ``n_values`` (values measured), ``spread`` (their 25th and 75th percentile of M, Pa).
        ``checkable`` False: ``note`` (why not: no strain or displacement, no load).
    """
    sed = np.asarray(sed_pa, dtype=float).reshape(np.shape(sed_pa)[0], -1)
    total = np.nansum(np.where(sed > 0, sed, 0.0), axis=1)
    if not np.any(total > 0):
        return {"checkable": False, "note": "no step holds SED > 0"}
    k = int(np.argmax(total))
    s = sed[k]
    strain = _strain_at(raw, opts, location, s.size)
    if strain is not None:
        cand = _spread(s.size)
        idx = cand[_most_loaded(s[cand])]
        eps2 = strain_magnitude(strain[1][k][idx]) ** 2
        source = f"strain tensor {strain[0]!r} ({location} data)"
        vals = s[idx]
    else:
        try:
            disp = find_displacement(raw)
        except SEDFormatError as err:  # an array the SED does not need, unreadable: the check cannot tell, the read goes on
            return {"checkable": False, "note": f"the displacements could not be decoded ({err})"}
        if disp is None:
            return {"checkable": False, "note": "the export has no strain tensor at the SED's location and no "
                                                "displacements in volume cells"}
        cells = raw.cells
        if s.size != (cells.n_cells if location == "cell" else raw.points.shape[0]):
            return {"checkable": False, "note": f"the SED's {location} values do not match the export's {location}s"}
        cand = _spread(cells.n_tetra)
        tetra, parent = cells.rows(cand)
        per_tet = s[parent] if location == "cell" else s[tetra].mean(axis=1)
        top = _most_loaded(per_tet)
        idx = cand[top]
        per_tet = per_tet[top]
        u = np.asarray(disp[1][min(k, disp[1].shape[0] - 1)], dtype=float)
        eps2 = _gradient_strain(np.asarray(raw.points, dtype=float), u, tetra[top])
        source = f"displacement gradient of {disp[0]!r} in the cells"
        vals = per_tet
    ok = np.isfinite(eps2) & (eps2 > 0)
    if int(ok.sum()) < MIN_VALUES:
        return {"checkable": False, "note": f"fewer than {MIN_VALUES} loaded values with a strain (from the {source})"}
    m = 2.0 * vals[ok] / eps2[ok]
    q25, q50, q75 = np.percentile(m, (25, 50, 75))
    return {"checkable": True, "modulus_pa": float(q50), "strain_from": source, "step": k, "n_values": int(ok.sum()),
            "spread_pa": [float(q25), float(q75)]}


def unit_hint(modulus_in_unit: float) -> list[str]:
    """The units of :data:`CANDIDATE_UNITS` in which a stiffness of ``modulus_in_unit`` (in an unknown unit) lies in
    :data:`MODULUS_BAND_PA`, the most typical of skin (nearest 0.1 MPa on a log scale) first."""
    lo, hi = MODULUS_BAND_PA
    fits = [u for u in CANDIDATE_UNITS if lo <= modulus_in_unit * SED_UNITS[u] <= hi]
    return sorted(fits, key=lambda u: abs(math.log10(modulus_in_unit * SED_UNITS[u]) - 5.0))


def modulus_verdict(record: dict, *, unit: str, factor: float) -> dict:
    """Judge a :func:`implied_modulus` record made with SED in Pa, the unit declared (or stated) being ``unit``.

    Returns the record with ``band_pa``, ``unit``, ``verdict``: ``'plausible'`` (inside
    :data:`MODULUS_BAND_PA`), ``'unit'`` (outside, and another unit of :data:`CANDIDATE_UNITS` puts it
    inside: ``likely_unit`` and ``likely_factor``, the factor the SED is off) or ``'material'`` (outside,
    and no unit puts it inside: a material far from skin).
    """
    out = dict(record, band_pa=list(MODULUS_BAND_PA), unit=unit)
    if not record.get("checkable"):
        return out
    m = record["modulus_pa"]
    lo, hi = MODULUS_BAND_PA
    if lo <= m <= hi:
        return dict(out, verdict="plausible")
    others = [u for u in unit_hint(m / factor) if not math.isclose(SED_UNITS[u], factor, rel_tol=1e-9)]
    if not others:
        return dict(out, verdict="material")
    return dict(out, verdict="unit", likely_unit=others[0], likely_factor=SED_UNITS[others[0]] / factor)


# --------------------------------------------------------------------------------------
# Scalars that are stress measures, not SED
# --------------------------------------------------------------------------------------

#: Pieces of canonical names (:func:`afferent.io._columns.canonical`) that name a stress measure, anywhere in the
#: name (Abaqus ``S.Mises``, ``S.Max. Principal``, COMSOL ``solid.mises``, Workbench ``Equivalent Stress``, code_aster
#: ``VMIS``, deal.II/FEniCS users' ``von_mises``...).
_MEASURE_PIECES = {"mises": "a von Mises stress", "vmis": "a von Mises stress", "tresca": "a Tresca stress",
                   "principal": "a principal stress", "pressure": "a pressure", "equivalentstress": "an equivalent "
                   "(von Mises) stress", "effectivestress": "an effective (von Mises) stress",
                   "stressintensity": "a stress intensity (Tresca)", "hydrostatic": "a hydrostatic stress",
                   "meanstress": "a mean stress", "maxshear": "a maximum shear stress"}
#: Whole canonical names of stress measures (alone or after a prefix ``solid``, ``stress``, ``sig`` or ``s``): ANSYS
#: ``SEQV``, ``SINT``, ``S1``..``S3``; Abaqus ``PRESS``; COMSOL ``solid.sp1``; code_aster ``PRIN_1``.
_MEASURE_NAMES = {"seqv": "a von Mises stress (ANSYS SEQV)", "eqv": "an equivalent (von Mises) stress",
                  "sint": "a stress intensity (ANSYS SINT)", "press": "a pressure", "vm": "a von Mises stress",
                  "1": "a principal stress", "2": "a principal stress", "3": "a principal stress",
                  "p1": "a principal stress", "p2": "a principal stress", "p3": "a principal stress",
                  "sp1": "a principal stress", "sp2": "a principal stress", "sp3": "a principal stress",
                  "prin1": "a principal stress", "prin2": "a principal stress", "prin3": "a principal stress"}
_PREFIXES = ("", "solid", "stress", "sig", "s")


def stress_measure_named(name: str) -> str | None:
    """What stress measure the array name ``name`` says it is (``'a von Mises stress'``), or None."""
    key = C.canonical(name)
    for piece, what in _MEASURE_PIECES.items():
        if piece in key:
            return what
    for prefix in _PREFIXES:
        if key.startswith(prefix) and key[len(prefix):] in _MEASURE_NAMES and (prefix or len(key) > 1):
            return _MEASURE_NAMES[key[len(prefix):]]
    return None


def _measures(stress: np.ndarray) -> dict:
    """Stress measures of canonical stress (n, 6), by name: von Mises, Tresca, pressure, the three principal values."""
    from ..strain_energy import full_tensor

    p = np.linalg.eigvalsh(full_tensor(stress))  # ascending
    s3, s2, s1 = p[:, 0], p[:, 1], p[:, 2]
    vm = np.sqrt(0.5 * ((s1 - s2) ** 2 + (s2 - s3) ** 2 + (s3 - s1) ** 2))
    mean = (s1 + s2 + s3) / 3.0
    return {"the von Mises stress": vm, "the Tresca stress (stress intensity)": s1 - s3,
            "the maximum shear stress": 0.5 * (s1 - s3), "the pressure (-1/3 trace)": -mean,
            "the mean stress (1/3 trace)": mean, "the largest principal stress": s1,
            "the middle principal stress": s2, "the smallest principal stress": s3}


#: A scalar equals a stress measure when the median relative difference over its values is at most this (after a
#: unit factor 1000^k, k in -3..3, if its values are in another unit than the tensor's).
MEASURE_RTOL = 1e-3


def stress_measure_values(raw: RawExport, arr, opts) -> dict | None:
    """Does the scalar array ``arr`` equal a stress measure of the export's stress tensor? None when it has no stress
    tensor at ``arr``'s location, or when the scalar matches none.

    Compared at the step where the scalar's total magnitude is largest, value by value (the median relative
    difference at most :data:`MEASURE_RTOL`), after a unit factor 1000^k when the ratio says so.

    Returns
    -------
    dict or None
        ``measure`` (e.g. 'the von Mises stress'), ``stress`` (the tensor's name), ``relative_difference``
        (median), ``factor`` (scalar = factor x measure).
    """
    from dataclasses import replace

    from ._find_arrays import find_tensor

    try:
        s_name, stress, loc = find_tensor(raw, replace(opts, location=arr.location, sed_column=None), "stress")
    except (SEDFormatError, ValueError):
        return None
    v = np.asarray(arr.values, dtype=float).reshape(arr.values.shape[0], -1)
    if loc != arr.location or stress.shape[:2] != v.shape:
        return None
    k = int(np.argmax(np.nansum(np.abs(v), axis=1)))
    ok = np.isfinite(v[k]) & np.isfinite(stress[k]).all(axis=1)
    if ok.sum() < MIN_VALUES:
        return None
    vk = v[k][ok]
    for what, c in _measures(stress[k][ok]).items():
        big = np.abs(c) > 1e-9 * np.max(np.abs(c), initial=0.0)
        if big.sum() < MIN_VALUES:
            continue
        ratio = float(np.median(vk[big] / c[big]))
        if not ratio > 0:
            continue
        factor = 1000.0 ** round(math.log10(ratio) / 3) if abs(math.log10(ratio)) < 10 else 1.0
        rel = float(np.median(np.abs(vk[big] - factor * c[big]) / np.abs(factor * c[big])))
        if rel <= MEASURE_RTOL:
            return {"measure": what, "stress": s_name, "relative_difference": rel, "factor": factor}
    return None


# --------------------------------------------------------------------------------------
# The sentences
# --------------------------------------------------------------------------------------

def _measured(record: dict) -> str:
    """How the stiffness was measured, as a parenthesis."""
    return (f"(the median over {record['n_values']} of its most loaded values at step {record['step']}, the strain from "
            f"the {record['strain_from']})")


def modulus_message(where: str, record: dict, *, param: str) -> tuple[str, str] | None:
    """(kind, sentence) for a judged :func:`modulus_verdict` record: kind ``'unit'`` (a sentence without its final
    period, to refuse unless confirmed: :func:`afferent._validation.refuse_unless`) or ``'material'`` (a sentence to
    warn with); None when plausible or not checkable.

    ``param`` is the unit's parameter (``'sed_unit'`` or ``'stress_unit'``); ``record['unit_source']`` says whether
    the unit was declared or stated by the file.
    """
    verdict = record.get("verdict")
    if verdict not in ("unit", "material"):
        return None
    m, unit = record["modulus_pa"], record["unit"]
    lo, hi = MODULUS_BAND_PA
    side, soft = ("below", "soft") if m < lo else ("above", "stiff")
    quantity = "the SED" if param == "sed_unit" else "the stress"
    read = (f"{quantity} read with {param}={unit!r}" if record.get("unit_source") != "file"
            else f"{quantity} in the unit {unit!r} the file states")
    said = (f"SED file {where!r}: {read} implies an elastic stiffness 2 SED / eps:eps of {m:.3g} Pa {_measured(record)}, "
            f"far {side} soft tissue's {lo / 1e3:g} kPa..{hi / 1e6:g} MPa")
    if verdict == "material":
        return "material", (f"{said}, and no unit of {', '.join(CANDIDATE_UNITS)} puts it inside: a material {soft}er "
                            "than skin, or a strain that is not the SED's (afferent's transduction is calibrated on "
                            "skin).")
    likely = record["likely_unit"]
    fix = (f"declare {param}={likely!r}" if record.get("unit_source") != "file" else "check the export's units")
    return "unit", (f"{said}: {quantity} is most likely in {likely} ({_factor(record['likely_factor'])} x {unit}), not "
                    f"a material that {soft}; {fix}")


def _factor(f: float) -> str:
    """A power of ten as '1e3', '1e-6'; other numbers as ``:g``."""
    k = round(math.log10(f)) if f > 0 else 0
    return f"1e{k}" if f > 0 and math.isclose(f, 10.0 ** k, rel_tol=1e-9) else f"{f:g}"
