"""The task stream's bookkeeping: task ids in 8 bytes each, the windows of tasks dispatched, the records read back.

A sweep's tasks are made one at a time (:meth:`~afferent._sweep.spec.SweepSpec.iter_tasks`) and
handed to the engines in windows of at most :data:`WINDOW` tasks; what stays in memory for the
whole sweep is 8 bytes per task (its id, to keep the table to this sweep's tasks) and the table.
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


def _gather(where: str, ids: _Ids, keys) -> tuple:
    """The table (this sweep's 'ok' records, in task order, one per task) and the failed tasks' summaries.

    Read file by file and assembled in chunks: the records are never all in memory, only the table."""
    import numpy as np
    import pandas as pd

    from .table import assemble

    frames, chunk, ok, failed = [], [], bytearray(), {}

    def flush():
        if chunk:
            df = assemble(chunk, keys)
            df.insert(0, "_index", np.repeat([r.get("index", 0) for r in chunk], [len(r.get("rows", [])) for r in chunk]))
            frames.append(df)
            chunk.clear()

    for rec in _iter_records(where):
        if rec["task"] not in ids:
            continue  # a task of this sweep's folder no longer in it (an input changed)
        if rec.get("status") == "ok":
            ok += int(rec["task"], 16).to_bytes(8, sys.byteorder)
            chunk.append({"status": "ok", "index": rec.get("index", 0), "rows": rec.get("rows", [])})  # the rest let go
            if len(chunk) >= 512:
                flush()
        else:
            failed[rec["task"]] = (rec.get("index", 0), {k: rec.get(k) for k in ("task", "scene", "scene_file", "params",
                                                                              "stage", "error")})
    flush()
    table = pd.concat(frames, ignore_index=True) if frames else assemble([], keys).assign(_index=0)
    table = table.drop_duplicates(subset=["task", "afferent"]).sort_values("_index", kind="stable")
    table = table.drop(columns="_index").reset_index(drop=True)
    done = _Ids.of(ok)
    failures = [f for k, (_, f) in sorted(failed.items(), key=lambda kv: kv[1][0]) if k not in done]
    return table, failures
