"""Stage 2: the SED field at the receptor sites.

::

    SEDField + ReceptorLayout --sample_sed--> ReceptorSED   (n_times, n_receptors) J/m^3

``'nearest'`` takes the value of the nearest mesh node (for cell data: of the cell holding
the receptor). ``'linear'`` interpolates inside the mesh's own cells with each cell's own shape functions
(barycentric in tetrahedra, trilinear in hexahedra, ..., quadratic in quadratic cells:
``afferent/_shape_functions.py``; the cells split into tetrahedra locate the points),
with weights computed once and reused for every time step; cell
data is first averaged to the nodes, each cell weighing its volume on each of its corners.
A table of points without connectivity (CSV) is triangulated (scipy ``Delaunay``) around the
receptors, in 3-D, or in the points' plane for a surface-only table.

How the values were placed is recorded with the result (:attr:`ReceptorSED.placement`,
:data:`PLACEMENTS`), next to where they came from (:class:`afferent.field.Provenance`:
``location``, ``location_source``).

The geometry (points in tetrahedra, cell volumes, cell-to-node averaging, triangulation of a
point table) is in ``afferent/_mesh_geometry.py``.

Size: just over 600 lines: the sampler's building (linear cells, quadratic cells, point tables),
its application per step and the records of both stay together; the geometry, the shape
functions and the material-interface reports are their own modules already.
"""

from __future__ import annotations

from ._typing import PathLike
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

import os
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, get_args

import numpy as np

from ._mesh_geometry import (  # noqa: F401 (locate_in_tets, JOGGLE, NEAR_NODES_FROM: importable here, as before)
    BARY_TOL,
    JOGGLE,
    NEAR_NODES_FROM,
    _find,
    _inside_hull,
    _triangulate,
    cell_volumes,
    locate_in_tets,
    node_average,
)
from ._shape_functions import clip_overshoot, shaped_types, with_shape_functions
from ._validation import check_option
from ._plausibility import refuse_collapse
from .exceptions import AfferentWarning, FieldCoverageError, SEDFormatError
from .field import SEDField
from .receptors import ReceptorLayout

if TYPE_CHECKING:  # scipy loads when a sampler is built, not for a cached ReceptorSED
    import scipy.sparse as sp

__all__ = ["ReceptorSED", "Sampler", "build_sampler", "sample_sed", "sample_steps", "read_receptor_sed", "node_average", "cell_volumes",
           "METHODS", "PLACEMENTS"]

#: How a receptor takes the field's value: interpolated in its mesh cell, or from the nearest node.
SamplingMethod = Literal["linear", "nearest"]
METHODS: tuple[str, ...] = get_args(SamplingMethod)
#: What a receptor outside the mesh does: refuse the run, warn, or take NaN.
OnOutside = Literal["raise", "warn", "nan"]
ON_OUTSIDE: tuple[str, ...] = get_args(OnOutside)


#: Neighbours gathered around each receptor when a scattered-point export is triangulated.
SCATTER_NEIGHBOURS = 48


@dataclass(frozen=True)
class ReceptorSED:
    """SED sampled at receptor sites.

    Parameters
    ----------
    values : ndarray of shape (n_times, n_receptors)
        SED in J/m^3 (NaN for receptors outside the field with ``on_outside='nan'|'warn'``).
    times : ndarray of shape (n_times,)
        Time of each step in s.
    layout : ReceptorLayout
        The receptor sites.
    method : str
        ``'linear'`` or ``'nearest'`` (``'csv'`` when read back by :func:`read_receptor_sed`).
    outside : ndarray of shape (n_receptors,), bool
        Receptors found outside the field.
    placement : str
        How the field's values were placed at the receptors, one of :data:`PLACEMENTS` (e.g.
        ``'cell value of the containing cell'``, ``'cells averaged to nodes by cell volume, then
        linear'``); empty when unknown (a table read back).
    interface : dict or None
        Receptors on a material interface, each side's SED, the side used (see :ref:`fe-interfaces`).
    time_unit : {'s', 'step'}, default='s'
        ``'step'``: ``times`` are the step numbers 0, 1, ... of an export that states no times
        (tables of several such steps name the column ``step``, never ``time_s``: :attr:`numbered`).
    """

    values: np.ndarray
    times: np.ndarray
    layout: ReceptorLayout
    method: str
    outside: np.ndarray
    placement: str = ""
    interface: dict | None = None
    time_unit: str = "s"

    @property
    def numbered(self) -> bool:
        """Whether ``times`` are the step numbers of a multi-step export that states no times (not seconds)."""
        return self.time_unit == "step" and self.values.shape[0] > 1

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self.values, dtype=dtype)

    def columns(self, *, sections: bool = False) -> dict:
        """The long table's columns (name -> 1-D array), one row per receptor and step.

        ``receptor, x_m, y_m, z_m, time_s, sed_pa`` (positions in m, time in s, SED in J/m^3 = Pa);
        with ``sections=True`` also ``longitudinal`` and ``cross`` section labels. What
        :meth:`to_dataframe` holds and ``sed_map.csv`` is written from (without pandas). Step numbers
        (:attr:`numbered`) go into a column ``step`` instead of ``time_s``.
        """
        n_t, n_r = self.values.shape
        pos = self.layout.positions
        cols = {
            "receptor": np.tile(self.layout.ids, n_t),
            "x_m": np.tile(pos[:, 0], n_t),
            "y_m": np.tile(pos[:, 1], n_t),
            "z_m": np.tile(pos[:, 2], n_t),
        }
        if sections:
            cols["longitudinal"] = np.tile(self.layout.longitudinal, n_t)
            cols["cross"] = np.tile(self.layout.cross, n_t)
        cols["step" if self.numbered else "time_s"] = np.repeat(self.times, n_r)
        cols["sed_pa"] = self.values.reshape(-1)
        return cols

    def to_dataframe(self, *, sections: bool = False) -> DataFrame:
        """Long table, one row per receptor and step (a pandas DataFrame of :meth:`columns`).

        Columns ``receptor, x_m, y_m, z_m, time_s, sed_pa`` (positions in m, time in s, SED in
        J/m^3 = Pa); with ``sections=True`` also ``longitudinal`` and ``cross`` section labels.
        """
        import pandas as pd

        return pd.DataFrame(self.columns(sections=sections))

    def __repr__(self) -> str:
        return (
            f"<ReceptorSED: {self.values.shape[1]} receptors x {self.values.shape[0]} step(s), method={self.method!r}, "
            f"SED in [{np.nanmin(self.values) if self.values.size else np.nan:.4g}, "
            f"{np.nanmax(self.values) if self.values.size else np.nan:.4g}] J/m^3>"
        )


@dataclass(frozen=True)
class Sampler:
    """Interpolation weights from field values to receptors, computed once.

    ``values_at_receptors = weights @ field_values`` for every time step.

    Parameters
    ----------
    weights : scipy.sparse.csr_matrix of shape (n_receptors, n_values)
    outside : ndarray of shape (n_receptors,), bool
    method : str
    placement : str
        How values are placed at the receptors, one of :data:`PLACEMENTS`.
    domain : str
        What "inside the field" means when it is not the mesh's cells (a table of points: its
        convex hull, its plane, its bounding box), for messages; empty for a mesh.
    """

    weights: sp.csr_matrix
    outside: np.ndarray
    method: str
    placement: str = ""
    domain: str = ""

    def apply(self, sed: np.ndarray) -> np.ndarray:
        """(n_times, n_values) -> (n_times, n_receptors); NaN where outside.

        Negative values that quadratic shape functions make between non-negative nodes are 0
        (``clip_overshoot`` in ``afferent/_shape_functions.py``; docs/fe-export.md)."""
        out = np.asarray((self.weights @ np.asarray(sed, dtype=float).T).T)
        clip_overshoot(out, self.weights, sed)
        out[:, self.outside] = np.nan
        return out




#: How the values reach the receptors, by (data location or 'scattered', method): recorded as
#: :attr:`Sampler.placement` and :attr:`ReceptorSED.placement`.
PLACEMENTS = {
    ("point", "nearest"): "value of the nearest node",
    ("point", "linear"): "linear in the mesh's cells (split into tetrahedra)",
    ("point", "shape"): "the cells' own shape functions (located by Newton on their isoparametric map): linear in "
                        "tetrahedra, trilinear in hexahedra, linear x linear in wedges, VTK's basis in pyramids, "
                        "quadratic in quadratic cells (values below 0 between non-negative nodes set to 0)",
    ("cell", "nearest"): "cell value of the containing cell",
    ("cell", "linear"): "cells averaged to nodes by cell volume, then linear",
    ("cell", "shape"): "cells averaged to nodes by cell volume, then the cells' own linear shape functions (linear "
                       "in tetrahedra, trilinear in hexahedra, linear x linear in wedges, VTK's basis in pyramids; "
                       "quadratic cells: linear in the tetrahedra of their corners)",
    ("scattered", "nearest"): "value of the nearest point",
    ("scattered", "linear"): "linear in a Delaunay tetrahedralisation of the points",
    ("plane", "linear"): "linear in a Delaunay triangulation of the points' plane (surface-only table)",
}


def build_sampler(field: SEDField, layout: ReceptorLayout, *, method: SamplingMethod = "linear") -> Sampler:
    """Compute the interpolation weights from ``field`` to the receptor sites (once).

    Parameters
    ----------
    field : SEDField
        Only its geometry (points in m, cells, location) is used.
    layout : ReceptorLayout
        Receptor positions in m.
    method : {'linear', 'nearest'}

    Returns
    -------
    Sampler
        Weights, the receptors outside the field, and how values are placed
        (:data:`PLACEMENTS`).

    Raises
    ------
    FieldCoverageError
        ``'linear'`` on a table of points that lie on a line (or fewer than 3 points): there is
        nothing to interpolate in.
    """
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    check_option("method", method, METHODS)
    xyz, pos = field.points, layout.positions
    n_r = layout.n_receptors
    if field.cells is not None:
        placement = PLACEMENTS[(field.location, method)]
        tet, bary = locate_in_tets(pos, xyz, field.cells)
        outside = tet < 0
        inside = np.flatnonzero(~outside)
        if field.location == "cell" and method == "nearest":
            cols = field.cells.rows(tet[inside])[1]
            w = sp.csr_matrix((np.ones(inside.size), (inside, cols)), shape=(n_r, field.cells.n_cells))
        elif method == "nearest":
            _, idx = cKDTree(xyz).query(pos)
            w = sp.csr_matrix((np.ones(inside.size), (inside, idx[inside])), shape=(n_r, field.n_points))
        else:
            nodes, parents = field.cells.rows(tet[inside])
            w = sp.csr_matrix(
                (bary[inside].ravel(), (np.repeat(inside, 4), nodes.ravel())), shape=(n_r, field.n_points)
            )
            types = shaped_types(field.cells, field.location)
            if types and inside.size:  # the cells' own shape functions where they have them (not their tetrahedra's)
                guess = np.full(n_r, -1, dtype=np.int64)
                guess[inside] = parents
                w, outside, placement = with_shape_functions(w, outside, pos, xyz, field.cells, guess,
                                                             PLACEMENTS[(field.location, "shape")], types)
            if field.location == "cell":
                w = w @ node_average(field.cells, xyz, field.n_points)
        return Sampler(w.tocsr(), outside, method, placement)
    # Scattered points (a CSV table): no connectivity.
    if method == "nearest":
        lo, hi = xyz.min(axis=0), xyz.max(axis=0)
        span = float(np.max(hi - lo)) or 1.0
        outside = np.any((pos < lo - 1e-9 * span) | (pos > hi + 1e-9 * span), axis=1)
        _, idx = cKDTree(xyz).query(pos)
        inside = np.flatnonzero(~outside)
        w = sp.csr_matrix((np.ones(inside.size), (inside, idx[inside])), shape=(n_r, field.n_points))
        return Sampler(w, outside, method, PLACEMENTS[("scattered", "nearest")],
                       f"the bounding box of its {field.n_points} points")
    return _scattered_linear(field, layout)


#: A point table thinner than this, relative to its extent, is a plane (a surface-only export):
#: coordinates written with 6 significant digits lie off their true plane by up to 5e-6 of
#: their magnitude (5e-5 of the extent for a model offset from the origin by 10 extents), and
#: no FE volume is that thin. Receptors farther than this from the plane are outside it.
PLANE_RTOL = 1e-4


def _source(field: SEDField) -> str:
    files = field.provenance.files
    return f" of SED file {files[0]!r}" if files else ""


#: Joggle, relative to the points' extent, applied before triangulating a point table. FE nodes

def _scattered_linear(field: SEDField, layout: ReceptorLayout) -> Sampler:
    """'linear' weights for a table of points: Delaunay in 3-D, or in their plane when they are one.

    A receptor is inside when it lies in the points' convex hull (3-D), or on the plane of a
    planar table and inside the hull of its points there; its weights are barycentric in the
    Delaunay simplex holding it. In 3-D only the points near the receptors are triangulated;
    receptors inside the hull that this does not cover are retried with 8x more neighbours,
    then with every point.
    """
    import scipy.sparse as sp
    from scipy.spatial import ConvexHull, QhullError, cKDTree

    n, n_r = field.n_points, layout.n_receptors
    centre = field.points.mean(axis=0)
    axes = np.linalg.svd(field.points - centre, full_matrices=False)[2] if n >= 2 else np.eye(3)
    widths = np.ptp((field.points - centre) @ axes.T, axis=0) if n else np.zeros(3)  # along the principal axes, m
    extent = float(widths[0])
    if n < 3 or widths[1] <= PLANE_RTOL * extent:
        raise FieldCoverageError(
            f"Linear sampling needs the points{_source(field)} to span a volume or a surface; its {n} point(s) "
            f"lie on a line (extent {extent:.6g} m, width across {float(widths[1]):.3g} m). Use method='nearest'."
        )
    # normalised coordinates (extent 1) along the principal axes: conditioning for Qhull
    xyz = (field.points - centre) @ axes.T / extent
    with np.errstate(over="ignore", invalid="ignore"):  # a receptor 1e305 m away: inf, outside the hull
        pos = (layout.positions - centre) @ axes.T / extent
    rows = np.zeros((n_r, 4), dtype=np.int64)
    weights = np.zeros((n_r, 4))
    found = np.zeros(n_r, dtype=bool)
    if widths[2] <= PLANE_RTOL * extent:
        # A surface-only table: triangulate in the plane; receptors off the plane are outside.
        on_plane = np.flatnonzero(np.abs(pos[:, 2]) <= PLANE_RTOL)
        on_plane = on_plane[_inside_hull(pos[on_plane, :2], ConvexHull(xyz[:, :2]).equations, BARY_TOL)]
        tri = _triangulate(xyz[:, :2])
        simplex, w = _find(tri, pos[on_plane, :2])
        hit = simplex >= 0
        idx = on_plane[hit]
        rows[idx, :3], weights[idx, :3], found[idx] = tri.simplices[simplex[hit]], w[hit], True
        normal = axes[2] * np.sign(axes[2][np.argmax(np.abs(axes[2]))])
        normal = ", ".join(f"{v:.4g}" for v in np.round(normal, 6) + 0.0)
        domain = (f"the field is a surface: its {n} points lie in one plane (normal [{normal}]); receptors farther "
                  f"than {PLANE_RTOL * extent:.3g} m from it, or off its points' hull in it, are outside")
        placement = PLACEMENTS[("plane", "linear")]
    else:
        try:
            hull = ConvexHull(xyz)
        except QhullError as err:
            raise FieldCoverageError(
                f"Linear sampling could not build the convex hull of the {n} points{_source(field)} (nearly flat: "
                f"widths {', '.join(f'{float(v):.3g}' for v in widths)} m along their principal axes): "
                f"{str(err).splitlines()[0]}. Use method='nearest'."
            ) from err
        todo = np.flatnonzero(_inside_hull(pos, hull.equations, BARY_TOL))
        tree = cKDTree(xyz)
        for k in (SCATTER_NEIGHBOURS, 8 * SCATTER_NEIGHBOURS, n):
            if not todo.size:
                break
            subset = np.arange(n) if k >= n else np.unique(tree.query(pos[todo], k=k)[1].reshape(-1))
            try:
                tri = _triangulate(xyz[subset])
            except QhullError as err:
                if subset.size < n:
                    continue  # the receptors' neighbours are degenerate (one layer of a layered table): grow
                raise FieldCoverageError(
                    f"Linear sampling could not triangulate the {n} points{_source(field)}: "
                    f"{str(err).splitlines()[0]}. Use method='nearest'."
                ) from err
            simplex, w = _find(tri, pos[todo])
            hit = simplex >= 0
            idx = todo[hit]
            rows[idx], weights[idx], found[idx] = subset[tri.simplices[simplex[hit]]], w[hit], True
            todo = todo[~hit]
        domain = f"the field is the convex hull of its {n} points"
        placement = PLACEMENTS[("scattered", "linear")]
    inside = np.flatnonzero(found)
    w = sp.csr_matrix((weights[inside].ravel(), (np.repeat(inside, 4), rows[inside].ravel())), shape=(n_r, n))
    w.eliminate_zeros()
    return Sampler(w, ~found, "linear", placement, domain)


#: Receptor extent over field extent beyond which the two were probably declared in different
#: length units (mm vs m is 1e3): above, the receptors spread far wider than the model; below,
#: they huddle in 1/300 of it (a region of interest is rarely that small).
RECEPTOR_SPAN_BAND = (1 / 300, 30.0)


def _unit_mismatch(layout: ReceptorLayout, field: SEDField) -> str:
    """A sentence when receptors and field are orders of magnitude apart in extent, else ''."""
    from ._plausibility import scale_ratio

    if layout.n_receptors < 2:
        return ""
    ratio = scale_ratio(layout.positions, field.points)
    lo, hi = RECEPTOR_SPAN_BAND
    if not np.isfinite(ratio) or lo <= ratio <= hi:
        return ""
    of = f" of receptor file {layout.source!r}" if layout.source else ""
    return (f"The receptors{of} span {ratio:.3g} x the field's extent: check the length unit declared for the "
            "receptor positions (mm vs m is a factor 1e3).")


def _receptors_smaller(layout: ReceptorLayout, field: SEDField) -> bool:
    """Whether the receptors span orders of magnitude less than the field (m read as mm): the case in which
    they collapse into one cell. Receptors spanning more (um read as mm) land mostly outside, reported as such;
    the few inside may share a cell legitimately."""
    from ._plausibility import scale_ratio

    return bool(scale_ratio(layout.positions, field.points) < RECEPTOR_SPAN_BAND[0])


def report_outside(layout: ReceptorLayout, outside, on_outside: str, *, where: str, hint: str, stacklevel: int = 2):
    """Raise or warn about receptors outside the SED field, per ``on_outside`` ('raise', 'warn', 'nan').

    The message names how many, the first one (id and position in m) and ``where`` (e.g. the
    field's bounds); ``hint`` says how to continue. Nothing happens when none is outside.
    """
    outside = np.asarray(outside, dtype=bool)
    n_out = int(outside.sum())
    if not n_out:
        return
    i = int(np.flatnonzero(outside)[0])
    p = ", ".join(f"{v:.6g}" for v in layout.positions[i])
    of = f" of receptor file {layout.source!r}" if layout.source else ""
    msg = (
        f"{n_out} of {layout.n_receptors} receptors{of} lie outside the SED field "
        f"(first: receptor {str(layout.ids[i])!r} at [{p}] m; {where})."
    )
    if on_outside == "raise":
        raise FieldCoverageError(f"{msg} {hint}")
    if on_outside == "warn":
        warnings.warn(msg + " They are NaN.", AfferentWarning, stacklevel=stacklevel + 1)


def sample_sed(
    field: SEDField,
    layout: ReceptorLayout,
    *,
    method: SamplingMethod = "linear",
    on_outside: OnOutside = "raise",
    sampler: Sampler | None = None,
    side: str | int = "average",
) -> ReceptorSED:
    """SED at each receptor site and time step.

    Parameters
    ----------
    field : SEDField
        SED in J/m^3 (from :func:`afferent.read_sed`).
    layout : ReceptorLayout
        Receptor sites in m (from :func:`afferent.read_receptors`).
    method : {'linear', 'nearest'}, default='linear'
        ``'linear'``: interpolation in the mesh's cells with each cell's own shape functions
        (barycentric in tetrahedra, trilinear in hexahedra, linear x linear in wedges, VTK's basis in
        pyramids, quadratic in quadratic cells: exact for a field linear in space; see
        docs/fe-export.md, "Each cell's own shape functions"); cell data is first averaged to the nodes, weighted by cell volume (exact at
        interior nodes of a regular grid for cell values linear in space); a table of points
        is triangulated (Delaunay, in its plane when the points are coplanar). ``'nearest'``:
        value of the nearest node, or of the containing cell for cell data. ``'nearest'`` is
        cheaper and cruder; ``benchmarks/bench_sampling.py`` measures both.
    on_outside : {'raise', 'warn', 'nan'}, default='raise'
        What to do with receptors outside the mesh (for a table of points with ``'linear'``:
        outside the points' convex hull, or off the plane of a planar table; with
        ``'nearest'``: outside their bounding box): raise :class:`FieldCoverageError` naming
        them, or keep them as NaN (with an :class:`AfferentWarning` for ``'warn'``).
    sampler : Sampler, optional
        Weights from :func:`build_sampler` to reuse (same geometry, same layout).
    side : 'average' or int, default='average'
        Receptors on an interface between materials (cells with material ids): ``'average'`` across
        them, or a material id for that material's SED alone (the dermis for Meissner corpuscles).
        See :ref:`fe-interfaces`.

    Returns
    -------
    ReceptorSED
        Values of shape (n_times, n_receptors) in J/m^3, times in s, the receptors outside,
        ``placement``: how the values were placed (e.g. ``'cell value of the containing
        cell'``, ``'cells averaged to nodes by cell volume, then linear'``), and ``interface``:
        the receptors on a material interface, each side's SED and the side used.

    Raises
    ------
    FieldCoverageError
        Receptors outside the field with ``on_outside='raise'``; ``'linear'`` on a table of
        points that lie on a line.
    """
    from ._interfaces import build_interface, check_side, sided

    side = check_side(side)
    head = _sample_field(field, layout, method=method, on_outside=on_outside, sampler=sampler)
    isamp = build_interface(field, layout)
    return sided(head, field, isamp, [isamp.step_values(field)] if isamp else [], side, stacklevel=3)


def _sample_field(field: SEDField, layout: ReceptorLayout, *, method: str, on_outside: str,
                  sampler: Sampler | None) -> ReceptorSED:
    """:func:`sample_sed` without the side: the values ``method`` gives."""
    check_option("method", method, METHODS)
    check_option("on_outside", on_outside, ON_OUTSIDE)
    if sampler is None:
        sampler = build_sampler(field, layout, method=method)
    units = _unit_mismatch(layout, field)
    if units and _receptors_smaller(layout, field):  # and every receptor in one cell or on one point: refused
        refuse_collapse(sampler.weights, sampler.outside, layout.source, units)
    if units and not sampler.outside.any():
        warnings.warn(units, AfferentWarning, stacklevel=2)
    if sampler.outside.any():
        lo, hi = field.bounds
        bounds = " ".join(f"{a} [{l:.6g}, {h:.6g}]" for a, l, h in zip("xyz", lo, hi))
        where = f"{sampler.domain}; field bounds {bounds} m" if sampler.domain else f"field bounds {bounds} m"
        from ._placement import swap_hint

        swapped = "" if units else swap_hint(layout, field)
        report_outside(layout, sampler.outside, on_outside, where=where,
                       hint=(f"{swapped} " if swapped else "") + "Pass on_outside='nan' to keep them as NaN or "
                       "on_outside='warn' to continue." + (f" {units}" if units else ""), stacklevel=4)
    return ReceptorSED(sampler.apply(field.sed), field.times.copy(), layout, method, sampler.outside.copy(),
                       sampler.placement, time_unit="step" if field.provenance.units.get("time") == "step" else "s")


def sample_steps(fields: Iterable[SEDField], layout: ReceptorLayout, *, method: SamplingMethod = "linear", on_outside: OnOutside = "raise",
                 sampler: Sampler | None = None, side: str | int = "average") -> ReceptorSED:
    """SED at each receptor site, from fields that arrive one time step at a time.

    The streaming form of :func:`sample_sed` for series too large to hold in memory: the
    weights are built from the first field (:func:`build_sampler`) and applied to each field
    as it arrives, so only one step of the mesh is held at a time (plus the
    (n_times, n_receptors) result). Gives the same values as :func:`sample_sed` on the
    whole series.

    Parameters
    ----------
    fields : iterable of SEDField
        Steps in time order, on one mesh (e.g. :func:`afferent.io.iter_sed`); SED in J/m^3.
    layout : ReceptorLayout
        Receptor sites in m.
    method, on_outside, side
        As for :func:`sample_sed`.
    sampler : Sampler, optional
        Weights from :func:`build_sampler` to use (built on the first field's geometry, or a
        crop of it), instead of building them from the first field.

    Returns
    -------
    ReceptorSED
        Values of shape (n_times, n_receptors) in J/m^3 over every step, times in s.

    Raises
    ------
    FieldCoverageError
        As :func:`sample_sed`, for the first field.
    SEDFormatError
        A later field not on the first field's mesh (points or cells differ).
    ValueError
        No field at all.
    """
    return sample_steps_together(fields, [layout], method=method, on_outside=on_outside,
                                 samplers=None if sampler is None else [sampler], side=side)[0]


def sample_steps_together(fields, layouts, *, method: str = "linear", on_outside: str = "raise", samplers=None,
                          side: str | int = "average") -> list:
    """:func:`sample_steps` for several receptor layouts in one pass over ``fields``: each step is read once
    and sampled at every layout (a scene's receptors and its second hot-spot map's sites, from one read of
    the export). ``samplers``: one per layout (or None, built from the first field). Returns one
    :class:`ReceptorSED` per layout, in order (J/m^3, times in s); errors as :func:`sample_steps`.
    """
    from ._interfaces import build_interface, check_side, sided

    side = check_side(side)
    n = len(layouts)
    samplers = [None] * n if samplers is None else list(samplers)
    first, times, heads, isamps = None, [], [None] * n, [None] * n
    values, side_values = [[] for _ in range(n)], [[] for _ in range(n)]
    for field in fields:
        if first is None:
            first = field
            for i, layout in enumerate(layouts):
                if samplers[i] is None:
                    samplers[i] = build_sampler(field, layout, method=method)
                heads[i] = _sample_field(field, layout, method=method, on_outside=on_outside, sampler=samplers[i])
                values[i].append(heads[i].values)
                isamps[i] = build_interface(field, layout)
        else:
            _check_same_mesh(first, field)
            for i in range(n):
                values[i].append(samplers[i].apply(field.sed))
        times.append(field.times)
        for i in range(n):
            if isamps[i] is not None:
                side_values[i].append(isamps[i].step_values(field))
    if first is None:
        raise ValueError("'fields' must hold at least one SEDField; got none.")
    out = []
    for i, layout in enumerate(layouts):
        sed = ReceptorSED(np.concatenate(values[i]), np.concatenate(times), layout, method, samplers[i].outside.copy(),
                          samplers[i].placement, time_unit=heads[i].time_unit)
        out.append(sided(sed, first, isamps[i], side_values[i], side))
    return out


def _check_same_mesh(first: SEDField, field: SEDField) -> None:
    """Refuse a later step of a series that is not on the first step's mesh (points or cells differ)."""
    from .exceptions import SEDFormatError

    same = (field.location == first.location and field.sed.shape[1] == first.sed.shape[1]
            and (field.cells is first.cells or (field.cells is not None and first.cells is not None
                                               and np.array_equal(field.cells.tetra, first.cells.tetra)))
            and (field.points is first.points or np.array_equal(field.points, first.points)))
    if not same:
        where = f"SED file {field.provenance.files[0]!r}" if field.provenance.files else "A step"
        raise SEDFormatError(f"{where} (t = {float(field.times[0]):g} s) is not on the mesh of the first step "
                             f"({first.sed.shape[1]} {first.location} values); a series must share one mesh.")


#: Columns of the long-form table written by ``afferent sample`` (:meth:`ReceptorSED.to_dataframe`).
SED_TABLE_COLUMNS = ("receptor", "x_m", "y_m", "z_m", "time_s", "sed_pa")


def read_receptor_sed(path: PathLike) -> ReceptorSED:
    """Read the long-form SED table written by ``afferent sample`` into a :class:`~afferent.sampling.ReceptorSED`.

    Parameters
    ----------
    path : str or path-like
        CSV with columns receptor, x_m, y_m, z_m (m), time_s (s) or step (the step numbers of an
        export without times), sed_pa (Pa = J/m^3); one row per receptor and time step. Receptors keep the order of their first appearance;
        sections (longitudinal by x, cross by z) are recomputed from the positions.

    Returns
    -------
    ReceptorSED
        Values of shape (n_times, n_receptors) in Pa, times in s, ``method='csv'``.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SEDFormatError
        Missing columns, non-numeric or non-finite values, a receptor at two positions, or a
        (receptor, time) pair missing or repeated.
    """
    import pandas as pd

    from ._tables import numeric_columns, read_table

    path = os.fspath(path)
    df, _ = read_table(path, what="SED file", expected=", ".join(SED_TABLE_COLUMNS))
    df.columns = [str(c).strip().lower() for c in df.columns]
    numbered = "time_s" not in df.columns and "step" in df.columns  # step numbers of an export without times
    df = df.rename(columns={"step": "time_s"}) if numbered else df
    missing = [c for c in SED_TABLE_COLUMNS if c not in df.columns]
    if missing:
        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise SEDFormatError(
            f"SED file {path!r} must have the columns {', '.join(SED_TABLE_COLUMNS)} (as written by 'afferent sample'); "
            f"missing {', '.join(missing)}. Found columns {found}."
        )
    if df.empty:
        raise SEDFormatError(f"SED file {path!r} has no data rows.")
    num = pd.DataFrame(numeric_columns(df, SED_TABLE_COLUMNS[1:], what="SED file", path=path),
                       columns=list(SED_TABLE_COLUMNS[1:]))
    blank = df["receptor"].isna().to_numpy()
    if blank.any():
        raise SEDFormatError(f"SED file {path!r}: column 'receptor' must name the receptor in every data row; data row "
                             f"{int(np.flatnonzero(blank)[0]) + 1} has none.")
    ids = df["receptor"].astype(str).to_numpy()
    names, first = np.unique(ids, return_index=True)
    order = np.argsort(first, kind="stable")
    names, first = names[order], first[order]
    col_of = {n: i for i, n in enumerate(names)}
    times = np.unique(num["time_s"].to_numpy(float))
    n_r, n_t = names.size, times.size
    xyz = num[["x_m", "y_m", "z_m"]].to_numpy(float)
    positions = xyz[first]
    cols = np.array([col_of[i] for i in ids])
    if not np.allclose(xyz, positions[cols], rtol=0, atol=1e-12):
        k = int(np.flatnonzero(~np.all(np.isclose(xyz, positions[cols], rtol=0, atol=1e-12), axis=1))[0])
        raise SEDFormatError(
            f"SED file {path!r}: receptor {ids[k]!r} must have one position; got two (data rows "
            f"{int(first[cols[k]]) + 1} and {k + 1}) instead."
        )
    rows = np.searchsorted(times, num["time_s"].to_numpy(float))
    counts = np.zeros((n_t, n_r), int)
    np.add.at(counts, (rows, cols), 1)
    if not np.all(counts == 1):
        t, j = (int(i) for i in np.argwhere(counts != 1)[0])
        what = "missing" if counts[t, j] == 0 else f"given {counts[t, j]} times"
        raise SEDFormatError(
            f"SED file {path!r} must have exactly one row per receptor and time step; receptor {names[j]!r} at "
            f"time {float(times[t])!r} s is {what}."
        )
    values = np.empty((n_t, n_r))
    values[rows, cols] = num["sed_pa"].to_numpy(float)
    layout = ReceptorLayout(positions, names, source=path)
    from ._plausibility import sed_warning, span_warning

    for msg in (sed_warning(values, what=f"SED file {path!r}", unit_hint="that sed_pa is in Pa"),
                span_warning(positions, what=f"SED file {path!r} (receptor positions)", unit_hint="that x_m, y_m, z_m are in m")):
        if msg:
            warnings.warn(msg, AfferentWarning, stacklevel=2)
    return ReceptorSED(values, times, layout, "csv", np.zeros(n_r, bool), time_unit="step" if numbered else "s")


