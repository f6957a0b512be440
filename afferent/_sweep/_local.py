"""Sweeps on this machine's Dask schedulers (threads, processes): the task graph, the workers' lives.

The worker processes die with the sweep (``engine.worker_init``); SIGTERM ends them at once
(:func:`_sigterm_ends`); a worker killed on its own is named with its signal (:func:`_worker_death`).
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading

__all__ = ["run_local"]


def run_local(windows, sink, *, kind, cache_dir, use_cache, batch_size, info) -> None:
    """Each window's task graph on a local Dask scheduler in turn; a group is sampled once for the whole sweep
    (its sampled SED kept here and handed to the later windows' batches)."""
    n = os.cpu_count() or 1
    info.update(kind=f"dask-{kind}", workers=n, batches=0, sampling_tasks=0, windows=0,
                cache_shared=True, cache_why="local scheduler: every worker is on this machine and shares its disk")
    sampled: dict = {}
    for groups in windows:
        _run_window(groups, sink, sampled, kind=kind, n=n, cache_dir=cache_dir, use_cache=use_cache,
                    batch_size=batch_size, info=info)


def _run_window(groups, sink, sampled, *, kind, n, cache_dir, use_cache, batch_size, info) -> None:
    from functools import partial

    from dask.callbacks import Callback

    from . import engine

    dsk, keys, members, new = {}, [], {}, {}
    for gi, (g, tasks) in enumerate(groups.items()):
        skey = f"sample-{gi}"
        if g in sampled:
            dsk[skey] = sampled[g]
        else:
            dsk[skey] = (partial(engine.sample, tasks[0], cache_dir, use_cache),)
            new[skey] = g
        for bi, b in enumerate(engine.batches(tasks, n, batch_size)):
            k = f"batch-{gi}-{bi}"
            dsk[k] = (partial(engine.run_batch, tasks=b), skey)
            keys.append(k)
            members[k] = b

    workers: dict = {}  # id -> multiprocessing process: every 'processes' worker, recorded as the pool makes it

    class _Collect(Callback):
        def _posttask(self, key, result, dsk, state, worker_id):
            if key in members:
                sink(result)

    info.update(batches=info["batches"] + len(keys), sampling_tasks=info["sampling_tasks"] + len(new),
                windows=info["windows"] + 1)
    from concurrent.futures.process import BrokenProcessPool

    with _pool(kind, n, workers, partial(engine.worker_init, os.getpid())) as get:  # workers die with this process
        try:
            with _Collect(), _sigterm_ends(workers) if kind == "processes" else contextlib.nullcontext():
                results = get(dsk, keys + list(new), num_workers=n)
        except BrokenProcessPool as err:
            raise _worker_death(workers, sink) from err
    for k, recs in zip(keys, results):  # anything a callback missed
        sink(recs)
    sampled.update((g, s) for s, g in zip(results[len(keys):], new.values()))


@contextlib.contextmanager
def _pool(kind: str, n: int, workers: dict, init):
    """Dask's ``get`` for ``kind``; for 'processes', on a process pool made here as dask makes its own (its context,
    its worker initializer around ``init``), whose every worker process goes into ``workers`` as it is made. A
    worker killed before a task of this window started is then known too, with its signal (before, only the
    workers seen when a task started were: one killed during the first task was not, and the death was blamed
    on an unguarded calling script, or on the SIGTERM the pool sends the others)."""
    from functools import partial

    if kind != "processes":
        from dask.threaded import get

        yield get
        return
    from concurrent.futures import ProcessPoolExecutor

    from dask.multiprocessing import get, get_context, initialize_worker_process

    if os.environ.get("PYTHONHASHSEED") in (None, "0"):  # as dask.multiprocessing.get does for its own pool
        os.environ["PYTHONHASHSEED"] = "6640"
    pool = ProcessPoolExecutor(n, mp_context=_Recording(get_context(), workers),
                               initializer=partial(initialize_worker_process, user_initializer=init))
    try:
        yield partial(get, pool=pool)
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


class _Recording:
    """A multiprocessing context that puts every process it makes into ``workers`` (id -> process)."""

    def __init__(self, context, workers: dict):
        self._context, self._workers = context, workers

    def __getattr__(self, name):
        return getattr(self._context, name)

    def Process(self, *args, **kwargs):  # noqa: N802 (multiprocessing's name)
        process = self._context.Process(*args, **kwargs)
        self._workers[id(process)] = process
        return process


@contextlib.contextmanager
def _sigterm_ends(workers: dict):
    """While local workers run (called in the main thread): SIGTERM kills them, then exits (code 143).

    The workers also die with this process by themselves (:func:`engine.worker_init`); this lets
    the ``finally`` clauses run (the records written so far are kept) and the exit come at once.
    """
    import signal

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_sigterm(signum, frame):
        for p in list(workers.values()):
            if p.pid is not None and p.exitcode is None:  # started, still running
                p.kill()
        raise SystemExit(128 + signum)

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _worker_death(workers: dict, sink) -> Exception:
    """The error for a broken process pool: a worker killed while running tasks (its signal), or workers
    that could not start (an unguarded calling script)."""
    import signal

    from ..exceptions import WorkerLostError

    import time

    deadline = time.monotonic() + 10.0
    for p in workers.values():  # the pool marks the tasks failed before it has ended and reaped its workers
        # while the pool's own thread is reaping a worker, exitcode reads None (its waitpid took the status
        # first): ask again until that thread has recorded it
        while p.exitcode is None and p.pid is not None and time.monotonic() < deadline:
            p.join(timeout=0.05)
    codes = [p.exitcode for p in workers.values() if p.exitcode]
    killed = [-c for c in codes if c < 0]
    if killed:  # the pool ends the other workers with SIGTERM: the odd one out is the cause
        sig = next((s for s in killed if s != signal.SIGTERM), killed[0])
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else "?"
        return WorkerLostError(
            f"a sweep worker died (signal {sig}, {name}) while running tasks (killed, or out of memory?); "
            f"{sink.n} task(s) finished and are kept in {sink.output!r}: run the same sweep again to resume.")
    main = getattr(sys.modules.get("__main__"), "__file__", None)
    return RuntimeError(
        "The 'processes' scheduler's worker processes died before running a task"
        + (f" (exit codes {sorted(set(codes))})" if codes else "") + ". They start by importing "
        f"the calling script{f' ({main!r})' if main else ''}: call afferent.sweep(...) under "
        "'if __name__ == \"__main__\":' there, or pass scheduler='threads' or 'serial'.")
