"""Writing results safely: to a temporary name, then renamed; never silently overwritten, and never
deleting what the package did not write (docs/cli.md, "Outputs and --overwrite").

One guard, :func:`check_writable`, runs before any work and again at the final rename:

- an output is never an input, the working folder, a folder holding either, nor inside an input
  folder, nor a symbolic link (:func:`check_place`). The inputs are those the writer names and
  those of the command running (:func:`command_inputs`: ``afferent.cli`` gathers every path a
  command reads from its parsed options and checks its ``-o`` before the command starts);
- a folder output is created whole (:func:`atomic_dir`) with :data:`MARKER` inside, afferent's
  record of each file it wrote there with its size and SHA-256 (:mod:`afferent._owned`);
  ``overwrite`` replaces an existing folder only if it is empty, or every entry in it is proven
  afferent's by that record; a folder without it (a user's, or one written before the record
  existed) is never replaced: the user deletes it. A file output replaces only a file that is not an input;
- the final rename never replaces what appeared meanwhile (Linux ``renameat2(RENAME_NOREPLACE)``,
  elsewhere a hard link for files and ``mkdir`` for folders); a replacement swaps old and new in one
  step (``RENAME_EXCHANGE``), proves again what it swapped out (not a link, afferent's own) and only
  then deletes it, file by file; anything else is swapped back and the run's results discarded;
- the environment (a full or read-only disk, a quota, permissions) is an :class:`OutputWriteError`
  naming the output, not an internal error.
"""

from __future__ import annotations

import ctypes
import errno
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable, Iterable
from contextlib import contextmanager

from ._owned import MARKER, owned, remove_owned, write_record
from ._owned import public as _public
from .exceptions import OutputExistsError, OutputWriteError

__all__ = ["atomic_file", "atomic_dir", "check_writable", "check_place", "command_inputs", "describe_os_error", "MARKER",
           "Terminated", "on_signal", "signals_seen"]

#: errno -> what it means for the user: the environment, not a bug (exit code 2 on the command line)
_ENVIRONMENT = {getattr(errno, name): reason for name, reason in (
    ("ENOSPC", "the disk is full"), ("EDQUOT", "the disk quota is exceeded"), ("EROFS", "the file system is read-only"),
    ("EACCES", "permission denied"), ("EPERM", "the operation is not permitted"),
    ("EIO", "an input/output error of the disk"), ("EFBIG", "the file is too large for this file system"),
    ("ENAMETOOLONG", "the name is too long"), ("ELOOP", "too many levels of symbolic links"),
) if hasattr(errno, name)}  # EDQUOT: not on Windows
_WRITING = tuple(getattr(errno, n) for n in ("ENOSPC", "EDQUOT", "EROFS", "EFBIG") if hasattr(errno, n))  # only writing


# ------------------------------------------------------------------------------ stopped by a signal
class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP received by a command (:func:`on_signal`): raised like Ctrl-C's KeyboardInterrupt, so that
    the same ``finally`` clauses remove the temporary outputs (``.NAME.*.part``) and stop a figure process; the
    command line exits with 128 + the signal's number (143, 129), a shell's status for a process ended by it."""

    def __init__(self, signum: int):
        import signal

        super().__init__(signum)
        self.signum, self.name = signum, signal.Signals(signum).name


#: the signals a command received (``seen``: all; ``pending``: not raised yet) and how deep the writers hold them off
_SIGNALS: dict = {"seen": [], "pending": [], "held": 0}


def on_signal(signum: int, frame=None) -> None:
    """The command line's handler of SIGINT, SIGTERM and SIGHUP: raise KeyboardInterrupt (SIGINT) or
    :class:`Terminated` at once, or, while a writer creates, renames or removes a temporary (:func:`_held`),
    as soon as it is done: a signal never strands a temporary between its creation and its ``try``."""
    _SIGNALS["seen"].append(signum)
    _SIGNALS["pending"].append(signum)
    if not _SIGNALS["held"]:
        _raise_pending()


def signals_seen(reset: bool = False) -> list[int]:
    """The signals received since the command started (:func:`on_signal`); ``reset``: forget them (a new command)."""
    seen = list(_SIGNALS["seen"])
    if reset:
        _SIGNALS.update(seen=[], pending=[], held=0)
    return seen


def _raise_pending() -> None:
    import signal

    sig = _SIGNALS["pending"][0]
    _SIGNALS["pending"].clear()
    raise KeyboardInterrupt() if sig == signal.SIGINT else Terminated(sig)


def _stop_if_signalled() -> None:
    """Before a final rename: a signal received, even one whose exception code swallowed (raised inside a weakref
    callback, say), stops the output from being put in place."""
    if _SIGNALS["seen"]:
        _SIGNALS["pending"][:] = _SIGNALS["seen"][:1]
        _raise_pending()


@contextmanager
def _held():
    """Hold :func:`on_signal` off while a temporary is created, renamed or removed; raise what came meanwhile after."""
    _SIGNALS["held"] += 1
    try:
        yield
    finally:
        _SIGNALS["held"] -= 1
    if not _SIGNALS["held"] and _SIGNALS["pending"]:
        _raise_pending()


# ------------------------------------------------------------------------------ the guard
def _real(path) -> str:
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def _within(inner: str, outer: str) -> bool:
    """``inner`` is ``outer`` or lies below it (both real, absolute paths)."""
    return inner == outer or inner.startswith(outer.rstrip(os.sep) + os.sep)


#: the inputs of the command running (:func:`command_inputs`), checked by every writer besides its own
_COMMAND: list[tuple] = [()]


@contextmanager
def command_inputs(paths: Iterable):
    """Within: every output (:func:`check_writable`, :func:`atomic_dir`, :func:`atomic_file`) is also checked
    against ``paths``, the files and folders the running command reads (``afferent.cli`` gathers them from the
    command's parsed options), so that no writer can leave one out."""
    _COMMAND.append(tuple(os.fspath(p) for p in paths if p is not None))
    try:
        yield
    finally:
        _COMMAND.pop()


def check_place(path, inputs: Iterable = (), what: str = "Output") -> None:
    """Refuse an output that is a link, the working folder, an input (``inputs`` and the command's), or holds
    or lies inside them.

    Raises
    ------
    OutputExistsError
        Naming the output and the input (or folder) it would replace.
    """
    path = os.fspath(path)
    if os.path.islink(path):
        raise OutputExistsError(f"{what} {path!r} is a symbolic link (to {os.readlink(path)!r}); afferent writes "
                                f"only to a real path: give {_real(path)!r} itself, or another name.")
    real, cwd = _real(path), _real(os.getcwd())
    if _within(cwd, real):
        where = "the working folder" if real == cwd else f"a folder holding the working folder {cwd!r}"
        raise OutputExistsError(f"{what} {path!r} is {where}; results go into a folder of their own: choose a new "
                                "name, e.g. 'results/run1'.")
    for inp in dict.fromkeys((*(os.fspath(p) for p in inputs if p is not None), *_COMMAND[-1])):
        ri = _real(inp)
        if _within(ri, real):
            relation = "is the input" if ri == real else "holds the input"
            raise OutputExistsError(f"{what} {path!r} {relation} {inp!r}; choose another output name.")
        if os.path.isdir(ri) and _within(real, ri):
            raise OutputExistsError(f"{what} {path!r} lies inside the input folder {inp!r}; choose an "
                                    "output outside it.")


def check_writable(path, *, overwrite: bool, what: str | None = None, inputs: Iterable = (), folder: bool = False,
                   resume: bool = False) -> None:
    """The guard every writer calls, before any work; create the missing parent folders.

    Parameters
    ----------
    path : str or path-like
        The output file or folder.
    overwrite : bool
        Replace an existing output: a file that is not an input, or a folder whose every entry is
        proven afferent's by its :data:`MARKER` (:func:`afferent._owned.owned`).
    what : str, optional
        How messages name it; default 'Output folder' or 'Output file'.
    inputs : iterable of paths
        The files and folders the run reads (besides the command's, :func:`command_inputs`): the
        output may not be, hold or lie inside any of them.
    folder : bool
        The output is a folder (else a file).
    resume : bool
        Accept an existing folder as it is (a sweep resuming; it checks the folder itself).

    Raises
    ------
    OutputExistsError
        The output exists and ``overwrite`` is False; or it may not be replaced (a link, the
        working folder, an input, a folder holding anything afferent cannot prove it wrote).
    NotADirectoryError, IsADirectoryError
        A folder output names a file, or a file output a folder.
    """
    path = os.fspath(path)
    what = what or ("Output folder" if folder else "Output file")
    inputs = tuple(inputs)
    check_place(path, inputs, what)
    if os.path.lexists(path):
        if folder and not os.path.isdir(path):
            raise NotADirectoryError(f"{what} {path!r} is a file, not a folder; afferent replaces only a folder it wrote.")
        if not folder and os.path.isdir(path):
            raise IsADirectoryError(f"{what} {path!r} is a folder, not a file.")
        if not (overwrite or resume):
            raise OutputExistsError(f"{what} {path!r} already exists; pass overwrite=True to replace it.")
        if folder and overwrite and not resume:
            owned(path, what)
    parent, base = os.path.split(os.path.abspath(path))
    if os.path.lexists(parent) and not os.path.isdir(parent):
        kind = "a broken symbolic link" if os.path.islink(parent) else "a file"
        raise NotADirectoryError(f"{what} {path!r}: {parent!r} is {kind}, not a folder.")
    with _environment(path, os.sep):  # anything failing here is about the output's place
        os.makedirs(parent, exist_ok=True)  # results/ on a fresh checkout
        with _held():
            fd, probe = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=parent)  # the writers' temporary name
            try:  # the folder takes files (not read-only, forbidden or full): said now, before the work
                os.write(fd, b"\0")
            finally:
                os.close(fd)
                os.remove(probe)


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


def _changed(path: str, what: str, now: str) -> OutputExistsError:
    return OutputExistsError(f"{what} {path!r} changed while this run was writing it ({now}); it is kept as it is "
                             "and this run's results are discarded: check it, then run again.")


def _swapped_out(old: str, dst: str, what: str, folder: bool) -> list[str]:
    """What the final step took from ``dst`` (now at ``old``) must still be what the guard accepted: a file,
    or a folder proven afferent's; the paths to delete (:func:`afferent._owned.owned`)."""
    if os.path.islink(old):
        raise _changed(dst, what, f"it is now a symbolic link to {os.readlink(old)!r}")
    if folder != os.path.isdir(old):
        raise _changed(dst, what, "it is now a folder" if os.path.isdir(old) else "it is now a file")
    return owned(old, what, shown=dst) if folder else [old]


def _delete(paths: list[str], old: str, dst: str, folder: bool) -> None:
    """Delete the old output, proven afferent's (:func:`_swapped_out`), now at the temporary name ``old``."""
    if not folder:
        os.unlink(old)
    elif not remove_owned(paths, old):
        warnings.warn(f"The previous {dst!r} was replaced, but something was written into it meanwhile; what is "
                      f"left of it is kept in {old!r}.", stacklevel=4)


def _replace(src: str, dst: str, *, what: str, inputs, folder: bool) -> None:
    """Put ``src`` at ``dst``: a new name without replacing anything, or (overwrite) over what the guard accepts.

    The old ``dst`` is swapped out in one step, proven again (a link or a user's folder swapped in
    meanwhile is swapped back, untouched) and deleted file by file: never ``rmtree`` on what may be a link.
    """
    if not os.path.lexists(dst):
        _rename_noreplace(src, dst, what)
        return
    check_place(dst, inputs, what)  # what is there now is proven once swapped out (_swapped_out), not twice
    if _renameat2(src, dst, _RENAME_EXCHANGE):
        try:
            paths = _swapped_out(src, dst, what, folder)
        except OutputExistsError:
            _renameat2(src, dst, _RENAME_EXCHANGE)  # back: theirs at dst, this run's results at src (discarded)
            raise
        _delete(paths, src, dst, folder)
        return
    if not folder:
        os.replace(src, dst)  # no exchange here: the check just above is the last word
        return
    parent, base = os.path.split(os.path.abspath(dst))
    hold = tempfile.mkdtemp(prefix=f".{base}.", suffix=".part", dir=parent)
    old = os.path.join(hold, base)
    try:
        os.rename(dst, old)
        try:
            paths = _swapped_out(old, dst, what, folder)
            _rename_noreplace(src, dst, what)
        except OutputExistsError:
            if not os.path.lexists(dst):
                os.rename(old, dst)  # back, as it was
            raise
        _delete(paths, old, dst, folder)
    finally:
        if os.path.isdir(hold) and not os.listdir(hold):
            os.rmdir(hold)


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
    _stop_if_signalled()
    with _held():  # a swap and its check, or a swap back, are never cut in two
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
        tmp = None
        try:
            with _held():  # created and named here, or not at all
                fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=folder)
                os.close(fd)
            yield tmp
            _public(tmp, folder=False)
            _put(tmp, path, overwrite=overwrite, inputs=inputs, folder=False)
        finally:
            with _held():
                if tmp is not None and os.path.lexists(tmp):
                    os.remove(tmp)


@contextmanager
def atomic_dir(path, *, overwrite: bool = False, inputs: Iterable = (), task_records: bool = False):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` as a whole.

    ``path`` passes :func:`check_writable` (``inputs``: what the run reads) first and again at the
    final rename; the folder gets :data:`MARKER`, the record of each file with its size and SHA-256
    (:func:`afferent._owned.write_record`; ``task_records``: a sweep's, whose task records are proven
    by their names), so that a later ``overwrite`` can prove what afferent wrote there.
    """
    path = os.fspath(path)
    inputs = tuple(inputs)
    parent, base = os.path.split(os.path.abspath(path))
    with _environment(path, os.path.join(parent, f".{base}.")):
        check_writable(path, overwrite=overwrite, what="Output folder", inputs=inputs, folder=True)
        tmp = None
        try:
            with _held():  # created and named here, or not at all
                tmp = tempfile.mkdtemp(prefix=f".{base}.", suffix=".part", dir=parent)
            yield tmp
            _public_tree(tmp)
            write_record(tmp, task_records=task_records)
            _put(tmp, path, overwrite=overwrite, inputs=inputs, folder=True)
        finally:
            with _held():  # this run's own folder (a swap put back included), removed whole
                if tmp is not None and os.path.isdir(tmp) and not os.path.islink(tmp):
                    shutil.rmtree(tmp, ignore_errors=True)


def write_csv(df, path: str, *, overwrite: bool = False, writer: Callable | None = None, inputs: Iterable = ()) -> str:
    """Write a DataFrame as CSV atomically (no index); returns ``path``."""
    with atomic_file(path, overwrite=overwrite, inputs=inputs) as tmp:
        (writer or (lambda d, p: d.to_csv(p, index=False)))(df, tmp)
    return path
