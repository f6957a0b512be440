"""On-disk cache of sampled SED (stage 2's output), so a re-run skips reading and sampling.

::

    export file(s) content + read options + receptor positions + sampling method
        --sampling_key--> key (sha256 hex)
    SEDCache(dir).get(key) -> CachedSED | None      SEDCache(dir).put(key, sed, meta=...)

Reading a large FE export and locating the receptors in its mesh are the slow stages of
a run; transduction, synthesis and spiking take milliseconds on the sampled values. A scene
(:mod:`afferent.scene`) re-run with other transduction, synthesis or spiking parameters
therefore finds its :class:`~afferent.sampling.ReceptorSED` here.

**What the key covers** (:func:`sampling_key`): the SHA-256 of the *content* of every file
the reader opens (the export(s), the VTU files a ``.pvd`` lists, the HDF5 files an XDMF
names, a ``coordinates`` table), the reader deduced from each file name, every read option
(units, ``sed_from``, columns, times, ...), the receptor positions (their float64 bytes) or,
for receptors found on the export itself (papilla tips, a grid over the export's extent),
the specification that finds them, the sampling method, the afferent version and
:data:`CACHE_VERSION`. File names, folders and modification times are not part of it:
copying an export elsewhere still hits, changing one byte of it misses.

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

import hashlib
import json
import os
import re
import shutil
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "CACHE_VERSION",
    "default_cache_dir",
    "export_files",
    "sampling_key",
    "positions_digest",
    "CachedSED",
    "SEDCache",
    "clear_cache",
]

#: Bumped whenever the entry layout, the meaning of a key or the sampling results change: old entries then miss.
#: 2: cell data averaged to nodes by whole cell volumes ('linear' on cell data changed); placement recorded.
#: 3: point data in quadratic cells interpolated with their own shape functions (was: between corners).
CACHE_VERSION = 3

_SUBDIR = "sed"
_ARRAYS = ("values", "times", "positions", "ids", "longitudinal", "cross", "outside", "meta")


def default_cache_dir() -> Path:
    """``$AFFERENT_CACHE_DIR`` if set (and not empty), else ``~/.cache/afferent``."""
    env = os.environ.get("AFFERENT_CACHE_DIR")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "afferent"


def export_files(paths) -> list[str]:
    """Every file the reader opens for ``paths``, in order: each path, then the files it names.

    A ``.pvd`` collection names its VTU steps (``<DataSet file=...>``, relative to the
    ``.pvd``); an XDMF file names HDF5 files (``file.h5:/dataset``). Files that do not exist
    are left out here: reading then fails with its own message.

    Parameters
    ----------
    paths : str, path-like or sequence of them

    Returns
    -------
    list of str
        Absolute paths, without duplicates.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    out: list[str] = []
    for p in paths:
        p = os.path.abspath(os.fspath(p))
        out.append(p)
        lower = p.lower()
        folder = os.path.dirname(p)
        try:
            if lower.endswith(".pvd"):
                for ds in ET.parse(p).getroot().iter("DataSet"):
                    f = ds.get("file")
                    if f:
                        out.append(os.path.abspath(os.path.join(folder, f)))
            elif lower.endswith((".xdmf", ".xmf")):
                text = Path(p).read_text(errors="replace")
                for name in re.findall(r"([^\s<>\"']+\.(?:h5|hdf5|hdf))\s*:", text):
                    out.append(os.path.abspath(os.path.join(folder, name)))
        except (OSError, ET.ParseError):
            pass  # unreadable: read_sed reports it
    seen, unique = set(), []
    for f in out:
        if f not in seen and os.path.isfile(f):
            seen.add(f)
            unique.append(f)
    return unique


def positions_digest(positions) -> str:
    """SHA-256 of receptor positions (m) as C-ordered little-endian float64 bytes."""
    pos = np.ascontiguousarray(np.asarray(positions, dtype="<f8"))
    h = hashlib.sha256(str(pos.shape).encode())
    h.update(pos.tobytes())
    return h.hexdigest()


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)


def sampling_key(*, exports, read_options: dict, receptors: dict, method: str) -> str:
    """The cache key of one sampling: SHA-256 (hex) of a canonical JSON of everything it depends on.

    Parameters
    ----------
    exports : sequence of (str, str)
        ``(reader, content sha256)`` of every file the reader opens, in order (see
        :func:`export_files`); the reader is the format deduced from the file name.
    read_options : dict
        The options passed to :func:`afferent.read_sed` (units, columns, ``sed_from``, ...),
        with file paths among them replaced by their content hashes.
    receptors : dict
        ``{'positions_sha256': ..., 'n': ...}`` (:func:`positions_digest`) for receptors known
        before reading, or the specification that finds them on the export.
    method : str
        Sampling method (``'linear'`` or ``'nearest'``).

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
        The key, the method and placement, the field's provenance and size, when it was written.
    path : str
        The entry's file.
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

    def layout(self):
        """The receptor sites as a :class:`~afferent.receptors.ReceptorLayout`."""
        from .receptors import ReceptorLayout

        return ReceptorLayout(self.positions, self.ids, self.longitudinal, self.cross)

    def to_receptor_sed(self, layout=None):
        """The entry as a :class:`~afferent.sampling.ReceptorSED` (on ``layout`` if given: same positions)."""
        from .sampling import ReceptorSED

        layout = self.layout() if layout is None else layout
        return ReceptorSED(self.values.copy(), self.times.copy(), layout, self.meta["method"], self.outside.copy(),
                           self.meta.get("placement", ""))


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

    def __init__(self, directory=None):
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

    def get(self, key: str, *, positions=None) -> CachedSED | None:
        """The entry for ``key``, or None (no entry, or one that is corrupt or does not match).

        Parameters
        ----------
        key : str
            From :func:`sampling_key`.
        positions : ndarray of shape (n_receptors, 3), optional
            Receptor positions in m the entry must hold exactly; an entry that does not is
            discarded.
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
        self.last_miss = None
        return entry

    def put(self, key: str, sed, *, meta: dict | None = None) -> Path:
        """Store a :class:`~afferent.sampling.ReceptorSED` under ``key`` (atomically); returns the file.

        ``meta`` (JSON-able) is stored beside the arrays, with the key, the method, the
        placement (:attr:`~afferent.sampling.ReceptorSED.placement`) and :data:`CACHE_VERSION` added.
        """
        path = self.path_for(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        lay = sed.layout
        info = dict(meta or {})
        info.update({"key": key, "cache_version": CACHE_VERSION, "method": sed.method,
                     "placement": getattr(sed, "placement", "")})
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


def clear_cache(directory=None) -> int:
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
