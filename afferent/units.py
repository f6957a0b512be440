"""Physical units at the boundary: declared by the user or stated by the file, never guessed.

Everything inside :mod:`afferent` is SI: lengths in m, SED and stress in Pa (= J/m^3),
times in s, currents in A. This module converts *into* SI at read time and records the
factor used.

>>> length_factor("mm")
0.001
>>> sed_factor("mJ/mm^3")
1000000.0
"""

from __future__ import annotations

import re

from .exceptions import UnitError

__all__ = ["LENGTH_UNITS", "SED_UNITS", "TIME_UNITS", "length_factor", "sed_factor", "time_factor", "parse_unit"]

#: Length units accepted, with their factor to metres.
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "micron": 1e-6}

#: SED / stress units accepted, with their factor to Pa (= J/m^3). SED has the unit of stress.
SED_UNITS: dict[str, float] = {
    "Pa": 1.0,
    "kPa": 1e3,
    "MPa": 1e6,
    "GPa": 1e9,
    "J/m^3": 1.0,
    "N/m^2": 1.0,
    "kJ/m^3": 1e3,
    "mJ/mm^3": 1e6,
    "J/mm^3": 1e9,
    "N/mm^2": 1e6,
    "uJ/mm^3": 1e3,
}

#: Time units accepted, with their factor to s.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6}

_NORMALISE = [
    (re.compile(r"\s+"), ""),
    (re.compile(r"\*\*"), "^"),
    (re.compile(r"³"), "^3"),
    (re.compile(r"²"), "^2"),
    (re.compile(r"(?<=[a-zA-Z])3$"), "^3"),  # J/m3 -> J/m^3
    (re.compile(r"(?<=[a-zA-Z])2$"), "^2"),  # N/mm2 -> N/mm^2
]


def _normalise(text: str) -> str:
    out = str(text).strip()
    for pat, rep in _NORMALISE:
        out = pat.sub(rep, out)
    return out.replace("μ", "u").replace("µ", "u")


def _lookup(kind: str, text: str, table: dict[str, float], name: str) -> float:
    key = _normalise(text)
    if key in table:
        return table[key]
    lower = {k.lower(): v for k, v in table.items()}
    # Case matters for Pa vs mPa only in theory; MPa and mPa are both spelled; keep exact first.
    if key.lower() in lower and key.lower() not in ("mpa",):
        return lower[key.lower()]
    allowed = ", ".join(repr(k) for k in table if k not in ("µm",))
    raise UnitError(f"{name} must be a {kind} unit, one of {allowed}; got {text!r} instead.")


def length_factor(unit: str, *, name: str = "'length_unit'") -> float:
    """Factor that converts a length in ``unit`` to metres (``'mm'`` -> 1e-3)."""
    return _lookup("length", unit, LENGTH_UNITS, name)


def sed_factor(unit: str, *, name: str = "'sed_unit'") -> float:
    """Factor that converts an SED or stress in ``unit`` to Pa = J/m^3 (``'MPa'`` -> 1e6)."""
    return _lookup("SED/stress", unit, SED_UNITS, name)


def time_factor(unit: str, *, name: str = "'time_unit'") -> float:
    """Factor that converts a time in ``unit`` to s (``'ms'`` -> 1e-3)."""
    return _lookup("time", unit, TIME_UNITS, name)


def parse_unit(text: str) -> str | None:
    """Return the canonical spelling of a unit written in a file (``'J/m3'`` -> ``'J/m^3'``), or None.

    Used for units stated in column headers such as ``solid.Ws (J/m^3)`` or
    ``X Location (mm)``; a unit that is not recognised returns None (the caller then
    requires the user to declare it).
    """
    key = _normalise(text)
    for table in (LENGTH_UNITS, SED_UNITS, TIME_UNITS):
        if key in table:
            return "um" if key in ("µm", "micron") else key
    if key in ("1", "", "-"):
        return "1"
    return None
