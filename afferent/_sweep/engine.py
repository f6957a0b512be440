"""Running tasks: sample each group once, then batches of parameter sets on the sampled SED.

Two kinds of work go to the scheduler:

* ``sample``: one per sampling group (export x receptors x region x method): read the export
  and sample it at the receptors, through the SED cache (:mod:`afferent.cache`); returns a
  :class:`Sampled` (the :class:`~afferent.sampling.ReceptorSED` and its record, a few kB).
* ``batch``: a few parameter sets of one group, run one after the other on that
  :class:`Sampled` (stimulus, transduction, synthesis, comparison, spiking); returns one record
  per task. A task that raises is recorded as failed; the others of its batch go on.

Batches exist because a task on the sample exports takes ~10 ms, the order of a distributed
scheduler's per-task overhead; the batch size is chosen to give every worker a few batches.
"""

from __future__ import annotations

import json
import os
import time
import traceback
import warnings
from dataclasses import dataclass, field

from ..scene.record import _QUIET_CATEGORIES
from ..scene.schema import SceneError


@dataclass(frozen=True)
class Sampled:
    """A sampling group's result: what every task of the group starts from.

    Attributes
    ----------
    sed : ReceptorSED or None
        SED at the region's receptors (J/m^3); None when sampling failed.
    full_layout : ReceptorLayout or None
        Every receptor before the region (a branching map is restricted with it).
    record : dict
        The run-record entries of sampling (field, sampling, cache, receptors).
    inputs : dict
        Input file -> sha256.
    seconds : dict
        Step -> wall time, s.
    where : str
        Host and process id that sampled.
    error : str or None
        Why sampling failed (every task of the group then fails with it).
    """

    sed: object = None
    full_layout: object = None
    record: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    region_info: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    warnings: tuple = ()
    where: str = ""
    error: str | None = None


def _here() -> str:
    import socket

    return f"{socket.gethostname()}:{os.getpid()}"


def _messages(caught) -> list[dict]:
    return [{"category": w.category.__name__, "message": " ".join(str(w.message).split())}
            for w in caught if not issubclass(w.category, _QUIET_CATEGORIES)]


def sample(task, cache_dir=None, use_cache: bool = True) -> Sampled:
    """Read and sample one group's export (with its first task's scene); never raises (a failure is returned)."""
    from ..scene.planning import plan, skip_reasons
    from ..scene.run import _hash_inputs, _receptor_sed, _Run, _Steps

    try:
        scene = task.scene
    except SceneError as err:  # the task's scene refuses its parameter set: each task of the group says so
        return Sampled(error=f"{type(err).__name__}: {' '.join(str(err).split())}", where=_here())
    run = _Run(scene, plan(scene), skip_reasons(scene), _Steps())
    run.region_info["region"] = {"x_range_m": scene.region.x_range_m, "z_range_m": scene.region.z_range_m}
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            exp_files, hashes = _hash_inputs(run)
            sed = _receptor_sed(run, exp_files, hashes, cache_dir=cache_dir, use_cache=use_cache, progress=False)
    except Exception as err:  # noqa: BLE001 - reported with every task of the group
        return Sampled(error=f"{type(err).__name__}: {' '.join(str(err).split())}", where=_here(),
                       seconds=dict(run.steps.seconds))
    return Sampled(sed=sed, full_layout=run.full_layout, record=dict(run.record), inputs=dict(run.inputs),
                   region_info=dict(run.region_info), seconds=dict(run.steps.seconds),
                   warnings=tuple(_messages(caught)), where=_here())


def run_task(task, sampled: Sampled) -> dict:
    """One task's record (status 'ok' with its table rows, or 'failed' with the error); never raises."""
    from ..scene.planning import plan, skip_reasons
    from ..scene.run import _compute_downstream, _Run, _Steps
    from .table import task_rows

    t0 = time.perf_counter()
    rec = {"task": task.id, "index": task.index, "scene": task.label, "scene_file": task.base.scene_path,
           "params": task.params, "group": task.group, "where": _here()}
    try:
        task.scene  # built here, in the worker (a value inside a range that the scene refuses fails its task)
    except SceneError as err:
        return dict(rec, status="failed", error=f"{type(err).__name__}: {' '.join(str(err).split())}", stage="scene",
                    seconds=time.perf_counter() - t0)
    if sampled.error is not None:
        return dict(rec, status="failed", error=f"sampling the export failed: {sampled.error}", stage="sampling",
                    seconds=0.0)
    run = _Run(task.scene, plan(task.scene), skip_reasons(task.scene), _Steps())
    run.full_layout = sampled.full_layout
    run.inputs.update(sampled.inputs)
    run.region_info.update(sampled.region_info)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            _compute_downstream(run, sampled.sed)
            rows = task_rows(task, run.out)
    except Exception as err:  # noqa: BLE001 - one failed task must not lose the others
        done = list(run.steps.seconds)
        return dict(rec, status="failed", error=f"{type(err).__name__}: {' '.join(str(err).split())}",
                    stage=next((s for s in run.planned if s not in done and s not in ("reading", "sampling")), None),
                    traceback=traceback.format_exc(limit=-4), seconds=time.perf_counter() - t0)
    record = {k: v for k, v in run.record.items() if k not in sampled.record}
    record["receptors"] = sampled.record.get("receptors")  # which sites (site kind 'RA-I', 'SA-I', 'file'), how many
    return dict(rec, status="ok", plan=run.planned, stages=dict(run.steps.seconds), record=record, inputs=run.inputs,
                warnings=list(sampled.warnings) + _messages(caught), seconds=time.perf_counter() - t0, rows=rows)


def record_line(task, rec: dict) -> str:
    """A task's record as one line of JSON (the resolved scene added; NaN -> null)."""
    from .. import __version__
    from ..export import jsonable

    try:
        tables = task.scene.to_dict()
    except SceneError:  # recorded as the task's error
        tables = None
    return json.dumps(jsonable(dict(rec, afferent=__version__, scene_tables=tables)), separators=(",", ":"))


def run_batch(sampled: Sampled, tasks) -> list[tuple]:
    """A few tasks of one group, run one after the other on its sampled SED.

    Returns ``(task id, status, seconds, record as a JSON line, inputs)`` per task (inputs: the files it read,
    path -> SHA-256, for the batch's index): the worker serialises, so the process writing the records only
    writes text.
    """
    out = []
    for t in tasks:
        rec = run_task(t, sampled)
        out.append((t.id, rec["status"], rec.get("seconds", 0.0), record_line(t, rec), rec.get("inputs")))
    return out


def failed_batch(tasks, error: str) -> list[tuple]:
    """What :func:`run_batch` would return for tasks whose worker was lost."""
    out = []
    for t in tasks:
        rec = {"task": t.id, "index": t.index, "scene": t.label, "scene_file": t.base.scene_path, "params": t.params,
               "group": t.group, "status": "failed", "error": error, "seconds": 0.0}
        out.append((t.id, "failed", 0.0, record_line(t, rec), None))
    return out


def batches(tasks, n_slots: int, batch_size: int | None = None) -> list[list]:
    """Split one group's tasks into batches: ``batch_size`` each, or about 4 batches per worker slot (at most 64 tasks)."""
    if batch_size is None:
        batch_size = max(1, min(64, -(-len(tasks) // max(1, 4 * n_slots))))
    return [list(tasks[i:i + batch_size]) for i in range(0, len(tasks), batch_size)]


def worker_init(parent_pid: int) -> None:
    """Initializer of each 'processes' worker: make it die with the process that started it
    (:func:`afferent._figure_process.die_with_parent`). Without this, a killed ``afferent sweep`` left its
    workers and multiprocessing's resource tracker running for good (~100 MB each).
    """
    from .._figure_process import die_with_parent

    die_with_parent(parent_pid)
