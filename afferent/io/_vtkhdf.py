"""VTKHDF files (``.vtkhdf``, ``.hdf``): the HDF5 format VTK 9.2+ and ParaView save natively, read with h5py.

A VTKHDF file holds one group ``/VTKHDF`` with the attributes ``Type`` and ``Version``. An
``UnstructuredGrid`` stores, for each part (piece) of each time step, its counts
(``NumberOfPoints``, ``NumberOfCells``, ``NumberOfConnectivityIds``: one row per part), and end to end
the ``Points`` (n, 3), ``Types`` (VTK cell type ids), ``Offsets`` (n_cells + 1 per part, from 0) and
``Connectivity`` (point numbers local to the part), and the arrays under ``PointData`` and
``CellData`` (n, components). Time steps (VTKHDF 2.0+) add the group ``Steps``: ``Values`` (the
times), ``PartOffsets`` and ``NumberOfParts`` (the parts of each step), ``PointOffsets``,
``CellOffsets`` and ``ConnectivityIdOffsets`` (where a step's mesh starts: equal offsets share one
mesh) and ``PointDataOffsets/<name>``, ``CellDataOffsets/<name>`` (where each array's values of a step
start). afferent reads every step, every part (each part's points numbered after the previous
part's), every point array and the cell arrays over the volume cells (surface cells are ignored,
as in a ``.vtu``). Every step must be on the first step's mesh (VTK's writer writes the mesh again at
each step of a temporal source: same values, checked).

Only the ``UnstructuredGrid`` type is read: a ``PolyData`` is a surface, an ``ImageData`` a voxel
volume, a ``MultiBlockDataSet``/``PartitionedDataSetCollection`` a composite, each refused with what
to save instead. VTK's writer with ``UseExternalTimeSteps`` stores the values in other files through
HDF5 virtual datasets; those, like external links and external raw storage, pass the one resolver
(:mod:`afferent.io._files`: inside the export's folder unless ``allow_outside_files``) before
anything is read, and are listed in the files read. No unit is stored: the user declares them.
This reader needs h5py only (a dependency); VTK's own ``vtkHDFReader`` (the ``vtk`` extra) reads
the same values (tests/test_vtkhdf.py compares every array).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import SEDFormatError
from ._files import Scope, h5_open, h5_read
from ._raw import RawArray, RawExport, check_export_file, files_read

__all__ = ["read_vtkhdf"]

#: The other VTKHDF types, what they are and what to save instead.
_OTHER_TYPES = {
    "PolyData": "a surface (PolyData); export the volume mesh",
    "ImageData": "an ImageData volume; in ParaView apply 'Clean to Grid' and save it as .vtkhdf or .vtu",
    "OverlappingAMR": "an AMR dataset; in ParaView apply 'Clean to Grid' and save it as .vtkhdf or .vtu",
    "HyperTreeGrid": "a HyperTreeGrid; in ParaView apply 'Clean to Grid' and save it as .vtkhdf or .vtu",
    "MultiBlockDataSet": "a composite (MultiBlockDataSet); in ParaView apply 'Merge Blocks' and save it as .vtkhdf",
    "PartitionedDataSetCollection": ("a composite (PartitionedDataSetCollection); in ParaView apply 'Merge Blocks' "
                                     "and save it as .vtkhdf"),
}


class _File:
    """An open VTKHDF file's ``/VTKHDF`` group, every dataset read through :func:`afferent.io._files.h5_read`."""

    def __init__(self, path: str, scope: Scope):
        self.path, self.scope, self.opened, self._cache = path, scope, [], {}
        try:
            self.h5 = h5_open(path, scope, self.opened)
        except OSError as err:
            raise SEDFormatError(f"SED file {path!r} could not be read as VTKHDF (HDF5; truncated or corrupt?): "
                                 f"{err}") from err
        self.root = self.h5.get("VTKHDF")
        if self.root is None:
            names = sorted(self.h5)[:8]
            self.h5.close()
            raise SEDFormatError(f"SED file {path!r} is HDF5 without a '/VTKHDF' group: not a VTKHDF file "
                                 f"(its top-level names: {names}).")

    def has(self, name: str) -> bool:
        return name in self.root

    def get(self, name: str, size: int | None = None) -> np.ndarray:
        """The values of dataset ``name`` under ``/VTKHDF`` (read once), at most ``size`` values."""
        from ._raw import h5_check

        if name not in self._cache:
            if name not in self.root:
                raise SEDFormatError(f"SED file {self.path!r}: the VTKHDF dataset {name!r} is missing.")
            label = f"SED file {self.path!r}: VTKHDF dataset {name!r}"
            try:
                self._cache[name] = np.asarray(h5_read(self.root, name, self.scope, self.opened,
                                                       check=lambda d: h5_check(d, label, size)))
            except SEDFormatError:
                raise
            except Exception as err:  # h5py's OSError/KeyError/TypeError on damaged data
                raise SEDFormatError(f"{label} could not be read (truncated or corrupt?): {type(err).__name__}: "
                                     f"{err}") from err
        return self._cache[name]

    def attr(self, name: str):
        value = self.root.attrs.get(name)
        if isinstance(value, (bytes, np.bytes_)):
            return value.decode("utf-8", "replace")
        return value


def _check_type(f: _File) -> None:
    kind, version = f.attr("Type"), f.attr("Version")
    if kind != "UnstructuredGrid":
        what = _OTHER_TYPES.get(str(kind), f"of type {kind!r}; save it as a VTKHDF UnstructuredGrid")
        raise SEDFormatError(f"SED file {f.path!r} is a VTKHDF file holding {what}; afferent reads the "
                             "UnstructuredGrid type (a volume mesh).")
    major = int(np.ravel(version)[0]) if version is not None and np.size(version) else None
    if major is None or major > 2:
        raise SEDFormatError(f"SED file {f.path!r}: VTKHDF version {np.ravel(version).tolist() if version is not None else None} "
                             "is not one afferent reads (1.x and 2.x, as VTK 9.2 to 9.7 write).")


def _step_table(f: _File) -> tuple[np.ndarray | None, dict]:
    """(times or None, {offset name: per-step starts}) of the ``Steps`` group; one step at 0 without it."""
    n_parts_total = f.get("NumberOfPoints").size
    if not f.has("Steps"):
        zero = np.zeros(1, dtype=np.int64)
        return None, {"PartOffsets": zero, "NumberOfParts": np.array([n_parts_total]), "PointOffsets": zero,
                      "CellOffsets": zero, "ConnectivityIdOffsets": zero}
    times = np.asarray(f.get("Steps/Values"), dtype=float).ravel()
    n = times.size
    table = {}
    for name in ("PartOffsets", "NumberOfParts", "PointOffsets", "CellOffsets", "ConnectivityIdOffsets"):
        v = np.asarray(f.get(f"Steps/{name}"), dtype=np.int64)
        v = v[:, 0] if v.ndim == 2 else v.ravel()  # PolyData's (steps, 4 cell kinds); an UnstructuredGrid's (steps,)
        if v.size < n:
            raise SEDFormatError(f"SED file {f.path!r}: VTKHDF dataset 'Steps/{name}' must have one value per time "
                                 f"step ({n}); got {v.size} instead.")
        table[name] = v[:n]
    return times, table


def _mesh(f: _File, table: dict, k: int):
    """(points (n, 3), connectivity, end offsets, types) of step ``k``, its parts joined."""
    parts = range(int(table["PartOffsets"][k]), int(table["PartOffsets"][k] + table["NumberOfParts"][k]))
    n_pts, n_cells, n_ids = (np.asarray(f.get(name), dtype=np.int64).ravel()
                             for name in ("NumberOfPoints", "NumberOfCells", "NumberOfConnectivityIds"))
    if parts.stop > min(n_pts.size, n_cells.size, n_ids.size):
        raise SEDFormatError(f"SED file {f.path!r}: step {k} names parts {parts.start} to {parts.stop - 1}, but the file "
                             f"counts {n_pts.size} parts.")
    p0, c0, i0 = (int(table[key][k]) for key in ("PointOffsets", "CellOffsets", "ConnectivityIdOffsets"))
    o0 = c0 + parts.start  # each part stores n_cells + 1 offsets
    pts, conn, offs, types = [], [], [], []
    base_pts = ids_end = 0
    for j in parts:
        a, b = p0 + base_pts, p0 + base_pts + int(n_pts[j])
        pts.append(f.get("Points")[a:b])
        o = f.get("Offsets")[o0:o0 + int(n_cells[j]) + 1].astype(np.int64)
        c = f.get("Connectivity")[i0:i0 + int(n_ids[j])].astype(np.int64)
        t = f.get("Types")[c0:c0 + int(n_cells[j])]
        if o.size != n_cells[j] + 1 or c.size != n_ids[j] or t.size != n_cells[j] or len(pts[-1]) != n_pts[j] or (
                o.size and (o[0] != 0 or o[-1] != c.size or np.any(np.diff(o) < 0))) or (
                c.size and (c.min() < 0 or c.max() >= n_pts[j])):
            raise SEDFormatError(f"SED file {f.path!r}: part {j} (step {k}) is inconsistent: its counts ({n_pts[j]} "
                                 f"points, {n_cells[j]} cells, {n_ids[j]} connectivity ids) do not match its Points, "
                                 "Offsets, Connectivity and Types (truncated or corrupt?).")
        conn.append(c + sum(len(p) for p in pts[:-1]))
        offs.append(o[1:] + ids_end)
        types.append(t)
        base_pts += int(n_pts[j])
        ids_end += c.size
        o0 += int(n_cells[j]) + 1
        c0 += int(n_cells[j])
        i0 += int(n_ids[j])
    points = np.concatenate(pts).astype(float) if pts else np.zeros((0, 3))
    return points, np.concatenate(conn), np.concatenate(offs), np.concatenate(types).astype(np.uint8)


def _arrays(f: _File, table: dict, k: int, counts: tuple[int, int]) -> dict[str, np.ndarray]:
    """``{(location, name): values}`` of step ``k`` (``counts``: the step's points and cells)."""
    out = {}
    for group, location, n in (("PointData", "point", counts[0]), ("CellData", "cell", counts[1])):
        if not f.has(group):
            continue
        for name in f.root[group]:
            offsets = f"Steps/{group}Offsets/{name}"
            start = int(np.ravel(f.get(offsets))[k]) if f.has("Steps") and f.has(offsets) else 0
            values = f.get(f"{group}/{name}")
            if values.dtype.kind not in "fiub":
                continue  # strings: not numbers
            step = values[start:start + n]
            if step.shape[0] != n:
                raise SEDFormatError(f"SED file {f.path!r}: {location} array {name!r} must have {n} values at step {k} "
                                     f"(from row {start}); got {step.shape[0]} instead.")
            out[(location, name)] = step.astype(float)
    return out


def read_vtkhdf(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """Read a VTKHDF ``UnstructuredGrid``: every part, every time step, every point and cell array.

    Parameters
    ----------
    path : str
        A ``.vtkhdf`` (or ``.hdf``) file.
    progress : bool
        Unused (read in one pass); accepted for a uniform reader signature.
    scope : Scope, optional
        Where the files its HDF5 external links, external storage and virtual datasets lead to may be;
        default inside its own folder.

    Returns
    -------
    RawExport
        Points (the model's length unit), volume cells, arrays (n_times, n, ...), times (``Steps/Values``,
        the model's time unit) or None for a file without steps.

    Raises
    ------
    SEDFormatError
        Not VTKHDF, a type other than UnstructuredGrid, inconsistent counts, steps on different meshes,
        a file outside the export's folder (not allowed).
    """
    from meshio._vtk_common import vtk_cells_from_data

    from ._cell_blocks import _volume_rows, cells_from_meshio, volume_type_blocks

    check_export_file(path)
    scope = scope or Scope.of(path)
    f = _File(path, scope)
    try:
        _check_type(f)
        version = ".".join(map(str, np.ravel(f.attr("Version")).tolist()))
        times, table = _step_table(f)
        points, conn, offs, types = _mesh(f, table, 0)
        try:
            blocks = volume_type_blocks(vtk_cells_from_data(conn, offs, types, {})[0], path)
        except SEDFormatError:
            raise
        except Exception as err:  # meshio's ReadError on an unknown layout
            raise SEDFormatError(f"SED file {path!r}: its cells could not be read: {type(err).__name__}: {err}") from err
        cells, rows = cells_from_meshio(blocks, path), _volume_rows(blocks)
        steps = []
        for k in range(1 if times is None else times.size):
            if k and any(table[key][k] != table[key][0] for key in ("PointOffsets", "CellOffsets",
                                                                    "ConnectivityIdOffsets", "PartOffsets")):
                same = _mesh(f, table, k)
                if not all(np.array_equal(a, b) for a, b in zip(same, (points, conn, offs, types))):
                    raise SEDFormatError(f"SED file {path!r}: time step {k} (t = {times[k]:g}) is on another mesh than "
                                         "step 0; afferent reads a series on one mesh.")
            steps.append(_arrays(f, table, k, (len(points), len(types))))
    finally:
        f.h5.close()
    arrays: dict[str, RawArray] = {}
    for (location, name) in steps[0]:
        values = np.stack([s[(location, name)] for s in steps])
        if location == "cell":
            if cells is None:
                continue
            values = values if rows is None else values[:, rows]
        key = name if location == "point" or name not in arrays else f"{name}@cell"
        arrays[key] = RawArray(name, values, location)
    notes = [f"VTKHDF {version} UnstructuredGrid: "
             f"{len(steps)} time step(s), {int(table['NumberOfParts'][0])} part(s) a step."]
    if cells is None:
        notes.append("No volume cells in the file: the points are treated as scattered samples.")
    if times is not None and times.size > 1 and np.any(np.diff(times) <= 0):
        k = int(np.flatnonzero(np.diff(times) <= 0)[0])
        raise SEDFormatError(f"SED file {path!r}: Steps/Values must increase; got {times[k]!r} then {times[k + 1]!r} "
                             f"(steps {k} and {k + 1}).")
    points.setflags(write=False)
    return RawExport(files=files_read([path], f.opened), format="vtkhdf", points=points, arrays=arrays, times=times,
                     cells=cells, notes=tuple(notes), reader="afferent (h5py)")
