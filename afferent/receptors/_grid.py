"""A regular receptor grid: one papilla row (RA-I) or one ridge-base row (SA-I) per fingerprint ridge
(:func:`grid_layout`), positions in m.
"""

from __future__ import annotations

from collections.abc import Callable

import numbers

import numpy as np

from .._validation import check_positive, plain
from ._layout import SITE_OF_KIND, ReceptorLayout

# --------------------------------------------------------------------------------------
# Layout generators: a regular ridge/papilla grid, and papilla tips found on an FE mesh
# --------------------------------------------------------------------------------------

#: Fingerprint-ridge pitch along x in m (:ref:`method-fe-model`): one papilla row per ridge.
RIDGE_PITCH_M = 0.44e-3
#: Dermal-papilla pitch along z (along a ridge) in m (:ref:`method-fe-model`).
PAPILLA_PITCH_M = 0.22e-3
#: A grid line within this fraction of a pitch outside a range end still counts as inside
#: (float round-off of ``x0 + i * pitch``).
_GRID_EPS = 1e-9
#: Largest layout :func:`grid_layout` builds; far above a whole fingertip (~ 5e3 tips), far
#: below what a range given in mm instead of m produces.
_MAX_GRID_RECEPTORS = 1_000_000


def _check_length(name: str, value) -> float:
    value = plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise TypeError(f"{name!r} must be a finite length in m; got {value!r} instead.")
    return float(value)


def _check_range(name: str, value) -> tuple[float, float]:
    try:
        lo, hi = (plain(v) for v in value)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name!r} must be a pair (min, max) in m; got {value!r} instead.") from err
    ok = all(not isinstance(v, bool) and isinstance(v, numbers.Real) and np.isfinite(v) for v in (lo, hi))
    if not ok:
        raise TypeError(f"{name!r} must be a pair (min, max) of finite lengths in m; got {value!r} instead.")
    if lo > hi:
        raise ValueError(f"{name!r} must be a pair (min, max) in m with min <= max; got {value!r} instead.")
    return float(lo), float(hi)


def _grid_ids(i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``'L{i}C{j}'`` with i, j zero-padded to the width of their largest value; duplicates get ``'.1'``, ``'.2'``."""
    wi = len(str(int(i.max()))) if i.size else 1
    wj = len(str(int(j.max()))) if j.size else 1
    ids = [f"L{a:0{wi}d}C{b:0{wj}d}" for a, b in zip(i.tolist(), j.tolist())]
    seen: dict[str, int] = {}
    for k, name in enumerate(ids):
        if name in seen:
            seen[name] += 1
            ids[k] = f"{name}.{seen[name]}"
        else:
            seen[name] = 0
    return np.array(ids, dtype=str)


def _axis_lines(axis: str, lo: float, hi: float, pitch: float, start: float | None) -> np.ndarray:
    """Grid coordinates ``start + k * pitch`` (m) inside [lo, hi]; centred on the range when ``start`` is None."""
    if start is None:
        n = int(np.floor((hi - lo) / pitch + _GRID_EPS)) + 1
        return 0.5 * (lo + hi) + (np.arange(n) - 0.5 * (n - 1)) * pitch
    k0 = int(np.ceil((lo - start) / pitch - _GRID_EPS))
    k1 = int(np.floor((hi - start) / pitch + _GRID_EPS))
    if k1 < k0:
        raise ValueError(
            f"'{axis}_range' must contain at least one grid line {axis} = {start!r} + k * {pitch!r} m "
            f"(from 'origin' and 'pitch_{axis}'); got ({lo!r}, {hi!r}) m instead."
        )
    return start + np.arange(k0, k1 + 1) * pitch


def grid_layout(
    *,
    x_range: tuple[float, float],
    z_range: tuple[float, float],
    y: float | Callable[[np.ndarray, np.ndarray], np.ndarray],
    pitch_x: float = RIDGE_PITCH_M,
    pitch_z: float = PAPILLA_PITCH_M,
    origin: tuple[float, float] | None=None,
    kind: str = "tips",
) -> ReceptorLayout:
    """Receptors on the study's regular ridge/papilla grid (:ref:`method-receptor-sites`).

    The grid is the lattice of papilla tips: point (i, j) at ``x = x0 + i * pitch_x`` (i-th
    papilla row, one per fingerprint ridge) and ``z = z0 + j * pitch_z`` (j-th papilla along
    the ridge). ``kind`` says which sites are placed on it, for every point inside
    ``x_range`` x ``z_range``, at height ``y``:

    * ``'tips'`` (RA-I): at the lattice points, ``x = x0 + i * pitch_x``;
    * ``'bases'`` (SA-I): on the intermediate ridges, which lie under the surface ridges with
      the papilla rows beside them, half a ridge pitch across x from the papilla rows:
      ``x = x0 + (i + 1/2) * pitch_x``, at the same z as the papillae (one base site opposite
      each papilla).

    Parameters
    ----------
    x_range : tuple of float
        ``(x_min, x_max)`` in m, across the ridges; ends included (to 1e-9 of a pitch).
    z_range : tuple of float
        ``(z_min, z_max)`` in m, along the ridges; ends included.
    y : float or callable
        Height of the receptors in m: a float for a flat surface, or a callable
        ``y(x, z) -> height`` taking two ndarrays of shape (n_receptors,) in m and returning
        heights in m of shape (n_receptors,) (or a scalar), e.g. the papilla-tip surface of
        the FE model.
    pitch_x : float, default=0.44e-3
        Grid pitch along x in m (fingerprint-ridge pitch).
    pitch_z : float, default=0.22e-3
        Grid pitch along z in m (papilla pitch along a ridge).
    origin : tuple of float, optional
        ``(x0, z0)`` in m: a point of the papilla-tip lattice, which fixes its phase (for
        ``kind='bases'`` too: the base rows are then at ``x0 + pitch_x / 2 + i * pitch_x``).
        Default: the tip lattice is centred on the ranges (as many points as fit, with equal
        margins at both ends), and the base rows are half a pitch from its rows.
    kind : {'tips', 'bases'}, default='tips'
        Papilla tips (RA-I sites) or intermediate-ridge bases (SA-I sites).

    Returns
    -------
    ReceptorLayout
        Receptors ordered by i (x) then j (z), ``site`` 'RA-I' (tips) or 'SA-I' (bases). Section labels are the grid indices:
        ``longitudinal = i`` (the line at one x, parallel to the ridges) and ``cross = j``,
        both counted from 0 at the smallest x and z inside the ranges. Ids are
        ``'L{i}C{j}'`` with i and j zero-padded to a common width, e.g. ``'L3C07'`` is the
        receptor of longitudinal section 3 and cross-section 7.

    Raises
    ------
    TypeError
        If a range is not a pair of finite numbers, ``y`` is neither a number nor a callable,
        or a pitch is not a number.
    ValueError
        If a range has min > max, a pitch is not > 0, no grid line falls in a range (with
        ``origin``), ``y(x, z)`` returns the wrong shape or non-finite heights, or the grid
        would exceed 1,000,000 receptors (ranges given in mm instead of m).

    See Also
    --------
    interface_sites : the papilla tips or ridge bases of an FE mesh, where the model put them.
    read_receptors : receptor sites from a CSV file.

    Examples
    --------
    >>> layout = grid_layout(x_range=(0.0, 0.88e-3), z_range=(0.0, 0.44e-3), y=2.45e-3)
    >>> layout.n_receptors
    9
    >>> layout.ids[:4].tolist()
    ['L0C0', 'L0C1', 'L0C2', 'L1C0']
    >>> layout.positions[4] * 1e3  # mm
    array([0.44, 2.45, 0.22])
    >>> bases = grid_layout(x_range=(0.0, 0.88e-3), z_range=(0.0, 0.44e-3), y=2.3e-3, kind="bases")
    >>> bases.site, (bases.positions[:, 0] * 1e3).round(2).tolist()[::3]
    ('SA-I', [0.22, 0.66])
    """
    if kind not in SITE_OF_KIND:
        raise ValueError(f"'kind' must be 'tips' or 'bases'; got {kind!r} instead.")
    xlo, xhi = _check_range("x_range", x_range)
    zlo, zhi = _check_range("z_range", z_range)
    pitch_x = check_positive("pitch_x", pitch_x, unit="m")
    pitch_z = check_positive("pitch_z", pitch_z, unit="m")
    if origin is None:
        x0 = z0 = None
    else:
        try:
            x0, z0 = origin
        except (TypeError, ValueError) as err:
            raise TypeError(f"'origin' must be a pair (x0, z0) in m; got {origin!r} instead.") from err
        x0, z0 = _check_length("origin[0]", x0), _check_length("origin[1]", z0)
    if not callable(y):
        y = plain(y)
        if isinstance(y, bool) or not isinstance(y, numbers.Real) or not np.isfinite(y):
            raise TypeError(
                f"'y' must be a height in m (a finite float) or a callable y(x, z) returning heights in m; "
                f"got {y!r} instead."
            )
    n_x = np.floor((xhi - xlo) / pitch_x + _GRID_EPS) + 1
    n_z = np.floor((zhi - zlo) / pitch_z + _GRID_EPS) + 1
    if n_x * n_z > _MAX_GRID_RECEPTORS:
        raise ValueError(
            f"'x_range' and 'z_range' must span at most {_MAX_GRID_RECEPTORS:,} grid points; got "
            f"({float(xlo)!r}, {float(xhi)!r}) x ({float(zlo)!r}, {float(zhi)!r}) m with pitches {float(pitch_x)!r} x "
            f"{float(pitch_z)!r} m, about {n_x * n_z:.3g} points, "
            "instead. Ranges and pitches are in m: pass 4e-3, not 4, for 4 mm."
        )
    if kind == "bases" and x0 is not None:  # the ridge rows: half a ridge pitch from the papilla rows
        xs = _axis_lines("x", xlo, xhi, pitch_x, x0 + 0.5 * pitch_x)
    else:
        xs = _axis_lines("x", xlo, xhi, pitch_x, x0)
        if kind == "bases":
            xs = _axis_lines("x", xlo, xhi, pitch_x, xs[0] - 0.5 * pitch_x)
    zs = _axis_lines("z", zlo, zhi, pitch_z, z0)
    ii, jj = (a.ravel() for a in np.meshgrid(np.arange(xs.size), np.arange(zs.size), indexing="ij"))
    x, z = xs[ii], zs[jj]
    if callable(y):
        heights = np.asarray(y(x, z), dtype=float)
        if heights.ndim == 0:
            heights = np.full(x.shape, float(heights))
        if heights.shape != x.shape:
            raise ValueError(
                f"'y' must return one height in m per grid point, an array of shape ({x.size},); "
                f"got shape {heights.shape} instead."
            )
        if not np.all(np.isfinite(heights)):
            k = int(np.argmin(np.isfinite(heights)))
            raise ValueError(
                f"'y' must return finite heights in m; got {heights[k]!r} at x = {x[k]!r} m, z = {z[k]!r} m instead."
            )
    else:
        heights = np.full(x.shape, float(y))
    positions = np.column_stack([x, heights, z])
    return ReceptorLayout(positions, _grid_ids(ii, jj), longitudinal=ii, cross=jj, site=SITE_OF_KIND[kind])
