"""Are these magnitudes those of skin under touch? Checks that warn, never choose a unit.

A unit declared wrongly (mm for m, Pa for MPa) gives numbers that look like numbers: the
wrong number that looks right. Units are always declared or stated, never guessed; these
checks only compare what was declared with what skin models hold and say so when they are
orders of magnitude apart. They use a robust level (a high percentile of the nonzero values),
not the maximum: a singular corner under a punch edge can be 100x the rest of the field.

The bands are wide on purpose (a warning must mean something): a factor 1e3 (mm/m) or 1e6
(MPa/Pa) moves typical values outside them; kPa/Pa (1e3) on SED may not.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SED_BAND_PA", "SPAN_BAND_M", "robust_level", "extent", "sed_warning", "span_warning", "scale_ratio",
           "refuse_collapse", "COLLAPSE_VALUES"]

#: Robust SED level (99th percentile of the nonzero |SED|) of skin under touch, in J/m^3 = Pa.
#: The study's peak is ~190 Pa; the bundled sample's tip medians 51-688 Pa and peaks up to 4.4 kPa;
#: a hard press on a fingertip reaches ~1e5 Pa. The band is two decades wider on each side.
SED_BAND_PA = (1e-2, 1e7)
#: Largest extent of an FE skin model, in m: from a 0.1 mm patch of papillae to a 0.5 m forearm
#: or robot-skin sheet (a fingertip block is 1-20 mm).
SPAN_BAND_M = (1e-4, 0.5)
#: Percentile of the nonzero absolute values used as the field's level.
LEVEL_PERCENTILE = 99.0


def _magnitudes(values) -> np.ndarray:
    """The finite, nonzero absolute values, flat."""
    v = np.abs(np.asarray(values, dtype=float).ravel())
    return v[np.isfinite(v) & (v > 0)]


def robust_level(values) -> float:
    """The 99th percentile of the finite, nonzero absolute values (0.0 when there are none)."""
    v = _magnitudes(values)
    return float(np.percentile(v, LEVEL_PERCENTILE)) if v.size else 0.0


def _level_inside(v: np.ndarray, band: tuple[float, float]) -> bool:
    """Whether the 99th percentile of ``v`` (:func:`_magnitudes`, not empty) surely lies inside ``band``, from two
    counts instead of a partial sort (0.3 ms instead of 2 ms for 300,000 values, the check of every step of a
    series): the values ranked one below and one above the percentile's two neighbours are both strictly inside
    the band, so the percentile, interpolated between values in between, is too. False: find the level."""
    rank = (v.size - 1) * LEVEL_PERCENTILE / 100
    low, high = max(math.floor(rank) - 1, 0), min(math.ceil(rank) + 1, v.size - 1)
    return (int(np.count_nonzero(v <= band[0])) <= low
            and int(np.count_nonzero(v >= band[1])) <= v.size - 1 - high)


def _outside(value: float, band: tuple[float, float], words: tuple[str, str]) -> str | None:
    """``words[0]`` below the band, ``words[1]`` above it, None inside it or for 0 (no data)."""
    if value == 0.0 or band[0] <= value <= band[1]:
        return None
    return words[0] if value < band[0] else words[1]


def extent(x) -> float:
    """Largest coordinate range of points (n, k), or the |value| range of a 1-D array; for
    coincident points, their largest |coordinate| (NaN rows ignored; 0 when empty)."""
    x = np.asarray(x, dtype=float)
    x = x.reshape(-1, 1) if x.ndim == 1 else x
    finite = np.isfinite(x)
    if not finite.all():  # a copy only when some rows are left out (2M points: 48 MB)
        x = x[finite.all(axis=1)]
    if x.shape[0] == 0:
        return 0.0
    with np.errstate(over="ignore"):  # points at -1e307 and 1.7e308: the range is inf, and says so
        # column by column: 0.04 instead of 0.33 s for 2M points against max(axis=0) of the (n, 3) array
        rng = max(float(c.max() - c.min()) for c in x.T)
    return rng if rng > 0 else float(np.max(np.abs(x)))


def sed_warning(sed_pa, *, what: str, unit_hint: str) -> str | None:
    """A warning text when the SED level lies outside :data:`SED_BAND_PA`, else None.

    Parameters
    ----------
    sed_pa : array_like
        SED in J/m^3 (after unit conversion).
    what : str
        What the values are, e.g. ``"SED file 'a.vtu' (SED column 'ENER', declared MPa)"``.
    unit_hint : str
        The option that sets the unit, e.g. ``"sed_unit"``.

    A field whose every value is 0 J/m^3 (the wrong column, or the undeformed state exported)
    is also reported: everything downstream of it would be zero.
    """
    v = _magnitudes(sed_pa)
    if v.size and _level_inside(v, SED_BAND_PA):
        return None
    level = float(np.percentile(v, LEVEL_PERCENTILE)) if v.size else 0.0
    if level == 0.0:
        v = np.asarray(sed_pa, dtype=float)
        if v.size and np.all(v == 0):
            return (f"{what}: every SED value is 0 J/m^3 ({v.size} values): the wrong column, or the undeformed state "
                    "exported? The currents and spikes computed from it are zero.")
        return None
    lo, hi = SED_BAND_PA
    side = _outside(level, SED_BAND_PA, ("below", "above"))
    if side is None:
        return None
    return (
        f"{what}: SED of {level:.3g} J/m^3 (99th percentile of the nonzero values) is far {side} what skin under "
        f"touch holds ({lo:g}..{hi:g} J/m^3); check {unit_hint} (MPa vs Pa is a factor 1e6)."
    )


def span_warning(points_m, *, what: str, unit_hint: str) -> str | None:
    """A warning text when the largest extent of ``points_m`` (m) lies outside :data:`SPAN_BAND_M`."""
    pts = np.asarray(points_m, dtype=float).reshape(-1, 3)
    if pts.shape[0] < 2:
        return None
    if not np.isfinite(pts).all():
        pts = pts[np.isfinite(pts).all(axis=1)]
    if pts.shape[0] < 2:
        return None
    # per column: reductions over axis 0 of an (n, 3) array (nanmax above all) are 10x slower
    span = max(float(pts[:, c].max() - pts[:, c].min()) for c in range(3))
    lo, hi = SPAN_BAND_M
    side = _outside(span, SPAN_BAND_M, ("smaller", "larger"))
    if side is None:
        return None
    return (
        f"{what}: the points span {span:.3g} m, far {side} than a skin model ({lo * 1e3:g} mm..{hi:g} m); "
        f"check {unit_hint} (mm vs m is a factor 1e3)."
    )


def scale_ratio(a, b) -> float:
    """Ratio of the extents (largest coordinate range, or |value| range for 1-D) of ``a`` over ``b``.

    NaN when either extent is 0. Used to flag two sets of positions (receptors and mesh,
    observed and afferent positions) declared in different units: a ratio near 1e3 or 1e-3.
    """
    ea, eb = extent(a), extent(b)
    return ea / eb if ea > 0 and eb > 0 else float("nan")


#: at most this many field values (one quadratic hexahedron's 27 nodes) feeding every receptor: they collapsed
COLLAPSE_VALUES = 27


def refuse_collapse(weights, outside, source, units: str) -> None:
    """Refuse receptors that, declared in a length unit apart from the field's, all fall in one cell or on one point.

    Every receptor would get (nearly) the same SED: a number wrong for all of them, not a
    warning's worth. Called by :func:`afferent.sampling.sample_sed` only when the receptors'
    extent is orders from the field's (``units``: that sentence).

    Parameters
    ----------
    weights : scipy.sparse matrix of shape (n_receptors, n_values)
        Sampling weights (field values -> receptors).
    outside : ndarray of bool, shape (n_receptors,)
        Receptors outside the field (not counted).
    source : str or None
        The receptor file, for the message.
    units : str
        The sentence saying how far apart the extents are.

    Raises
    ------
    UnitError
        Two or more receptors inside the field, all fed by at most :data:`COLLAPSE_VALUES` values.
    """
    from .exceptions import UnitError

    inside = np.flatnonzero(~np.asarray(outside, dtype=bool))
    if inside.size < 2:
        return
    used = np.unique(weights[inside].tocsr().indices)
    if used.size > COLLAPSE_VALUES:
        return
    of = f" of receptor file {source!r}" if source else ""
    raise UnitError(
        f"All {inside.size} receptors{of} inside the field fall in one cell or on one point ({used.size} field "
        f"value(s) feed them all): each would get the same SED. {units} Declare the receptors' unit (--receptor-unit, "
        "[receptors] length_unit) and the export's (--length-unit, [export] length_unit).")
