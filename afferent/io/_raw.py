"""The common intermediate form every format reader returns.

A reader's only job is to turn bytes into numbers: it returns a :class:`RawExport` with the
export's own names and units, untouched. Choosing the SED array, recognising tensor
components, converting units and validating is done once, for every format, in
:mod:`afferent.io._assemble`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..field import Cells

__all__ = ["RawExport", "RawArray", "drop_valueless_nodes", "split_steps", "stack_steps"]


@dataclass(frozen=True)
class RawArray:
    """One named array of an export, in the file's units.

    Parameters
    ----------
    name : str
        The name as the export spells it (CSV header without its unit, VTU array name).
    values : ndarray of shape (n_times, n_values) or (n_times, n_values, n_components)
        Values in the file's units (float64).
    location : {'point', 'cell'}
        Point (node) data or one value per cell.
    unit : str or None
        The unit the file states for this array (e.g. from ``solid.Ws (J/m^3)``), else None.
    components : tuple of str
        Component names when the file gives them (VTU ``ComponentName``), else ().
    """

    name: str
    values: np.ndarray
    location: str = "point"
    unit: str | None = None
    components: tuple[str, ...] = ()


@dataclass(frozen=True)
class RawExport:
    """What a format reader found in an export, before interpretation.

    Parameters
    ----------
    files : tuple of str
        Files read, in time order.
    format : str
        Reader name (``'csv'``, ``'vtu'``, ``'pvd'``, ``'xdmf'``).
    points : ndarray of shape (n_points, 3) or None
        Coordinates in the file's length unit; None for a CSV whose coordinate columns have
        not been identified yet (then they are among ``arrays``).
    arrays : dict of str to RawArray
        Every numeric array/column found, keyed by name.
    times : ndarray of shape (n_times,) or None
        Step times in the file's time unit when the file states them (PVD ``timestep``,
        a CSV time column, ``@ t=`` headers), else None.
    cells : Cells or None
        Volume cells (VTU/XDMF); None for CSV tables.
    length_unit : str or None
        Length unit the file states (COMSOL ``% Length unit``, ``X Location (mm)``), else None.
    time_unit : str or None
        Time unit the file states, else None.
    notes : tuple of str
        What the reader did that a user should know (rows skipped, footers dropped, ...).
    preset : str or None
        The tool whose conventions the file follows when the format itself says so (a
        CalculiX ``.frd`` is always CalculiX's component order and shear), a key of
        :data:`afferent.strain_energy.PRESETS`; None when only the user can tell.
    """

    files: tuple[str, ...]
    format: str
    points: np.ndarray | None
    arrays: dict[str, RawArray] = field(default_factory=dict)
    times: np.ndarray | None = None
    cells: Cells | None = None
    length_unit: str | None = None
    time_unit: str | None = None
    notes: tuple[str, ...] = ()
    preset: str | None = None

    @property
    def n_times(self) -> int:
        """Number of time steps found (1 for a static export)."""
        for arr in self.arrays.values():
            return arr.values.shape[0]
        return 0


def split_steps(raw: RawExport):
    """Yield ``raw`` one time step at a time (one-step RawExports sharing points and cells).

    For readers that read a whole file at once (CSV, .frd, Exodus, .rst): the steps are views,
    nothing is copied.
    """
    from dataclasses import replace

    for k in range(max(raw.n_times, 1)):
        yield replace(raw, arrays={key: replace(a, values=a.values[k:k + 1]) for key, a in raw.arrays.items()},
                      times=None if raw.times is None else raw.times[k:k + 1])


def stack_steps(steps, **override) -> RawExport:
    """One RawExport holding every step of an iterable of one-step RawExports (on one mesh).

    The first step gives the mesh, names and units; its arrays' values are stacked along the
    time axis. ``override`` replaces fields of the result (``files``, ``format``, ``notes``).
    """
    from dataclasses import replace

    first, stacks, times = None, {}, []
    for step in steps:
        if first is None:
            first = step
            stacks = {key: [a.values] for key, a in step.arrays.items()}
        else:
            for key in stacks:
                stacks[key].append(step.arrays[key].values)
        if step.times is not None:
            times.append(step.times)
    arrays = {key: replace(first.arrays[key], values=np.concatenate(v)) for key, v in stacks.items()}
    stacked_times = np.concatenate(times) if first.times is not None else None
    return replace(first, arrays=arrays, times=stacked_times, **override)


def drop_valueless_nodes(raw: RawExport) -> RawExport:
    """Leave out the nodes that lack a value in some point array and belong to no volume cell's tets.

    FE tools average results only at some nodes (the corner nodes of quadratic elements, the
    nodes of the elements an output set covers); the others come back as NaN and carry nothing.
    Nodes used by the cells' tetrahedra are always kept (their NaN is then an error later).
    """
    import numpy as np

    n = raw.points.shape[0]
    has_value = np.ones(n, bool)  # a value in every point array, at every step
    for arr in raw.arrays.values():
        if arr.location == "point":
            v = arr.values.reshape(arr.values.shape[0], n, -1)
            has_value &= np.isfinite(v).all(axis=(0, 2))
    if has_value.all() or not has_value.any():
        return raw
    used = np.zeros(n, bool)
    if raw.cells is not None:
        used[np.unique(raw.cells.tetra)] = True
    if (used & ~has_value).any():
        return raw
    keep = np.flatnonzero(has_value)
    remap = np.full(n, -1)
    remap[keep] = np.arange(keep.size)
    arrays = {k: (RawArray(a.name, a.values[:, keep], a.location, a.unit, a.components) if a.location == "point" else a)
              for k, a in raw.arrays.items()}
    cells = raw.cells
    if cells is not None:
        cells = Cells(remap[cells.tetra], cells.parent, cells.n_cells, cells.cell_types,
                      tuple(remap[n] for n in cells.nodes))  # -1: a mid-side node left out (that cell: corners only)
    note = f"{n - keep.size} node(s) without results and outside every volume cell's corners left out."
    return RawExport(files=raw.files, format=raw.format, points=raw.points[keep], arrays=arrays, times=raw.times,
                     cells=cells, length_unit=raw.length_unit, time_unit=raw.time_unit, notes=raw.notes + (note,),
                     preset=raw.preset)
