"""Mesh-based exports through meshio: VTU/VTK files, PVD collections, XDMF time series.

Each reader returns a :class:`~afferent.io._raw.RawExport` in the file's units. A ``.vtu`` is
read by :func:`afferent.io._vtu.read_vtu` (one parse, every piece, no block inflated beyond its
declared size), other formats by meshio's readers; the VTK-library path is :mod:`afferent.io._vtk`. For a time
series the mesh (points and cells) is decoded once; later steps decode only their points and
data arrays (a VTU series is checked to share the first step's points).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import warnings

import numpy as np

from ..exceptions import AfferentWarning, SEDFormatError
from ..field import Cells
from dataclasses import replace

from ._cell_blocks import (_complete_meshio_dimensions, _volume_blocks, _volume_rows, _vtu_version, cells_from_meshio,
                           volume_type_blocks)
from ._files import Scope, resolve_member
from ._raw import Deferred, RawArray, RawExport, check_export_file, files_read, stack_steps
from ._vtu import VtuCountError, read_vtu
from ._xml import parse_xml

__all__ = ["read_mesh_file", "read_vtu_series", "read_pvd", "read_xdmf", "cells_from_meshio"]

def _read_meshio(path: str, opened: list | None = None, scope: Scope | None = None, fmt: str | None = None):
    """(mesh, component names) of ``path``: a .vtu through :func:`afferent.io._vtu.read_vtu` (one
    parse, every piece), a legacy .vtk and a single-grid XDMF file through meshio's readers; the side
    files read are appended to ``opened`` (XDMF heavy data, resolved in ``scope``). The reader is the
    file name's (``fmt``, the declared format, for another ending); no other meshio reader is used
    (some follow include files, or HDF5 links, of their own)."""
    import meshio

    from ._xdmf import read_single_grid

    check_export_file(path)
    # The format's own reader, not meshio.read: its dispatcher prints and calls sys.exit on failure.
    ext = os.path.splitext(path)[1].lower()
    kind = {".vtu": "vtu", ".vtk": "vtk", ".xdmf": "xdmf", ".xmf": "xdmf"}.get(ext, fmt)
    if kind == "vtu":
        _check_vtk_xml_type(path)
        content = _guarded(path, read_vtu)
        return _VtuMesh(content.points, content.cells, content.point_data, content.cell_values), content.components
    if kind == "vtk":
        return _guarded(path, meshio.vtk.read), {}
    if kind == "xdmf":
        return _guarded(path, lambda p: read_single_grid(p, [] if opened is None else opened, scope)), {}
    raise SEDFormatError(f"SED file {path!r} is not a .vtu, .vtk, .pvtu, .vtm, .vtkhdf or .xdmf file, the files afferent reads "
                         "as the steps of a series; name each step by its format.")


class _VtuMesh:
    """What :func:`raw_from_mesh` reads of a VTU (:func:`afferent.io._vtu.read_vtu`), in place of a
    meshio.Mesh: points, cell blocks, point data, and each cell array over all the file's cells in
    the blocks' order (ndarrays, or :class:`~afferent.io._raw.Deferred` values, decoded when used)."""

    def __init__(self, points, cells, point_data, cell_values):
        self.points, self.cells, self.point_data, self.cell_values = points, cells, point_data, cell_values


def _one_step(path: str, values):
    """``values`` (n, ...) as one step, float64, shape (1, n, ...); a Deferred stays one, its decoding's
    failures one SEDFormatError naming ``path`` (as when read at once)."""
    if not isinstance(values, Deferred):
        return np.asarray(values, dtype=float)[None]
    return Deferred((1,) + values.shape, lambda: np.asarray(_guarded(path, lambda _: values.decode()), dtype=float)[None],
                    values.label)


def _guarded(path: str, read, *args):
    """``read(path, *args)`` with meshio's failures as one SEDFormatError naming ``path``, and what
    meshio prints on stderr (a corrupt array it skips) as one AfferentWarning."""
    import meshio

    ext = os.path.splitext(path)[1].lower()
    _complete_meshio_dimensions()
    said = io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stderr(said):
            warnings.simplefilter("ignore")  # meshio warns on skipped data; we report what we keep
            out = read(path, *args)
    except SEDFormatError:
        raise
    except meshio.ReadError as err:
        if not str(err).strip() or not _well_formed(path, ext):
            raise SEDFormatError(
                f"SED file {path!r} could not be read as {ext or 'a mesh'} (truncated or corrupt?): ReadError: {err}"
            ) from err
        # meshio parsed the file and met a layout it does not handle
        raise SEDFormatError(
            f"SED file {path!r} is a {ext or 'mesh'} file in a layout afferent cannot read (through meshio): "
            f"{str(err).rstrip('.')}. Save it as a VTU UnstructuredGrid (ParaView: File > Save Data > .vtu)."
        ) from err
    except (Exception, SystemExit) as err:  # ET.ParseError, ValueError, KeyError, zlib.error...
        kind = type(err).__name__
        raise SEDFormatError(
            f"SED file {path!r} could not be read as {os.path.splitext(path)[1] or 'a mesh'} "
            f"(truncated or corrupt?): {kind}: {err}"
        ) from err
    if said.getvalue().strip():  # meshio prints what it skips (a corrupt array) to stderr: one line of ours instead
        warnings.warn(f"SED file {path!r}: meshio: {' '.join(said.getvalue().split())}", AfferentWarning, stacklevel=4)
    return out


def _well_formed(path: str, ext: str) -> bool:
    """Whether an XML mesh file parses as XML to its end (a truncated file does not)."""
    if ext not in (".vtu", ".xdmf", ".xmf"):
        return True
    try:
        parse_xml(path, ext)
    except SEDFormatError:
        return False
    return True


#: VTK XML dataset types other than UnstructuredGrid, and what to do with them.
_VTK_XML_TYPES = {
    "PolyData": ("a surface (PolyData)", "export the volume mesh, or the surface points as a CSV table"),
    "StructuredGrid": ("a StructuredGrid", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "RectilinearGrid": ("a RectilinearGrid", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "ImageData": ("an ImageData volume", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "PUnstructuredGrid": ("a parallel index (.pvtu) listing its pieces", "name it .pvtu (read through VTK, the 'vtk' extra)"),
    "vtkMultiBlockDataSet": ("a multiblock index (.vtm) listing its blocks", "name it .vtm (read through VTK, the 'vtk' extra)"),
}


def _check_vtk_xml_type(path: str) -> None:
    """Refuse a .vtu whose VTKFile type is not UnstructuredGrid, saying what it is instead."""
    import re

    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return
    m = re.search(rb'<VTKFile[^>]*\btype="([^"]+)"', head)
    if m is None:
        return  # not XML or damaged: the reader says so
    kind = m.group(1).decode("ascii", "replace")
    if kind != "UnstructuredGrid":
        what, advice = _VTK_XML_TYPES.get(kind, (f"a VTK XML {kind!r} dataset", "save it as a VTU UnstructuredGrid"))
        raise SEDFormatError(
            f"SED file {path!r} holds {what}, not the UnstructuredGrid (volume mesh) afferent reads from a .vtu; {advice}."
        )
    version = _vtu_version(path)
    if version is not None and version[0] > 2:
        raise SEDFormatError(
            f"SED file {path!r} is a VTU of file version {'.'.join(map(str, version))}; afferent reads VTU versions "
            "0.1 to 2.x. Save it with an older VTK or ParaView, or as legacy VTK (.vtk).")


def _rows(values, rows: np.ndarray | None):
    """``values[rows]`` (all of ``values`` when ``rows`` is None), still deferred when ``values`` is."""
    if rows is None:
        return values
    return values.then(lambda v: v[rows], (len(rows),) + values.shape[1:]) if isinstance(values, Deferred) else values[rows]


def _volume_cell_data(mesh) -> dict:
    """Each numeric cell array of ``mesh`` over its volume cells (a meshio.Mesh: per block; a
    :class:`_VtuMesh`: rows of its arrays over all cells, still deferred)."""
    if isinstance(mesh, _VtuMesh):
        rows = _volume_rows(mesh.cells)
        return {name: _rows(v, rows) for name, v in mesh.cell_values.items()}
    out = {}
    for name, per_block in mesh.cell_data.items():
        try:
            out[name] = np.concatenate([np.asarray(per_block[k], dtype=float) for k, _, _ in _volume_blocks(mesh.cells)])
        except (TypeError, ValueError):
            continue  # non-numeric cell data
    return out


def _arrays_from_mesh(mesh, path: str, cells_obj: Cells | None, components: dict) -> dict[str, RawArray]:
    """The point arrays, and the cell arrays over the volume cells, of ``mesh`` as one-step RawArrays
    (with their ``components`` names where these name every component)."""
    arrays: dict[str, RawArray] = {}
    n_points = len(mesh.points)

    def raw(name, data, location):
        if not isinstance(data, Deferred) and np.ndim(data) > 1:  # meshio's legacy TENSORS (n, 3, 3) and SCALARS
            data = np.reshape(data, (len(data), -1))  # (n, 1): as VTK reads them, 9 components and (n,)
            data = data[:, 0] if data.shape[1] == 1 else data
        names = components.get(name, ())
        named = len(data.shape) == 2 and data.shape[1] == len(names)
        return RawArray(name, _one_step(path, data), location, None, names if named else ())

    for name, data in mesh.point_data.items():
        if data.shape[0] != n_points:
            raise SEDFormatError(
                f"SED file {path!r}: point array {name!r} must have one value per point ({n_points}); "
                f"got {data.shape[0]} instead."
            )
        arrays[name] = raw(name, data, "point")
    if cells_obj is not None:
        for name, data in _volume_cell_data(mesh).items():
            if data.shape[0] != cells_obj.n_cells:
                raise SEDFormatError(
                    f"SED file {path!r}: cell array {name!r} must have one value per volume cell "
                    f"({cells_obj.n_cells}); got {data.shape[0]} instead."
                )
            key = name if name not in arrays else f"{name}@cell"
            arrays[key] = raw(name, data, "cell")
    return arrays


def read_mesh_file(path: str, *, scope: Scope | None = None, fmt: str | None = None) -> RawExport:
    """A single VTU / VTK / single-grid XDMF file: one time step.

    ``.pvtu`` and ``.vtm`` files, and ``.vtk``/``.vtu`` files meshio cannot read, are read
    through VTK (:mod:`afferent.io._vtk`, the ``vtk`` extra); ``RawExport.reader`` says which.
    The files it points to (pieces, blocks, heavy data) are resolved in ``scope``
    (:func:`afferent.io._files.resolve_member`; default: inside the file's own folder). ``fmt``:
    the declared format of a file whose name does not tell.
    """
    import meshio

    ext = os.path.splitext(path)[1].lower()
    if fmt in ("pvtu", "vtm") and ext != f".{fmt}":  # VTK would pick its reader, and the files it opens, by itself
        raise SEDFormatError(f"SED file {path!r}: a {fmt} file is read by its name; name it .{fmt}.")
    if ext in (".pvtu", ".vtm"):
        from ._vtk import read_vtk_file

        return read_vtk_file(path, scope=scope)
    if ext == ".vtkhdf":  # a step of a series: one time step
        from ._vtkhdf import read_vtkhdf

        raw = read_vtkhdf(path, scope=scope)
        if raw.n_times > 1:
            raise SEDFormatError(f"SED file {path!r} holds {raw.n_times} time steps; as a step of a series it must hold "
                                 "one (name the file itself to read its steps).")
        return replace(raw, times=None)
    side: list[str] = []  # the files meshio opened besides path (an XDMF's HDF5 and .bin files)
    try:
        mesh, names = _read_meshio(path, side, scope, fmt)  # names: the arrays' ComponentName attributes (a .vtu's)
    except SEDFormatError as err:
        if isinstance(err, VtuCountError) or ext not in (".vtk", ".vtu") or not os.path.isfile(path) or os.path.getsize(path) == 0 or _not_unstructured(path):
            raise
        from ._vtk import read_vtk_file

        return read_vtk_file(path, meshio_error=err, scope=scope)
    return raw_from_mesh(mesh, path, ext.lstrip("."), names, [], reader=f"meshio {meshio.__version__}",
                         files=files_read([path], side))


def _not_unstructured(path: str) -> bool:
    """Whether a .vtu's own header says it is not an UnstructuredGrid (refused as such, not re-read by VTK)."""
    try:
        _check_vtk_xml_type(path)
    except SEDFormatError:
        return True
    return False


def raw_from_mesh(mesh, path: str, fmt: str, components: dict, notes: list, *, reader: str,
                  files: tuple[str, ...]) -> RawExport:
    """A meshio.Mesh (from meshio, or built from VTK's output) as a one-step RawExport.

    ``components`` maps array names to their component names (``XX YY ZZ XY YZ ZX``); ``files`` is
    every file read for it (:attr:`RawExport.files`).
    """
    mesh.cells = volume_type_blocks(mesh.cells, path)
    cells_obj = cells_from_meshio(mesh.cells, path)
    points = np.asarray(mesh.points, dtype=float)
    if points.ndim != 2 or points.shape[0] == 0:
        raise SEDFormatError(f"SED file {path!r} holds no points.")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    points.setflags(write=False)  # the coincident search remembers read-only coordinates without a digest
    notes = list(notes)
    if cells_obj is None:
        from meshio._mesh import topological_dimension

        flat = ", ".join(dict.fromkeys(b.type for b in mesh.cells if topological_dimension.get(b.type) == 2))
        notes.append("No volume cells in the file" + (f" (its cells: {flat}; a 2-D model?)" if flat else "")
                     + ": the points are treated as scattered samples.")
    arrays = _arrays_from_mesh(mesh, path, cells_obj, components)
    return RawExport(files=tuple(files), format=fmt, points=points, arrays=arrays, cells=cells_obj, notes=tuple(notes),
                     reader=reader)


def iter_vtu_series(paths: list[str], times=None, *, progress: bool = False, scope: Scope | None = None,
                    allow: bool = False):
    """Several VTU files, one per time step, on one mesh: yield one one-step RawExport per file.

    The first file is read whole (mesh and arrays); for the others only Points (to check that
    the mesh is the same) and the data arrays are decoded, and each step shares the first
    step's points and cells. Memory: one step at a time.

    Parameters
    ----------
    paths : list of str
        Files in time order.
    times : array_like of shape (n_files,), optional
        Step times (file units) when known (from a PVD); else None.
    progress : bool
        Show a progress bar (tqdm) over the files.
    scope : Scope, optional
        Where the files they point to may be (a ``.pvd``'s: its folder); default each file's own folder,
        outside it only if ``allow``.
    """
    from .._progress import progress_bar

    times = None if times is None else np.asarray(times, dtype=float)

    def where(path):
        return scope or Scope.of(path, allow)

    def read_step(path):
        return read_mesh_file(path, scope=where(path))
    if len(paths) > 1 and all(p.lower().endswith((".pvtu", ".vtm")) for p in (paths[0], paths[-1])):
        from ._vtk import read_vtk_file, series_merge_plan

        # one merge of the pieces' shared nodes for every step
        plan = series_merge_plan(paths[0], paths[-1], where(paths[0]), where(paths[-1]))

        def read_step(path):
            return read_vtk_file(path, plan=plan, scope=where(path)) if path.lower().endswith((".pvtu", ".vtm")) \
                else read_mesh_file(path, scope=where(path))
    first = read_step(paths[0])
    n_points = first.points.shape[0]
    n_cells = first.cells.n_cells if first.cells is not None else None
    volume_rows = None  # the volume cells' rows among all of a step's cells, found once when needed
    yield replace(first, times=None if times is None else times[:1])
    for k, path in enumerate(progress_bar(paths[1:], enabled=progress, desc="reading series", unit="file"), start=1):
        if not os.path.isfile(path):
            raise FileNotFoundError(f"SED file {path!r} not found.")
        if not path.lower().endswith(".vtu"):
            step = read_step(path)
            pd = {a.name: a.values[0] for a in step.arrays.values() if a.location == "point"}
            cd = {a.name: a.values[0] for a in step.arrays.values() if a.location == "cell"}
            pts, npts = step.points, step.points.shape[0]
        else:
            step = _guarded(path, read_vtu, ("Points", "PointData", "CellData"))  # no cells: the first step's
            pd, cd, pts, npts = step.point_data, step.cell_values, step.points, step.n_points
            if cd and n_cells is not None and step.n_cells != n_cells and paths[0].lower().endswith(".vtu"):
                if volume_rows is None:  # surface cells besides the volume: the first file's blocks say which rows
                    first_cells = _guarded(paths[0], read_vtu, ("Cells",)).cells
                    volume_rows = _volume_rows(volume_type_blocks(first_cells, paths[0]))
                cd = {name: _rows(v, volume_rows) for name, v in cd.items()}
        if npts != n_points or (pts is not None and not np.array_equal(np.asarray(pts, dtype=float), first.points)):
            raise SEDFormatError(
                f"SED file {path!r} is not on the same mesh as {paths[0]!r} "
                f"({npts} points vs {n_points}, or moved points); a series must share one mesh."
                + (" The nodes that pieces share are merged where their values agree at that step: a field continuous "
                   "across pieces at one step and not at another is merged differently (see each step's notes)."
                   if path.lower().endswith((".pvtu", ".vtm")) else "")
            )
        arrays = {}
        for key, arr in first.arrays.items():
            source = pd if arr.location == "point" else cd
            if arr.name not in source:
                raise SEDFormatError(
                    f"SED file {path!r} lacks the {arr.location} array {arr.name!r} that {paths[0]!r} has; "
                    "every step of a series must carry the same arrays."
                )
            values = source[arr.name]
            expected = n_points if arr.location == "point" else n_cells
            if values.shape[0] != expected:
                raise SEDFormatError(
                    f"SED file {path!r}: array {arr.name!r} must have {expected} values; got {values.shape[0]} instead."
                )
            if tuple(values.shape[1:]) != arr.shape[2:]:
                raise SEDFormatError(
                    f"SED file {path!r}: array {arr.name!r} has shape {tuple(values.shape[1:])} per value; "
                    f"{paths[0]!r} has {arr.shape[2:]}."
                )
            arrays[key] = replace(arr, values=_one_step(path, values))
        files = step.files if isinstance(step, RawExport) else (path,)  # a .pvtu's pieces, a .vtm's blocks
        yield replace(first, files=files, arrays=arrays, times=None if times is None else times[k:k + 1])


def read_vtu_series(paths: list[str], times=None, *, progress: bool = False, scope: Scope | None = None,
                    allow: bool = False) -> RawExport:
    """Several VTU files, one per time step, on one mesh; the mesh is decoded once.

    The steps of :func:`iter_vtu_series`, stacked (all in memory).
    """
    first_notes, files = [], []

    def steps():
        for k, step in enumerate(iter_vtu_series(paths, times, progress=progress, scope=scope, allow=allow)):
            if k == 0:
                first_notes.extend(step.notes)
            files.append(step.files)
            yield step

    raw = stack_steps(steps())
    return replace(raw, files=files_read(*files), format="vtu-series",
                       notes=tuple(first_notes) + (f"{len(paths)} steps read; mesh decoded once, from {paths[0]!r}.",))


def _series_entries(path: str) -> list[tuple[float | None, int, str]]:
    """(time or None, part, file) of a ParaView JSON file series (``{"files": [{"name", "time"}]}``)."""
    import json

    try:
        with open(path, encoding="utf-8") as fh:
            files = json.load(fh)["files"]
        if not isinstance(files, list) or not all(isinstance(f, dict) for f in files):
            raise TypeError("'files' must be a list of {name, time} objects")
    except (ValueError, KeyError, TypeError) as err:
        raise SEDFormatError(f"SED file {path!r} is not a ParaView file series (JSON with files: [{{name, time}}]): "
                             f"{type(err).__name__}: {err}") from err
    if not files:
        raise SEDFormatError(f"SED file {path!r} lists no files; expected a ParaView file series.")
    entries = []
    for k, f in enumerate(files):
        name, t = f.get("name"), f.get("time")
        if not isinstance(name, str):
            raise SEDFormatError(f"SED file {path!r}: entry {k} must have a file name (\"name\": a string); got "
                                 f"{name!r} instead.")
        try:  # a number, or a number written as a string (as some writers do); not true/false
            time = None if t is None else float(t) if not isinstance(t, bool) else math.nan
        except (TypeError, ValueError):
            time = math.nan
        if time is not None and not math.isfinite(time):
            raise SEDFormatError(f"SED file {path!r}: entry {k} ({name!r}) must have a finite number as its time; "
                                 f"got {t!r} instead.")
        entries.append((time, 0, name))
    return entries


def _pvd_xml_entries(path: str) -> list[tuple[float | None, int, str]]:
    """(timestep or None, part, file) of each ``<DataSet>`` of a .pvd."""
    root = parse_xml(path, ".pvd")
    datasets = root.findall(".//DataSet")
    if not datasets:
        raise SEDFormatError(f"SED file {path!r} lists no <DataSet> entries; expected a ParaView collection.")
    entries = []
    for k, ds in enumerate(datasets):
        if "file" not in ds.attrib:
            raise SEDFormatError(f"SED file {path!r}: DataSet {k} has no 'file' attribute.")
        try:
            t = float(ds.attrib["timestep"]) if "timestep" in ds.attrib else None
            if t is not None and not math.isfinite(t):
                raise ValueError("not finite")
        except ValueError as err:
            raise SEDFormatError(
                f"SED file {path!r}: DataSet {k} timestep must be a finite number; got {ds.attrib['timestep']!r} instead."
            ) from err
        try:
            part = int(ds.attrib.get("part", 0))
        except ValueError as err:
            raise SEDFormatError(
                f"SED file {path!r}: DataSet {k} part must be a whole number; got {ds.attrib['part']!r} instead."
            ) from err
        entries.append((t, part, ds.attrib["file"]))
    return entries


def pvd_entries(path: str, scope: Scope | None = None) -> tuple[list[str], list[float] | None]:
    """The files and times of a ParaView ``.pvd`` collection (``<DataSet timestep=... file=...>``) or
    JSON file series (``.vtu.series``, Kratos' ``.vtm.series``); times None when no entry states one,
    or every entry the same one (MFEM's ``ParaViewDataCollection`` writes ``timestep="0"`` at every
    step unless ``SetTime`` is called): the steps are then numbered, not given invented seconds. Each file
    is resolved in ``scope`` (:func:`afferent.io._files.resolve_member`: inside the collection's folder
    unless allowed; a regular file)."""
    check_export_file(path)
    raw = _series_entries(path) if path.lower().endswith(".series") else _pvd_xml_entries(path)
    scope = scope or Scope.of(path)
    entries = [(t, part, resolve_member(path, f, what=f"the step file (entry {k})", scope=scope, must_exist=False))
               for k, (t, part, f) in enumerate(raw)]
    from ._vtk import missing_members

    missing_members(path, [e[2] for e in entries], "step")  # every entry checked before any is read
    if len({e[1] for e in entries}) > 1:
        raise SEDFormatError(f"SED file {path!r} has several parts per time step; afferent reads single-part series.")
    stated = [e[0] is not None for e in entries]
    if any(stated) and not all(stated):
        k = stated.index(False)
        raise SEDFormatError(f"SED file {path!r}: entry {k} states no time while others do; state a time for every entry.")
    if not all(stated):
        return [e[2] for e in entries], None
    times = [e[0] for e in entries]
    if len(times) > 1 and len(set(times)) == 1:  # MFEM's ParaViewDataCollection without SetTime: 0 at every step
        return [e[2] for e in entries], None
    if any(b <= a for a, b in zip(times, times[1:])):
        k = next(i for i, (a, b) in enumerate(zip(times, times[1:])) if b <= a)
        raise SEDFormatError(
            f"SED file {path!r}: timesteps must be strictly increasing; got {times[k]!r} followed by "
            f"{times[k + 1]!r} ({'entries' if path.lower().endswith('.series') else 'DataSets'} {k} and {k + 1}) instead."
        )
    return [e[2] for e in entries], times


def iter_pvd(path: str, *, progress: bool = False, scope: Scope | None = None):
    """A ParaView ``.pvd`` collection, one one-step RawExport at a time (see :func:`iter_vtu_series`); its files
    resolved in ``scope`` (default: its own folder)."""
    scope = scope or Scope.of(path)
    files, times = pvd_entries(path, scope)
    for step in iter_vtu_series(files, times, progress=progress, scope=scope):
        yield replace(step, format="pvd", files=(path,) + step.files)


def read_pvd(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """A ParaView ``.pvd`` collection, every step in memory, sorted by time; its files resolved in ``scope``."""
    scope = scope or Scope.of(path)
    files, times = pvd_entries(path, scope)
    raw = read_vtu_series(files, times, progress=progress, scope=scope)
    return replace(raw, files=(path,) + raw.files, format="pvd")


def read_xdmf(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """An XDMF file: grid collections over time (FEniCS/DOLFINx ``write_function``, meshio time
    series) through :mod:`afferent.io._xdmf`; a single grid through meshio. Its heavy data are
    resolved in ``scope`` (default: inside its own folder)."""
    from ._xdmf import has_collections, read_xdmf_collections

    check_export_file(path)
    if has_collections(path):
        return read_xdmf_collections(path, progress=progress, scope=scope)
    raw = read_mesh_file(path, scope=scope)
    return RawExport(raw.files, "xdmf", raw.points, raw.arrays, None, raw.cells, notes=raw.notes, reader=raw.reader)
