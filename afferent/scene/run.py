"""The executor: the planned stages in order, the sampled-SED cache, the region, the outputs.

:func:`run_scene` is the only function that runs the pipeline for a scene, whether it came
from a TOML file or from the options of ``afferent run EXPORT``. Each stage is one function
below, over a :class:`_Run` that carries the results and the record entries so far.

Size: just over 600 lines once the hot-spot maps, the cycles, the zones branching and the afferent
classes are all in: one executor, one function per stage; the route branch moves stages out of it.
"""

from __future__ import annotations

from .._typing import PathLike
from collections.abc import Callable

import os
import sys
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

from ..export import profile_step_record
from .planning import plan, skip_reasons
from .record import _QUIET_CATEGORIES, SceneResult, build_record, reemit, summary_lines  # noqa: F401 (SceneResult: importable here)
from .defaults import class_record, resolve
from .schema import _LIF_FIELDS, Scene, SceneError, _plain_json
from .stages import (_beside_scene, _branching, _check_before_reading, _crop, _named_inputs, _hash_all, _inside_field, _judge_placement, _layout_before_reading,
                     _layout_from_field, _params, _refuse_rate_keys_without_rate, _refuse_step_numbers, _restrict, _trim,
                     _waveform)

class _Steps:
    """Wall time of each executed step, in order."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    @contextmanager
    def __call__(self, name: str):
        t = time.perf_counter()
        yield
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t



# ------------------------------------------------------------------------------- run
def run_scene(scene: Scene, *, overwrite: bool = False, cache_dir: PathLike | None=None, progress: bool = False,
              use_cache: bool = True, record_extra: dict | None = None, figure_process: bool = False) -> SceneResult:
    """Run a scene: only the stages its outputs need, on the receptors of its region; write outputs and run.json.

    Parameters
    ----------
    scene : Scene
        From :func:`load_scene` (resolved here if it is not yet).
    overwrite : bool, default=False
        Replace an existing output folder that afferent wrote (docs/cli.md, "Outputs and --overwrite"),
        once the new results are complete. Without it an existing folder is an error, raised
        before any work is done.
    cache_dir : str or path-like, optional
        Folder of the sampled-SED cache (:mod:`afferent.cache`); default
        ``$AFFERENT_CACHE_DIR`` or ``~/.cache/afferent``.
    progress : bool, default=False
        Progress bars while reading a series.
    use_cache : bool, default=True
        False: neither read nor write the cache.
    record_extra : dict, optional
        More entries for ``run.json`` (e.g. the command line).
    figure_process : bool, default=False
        Draw the figures (output ``plots``) in a second process, started as the export is read
        (one of ``afferent._figure_process.MIN_EXPORT_BYTES``, 16 MB, or more), while this one reads,
        samples and writes the tables (``afferent._figure_process``; not with one usable core nor
        with ``AFFERENT_FIGURE_PROCESS=0``). The command line does; from Python, only under ``if
        __name__ == "__main__":`` in a script (the process imports the calling script again).

    Returns
    -------
    SceneResult

    Raises
    ------
    OutputExistsError
        The output folder exists and ``overwrite`` is False; or it may not be replaced (an input,
        the working folder, a link, a folder holding files afferent did not write).
    OutputWriteError
        The disk refuses (full, read-only, permissions); the message names the output.
    SceneError
        As :func:`resolve`; a region with no receptor; an unreadable calibration result.
    FileNotFoundError, SEDFormatError, UnitError, FieldCoverageError, ValueError
        From the stages (reading, receptors, sampling, ...).

    Notes
    -----
    ``run.json`` holds: ``scene`` (as resolved), ``scene_file`` (path, sha256), ``plan``,
    ``inputs`` (every file read, with its sha256), ``versions``, ``stages`` (executed steps
    and wall times in s), ``skipped`` (stage -> why), ``cache``, ``receptors`` (counts in and
    out of the region), ``outside`` (with ``[sampling] on_outside`` 'nan' or 'warn': the receptors
    sampled outside the FE field, NaN in the SED tables and left out of every stage from transduction on,
    and the afferents that lost some or all of their receptors to it; also said in a warning), ``field`` (the export's provenance), ``transduction``,
    ``saturation``, ``fit``, ``spikes``, ``time_span``, ``warnings``, ``outputs``, ``figures``
    (with ``plots``: drawn in the ``'same'`` or a ``'separate'`` process, why, seconds; ``fallback``:
    why a figure process that died left them to the run's),
    ``started_utc`` and ``wall_seconds``.
    """
    from contextlib import nullcontext
    from datetime import datetime, timezone

    from .._figure_process import figure_drawer
    from .._output import atomic_dir, check_writable
    from ..export import write_json, write_outputs

    t_run = time.perf_counter()
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    scene = resolve(scene)
    outdir = scene.outputs.dir
    check_writable(outdir, overwrite=overwrite, what="Output folder", inputs=scene.input_files, folder=True)
    want = set(scene.outputs.want)
    run = _Run(scene, plan(scene), skip_reasons(scene), _Steps(), figure_process=figure_process and "plots" in want)
    with warnings.catch_warnings(record=True) as caught, _stopping(run):
        warnings.simplefilter("always")
        _compute(run, cache_dir=cache_dir, use_cache=use_cache, progress=progress)  # may start run.figures
        if "plots" in want and run.figures is None:  # not started while reading (a cache hit): why, in run.json
            run.figures = figure_drawer(figure_process)
        figures = run.figures
        files: list[str] = []
        with atomic_dir(outdir, overwrite=overwrite, inputs=scene.input_files) as tmp:
            with run.steps("writing"), figures or nullcontext():  # stopped before the folder is removed or renamed
                files = write_outputs(tmp, want=want, plots="plots" in want, results_format=scene.outputs.format,
                                      figures=figures, **run.out)
            if figures is not None:
                run.record["figures"] = figures.record
            full = build_record(scene, run.planned, run.skipped, run.steps.seconds, run.record, run.inputs, caught,
                                files, started, t_run, record_extra)
            write_json(os.path.join(tmp, "run.json"), full)
            files.append("run.json")
    messages = reemit(caught)
    out = run.out
    return SceneResult(
        scene=scene, output=outdir, files=tuple(files), record=full, stages=dict(run.steps.seconds),
        skipped=dict(run.skipped), cache_hit=run.record.get("cache", {}).get("hit"), sed=out.get("sed_static"),
        current=out.get("current"), afferent=out.get("afferent"), fit=out.get("fit"), spikes=out.get("spikes"),
        waveform=out.get("waveform"), warnings=tuple(messages),
    )


@dataclass
class _Run:
    """The state of one execution: the scene, its plan, results so far and the record entries."""

    scene: Scene
    planned: list
    skipped: dict
    steps: _Steps
    record: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)  # path -> sha256 (None until hashed)
    region_info: dict = field(default_factory=dict)
    out: dict = field(default_factory=dict)  # what the writer gets
    span: dict = field(default_factory=dict)
    full_layout: object = None
    figure_process: bool = False  # the figures may be drawn in a second process (run_scene's keyword, plots wanted)
    figures: object = None  # who draws them, once decided (afferent._figure_process): as the export is read


@contextmanager
def _stopping(run: _Run):
    """Stop the run's figure process, if one started, however the run ends (error, Ctrl-C)."""
    try:
        yield
    finally:
        if run.figures is not None:
            run.figures.stop()


def _start_figures(run: _Run) -> None:
    """As the export is about to be read: a second process for the figures, if asked and the export is large
    enough to hide its start-up (:func:`afferent._figure_process.choose`)."""
    if not run.figure_process or run.figures is not None:
        return
    from .._figure_process import export_bytes, figure_drawer

    ex = run.scene.export
    run.figures = figure_drawer(True, export_bytes(ex.files, ex.format, side=[ex.coordinates]))


def _compute(run: _Run, *, cache_dir, use_cache: bool, progress: bool) -> None:
    """Run the planned stages in order; fill ``run.out`` (results) and ``run.record`` (run.json entries)."""
    scene = run.scene
    run.region_info["region"] = {"x_range_m": scene.region.x_range_m, "z_range_m": scene.region.z_range_m}
    exp_files, hashes = _hash_inputs(run)
    beside = _beside_scene(scene)
    # the second hot-spot map's sites are sampled as the scene's are (region, cache), from the same one read
    sub = None if beside is None else _Run(beside, run.planned, {}, run.steps, inputs=run.inputs)
    seds = _receptor_seds([run] if sub is None else [run, sub], exp_files, hashes, cache_dir=cache_dir,
                          use_cache=use_cache, progress=progress)
    _compute_downstream(run, seds[0])
    run.out["hotspot_threshold"] = scene.outputs.hotspot_threshold
    if sub is not None:
        run.out["sed_beside"] = _leave_outside(run, seds[1], "outside_beside", drop=False)
        run.record["hotspots_beside"] = {k: sub.record.get(k) for k in ("receptors", "cache", "sampling")}


def _compute_downstream(run: _Run, sed) -> None:
    """The planned stages after sampling, from SED at the region's receptors (J/m^3); also :mod:`afferent.sweep`'s tasks."""
    inside = _leave_outside(run, sed, "outside", drop="transduction" in run.planned)
    run.out.update(sed_static=sed, sed=inside, current=None, branching=None, afferent=None, fit=None, waveform=None,
                   spikes=None, profile_index=-1)
    run.record["afferent_class"] = class_record(run.scene, getattr(sed.layout, "site", None))
    sed_t = _stimulus(run, inside) if "stimulus" in run.planned else inside
    if "transduction" not in run.planned:
        return _cycles(run)
    _transduce_and_synthesize(run, sed_t)
    if "comparison" in run.planned:
        _compare(run)
    if "spiking" in run.planned:
        _spike(run)
    if run.span:
        run.record["time_span"] = run.span
    _cycles(run)


def _leave_outside(run: _Run, sed, key: str, *, drop: bool):
    """``sed``, with ``drop`` without the receptors outside the FE field (``stages._inside_field``); those receptors
    said in a warning and in run.json under ``key``."""
    full_ids = None if run.full_layout is None else run.full_layout.ids
    sed, record, message = _inside_field(run.scene, sed, full_ids, drop=drop)
    if record is not None:
        from ..exceptions import AfferentWarning

        run.record[key] = record
        warnings.warn(message, AfferentWarning, stacklevel=3)
    return sed


def _cycles(run: _Run) -> None:
    """The ``cycles`` output's table and record (:func:`afferent.cycles.receptor_cycles`), on the export's SED."""
    o = run.scene.outputs
    if "cycles" not in (o.want or ()):
        return
    from ..cycles import receptor_cycles

    _refuse_step_numbers(run.scene, run.out["sed"], "the cycles output")
    given = o.cycles_frequency_hz is not None
    f = o.cycles_frequency_hz if given else run.scene.stimulus.frequency_hz
    run.out["cycles"], run.record["cycles"] = receptor_cycles(  # SED over the stimulus' times, as the spikes
        run.out["sed"], f, x_range_m=o.cycles_x_range_m, z_range_m=o.cycles_z_range_m, edge_m=o.cycles_edge_m,
        spikes=run.out.get("spikes"))
    run.record["cycles"]["frequency_from"] = ("the scene's [outputs] cycles_frequency_hz" if given else
                                              "the scene's [stimulus] sine frequency_hz")


def _hash_inputs(run: _Run):
    """Content hashes of every input the planned stages name (they key the cache and go into the record).

    The side files the export makes the reader open are hashed once known: after reading
    (:func:`_read_and_sample`) or when a cache entry's files are checked (:func:`_receptor_sed`).
    """
    from ..io._files import check_regular

    scene, planned = run.scene, run.planned
    ex = scene.export
    with run.steps("hashing"):
        exp_files = list(dict.fromkeys(ex.files))
        for p in exp_files:
            if not os.path.exists(p):
                raise FileNotFoundError(f"SED file {p!r}{' ([export] file)' if scene.source else ''} not found.")
            check_regular(p)  # a FIFO or a device: refused before hashing (it would block, or never end)
        _check_before_reading(scene, planned)  # the first step of every route through a scene: nothing read yet
        hashes = _hash_all({p: None for p in exp_files})
        run.inputs.update(hashes)
        for _, p, _ in _named_inputs(scene, planned):  # each checked by _check_before_reading
            run.inputs[p] = None
        run.inputs.update(_hash_all(run.inputs))
    return exp_files, hashes


def _cache_key(run: _Run, layout, exp_files, hashes) -> str:
    """The sampled-SED cache key: export content, read options, receptors (or how they are found), method."""
    from ..cache import positions_digest, sampling_key
    from ..io import format_of

    scene = run.scene
    ex, rec = scene.export, scene.receptors
    read_opts = ex.read_kwargs()
    if not read_opts.get("allow_outside_files"):  # the default reads what it read before: the keys of earlier entries
        read_opts.pop("allow_outside_files", None)
    from ..io._read_options import READ_ACCEPTS

    read_checks = sorted(set(scene.info.accept or ()) & set(READ_ACCEPTS))  # the reader's confirmations
    if read_checks:  # a read the checks refuse without them is not served from one they confirmed
        read_opts["accept"] = read_checks
    for name in ("coordinates", "materials"):  # a side table keys the cache by its content, not its name
        if read_opts.get(name):
            read_opts[name] = run.inputs.get(read_opts[name])
    if layout is not None:
        rkey = {"positions_sha256": positions_digest(layout.positions), "n": int(layout.n_receptors)}
    else:
        rkey = {"found_on_export": {k: _plain_json(getattr(rec, k)) for k in
                                    ("grid", "rows", "y_m", "pitch_x_m", "pitch_z_m", "x_range_m", "z_range_m", "origin_m",
                                     "material_array", "upper", "lower")},
                "region": {"x_range_m": _plain_json(scene.region.x_range_m),
                           "z_range_m": _plain_json(scene.region.z_range_m)}}
    # each export file named: (the reader its name selects, content hash); the side files it makes the reader
    # open are checked by SEDCache.get against the entry's list
    readers = [(format_of(p, ex.format), hashes[p]) for p in exp_files]
    return sampling_key(exports=readers, read_options=read_opts, receptors=rkey, method=scene.sampling.method,
                        side=scene.sampling.side)


def _receptor_sed(run: _Run, exp_files, hashes, *, cache_dir, use_cache: bool, progress: bool):
    """Stages 'reading' and 'sampling' (or a cache hit): SED at the region's receptors, J/m^3."""
    return _receptor_seds([run], exp_files, hashes, cache_dir=cache_dir, use_cache=use_cache, progress=progress)[0]


def _receptor_seds(runs: list, exp_files, hashes, *, cache_dir, use_cache: bool, progress: bool) -> list:
    """:func:`_receptor_sed` of runs on one export (a scene's and its second hot-spot map's): each served by the
    cache where it can be; the others sampled together from one read of the export (:func:`_read_sample_store`)."""
    from ..cache import SEDCache

    cache = SEDCache(cache_dir) if use_cache else None
    seds, pending = [None] * len(runs), []
    for k, run in enumerate(runs):
        scene = run.scene
        with run.steps("receptors"):
            run.full_layout = _layout_before_reading(scene)
            layout = None if run.full_layout is None else _restrict(run.full_layout, scene, run.region_info)
        key = _cache_key(run, layout, exp_files, hashes)
        cache_info: dict = {"enabled": bool(use_cache), "key": key}
        entry = None
        if cache is not None:
            cache_info["dir"] = str(cache.directory)
            with run.steps("cache"):
                entry = cache.get(key, positions=None if layout is None else layout.positions, base=_base(scene),
                                  hashes=run.inputs)
            cache_info["hit"] = entry is not None
            if entry is None:
                cache_info["miss"] = cache.last_miss
        run.record["cache"] = cache_info
        if entry is not None:
            seds[k] = _from_cache(run, entry, layout, key)
            _add_inputs(run, entry.files)
        else:
            pending.append((k, run, layout, key))
    if pending:
        read = _read_sample_store([(run, layout, key) for _, run, layout, key in pending], cache, progress=progress)
        for (k, *_), sed in zip(pending, read):
            seds[k] = sed
    for run, sed in zip(runs, seds):
        _judge_placement(run.scene, run.record.get("receptor_sites"), run.planned)
        run.region_info["n_receptors_sampled"] = int(sed.layout.n_receptors)
        rec = run.scene.receptors
        source = rec.file or f"grid = {rec.grid!r}" + (f", rows = {rec.rows!r}" if rec.grid == "regular" else "")
        run.record["receptors"] = {"source": source, "site": sed.layout.site, **run.region_info}
    return seds


def _read_sample_store(pending: list, cache, *, progress: bool) -> list:
    """Read and sample (cache misses): ``pending`` holds (run, layout or None, cache key) of runs on one export,
    sampled from one read; hash every file the reader opened; store each run's entry with their list.

    A file modified after reading began (its modification time is later) may have been read
    half old, half new: its hash would not describe the values, so no entry is written then.
    """
    from ..cache import file_records

    for run, _, _ in pending:
        _start_figures(run)
    t_read = time.time_ns()
    seds = _read_and_sample([(run, layout) for run, layout, _ in pending], progress=progress)
    for (run, _, key), sed in zip(pending, seds):
        read = run.record["field"]["files"]
        with run.steps("hashing"):
            _add_inputs(run, _hash_all({p: run.inputs.get(p) for p in read}))
            records = file_records(read, run.inputs)
        if cache is not None:
            _store(run, sed, key, cache, records, t_read)
    return seds


def _store(run: _Run, sed, key: str, cache, records: list, t_read: int) -> None:
    """Write the run's sampled SED into the cache (unless a file read changed after ``t_read``, ns)."""
    cache_info = run.record["cache"]
    late = [r["path"] for r in records if r["mtime_ns"] >= t_read]
    if late:
        cache_info["not_written"] = (f"file {late[0]!r} was modified after reading began: the values may not match "
                                     "its content; not cached")
        return
    with run.steps("cache"):
        try:
            path = cache.put(key, sed, meta={"field": run.record["field"], "region_info": {
                k: v for k, v in run.region_info.items() if k != "region"}, "interface": sed.interface,
                "receptor_sites": run.record.get("receptor_sites")}, files=records,
                base=_base(run.scene))
            cache_info["written"] = str(path)
        except OSError as err:  # a read-only or full cache disk must not fail the run
            cache_info["write_error"] = str(err)


def _add_inputs(run: _Run, hashes: dict) -> None:
    """Files the reader opened (path -> sha256) into the record's inputs, once each (a path already there
    under another spelling of the same file keeps its spelling)."""
    known = {os.path.abspath(p) for p in run.inputs}
    run.inputs.update({p: h for p, h in hashes.items() if p in run.inputs or os.path.abspath(p) not in known})


def _base(scene: Scene) -> str:
    """The folder of the first export file (where a cache entry's files are looked for when the export moved)."""
    return os.path.dirname(os.path.abspath(scene.export.files[0]))


def _from_cache(run: _Run, entry, layout, key: str):
    from ..sampling import report_outside

    sed = entry.to_receptor_sed(layout)
    if layout is None:
        run.region_info.update(entry.meta.get("region_info", {}))
    report_outside(sed.layout, sed.outside, _sampling_outside(run.scene), where="from the sampling cache",
                   hint="Set [sampling] on_outside = 'nan' or 'warn' to continue.", stacklevel=5)
    why = (f"cache hit: SED at these {sed.layout.n_receptors} receptors was sampled before from identical export "
           f"content with the same read options and method (key {key[:12]}, {entry.path})")
    run.skipped["reading"] = run.skipped["sampling"] = why
    run.record["field"] = dict(entry.meta.get("field", {}), from_cache=True)
    run.record["receptor_sites"] = entry.meta.get("receptor_sites")
    run.record["sampling"] = {"method": sed.method, "placement": sed.placement, "side": run.scene.sampling.side,
                              "interface": entry.meta.get("interface")}
    return sed


def _sampling_outside(scene: Scene) -> str:
    """The sampler's ``on_outside``: 'raise' as the scene says; 'warn' and 'nan' both sample NaN outside, the
    receptors then said and left out once, after sampling (:func:`_leave_outside`)."""
    return "raise" if scene.sampling.on_outside == "raise" else "nan"


def _read_and_sample(pairs: list, *, progress: bool) -> list:
    """Stages 'reading' and 'sampling' of (run, layout) pairs on one export, from one read of it, one export
    step at a time (memory: one step of the mesh). A layout None is found on the first step as read
    (``receptors`` tips, bases; :func:`afferent.io.iter_sed`'s ``on_first_raw``): the export is read once.

    'reading' times the first step (the mesh); the later steps are read while they are sampled.
    """
    from itertools import chain

    from .._placement import placement_record
    from ..io import iter_sed, series_provenance
    from ..sampling import build_sampler, sample_steps_together

    scene = pairs[0][0].scene
    ex, method, steps_of = scene.export, scene.sampling.method, pairs[0][0].steps
    raws = []
    with steps_of("reading"):
        steps = iter_sed(list(ex.files) if len(ex.files) > 1 else ex.files[0], progress=progress,
                         accept=scene.info.accept, on_first_raw=raws.append, **ex.read_kwargs())
        first = next(steps)
    layouts = []
    for run, layout in pairs:
        if layout is None:
            with run.steps("receptors"):
                run.full_layout = _layout_from_field(run.scene, first, raws[0])
                layout = _restrict(run.full_layout, run.scene, run.region_info)
        layouts.append(layout)
    raws.clear()  # the first step as read: no longer needed once the sites are found
    provenances = []

    def recorded(fields):
        for f in fields:
            provenances.append(f.provenance)
            yield f

    with steps_of("sampling"):
        crops = [_crop(first, layout.positions, method) for layout in layouts]
        samplers = [build_sampler(cropped, layout, method=method) for (cropped, _), layout in zip(crops, layouts)]
        seds = sample_steps_together(recorded(chain([first], steps)), layouts, method=method,
                                     on_outside=_sampling_outside(scene), samplers=samplers, side=scene.sampling.side)
    field_record = dict(series_provenance(provenances).to_dict(), n_points=int(first.n_points),
                        n_cells=int(first.cells.n_cells) if first.cells is not None else 0,
                        n_times=int(seds[0].values.shape[0]))
    for (run, _), layout, sed, (_, crop_info) in zip(pairs, layouts, seds, crops):
        run.record["field"] = dict(field_record)
        run.record["sampling"] = {"method": sed.method, "placement": sed.placement, "side": scene.sampling.side,
                                  "interface": sed.interface}
        run.record["receptor_sites"] = placement_record(first, layout, sed.outside)
        if crop_info:
            run.record["sampling"]["mesh_cropped_to_receptors"] = crop_info
    return seds


def _stimulus(run: _Run, sed):
    """Stage 'stimulus': the waveform (trimmed to the simulated span when only spikes are wanted) drives the SED."""
    from ..stimulus import apply_waveform, no_reference_step_message

    scene = run.scene
    st = scene.stimulus
    if st.reference_step is None and sed.values.shape[0] > 1 and scene.source is not None:
        # a scene file's key; a scene built from options gets apply_waveform's own words (reference_step=K)
        raise SceneError(f"Scene file {scene.source!r}: [stimulus] " + no_reference_step_message(
            sed.values.shape[0], sed.times).replace("reference_step=K", "reference_step = K"), path=scene.source,
            key="[stimulus] reference_step")
    with run.steps("stimulus"):
        waveform = _waveform(scene)
        run.span["waveform_s"] = [float(waveform.times[0]), float(waveform.times[-1])]
        time_resolved = {"currents", "profiles", "fit"} & set(scene.outputs.want)
        dur = scene.spikes.duration_s
        if "spiking" in run.planned and dur is not None and not time_resolved:
            waveform, trimmed = _trim(waveform, dur)
            if trimmed:
                run.span["trimmed_to_s"] = [float(waveform.times[0]), float(waveform.times[-1])]
                run.span["why"] = (f"only spikes are wanted and [spikes] duration is {dur:g} s: the stimulus beyond "
                                   "it is neither transduced nor simulated")
        sed_t, scaling = apply_waveform(sed, waveform, d_ref=st.d_ref_m, reference_step=st.reference_step,
                                        series_depths=st.series_depths_m, accept=scene.info.accept)
    run.record["stimulus"] = {
        "waveform": {"kind": waveform.kind, "parameters": dict(waveform.parameters), "notes": list(waveform.notes)},
        "scaling": scaling}
    run.out.update(waveform=waveform, sed=sed_t)
    return sed_t


def _transduce_and_synthesize(run: _Run, sed_t) -> None:
    """Stages 'transduction' and 'synthesis', and the profile step (largest total afferent current)."""
    from ..profiles import peak_step
    from ..synthesis import synthesize
    from ..transduction import saturation_report, transduce

    scene = run.scene
    params, source = _params(scene, run.inputs)
    run.inputs.update(_hash_all(run.inputs))
    with run.steps("transduction"):
        current = transduce(sed_t, params)
        sat = saturation_report(sed_t, params)
    run.record["transduction"] = {"alpha_a": params.alpha, "gamma_per_pa": params.gamma, "lambda_pa": params.lambda_,
                                  **source}
    run.record["saturation"] = {"fraction_sensitive": sat.fraction_sensitive, "fraction_high": sat.fraction_high,
                                "fraction_low": sat.fraction_low, "modulation": sat.modulation,
                                "gamma_sed_range": sat.gamma_sed_range, "message": sat.message}
    with run.steps("synthesis"):
        full_ids = None if run.full_layout is None else run.full_layout.ids
        branching, map_info = _branching(scene, sed_t.layout, full_ids)
        afferent = synthesize(current, branching)
    run.record["synthesis"] = {"kind": branching.kind, "n_afferents": int(branching.n_afferents), **map_info}
    profile_index = peak_step(afferent)
    run.out.update(current=current, branching=branching, afferent=afferent, profile_index=profile_index,
                   saturation=sat)
    run.record["profile_step"] = profile_step_record(afferent, profile_index)
    if afferent.times is not None:
        run.record["profile_time_s"] = float(afferent.times[profile_index])


def _compare(run: _Run) -> None:
    """Stage 'comparison': the afferent profile at the profile step against the recorded one."""
    from ..profiles import compare_profiles, read_observed

    fi = run.scene.fit
    with run.steps("comparison"):
        observed = read_observed(fi.observed, length_unit=fi.length_unit, position_column=fi.position_column,
                                 response_column=fi.response_column)
        fit = compare_profiles(run.out["afferent"], observed, normalise=fi.normalise,
                               time_index=run.out["profile_index"])
    run.out["fit"] = fit
    _warn_if_stretched(fit)
    run.record["fit"] = {"r2_study": fit.r2_study, "r2": fit.r2, "ssd": fit.ssd, "normalise": fit.normalise,
                         "dropped": fit.dropped, "time_s": fit.time,
                         "variation": dict(zip(("predicted", "observed"), fit.variation))}


def _warn_if_stretched(fit) -> None:
    """A fit whose normalised profiles were a few-% ripple before min-max normalisation: say what R^2 then measures."""
    import warnings

    from ..exceptions import AfferentWarning
    from ..profiles import SMALL_VARIATION, stretched

    small = stretched(fit)
    if small:
        varied = ", ".join(f"the {k} profile varies by {100 * v:.2g} %" for k, v in small.items())
        warnings.warn(f"Before min-max normalisation {varied} of its largest value (under {100 * SMALL_VARIATION:g} %): "
                      f"normalising stretches that ripple to 0..1, so R^2 = {fit.r2:.3g} (r2_study {fit.r2_study:.3g}) "
                      "compares the shapes of small ripples, not the profiles' contrast; compare with normalise = "
                      "'neither' too, or choose a profile step with more contrast.", AfferentWarning, stacklevel=2)


def _spike(run: _Run) -> None:
    """Stages 'input' and 'spiking' (:func:`afferent.spiking.spike_afferents`)."""
    from ..spiking import LIFParams, spike_afferents

    sp, out = run.scene.spikes, run.out
    lif = LIFParams.from_preset(sp.lif_preset)
    over = {f[: f.rfind("_")]: getattr(sp, f) for f in _LIF_FIELDS if getattr(sp, f) is not None}
    if over:
        lif = replace(lif, **over)
    duration = sp.duration_s
    if duration is None and out["afferent"].n_times == 1:
        duration = 1.0
    _refuse_step_numbers(run.scene, out["sed"], "spiking")  # not when a waveform's times drive the run
    _refuse_rate_keys_without_rate(run.scene, out["afferent"])
    zones = None
    if sp.branching == "zones":
        from ..zones import split_zones, zones_from_map

        zones = (zones_from_map(out["branching"], sp.zone_map) if sp.zone_map is not None
                 else split_zones(out["branching"], out["current"].layout, sp.zones_per_afferent))
    pr = spike_afferents(out["afferent"], lif, dt=sp.dt_s, engine=sp.engine, input=sp.input, current=out["current"],
                         branching=out["branching"], gain=sp.gain_s, tau=sp.tau_s, duration=duration, drive=sp.drive,
                         rheobase_multiple=sp.rheobase_multiple, reference_current=sp.reference_current_a, static_gain=sp.static_gain,
                         zones=zones, rectify=sp.rectify, slow_gain=sp.slow_gain_s, slow_tau=sp.slow_tau_s)
    run.steps.seconds.update(pr.seconds)
    spikes = pr.spikes
    out.update(spikes=spikes, drive=pr.input)
    run.span["simulated_s"] = float(spikes.duration)
    run.record["spikes"] = {
        "engine": spikes.engine, "backend": getattr(spikes, "backend", None), "dt_s": spikes.dt,
        "duration_s": spikes.duration, "input": getattr(pr.input, "kind", None),
        "input_params": {**{k: getattr(pr.input, k, None) for k in ("mode", "tau", "gain", "off_gain", "static_gain")},
                         **({"rectify": sp.rectify or "sum", "slow_gain_s": sp.slow_gain_s, "slow_tau_s": sp.slow_tau_s}
                            if sp.input == "slowly-adapting" else {})},
        "branching": sp.branching, **({"zones": zones.record()} if zones is not None else {}),
        "n_afferents": int(spikes.n_afferents), "n_spikes": int(sum(len(t) for t in spikes.spike_times)),
        "silent_skipped": [str(spikes.afferent_ids[i]) for i in spikes.silent_skipped],
        "notes": list(getattr(spikes, "notes", ())),
        "lif": {k: getattr(lif, k) for k in ("tau_m", "r_m", "v_rest", "v_thresh", "v_reset", "t_ref")},
        "drive": pr.drive,
    }
    if "nwb" in run.scene.outputs.want:  # what spikes.nwb says beside the spikes (afferent._nwb)
        from .._nwb import nwb_missing

        out["nwb"] = {"afferent_class": run.scene.afferent.afferent_class, "spikes": run.record["spikes"],
                      "metadata": run.scene.nwb}
        run.record["nwb"] = {"missing": nwb_missing(run.scene.nwb)}


# --------------------------------------------------------------------------------- CLI
def run_scene_cli(path: PathLike | Scene, *, output: PathLike | None=None, overwrite: bool = False, quiet: bool = False, cache_dir: PathLike | None=None,
                  use_cache: bool = True, command: str | None = None, speak: Callable[[str], None] | None=None, figure_process: bool = True) -> int:
    """``afferent run``: load (or take) a scene, run it, summarise on stderr; returns the exit code (0).

    Parameters
    ----------
    path : str, path-like or Scene
        The scene file, or a :class:`Scene` built from the command's options.
    output : str or path-like, optional
        Output folder, overriding ``[outputs] dir`` (relative to the current folder).
    overwrite : bool, default=False
        Replace an existing output folder.
    quiet : bool, default=False
        No summary, no progress bars, no warnings printed (they are still in run.json).
    cache_dir : str or path-like, optional
        Sampled-SED cache folder (default ``$AFFERENT_CACHE_DIR`` or ``~/.cache/afferent``).
    use_cache : bool, default=True
    command : str, optional
        The command line recorded in run.json; default ``afferent run PATH [-o OUT] [--overwrite]``.
    speak : callable, optional
        Rewrites a warning in the command's words (``afferent.cli._main.speak_cli``).
    figure_process : bool, default=True
        Draw the figures in a second process (:func:`run_scene`; the command's default, off with
        ``AFFERENT_FIGURE_PROCESS=0``).

    Raises
    ------
    The errors of :func:`load_scene` and :func:`run_scene`; :func:`afferent.cli.main` turns
    them into ``afferent: error: ...`` and exit code 2.
    """
    from .parse import load_scene

    scene = path if isinstance(path, Scene) else load_scene(path)
    if output is not None:
        scene = scene.with_output(output)
    if command is None:
        argv = [os.fspath(path)] + (["-o", os.fspath(output)] if output is not None else []) + (
            ["--overwrite"] if overwrite else [])
        command = "afferent run " + " ".join(argv)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_scene(scene, overwrite=overwrite, cache_dir=cache_dir, use_cache=use_cache,
                           progress=not quiet and sys.stderr.isatty(), record_extra={"command": command},
                           figure_process=figure_process)
    if quiet:
        return 0
    for line in summary_lines(result):
        print(line, file=sys.stderr)
    for msg in dict.fromkeys(str(w.message) for w in caught if not issubclass(w.category, _QUIET_CATEGORIES)):
        msg = " ".join(msg.split())
        print(f"afferent: warning: {speak(msg) if speak else msg}", file=sys.stderr)
    return 0
