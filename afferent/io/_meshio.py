"""Mesh-based exports through meshio: VTU/VTK files, PVD collections, XDMF time series.

Each reader returns a :class:`~afferent.io._raw.RawExport` in the file's units. For a time
series the mesh (points and cells) is decoded once; later steps decode only their data
arrays (a VTU series is checked to share the first step's points).
"""

from __future__ import annotations

import os
import re
import warnings
from xml.etree import ElementTree as ET

import numpy as np

from ..exceptions import SEDFormatError
from ..field import Cells
from dataclasses import replace

from ._raw import RawArray, RawExport, stack_steps

__all__ = ["read_mesh_file", "read_vtu_series", "read_pvd", "read_xdmf", "cells_from_meshio"]

# Corner nodes of each volume cell type, then its split into linear tetrahedra (VTK node order).
_TETS = {
    "tetra": [(0, 1, 2, 3)],
    "hexahedron": [(0, 6, 1, 2), (0, 6, 2, 3), (0, 6, 3, 7), (0, 6, 7, 4), (0, 6, 4, 5), (0, 6, 5, 1)],
    "wedge": [(0, 1, 2, 3), (1, 2, 3, 4), (2, 3, 4, 5)],
    "pyramid": [(0, 1, 2, 4), (0, 2, 3, 4)],
}
_HIGHER = {
    "tetra10": "tetra", "tetra14": "tetra", "hexahedron20": "hexahedron", "hexahedron24": "hexahedron",
    "hexahedron27": "hexahedron", "wedge15": "wedge", "wedge18": "wedge", "pyramid13": "pyramid",
    "pyramid14": "pyramid",
}


def _volume_blocks(cells) -> list[tuple[int, str, np.ndarray]]:
    out = []
    for k, block in enumerate(cells):
        base = _HIGHER.get(block.type, block.type)
        if base in _TETS:
            out.append((k, block.type, np.asarray(block.data)))
    return out


def cells_from_meshio(cells) -> Cells | None:
    """Split meshio volume cell blocks into linear tetrahedra; None when the mesh has no volume cells.

    Quadratic cells use their corner nodes (the field is then interpolated linearly between
    corners). Surface and line blocks are ignored.
    """
    blocks = _volume_blocks(cells)
    if not blocks:
        return None
    tets, parents, offset = [], [], 0
    for _, ctype, conn in blocks:
        pattern = np.asarray(_TETS[_HIGHER.get(ctype, ctype)])
        n = conn.shape[0]
        tets.append(conn[:, pattern].reshape(-1, 4))
        parents.append(np.repeat(np.arange(offset, offset + n), len(pattern)))
        offset += n
    return Cells(np.concatenate(tets), np.concatenate(parents), offset, tuple(b[1] for b in blocks))


def _read_meshio(path: str):
    import meshio

    if not os.path.isfile(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    if os.path.getsize(path) == 0:
        raise SEDFormatError(f"SED file {path!r} is empty.")
    # The format's own reader, not meshio.read: its dispatcher prints and calls sys.exit on failure.
    ext = os.path.splitext(path)[1].lower()
    reader = {".vtu": meshio.vtu.read, ".vtk": meshio.vtk.read, ".xdmf": meshio.xdmf.read, ".xmf": meshio.xdmf.read}.get(
        ext, meshio.read
    )
    if ext == ".vtu":
        _check_vtk_xml_type(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # meshio warns on skipped data; we report what we keep
            return reader(path)
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


def _well_formed(path: str, ext: str) -> bool:
    """Whether an XML mesh file parses as XML to its end (a truncated file does not)."""
    if ext not in (".vtu", ".xdmf", ".xmf"):
        return True
    try:
        ET.parse(path)
    except ET.ParseError:
        return False
    return True


#: VTK XML dataset types other than UnstructuredGrid, and what to do with them.
_VTK_XML_TYPES = {
    "PolyData": ("a surface (PolyData)", "export the volume mesh, or the surface points as a CSV table"),
    "StructuredGrid": ("a StructuredGrid", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "RectilinearGrid": ("a RectilinearGrid", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "ImageData": ("an ImageData volume", "in ParaView apply 'Clean to Grid' and save as .vtu"),
    "PUnstructuredGrid": ("a parallel index (.pvtu) listing its pieces", "in ParaView apply 'Merge Blocks' and save as .vtu"),
    "vtkMultiBlockDataSet": ("a multiblock index (.vtm) listing its blocks", "in ParaView apply 'Merge Blocks' and save as .vtu"),
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


def _arrays_from_mesh(mesh, path: str, cells_obj: Cells | None) -> dict[str, RawArray]:
    arrays: dict[str, RawArray] = {}
    n_points = len(mesh.points)
    for name, data in mesh.point_data.items():
        data = np.asarray(data, dtype=float)
        if data.shape[0] != n_points:
            raise SEDFormatError(
                f"SED file {path!r}: point array {name!r} must have one value per point ({n_points}); "
                f"got {data.shape[0]} instead."
            )
        arrays[name] = RawArray(name, data[None], "point")
    if cells_obj is not None:
        vol = [k for k, _, _ in _volume_blocks(mesh.cells)]
        for name, per_block in mesh.cell_data.items():
            try:
                parts = [np.asarray(per_block[k], dtype=float) for k in vol]
            except (TypeError, ValueError):
                continue  # non-numeric cell data
            data = np.concatenate(parts)
            if data.shape[0] != cells_obj.n_cells:
                raise SEDFormatError(
                    f"SED file {path!r}: cell array {name!r} must have one value per volume cell "
                    f"({cells_obj.n_cells}); got {data.shape[0]} instead."
                )
            key = name if name not in arrays else f"{name}@cell"
            arrays[key] = RawArray(name, data[None], "cell")
    return arrays


def read_mesh_file(path: str) -> RawExport:
    """A single VTU / VTK (or any meshio-readable) file: one time step."""
    mesh = _read_meshio(path)
    cells_obj = cells_from_meshio(mesh.cells)
    points = np.asarray(mesh.points, dtype=float)
    if points.ndim != 2 or points.shape[0] == 0:
        raise SEDFormatError(f"SED file {path!r} holds no points.")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    notes = []
    if cells_obj is None:
        notes.append("No volume cells in the file: the points are treated as scattered samples.")
    arrays = _arrays_from_mesh(mesh, path, cells_obj)
    if path.lower().endswith(".vtu"):  # meshio drops the arrays' ComponentName attributes: keep them
        names = _vtu_component_names(path)
        arrays = {k: (RawArray(a.name, a.values, a.location, a.unit, names[a.name])
                      if a.name in names and a.values.ndim == 3 and a.values.shape[2] == len(names[a.name]) else a)
                  for k, a in arrays.items()}
    return RawExport(
        files=(path,), format=os.path.splitext(path)[1].lstrip(".").lower(), points=points,
        arrays=arrays, cells=cells_obj, notes=tuple(notes),
    )


_DATA_ARRAY = re.compile(rb"<DataArray\b[^>]*>")
_ATTR = re.compile(rb'\b(\w+)="([^"]*)"')  # \b: linear on a long run of letters


def _vtu_component_names(path: str) -> dict[str, tuple[str, ...]]:
    """``{array name: (ComponentName0, ...)}`` from a VTU's DataArray tags (ccx2paraview writes
    ``XX YY ZZ XY YZ ZX`` for S and E); arrays without names are left out."""
    with open(path, "rb") as fh:
        text = fh.read()
    end = text.find(b"<AppendedData")
    out = {}
    for tag in _DATA_ARRAY.findall(text if end < 0 else text[:end]):
        attrs = {k.decode(): v.decode("utf-8", "replace") for k, v in _ATTR.findall(tag)}
        comps = [attrs[f"ComponentName{i}"] for i in range(int(attrs.get("NumberOfComponents", "1") or 1))
                 if f"ComponentName{i}" in attrs]
        if "Name" in attrs and comps and len(comps) == int(attrs.get("NumberOfComponents", "0") or 0):
            out[attrs["Name"]] = tuple(comps)
    return out


class _VtuDataReader:
    """Decode only the data arrays of a VTU file, with meshio's own decoder.

    meshio re-reads points and connectivity for every file of a series; for step 2..N of a
    series we parse the XML and decode only Points (to check the mesh is the same) and the
    PointData / CellData arrays.
    """

    def __init__(self, path: str):
        from meshio.vtu import _vtu

        self.path = path
        try:
            try:
                root = ET.parse(path).getroot()
            except ET.ParseError:
                root = _vtu._parse_raw_binary(path)
            reader = _vtu.VtuReader.__new__(_vtu.VtuReader)
            reader.compression = root.attrib.get("compressor")
            reader.header_type = root.attrib.get("header_type", "UInt32")
            reader.byte_order = root.attrib.get("byte_order")
            grid, reader.appended_data = _vtu.get_grid(root)
            pieces = [c for c in grid if c.tag == "Piece"]
            if len(pieces) != 1:
                raise SEDFormatError(f"SED file {path!r}: expected one Piece in a series step; got {len(pieces)}.")
            piece = pieces[0]
            self.n_points = int(piece.attrib["NumberOfPoints"])
            self.n_cells = int(piece.attrib["NumberOfCells"])
            self.points = None
            self.point_data, self.cell_data = {}, {}
            for child in piece:
                if child.tag == "Points":
                    self.points = reader.read_data(child[0]).reshape(self.n_points, -1)
                elif child.tag == "PointData":
                    self.point_data = {c.attrib["Name"]: reader.read_data(c) for c in child}
                elif child.tag == "CellData":
                    self.cell_data = {c.attrib["Name"]: reader.read_data(c) for c in child}
        except SEDFormatError:
            raise
        except Exception as err:
            raise SEDFormatError(
                f"SED file {path!r} could not be read as .vtu (truncated or corrupt?): {type(err).__name__}: {err}"
            ) from err


def iter_vtu_series(paths: list[str], times=None, *, progress: bool = False):
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
    """
    from .._progress import progress_bar

    times = None if times is None else np.asarray(times, dtype=float)
    first = read_mesh_file(paths[0])
    n_points = first.points.shape[0]
    n_cells = first.cells.n_cells if first.cells is not None else None
    yield replace(first, times=None if times is None else times[:1])
    for k, path in enumerate(progress_bar(paths[1:], enabled=progress, desc="reading series", unit="file"), start=1):
        if not os.path.isfile(path):
            raise FileNotFoundError(f"SED file {path!r} not found.")
        if not path.lower().endswith(".vtu"):
            step = read_mesh_file(path)
            pd = {a.name: a.values[0] for a in step.arrays.values() if a.location == "point"}
            cd = {a.name: a.values[0] for a in step.arrays.values() if a.location == "cell"}
            pts, npts = step.points, step.points.shape[0]
        else:
            step = _VtuDataReader(path)
            pd, cd, pts, npts = step.point_data, step.cell_data, step.points, step.n_points
        if npts != n_points or (pts is not None and not np.array_equal(np.asarray(pts, dtype=float), first.points)):
            raise SEDFormatError(
                f"SED file {path!r} is not on the same mesh as {paths[0]!r} "
                f"({npts} points vs {n_points}, or moved points); a series must share one mesh."
            )
        arrays = {}
        for key, arr in first.arrays.items():
            source = pd if arr.location == "point" else cd
            if arr.name not in source:
                raise SEDFormatError(
                    f"SED file {path!r} lacks the {arr.location} array {arr.name!r} that {paths[0]!r} has; "
                    "every step of a series must carry the same arrays."
                )
            values = np.asarray(source[arr.name], dtype=float)
            expected = n_points if arr.location == "point" else n_cells
            if values.shape[0] != expected:
                raise SEDFormatError(
                    f"SED file {path!r}: array {arr.name!r} must have {expected} values; got {values.shape[0]} instead."
                )
            if values.shape[1:] != arr.values.shape[2:]:
                raise SEDFormatError(
                    f"SED file {path!r}: array {arr.name!r} has shape {values.shape[1:]} per value; "
                    f"{paths[0]!r} has {arr.values.shape[2:]}."
                )
            arrays[key] = replace(arr, values=values[None])
        yield replace(first, files=(path,), arrays=arrays, times=None if times is None else times[k:k + 1])


def read_vtu_series(paths: list[str], times=None, *, progress: bool = False) -> RawExport:
    """Several VTU files, one per time step, on one mesh; the mesh is decoded once.

    The steps of :func:`iter_vtu_series`, stacked (all in memory).
    """
    first_notes = []

    def steps():
        for k, step in enumerate(iter_vtu_series(paths, times, progress=progress)):
            if k == 0:
                first_notes.extend(step.notes)
            yield step

    raw = stack_steps(steps())
    return replace(raw, files=tuple(paths), format="vtu-series",
                       notes=tuple(first_notes) + (f"{len(paths)} steps read; mesh decoded once, from {paths[0]!r}.",))


def pvd_entries(path: str) -> tuple[list[str], list[float]]:
    """The files and times of a ParaView ``.pvd`` collection (``<DataSet timestep=... file=...>``)."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as err:
        raise SEDFormatError(f"SED file {path!r} is not a valid .pvd (XML) file: {err}") from err
    datasets = root.findall(".//DataSet")
    if not datasets:
        raise SEDFormatError(f"SED file {path!r} lists no <DataSet> entries; expected a ParaView collection.")
    folder = os.path.dirname(path)
    entries = []
    for k, ds in enumerate(datasets):
        if "file" not in ds.attrib:
            raise SEDFormatError(f"SED file {path!r}: DataSet {k} has no 'file' attribute.")
        try:
            t = float(ds.attrib.get("timestep", k))
        except ValueError as err:
            raise SEDFormatError(
                f"SED file {path!r}: DataSet {k} timestep must be a number; got {ds.attrib['timestep']!r} instead."
            ) from err
        try:
            part = int(ds.attrib.get("part", 0))
        except ValueError as err:
            raise SEDFormatError(
                f"SED file {path!r}: DataSet {k} part must be a whole number; got {ds.attrib['part']!r} instead."
            ) from err
        entries.append((t, part, os.path.join(folder, ds.attrib["file"])))
    if len({e[1] for e in entries}) > 1:
        raise SEDFormatError(f"SED file {path!r} has several parts per time step; afferent reads single-part series.")
    times = [e[0] for e in entries]
    if any(b <= a for a, b in zip(times, times[1:])):
        k = next(i for i, (a, b) in enumerate(zip(times, times[1:])) if b <= a)
        raise SEDFormatError(
            f"SED file {path!r}: timesteps must be strictly increasing; got {times[k]!r} followed by "
            f"{times[k + 1]!r} (DataSets {k} and {k + 1}) instead."
        )
    return [e[2] for e in entries], times


def iter_pvd(path: str, *, progress: bool = False):
    """A ParaView ``.pvd`` collection, one one-step RawExport at a time (see :func:`iter_vtu_series`)."""
    files, times = pvd_entries(path)
    for step in iter_vtu_series(files, times, progress=progress):
        yield replace(step, format="pvd", files=(path,) + step.files)


def read_pvd(path: str, *, progress: bool = False) -> RawExport:
    """A ParaView ``.pvd`` collection, every step in memory, sorted by time."""
    files, times = pvd_entries(path)
    raw = read_vtu_series(files, times, progress=progress)
    return replace(raw, files=(path,) + raw.files, format="pvd")


def read_xdmf(path: str, *, progress: bool = False) -> RawExport:
    """An XDMF file: grid collections over time (FEniCS/DOLFINx ``write_function``, meshio time
    series) through :mod:`afferent.io._xdmf`; a single grid through meshio."""
    from ._xdmf import has_collections, read_xdmf_collections

    if not os.path.isfile(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    if os.path.getsize(path) == 0:
        raise SEDFormatError(f"SED file {path!r} is empty.")
    if has_collections(path):
        return read_xdmf_collections(path, progress=progress)
    raw = read_mesh_file(path)
    return RawExport(raw.files, "xdmf", raw.points, raw.arrays, None, raw.cells, notes=raw.notes)
