"""The common intermediate form every format reader returns.

A reader's only job is to turn bytes into numbers: it returns a :class:`RawExport` with the
export's own names and units, untouched. Choosing the SED array, recognising tensor
components, converting units and validating is done once, for every format, in
:mod:`afferent.io._assemble`.

**Every file a reader opens is listed in** :attr:`RawExport.files` (the export first, then each
side file in the order it was first opened), because the sampled-SED cache
(:mod:`afferent.cache`) and ``run.json`` hash exactly that list: a side file missing from it
is a file whose rewrite goes unnoticed (stale SED from the cache, an incomplete run record).
The list is filled where the file is really opened, never by parsing the export for names:

- a reader that opens a file itself adds that path (as opened: relative to the export's folder
  when the export names it so); :func:`files_read` joins the lists without repeats;
- HDF5 through h5py: :func:`h5_files` gives the files an object and every group on its path
  really live in, so the targets of external links are included;
- a library that opens files for you (meshio, VTK, netCDF4, ...): route its file access through
  your own code (afferent's XDMF reads meshio's data items itself), or ask the library for
  the files it opened (VTK: each piece reader's file name); if neither is possible, refuse
  the construct rather than leave a file out.

Step-wise readers (``iter_*``) give each step the files opened so far; :func:`afferent.io.
series_provenance` joins them.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import SEDFormatError
from ..field import Cells, Deferred, _DecodedOnUse

__all__ = ["RawExport", "RawArray", "Deferred", "check_export_file", "material_array", "drop_valueless_nodes", "split_steps", "stack_steps", "files_read", "h5_files", "h5_values"]


@dataclass(frozen=True)
class RawArray:
    """One named array of an export, in the file's units.

    Parameters
    ----------
    name : str
        The name as the export spells it (CSV header without its unit, VTU array name).
    values : ndarray of shape (n_times, n_values) or (n_times, n_values, n_components), or Deferred
        Values in the file's units (float64). A :class:`Deferred` is decoded on first access of
        ``values``; :attr:`shape` and :attr:`ndim` are known without decoding.
    location : {'point', 'cell'}
        Point (node) data or one value per cell.
    unit : str or None
        The unit the file states for this array (e.g. from ``solid.Ws (J/m^3)``), else None.
    components : tuple of str
        Component names when the file gives them (VTU ``ComponentName``), else ().
    """

    name: str
    values: np.ndarray = _DecodedOnUse()
    location: str = "point"
    unit: str | None = None
    components: tuple[str, ...] = ()

    @property
    def shape(self) -> tuple:
        """The values' shape, without decoding them."""
        return self.__dict__["_values"].shape

    @property
    def ndim(self) -> int:
        """The values' number of dimensions (2: one value per point or cell, 3: components), without decoding them."""
        return len(self.shape)

    @property
    def decoded(self) -> bool:
        """Whether the values are in memory (not a :class:`Deferred` still to decode)."""
        return not isinstance(self.__dict__["_values"], Deferred)

    def then(self, function, shape: tuple | None = None) -> RawArray:
        """This array with values ``function(values)``, deferred when these are (``shape``: the result's, default unchanged)."""
        from dataclasses import replace

        values = self.__dict__["_values"]
        return replace(self, values=values.then(function, shape) if isinstance(values, Deferred) else function(values))


@dataclass(frozen=True)
class RawExport:
    """What a format reader found in an export, before interpretation.

    Parameters
    ----------
    files : tuple of str
        Every file the reader opened: the export file(s) as given, in time order, then the side
        files they name (a ``.pvd``'s VTU files, an XDMF's HDF5 and ``.bin`` files, the targets
        of HDF5 external links, a ``coordinates`` table), each once, in the order first opened.
        The cache and ``run.json`` hash exactly these (see the module docstring).
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
    reader : str or None
        The library that decoded the file when it is not afferent's own code (``'meshio 5.3.5'``,
        ``'VTK 9.5.2'``), for ``afferent info`` and the provenance notes.
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
    reader: str | None = None

    @property
    def n_times(self) -> int:
        """Number of time steps found (1 for a static export)."""
        for arr in self.arrays.values():
            return arr.shape[0]
        return 0


def material_array(ids, n_times: int = 1) -> RawArray | None:
    """Each cell's material id (cell order, the same at every step) as the cell array ``material``, or None
    when the cells carry fewer than two ids: the array the interface site finders (``--material-array``)
    and ``side=`` use. For readers whose format states materials (a CalculiX ``.frd``'s material
    numbers, an FEBio ``.xplt``'s parts, an Exodus file's element blocks).

    Parameters
    ----------
    ids : array_like of shape (n_cells,)
        Material id of each volume cell (a number).
    n_times : int
        Time steps of the export (the array is broadcast over them, not copied).
    """
    ids = np.asarray(ids, dtype=float).ravel()
    if ids.size == 0 or np.unique(ids).size < 2:
        return None
    return RawArray("material", np.broadcast_to(ids, (max(n_times, 1), ids.size)), "cell")


def check_export_file(path: str) -> None:
    """Refuse an export file that is missing (FileNotFoundError), not a regular file (a FIFO, a device, a
    folder: SEDFormatError, before anything opens it) or empty (SEDFormatError), naming it."""
    from ._files import check_regular

    check_regular(path)
    if os.path.getsize(path) == 0:
        raise SEDFormatError(f"SED file {path!r} is empty.")


def files_read(*groups) -> tuple[str, ...]:
    """The paths of ``groups`` (iterables of str or path-like) in order, each file once (two spellings of one
    path, as HDF5 names a link's target absolute, count once: the first kept): for :attr:`RawExport.files`."""
    out: dict[str, str] = {}
    for p in (os.fspath(p) for group in groups for p in group):
        out.setdefault(os.path.abspath(p), p)
    return tuple(out.values())


def h5_files(h5file, name: str) -> list[str]:
    """The files the HDF5 object ``name`` of an open h5py file and every group on its path live in,
    and, for a dataset, the files its values are stored in (external raw storage, a virtual
    dataset's sources: :func:`_storage_files`).

    An external link (``h5py.ExternalLink``) makes HDF5 open another file: the object then
    lives there, and that file is among the result, as is every file a chain of external links
    passes through on the way (an external link to an external link). Paths as h5py reports
    them (``File.filename``), each file once.

    Parameters
    ----------
    h5file : h5py.File
    name : str
        An object path in it, e.g. ``'/Function/sed/1'``.
    """
    import os

    parts = [p for p in name.split("/") if p]
    out = [h5file.filename]
    for k in range(1, len(parts) + 1):
        prefix = "/" + "/".join(parts[:k])
        out.extend(_link_chain(h5file, prefix, h5file[os.path.dirname(prefix)].file.filename))
        out.append(h5file[prefix].file.filename)
    import h5py

    obj = h5file[name]
    if isinstance(obj, h5py.Dataset):
        out.extend(_storage_files(obj))
    seen, unique = set(), []
    for f in out:
        if os.path.abspath(f) not in seen:
            seen.add(os.path.abspath(f))
            unique.append(f)
    return unique


#: Bytes of values an HDF5 dataset may hold without its file storing any of them (:func:`h5_values`).
H5_UNSTORED_BYTES = 64 * 2**20
#: How many times the bytes its file stores for it a dataset's values may take beyond that: deflate (gzip), the
#: filter HDF5 writers use, inflates at most ~1,032:1.
H5_MAX_RATIO = 1100


def h5_values(dataset, label: str, size: int | None = None) -> np.ndarray:
    """The values of an h5py dataset, read whole only after what its header tells has been checked.

    - ``size``: the number of values the caller expects (from the mesh's counts, a declared
      size): a dataset holding more is refused before anything is read (fewer: read, for the
      caller's own message);
    - values the file does not store: a dataset whose values take more than
      :data:`H5_UNSTORED_BYTES` (64 MiB) and more than :data:`H5_MAX_RATIO` (1,100) times the
      bytes stored for it is refused. Its chunks were never written, or its storage never
      allocated (HDF5 reads its fill value there: no data; 8 GB from a file of a few kB), or
      a filter compresses beyond what deflate can (HDF5 writers use gzip). All-zero arrays
      compressed by gzip (~1,000:1) pass.

    Parameters
    ----------
    dataset : h5py.Dataset
    label : str
        What the values are, for the messages (e.g. ``"SED file 'a.med': the node coordinates
        ('/ENS_MAA/m/NOE/COO')"``).
    size : int, optional
        The most values the caller will use.

    Raises
    ------
    SEDFormatError
        Naming ``label``, the dataset's shape and the limit it exceeds.
    """
    h5_check(dataset, label, size)
    return np.asarray(dataset[()])


def h5_check(dataset, label: str, size: int | None = None) -> None:
    """The checks of :func:`h5_values`, nothing read: a SEDFormatError naming ``label`` when one fails."""
    shape = tuple(dataset.shape or ())
    n_values = int(np.prod(shape, dtype=np.int64)) if dataset.shape is not None else 0
    if size is not None and n_values > size:
        raise SEDFormatError(f"{label}: the dataset holds {n_values:,} values (shape {shape}) where {size:,} are "
                             "expected: the file is corrupt; refused before reading it.")
    n_bytes = n_values * dataset.dtype.itemsize
    if n_bytes <= H5_UNSTORED_BYTES:
        return
    stored = _stored_bytes(dataset)
    if stored is not None and n_bytes > H5_MAX_RATIO * stored:
        raise SEDFormatError(f"{label}: the dataset holds {n_values:,} values (shape {shape}, {n_bytes:,} bytes) of "
                             f"which the file stores {stored:,} bytes: chunks never written (no data, HDF5's fill value) or a "
                             f"compression beyond gzip's ({H5_MAX_RATIO:,}:1 at most); refused before reading it.")


def _stored_bytes(dataset) -> int | None:
    """The bytes a dataset's file stores for its values (a virtual dataset: its mapped values' bytes);
    None when they live in external raw files (as large as those files)."""
    if dataset.id.get_create_plist().get_external_count():
        return None
    if dataset.is_virtual:
        return sum(int(src.vspace.get_select_npoints()) for src in dataset.virtual_sources()) * dataset.dtype.itemsize
    return int(dataset.id.get_storage_size())


def _storage_files(dataset) -> list[str]:
    """The files a dataset's values live in besides its HDF5 file: the raw files of external storage
    (``H5Pset_external``) and the source files of a virtual dataset (``'.'``: its own file, left out).

    A relative name is taken beside the dataset's file, where :func:`afferent.io._files.h5_read` reads it
    (HDF5's default would be the working folder).
    """
    import os

    from ._files import storage_names

    raw, sources = storage_names(dataset)
    base = os.path.dirname(dataset.file.filename)
    return [os.path.join(base, n) for n in raw + [src.file_name for src in sources if src.file_name != "."]]


def _link_chain(h5file, name: str, parent: str, limit: int = 32) -> list[str]:
    """The files a chain of external links starting at ``name`` (a link in the file ``parent``) opens.

    Each target name is resolved as HDF5 does by default: absolute as written, else relative to
    the folder of the file holding the link. A target that is not there ends the chain (HDF5
    found it elsewhere, e.g. through ``HDF5_EXT_PREFIX``; its final file is still reported by
    :func:`h5_files`).
    """
    import os

    import h5py

    out: list[str] = []
    link = h5file.get(name, getlink=True)
    while isinstance(link, h5py.ExternalLink) and len(out) < limit:
        target = link.filename if os.path.isabs(link.filename) else os.path.join(os.path.dirname(parent), link.filename)
        if not os.path.isfile(target):
            break
        out.append(target)
        with h5py.File(target, "r") as f:
            link = f.get(link.path, getlink=True)
        parent = target
    return out


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
        cells = Cells(remap[cells.tetra], cells.parent, cells.n_cells, cells.cell_types, materials=cells.materials,
                      nodes=cells.renumbered_nodes(remap))  # -1: a mid-side node left out (that cell: corners only)
    note = f"{n - keep.size} node(s) without results and outside every volume cell's corners left out."
    return RawExport(files=raw.files, format=raw.format, points=raw.points[keep], arrays=arrays, times=raw.times,
                     cells=cells, length_unit=raw.length_unit, time_unit=raw.time_unit, notes=raw.notes + (note,),
                     preset=raw.preset)
