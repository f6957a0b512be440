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
    from ..io._files import open_regular

    folder = os.path.join(output, "tasks")
    for name in sorted(os.listdir(folder)) if os.path.isdir(folder) else ():
        if not name.endswith(".jsonl"):
            continue
        try:
            with open_regular(os.path.join(folder, name), "Sweep record", "rb") as f:
                lines = f.read().splitlines()
        except OSError:
            continue
        for line in lines:
            try:
                rec = json.loads(line)
            except ValueError:  # json.JSONDecodeError, or UnicodeDecodeError: bytes that are not UTF-8
                continue
            if isinstance(rec, dict) and isinstance(rec.get("task"), str):
                yield rec


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
