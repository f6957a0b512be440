"""Sweeps: a study of many runs (scenes x parameter sets), run on Dask, gathered in one tidy table.

A sweep is a scene file with a ``[sweep]`` table::

    [export]                                   # ... any scene, as for `afferent run`
    file = "../block4/indent_0p88mm.vtu"
    ...
    [sweep]
    mode = "product"                           # every combination; "zip": the i-th values together
    "transduction.gamma_per_pa" = [2e-3, 4.6e-3, 1e-2]
    "spikes.gain_ms" = {start = 100, stop = 300, num = 5}   # a range (spacing = "log" for geometric)
    # scenes = ["a.toml", "b.toml"] or "folder": these scenes x the parameter sets (then no scene tables here)

A swept key is ``"table.key"`` with the key as a scene writes it (units in the name), or the
TOML dotted form ``transduction.gamma_per_pa = [...]``. Plain scene files and folders of them
are sweeps too (one task per scene).

::

    load_sweep(files) -> a specification, tasks counted (every written value checked as a scene)
        -> tasks made one at a time (an id and a group, no resolved scene: ~15 us each), dispatched in windows
           of a few thousand (records.py); each task's scene is built by the worker that runs it
        -> group tasks by what sampling depends on (export content, receptors, region, method)
        -> sample: one task per group, read + sample once (through the SED cache)
        -> batches of tasks on the sampled SED (stimulus, transduction, synthesis, fit, spikes)
        -> OUT/tasks/batch-*.jsonl (one JSON line per task) and index-*.json (its done tasks, for resume),
           OUT/table.csv (or .parquet), OUT/sweep.json

**Engines.** ``scheduler=None`` runs on Dask's local multiprocessing scheduler, one process
per core. Chosen by measurement (benchmarks/bench_sweep.py, 600 tasks, 3 interleaved rounds on
a shared 2-core machine): serial 9.4 s median (8.8 s best), threads 10.7 (9.0), processes 12.8
(8.6). Threads cannot gain: a task is many small numpy and pandas steps that hold the GIL, and
two threads' task times add up to 2.2x serial's (18.0 s against 8.3 s), so two at once run no
faster than one. Processes run tasks in parallel (each 1.4x slower while two share the two
cores, so 1.4x the throughput) and are the local engine that scales with free cores; each costs
a start-up (imports, the compiled LIF). They start by importing the calling script, so a script
must call :func:`sweep` under ``if __name__ == "__main__":`` (the error says so).
``'threads'`` / ``'processes'`` choose;
``'serial'`` runs in this process without Dask; an address (``'tcp://host:8786'``) or a
``distributed.Client`` runs on that cluster. Without Dask installed the local default
runs serially, with a one-line note: same tasks, same results.

**The SED cache on a cluster.** Locally, every worker shares this machine's disk, so the
sampling tasks go to the workers and use the cache. On a cluster, each worker is asked (once,
``Client.run``) whether it sees the export files (same size) and a token file this process has
just written into the cache folder; if every worker does, the disk is shared and sampling runs
on the cluster, cache included. Otherwise sampling runs here, with this machine's cache, and the
sampled SEDs are scattered to the workers: no worker reads an export or assumes a cache.

**Outputs** are written file by file, each atomically, as batches finish: a crash keeps what is
done. One file per batch, not per task: writing a file costs this machine ~0.5 ms, a record
serialised by its worker costs the writer almost nothing, and the writer (this process) must
keep up with every worker of a cluster. A re-run into the same folder skips the tasks whose records say 'ok' (resume) and retries
failed ones, reading each batch's index (records.index_of), or the batch where the index is not current; a folder holding another sweep is refused unless ``overwrite``, and then the new sweep
is written beside it and replaces it only when complete (``afferent._output.atomic_dir``: an
interrupted ``overwrite`` keeps the previous sweep whole).
"""

from __future__ import annotations

from .._typing import PathLike
from collections.abc import Sequence
from typing import Any

import itertools
import json
import os
import sys
import threading
import time
from dataclasses import dataclass, field

from ._local import run_local
from . import records as _records
from .records import _gather, _Ids
from .spec import SweepSpec, Task, load_sweep
from .table import COLUMNS, read_table

__all__ = ["sweep", "load_sweep", "SweepResult", "SweepSpec", "Task", "COLUMNS", "read_table", "LOCAL_DEFAULT"]

#: The local scheduler used by default (chosen by benchmarks/bench_sweep.py; see the module docstring).
LOCAL_DEFAULT = "processes"
_LOCAL = ("threads", "processes")


@dataclass(frozen=True)
class SweepResult:
    """What :func:`sweep` computed and wrote.

    Attributes
    ----------
    output : str
        The output folder.
    table : pandas.DataFrame
        One row per scene x parameter set x afferent (``COLUMNS``: name -> meaning), tasks that succeeded:
        read from ``table_path`` on first access (:func:`read_table`), not held by the sweep (it is
        streamed to its file as the records are gathered, so a sweep of 10^6 tasks never holds it).
    table_path : str
        ``table.csv`` or ``table.parquet`` (``table_format``).
    n_rows : int
        Rows of the table.
    n_tasks, n_ran, n_skipped, n_failed : int
        Tasks in the sweep; run now; skipped (done before: resume); failed.
    failures : list of dict
        Each failed task's id, scene, parameters and error.
    record : dict
        The content of ``sweep.json``.
    """

    output: str
    table_path: str
    n_tasks: int
    n_ran: int
    n_skipped: int
    n_failed: int
    failures: list = field(default_factory=list, repr=False)
    record: dict = field(default_factory=dict, repr=False)
    n_rows: int = 0
    _table: object = field(default=None, repr=False, compare=False)
    _stamp: tuple = field(default=(), repr=False, compare=False)

    @property
    def table(self):
        if self._table is None:
            if self._stamp and _stamp(self.table_path) != self._stamp:
                from ..exceptions import AfferentError

                raise AfferentError(f"{self.table_path!r} was rewritten after this sweep (a later run into its folder?): "
                                    "SweepResult.table reads the table from its file on first access; read it before "
                                    "running the sweep again, or read_table(path) for the table there now.")
            object.__setattr__(self, "_table", read_table(self.table_path))
        return self._table

    def __repr__(self) -> str:
        return (f"<SweepResult {self.output}: {self.n_tasks} tasks ({self.n_ran} run, {self.n_skipped} done before, "
                f"{self.n_failed} failed), {self.n_rows} rows in {os.path.basename(self.table_path)}>")


def _stamp(path: str) -> tuple:
    """What tells a file rewritten since: its inode, size and modification time (ns)."""
    st = os.stat(path)
    return st.st_ino, st.st_size, st.st_mtime_ns


def _note(message: str) -> None:
    print(f"afferent: note: {message}", file=sys.stderr)


def _write_json(path: str, data: dict) -> None:
    """Write sweep.json atomically and record it in its folder's record of afferent's files (afferent._owned)."""
    from .._output import atomic_file
    from .._owned import add_to_record
    from ..export import jsonable

    with atomic_file(path, overwrite=True) as tmp:
        with open(tmp, "w") as f:
            json.dump(jsonable(data), f, indent=1)
    add_to_record(os.path.dirname(path), [os.path.basename(path)], task_records=True)


def _inputs(spec: SweepSpec, probe) -> tuple:
    """The sweep files and every file its scenes read (``probe``: :meth:`SweepSpec.probe_tasks`): the output may
    not be, hold or lie inside one."""
    seen = dict.fromkeys(spec.sources)
    for t in probe:
        seen.update(dict.fromkeys(t.scene.input_files))
    return tuple(seen)


def _prepare(output: str, spec: SweepSpec, overwrite: bool, inputs: tuple) -> _Ids:
    """Check the output folder (``afferent._output.check_writable``); the ids of tasks done before (resume).

    A folder of the same sweep is resumed; with ``overwrite`` an existing folder is checked here and
    replaced only when the new sweep is complete (:func:`sweep`)."""
    from .._output import check_writable
    from ..exceptions import OutputExistsError

    record = os.path.join(output, "sweep.json")
    check_writable(output, overwrite=overwrite, what="Output folder", inputs=inputs, folder=True, resume=not overwrite)
    if overwrite or not os.path.lexists(output):
        return _Ids()
    if os.path.isfile(record):
        try:
            with open(record) as f:
                old = json.load(f)
        except (OSError, json.JSONDecodeError) as err:
            raise OutputExistsError(f"Output folder {output!r} holds an unreadable sweep.json ({err}); pass "
                                    "overwrite=True to replace the folder.") from err
        if old.get("sweep_digest") != spec.digest:
            raise OutputExistsError(
                f"Output folder {output!r} holds another sweep ({old.get('n_tasks')} tasks from "
                f"{', '.join(map(repr, old.get('sources', [])))}); a re-run resumes only the same sweep. Pass "
                "overwrite=True to replace it, or choose another folder.")
    elif os.listdir(output):
        raise OutputExistsError(f"Output folder {output!r} already exists and is not a sweep's (no sweep.json); "
                                "pass overwrite=True to replace it, or choose another folder.")
    hashes: dict = {}
    return _Ids(task for task, inputs in _records._done_records(output) if _inputs_unchanged(inputs, hashes))


def _inputs_unchanged(inputs, hashes: dict) -> bool:
    """Whether every file a task read (path -> sha256 in its record: the export's side files too) is unchanged.

    A task's id covers the files its scene names; the side files an export makes the reader open
    (HDF5 of an XDMF, VTU of a .pvd) are known from its record only. A record without them is redone.
    """
    from ..export import file_sha256

    if not isinstance(inputs, dict) or not inputs:
        return False
    for path, sha in inputs.items():
        if path not in hashes:
            hashes[path] = file_sha256(path) if os.path.isfile(path) else None
        if hashes[path] != sha:
            return False
    return True


def _open_folder(output: str, existed: bool) -> None:
    """Create the sweep's folder (refused if it appeared since the check) and its record of afferent's files
    (afferent._owned: the task records are proven by their names, sweep.json and the table recorded as written)."""
    from .._output import MARKER, _appeared
    from .._owned import add_to_record

    if not existed:
        try:
            os.mkdir(output)
        except FileExistsError:
            raise _appeared(output, "Output folder") from None
    os.makedirs(os.path.join(output, "tasks"), exist_ok=True)
    if not os.path.exists(os.path.join(output, MARKER)):
        add_to_record(output, task_records=True)


class _Sink:
    """Writes the records of each batch as it arrives (any thread) into one file, and drives the progress bar."""

    def __init__(self, output, total, progress: bool):
        self.output, self.lock = output, threading.Lock()
        self.batches: set = set()  # the batches written (a cluster's batch may be handed in twice)
        self.n, self.seconds = 0, 0.0  # tasks written, their seconds
        self.bar = None
        if progress:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, unit="task", desc="afferent sweep", file=sys.stderr)

    def __call__(self, items) -> None:
        import hashlib

        from .._output import atomic_file

        with self.lock:
            name = hashlib.sha256(",".join(i[0] for i in items).encode()).hexdigest()[:16]
            if not items or name in self.batches:
                return
            batch, index = (os.path.join(self.output, "tasks", f"{k}-{name}.{x}") for k, x in (("batch", "jsonl"),
                                                                                              ("index", "json")))
            if os.path.lexists(index):  # a batch rewritten (a re-run of the same tasks): never beside its old index
                os.remove(index)
            with atomic_file(batch, overwrite=True) as tmp:
                with open(tmp, "w") as f:
                    f.write("".join(i[3] + "\n" for i in items))
            with atomic_file(index, overwrite=True) as tmp:
                with open(tmp, "w") as f:  # what resume reads of the batch (records.index_of), written after it
                    json.dump(_records.index_of(batch, items), f, separators=(",", ":"))
            self.batches.add(name)
            self.n += len(items)
            self.seconds += sum(i[2] for i in items)
            if self.bar is not None:
                self.bar.update(len(items))

    def close(self):
        if self.bar is not None:
            self.bar.close()


# ---------------------------------------------------------------------------- engines
def _run_serial(windows, sink, *, cache_dir, use_cache, batch_size, info) -> None:
    """Each window's groups in turn in this process; a group is sampled once for the whole sweep."""
    from . import engine

    info.update(kind="serial", workers=1)
    done: dict = {}
    for groups in windows:
        for g, tasks in groups.items():
            if g not in done:
                done[g] = engine.sample(tasks[0], cache_dir, use_cache)
                info.setdefault("sampled", []).append({"where": done[g].where, "seconds": done[g].seconds})
            for b in engine.batches(tasks, 4, batch_size):
                sink(engine.run_batch(done[g], b))


def _shared_disk(client, exports, cache_dir) -> tuple[bool, str]:
    """Whether every worker sees the export files and the cache folder as this process does."""
    import secrets

    from ..cache import default_cache_dir

    folder = os.path.abspath(os.fspath(cache_dir)) if cache_dir is not None else str(default_cache_dir())
    try:
        os.makedirs(folder, exist_ok=True)
        token = secrets.token_hex(16)
        probe = os.path.join(folder, f".probe-{token}")
        with open(probe, "w") as f:
            f.write(token)
    except OSError as err:
        return False, f"the cache folder {folder!r} is not writable here ({err})"
    files = {p: os.path.getsize(p) for p in exports if os.path.isfile(p)}

    def check(probe=probe, token=token, files=files):
        try:
            with open(probe) as f:
                if f.read() != token:
                    return "cache token differs"
        except OSError:
            return "cache folder not visible"
        for p, size in files.items():
            if not os.path.isfile(p) or os.path.getsize(p) != size:
                return f"export {p} not visible"
        return None

    try:
        answers = client.run(check)
    finally:
        os.remove(probe)
    bad = {w: a for w, a in answers.items() if a is not None}
    if bad:
        w, a = next(iter(bad.items()))
        return False, f"{len(bad)} of {len(answers)} workers do not share this disk (e.g. {w}: {a})"
    return True, f"all {len(answers)} workers read a token file written into {folder!r} and see the export files"


def _run_cluster(windows, sink, *, scheduler, probe, cache_dir, use_cache, batch_size, shared_disk, progress,
                 info) -> None:
    """Each window's batches on a Dask cluster, one window at a time; a group is sampled once for the whole sweep."""
    import distributed

    own = not isinstance(scheduler, distributed.Client)
    client = distributed.Client(scheduler) if own else scheduler
    try:
        workers = client.scheduler_info().get("workers", {})
        slots = sum(w.get("nthreads", 1) for w in workers.values()) or 1
        if shared_disk is None:
            exports = sorted({p for t in probe for p in t.scene.export.files})
            shared, why = _shared_disk(client, exports, cache_dir)
        else:
            shared, why = bool(shared_disk), f"shared_disk={bool(shared_disk)} given"
        info.update(kind="dask-distributed", scheduler=str(client.scheduler.address), workers=len(workers),
                    threads=slots, cache_shared=shared, cache_why=why, batches=0,
                    sampling="on the cluster" if shared else "here, then scattered to the workers")
        side = sorted({p for t in probe for p in (t.scene.synthesis.map, t.scene.fit.observed, t.scene.stimulus.file,
                                                  t.scene.transduction.calibration) if p})
        if side and not shared:
            info["side_files"] = side
            _note(f"the workers do not share this disk, yet the tasks read {len(side)} small file(s) on them (e.g. "
                  f"{side[0]!r}): each must exist at the same path on every worker, else its tasks fail and are reported.")
        sampled: dict = {}  # group -> the future of its sampled SED, for every window
        for groups in windows:
            _cluster_window(client, groups, sink, sampled, shared=shared, slots=slots, cache_dir=cache_dir,
                            use_cache=use_cache, batch_size=batch_size, progress=progress, info=info)
    finally:
        if own:
            client.close()


def _cluster_window(client, groups, sink, sampled, *, shared, slots, cache_dir, use_cache, batch_size, progress,
                    info) -> None:
    from functools import partial

    import distributed

    from . import engine

    futures, members = [], {}
    for g, tasks in groups.items():
        if g not in sampled and shared:
            sampled[g] = client.submit(partial(engine.sample, tasks[0], cache_dir, use_cache), pure=False)
        elif g not in sampled:
            sampled[g] = client.scatter(engine.sample(tasks[0], cache_dir, use_cache))
        for b in engine.batches(tasks, slots, batch_size):
            f = client.submit(partial(engine.run_batch, tasks=b), sampled[g], pure=False)
            futures.append(f)
            members[f.key] = b
    info["batches"] += len(futures)

    def collect(f):
        try:
            sink(f.result())
        except Exception as err:  # noqa: BLE001 - a lost worker: its batch fails, the others stand
            sink(engine.failed_batch(members[f.key], f"the batch's worker failed: {type(err).__name__}: {err}"))

    for f in futures:
        f.add_done_callback(collect)
    if progress:
        distributed.progress(futures)
    distributed.wait(futures)
    for f in futures:  # callbacks run in another thread: make sure every batch is in
        collect(f)


# ------------------------------------------------------------------------------- API
def sweep(sources: PathLike | Sequence[PathLike], output: PathLike, *, scheduler: str | Any | None=None, overwrite: bool = False, cache_dir: PathLike | None=None, use_cache: bool = True,
          batch_size: int | None = None, shared_disk: bool | None = None, progress: bool = False,
          record_extra: dict | None = None, max_tasks: int | None = None, table_format: str = "csv") -> SweepResult:
    """Run a sweep: every scene x parameter set, each export read and sampled once; one tidy table.

    Parameters
    ----------
    sources : str, path-like or sequence of them
        Sweep files (a scene plus ``[sweep]``), scene files, or folders of them
        (:func:`load_sweep`).
    output : str or path-like
        Output folder: ``table.csv`` (or ``table.parquet``: ``table_format``), ``tasks/*.jsonl``
        (one record per task, a JSON line; one file per batch) and ``sweep.json``. An existing folder of the same sweep is
        resumed (tasks done are skipped); one of another sweep is refused unless ``overwrite``.
    scheduler : None, str or distributed.Client, optional
        None: Dask's local ``'processes'`` scheduler (:data:`LOCAL_DEFAULT`), or serial with a note
        when Dask is not installed; ``'threads'``, ``'processes'``, ``'serial'``; a scheduler
        address (``'tcp://host:8786'``) or a ``distributed.Client``.
    overwrite : bool, default=False
        Replace an existing output folder that afferent wrote (docs/cli.md, "Outputs and --overwrite"); the
        previous sweep stays whole until the new one is complete.
    cache_dir : str or path-like, optional
        Sampled-SED cache (:mod:`afferent.cache`); default ``$AFFERENT_CACHE_DIR`` or
        ``~/.cache/afferent``.
    use_cache : bool, default=True
        False: neither read nor write the cache.
    batch_size : int, optional
        Tasks per Dask task; default about four batches per worker thread (at most 64 tasks).
    shared_disk : bool, optional
        On a cluster: whether workers share this machine's disk (exports and cache); default:
        asked of the workers (see the module docstring).
    progress : bool, default=False
        A tqdm bar over tasks (locally), Dask's progress bar on a cluster.
    record_extra : dict, optional
        More entries for ``sweep.json`` (the command line).
    table_format : {'csv', 'parquet'}, default='csv'
        The table's format: ``table.csv``, or ``table.parquet`` (typed columns; needs pyarrow, checked
        before anything runs).
    max_tasks : int, optional
        Most tasks the sweep may have (default 1,000,000): counted before any task is made;
        more is refused (:func:`load_sweep`). The tasks are made as they are dispatched, in
        windows of ``afferent._sweep.records.WINDOW`` (4096); the table is streamed to its file.

    Returns
    -------
    SweepResult

    Raises
    ------
    SceneError, SceneTypeError, FileNotFoundError
        From :func:`load_sweep`, before anything runs.
    OutputExistsError
        ``output`` holds another sweep (or is not a sweep's folder) and ``overwrite`` is False; or
        it may not be replaced (an input, the working folder, a link, files afferent did not write).
    ImportError
        ``scheduler`` names a cluster or a Dask scheduler and Dask is not installed.

    Examples
    --------
    >>> res = sweep("sample_sed/scenes/sweep_gamma.toml", "results/sweep")  # doctest: +SKIP
    >>> res.table.groupby("transduction.gamma_per_pa").rate_hz.mean()  # doctest: +SKIP
    """
    from datetime import datetime, timezone

    from .. import __version__
    from .._output import atomic_dir
    from ..export import file_sha256

    import multiprocessing

    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # a worker process of the 'processes' scheduler importing an unguarded script: touch nothing
        raise RuntimeError("afferent.sweep(...) was called while a worker process imported the calling script; call "
                           "it under 'if __name__ == \"__main__\":' (or pass scheduler='threads' or 'serial').")
    from .table import check_table_format

    t0 = time.perf_counter()
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    check_table_format(table_format)
    spec = load_sweep(sources, max_tasks=max_tasks)
    output = os.path.abspath(os.fspath(output))
    probe = list(spec.probe_tasks())
    inputs = _inputs(spec, probe)
    done = _prepare(output, spec, overwrite, inputs)
    head = {"afferent_sweep": 2, "afferent": __version__, "started_utc": started,
            "sources": list(spec.sources), "sources_sha256": {p: file_sha256(p) for p in spec.sources},
            "mode": spec.mode, "keys": list(spec.keys), "sweep_digest": spec.digest, "n_tasks": spec.n_tasks,
            "specification": _specification(spec), **(record_extra or {})}
    run = dict(scheduler=scheduler, cache_dir=cache_dir, use_cache=use_cache, batch_size=batch_size,
               shared_disk=shared_disk, progress=progress, head=head, t0=t0, probe=probe, table_format=table_format)
    if overwrite and os.path.lexists(output):  # the previous sweep stays whole until this one is complete
        with atomic_dir(output, overwrite=True, inputs=inputs, task_records=True) as tmp:
            os.mkdir(os.path.join(tmp, "tasks"))
            table_path, full = _execute(spec, tmp, done, **run)
        table_path = os.path.join(output, os.path.basename(table_path))
    else:
        _open_folder(output, existed=os.path.lexists(output))
        table_path, full = _execute(spec, output, done, **run)
    return SweepResult(output=output, table_path=table_path, n_tasks=spec.n_tasks, n_rows=full["n_rows"],
                       n_ran=full["n_ran"], n_skipped=full["n_skipped"], n_failed=full["n_failed"],
                       failures=full["failures"], record=full, _stamp=_stamp(table_path))


def _specification(spec: SweepSpec) -> list:
    """What sweep.json records of the tasks: per sweep file, its mode, swept values (a range as written) and scenes."""
    def values(v):
        return {"start": v.start, "stop": v.stop, "num": v.num, "spacing": v.spacing} if hasattr(v, "spacing") else v

    return [{"file": path, "mode": mode, "params": {p: values(v) for p, (v, _) in params.items()},
             "scenes": [f for f, _, _ in bases]} for path, _, mode, params, bases in spec.plans]


def _execute(spec: SweepSpec, where: str, done: _Ids, *, scheduler, cache_dir, use_cache, batch_size, shared_disk,
             progress, head: dict, t0: float, probe: list, table_format: str = "csv"):
    """Run the tasks not ``done`` (made as they are dispatched) and write their records, the table and sweep.json."""
    _write_json(os.path.join(where, "sweep.json"), dict(head, status="running"))
    info: dict = {}
    kind = LOCAL_DEFAULT if scheduler in (None, "local") else scheduler
    if isinstance(kind, str) and kind in _LOCAL:
        try:
            import dask  # noqa: F401
        except ImportError:
            if spec.n_tasks > len(done):
                _note(f"Dask is not installed (pip install 'afferent-skin[dask]'): running the {spec.n_tasks} tasks "
                      "serially, same results.")
            info["why"] = "Dask is not installed"
            kind = "serial"
    elif not (isinstance(kind, str) and kind == "serial"):
        try:
            import distributed  # noqa: F401
        except ImportError as err:
            from ..exceptions import MissingExtraError

            raise MissingExtraError(f"scheduler={scheduler!r} needs Dask's distributed scheduler: pip install "
                              "'afferent-skin[dask]'.") from err
    sink = _Sink(where, max(0, spec.n_tasks - len(done)), progress=progress and (kind == "serial" or kind in _LOCAL))
    ids, counts = bytearray(), {"skipped": 0, "groups": 0}
    windows = _records._windows(spec, done, ids, counts)
    first = next(windows, None)
    windows = itertools.chain([first], windows) if first is not None else iter(())
    try:
        if first is None:
            info.update(kind="none", why="every task was done before (resume)")
        elif kind == "serial":
            _run_serial(windows, sink, cache_dir=cache_dir, use_cache=use_cache, batch_size=batch_size, info=info)
        elif kind in _LOCAL:
            run_local(windows, sink, kind=kind, cache_dir=cache_dir, use_cache=use_cache, batch_size=batch_size,
                      info=info)
        else:
            _run_cluster(windows, sink, scheduler=kind, probe=probe, cache_dir=cache_dir, use_cache=use_cache,
                         batch_size=batch_size, shared_disk=shared_disk, progress=progress, info=info)
    finally:
        sink.close()
    table_path, n_rows, columns, failures = _gather(where, _Ids.of(ids), spec.keys, table_format)
    full = dict(head, status="done" if not failures else "done, with failed tasks", engine=info,
                n_sampling_groups=counts["groups"], n_ran=sink.n, n_skipped=counts["skipped"],
                n_failed=len(failures), failures=failures, table=os.path.basename(table_path), n_rows=n_rows,
                columns={c: COLUMNS.get(c, "swept key, as written") for c in columns if c not in ("scene", "task")},
                task_seconds=sink.seconds, wall_seconds=time.perf_counter() - t0)
    _write_json(os.path.join(where, "sweep.json"), full)
    return table_path, full
