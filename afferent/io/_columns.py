"""How FE tools spell coordinates, time, SED, stress and strain (see the documentation's page on FE exports, docs/fe-export.md).

Names are matched after :func:`canonical` (lower case; spaces, dots, dashes, colons and
underscores removed), so ``S.S11``, ``S-S11``, ``S:S11`` and ``s_11`` all read ``ss11``/``s11``.
Names are hints: where an array named like an energy sits beside stress and strain tensors,
its values decide whether it is a density (:func:`afferent.io._export_checks.density_by_values`).
"""

from __future__ import annotations

import re

__all__ = [
    "canonical",
    "split_unit",
    "COORD_ALIASES",
    "TIME_ALIASES",
    "ID_ALIASES",
    "SED_ALIASES",
    "ENERGY_NOT_DENSITY",
    "STRESS_COMPONENTS",
    "STRAIN_COMPONENTS",
    "TENSOR_ARRAY_NAMES",
    "FINITE_STRAIN_NAMES",
]

_STRIP = re.compile(r"[\s._:\-/\[\]()]+")


def canonical(name: str) -> str:
    """Canonical spelling used for matching: ``'S.S11'`` -> ``'ss11'``, ``'solid.Ws'`` -> ``'solidws'``."""
    return _STRIP.sub("", str(name)).lower()


def split_unit(header: str) -> tuple[str, str | None]:
    """Split ``'solid.Ws (J/m^3)'`` into ``('solid.Ws', 'J/m^3')``; no unit gives ``(header, None)``."""
    header = str(header).strip()
    if header.endswith((")", "]")):  # the unit: from the first bracket after the last closing one (linear time)
        body = header[:-1]
        last = max(body.rfind(")"), body.rfind("]"))
        opening = [i for i in (body.find("(", last + 1), body.find("[", last + 1)) if i >= 0]
        if opening and min(opening) > 0:
            return body[:min(opening)].strip(), body[min(opening) + 1:].strip()
    return header, None


def _c(*names: str) -> frozenset[str]:
    return frozenset(canonical(n) for n in names)


#: Coordinate columns, by axis.
COORD_ALIASES: dict[str, frozenset[str]] = {
    "x": _c("x", "coord1", "coor1", "coordx", "coordinatex", "xlocation", "xcoord", "xcoordinate", "points0"),
    "y": _c("y", "coord2", "coor2", "coordy", "coordinatey", "ylocation", "ycoord", "ycoordinate", "points1"),
    "z": _c("z", "coord3", "coor3", "coordz", "coordinatez", "zlocation", "zcoord", "zcoordinate", "points2"),
}

# Abaqus reports give coordinates as the COORD output variable's components (``COORD.COOR1``,
# ``@Loc 1`` removed; ``COORD-COOR1`` reads the same once canonical): docs/fe-export.md, Abaqus.
for _axis, _coor in (("x", "COORD.COOR1"), ("y", "COORD.COOR2"), ("z", "COORD.COOR3")):
    COORD_ALIASES[_axis] = COORD_ALIASES[_axis] | _c(_coor)

#: Time columns.
TIME_ALIASES: frozenset[str] = _c("time", "t", "steptime", "totaltime", "timestep", "time_s")

#: Node / element label columns (kept, never used as data).
ID_ALIASES: frozenset[str] = _c(
    "node", "nodelabel", "nodenumber", "nodeid", "node_id", "nid", "element", "elementlabel",
    "elementnumber", "elementid", "elem", "eid", "id", "label", "ip", "intpt", "integrationpoint", "integ.pnt.",
)

#: SED *density* arrays, in order of preference (:ref:`fe-checklist`).
SED_ALIASES: tuple[str, ...] = tuple(
    canonical(n)
    for n in (
        "sed", "sener", "eseden", "send", "sendelastic", "solid.Ws", "Ws", "ener",
        "strain energy density", "strain_energy_density", "strainenergydensity",
        "elastic strain energy density", "internal energy density", "enel", "enel_noeu", "enel_elno", "enel_elga",
    )
)

#: Arrays that are element *energies*, not densities: refused with a hint (:ref:`fe-checklist`).
ENERGY_NOT_DENSITY: dict[str, str] = {
    canonical("ELSE"): "Abaqus/CalculiX ELSE is the element's total strain energy (J), not a density",
    canonical("SENE"): "ANSYS SENE is the element strain energy (J), not a density; export SEND",
    canonical("element strain energy"): "FEBio 'element strain energy' is an energy, not a density",
    canonical("solid.Ws_tot"): "COMSOL solid.Ws_tot is the integrated energy, not a density; export solid.Ws",
    canonical("strain energy"): "'Strain Energy' (Workbench) is an element energy, not a density; Kratos' "
                                "STRAIN_ENERGY is a density despite its name",
    canonical("ALLSE"): "Abaqus ALLSE is the whole model's strain energy",
    canonical("internal energy"): "CalculiX 'internal energy' (ELSE, .dat) is the element's energy, not a density; print ENER",
    canonical("ENEL_ELEM"): "code_aster ENEL_ELEM is the elastic energy per element, not a density; export ENEL_NOEU, "
                            "ENEL_ELNO or ENEL_ELGA",
}

_AXES = {"1": "x", "2": "y", "3": "z", "x": "x", "y": "y", "z": "z"}


def _component_aliases(prefixes: tuple[str, ...]) -> dict[str, frozenset[str]]:
    """``{'xx': {...}, 'yy': ..., 'xy': ..., 'yz': ..., 'xz': ...}`` for the given name prefixes."""
    pairs = {"xx": ("11", "xx", "x"), "yy": ("22", "yy", "y"), "zz": ("33", "zz", "z"),
             "xy": ("12", "xy", "21", "yx"), "yz": ("23", "yz", "32", "zy"), "xz": ("13", "xz", "31", "zx")}
    out = {}
    for comp, suffixes in pairs.items():
        names = set()
        for p in prefixes:
            for s in suffixes:
                if len(s) == 1 and p.lower() in ("s", "e", "ep"):
                    continue  # 'SX' is fine for ANSYS stress but 'sx'/'ex' alone are handled below
                names.add(canonical(p + s))
        out[comp] = frozenset(names)
    return out


#: Stress component columns by canonical component (tensor order xx yy zz xy yz xz).
STRESS_COMPONENTS = _component_aliases(
    ("S", "S.S", "S-S", "S:S", "sigma", "sig", "stress", "stress_", "solid.s", "SI", "SIG", "cauchy_stress")
)
for _comp, _names in (("xx", ("sx", "solid.sx")), ("yy", ("sy", "solid.sy")), ("zz", ("sz", "solid.sz"))):
    STRESS_COMPONENTS[_comp] = STRESS_COMPONENTS[_comp] | _c(*_names)

#: Strain component columns by canonical component. Which shear convention applies is a
#: property of the tool (see :data:`afferent.strain_energy.PRESETS`), not of the name.
STRAIN_COMPONENTS = _component_aliases(
    ("E", "E.E", "E-E", "E:E", "LE", "LE.LE", "LE-LE", "EE", "EE.EE", "NE", "eps", "epsilon", "strain",
     "strain_", "solid.e", "EP", "EPEL", "EPTO", "EPTO.", "EPEL.", "cauchy_strain", "Lagrange strain", "TOSTRAIN")
)
for _comp, _names in (("xx", ("ex", "epelx", "eptox")), ("yy", ("ey", "epely", "eptoy")), ("zz", ("ez", "epelz", "eptoz"))):
    STRAIN_COMPONENTS[_comp] = STRAIN_COMPONENTS[_comp] | _c(*_names)

#: code_aster's field supports: nodes, element nodes, Gauss points (its ``SIEF_NOEU``, ``EPSI_ELGA``...).
_ASTER_SUPPORTS = ("NOEU", "ELNO", "ELGA", "ELEM")

#: Multi-component tensor arrays (VTU/XDMF/MED): a 6- or 9-component array with one of these names.
TENSOR_ARRAY_NAMES: dict[str, frozenset[str]] = {
    "stress": _c("S", "stress", "sigma", "cauchy_stress", "Stress", "SIEF", "SIGM", "STRESS", "nodal stress",
                 "CAUCHY_STRESS_VECTOR", "CAUCHY_STRESS_TENSOR",
                 *(f"{q}_{where}" for q in ("SIEF", "SIGM") for where in _ASTER_SUPPORTS)),
    "strain": _c("E", "strain", "eps", "epsilon", "cauchy_strain", "Strain", "LE", "EE", "EPSI", "TOSTRAIN",
                 "Lagrange strain", "infinitesimal strain", "EPEL", "EPTO", "GREEN_LAGRANGE_STRAIN_VECTOR",
                 "GREEN_LAGRANGE_STRAIN_TENSOR", *(f"EPSI_{where}" for where in _ASTER_SUPPORTS)),
}

#: Strain arrays whose name says they are a finite-strain measure (Green-Lagrange, logarithmic),
#: written by a geometrically nonlinear analysis beside Cauchy stress: FEBio's ``Lagrange strain``
#: (FEBio always solves finite deformation), Kratos' Green-Lagrange vectors, Abaqus' ``LE``
#: (logarithmic, written with NLGEOM; ``E`` without). The tensor checks judge such data only at
#: steps within :data:`afferent.io._read_options.SMALL_STRAIN_BOUND`.
FINITE_STRAIN_NAMES: frozenset[str] = _c("Lagrange strain", "Green-Lagrange strain", "GREEN_LAGRANGE_STRAIN_VECTOR",
                                         "GREEN_LAGRANGE_STRAIN_TENSOR", "LE")


# --------------------------------------------------------------------------------------
# Part instances: Abaqus numbers the nodes of each part instance from 1, so a label names a node only with its part
# --------------------------------------------------------------------------------------

#: Names of a column of part-instance names in a table (canonical): ``Part``, ``Instance``, ``Part Instance``.
PART_ALIASES = frozenset({"part", "instance", "partinstance", "partname", "instancename"})
#: The note that keeps the names of a part column's codes (arrays are float): ``column 'Part' numbers the rows' part
#: instances: 0 = 'DERMIS-1', 1 = 'EPIDERMIS-1'``.
_PART_NOTE = re.compile(r"^(?:all \d+ files: )?column '(?P<col>[^']*)' numbers the rows' part instances: (?P<names>.*)$")
_PART_NAME = re.compile(r"(\d+) = '([^']*)'")


def part_note(column: str, names) -> str:
    """The note naming the codes 0, 1, ... of part column ``column`` (parsed back by :func:`part_names`)."""
    return f"column '{column}' numbers the rows' part instances: " + ", ".join(
        f"{k} = '{n}'" for k, n in enumerate(names))


def part_names(notes) -> tuple[str, tuple[str, ...]] | None:
    """(column, part names in code order) from the notes of a table with a part column, or None."""
    for note in notes:
        m = _PART_NOTE.match(note)
        if m:
            return m.group("col"), tuple(n for _, n in _PART_NAME.findall(m.group("names")))
    return None
