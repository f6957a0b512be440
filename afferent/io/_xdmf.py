"""XDMF files with time series: FEniCS/DOLFINx ``write_function`` output, meshio time series.

``XDMFFile.write_mesh`` + ``write_function`` (DOLFINx, legacy FEniCS) write one uniform grid
for the mesh and, per function, a temporal collection of grids, one per time, each pointing at
the mesh grid's topology and geometry (``xi:include``) and holding one attribute. meshio's
reader refuses such a file ("only supports one grid"); this reader parses the XML itself and
reads the heavy data from HDF5 with h5py (or inline XML numbers):

- every collection's grids are grouped by their ``Time``: grids with the same time are one
  step, so several functions written at each time come out side by side;
- attributes are point data (``Center="Node"``) or cell data (``Center="Cell"``); ``Tensor``
  attributes are the 9 components of a 3x3 tensor, row-major (DOLFINx writes ``sym(grad(u))``
  as such: tensor shear);
- the mesh (topology, geometry) is read once.

A file with a single grid and no collection is interpreted by meshio (:mod:`afferent.io._meshio`),
its heavy data read here (:func:`read_single_grid`). Heavy data are HDF5 datasets (``file.h5:/path``,
relative to the XDMF file; external links followed), raw ``Format="Binary"`` files (relative to the
XDMF file; meshio names them relative to the folder it ran in, so a name not found there is looked
for by its last part beside the XDMF file) or inline numbers; every file read is listed in
:attr:`~afferent.io._raw.RawExport.files`. Each heavy-data file, the targets of its HDF5 external
links and the files its datasets are stored in pass :func:`afferent.io._files.resolve_member` before
they are opened: inside the folder of the export named, unless the user allows files outside
(``allow_outside_files``), and regular files only. ``xi:include`` is followed within the XDMF file
only (DOLFINx's ``xpointer`` to the mesh grid).

Size: just over 600 lines once every heavy-data read passed the resolver and the size checks
(issue 33): the grid walk and :class:`_Heavy` share the file's state; the heavy-data reader is the
part to move out when it grows again.
"""

from __future__ import annotations

import math
import os
import re
from types import SimpleNamespace
from xml.etree import ElementTree as ET

import numpy as np

from ..exceptions import SEDFormatError
from ._files import Scope, h5_open, h5_read, resolve_member
from ._raw import RawArray, RawExport, files_read
from ._xml import parse_xml

__all__ = ["read_xdmf_collections", "has_collections", "read_single_grid", "heavy_files"]

#: xi:include, under the 2001 namespace (DOLFINx) or the 2003 one (meshio's time series writer).
_XI_TAGS = ("{http://www.w3.org/2001/XInclude}include", "{http://www.w3.org/2003/XInclude}include")
def _parse(path: str) -> ET.Element:
    return parse_xml(path, "XDMF")


def _counts(text: str | None, what: str, path: str) -> tuple[int, ...]:
    """The whole numbers of an XDMF attribute (``Dimensions="32 8"``, ``NumberOfElements="32"``)."""
    words = (text or "").split()
    if not all(re.fullmatch("[0-9]+", w) for w in words):  # not str.isdigit: '²' is a digit int() refuses
        shown = text if len(text) <= 40 else text[:40] + "..."
        raise SEDFormatError(f"SED file {path!r}: {what} must be whole numbers separated by spaces; got {shown!r} instead.")
    return tuple(int(w) for w in words)


def has_collections(path: str | ET.Element) -> bool:
    """Whether an XDMF file (its path, or its parsed root) holds grid collections (a time series) rather than a
    single grid."""
    root = path if isinstance(path, ET.Element) else _parse(path)
    return any(g.get("GridType") == "Collection" for g in root.iter("Grid"))


def series_steps(path: str, *, progress: bool = False, scope: Scope | None = None):
    """(number of time steps, :func:`iter_xdmf_collections` iterator) for an XDMF file with grid collections,
    else None; the XML is parsed once for the three."""
    root = _parse(path)
    if not has_collections(root):
        return None
    return step_count(root), iter_xdmf_collections(path, progress=progress, root=root, scope=scope)


def _read_whole(h5, dataset: str, check) -> np.ndarray | None:
    """A hard-linked dataset of ``h5`` read whole by one ``H5Dread`` into a new array, or None.

    Only a contiguous dataset whose storage is allocated in the file itself (HDF5 gives its
    offset: every value is read from it, none left unwritten) holding integers or reals in a
    simple dataspace is read so; anything else (chunked, filtered or compact storage, external
    raw files, virtual datasets, unallocated storage, scalar dataspaces, enums and other types)
    returns None for h5py's own read. The same bytes as ``h5[dataset][()]``, without building
    h5py's ``Dataset`` object and without the zero-filled buffer h5py reads into: a step of
    300,763 float64 values in 0.5 ms instead of 0.7 ms (docs/performance.md, "Series streaming").
    ``check(shape)`` is called before anything is allocated or read.
    """
    from h5py import h5d, h5s

    dsid = h5d.open(h5.id, dataset.encode())
    if dsid.get_offset() is None:  # HADDR_UNDEF: not contiguous, not allocated, or in external raw files
        return None
    space, dtype = dsid.get_space(), dsid.dtype
    if space.get_simple_extent_type() != h5s.SIMPLE or dtype.kind not in "iuf" or dtype.metadata:
        return None
    check(space.shape)
    data = np.empty(space.shape, dtype)
    dsid.read(h5s.ALL, h5s.ALL, data)
    return data


class _Heavy:
    """Reads DataItems: HDF5 datasets (one open file per .h5), raw binary files or inline XML numbers.

    ``opened`` lists every file read so far (HDF5 files, the targets of their external links,
    ``.bin`` files), in the order first opened: the side files of :attr:`RawExport.files`. Each
    is resolved in ``scope`` first (:mod:`afferent.io._files`).
    """

    def __init__(self, path: str, scope: Scope | None = None):
        self.path, self.folder, self.files, self.opened = path, os.path.dirname(path), {}, []
        self.scope, self._seen = scope or Scope.of(path), set()
        self.plain_groups: dict = {}  # (h5 file, group path) whose path holds no external link -> its hard links

    def _note(self, *paths) -> None:
        """Add files read to :attr:`opened`, each once (the first spelling kept: HDF5 names a link's target absolute)."""
        for p in paths:
            full = os.path.abspath(p)
            if full not in self._seen:
                self._seen.add(full)
                self.opened.append(p)

    def read(self, item: ET.Element | None, what: str, rows: tuple | None = None) -> np.ndarray:
        """A DataItem's values, shaped by its Dimensions. ``rows``: (count, 'point' or 'cell') when the
        mesh says how many rows the values must have: another count is refused before any reading
        (from the Dimensions, else from the HDF5 dataset's shape)."""
        if item is None:  # a Topology, Geometry or Attribute without its <DataItem>
            raise SEDFormatError(f"SED file {self.path!r}: {what} has no <DataItem> holding its values.")
        fmt = item.get("Format", "XML").upper()
        dims = _counts(item.get("Dimensions"), f"the Dimensions of {what}", self.path) or None
        text = (item.text or "").strip()
        if rows is not None and dims is not None:
            self.check_rows(what, rows, dims[0])
        if fmt == "HDF":
            data = self._hdf(text, what, dims, rows)
        elif fmt == "BINARY":
            data = self._binary(item, text, what, -1 if dims is None else math.prod(dims))
        elif fmt == "XML":
            try:
                data = np.array(text.split(), dtype=float)
            except ValueError as err:
                raise SEDFormatError(f"SED file {self.path!r}: the inline numbers of {what} are not numbers: {err}") from err
        else:
            raise SEDFormatError(f"SED file {self.path!r}: {what} is stored as Format={fmt!r}; afferent reads HDF, "
                                 "Binary and XML DataItems.")
        if dims is not None:
            self.check_size(what, dims, data.size)
            data = data.reshape(dims)
        return data

    def check_size(self, what: str, dims: tuple, size: int) -> None:
        """Refuse ``size`` values where the Dimensions ``dims`` say how many."""
        if math.prod(dims) != size:
            raise SEDFormatError(f"SED file {self.path!r}: {what} must hold {' x '.join(map(str, dims))} values "
                                 f"(its Dimensions); got {size} instead.")

    def check_rows(self, what: str, rows: tuple, got: int) -> None:
        """Refuse ``got`` rows where the mesh has ``rows[0]`` points or cells (``rows[1]``)."""
        if got != rows[0]:
            raise SEDFormatError(f"SED file {self.path!r}: {what} must have one row per {rows[1]} ({rows[0]}); "
                                 f"got {got}.")

    def _hdf(self, text: str, what: str, dims: tuple | None = None, rows: tuple | None = None) -> np.ndarray:
        """``file.h5:/dataset`` (the file relative to the XDMF file's folder), its shape checked against
        ``dims`` and ``rows`` (:meth:`read`) and against what its file stores (:func:`~afferent.io._raw.h5_check`)
        before it is read."""
        from ._raw import h5_check

        def check(shape):
            if dims is not None:
                self.check_size(what, dims, math.prod(shape))
            elif rows is not None and shape:
                self.check_rows(what, rows, shape[0])

        if ":" not in text:
            raise SEDFormatError(f"SED file {self.path!r}: the HDF DataItem of {what} must read 'file.h5:/path'; "
                                 f"got {text!r} instead.")
        dataset = text.split(":", 1)[1]
        h5path = _hdf_file(self.folder, text)
        if h5path not in self.files:
            resolve_member(self.path, text.split(":", 1)[0], what=f"the heavy-data file of {what}", scope=self.scope,
                           must_exist=False)
            if not os.path.isfile(h5path):
                raise SEDFormatError(f"SED file {self.path!r}: the heavy-data file {h5path!r} of {what} is missing "
                                     "(keep the .h5 beside the .xdmf).")
            try:
                linked: list[str] = []
                self.files[h5path] = h5_open(h5path, self.scope, linked)
            except OSError as err:
                raise SEDFormatError(f"SED file {self.path!r}: the heavy-data file {h5path!r} could not be opened "
                                     f"(truncated or corrupt?): {err}") from err
            self._note(h5path, *linked)
        h5 = self.files[h5path]
        head, _, leaf = dataset.rstrip("/").rpartition("/")
        group = (h5path, head)
        plain = leaf in self.plain_groups.get(group, ())
        if not plain:
            self._follow(h5, h5path, dataset, what, group)
        # else a hard link of a group whose path was followed before: nothing new to find or note (a series' steps)
        try:
            data = _read_whole(h5, dataset, check) if plain else None
            if data is None:
                if plain:  # not contiguous in the file itself: its storage may name files of its own (external raw, virtual)
                    self._follow(h5, h5path, dataset, what, group)
                stored: list[str] = []
                label = f"SED file {self.path!r}: {what} ({h5path!r}, dataset {dataset!r})"
                data = np.asarray(h5_read(h5, dataset, self.scope, stored,
                                          check=lambda d: (check(d.shape or ()), h5_check(d, label))))
                self._note(*(h5path if f == h5.filename else f for f in stored))
        except OSError as err:
            raise SEDFormatError(f"SED file {self.path!r}: dataset {dataset!r} of {what} in {h5path!r} could not "
                                 f"be read (truncated?): {err}") from err
        if data.dtype.kind not in "biuf":  # complex (a PETSc complex build), text, compound: not one real per value
            kind = "complex" if data.dtype.kind == "c" else "non-numeric"
            raise SEDFormatError(f"SED file {self.path!r}: dataset {dataset!r} of {what} in {h5path!r} holds "
                                 f"{kind} values ({data.dtype}); afferent reads real numbers (write the real part).")
        return data

    def _follow(self, h5, h5path: str, dataset: str, what: str, group: tuple) -> None:
        """Check that ``dataset`` is in the open file ``h5`` and note every file its path opens (external links)."""
        from ._raw import h5_files

        try:
            files = h5_files(h5, dataset) if dataset in h5 else None
        except (OSError, KeyError):  # an external link to an object its target file does not hold
            files = None
        if files is None:
            raise SEDFormatError(f"SED file {self.path!r}: dataset {dataset!r} of {what} is not in {h5path!r} (or "
                                 "an external link on its path points to a missing file).")
        try:
            files = h5_files(h5, dataset)
        except (OSError, KeyError) as err:  # a link's target not HDF5, its object missing, a link back to itself
            raise SEDFormatError(f"SED file {self.path!r}: dataset {dataset!r} of {what} in {h5path!r} could not be "
                                 f"reached: {_link_failure(err)}") from err
        self._note(*(h5path if f == h5.filename else f for f in files))
        if files == [h5.filename] and dataset.startswith("/") and group not in self.plain_groups:
            self.plain_groups[group] = self._hard_links(h5, group[1] or "/")  # no external link on the way

    @staticmethod
    def _hard_links(h5, group: str) -> frozenset:
        """The names of the hard links of a group of the open file (objects in it), listed once by HDF5's link
        iteration: a series' later datasets in that group need no search of their own (a link check per step
        cost ~0.02 ms of a 0.6 ms step amid the reads)."""
        import h5py

        hard = []
        try:
            h5.id.links.iterate(lambda name, info: hard.append(name.decode()) if info.type == h5py.h5l.TYPE_HARD else None,
                                obj_name=group.encode(), info=True)
        except (RuntimeError, SystemError, OSError, KeyError, ValueError, UnicodeDecodeError):  # a damaged group: none
            return frozenset()  # known, each dataset is then looked up (and its damage reported) on its own
        return frozenset(hard)

    def _binary(self, item: ET.Element, text: str, what: str, count: int) -> np.ndarray:
        """A raw binary file (XDMF ``Format="Binary"``, :func:`_binary_file`)."""
        from meshio.xdmf.common import xdmf_to_numpy_type

        binpath = resolve_member(self.path, _binary_name(self.folder, text), what=f"the binary data file of {what}",
                                 scope=self.scope, must_exist=False)
        if not os.path.isfile(binpath):
            raise SEDFormatError(f"SED file {self.path!r}: the binary data file {text!r} of {what} is missing "
                                 f"(looked for {os.path.join(self.folder, text)!r}).")
        kind = (item.get("DataType") or item.get("NumberType") or "Float", item.get("Precision", "4"))
        if kind not in xdmf_to_numpy_type:
            raise SEDFormatError(f"SED file {self.path!r}: {what} has DataType/Precision {kind!r}, not one XDMF defines.")
        if (item.get("Compression") or "Raw").lower() != "raw":
            raise SEDFormatError(f"SED file {self.path!r}: {what} is compressed ({item.get('Compression')!r}); "
                                 "afferent reads Raw binary data.")
        endian = {"big": ">", "little": "<"}.get((item.get("Endian") or "Native").lower(), "=")
        dtype = np.dtype(xdmf_to_numpy_type[kind]).newbyteorder(endian)
        seek = item.get("Seek", "0").strip()
        if not re.fullmatch("[0-9]+", seek):
            raise SEDFormatError(f"SED file {self.path!r}: the Seek of {what} must be a byte offset, a whole number "
                                 f">= 0; got {seek[:40]!r} instead.")
        seek = int(seek)
        self._note(binpath)
        with open(binpath, "rb") as f:
            held = max(0, os.fstat(f.fileno()).st_size - seek)  # bytes from Seek to the end
            if count > held // dtype.itemsize:  # checked before numpy allocates the count asked for
                raise SEDFormatError(f"SED file {self.path!r}: {what} must hold {count} values of {dtype.itemsize} "
                                     f"byte(s) (its Dimensions) from byte {seek} of {binpath!r}; the file holds "
                                     f"{held} byte(s) from there.")
            f.seek(seek)
            return np.fromfile(f, dtype=dtype, count=count).astype(dtype.newbyteorder("="))

    def close(self):
        for f in self.files.values():
            f.close()


def _link_failure(err: Exception) -> str:
    """What h5py's error on following an external link means, in words (its own text kept)."""
    text = str(err.args[0] if isinstance(err, KeyError) and err.args else err)
    for clue, meaning in (("file signature not found", "an external link on its path points to a file that is not HDF5"),
                          ("too many links", "an external link on its path leads back to itself"),
                          ("doesn't exist", "an external link on its path points to an object its file does not hold")):
        if clue in text:
            return f"{meaning} ({text})."
    return f"an external link on its path cannot be followed ({text})."


def _hdf_file(folder: str, text: str) -> str:
    """The HDF5 file of an HDF DataItem's ``file.h5:/dataset``: relative to ``folder``, the XDMF file's."""
    return os.path.join(folder, text.split(":", 1)[0])


def _binary_name(folder: str, text: str) -> str:
    """The name of the file of a Binary DataItem, relative to ``folder`` (the XDMF file's) as XDMF defines it.

    meshio writes the name relative to the folder it ran in (``sub/bin0.bin`` for ``sub/bin.xdmf``,
    an absolute name for an absolute path); when no file of that name exists, the name's last part
    beside the XDMF file is taken if it exists there. Never the working folder.
    """
    if not os.path.lexists(os.path.join(folder, text)) and os.path.isfile(os.path.join(folder, os.path.basename(text))):
        return os.path.basename(text)
    return text


def _binary_file(folder: str, text: str) -> str:
    """The file of a Binary DataItem (:func:`_binary_name`)."""
    return os.path.join(folder, _binary_name(folder, text))


def heavy_files(path: str) -> list[str]:
    """The heavy-data files an XDMF file's DataItems name (HDF5 files, ``Format="Binary"`` files), each once, in
    file order, from its XML alone: nothing opened but the XDMF file (the targets of HDF5 external links are
    not listed). For sizing a read before it starts (:func:`afferent.io.data_files`); the files a read opens
    are recorded as it opens them (:class:`_Heavy`)."""
    folder, out = os.path.dirname(path), []
    for item in _parse(path).iter("DataItem"):
        fmt, text = item.get("Format", "XML").upper(), (item.text or "").strip()
        if fmt == "HDF" and ":" in text:
            out.append(_hdf_file(folder, text))
        elif fmt == "BINARY" and text:
            out.append(_binary_file(folder, text))
    return list(dict.fromkeys(out))


def read_single_grid(path: str, opened: list, scope: Scope | None = None):
    """A single-grid XDMF file through meshio's XDMF reader, its HDF and Binary DataItems read here.

    meshio interprets the grid (topology, geometry, attributes); the heavy data go through
    :class:`_Heavy`, so that every file read (HDF5 files, external-link targets, ``.bin``
    files) is resolved in ``scope`` and appended to ``opened``.

    Returns
    -------
    meshio.Mesh
    """
    from meshio.xdmf.main import XdmfReader

    heavy = _Heavy(path, scope)

    class _Reader(XdmfReader):
        def _read_data_item(self, data_item, root=None):
            if "Reference" not in data_item.attrib and data_item.get("Format", "XML").upper() in ("HDF", "BINARY"):
                return heavy.read(data_item, f"the data item {(data_item.text or '').strip()!r}")
            return super()._read_data_item(data_item, root)

    try:
        return _Reader(path).read()
    finally:
        opened.extend(heavy.opened)
        heavy.close()


def _uniform_grids(domain: ET.Element) -> list:
    """The uniform grids of the domain that hold a Topology and a Geometry (the meshes), in file order."""
    return [g for g in domain.iter("Grid") if g.get("GridType", "Uniform") == "Uniform"
            and g.find("Topology") is not None and g.find("Geometry") is not None]


def _mesh_grid(uniform: list, grid: ET.Element) -> ET.Element:
    """The grid whose Topology/Geometry a grid uses: its own, or the one of ``uniform`` (:func:`_uniform_grids`)
    its xi:include names."""
    if grid.find("Topology") is not None and grid.find("Geometry") is not None:
        return grid
    inc = next((c for c in grid if c.tag in _XI_TAGS), None)
    if inc is not None:
        m = re.search(r"@Name\s*=\s*[\"']([^\"']+)[\"']", inc.get("xpointer", ""))
        if m:
            named = [g for g in uniform if g.get("Name") == m.group(1)]
            if named:
                return named[0]
    if not uniform:
        raise SEDFormatError("no grid with a Topology and a Geometry")
    return uniform[0]


def step_count(path: str | ET.Element) -> int:
    """Number of distinct times in the temporal grid collections of an XDMF file (its path, or its parsed root)."""
    root = path if isinstance(path, ET.Element) else _parse(path)
    times = {t.get("Value") for coll in root.iter("Grid") if coll.get("GridType") == "Collection"
             for grid in coll.findall("Grid") for t in grid.findall("Time")}
    return len(times)


def _temporal_leaves(domain: ET.Element, path: str) -> list:
    """(time, grid) of every uniform grid inside a temporal collection, in file order."""
    leaves = []
    for coll in domain.iter("Grid"):
        if coll.get("GridType") != "Collection":
            continue
        if coll.get("CollectionType", "Temporal") != "Temporal":
            raise SEDFormatError(f"SED file {path!r}: grid collection {coll.get('Name')!r} is "
                                 f"{coll.get('CollectionType')!r}; afferent reads temporal collections.")
        for k, grid in enumerate(coll.findall("Grid")):
            t = grid.find("Time")
            if t is None or t.get("Value") is None:
                raise SEDFormatError(f"SED file {path!r}: grid {k} of collection {coll.get('Name')!r} has no <Time>.")
            try:
                leaves.append((float(t.get("Value")), grid))
            except ValueError:
                raise SEDFormatError(f"SED file {path!r}: grid {k} of collection {coll.get('Name')!r} has the time "
                                     f"{t.get('Value')!r}, not a number.") from None
    if not leaves:
        raise SEDFormatError(f"SED file {path!r} has no grid inside a temporal collection.")
    return leaves


def _one_mesh(domain: ET.Element, leaves: list, path: str) -> ET.Element:
    """The grid holding the mesh every leaf uses; more than one mesh is refused."""
    try:
        uniform = _uniform_grids(domain)  # once: searched again for every leaf, a series of N steps cost N^2
        meshes = {id(m): m for m in (_mesh_grid(uniform, g) for _, g in leaves)}
    except SEDFormatError as err:
        raise SEDFormatError(f"SED file {path!r}: {err}.") from None
    if len(meshes) > 1:
        raise SEDFormatError(f"SED file {path!r}: its grids use {len(meshes)} different meshes; afferent reads "
                             "functions on one mesh.")
    return next(iter(meshes.values()))


def _mesh_points(heavy, mesh: ET.Element, path: str) -> np.ndarray:
    """The mesh's points (n, 3) in the file's length unit; XY geometry padded with z = 0."""
    geo = mesh.find("Geometry")
    points = heavy.read(geo.find("DataItem"), f"the geometry of grid {mesh.get('Name')!r}").astype(float)
    gtype = geo.get("GeometryType", "XYZ").upper()
    if gtype not in ("XYZ", "XY"):
        raise SEDFormatError(f"SED file {path!r}: GeometryType {gtype!r} is not supported (XYZ or XY).")
    points = points.reshape(-1, 3 if gtype == "XYZ" else 2)
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    return points


def _mesh_cells(heavy, mesh: ET.Element, n_points: int, path: str, notes: list):
    """The mesh's volume cells (or None, noted), from its topology through meshio's XDMF tables."""
    from ._meshio import cells_from_meshio

    # XDMF topology names and mixed-cell codes as meshio defines them (meshio.xdmf.common)
    from meshio.xdmf.common import translate_mixed_cells, xdmf_to_meshio_type

    topo = mesh.find("Topology")
    ttype = topo.get("TopologyType") or topo.get("Type") or ""
    names = {k.lower(): v for k, v in xdmf_to_meshio_type.items()}
    conn = heavy.read(topo.find("DataItem"), f"the topology of grid {mesh.get('Name')!r}").astype(np.int64)
    if ttype.lower() == "mixed":
        try:
            blocks = translate_mixed_cells(conn.ravel())
        except Exception as err:  # an unknown cell code or a short array
            raise SEDFormatError(f"SED file {path!r}: the mixed topology of grid {mesh.get('Name')!r} could not be "
                                 f"decoded: {type(err).__name__}: {err}") from err
    elif ttype.lower() in names:
        blocks = [SimpleNamespace(type=names[ttype.lower()], data=_uniform_cells(conn, names[ttype.lower()], topo, path))]
    else:
        raise SEDFormatError(f"SED file {path!r}: TopologyType {ttype!r} is not an XDMF topology afferent knows.")
    for b in blocks:
        data = np.asarray(b.data)
        if data.size and (data.min() < 0 or data.max() >= n_points):
            bad = int(data.min()) if data.min() < 0 else int(data.max())
            raise SEDFormatError(f"SED file {path!r}: the topology refers to point {bad}, but the geometry has "
                                 f"{n_points} points (numbered from 0).")
    cells = cells_from_meshio(blocks, path)
    if cells is None:
        notes.append(f"topology {ttype!r} has no volume cells: the points are treated as scattered samples.")
    return cells


def _uniform_cells(conn: np.ndarray, ctype: str, topo: ET.Element, path: str) -> np.ndarray:
    """A uniform topology's connectivity as (n_cells, nodes per cell), checked against its cell type."""
    from meshio._common import num_nodes_per_cell

    counts = _counts(topo.get("NumberOfElements"), "the topology's NumberOfElements", path)
    n_cells = counts[0] if len(counts) == 1 else conn.shape[0]
    per_cell = num_nodes_per_cell.get(ctype)
    if per_cell is None or n_cells * per_cell != conn.size:
        raise SEDFormatError(f"SED file {path!r}: a {ctype!r} topology of {n_cells} cells must hold {n_cells} x "
                             f"{per_cell} node numbers; got {conn.size} instead.")
    return conn.reshape(n_cells, per_cell)


def _step_attributes(heavy, grids: list, t: float, n_points: int, cells, first_names, path: str, bar) -> dict:
    """The attributes of every grid at time ``t``: name -> RawArray (1, n[, n_components])."""
    n_cells = cells.n_cells if cells is not None else 0
    found: dict[str, RawArray] = {}
    for grid in grids:
        bar.update(1)
        for att in grid.findall("Attribute"):
            name = att.get("Name") or "unnamed"
            center = (att.get("Center") or "Node").lower()
            if center not in ("node", "cell"):
                raise SEDFormatError(f"SED file {path!r}: attribute {name!r} has Center={att.get('Center')!r}; "
                                     "afferent reads Node and Cell data.")
            location = "point" if center == "node" else "cell"
            if location == "cell" and cells is None:
                continue  # no volume cells: cell data unused, not read
            rows = (n_points if location == "point" else n_cells, location)
            what = f"attribute {name!r} at t = {t:g}"
            data = heavy.read(att.find("DataItem"), what, rows).astype(float, copy=False)  # float64 in the file: no copy
            data = data.reshape(data.shape[0], -1) if data.ndim > 1 else data.reshape(-1, 1)
            heavy.check_rows(what, rows, data.shape[0])
            if (first_names or {}).get(name, location) != location or name in found and found[name].location != location:
                raise SEDFormatError(f"SED file {path!r}: attribute {name!r} is point data at one time and cell "
                                     "data at another.")
            values = data[:, 0] if data.shape[1] == 1 else data
            found[name] = RawArray(name, values[None], location)
    return found


def _check_same_functions(found: dict, t: float, times: list, first_names: dict, first_shapes: dict, path: str) -> None:
    """Every step holds the functions of the first, with as many components."""
    names = {name: a.location for name, a in found.items()}
    missing = sorted(set(first_names) - set(names)) or sorted(set(names) - set(first_names))
    if missing:
        at = t if set(first_names) - set(names) else times[0]
        raise SEDFormatError(f"SED file {path!r}: function {missing[0]!r} has no value at t = {at:g}, a time "
                             "the other functions have; write every function at every time.")
    for name, a in found.items():
        if a.values.shape[2:] != first_shapes[name]:
            raise SEDFormatError(f"SED file {path!r}: function {name!r} has {a.values.shape[2:] or 1} "
                                 f"component(s) at t = {t:g} but {first_shapes[name] or 1} at t = {times[0]:g}.")


def iter_xdmf_collections(path: str, *, progress: bool = False, root: ET.Element | None = None,
                          scope: Scope | None = None):
    """Read an XDMF file made of grid collections (one or several functions over time), one time
    step at a time: the mesh is read once, then each step's attributes (memory: one step).

    Parameters
    ----------
    path : str
        The ``.xdmf``/``.xmf`` file; its ``.h5`` heavy-data file(s) beside it.
    progress : bool
        Show a progress bar over the grids.
    root : xml.etree.ElementTree.Element, optional
        The file's XML already parsed (:func:`series_steps`), else parsed here.
    scope : Scope, optional
        Where the heavy-data files may be (:mod:`afferent.io._files`); default inside the file's folder.

    Yields
    ------
    RawExport
        One per time step, in time order: points (file length unit), volume cells (shared by
        every step), one array per attribute name (point or cell data; (1, n[, n_components])),
        the step's time.

    Raises
    ------
    SEDFormatError
        Invalid XML, a missing .h5 or dataset, sizes that do not match the mesh, grids on
        different meshes, a function missing at a time the others have.
    """
    from .._progress import progress_bar

    root = _parse(path) if root is None else root
    domain = root.find("Domain")
    if domain is None:
        raise SEDFormatError(f"SED file {path!r} has no <Domain>: not an XDMF file?")
    heavy = _Heavy(path, scope)
    try:
        leaves = _temporal_leaves(domain, path)
        mesh = _one_mesh(domain, leaves, path)
        points = _mesh_points(heavy, mesh, path)
        notes = []
        cells = _mesh_cells(heavy, mesh, len(points), path, notes)
        times = sorted({t for t, _ in leaves})
        by_time: dict[float, list] = {t: [] for t in times}
        for t, grid in leaves:
            by_time[t].append(grid)
        n_grids = len({id(g) for _, g in leaves})
        first_names: dict[str, str] | None = None
        first_shapes: dict[str, tuple] = {}
        bar = progress_bar(total=len(leaves), enabled=progress, desc="reading xdmf", unit="grid")
        files, n_opened = (), -1  # heavy.opened only grows: the files' tuple is rebuilt when it does
        for t in times:
            found = _step_attributes(heavy, by_time[t], t, len(points), cells, first_names, path, bar)
            if first_names is None:
                first_names = {name: a.location for name, a in found.items()}
                first_shapes = {name: a.values.shape[2:] for name, a in found.items()}
                notes.insert(0, f"XDMF with {n_grids} grids in temporal collections: {len(times)} time step(s), "
                                f"functions {', '.join(found) or 'none'}; mesh read once.")
            else:
                _check_same_functions(found, t, times, first_names, first_shapes, path)
            if len(heavy.opened) != n_opened:
                files, n_opened = files_read([path], heavy.opened), len(heavy.opened)
            yield RawExport(files=files, format="xdmf", points=points, arrays=found, times=np.array([t]), cells=cells,
                            notes=tuple(notes))
        bar.close()
    finally:
        heavy.close()


def read_xdmf_collections(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """Every step of :func:`iter_xdmf_collections` in memory: arrays of shape (n_times, n[, n_components])."""
    from ._raw import stack_steps

    return stack_steps(iter_xdmf_collections(path, progress=progress, scope=scope))
