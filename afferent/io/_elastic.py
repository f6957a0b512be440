"""SED from stress alone (``sed_from='stress'``): the elastic constants of each material, and what the file can check.

::

    stress (n_t, n, 6) Pa + E (Pa), nu of each value's material
        --sed_from_stress--> U = (1 + nu)/(2E) sigma:sigma - nu/(2E) tr(sigma)^2   (J/m^3)

Linear elastic, isotropic, small strain. The constants: one pair for a homogeneous model
(``elastic=(E, nu)`` with ``modulus_unit``), or a table (``materials='materials.csv'``: columns
``material``, ``E``, ``nu``) keyed by the ids of the export's material array (``material_array``,
else the one :func:`afferent.io._find_arrays.find_material_array` finds). Refused: a material of the
export without constants (named), E <= 0, nu outside (-1, 0.5], stress at nodes shared by cells of
different materials (their nodal stress mixes materials: use the cell stress), and a large strain the
file shows (:func:`strain_check`) unless ``accept='large-strain'``.

Where the file also holds a strain tensor at the stress's location, the stress is compared with Hooke's
law of that strain under the declared constants (:func:`hooke_check`): it agrees to round-off for a
linear-elastic model, differs by a factor 1e3 or 1e6 for a unit slip (refused unless
``accept='modulus'``), and by a few percent for a nonlinear material.
"""

from __future__ import annotations

import csv
import math
import os
import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import AfferentWarning, SEDFormatError, UnitError
from ..strain_energy import PRESETS, sed_from_stress
from ..units import parse_unit, sed_factor
from . import _columns as C
from ._find_arrays import _convention, _order_from_names, _where, find_material_array, find_tensor
from ._raw import RawExport
from ._read_options import SMALL_STRAIN_BOUND, ReadOptions

__all__ = ["Elastic", "elastic_constants", "read_materials", "constants_at", "hooke_check", "strain_check",
           "sed_from_stress_field", "HOOKE_RTOL", "HOOKE_SCALE_BAND"]

#: Relative L2 difference between the stress and Hooke's law of the file's strain (declared constants) up to which the
#: model is linear elastic with those constants. Measured on the real linear-elastic exports of tests/data
#: (tests/test_sed_from_stress.py): 0 .. 4e-16 (DOLFINx, FreeFEM, SfePy, code_aster: double precision), 7e-8 (Kratos),
#: 4e-7 (CalculiX .dat), 2e-6 .. 6e-6 (CalculiX .frd: 5 significant digits); FEBio's neo-Hookean block at strains up to
#: 0.08: 0.22.
HOOKE_RTOL = 1e-3
#: Least-squares scale of the stress over Hooke's law of the strain outside which the constants and the stress
#: disagree in kind (a unit slip of E or of the stress: 1e3, 1e6), not by a nonlinear material (a few percent).
HOOKE_SCALE_BAND = (0.5, 2.0)
#: Names of deformation-gradient arrays (9 components, row-major), compared canonical.
DEFORMATION_GRADIENT_NAMES = frozenset(C.canonical(n) for n in (
    "F", "deformation gradient", "deformation_gradient", "DEFORMATION_GRADIENT", "defgrad", "def_grad"))
_COLUMNS = {"material": ("material", "materialid", "id", "mat", "matid"),
            "E": ("e", "young", "youngsmodulus", "youngmodulus", "modulus"),
            "nu": ("nu", "poisson", "poissonsratio", "poissonratio"),
            "name": ("name", "label")}
FORMULA = "U = (1 + nu)/(2E) sigma:sigma - nu/(2E) tr(sigma)^2 (linear elastic, isotropic, small strain)"


@dataclass(frozen=True)
class Elastic:
    """Elastic constants: ``constants`` material id (None: every value) -> (E in Pa, nu); ``unit`` of E as given,
    ``unit_source`` ('declared' or the table's header), ``source`` ('elastic=' or the table's path), ``labels``
    id -> name from the table's ``name`` column."""

    constants: dict
    unit: str
    unit_source: str
    source: str
    labels: dict

    def describe(self) -> str:
        f = sed_factor(self.unit)
        pairs = [f"{'all' if k is None else f'material {k}' + (f' ({self.labels[k]})' if k in self.labels else '')}: "
                 f"E = {e / f:g} {self.unit}, nu = {nu:g}" for k, (e, nu) in self.constants.items()]
        return "; ".join(pairs) + f" (from {self.source}, E unit {self.unit} {self.unit_source})"


def _check_pair(e: float, nu: float, what: str) -> None:
    if not (math.isfinite(e) and e > 0):
        raise ValueError(f"{what}: Young's modulus E must be a finite number > 0; got {e!r} instead.")
    if not (math.isfinite(nu) and -1 < nu <= 0.5):
        raise ValueError(f"{what}: Poisson's ratio nu must be in (-1, 0.5]; got {nu!r} instead.")


def _modulus_unit(declared: str | None, stated: str | None, where: str) -> tuple[str, str]:
    """The unit of E: declared (``modulus_unit``) or stated (a table's header); both must agree; never guessed."""
    if stated is not None and parse_unit(stated) is None:
        raise UnitError(f"{where} states the unit {stated!r} for E, which afferent does not know; write one of Pa, kPa, "
                        "MPa, GPa, N/mm^2.")
    if declared is not None:
        f = sed_factor(declared, name="'modulus_unit'")
        if stated is not None and not math.isclose(sed_factor(parse_unit(stated)), f, rel_tol=1e-12):
            raise UnitError(f"'modulus_unit' is {declared!r} but {where} states {stated!r} for E; drop modulus_unit or "
                            "make it agree.")
        return declared, "declared"
    if stated is not None:
        return parse_unit(stated), f"stated in {where}"
    raise UnitError(f"The unit of E in {where} is neither stated nor declared; pass modulus_unit= (--modulus-unit, "
                    "e.g. 'MPa'), or write it in the header: 'E (MPa)'.")


def read_materials(path: str, modulus_unit: str | None = None) -> Elastic:
    """A materials table: CSV with a header ``material, E, nu`` (optional ``name``; ``#`` comment lines).

    ``material`` is the integer id the export's material array holds; the unit of E is written in its
    header (``E (MPa)``, ``E [kPa]``) or declared (``modulus_unit``); both must agree.
    """
    where = f"materials file {path!r}"
    if not os.path.isfile(path):
        raise FileNotFoundError(f"Materials file {path!r} not found.")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = [r for r in csv.reader(line for line in fh if line.strip() and not line.lstrip().startswith("#"))]
    if not rows:
        raise SEDFormatError(f"{where.capitalize()} is empty; expected a header 'material, E (MPa), nu' and one row per "
                             "material.")
    header = [C.split_unit(h) for h in rows[0]]
    col, unit = {}, None
    for i, (name, u) in enumerate(header):
        key = next((k for k, names in _COLUMNS.items() if C.canonical(name) in names), None)
        if key is not None and key not in col:
            col[key] = i
            unit = u if key == "E" else unit
    missing = [k for k in ("material", "E", "nu") if k not in col]
    if missing:
        raise SEDFormatError(f"{where.capitalize()} must have the columns material, E and nu (header e.g. 'material, "
                             f"E (MPa), nu'); missing {', '.join(missing)} in header {rows[0]!r}.")
    unit, source = _modulus_unit(modulus_unit, unit, where)
    f = sed_factor(unit)
    constants, labels = {}, {}
    for k, row in enumerate(rows[1:], start=2):
        cells = [c.strip() for c in row]
        if len(cells) < len(rows[0]):
            raise SEDFormatError(f"{where.capitalize()}, line {k}: expected {len(rows[0])} values; got {row!r} instead.")
        try:
            mid = float(cells[col["material"]])
            if mid != round(mid):
                raise ValueError
        except ValueError:
            raise SEDFormatError(
                f"{where.capitalize()}, line {k}: 'material' must be the integer id the export's material array holds "
                f"(afferent info lists them; a 'name' column may label it); got {cells[col['material']]!r} instead."
            ) from None
        try:
            e, nu = float(cells[col["E"]]), float(cells[col["nu"]])
        except ValueError:
            raise SEDFormatError(f"{where.capitalize()}, line {k}: E and nu must be numbers; got "
                                 f"{cells[col['E']]!r} and {cells[col['nu']]!r} instead.") from None
        _check_pair(e, nu, f"{where.capitalize()}, line {k} (material {int(mid)})")
        if int(mid) in constants:
            raise SEDFormatError(f"{where.capitalize()}, line {k}: material {int(mid)} is listed twice.")
        constants[int(mid)] = (e * f, nu)
        if "name" in col and cells[col["name"]]:
            labels[int(mid)] = cells[col["name"]]
    if not constants:
        raise SEDFormatError(f"{where.capitalize()} lists no material (a header only).")
    return Elastic(constants, unit, source, path, labels)


def elastic_constants(opts: ReadOptions) -> Elastic:
    """The constants ``opts`` declares: ``elastic=(E, nu)`` with ``modulus_unit``, or the table ``materials``."""
    if opts.materials is not None:
        return read_materials(opts.materials, opts.modulus_unit)
    e, nu = (float(v) for v in opts.elastic)
    _check_pair(e, nu, "'elastic'")
    unit, source = _modulus_unit(opts.modulus_unit, None, "'elastic'")
    return Elastic({None: (e * sed_factor(unit), nu)}, unit, source, "elastic=", {})


def _material_ids(raw: RawExport, opts: ReadOptions):
    found = find_material_array(raw, name=opts.material_array)
    if found is None:
        wanted = f"no material array {opts.material_array!r}" if opts.material_array else "no material array"
        raise SEDFormatError(
            f"SED file {_where(raw)!r} has {wanted} (cell data of material ids, or point data constant over each "
            "cell) to look the materials table up with; name it with material_array= (--material-array), or give one "
            "pair elastic=(E, nu) for a homogeneous model."
        )
    return found


def constants_at(raw: RawExport, opts: ReadOptions, el: Elastic, location: str, n: int, notes: list):
    """E (Pa) and nu of each of the ``n`` stress values at ``location``: (E (n,), nu (n,), material array name or None).

    Cell values take their cell's material. Point values take the material of the cells they belong to; a point
    in cells of two materials (a node on an interface, whose stress mixes them) is refused.
    """
    if None in el.constants:
        e, nu = el.constants[None]
        found = find_material_array(raw, name=opts.material_array) if raw.cells is not None else None
        if found is not None and np.unique(found[2]).size > 1:
            msg = (f"SED file {_where(raw)!r}: one pair of elastic constants applied to all "
                   f"{np.unique(found[2]).size} materials of its array {found[0]!r} (ids "
                   f"{', '.join(map(str, np.unique(found[2])[:8]))}); if they differ, give a materials table.")
            notes.append(msg)
            warnings.warn(msg, AfferentWarning, stacklevel=5)
        return np.full(n, e), np.full(n, nu), None
    if raw.cells is None:
        raise SEDFormatError(f"SED file {_where(raw)!r} has no cells, so no material array for the materials table "
                             f"{el.source!r}; give one pair elastic=(E, nu) for a homogeneous model.")
    name, where, ids = _material_ids(raw, opts)
    cells = raw.cells
    if location == "cell":
        if ids.size != n:
            raise SEDFormatError(f"SED file {_where(raw)!r}: its material array {name!r} has {ids.size} values, not one "
                                 f"per stress value ({n}).")
        per_value = ids
    else:
        lo, hi = np.full(n, np.iinfo(np.int64).max), np.full(n, np.iinfo(np.int64).min)
        blocks = [(b, np.arange(b.shape[0])) for b in cells.nodes] if cells.nodes else [(cells.tetra, cells.parent)]
        start = 0
        for conn, parent in blocks:
            owner = ids[parent + (start if cells.nodes else 0)]
            start += conn.shape[0]
            keep = conn >= 0
            pts, mats = conn[keep], np.broadcast_to(owner[:, None], conn.shape)[keep]
            np.minimum.at(lo, pts, mats)
            np.maximum.at(hi, pts, mats)
        big = np.iinfo(np.int64).max
        if np.any(lo == big):
            k = int(np.argmax(lo == big))
            raise SEDFormatError(f"SED file {_where(raw)!r}: {int(np.sum(lo == big))} stress point(s) belong to no cell, so "
                                 f"to no material (first: point {k}); give elastic=(E, nu) if the model is homogeneous.")
        interface = np.flatnonzero(lo != hi)
        if interface.size:
            k = int(interface[0])
            raise SEDFormatError(
                f"SED file {_where(raw)!r}: {interface.size} of its {n} stress points are nodes shared by cells of "
                f"different materials (array {name!r}; first: point {k}, materials {lo[k]} and {hi[k]}): a nodal stress "
                "there is an average across materials that the constants of neither fit. Use the stress of the cells "
                "(location='cell'), or an export with a copy of each node per cell (discontinuous output)."
            )
        per_value = lo
    missing = sorted(set(np.unique(per_value).tolist()) - set(el.constants))
    if missing:
        raise SEDFormatError(
            f"Materials file {el.source!r} has no constants for material(s) {', '.join(map(str, missing))} of SED file "
            f"{_where(raw)!r} (array {name!r}, {where}); it lists {', '.join(map(str, el.constants))}. Add a row for each."
        )
    table = np.array([el.constants[int(m)] for m in np.unique(per_value)])
    index = np.searchsorted(np.unique(per_value), per_value)
    return table[index, 0], table[index, 1], name


def hooke_check(stress_pa: np.ndarray, strain: np.ndarray, e: np.ndarray, nu: np.ndarray) -> dict:
    """Compare stress (n_t, n, 6) Pa with Hooke's law of strain (n_t, n, 6, tensor shear) under E (n,) Pa and nu (n,).

    Returns ``relative`` (||sigma - C:eps|| / ||sigma||, all steps) and ``scale`` (least-squares factor of sigma over
    C:eps). Both are 0 and 1 for a linear-elastic model with these constants.
    """
    lam = e * nu / ((1 + nu) * (1 - 2 * nu)) if np.all(nu < 0.5) else None
    if lam is None:
        return {"relative": float("nan"), "scale": float("nan"), "note": "nu = 0.5: the pressure is not a function of "
                                                                        "the strain"}
    mu = e / (2 * (1 + nu))
    trace = strain[..., :3].sum(-1, keepdims=True)
    pred = 2 * mu[:, None] * strain
    pred[..., :3] += lam[:, None] * trace
    w = np.array([1, 1, 1, 2, 2, 2], float)  # tensor norm: each shear twice
    ss, pp, sp = (float(np.sum(w * a * b)) for a, b in ((stress_pa, stress_pa), (pred, pred), (stress_pa, pred)))
    if ss == 0.0 or pp == 0.0:
        return {"relative": float("nan"), "scale": float("nan"), "note": "no load"}
    rel = math.sqrt(max(float(np.sum(w * (stress_pa - pred) ** 2)), 0.0) / ss)
    return {"relative": rel, "scale": sp / pp}


def _gradient_peak(raw: RawExport) -> tuple[float, str] | None:
    """The 99th percentile of sqrt(eps:eps) of the displacement gradient over the cells' tetrahedra at the most strained step."""
    from ._unit_physics import _gradient_strain, find_displacement

    disp = find_displacement(raw)
    if disp is None:
        return None
    xyz = np.asarray(raw.points, float)
    peaks = [np.nanpercentile(np.sqrt(_gradient_strain(xyz, np.asarray(u, float), raw.cells.tetra)), 99)
             for u in disp[1]]
    return float(max(peaks)), f"the gradient of the displacements {disp[0]!r} (sym(grad u), per tetrahedron)"


def strain_check(raw: RawExport, opts: ReadOptions, location: str, n: int) -> dict:
    """How large the model's strain is, as far as the file tells: ``peak`` (the 99th percentile over the values of the
    most strained step of sqrt(eps:eps), dimensionless) and ``source`` (what it was measured on: the strain
    tensor at the stress's location, else a deformation gradient (the norm of F - I), else the displacement gradient in the
    cells), ``strain`` (the canonical strain tensor when its shear convention is known: a preset, ``shear=``, or
    9 components; else None), ``strain_name``; ``peak`` None when the file holds none of them."""
    from ._export_checks import strain_magnitude
    from dataclasses import replace

    try:
        conv = _convention(opts, raw)
    except ValueError:
        conv = None
    try:
        name, e, loc = find_tensor(raw, replace(opts, location=location), "strain", conv)
    except (SEDFormatError, ValueError):
        name = None
    if name is not None and loc == location and e.shape[1] == n:
        mag = strain_magnitude(e)
        return {"peak": float(np.max(np.nanpercentile(mag, 99, axis=1))), "source": f"the strain tensor {name!r}",
                "strain": e if conv is not None else None, "strain_name": name}
    for a in raw.arrays.values():
        if C.canonical(a.name) in DEFORMATION_GRADIENT_NAMES and a.ndim == 3 and a.shape[2] == 9:
            d = a.values.reshape(a.shape[:2] + (3, 3)) - np.eye(3)
            mag = np.sqrt(np.sum(d ** 2, axis=(-1, -2)))
            return {"peak": float(np.max(np.nanpercentile(mag, 99, axis=1))),
                    "source": f"the deformation gradient {a.name!r} (|F - I|)", "strain": None}
    if raw.cells is not None and raw.points is not None:
        found = _gradient_peak(raw)
        if found is not None:
            return {"peak": found[0], "source": found[1], "strain": None}
    return {"peak": None, "source": "the file holds no strain tensor, deformation gradient or displacements",
            "strain": None}


def _stress(raw: RawExport, opts: ReadOptions):
    """The stress tensor (name, values in file units, canonical, location); a 6-component array without component
    names needs the order declared (preset=), as its SED mixes normal and shear components otherwise."""
    preset = opts.preset or raw.preset
    conv = PRESETS[preset] if preset else None
    name, s, loc = find_tensor(raw, opts, "stress", conv)
    arr = next((a for a in raw.arrays.values() if a.name == name and a.location == loc), None)
    if conv is None and arr is not None and arr.ndim == 3 and arr.shape[2] == 6 and _order_from_names(arr.components) is None:
        orders = "; ".join(f"{' '.join(c.order)}: {', '.join(repr(p) for p, v in PRESETS.items() if v.order == c.order)}"
                           for c in {v.order: v for v in PRESETS.values()}.values())
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: the 6-component stress array {name!r} has no component names, so its order must "
            f"be declared (the SED from stress alone mixes normal and shear components otherwise): pass preset= ({orders})."
        )
    return name, s, loc


def sed_from_stress_field(raw: RawExport, opts: ReadOptions, rec, unit_of) -> tuple[np.ndarray, str]:
    """The SED from the stress alone (J/m^3): (sed (n_t, n), location), the constants, checks and formula in ``rec``.

    ``unit_of``: the stress unit resolver of :mod:`afferent.io._assemble` (declared or stated, never guessed).
    """
    from ._export_checks import _check_values

    if opts.sed_unit is not None:
        raise ValueError(f"sed_unit={opts.sed_unit!r} does not apply with sed_from='stress': SED is computed from "
                         "stress, so declare stress_unit= instead.")
    el = elastic_constants(opts)
    s_name, s, location = _stress(raw, opts)
    rec.columns["stress"] = s_name
    _check_values(raw, s, f"stress ({s_name})")
    stated = {a.unit for a in raw.arrays.values() if a.name in s_name.split(", ") or a.name == s_name}
    stated.discard(None)
    su, sf, ssrc = unit_of(raw, opts.stress_unit, stated.pop() if len(stated) == 1 else None, "stress", "stress_unit",
                           f"stress ({s_name})")
    rec.units.update(stress=su, stress_source=ssrc, modulus=el.unit, modulus_source=el.unit_source)
    rec.factors["stress"] = sf
    s = s * sf
    e, nu, mat = constants_at(raw, opts, el, location, s.shape[1], rec.notes)
    if mat is not None:
        rec.columns["material"] = mat
    checks = {"constants": {("all" if k is None else str(k)): {"young_pa": v[0], "poisson": v[1]}
                            for k, v in el.constants.items()}, "source": el.source}
    strain = strain_check(raw, opts, location, s.shape[1])
    checks["small_strain"] = {"peak": strain["peak"], "source": strain["source"], "bound": SMALL_STRAIN_BOUND}
    peak = strain["peak"]
    unknown = strain.get("strain_name") is not None and strain["strain"] is None
    linear, hooke = False, None
    if strain["strain"] is not None:
        hooke = hooke_check(s, strain["strain"], e, nu)
        checks["hooke"] = dict(hooke, rtol=HOOKE_RTOL, strain=strain["strain_name"])
        linear = math.isfinite(hooke["relative"]) and hooke["relative"] <= HOOKE_RTOL
    from .._validation import refuse_unless

    large = peak is not None and peak > SMALL_STRAIN_BOUND and not linear
    if hooke is not None and math.isfinite(hooke["scale"]) and not (
            HOOKE_SCALE_BAND[0] <= hooke["scale"] <= HOOKE_SCALE_BAND[1]):
        said = (f"SED file {_where(raw)!r}: its stress ({su} {ssrc}) is {hooke['scale']:.3g} x Hooke's law of its "
                f"strain {strain['strain_name']!r} under the elastic constants given ({el.describe()}): a unit of E "
                "or of the stress is off, or the constants are not the model's"
                + (f", or the model is far from linear elasticity (its strain is large: {peak:.3g})" if large else ""))
        refuse_unless("modulus", opts.accept, said, cls=UnitError, stacklevel=4)
        rec.notes.append(said + " (confirmed: accept='modulus').")
    if large:
        said = (f"SED file {_where(raw)!r}: its strain is large (the 99th percentile of |eps| at the most strained step "
                f"is {peak:.3g}, measured on {strain['source']}; small strain: at most {SMALL_STRAIN_BOUND:g}), where "
                "the SED from stress alone assumes linear elasticity at small strain; export the SED or the strain "
                "(sed_from='exact')" + ("; a linear-elastic model shows as such when the strain's shear convention is "
                                        "known (preset= or shear=: its stress is then checked against Hooke's law)"
                                        if unknown else ""))
        refuse_unless("large-strain", opts.accept, said, cls=SEDFormatError, stacklevel=4)
        rec.notes.append(said + " (confirmed: accept='large-strain').")
    sed = sed_from_stress(s, e[None, :], nu[None, :])
    said = (f"SED computed from the stress alone: {FORMULA}; constants: {el.describe()}"
            + (f", looked up by material array {mat!r}" if mat else "") + ". Small strain: "
            + (f"the 99th percentile of |eps| at the most strained step is {peak:.3g} ({strain['source']}; bound "
               f"{SMALL_STRAIN_BOUND:g}" + (", exceeded where the stress is Hooke's law of the strain: the tool's own "
                                            "linear-elastic model)" if peak > SMALL_STRAIN_BOUND and linear else ")")
               if peak is not None else f"not checked ({strain['source']})"))
    if "hooke" in checks:
        h = checks["hooke"]
        said += (f". Hooke's law: the stress is {h['scale']:.6g} x C:eps of the strain {h['strain']!r} under these "
                 f"constants, relative difference {h['relative']:.2g}"
                 + (" (a linear-elastic model with these constants)" if linear else
                    f" (above {HOOKE_RTOL:g}: the model is not linear elastic with these constants; the SED is the "
                    "linear-elastic one of its stress)"))
        if not linear:
            warnings.warn(said, AfferentWarning, stacklevel=4)
    rec.notes.append(said + ".")
    rec.checks["elastic"] = checks
    return sed, location
