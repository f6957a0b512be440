"""The one resolver of the files an export points to: heavy data, members, links, external storage.

Many exports are indexes: a ``.pvd`` or JSON ``.series`` lists step files, a ``.pvtu`` its pieces, a
``.vtm`` its blocks, an XDMF file its HDF5 and ``Format="Binary"`` heavy-data files; an HDF5 file (XDMF
heavy data, MED, Exodus netCDF-4, a run's ``currents.nc``) may hold external links to other HDF5 files,
datasets stored in external raw files (``H5Pset_external``) and virtual datasets whose values live in
other files. Every such file passes :func:`resolve_member` before anything opens it:

- a relative name is taken relative to the folder of the file that names it, as the formats define
  it (never the working folder);
- the file must lie inside the folder of the export the user named (:class:`Scope`; symbolic links
  are followed to where the file really is), unless the user allows otherwise on purpose:
  ``allow_outside_files=True`` (:func:`afferent.read_sed`), ``--allow-outside-files`` (every
  command that reads an export), ``allow_outside_files = true`` under a scene's ``[export]``;
- it must be a regular file: a FIFO, a device, a folder or a socket is refused from ``os.stat``,
  before it is opened (opening a FIFO blocks; ``/dev/zero`` never ends).

Each refusal is one sentence naming the file, the export that points to it and the option that
allows it. The files read are recorded as before (:attr:`afferent.io._raw.RawExport.files`, the run's
``run.json``); those outside the export's folder, when allowed, are also named in a note.

HDF5 follows links and reads external storage by itself, so :func:`h5_open` resolves every external
link of a file (and of the files they lead to) before anything is looked up in it, and
:func:`h5_read` resolves a dataset's external raw files and virtual sources before reading its
values, which it reads with the external files taken beside the dataset's file (HDF5's own default
is the working folder).
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass

from ..exceptions import SEDFormatError

__all__ = ["Scope", "resolve_member", "check_regular", "open_regular", "outside_note", "h5_open", "h5_read",
           "h5_refuse_external", "storage_names", "ALLOW_OUTSIDE"]

#: How a user allows files outside an export's folder, as the refusals name it.
#: The command line says ``--allow-outside-files`` (:func:`afferent.cli._main.speak_cli`), a scene's ``[export]`` the key.
ALLOW_OUTSIDE = "if it is meant to be read, pass allow_outside_files=True"

#: Longest chain of files leading to other files (external links to files with links, indexes of indexes).
MAX_DEPTH = 16


def _not_regular(mode: int) -> str | None:
    """What a file of ``st_mode`` is when it is not a regular file (None for a regular file)."""
    if stat.S_ISREG(mode):
        return None
    for test, what in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISDIR, "a folder"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return "not a regular file"


def check_regular(path: str, what: str = "SED file") -> None:
    """Refuse ``path`` unless it is a regular file (symbolic links followed), from ``os.stat``: nothing is opened.

    Raises
    ------
    FileNotFoundError
        ``"<what> '<path>' not found."``
    SEDFormatError
        ``"<what> '<path>' is a FIFO (named pipe), not a regular file; ..."`` (or a device, a folder, a socket).
    """
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        raise FileNotFoundError(f"{what} {path!r} not found.") from None
    except (OSError, ValueError) as err:  # a loop of symbolic links, a name too long, a NUL byte, no permission
        raise SEDFormatError(f"{what} {path!r} cannot be opened: {getattr(err, 'strerror', None) or err}.") from None
    kind = _not_regular(mode)
    if kind is not None:
        raise SEDFormatError(f"{what} {path!r} is {kind}, not a regular file; afferent reads regular files only.")


def open_regular(path: str, what: str = "File", mode: str = "rb"):
    """``open(path, mode)`` for reading, refusing anything but a regular file without blocking on it.

    The file is opened non-blocking (a FIFO without a writer opens at once) and checked with
    ``fstat`` on the open descriptor, so a file swapped for a FIFO after a check is refused too.
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except (FileNotFoundError, NotADirectoryError):
        raise FileNotFoundError(f"{what} {path!r} not found.") from None
    try:
        kind = _not_regular(os.fstat(fd).st_mode)
        if kind is not None:
            raise SEDFormatError(f"{what} {path!r} is {kind}, not a regular file; afferent reads regular files only.")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, mode, **({} if "b" in mode else {"encoding": "utf-8"}))
    except BaseException:
        os.close(fd)
        raise


@dataclass(frozen=True)
class Scope:
    """Where the files an export points to may be: the folder of the export the user named.

    Parameters
    ----------
    export : str
        The file the user named (for the messages).
    folder : str
        Its folder, symbolic links resolved: files must really lie under it.
    allow_outside : bool
        The user allowed files outside ``folder`` on purpose (regular files still).
    """

    export: str
    folder: str
    allow_outside: bool = False

    @classmethod
    def of(cls, export, allow_outside: bool = False) -> Scope:
        """The scope of the export file ``export``: its own folder."""
        export = os.fspath(export)
        return cls(export, os.path.realpath(os.path.dirname(os.path.abspath(export))), bool(allow_outside))

    def inside(self, path: str) -> bool:
        """Whether ``path`` (symbolic links followed as far as they exist) lies inside :attr:`folder`."""
        real = os.path.realpath(path)
        return os.path.commonpath([real, self.folder]) == self.folder


def resolve_member(referrer: str, reference, *, what: str, scope: Scope | None = None,
                   must_exist: bool = True) -> str:
    """The path of a file that ``referrer`` names, checked before anything opens it.

    Parameters
    ----------
    referrer : str
        The file that names it (an index, an XDMF file, an HDF5 file holding a link).
    reference : str or bytes
        The name as written there: relative to ``referrer``'s folder, or absolute.
    what : str
        What the file is to ``referrer``, for the messages (``'the piece'``, ``'the heavy-data file of
        attribute 'sed''``).
    scope : Scope, optional
        The export the user named and whether files outside its folder are allowed; default the
        folder of ``referrer``, nothing outside.
    must_exist : bool
        A missing file is an error (else its path is returned, for the caller's own message).

    Returns
    -------
    str
        ``reference`` joined to ``referrer``'s folder (as is when absolute).

    Raises
    ------
    SEDFormatError
        The file lies outside the scope's folder and that is not allowed; it is not a regular file;
        the name is not a file name.
    FileNotFoundError
        It does not exist and ``must_exist``.
    """
    scope = scope or Scope.of(referrer)
    if isinstance(reference, bytes):
        reference = reference.decode("utf-8", "surrogateescape")
    reference = os.fspath(reference)
    if not reference.strip() or "\x00" in reference:
        raise SEDFormatError(f"SED file {referrer!r} names {what} {reference!r}, which is not a file name.")
    path = reference if os.path.isabs(reference) else os.path.join(os.path.dirname(referrer), reference)
    if not scope.allow_outside and not scope.inside(path):
        real = os.path.realpath(path)
        really = f" (really {real!r})" if real != os.path.normpath(os.path.abspath(path)) else ""
        raise SEDFormatError(
            f"SED file {referrer!r} points to {what} {reference!r}{really}, outside the folder of the export "
            f"{scope.export!r}; afferent reads only the files inside an export's own folder: {ALLOW_OUTSIDE}.")
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        if must_exist:
            raise FileNotFoundError(f"SED file {referrer!r} lists {what} {path!r}, which does not exist.") from None
        return path
    except OSError as err:  # a loop of symbolic links, a name too long, no permission
        raise SEDFormatError(f"SED file {referrer!r} names {what} {path!r}, which cannot be opened: "
                             f"{err.strerror or err}.") from None
    kind = _not_regular(mode)
    if kind is not None:
        raise SEDFormatError(f"SED file {referrer!r} names {what} {path!r}, which is {kind}, not a regular file; "
                             "afferent reads regular files only.")
    return path


def outside_note(files, named, scope_of) -> tuple[str, ...]:
    """A note naming the files of ``files`` that lie outside the folders of the ``named`` export files
    (read because the user allowed it), or ()."""
    named = {os.path.abspath(p) for p in named}
    scopes = [scope_of(p) for p in named]
    outside = [f for f in files if os.path.abspath(f) not in named and not any(s.inside(f) for s in scopes)]
    if not outside:
        return ()
    return (f"read outside the export's folder (allowed: allow_outside_files): {', '.join(map(repr, outside))}.",)


# ---------------------------------------------------------------------------------------------- HDF5


def _links(h5) -> list[tuple[str, str, str]]:
    """(link name, target file, target object) of every external link of an open HDF5 file, found without
    following any link (HDF5's link iteration visits hard-linked groups only)."""
    import h5py

    names: list[bytes] = []
    out = []
    try:
        h5.id.links.visit(lambda name, info: names.append(name) if info.type == h5py.h5l.TYPE_EXTERNAL else None,
                          info=True)
        for name in names:
            target, obj = h5.id.links.get_val(name)
            out.append((name.decode("utf-8", "replace"), target, obj.decode("utf-8", "replace")))
    except (RuntimeError, SystemError, OSError, KeyError, ValueError) as err:  # damaged groups or link messages
        raise SEDFormatError(f"HDF5 file {h5.filename!r}: its links could not be read (truncated or corrupt?): "
                             f"{type(err).__name__}: {err}") from err
    return out


def _check_links(h5, scope: Scope, seen: set, depth: int, opened: list) -> None:
    """Resolve every external link of ``h5`` and, recursively, of the files they lead to (each opened to look at
    its links: appended to ``opened``)."""
    import h5py

    for name, target, _ in _links(h5):
        path = resolve_member(h5.filename, target, what=f"the target of the HDF5 external link {name!r}", scope=scope)
        real = os.path.realpath(path)
        if real in seen:
            continue
        if depth >= MAX_DEPTH:
            raise SEDFormatError(f"SED file {h5.filename!r}: its HDF5 external links lead through more than "
                                 f"{MAX_DEPTH} files; afferent follows at most {MAX_DEPTH}.")
        seen.add(real)
        opened.append(path)
        try:
            with h5py.File(path, "r") as other:
                _check_links(other, scope, seen, depth + 1, opened)
        except OSError as err:
            raise SEDFormatError(f"SED file {h5.filename!r}: the target {path!r} of its HDF5 external link "
                                 f"{name!r} could not be opened as HDF5 (truncated or corrupt?): {err}") from err


def h5_open(path: str, scope: Scope | None = None, opened: list | None = None):
    """An HDF5 file opened read-only (h5py) once it and every file its external links lead to have passed
    :func:`resolve_member`; nothing is looked up in it before. The files the links lead to are opened to
    look at their own links, and appended to ``opened`` (for :attr:`~afferent.io._raw.RawExport.files`).
    The caller checks ``path`` itself (:func:`check_regular` or :func:`resolve_member`) and turns h5py's
    OSError into its own message."""
    import h5py

    scope = scope or Scope.of(path)
    h5 = h5py.File(path, "r")
    try:
        _check_links(h5, scope, {os.path.realpath(path)}, 0, [] if opened is None else opened)
    except BaseException:
        h5.close()
        raise
    return h5


def storage_names(dataset) -> tuple[list[str], list]:
    """The external raw files of an h5py dataset (names as written) and its virtual sources (``VDSmap``: ``file_name``
    ``'.'`` for its own file), read from its creation properties: no value is read."""
    plist = dataset.id.get_create_plist()
    names = [plist.get_external(k)[0] for k in range(plist.get_external_count())]
    return [n.decode("utf-8", "surrogateescape") if isinstance(n, bytes) else n for n in names], \
        (dataset.virtual_sources() if dataset.is_virtual else [])


def _check_storage(dataset, scope: Scope, opened: list) -> None:
    """Resolve the files a dataset's values are stored in: external raw files, virtual sources (whose own
    values must lie in their file: a source stored elsewhere again is refused); each is appended to ``opened``."""
    import h5py

    where = dataset.file.filename
    try:
        raw, sources = storage_names(dataset)
    except (RuntimeError, OSError, ValueError) as err:  # a source name HDF5 cannot parse (a bad printf pattern)
        raise SEDFormatError(f"SED file {where!r}: the files HDF5 dataset {dataset.name!r} is stored in cannot be "
                             f"read from its properties: {err}") from err
    patterns = [s.file_name for s in sources if "%" in s.file_name]
    if patterns:
        raise SEDFormatError(f"SED file {where!r}: HDF5 virtual dataset {dataset.name!r} names its source file "
                             f"{patterns[0]!r} with '%' (a printf-style pattern to HDF5); afferent reads sources named "
                             "plainly.")
    for name in raw:
        opened.append(resolve_member(where, name, what=f"the external storage of HDF5 dataset {dataset.name!r}",
                                     scope=scope))
    for src in sources:
        what = f"the source of HDF5 virtual dataset {dataset.name!r}"
        path = where if src.file_name == "." else resolve_member(where, src.file_name, what=what, scope=scope)
        opened.append(path)
        try:
            with h5_open(path, scope, opened) as f:
                inner = f.get(src.dset_name)
                nested = isinstance(inner, h5py.Dataset) and any(storage_names(inner))
        except OSError as err:
            raise SEDFormatError(f"SED file {where!r}: {what} in {path!r} could not be opened (truncated or "
                                 f"corrupt?): {err}") from err
        if nested:
            raise SEDFormatError(f"SED file {where!r}: {what} ({src.dset_name!r} in {path!r}) is stored in other "
                                 "files again (external or virtual); afferent reads one level of virtual sources.")


def h5_read(group, name: str, scope: Scope | None = None, opened: list | None = None, check=None):
    """The values (ndarray) of dataset ``name`` of an open h5py group, read once every file they are stored in
    (external raw files, virtual sources) has passed :func:`resolve_member`, and ``check(dataset)`` (the
    caller's sizes: :func:`afferent.io._raw.h5_check`) has not refused it.

    External raw files named relatively are read beside the dataset's file (``${ORIGIN}``), where
    :func:`resolve_member` looked, not in the working folder (HDF5's default). The file holding the
    dataset (another file when an external link led there) and the files its values are stored in are
    appended to ``opened`` (for :attr:`~afferent.io._raw.RawExport.files`).
    """
    import h5py
    from h5py import h5d, h5p

    dapl = h5p.create(h5p.DATASET_ACCESS)
    dapl.set_efile_prefix(b"${ORIGIN}")
    dataset = h5py.Dataset(h5d.open(group.id, name.encode(), dapl=dapl))
    opened = [] if opened is None else opened
    opened.append(dataset.file.filename)
    _check_storage(dataset, scope or Scope.of(dataset.file.filename), opened)
    if check is not None:
        check(dataset)
    return dataset[()]


def h5_refuse_external(h5, what: str) -> None:
    """Refuse an HDF5 file afferent wrote self-contained (a run's ``currents.nc``) that holds an external link,
    or a dataset stored in other files, before anything is read from it."""
    import h5py

    links = _links(h5)
    if links:
        raise SEDFormatError(f"{what} {h5.filename!r} holds an HDF5 external link ({links[0][0]!r} to "
                             f"{links[0][1]!r}); afferent writes it self-contained and reads nothing outside it.")
    found = []
    def elsewhere(obj) -> bool:
        try:
            return any(storage_names(obj))
        except (RuntimeError, OSError, ValueError):  # properties HDF5 cannot parse: not self-contained either
            return True

    h5.visititems(lambda name, obj: found.append(name) if isinstance(obj, h5py.Dataset) and elsewhere(obj) else None)
    if found:
        raise SEDFormatError(f"{what} {h5.filename!r}: dataset {found[0]!r} is stored in other files (external or "
                             "virtual storage); afferent writes it self-contained and reads nothing outside it.")
