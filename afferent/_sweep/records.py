"""The task stream's bookkeeping: task ids in 8 bytes each, the windows of tasks dispatched, the records read back.

A sweep's tasks are made one at a time (:meth:`~afferent._sweep.spec.SweepSpec.iter_tasks`) and
handed to the engines in windows of at most :data:`WINDOW` tasks; what stays in memory for the
whole sweep is 8 bytes per task (its id, to keep the table to this sweep's tasks); the table is streamed to
its file as the records are gathered (:func:`_gather`).
"""

from __future__ import annotations

import json
import os
import sys

class _Ids:
    """A set of task ids (16 hex digits) as a sorted array of 8-byte integers: 8 bytes a task, not ~100."""

    def __init__(self, ids=()):
        import numpy as np

        self.array = np.unique(np.fromiter((int(i, 16) for i in ids), dtype=np.uint64))

    @classmethod
    def of(cls, ints):
        import numpy as np

        out = cls()
        out.array = np.unique(np.frombuffer(ints, dtype=np.uint64)) if len(ints) else out.array
        return out

    def __len__(self) -> int:
        return len(self.array)

    def __contains__(self, task_id) -> bool:
        import numpy as np

        v = np.uint64(int(task_id, 16))
        i = int(np.searchsorted(self.array, v))
        return i < len(self.array) and self.array[i] == v


#: Tasks made and dispatched at a time: each held as a resolved scene (~8 KiB) until its window is done.
WINDOW = 4096


def _windows(spec, done: _Ids, ids: bytearray, counts: dict):
    """The tasks not ``done``, made one at a time, handed out as {group: [tasks]} of at most :data:`WINDOW` tasks.

    Every task's id goes into ``ids`` (8 bytes each); ``counts``: skipped, sampling groups seen."""
    window, n, groups = {}, 0, set()
    for t in spec.iter_tasks():
        ids += int(t.id, 16).to_bytes(8, sys.byteorder)
        groups.add(t.group)
        counts["groups"] = len(groups)
        if t.id in done:
            counts["skipped"] += 1
            continue
        window.setdefault(t.group, []).append(t)
        n += 1
        if n >= WINDOW:
            yield window
            window, n = {}, 0
    if window:
        yield window


def _iter_records(output: str):
    """Every task record of ``tasks/*.jsonl``, one at a time (a line that is not a record is skipped: it runs again;
    so is a line that is not UTF-8 JSON, read as bytes: a damaged file's other lines are still records; a file
    that is not a regular file - a FIFO would block - is refused, naming it)."""
    folder = os.path.join(output, "tasks")
    for name in sorted(os.listdir(folder)) if os.path.isdir(folder) else ():
        if name.endswith(".jsonl"):
            yield from _file_records(os.path.join(folder, name))


def _file_records(path: str):
    """The task records of one batch file (:func:`_iter_records`); nothing if it cannot be read."""
    from ..io._files import open_regular

    try:
        with open_regular(path, "Sweep record", "rb") as f:
            lines = f.read().splitlines()
    except OSError:
        return
    for line in lines:
        try:
            rec = json.loads(line)
        except ValueError:  # json.JSONDecodeError, or UnicodeDecodeError: bytes that are not UTF-8
            continue
        if isinstance(rec, dict) and isinstance(rec.get("task"), str):
            yield rec


#: An index's format (``tasks/index-<name>.json`` beside ``tasks/batch-<name>.jsonl``).
INDEX_FORMAT = 1


def index_of(batch: str, items) -> dict:
    """The index of a batch file just written (``items``: :func:`engine.run_batch`'s tuples, in the batch's order).

    What resume needs of a batch, without its records: every task id in order (afferent's name for both files
    is the start of the SHA-256 of these ids joined by commas: ``afferent._owned`` proves an index by it), the
    tasks that succeeded with the files each read (path -> SHA-256; the distinct sets once each), and the batch
    file's size (bytes) and modification time (ns) when written: a batch that differs from them is read instead.
    """
    st = os.stat(batch)
    sets: dict = {}
    ok = {}
    for i in items:
        if i[1] == "ok":
            key = tuple(sorted(i[4].items())) if isinstance(i[4], dict) else None
            ok[i[0]] = sets.setdefault(key, len(sets))
    return {"afferent_sweep_index": INDEX_FORMAT, "batch": os.path.basename(batch), "size": st.st_size,
            "mtime_ns": st.st_mtime_ns, "tasks": [i[0] for i in items], "ok": ok,
            "inputs": [None if k is None else dict(k) for k in sets]}


def _indexed(folder: str, name: str) -> list | None:
    """``[(task id, inputs)]`` of the 'ok' tasks of batch ``name`` from its index, or None (scan the batch): no index,
    unreadable, another format, or stale - the batch's size or modification time not those recorded, or the index's
    tasks not consistent with the batch's name and with themselves. An index is never trusted over its batch."""
    import hashlib
    import stat

    from ..io._files import open_regular

    stem = name[len("batch-"):-len(".jsonl")] if name.startswith("batch-") else None
    if stem is None:
        return None
    try:
        st = os.stat(os.path.join(folder, name))
        with open_regular(os.path.join(folder, f"index-{stem}.json"), "Sweep index", "rb") as f:
            index = json.loads(f.read())
    except Exception:  # noqa: BLE001 - missing, unreadable, not a regular file, not JSON: the batch is read instead
        return None
    try:
        if (not stat.S_ISREG(st.st_mode) or index.get("afferent_sweep_index") != INDEX_FORMAT
                or index.get("batch") != name or index.get("size") != st.st_size
                or index.get("mtime_ns") != st.st_mtime_ns):
            return None
        tasks, ok, inputs = index["tasks"], index["ok"], index["inputs"]
        if (not isinstance(tasks, list) or not tasks or not all(isinstance(t, str) for t in tasks)
                or not isinstance(ok, dict) or not isinstance(inputs, list) or not set(ok) <= set(tasks)
                or not all(type(k) is int and 0 <= k < len(inputs) for k in ok.values())
                or hashlib.sha256(",".join(tasks).encode()).hexdigest()[:16] != stem):
            return None
        return [(t, inputs[k]) for t, k in ok.items()]
    except (KeyError, TypeError, AttributeError):
        return None


def _done_records(output: str):
    """``(task id, inputs)`` of every 'ok' task record of ``tasks/*.jsonl`` (resume): from each batch's index where it
    is current (:func:`_indexed`), else from the batch's records (:func:`_file_records`)."""
    folder = os.path.join(output, "tasks")
    for name in sorted(os.listdir(folder)) if os.path.isdir(folder) else ():
        if not name.endswith(".jsonl"):
            continue
        done = _indexed(folder, name)
        if done is None:
            done = ((r["task"], r.get("inputs")) for r in _file_records(os.path.join(folder, name))
                    if r.get("status") == "ok")
        yield from done


#: Rows held at a time while the table is gathered: a bucket of tasks written at once, and the rows read and not
#: yet put aside (the bound on the table's memory: ~0.3 kB a row in pandas).
BUCKET_ROWS = 20_000


def _gather(where: str, ids: _Ids, keys, table_format: str = "csv") -> tuple:
    """Write the table (this sweep's 'ok' records, in task order, one per task) to its file, streamed; return
    ``(path, rows, columns, failures)``, the failed tasks' summaries.

    The records are read once, file by file (in no particular task order: a batch file is named by its
    tasks); each 'ok' record's rows, as tuples, go to the bucket of its task index (``index // width``, width
    such that a bucket holds ~:data:`BUCKET_ROWS` rows), put aside (pickled) into an anonymous temporary file
    as buffers fill; then each bucket in turn is read back, ordered by task index and appended to the table
    (:func:`table.table_writer`: a Parquet row group, a CSV chunk). Memory: 16 bytes a task (its id and index,
    to keep each task's first record) and ~2 buckets of rows, not the table (was: all of it in memory, ~0.6 GB
    for 10^6 tasks of 3 rows).
    """
    import pickle
    import tempfile
    from array import array

    import numpy as np

    from .table import columns_of, table_writer

    columns = columns_of(keys)
    task, failed = array("Q"), {}
    kinds: dict = {k: set() for k in keys}
    width, held, buffers, pieces = None, 0, {}, {}

    def put_aside(spill):
        nonlocal held
        for b, buf in buffers.items():
            pieces.setdefault(b, []).append(spill.tell())
            pickle.dump(buf, spill, protocol=pickle.HIGHEST_PROTOCOL)
        buffers.clear()
        held = 0

    with tempfile.TemporaryFile(dir=where) as spill:
        for rec in _iter_records(where):
            if rec["task"] not in ids:
                continue  # a task of this sweep's folder no longer in it (an input changed)
            if rec.get("status") == "ok":
                rows = rec.get("rows") or []
                for k in keys:
                    kinds[k].update(type(r.get(k)) for r in rows[:1])
                index = int(rec.get("index", 0))
                width = width or max(1, BUCKET_ROWS // max(1, len(rows)))
                buffers.setdefault(index // width, []).append(
                    (index, len(task), [tuple(r.get(c) for c in columns) for r in rows]))
                task.append(int(rec["task"], 16))
                held += len(rows) + 1
                if held >= BUCKET_ROWS:
                    put_aside(spill)
            else:
                failed[rec["task"]] = (rec.get("index", 0), {k: rec.get(k) for k in ("task", "scene", "scene_file",
                                                                                  "params", "stage", "error")})
        put_aside(spill)
        task_ids = np.frombuffer(task, dtype=np.uint64) if len(task) else np.zeros(0, np.uint64)
        keep = np.zeros(len(task_ids), dtype=bool)  # each task's first record (a task recorded twice: once)
        keep[np.unique(task_ids, return_index=True)[1]] = True
        with table_writer(where, table_format, keys, kinds) as write:
            for b in sorted(pieces):
                bucket = []
                for offset in pieces[b]:
                    spill.seek(offset)
                    bucket.extend(t for t in pickle.load(spill) if keep[t[1]])
                bucket.sort(key=lambda t: (t[0], t[1]))  # task order; a record read earlier first
                write([r for t in bucket for r in t[2]])
        done = _Ids.of(task_ids.tobytes())
    failures = [f for k, (_, f) in sorted(failed.items(), key=lambda kv: kv[1][0]) if k not in done]
    return write.path, write.rows, write.columns, failures
