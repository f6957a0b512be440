"""What afferent wrote in an output folder: the record :data:`MARKER`, the proof that a folder holds
nothing else, and the removal of exactly those files (docs/cli.md, "Outputs and --overwrite").

The record names each file afferent wrote, one by one, with its size (bytes) and SHA-256, and each
subfolder it made. A folder may be replaced (``overwrite``) only if every entry below it is proven
afferent's:

- a file named in the record whose size and SHA-256 are still those recorded (a file changed since,
  or written by hand under a recorded name, is not afferent's);
- a subfolder named in the record; the record itself;
- in a sweep's folder (``task_records``), a task-record file ``tasks/batch-<16 hex>.jsonl`` whose
  every line is a task record (``{"task":"<id>",...``) and whose 16 hex digits are the start of the
  SHA-256 of its task ids joined by commas, the name afferent gives it (:mod:`afferent._sweep`); and its
  index ``tasks/index-<16 hex>.json``, a JSON object whose ``tasks`` (the ids) give the same digits;
- a temporary that afferent's writers name ``.<name>.<8 characters>.part``, left by a killed
  process, for a ``<name>`` proven above in the same folder.

Nothing else: no patterns, no record found below the folder, no file kinds. A record without
checksums (one written by hand, or by an afferent before this record existed) proves nothing; such a
folder the user deletes. Links, FIFOs and devices are never afferent's.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
import tempfile

from .exceptions import OutputExistsError

__all__ = ["MARKER", "write_record", "add_to_record", "recorded", "owned", "remove_owned", "public"]

#: the file in every output folder recording what afferent wrote there (the only files ``overwrite`` deletes)
MARKER = ".afferent-output.json"
#: the record's format: 2 = each file with its size and SHA-256 (1, a list of names and patterns, proved nothing)
FORMAT = 2
#: a sweep's folder of task records
TASKS = "tasks"
_SWEEP_FILES = ("sweep.json", "table.parquet", "table.csv")  # a sweep's files, written in place, then recorded
_BATCH = re.compile(r"batch-([0-9a-f]{16})\.jsonl|index-([0-9a-f]{16})\.json")  # a batch, its index
_TASK_LINE = re.compile(rb'\{"task":"([^"\\]+)"')
_TEMPORARY = re.compile(r"\.(.+)\.[a-z0-9_]{8}\.part")  # tempfile's names: prefix '.NAME.', 8 characters, '.part'


def _umask() -> int:
    """The process umask (read by setting it and putting it back: os has no getter)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def public(path: str, *, folder: bool) -> None:
    """Give a temporary file or folder the mode ordinary creation would have given it.

    ``tempfile`` creates them private (0600 files, 0700 folders) whatever the umask; results
    renamed into place would keep that, and colleagues on a shared server could not read them.
    """
    os.chmod(path, (0o777 if folder else 0o666) & ~_umask())


def _regular(path: str):
    """``path`` opened for binary reading if it is a regular file (a link not followed, a FIFO not waited on);
    None for anything else."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        return None
    return os.fdopen(fd, "rb")


def _entry(path: str) -> dict | None:
    """{'size': bytes, 'sha256': hex} of a regular file (not followed if a link); None for anything else."""
    f = _regular(path)
    if f is None:
        return None
    with f:
        return {"size": os.fstat(f.fileno()).st_size, "sha256": hashlib.file_digest(f, "sha256").hexdigest()}


def _walk(folder: str):
    """(relative '/'-separated path, os.DirEntry) of everything below ``folder``, links not followed."""
    stack = [""]
    while stack:
        rel = stack.pop()
        with os.scandir(os.path.join(folder, rel) if rel else folder) as it:
            for e in it:
                name = f"{rel}/{e.name}" if rel else e.name
                yield name, e
                if e.is_dir(follow_symlinks=False):
                    stack.append(name)


def write_record(folder: str, *, task_records: bool = False) -> None:
    """Write :data:`MARKER` in ``folder``, a folder afferent has just written whole (its temporary, private
    folder): every file with its size and SHA-256, every subfolder; with ``task_records``, a sweep's task-record
    files are proven by their names instead (module docstring) and not listed."""
    files, folders = {}, []
    for rel, e in _walk(folder):
        if e.is_dir(follow_symlinks=False):
            folders.append(rel)
        elif rel != MARKER and not (task_records and _batch(rel)):
            files[rel] = _entry(e.path)
    _save(folder, {"files": files, "folders": sorted(folders), "task_records": task_records})


def add_to_record(folder: str, names=(), *, drop=(), task_records: bool = False) -> None:
    """Record files afferent has just written in ``folder`` (a sweep writing in its own folder), and ``drop``
    files it removed; a folder without afferent's record of this format starts one (with the ``tasks`` folder
    when ``task_records``) that names only these files."""
    record = _load(folder) or {"files": {}, "folders": [TASKS] if task_records else [], "task_records": task_records}
    for name in drop:
        record["files"].pop(name, None)
    for name in names:
        record["files"][name] = _entry(os.path.join(folder, name))
    _save(folder, record)


def recorded(folder: str, name: str) -> bool:
    """``folder``/``name`` is a file afferent wrote, as its record says (same size and SHA-256)."""
    record = _load(folder)
    want = record["files"].get(name) if record else None
    return want is not None and _entry(os.path.join(folder, name)) == want


def _save(folder: str, record: dict) -> None:
    from . import __version__

    record = {"afferent_output": FORMAT, "afferent": __version__, **record}
    fd, tmp = tempfile.mkstemp(prefix=f"{MARKER}.", suffix=".part", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(record, f, indent=1)
        public(tmp, folder=False)
        os.replace(tmp, os.path.join(folder, MARKER))
    finally:
        if os.path.lexists(tmp):
            os.remove(tmp)


def _load(folder: str) -> dict | None:
    """The record of ``folder`` if it is afferent's of this format (each file with a size and a SHA-256), else None."""
    try:
        with open(os.path.join(folder, MARKER), encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    if not (isinstance(data, dict) and data.get("afferent_output") == FORMAT and isinstance(data.get("files"), dict)
            and isinstance(data.get("folders"), list)):
        return None
    if not all(isinstance(v, dict) and isinstance(v.get("size"), int) and isinstance(v.get("sha256"), str)
               for v in data["files"].values()):
        return None
    return data


def _batch(rel: str) -> re.Match | None:
    head, _, name = rel.rpartition("/")
    return _BATCH.fullmatch(name) if head == TASKS else None


def _task_file(path: str, digits: str) -> bool:
    """A sweep's task-record file as afferent names it: every line a record, the name from its task ids."""
    f = _regular(path)
    if f is None:
        return False
    with f:
        ids = []
        for line in f:
            m = _TASK_LINE.match(line)
            if m is None:
                return False
            ids.append(m.group(1))
    return bool(ids) and hashlib.sha256(b",".join(ids)).hexdigest()[:16] == digits


def _index_file(path: str, digits: str) -> bool:
    """A batch's index as afferent writes it (afferent._sweep.records.index_of): its task ids give its name."""
    f = _regular(path)
    if f is None:
        return False
    with f:
        try:
            index = json.loads(f.read())
            ids = index["tasks"]
            return (isinstance(index, dict) and "afferent_sweep_index" in index and isinstance(ids, list) and bool(ids)
                    and all(isinstance(i, str) for i in ids)
                    and hashlib.sha256(",".join(ids).encode()).hexdigest()[:16] == digits)
        except (ValueError, KeyError, TypeError):
            return False


def owned(folder: str, what: str, shown: str | None = None) -> list[str]:
    """Prove that afferent wrote everything in ``folder`` (module docstring); the paths to delete, deepest first.

    Raises
    ------
    OutputExistsError
        Something in it is not proven afferent's: named (``shown``: the folder's name in the message).
    """
    shown = folder if shown is None else shown
    entries = list(_walk(folder))
    if not entries:
        return []
    record = _load(folder)
    if record is None:
        if not any(rel == MARKER for rel, _ in entries):
            raise OutputExistsError(f"{what} {shown!r} was not written by afferent (it has no {MARKER}, the record of "
                                    "each file afferent wrote there; nor have folders of afferent versions before the "
                                    "record); overwrite=True deletes only files afferent can prove it wrote: move its "
                                    "contents away or delete it yourself, or choose another folder.")
        raise OutputExistsError(f"{what} {shown!r} has a {MARKER} that is not afferent's record of its files (each "
                                "file with its size and SHA-256: one written by hand, or by an earlier afferent); "
                                "overwrite=True deletes only files afferent can prove it wrote: delete the folder "
                                "yourself, or choose another folder.")
    foreign, changed = _unproven(entries, record)
    if foreign or changed:
        raise OutputExistsError(_refusal(what, shown, foreign, changed))
    return [e.path for _, e in sorted(entries, key=lambda x: -x[0].count("/"))]


def _unproven(entries, record: dict) -> tuple[list, list]:
    """The entries not proven afferent's: (foreign ones, recorded files changed since)."""
    files, folders = record["files"], set(record["folders"])
    tasks = bool(record.get("task_records"))
    known = {MARKER, *files, *(_SWEEP_FILES if tasks else ())}  # names whose temporaries may be left
    foreign, changed, maybe = [], [], []
    for rel, e in entries:
        if e.is_dir(follow_symlinks=False):
            if rel not in folders and not (tasks and rel == TASKS):
                foreign.append(rel)
        elif rel in files or rel == MARKER:
            maybe.append((rel, e))
        elif tasks and _batch(rel) and e.is_file(follow_symlinks=False):
            maybe.append((rel, e))
        elif _temporary_of(rel, e, known, tasks):
            continue
        else:
            foreign.append(rel)
    if foreign:  # said before any file is read
        return foreign, []
    for rel, e in maybe:
        if rel == MARKER:
            continue
        if rel in files:
            want = files[rel]
            try:
                size = e.stat(follow_symlinks=False).st_size
            except OSError:
                size = None
            if size != want["size"] or _entry(e.path) != want:
                changed.append(rel)
        elif not (_task_file(e.path, _batch(rel).group(1)) if _batch(rel).group(1) else
                  _index_file(e.path, _batch(rel).group(2))):
            foreign.append(rel)
    return foreign, changed


def _temporary_of(rel: str, e, known: set, tasks: bool) -> bool:
    """``rel`` is a temporary file of afferent's writers (``.NAME.xxxxxxxx.part``) for a NAME it writes there."""
    m = _TEMPORARY.fullmatch(os.path.basename(rel))
    if m is None or not e.is_file(follow_symlinks=False):
        return False
    head = os.path.dirname(rel)
    name = f"{head}/{m.group(1)}" if head else m.group(1)
    return name in known or bool(tasks and _batch(name))


def _refusal(what: str, shown: str, foreign: list, changed: list) -> str:
    def listed(names):
        return ", ".join(map(repr, names[:3])) + (f" and {len(names) - 3} more" if len(names) > 3 else "")

    parts = []
    if foreign:
        parts.append(f"files afferent did not write ({listed(foreign)})")
    if changed:
        parts.append(f"files changed since afferent wrote them ({listed(changed)})")
    return (f"{what} {shown!r} holds {' and '.join(parts)}; overwrite=True would delete them: move them away or "
            "choose another folder.")


def remove_owned(paths: list[str], folder: str) -> bool:
    """Delete ``paths`` (from :func:`owned`: files, then their folders, deepest first) and ``folder``; False if
    something appeared meanwhile (a folder not empty: then it and what appeared are kept)."""
    try:
        for path in paths:
            if os.path.isdir(path) and not os.path.islink(path):
                os.rmdir(path)
            else:
                try:
                    os.unlink(path)
                except FileNotFoundError:
                    pass
        os.rmdir(folder)
    except OSError:
        return False
    return True
