"""Writing results safely: to a temporary name, then renamed; never silently overwritten, and never
deleting what the package did not write (README "Outputs and --overwrite").

One guard, :func:`check_writable`, runs before any work and again at the final rename:

- an output is never an input, the working folder, a folder holding either, nor inside an input
  folder, nor a symbolic link;
- a folder output is created whole (:func:`atomic_dir`) with :data:`MARKER` inside, the list of the
  files afferent wrote there; ``overwrite`` replaces an existing folder only if it is empty, or
  carries that list and holds nothing else (a folder written before the list existed is recognised
  by its afferent ``run.json`` / ``sweep.json``, and only its CSV, PNG, VTU, JSON, Parquet,
  Markdown, NetCDF and NWB files count as afferent's); a file output replaces only a file that is not an input;
- the final rename never replaces what appeared meanwhile (Linux ``renameat2(RENAME_NOREPLACE)``,
  elsewhere a hard link for files and ``mkdir`` for folders); a replacement swaps old and new in one
  step (``RENAME_EXCHANGE``) and only then deletes the old one;
- the environment (a full or read-only disk, a quota, permissions) is an :class:`OutputWriteError`
  naming the output, not an internal error.
"""

from __future__ import annotations

import ctypes
import errno
import fnmatch
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from contextlib import contextmanager

from .exceptions import OutputExistsError, OutputWriteError

__all__ = ["atomic_file", "atomic_dir", "check_writable", "mark_folder", "describe_os_error", "MARKER"]

#: the file in every output folder listing what afferent wrote there (the only files ``overwrite`` deletes)
MARKER = ".afferent-output.json"

#: errno -> what it means for the user: the environment, not a bug (exit code 2 on the command line)
_ENVIRONMENT = {getattr(errno, name): reason for name, reason in (
    ("ENOSPC", "the disk is full"), ("EDQUOT", "the disk quota is exceeded"), ("EROFS", "the file system is read-only"),
    ("EACCES", "permission denied"), ("EPERM", "the operation is not permitted"),
    ("EIO", "an input/output error of the disk"), ("EFBIG", "the file is too large for this file system"),
    ("ENAMETOOLONG", "the name is too long"), ("ELOOP", "too many levels of symbolic links"),
) if hasattr(errno, name)}  # EDQUOT: not on Windows
#: in a folder written before MARKER existed, the kinds of file afferent writes (a notes.txt there is not its)
_LEGACY = tuple(f"*.{ext}" for ext in ("csv", "png", "vtu", "json", "jsonl", "parquet", "md", "nc",
                                               "nwb"))
_TEMPORARIES = (".*.part", "*/.*.part")  # afferent's own temporary names, left by a killed run
_WRITING = tuple(getattr(errno, n) for n in ("ENOSPC", "EDQUOT", "EROFS", "EFBIG") if hasattr(errno, n))  # only writing


def _umask() -> int:
    """The process umask (read by setting it and putting it back: os has no getter)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _public(path: str, *, folder: bool) -> None:
    """Give a temporary file or folder the mode ordinary creation would have given it.

    ``tempfile`` creates them private (0600 files, 0700 folders) whatever the umask; results
    renamed into place would keep that, and colleagues on a shared server could not read them.
    """
    os.chmod(path, (0o777 if folder else 0o666) & ~_umask())


# ------------------------------------------------------------------------------ the guard
def _real(path) -> str:
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def _within(inner: str, outer: str) -> bool:
    """``inner`` is ``outer`` or lies below it (both real, absolute paths)."""
    return inner == outer or inner.startswith(outer.rstrip(os.sep) + os.sep)


def _check_place(path: str, inputs: Iterable, what: str) -> None:
    """Refuse an output that is a link, the working folder, an input, or holds or lies inside them."""
    if os.path.islink(path):
        raise OutputExistsError(f"{what} {path!r} is a symbolic link (to {os.readlink(path)!r}); afferent writes "
                                f"only to a real path: give {_real(path)!r} itself, or another name.")
    real, cwd = _real(path), _real(os.getcwd())
    if _within(cwd, real):
        where = "the working folder" if real == cwd else f"a folder holding the working folder {cwd!r}"
        raise OutputExistsError(f"{what} {path!r} is {where}; results go into a folder of their own: choose a new "
                                "name, e.g. 'results/run1'.")
    for inp in inputs:
        if inp is None:
            continue
        ri = _real(inp)
        if _within(ri, real):
            relation = "is the input" if ri == real else "holds the input"
            raise OutputExistsError(f"{what} {path!r} {relation} {os.fspath(inp)!r}; choose another output name.")
        if os.path.isdir(ri) and _within(real, ri):
            raise OutputExistsError(f"{what} {path!r} lies inside the input folder {os.fspath(inp)!r}; choose an "
                                    "output outside it.")


def _files_under(folder: str) -> list[str]:
    """Every file and link below ``folder``, as '/'-separated paths relative to it, sorted."""
    out = []
    for root, dirs, files in os.walk(folder):
        rel = os.path.relpath(root, folder)
        for name in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            out.append(name if rel == "." else f"{rel}/{name}".replace(os.sep, "/"))
    return sorted(out)


def _afferent_record(path: str) -> bool:
    """``path`` is a run.json or sweep.json written by afferent (before :data:`MARKER` existed)."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return False
    versions = data.get("versions") if isinstance(data, dict) else None
    return isinstance(data, dict) and ("afferent_sweep" in data or "afferent-skin" in (versions or {}))


def _manifest(folder: str) -> dict | None:
    """The list of what afferent wrote in ``folder`` (:data:`MARKER`); None when it is not afferent's."""
    try:
        with open(os.path.join(folder, MARKER), encoding="utf-8") as f:
            data = json.load(f)
        if isinstance(data, dict) and isinstance(data.get("files"), list):
            return data
    except (OSError, ValueError):
        pass
    records = [os.path.join(folder, n) for n in ("run.json", "sweep.json")]
    records += [os.path.join(folder, d, "run.json") for d in sorted(os.listdir(folder))]  # afferent demo's
    if any(_afferent_record(p) for p in records):
        return {"files": [], "patterns": list(_LEGACY)}  # written by afferent before the list: its kinds of file
    return None


def _check_own(path: str, what: str) -> None:
    """Refuse to replace a folder unless afferent wrote everything in it (or it is empty)."""
    names = _files_under(path)
    if not names:
        return
    manifest = _manifest(path)
    if manifest is None:
        raise OutputExistsError(f"{what} {path!r} was not written by afferent (it has no {MARKER}, the list of the "
                                "files afferent wrote there); overwrite=True replaces only afferent's own output "
                                "folders: move its contents away or choose another folder.")
    files, patterns = set(manifest["files"]) | {MARKER}, [*manifest.get("patterns", []), *_TEMPORARIES]
    foreign = [n for n in names if n not in files and not any(fnmatch.fnmatchcase(n, p) for p in patterns)]
    if foreign:
        listed = ", ".join(map(repr, foreign[:3])) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise OutputExistsError(f"{what} {path!r} holds files afferent did not write ({listed}); overwrite=True "
                                "would delete them: move them away or choose another folder.")


def check_writable(path, *, overwrite: bool, what: str | None = None, inputs: Iterable = (), folder: bool = False,
                   resume: bool = False) -> None:
    """The guard every writer calls, before any work; create the missing parent folders.

    Parameters
    ----------
    path : str or path-like
        The output file or folder.
    overwrite : bool
        Replace an existing output: a file that is not an input, or a folder afferent wrote whole.
    what : str, optional
        How messages name it; default 'Output folder' or 'Output file'.
    inputs : iterable of paths
        The files and folders the run reads: the output may not be, hold or lie inside any of them.
    folder : bool
        The output is a folder (else a file).
    resume : bool
        Accept an existing folder as it is (a sweep resuming; it checks the folder itself).

    Raises
    ------
    OutputExistsError
        The output exists and ``overwrite`` is False; or it may not be replaced (a link, the
        working folder, an input, a folder holding files afferent did not write).
    NotADirectoryError, IsADirectoryError
        A folder output names a file, or a file output a folder.
    """
    path = os.fspath(path)
    what = what or ("Output folder" if folder else "Output file")
    _check_place(path, inputs, what)
    if os.path.lexists(path):
        if folder and not os.path.isdir(path):
            raise NotADirectoryError(f"{what} {path!r} is a file, not a folder; afferent replaces only a folder it wrote.")
        if not folder and os.path.isdir(path):
            raise IsADirectoryError(f"{what} {path!r} is a folder, not a file.")
        if not (overwrite or resume):
            raise OutputExistsError(f"{what} {path!r} already exists; pass overwrite=True to replace it.")
        if folder and overwrite and not resume:
            _check_own(path, what)
    parent, base = os.path.split(os.path.abspath(path))
    if os.path.lexists(parent) and not os.path.isdir(parent):
        kind = "a broken symbolic link" if os.path.islink(parent) else "a file"
        raise NotADirectoryError(f"{what} {path!r}: {parent!r} is {kind}, not a folder.")
    with _environment(path, os.sep):  # anything failing here is about the output's place
        os.makedirs(parent, exist_ok=True)  # results/ on a fresh checkout
        fd, probe = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=parent)  # the writers' temporary name
        try:  # the folder takes files (not read-only, forbidden or full): said now, before the work
            os.write(fd, b"\0")
        finally:
            os.close(fd)
            os.remove(probe)


def mark_folder(folder: str, *, patterns: Iterable[str] = (), files: Iterable[str] | None = None) -> None:
    """Write :data:`MARKER` in ``folder``: ``files`` (default: every file now in it), plus ``patterns``
    (fnmatch, '/'-separated) for files afferent adds there later (a sweep's task records)."""
    from . import __version__

    listed = [n for n in _files_under(folder) if n != MARKER] if files is None else list(files)
    record = {"afferent_output": 1, "afferent": __version__, "patterns": list(patterns), "files": listed}
    fd, tmp = tempfile.mkstemp(prefix=f"{MARKER}.", suffix=".part", dir=folder)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(record, f, indent=1)
    _public(tmp, folder=False)
    os.replace(tmp, os.path.join(folder, MARKER))


# ---------------------------------------------------------------------------- the final step
_AT_FDCWD, _RENAME_NOREPLACE, _RENAME_EXCHANGE = -100, 1, 2


def _renameat2(src: str, dst: str, flags: int) -> bool:
    """Linux ``renameat2``; False when this system or file system has none (then the caller falls back)."""
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2  # glibc >= 2.28; not musl before 1.2.2, not macOS, not Windows
    except (AttributeError, OSError, TypeError):
        return False
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), ctypes.c_uint(flags)) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), dst)


def _appeared(path: str, what: str) -> OutputExistsError:
    return OutputExistsError(f"{what} {path!r} appeared while this run was writing it (another run?); it is kept and "
                             "this run's results are discarded: choose another name, or pass overwrite=True.")


def _rename_noreplace(src: str, dst: str, what: str) -> None:
    """Rename ``src`` to ``dst`` only if nothing is at ``dst`` (else :func:`_appeared`), in one step."""
    try:
        if _renameat2(src, dst, _RENAME_NOREPLACE):
            return
        if os.name == "nt":
            os.rename(src, dst)  # Windows never replaces
        elif os.path.isdir(src):
            os.mkdir(dst)  # claims the name; rename replaces only this empty folder
            try:
                os.rename(src, dst)
            except OSError:
                os.rmdir(dst)
                raise
        else:
            try:
                os.link(src, dst)
                os.unlink(src)
            except FileExistsError:
                raise
            except OSError:  # no hard links on this file system: a check just before
                if os.path.lexists(dst):
                    raise FileExistsError(errno.EEXIST, "exists", dst) from None
                os.rename(src, dst)
    except FileExistsError:
        raise _appeared(dst, what) from None


def _replace(src: str, dst: str, *, what: str, inputs, folder: bool) -> None:
    """Put ``src`` at ``dst``: a new name without replacing anything, or (overwrite) over what the guard accepts now."""
    if not os.path.lexists(dst):
        _rename_noreplace(src, dst, what)
        return
    check_writable(dst, overwrite=True, what=what, inputs=inputs, folder=folder)  # what is there now
    if not folder:
        os.replace(src, dst)
    elif _renameat2(src, dst, _RENAME_EXCHANGE):
        shutil.rmtree(src)  # the old folder, now at the temporary name
    else:
        parent, base = os.path.split(os.path.abspath(dst))
        old = tempfile.mkdtemp(prefix=f".{base}.", suffix=".old", dir=parent)
        os.replace(dst, os.path.join(old, base))
        try:
            _rename_noreplace(src, dst, what)
        finally:
            shutil.rmtree(old, ignore_errors=True)


# ---------------------------------------------------------------------------- the environment
def describe_os_error(err: OSError, path=None) -> str | None:
    """One line for an error of the environment (full or read-only disk, permissions, ...), else None.

    >>> describe_os_error(OSError(errno.ENOSPC, "No space left on device"), "out/")
    "cannot write 'out/': the disk is full (ENOSPC)"
    """
    reason = _ENVIRONMENT.get(getattr(err, "errno", None))
    if reason is None:
        return None
    target = os.fspath(path) if path is not None else err.filename
    verb = "cannot write" if path is not None or err.errno in _WRITING else "cannot use"
    return f"{verb} {target!r}: {reason} ({errno.errorcode[err.errno]})" if target else f"{reason} ({errno.errorcode[err.errno]})"


@contextmanager
def _environment(path: str, tmp_prefix: str):
    """Errors of the environment while writing ``path`` (or its temporaries) as :class:`OutputWriteError`."""
    try:
        yield
    except OSError as err:  # an OutputWriteError of a file inside this output's temporary folder too
        name = os.path.abspath(err.filename) if isinstance(err.filename, str) else None
        ours = name is None or name.startswith(tmp_prefix) or _within(name, os.path.abspath(path))
        message = describe_os_error(err, path) if ours and (err.errno in _WRITING or name is not None) else None
        if message is None:
            raise
        raise OutputWriteError(err.errno, message, path) from err


def _public_tree(tmp: str) -> None:
    _public(tmp, folder=True)
    for root, dirs, files in os.walk(tmp):  # files written inside keep the umask already; mkstemp ones do not
        for name in files:
            full = os.path.join(root, name)
            if os.stat(full).st_mode & 0o777 == 0o600:
                _public(full, folder=False)
        for name in dirs:
            _public(os.path.join(root, name), folder=True)


def _put(tmp: str, path: str, *, overwrite: bool, inputs: tuple, folder: bool) -> None:
    """The final step of atomic_file / atomic_dir: ``tmp`` becomes ``path``, replacing only what
    :func:`_replace` allows (``overwrite``), else never replacing anything that appeared meanwhile."""
    what = "Output folder" if folder else "Output file"
    if overwrite:
        _replace(tmp, path, what=what, inputs=inputs, folder=folder)
    else:
        _rename_noreplace(tmp, path, what)


@contextmanager
def atomic_file(path, *, overwrite: bool = False, inputs: Iterable = ()):
    """Yield a temporary path beside ``path``; on success rename it to ``path``, else delete it.

    ``path`` passes :func:`check_writable` first and again at the rename, which never replaces a
    file that appeared meanwhile unless ``overwrite``.

    >>> with atomic_file("out.csv", overwrite=True) as tmp:  # doctest: +SKIP
    ...     df.to_csv(tmp)
    """
    path = os.fspath(path)
    inputs = tuple(inputs)
    folder, base = os.path.split(os.path.abspath(path))
    with _environment(path, os.path.join(folder, f".{base}.")):
        check_writable(path, overwrite=overwrite, inputs=inputs)
        fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=folder)
        os.close(fd)
        try:
            yield tmp
            _public(tmp, folder=False)
            _put(tmp, path, overwrite=overwrite, inputs=inputs, folder=False)
        finally:
            if os.path.lexists(tmp):
                os.remove(tmp)


@contextmanager
def atomic_dir(path, *, overwrite: bool = False, inputs: Iterable = (), patterns: Iterable[str] = ()):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` as a whole.

    ``path`` passes :func:`check_writable` (``inputs``: what the run reads) first and again at the
    final rename; the folder gets :data:`MARKER` listing its files (plus ``patterns``, see
    :func:`mark_folder`), so that a later ``overwrite`` knows what afferent wrote there.
    """
    path = os.fspath(path)
    inputs = tuple(inputs)
    parent, base = os.path.split(os.path.abspath(path))
    with _environment(path, os.path.join(parent, f".{base}.")):
        check_writable(path, overwrite=overwrite, what="Output folder", inputs=inputs, folder=True)
        tmp = tempfile.mkdtemp(prefix=f".{base}.", suffix=".part", dir=parent)
        try:
            yield tmp
            _public_tree(tmp)
            mark_folder(tmp, patterns=patterns)
            _put(tmp, path, overwrite=overwrite, inputs=inputs, folder=True)
        finally:
            if os.path.exists(tmp):
                shutil.rmtree(tmp, ignore_errors=True)


def write_csv(df, path: str, *, overwrite: bool = False, writer: Callable | None = None, inputs: Iterable = ()) -> str:
    """Write a DataFrame as CSV atomically (no index); returns ``path``."""
    with atomic_file(path, overwrite=overwrite, inputs=inputs) as tmp:
        (writer or (lambda d, p: d.to_csv(p, index=False)))(df, tmp)
    return path
