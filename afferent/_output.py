"""Writing results safely: to a temporary name, then renamed; never silently overwritten."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from contextlib import contextmanager

from .exceptions import OutputExistsError

__all__ = ["atomic_file", "atomic_dir", "check_writable"]


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


def check_writable(path: str, *, overwrite: bool, what: str = "Output file") -> None:
    """Raise :class:`OutputExistsError` if ``path`` exists and ``overwrite`` is False; create
    its missing parent folders (``results/`` on a fresh checkout)."""
    if os.path.lexists(path) and not overwrite:
        raise OutputExistsError(f"{what} {path!r} already exists; pass overwrite=True to replace it.")
    parent = os.path.dirname(os.path.abspath(path))
    if os.path.exists(parent) and not os.path.isdir(parent):
        raise NotADirectoryError(f"{what} {path!r}: {parent!r} is a file, not a folder.")
    os.makedirs(parent, exist_ok=True)


@contextmanager
def atomic_file(path: str, *, overwrite: bool = False):
    """Yield a temporary path beside ``path``; on success rename it to ``path``, else delete it.

    >>> with atomic_file("out.csv", overwrite=True) as tmp:  # doctest: +SKIP
    ...     df.to_csv(tmp)
    """
    path = os.fspath(path)
    check_writable(path, overwrite=overwrite)
    folder, base = os.path.split(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".part", dir=folder)
    os.close(fd)
    try:
        yield tmp
        _public(tmp, folder=False)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


@contextmanager
def atomic_dir(path: str, *, overwrite: bool = False):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` as a whole."""
    path = os.fspath(path)
    check_writable(path, overwrite=overwrite, what="Output folder")
    parent, base = os.path.split(os.path.abspath(path))
    tmp = tempfile.mkdtemp(prefix=f".{base}.", suffix=".part", dir=parent)
    try:
        yield tmp
        _public(tmp, folder=True)
        for root, dirs, files in os.walk(tmp):  # files written inside keep the umask already; mkstemp ones do not
            for name in files:
                full = os.path.join(root, name)
                if os.stat(full).st_mode & 0o777 == 0o600:
                    _public(full, folder=False)
            for name in dirs:
                _public(os.path.join(root, name), folder=True)
        if os.path.lexists(path):
            old = tempfile.mkdtemp(prefix=f".{base}.", suffix=".old", dir=parent)
            os.replace(path, os.path.join(old, base))
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            shutil.rmtree(tmp, ignore_errors=True)


def write_csv(df, path: str, *, overwrite: bool = False, writer: Callable | None = None) -> str:
    """Write a DataFrame as CSV atomically (no index); returns ``path``."""
    with atomic_file(path, overwrite=overwrite) as tmp:
        (writer or (lambda d, p: d.to_csv(p, index=False)))(df, tmp)
    return path
