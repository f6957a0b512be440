"""The SED field read from an FE export: the output of stage 1 (:func:`afferent.read_sed`).

::

    FE export (CSV / VTU / PVD / XDMF) --read_sed--> SEDField --sample_sed--> ReceptorSED

An :class:`SEDField` holds SI values only (m, Pa = J/m^3, s) and a :class:`Provenance`
saying where they came from and which conversion was applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np

from ._typing import ArrayLike
from .exceptions import SEDFormatError
from ._validation import check_finite_array

__all__ = ["SEDField", "Provenance", "Cells", "NodeSides"]


@dataclass(frozen=True)
class Provenance:
    """Where a field came from, so that every number can be traced back.

    Parameters
    ----------
    files : tuple of str
        Every file the reader opened: the export file(s), in time order, then their side files
        (a ``.pvd``'s VTU files, an XDMF's HDF5 and ``.bin`` files, HDF5 external-link targets,
        a ``coordinates`` table) in the order first opened. The sampled-SED cache and
        ``run.json`` hash exactly these.
    format : str
        Reader used (``'vtu'``, ``'csv'``, ``'pvd'``, ``'xdmf'``).
    sed_from : str
        ``'field'`` (an SED array of the export), ``'exact'`` (1/2 sigma:eps from tensors)
        or ``'equivalent'`` (the study's 1/2 sigma_e eps_e, see :mod:`afferent.strain_energy`).
    columns : dict
        Which export array or column was used for what, e.g. ``{'sed': 'SENER', 'x': 'X'}``.
    units : dict
        Units as declared or read, e.g. ``{'length': 'mm', 'sed': 'MPa'}``, and where each
        unit came from under ``'<name>_source'`` (``'declared'`` or ``'file'``).
    factors : dict
        Factors applied to reach SI, e.g. ``{'length': 1e-3, 'sed': 1e6}``.
    notes : tuple of str
        Free-text remarks recorded by the reader (rows skipped, units assumed, ...).
    negative_sed : dict or None
        The export's negative SED values, when it had any (nodal-averaging artefacts of the FE
        tool): ``count``, ``n_values``, ``min_pa`` (J/m^3, after unit conversion),
        ``min_relative`` (over the largest SED), ``tolerance`` and ``action`` ('set to 0').
        None when every value was >= 0.
    checks : dict
        Cross-checks made while reading, by name, e.g. ``'tensor_sed_vs_export_sed'`` (SED from
        the tensors against the export's own SED array; see
        :func:`afferent.io._assemble.tensor_sed_crosscheck`).
    location : {'point', 'cell', ''}
        Where the values used (the SED array, or the stress and strain) live in the export:
        ``'point'`` (one value per node or table row) or ``'cell'`` (one value per FE cell).
        Empty for a field built by hand.
    location_source : str
        How that location was chosen: ``'declared'`` (``location=`` was passed), ``'only point
        data'`` / ``'only cell data'`` (the export holds the values at that location only), or
        ``'point preferred over cell'`` (it holds both; point data is the default). Empty for a
        field built by hand. How the values are then placed at the receptors is recorded by
        sampling (:attr:`afferent.sampling.ReceptorSED.placement`).
    coincident : dict or None
        Coincident points merged into nodes (discontinuous output: deal.II ``DataOut``, DG
        fields), from ``afferent.io._coincident.merge_coincident``: ``n_points``,
        ``n_nodes``, ``n_copies_merged``, ``max_copies``, ``tolerance`` (m), ``rule``, and for
        point data how far the copies disagreed (``median_relative``, ``max_relative``). None
        when no two points coincide.
    """

    files: tuple[str, ...] = ()
    format: str = ""
    sed_from: str = "field"
    columns: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    factors: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    negative_sed: dict | None = None
    checks: dict = field(default_factory=dict)
    location: str = ""
    location_source: str = ""
    coincident: dict | None = None

    def to_dict(self) -> dict:
        """Plain-dict form, for JSON records."""
        return {
            "files": list(self.files),
            "format": self.format,
            "sed_from": self.sed_from,
            "columns": dict(self.columns),
            "units": dict(self.units),
            "factors": dict(self.factors),
            "notes": list(self.notes),
            "negative_sed": None if self.negative_sed is None else dict(self.negative_sed),
            "checks": {k: dict(v) for k, v in self.checks.items()},
            "location": self.location,
            "location_source": self.location_source,
            "coincident": None if self.coincident is None else dict(self.coincident),
        }


class Deferred:
    """Array values decoded on first use, their shape known before (from the file's header).

    A reader that can tell an array's shape without decoding it (a VTU's binary DataArray: its
    header gives the byte count) hands :class:`RawArray` a ``Deferred`` instead of the values;
    ``afferent.read_sed`` then decodes only the arrays it uses (the SED, the material ids), not
    the displacements and the other arrays an export carries besides. The values come back once,
    checked against ``shape``.

    Parameters
    ----------
    shape : tuple of int
        The values' shape once decoded, in the layout of :attr:`RawArray.values`.
    decode : callable
        ``decode()`` returns the values (an ndarray of ``shape``); its errors are the reader's
        (an :class:`afferent.exceptions.SEDFormatError` naming the file and the array).
    label : str
        What the values are, for the message should they not have ``shape`` (e.g. ``"SED file
        'a.vtu': point array 'U'"``).
    """

    __slots__ = ("shape", "_decode", "label", "_values")

    def __init__(self, shape: tuple, decode, label: str = "an array"):
        self.shape, self._decode, self.label = tuple(int(n) for n in shape), decode, label
        self._values = None

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def then(self, function, shape: tuple | None = None) -> Deferred:
        """The values ``function(values)`` will have, still not decoded (shape: the result's, default unchanged)."""
        return Deferred(self.shape if shape is None else shape, lambda: function(self.decode()), self.label)

    def decode(self) -> np.ndarray:
        """The values, checked against :attr:`shape` (decoded once: a second call returns the same array)."""
        if self._values is None:
            values = self._decode()
            if values.shape != self.shape:
                raise SEDFormatError(f"{self.label} decoded to shape {values.shape}, where the file's header announced "
                                     f"{self.shape}: the file is corrupt.")
            self._values, self._decode = values, None
        return self._values

    def __reduce__(self):  # pickled as its values: the decoder's closure does not travel
        return np.asarray, (self.decode(),)


class _DecodedOnUse:
    """An array field of a frozen dataclass (``RawArray.values``, ``Cells.tetra``): an ndarray, or a ``Deferred``
    decoded (once) on first access."""

    def __set_name__(self, owner, name):
        self.key = "_" + name

    def __get__(self, obj, owner=None):
        if obj is None:
            raise AttributeError("no default")  # a dataclass field without a default
        values = obj.__dict__[self.key]
        if isinstance(values, Deferred):
            values = obj.__dict__[self.key] = values.decode()
        return values

    def __set__(self, obj, values):
        obj.__dict__[self.key] = values


@dataclass(frozen=True)
class Cells:
    """Volume cells of the FE mesh, as linear tetrahedra used for point location.

    Parameters
    ----------
    tetra : ndarray of shape (n_tetra, 4), int
        Point indices of the linear tetrahedra that tile the mesh (hexahedra, wedges and
        pyramids are split; quadratic cells are split by their corner nodes): used to locate
        points, and to interpolate in linear cells. Cells made by :meth:`split` make them on first
        access (:meth:`rows` and :meth:`tetra_rows` serve a part of them without that).
    parent : ndarray of shape (n_tetra,), int
        Index of the original FE cell each tetrahedron came from (into the cell-data arrays).
    n_cells : int
        Number of original volume cells.
    cell_types : tuple of str
        meshio names of the original volume cell blocks, in order.
    materials : ndarray of shape (n_cells,), int, or None
        Material id of each original cell when the export has a material array
        (``Provenance.columns['material']`` names it), else None. Used to tell which materials
        meet at a receptor (see :ref:`fe-interfaces`).
    nodes : tuple of ndarray
        Full connectivity of each block in VTK/meshio node order, parallel to ``cell_types``
        (the cells of block k follow those of blocks 0..k-1): the quadratic cells' own shape
        functions use it (``afferent/_shape_functions.py``). Empty when not needed (a mesh of
        linear cells) or not known. A node index of -1 marks a node left out for want of
        values: that cell is then interpolated from its corners.
    """

    tetra: np.ndarray = _DecodedOnUse()
    parent: np.ndarray = _DecodedOnUse()
    n_cells: int
    cell_types: tuple[str, ...] = ()
    materials: np.ndarray | None = None
    nodes: tuple[np.ndarray, ...] = ()

    def __post_init__(self):
        tetra, parent = self.__dict__["_tetra"], self.__dict__["_parent"]
        for name, values in (("tetra", tetra), ("parent", parent)):
            if isinstance(values, Deferred):  # split on first use (Cells.split): made contiguous, read-only then
                object.__setattr__(self, name, values.then(_frozen_int64))
            else:
                object.__setattr__(self, name, _frozen_int64(np.asarray(values)))
        tetra, parent = self.__dict__["_tetra"], self.__dict__["_parent"]
        if len(tetra.shape) != 2 or tetra.shape[1] != 4:
            raise ValueError(f"'tetra' must be an array of shape (n_tetra, 4); got shape {tetra.shape} instead.")
        if parent.shape != (tetra.shape[0],):
            raise ValueError(
                f"'parent' must be an array of shape (n_tetra,) = ({tetra.shape[0]},); "
                f"got shape {parent.shape} instead."
            )
        nodes = tuple(np.ascontiguousarray(n, dtype=np.int64) for n in self.nodes)
        if nodes and (len(nodes) != len(self.cell_types) or sum(n.shape[0] for n in nodes) != self.n_cells):
            raise ValueError(f"'nodes' must hold one connectivity array per cell type ({len(self.cell_types)}) and "
                             f"n_cells = {self.n_cells} cells in all; got {len(nodes)} array(s) of "
                             f"{sum(n.shape[0] for n in nodes)} cells instead.")
        for n in nodes:
            n.setflags(write=False)
        object.__setattr__(self, "nodes", nodes)
        if self.materials is not None:
            mat = np.ascontiguousarray(self.materials, dtype=np.int64)
            if mat.shape != (self.n_cells,):
                raise ValueError(f"'materials' must be an array of shape (n_cells,) = ({self.n_cells},); "
                                 f"got shape {mat.shape} instead.")
            mat.setflags(write=False)
            object.__setattr__(self, "materials", mat)

    @cached_property
    def index_range(self) -> tuple[int, int]:
        """(lowest, highest) point index the tetrahedra use; (0, -1) without tetrahedra. Computed once
        per Cells (the arrays are read-only): a series' fields share their mesh's Cells. Cells still to be
        split (:meth:`split`): from the corner nodes of their blocks, which are the tetrahedra's."""
        if not self.n_tetra:
            return 0, -1
        if self._blocks is not None and not self.split_done:
            ends = []
            for pattern, conn, _, _ in self._blocks:
                used = np.unique(pattern)
                corners = conn if used.size == conn.shape[1] else conn[:, used]  # every node a corner: no copy
                if corners.size:
                    ends.append((int(corners.min()), int(corners.max())))
            return min(e[0] for e in ends), max(e[1] for e in ends)
        return int(self.tetra.min()), int(self.tetra.max())

    #: (pattern (k, 4), connectivity (n, m), first cell, first tetrahedron) of each block of Cells made by
    #: :meth:`split`; None for Cells given their tetrahedra.
    _blocks = None

    @classmethod
    def split(cls, blocks: list, *, n_cells: int, cell_types: tuple = (), nodes: bool = False) -> Cells:
        """Cells whose tetrahedra are split from their blocks on first use of :attr:`tetra` / :attr:`parent`.

        ``blocks``: ``(pattern, connectivity)`` per block in cell order: each cell (a row of the
        connectivity) is split into the tetrahedra ``connectivity[cell, pattern[j]]``, cell after cell.
        :meth:`rows` and :meth:`tetra_rows` serve a part of them without splitting the rest: a
        2,000,376-node hexahedral mesh's 11.7 million tetrahedra (0.47 GB with their parents) are
        not made when the receptors need a few thousand of them. ``nodes``: keep the connectivities
        as :attr:`nodes`.
        """
        done: list = []
        first_cell = first_tet = 0
        for pattern, conn in blocks:
            pattern = np.asarray(pattern, dtype=np.intp).reshape(-1, 4)
            conn = np.ascontiguousarray(conn, dtype=np.int64)  # the array :attr:`nodes` holds, when it is given
            done.append((pattern, conn, first_cell, first_tet))
            first_cell += conn.shape[0]
            first_tet += conn.shape[0] * pattern.shape[0]
        tetra = Deferred((first_tet, 4), lambda: _split_rows(done, None, "tetra"), "the tetrahedra of the cells")
        parent = Deferred((first_tet,), lambda: _split_rows(done, None, "parent"), "the cells of the tetrahedra")
        cells = cls(tetra, parent, n_cells, cell_types, nodes=tuple(b[1] for b in done) if nodes else ())
        object.__setattr__(cells, "_blocks", tuple(done))
        return cells

    @property
    def n_tetra(self) -> int:
        """Number of tetrahedra (without splitting the cells)."""
        return self.__dict__["_tetra"].shape[0]

    @property
    def split_done(self) -> bool:
        """Whether :attr:`tetra` is in memory."""
        return not isinstance(self.__dict__["_tetra"], Deferred)

    def rows(self, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(tetra[t], parent[t]) for tetrahedron indices ``t``, without splitting the other cells."""
        t = np.asarray(t, dtype=np.int64)
        if self._blocks is None or self.split_done:
            return self.tetra[t], self.parent[t]
        return _split_rows(self._blocks, t)

    def tetra_rows(self, cells: ArrayLike, first: bool = False) -> np.ndarray:
        """Indices of the tetrahedra of ``cells`` (sorted cell indices), in increasing order; ``first``:
        each cell's first tetrahedron only."""
        cells = np.asarray(cells, dtype=np.int64)
        if self._blocks is not None:
            out = []
            for pattern, conn, c0, t0 in self._blocks:
                mine = cells[(cells >= c0) & (cells < c0 + conn.shape[0])] - c0
                k = 1 if first else pattern.shape[0]
                out.append((t0 + mine[:, None] * pattern.shape[0] + np.arange(k)).ravel())
            return np.concatenate(out) if out else np.zeros(0, np.int64)
        parent = self.parent
        if first:
            if parent.size and np.all(parent[1:] >= parent[:-1]):
                return np.searchsorted(parent, cells)
            order = np.argsort(parent, kind="stable")
            return order[np.searchsorted(parent[order], cells)]
        return np.flatnonzero(np.isin(parent, cells))

    def with_materials(self, materials: ArrayLike | None) -> Cells:
        """These cells with ``materials`` (their tetrahedra split or not, as these are)."""
        cells = Cells(self.__dict__["_tetra"], self.__dict__["_parent"], self.n_cells, self.cell_types, materials,
                      self.nodes)
        object.__setattr__(cells, "_blocks", self._blocks)
        return cells

    def renumbered_nodes(self, new_index: np.ndarray) -> tuple[np.ndarray, ...]:
        """:attr:`nodes` with each point index ``i`` replaced by ``new_index[i]`` (points merged or left out);
        -1 (a node left out) stays -1."""
        return tuple(np.where(n >= 0, new_index[np.maximum(n, 0)], -1) for n in self.nodes)


def _frozen_int64(values: np.ndarray) -> np.ndarray:
    values = np.ascontiguousarray(values, dtype=np.int64)
    values.setflags(write=False)
    return values


def _split_rows(blocks: tuple, t, part: str = ""):
    """The tetrahedra of :meth:`Cells.split`'s blocks: every row (``t`` None) as ``part`` ("tetra": the
    tetrahedra, "parent": their cells), or (tetra, parent) of the rows ``t``."""
    if t is None:
        out = []
        for pattern, conn, c0, _ in blocks:
            if part == "tetra":
                # take along axis 1 of the flat pattern: C-ordered, so the reshape is a view (conn[:, pattern]
                # is laid out otherwise and the reshape copied it: 23 -> 8 ms for 108k hexahedra); int64 (what
                # Cells holds) before the take, on the connectivity, not after it on the larger tetrahedra
                out.append(np.take(conn.astype(np.int64, copy=False), pattern.ravel(), axis=1).reshape(-1, 4))
            else:
                out.append(np.repeat(np.arange(c0, c0 + conn.shape[0]), pattern.shape[0]))
        return out[0] if len(out) == 1 else np.concatenate(out)
    tetra, parent = np.zeros((t.size, 4), np.int64), np.zeros(t.size, np.int64)
    for pattern, conn, c0, t0 in blocks:
        k = pattern.shape[0]
        mine = np.flatnonzero((t >= t0) & (t < t0 + conn.shape[0] * k))
        cell, j = np.divmod(t[mine] - t0, k)
        tetra[mine] = conn[cell[:, None], pattern[j]]
        parent[mine] = c0 + cell
    return tetra, parent


@dataclass(frozen=True)
class NodeSides:
    """SED on each side of a material interface, at the nodes where materials meet.

    Discontinuous output (deal.II ``DataOut``, DG fields) gives each cell its own copy of a
    node; merging the copies (``afferent.io._coincident.merge_coincident``) keeps, besides
    their mean, the mean of the copies of each material at the nodes where several meet.

    Parameters
    ----------
    nodes : ndarray of shape (k,), int
        Node index (into the field's points) of each entry.
    materials : ndarray of shape (k,), int
        Material id of each entry.
    sed : ndarray of shape (n_times, k)
        SED in J/m^3: the mean of the node's copies in cells of that material (the element-node rule).
    """

    nodes: np.ndarray
    materials: np.ndarray
    sed: np.ndarray

    def __post_init__(self):
        for name, dtype in (("nodes", np.int64), ("materials", np.int64), ("sed", float)):
            arr = np.ascontiguousarray(getattr(self, name), dtype=dtype)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        k = self.nodes.shape[0]
        if self.materials.shape != (k,) or self.sed.ndim != 2 or self.sed.shape[1] != k:
            raise ValueError(f"'nodes' (k,), 'materials' (k,) and 'sed' (n_times, k) must agree; got shapes "
                             f"{self.nodes.shape}, {self.materials.shape}, {self.sed.shape} instead.")


@dataclass(frozen=True)
class SEDField:
    """Strain-energy density over an FE mesh, in SI units.

    Parameters
    ----------
    points : ndarray of shape (n_points, 3)
        Node (or sample-point) coordinates in m.
    sed : ndarray of shape (n_times, n_values)
        SED in J/m^3 (= Pa). ``n_values`` is ``n_points`` when ``location='point'`` and
        ``cells.n_cells`` when ``location='cell'``.
    times : ndarray of shape (n_times,)
        Time of each step in s, strictly increasing. A static export has ``times = [0.]``.
    location : {'point', 'cell'}
        Whether ``sed`` lives on the points or is one value per FE cell (element average
        or centroid value, as the export gave it).
    cells : Cells or None
        The mesh's volume cells; ``None`` for scattered points (a CSV without connectivity).
    provenance : Provenance
        Files, columns, units and conversions that produced the field.
    sides : NodeSides or None
        SED of each material at the nodes where materials meet, when the export held one copy
        of those nodes per cell (discontinuous output) and material ids; else None.

    Notes
    -----
    Arrays are made read-only: a field is an immutable value.
    """

    points: np.ndarray
    sed: np.ndarray
    times: np.ndarray
    location: Literal["point", "cell"] = "point"
    cells: Cells | None = None
    provenance: Provenance = field(default_factory=Provenance)
    sides: NodeSides | None = None

    def __post_init__(self):
        where = self.provenance.files[0] if len(self.provenance.files) == 1 else ""
        points = check_finite_array("points", self.points, ndim=2, shape_doc="(n_points, 3)", where=where)
        if points.shape[1] != 3:
            raise ValueError(f"'points' must be an array of shape (n_points, 3) in m; got shape {points.shape} instead.")
        sed = check_finite_array("sed", self.sed, ndim=2, shape_doc="(n_times, n_values)", where=where)
        times = check_finite_array("times", self.times, ndim=1, shape_doc="(n_times,)", where=where)
        if self.location not in ("point", "cell"):
            raise ValueError(f"'location' must be 'point' or 'cell'; got {self.location!r} instead.")
        if self.location == "cell" and self.cells is None:
            raise ValueError("A field with location='cell' needs its 'cells'; got cells=None instead.")
        n_values = points.shape[0] if self.location == "point" else self.cells.n_cells
        if sed.shape[1] != n_values:
            what = "n_points" if self.location == "point" else "n_cells"
            raise ValueError(
                f"'sed' must have one column per {what[2:-1]} ({what} = {n_values}); "
                f"got shape {sed.shape} instead."
            )
        if times.shape[0] != sed.shape[0]:
            raise ValueError(
                f"'times' must have one entry per SED row (n_times = {sed.shape[0]}); got shape {times.shape} instead."
            )
        if times.size > 1 and not np.all(np.diff(times) > 0):
            k = int(np.argmin(np.diff(times) > 0))
            raise ValueError(
                f"'times' must be strictly increasing; got {float(times[k])!r} s followed by {float(times[k + 1])!r} s "
                f"(steps {k} and {k + 1}) instead."
            )
        lowest, highest = self.cells.index_range if self.cells is not None else (0, -1)
        if highest >= points.shape[0]:
            raise ValueError(f"'cells' refer to point {highest} but the field has only {points.shape[0]} points.")
        if lowest < 0:
            raise ValueError(
                f"'cells' refer to point {lowest}; point indices must be >= 0 (a corrupt connectivity array?)."
            )
        for name, arr in (("points", points), ("sed", sed), ("times", times)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_points(self) -> int:
        """Number of points (nodes)."""
        return self.points.shape[0]

    @property
    def n_times(self) -> int:
        """Number of time steps."""
        return self.sed.shape[0]

    @property
    def bounds(self) -> np.ndarray:
        """Bounding box, ndarray of shape (2, 3): [[xmin, ymin, zmin], [xmax, ymax, zmax]] in m."""
        return np.stack([self.points.min(axis=0), self.points.max(axis=0)])

    def __repr__(self) -> str:
        lo, hi = self.bounds * 1e3
        cells = f"{self.cells.n_cells} cells" if self.cells is not None else "no cells"
        return (
            f"<SEDField: {self.n_points} points, {cells}, {self.n_times} time step(s) "
            f"[{self.times[0]:g}..{self.times[-1]:g}] s, SED on {self.location}s "
            f"in [{self.sed.min():.4g}, {self.sed.max():.4g}] J/m^3, "
            f"bounds x [{lo[0]:.4g}, {hi[0]:.4g}] y [{lo[1]:.4g}, {hi[1]:.4g}] z [{lo[2]:.4g}, {hi[2]:.4g}] mm, "
            f"sed_from={self.provenance.sed_from!r}>"
        )
