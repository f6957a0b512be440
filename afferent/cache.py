"""On-disk cache of sampled SED (stage 2's output), so a re-run skips reading and sampling.

::

    export file(s) content + read options + receptor positions + sampling method
        --sampling_key--> key (sha256 hex)
    SEDCache(dir).get(key) -> CachedSED | None      SEDCache(dir).put(key, sed, meta=...)

Reading a large FE export and locating the receptors in its mesh are the slow stages of
a run; transduction, synthesis and spiking take milliseconds on the sampled values. A scene
(:mod:`afferent.scene`) re-run with other transduction, synthesis or spiking parameters
therefore finds its :class:`~afferent.sampling.ReceptorSED` here.

**What the key covers** (:func:`sampling_key`): the SHA-256 of the *content* of the export
file(s) the user names and of a ``coordinates`` table, the reader deduced from each file name,
every read option (units, ``sed_from``, columns, times, ...), the receptor positions (their
float64 bytes) or, for receptors found on the export itself (papilla tips, a grid over the
export's extent), the specification that finds them, the sampling method, the afferent
version and :data:`CACHE_VERSION`. File names, folders and modification times are not part
of it: copying an export elsewhere still hits, changing one byte of it misses.

**The files the reader opened.** Which side files an export makes the reader open (the VTU
files of a ``.pvd``, the HDF5 and ``.bin`` files of an XDMF, the targets of HDF5 external
links) is known only by reading it, so they cannot be in a key computed before reading.
Instead each entry stores the list the reader itself reported
(:attr:`afferent.field.Provenance.files`, see ``afferent.io._raw``) with each file's size,
modification time and SHA-256 (:func:`file_records`), and :meth:`SEDCache.get` re-hashes
them: an entry one of whose files changed or disappeared is stale (ignored, deleted,
rebuilt). Whatever decides which side files are opened lies in the files opened before
them (an XDMF's text, an HDF5 file's links), so an unchanged list means the same files.
For an export copied to another folder, a file is looked for both where it was and at the
same place relative to the export; every one that exists must be unchanged.

**Never stale.** An entry stores its own key and the receptor positions; an entry whose
key or positions do not match, or that cannot be read (truncated, corrupt, written by
another version), is ignored, deleted and rebuilt. Entries are written to a temporary
name and renamed, so a crash never leaves half an entry under a valid name.

**Safe to delete.** :func:`clear_cache` (or ``rm -r`` of the folder) only costs the next
run its reading and sampling time.

Location: ``$AFFERENT_CACHE_DIR`` if set, else ``~/.cache/afferent``; entries live in
``<dir>/sed/<key[:2]>/<key>.npz``.
"""

from __future__ import annotations

from .receptors._layout import ReceptorLayout
from .sampling import ReceptorSED

from ._typing import ArrayLike, PathLike
from collections.abc import Sequence

import hashlib
import json
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

__all__ = [
    "CACHE_VERSION",
    "default_cache_dir",
    "file_records",
    "sampling_key",
    "positions_digest",
    "CachedSED",
    "SEDCache",
    "clear_cache",
]

#: Bumped whenever the entry layout, the meaning of a key or the sampling results change: old entries then miss.
#: 2: cell data averaged to nodes by whole cell volumes ('linear' on cell data changed); placement recorded.
#: 3: the key covers the named export files only; the entry lists (and get checks) every file the reader opened;
#: coincident points merged into nodes (discontinuous output changed); the interface side in the key.
#: point data in quadratic cells interpolated with their own shape functions (was: between corners).
#: 4: reads the unit and SED-array checks refuse (io._unit_physics) are no longer served from entries made before
#: them; the confirmed checks ([scene] accept) in the key.
#: 5: 'linear' in hexahedra, wedges and pyramids with their own shape functions (was: their split's tetrahedra).
CACHE_VERSION = 5

_SUBDIR = "sed"
_ARRAYS = ("values", "times", "positions", "ids", "longitudinal", "cross", "outside", "meta")


def default_cache_dir() -> Path:
    """``$AFFERENT_CACHE_DIR`` if set (and not empty), else ``~/.cache/afferent``."""
    env = os.environ.get("AFFERENT_CACHE_DIR")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "afferent"


def file_records(paths: Sequence[PathLike], hashes: dict | None = None) -> list[dict]:
    """``{'path', 'size', 'mtime_ns', 'sha256'}`` of each file (absolute path), for an entry's ``files``.

    Parameters
    ----------
    paths : sequence of str or path-like
        Files the reader opened (:attr:`afferent.field.Provenance.files`).
    hashes : dict, optional
        Path -> sha256 already computed (not hashed again); absolute or as given in ``paths``.

    Returns
    -------
    list of dict
        One per file without repeats, size in bytes, modification time in ns since the epoch.
    """
    from .export import file_sha256

    hashes = hashes or {}
    out, seen = [], set()
    for p in paths:
        given = os.fspath(p)
        full = os.path.abspath(given)
        if full in seen:
            continue
        seen.add(full)
        st = os.stat(full)
        sha = hashes.get(given) or hashes.get(full) or file_sha256(full)
        out.append({"path": full, "size": st.st_size, "mtime_ns": st.st_mtime_ns, "sha256": sha})
    return out


def _changed_file(records, base_then: str | None, base_now: str | None, hashes: dict) -> str | None:
    """Why an entry's files are stale (None: every one unchanged); fills ``hashes`` (path -> sha256)."""
    from .export import file_sha256

    for rec in records:
        where = [_now(rec["path"], base_then, base_now)]
        present = [p for p in where if os.path.isfile(p)]
        if not present:
            return f"file {rec['path']!r} read for the entry is missing; entry ignored"
        for p in present:
            if os.path.getsize(p) != rec["size"]:
                return f"file {p!r} changed since the entry was written (size); entry ignored"
            sha = hashes.get(p) or file_sha256(p)
            if sha != rec["sha256"]:
                return f"file {p!r} changed since the entry was written (content); entry ignored"
            hashes[p] = sha
    return None


def positions_digest(positions: ArrayLike) -> str:
    """SHA-256 of receptor positions (m) as C-ordered little-endian float64 bytes."""
    pos = np.ascontiguousarray(np.asarray(positions, dtype="<f8"))
    h = hashlib.sha256(str(pos.shape).encode())
    h.update(pos.tobytes())
    return h.hexdigest()


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def sampling_key(*, exports: Sequence[tuple[str, str]], read_options: dict, receptors: dict, method: str, side: str | int="average") -> str:
    """The cache key of one sampling: SHA-256 (hex) of a canonical JSON of everything it depends on.

    Parameters
    ----------
    exports : sequence of (str, str)
        ``(reader, content sha256)`` of every export file the user names, in order; the reader
        is the format deduced from the file name. The side files these make the reader open
        are checked by :meth:`SEDCache.get` (the entry's ``files``).
    read_options : dict
        The options passed to :func:`afferent.read_sed` (units, columns, ``sed_from``, ...),
        with file paths among them replaced by their content hashes.
    receptors : dict
        ``{'positions_sha256': ..., 'n': ...}`` (:func:`positions_digest`) for receptors known
        before reading, or the specification that finds them on the export.
    method : str
        Sampling method (``'linear'`` or ``'nearest'``).
    side : 'average' or int
        The side taken at receptors on a material interface (:func:`afferent.sample_sed`).

    Returns
    -------
    str
        64 hex digits.
    """
    from . import __version__

    payload = {
        "cache_version": CACHE_VERSION,
        "afferent": __version__,
        "exports": [list(e) for e in exports],
        "read_options": read_options,
        "receptors": receptors,
        "method": method,
        "side": side,
    }
    return hashlib.sha256(_canonical(payload).encode()).hexdigest()


@dataclass(frozen=True)
class CachedSED:
    """One cache entry: SED sampled at receptor sites, and what produced it.

    Parameters
    ----------
    values : ndarray of shape (n_times, n_receptors)
        SED in J/m^3 (NaN for receptors outside the field).
    times : ndarray of shape (n_times,)
        Step times in s.
    positions : ndarray of shape (n_receptors, 3)
        Receptor positions in m.
    ids : ndarray of shape (n_receptors,) of str
    longitudinal, cross : ndarray of shape (n_receptors,), int
        Section labels.
    outside : ndarray of shape (n_receptors,), bool
        Receptors outside the field.
    meta : dict
        The key, the method and placement, the field's provenance and size, when it was written,
        ``files`` (:func:`file_records` of every file the reader opened) and ``base`` (the
        folder of the first export file).
    path : str
        The entry's file.
    files : dict
        Path -> sha256 of the entry's files as checked by :meth:`SEDCache.get` (where they are now).
    """

    values: np.ndarray
    times: np.ndarray
    positions: np.ndarray
    ids: np.ndarray
    longitudinal: np.ndarray
    cross: np.ndarray
    outside: np.ndarray
    meta: dict
    path: str
    files: dict = field(default_factory=dict)

    def layout(self) -> ReceptorLayout:
        """The receptor sites as a :class:`~afferent.receptors.ReceptorLayout` (with the site kind they were stored with)."""
        from .receptors import ReceptorLayout

        return ReceptorLayout(self.positions, self.ids, self.longitudinal, self.cross, site=self.meta.get("site", "file"))

    def to_receptor_sed(self, layout: ReceptorLayout | None=None) -> ReceptorSED:
        """The entry as a :class:`~afferent.sampling.ReceptorSED` (on ``layout`` if given: same positions)."""
        from .sampling import ReceptorSED

        layout = self.layout() if layout is None else layout
        return ReceptorSED(self.values.copy(), self.times.copy(), layout, self.meta["method"], self.outside.copy(),
                           self.meta.get("placement", ""), time_unit=self.meta.get("time_unit") or (
                               "step" if ((self.meta.get("field") or {}).get("units") or {}).get("time") == "step"
                               else "s"))  # an entry written before time_unit was: its field's time unit


class SEDCache:
    """Sampled SED on disk, one ``.npz`` per key.

    Parameters
    ----------
    directory : str or path-like, optional
        Cache folder; default :func:`default_cache_dir`. Created on the first write.

    Examples
    --------
    >>> cache = SEDCache("/tmp/afferent-cache")  # doctest: +SKIP
    >>> cache.put(key, sed, meta={"provenance": field.provenance.to_dict()})  # doctest: +SKIP
    >>> cache.get(key).to_receptor_sed()  # doctest: +SKIP
    """

    def __init__(self, directory: PathLike | None=None) -> None:
        self.directory = Path(directory).expanduser() if directory is not None else default_cache_dir()
        #: Why the last :meth:`get` missed: 'no entry', 'corrupt entry ...', 'positions differ', or None after a hit.
        self.last_miss: str | None = None

    def path_for(self, key: str) -> Path:
        """File of the entry for ``key`` (it may not exist)."""
        if not re.fullmatch(r"[0-9a-f]{64}", str(key)):
            raise ValueError(f"'key' must be 64 lowercase hex digits (a sha256); got {key!r} instead.")
        return self.directory / _SUBDIR / key[:2] / f"{key}.npz"

    def _discard(self, path: Path, why: str) -> None:
        self.last_miss = why
        try:
            path.unlink()
        except OSError:
            pass

    def get(self, key: str, *, positions: ArrayLike | None=None, base: str | None = None, hashes: dict | None = None
            ) -> CachedSED | None:
        """The entry for ``key``, or None (no entry, or one that is corrupt, stale or does not match).

        Parameters
        ----------
        key : str
            From :func:`sampling_key`.
        positions : ndarray of shape (n_receptors, 3), optional
            Receptor positions in m the entry must hold exactly; an entry that does not is
            discarded.
        base : str, optional
            Folder of the first export file now; where the entry's files are also looked for
            when it was written for an export in another folder (see the module docstring).
        hashes : dict, optional
            Path -> sha256 of files already hashed (not hashed again).

        Every file the entry lists (the files the reader opened) is hashed again; an entry one
        of whose files changed or is missing is discarded (:attr:`last_miss` says which).
        """
        path = self.path_for(key)
        if not path.is_file():
            self.last_miss = "no entry"
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                missing = [a for a in _ARRAYS if a not in z.files]
                if missing:
                    raise ValueError(f"missing arrays {missing}")
                arrays = {a: z[a] for a in _ARRAYS}
            meta = json.loads(str(arrays.pop("meta")))
            if meta.get("key") != key or meta.get("cache_version") != CACHE_VERSION:
                raise ValueError("its key does not match its name")
            v, t, p = arrays["values"], arrays["times"], arrays["positions"]
            n = p.shape[0]
            if v.ndim != 2 or v.shape != (t.shape[0], n) or p.shape != (n, 3) or any(
                arrays[a].shape != (n,) for a in ("ids", "longitudinal", "cross", "outside")
            ):
                raise ValueError("inconsistent shapes")
            entry = CachedSED(
                values=v.astype(float), times=t.astype(float), positions=p.astype(float), ids=arrays["ids"].astype(str),
                longitudinal=arrays["longitudinal"].astype(np.int64), cross=arrays["cross"].astype(np.int64),
                outside=arrays["outside"].astype(bool), meta=meta, path=str(path),
            )
        except Exception as err:  # noqa: BLE001 - any unreadable entry is a miss, never an error
            self._discard(path, f"corrupt entry ignored ({type(err).__name__}: {err})")
            return None
        if positions is not None:
            pos = np.asarray(positions, dtype=float)
            if pos.shape != entry.positions.shape or not np.array_equal(pos, entry.positions):
                self._discard(path, "entry's receptor positions differ; ignored")
                return None
        checked = {os.path.abspath(p): h for p, h in (hashes or {}).items() if h}
        why = _changed_file(meta.get("files", ()), meta.get("base"), base, checked)
        if why is not None:
            self._discard(path, why)
            return None
        self.last_miss = None
        return replace(entry, files={p: checked[p] for p in checked if p in _where(meta, base)})

    def put(self, key: str, sed: ReceptorSED, *, meta: dict | None = None, files: Sequence[PathLike]=(), base: str | None = None) -> Path:
        """Store a :class:`~afferent.sampling.ReceptorSED` under ``key`` (atomically); returns the file.

        ``meta`` (JSON-able) is stored beside the arrays, with the key, the method, the
        placement (:attr:`~afferent.sampling.ReceptorSED.placement`) and :data:`CACHE_VERSION` added.
        ``files`` (:func:`file_records` of every file the reader opened) and ``base`` (the
        folder of the first export file) are what :meth:`get` checks.
        """
        path = self.path_for(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        lay = sed.layout
        info = dict(meta or {})
        info.update({"key": key, "cache_version": CACHE_VERSION, "method": sed.method,
                     "placement": getattr(sed, "placement", ""), "time_unit": getattr(sed, "time_unit", "s"),
                     "files": list(files), "site": lay.site,
                     "base": None if base is None else os.path.abspath(base)})
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".part", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(
                    f, values=np.asarray(sed.values, dtype=float), times=np.asarray(sed.times, dtype=float),
                    positions=lay.positions, ids=np.asarray(lay.ids).astype(str), longitudinal=lay.longitudinal,
                    cross=lay.cross, outside=np.asarray(sed.outside, dtype=bool),
                    meta=np.array(json.dumps(info, default=str)),
                )
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
        return path


def _now(path: str, base_then: str | None, base_now: str | None) -> str:
    """Where an entry's file is for the export as it is now: a file under the export's folder then, under its folder
    now (moved with it); any other file (outside the folder, allowed explicitly) where it was. Only there: a copy
    left in the old folder is never read (nothing is read that the user did not give)."""
    if not (base_then and base_now) or os.path.abspath(base_then) == os.path.abspath(base_now):
        return path
    rel = os.path.relpath(path, base_then)
    if rel == os.pardir or rel.startswith(os.pardir + os.sep):
        return path
    return os.path.normpath(os.path.join(os.path.abspath(base_now), rel))


def _where(meta: dict, base: str | None) -> set:
    """Where the entry's files were checked (:func:`_now`)."""
    return {_now(rec["path"], meta.get("base"), base) for rec in meta.get("files", ())}


def clear_cache(directory: PathLike | None=None) -> int:
    """Delete every cached entry; returns how many were removed.

    Parameters
    ----------
    directory : str or path-like, optional
        Cache folder; default :func:`default_cache_dir`. Only its ``sed/`` subfolder (the
        entries this module writes) is removed.
    """
    root = (Path(directory).expanduser() if directory is not None else default_cache_dir()) / _SUBDIR
    if not root.is_dir():
        return 0
    n = sum(1 for _ in root.rglob("*.npz"))
    shutil.rmtree(root, ignore_errors=True)
    return n
