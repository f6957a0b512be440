"""Sweep files -> tasks: a scene (or scenes) x parameter sets, each checked as a scene before anything runs.

Every error names the file, the key and its line, as scene errors do (the line lookup is
:func:`afferent.scene.key_lines`); a swept value a scene refuses is reported at its line in
``[sweep]``, with the value.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import os
import re
from dataclasses import dataclass, field

from .._validation import suggest
from ..scene.schema import _TABLES, Scene, SceneError, SceneTypeError, key_lines

#: Tables a sweep may vary ([scene] names and [outputs] are the sweep's own business).
_SWEEPABLE = tuple(t for t in _TABLES if t not in ("scene", "outputs"))
#: Tables upstream of sampling: tasks equal in these share one sampled SED.
_SAMPLING_TABLES = ("export", "receptors", "sampling", "region")
#: Outputs whose stages give per-afferent results (the table's rows).
_AFFERENT_OUTPUTS = ("currents", "profiles", "fit", "spikes")
_MODES = ("product", "zip")
_RANGE_KEYS = ("start", "stop", "num", "spacing")
#: Most tasks a sweep runs unless told otherwise (``max_tasks``). Tasks are made one at a time as
#: they are dispatched (:meth:`SweepSpec.iter_tasks`, ~15 us of CPU each: :class:`_Maker`), and the table is
#: streamed to its file (records.py: ``_gather``), so their number costs ~16 bytes a task (its id and index) and
#: the time to run them; the limit guards against a sweep of many more tasks than meant.
MAX_TASKS = 1_000_000


@dataclass(frozen=True)
class _Range:
    """A swept range ``{start, stop, num, spacing}``: its ``num`` values are made only when iterated,
    after the sweep's task count has been checked (a range of 10^10 values is refused, not allocated)."""

    start: float
    stop: float
    num: int
    spacing: str

    def __len__(self) -> int:
        return self.num

    def __iter__(self):
        import numpy as np

        grid = (np.geomspace if self.spacing == "log" else np.linspace)(self.start, self.stop, self.num)
        return (float(v) for v in grid)


@dataclass(frozen=True)
class _Base:
    """One scene of one sweep file: what each of its tasks is built from (shared by its tasks, pickled once a batch)."""

    sweep_path: str
    sweep_lines: dict = field(repr=False)
    params: dict = field(repr=False)  # swept key -> (values, line keys): only the line keys are used (errors)
    scene_path: str = ""
    tables: dict = field(default_factory=dict, repr=False)
    lines: dict = field(default_factory=dict, repr=False)

    def build(self, pset: dict) -> Scene:
        """The resolved scene of parameter set ``pset`` (SceneError, at the [sweep] line, for a value it refuses)."""
        scene = _build(self.tables, self.lines, scene_path=self.scene_path, base_dir=os.path.dirname(self.scene_path),
                       pset=pset, params=self.params, sweep_path=self.sweep_path, sweep_lines=self.sweep_lines)
        _check_outputs(scene, f"Scene file {self.scene_path!r}")
        return scene


@dataclass(frozen=True)
class Task:
    """One scene with one parameter set: the unit of work, of resume and of failure.

    Attributes
    ----------
    id : str
        16 hex digits: a digest of the scene's tables as written with the parameter set applied
        (and of its folder, its first parameter set's resolved scene and the content of every file
        it reads); equal ids mean equal results, so a re-run skips it.
    scene : Scene
        The resolved scene with the parameter set applied: built on first use (in the worker that
        runs the task), not when the task is made; a value it refuses raises SceneError then.
    label : str
        The scene's name (``[scene] name`` or the file's stem).
    params : dict
        Swept key as written (``'transduction.gamma_per_pa'``) -> value as written.
    group : str
        Digest of what sampling depends on (export content, read options, receptors,
        sampling method, region): tasks of one group share one sampled SED.
    index : int
        Position in the sweep's task stream (:meth:`SweepSpec.iter_tasks`): the task is made
        again from the specification and this index.
    """

    id: str
    label: str
    params: dict
    group: str
    index: int = 0
    base: _Base | None = field(default=None, repr=False, compare=False)
    built: Scene | None = field(default=None, repr=False, compare=False)

    @property
    def scene(self) -> Scene:
        if self.built is None:
            object.__setattr__(self, "built", self.base.build(self.params))
        return self.built


@dataclass(frozen=True)
class SweepSpec:
    """A sweep's specification: its files read and checked, its tasks counted but not made.

    Attributes
    ----------
    plans : tuple
        Per sweep file: ``(path, lines, mode, params, scenes)``, ``params`` the swept key ->
        (values: a list, or a range ``{start, stop, num, spacing}``; line keys), ``scenes`` the ``(scene file, tables, lines)``.
    keys : tuple
        The swept keys, as written (the table's columns).
    sources : tuple
        The sweep (or scene) files.
    mode : str
        'product', 'zip' or 'mixed'.
    n_tasks : int
        How many tasks :meth:`iter_tasks` makes (counted, not made).
    digest : str
        sha256 of the definition (each source's and scene file's content, the parameter
        specification): equal digests mean the same sweep (resume).
    """

    plans: tuple = field(repr=False)
    keys: tuple
    sources: tuple
    mode: str
    n_tasks: int
    digest: str

    def iter_tasks(self):
        """The tasks, made one at a time in a fixed order (each a resolved scene checked as in :func:`load_sweep`).

        Task ``i`` depends only on the specification, so a re-run makes the same tasks with the
        same ids; a task equal to an earlier one (a scene listed twice) is made again with the same id.
        """
        hashes: dict = {}
        index = 0
        for path, lines, mode, params, bases in self.plans:
            for scene_path, sdata, slines in bases:
                maker = _Maker(_Base(path, lines, params, scene_path, sdata, slines), mode, hashes)
                for pset in _combinations(params, mode or "product"):
                    yield maker.task(pset, index)
                    index += 1

    @property
    def tasks(self) -> tuple:
        """Every task, made at once (to inspect a small sweep; :func:`afferent.sweep` streams them)."""
        return tuple(self.iter_tasks())

    @property
    def groups(self) -> dict:
        """Sampling group -> its tasks, in task order (made at once, as :attr:`tasks`)."""
        out: dict = {}
        for t in self.iter_tasks():
            out.setdefault(t.group, []).append(t)
        return out

    def probe_tasks(self):
        """A few tasks, each checked as a scene, that together hold every swept value written and read every file
        the sweep's tasks read: per scene, the first parameter set, then each listed value (a file can only be a
        listed value) and each range's two ends of each swept key in turn (index -1: not tasks of the stream)."""
        hashes: dict = {}
        for path, lines, mode, params, bases in self.plans:
            first = next(_combinations(params, mode or "product"))
            sets = [first] + [dict(first, **{p: v}) for p, (vals, _) in params.items()
                              for v in (vals if isinstance(vals, list) else (float(vals.start), float(vals.stop)))]
            for scene_path, sdata, slines in bases:
                maker = _Maker(_Base(path, lines, params, scene_path, sdata, slines), mode, hashes)
                for pset in sets:
                    yield maker.task(pset, -1, maker.base.build(pset))


# --------------------------------------------------------------------------- reading
def _read_toml(path: str, what: str):
    from ..scene.parse import loads_toml, read_toml_text

    text = read_toml_text(path, what)
    return loads_toml(text, f"{what} {path!r}", path), key_lines(text)


def _where(path: str, lines: dict, *keys) -> str:
    n = next((lines[k] for k in keys if k in lines), None)
    return f"Sweep file {path!r}" + (f", line {n}" if n else "")


def _err(path, lines, keys, message, cls=SceneError, key=None):
    where = _where(path, lines, *keys)
    n = next((lines[k] for k in keys if k in lines), None)
    return cls(f"{where}: {message}", path=path, key=key, line=n)


def _scene_files(entry, path: str, lines: dict) -> list[str]:
    """``scenes = [...]`` or ``scenes = "folder"`` -> scene files (relative to the sweep file's folder)."""
    base = os.path.dirname(path)
    items = [entry] if isinstance(entry, str) else entry
    if not isinstance(items, list) or not items or not all(isinstance(v, str) and v for v in items):
        raise _err(path, lines, [("sweep", "scenes")], "[sweep] 'scenes' must be a folder or a non-empty array of scene "
                   f"files; got {entry!r} instead.", SceneTypeError, "[sweep] scenes")
    out = []
    for item in items:
        p = os.path.normpath(os.path.join(base, os.path.expanduser(item)))
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p) if f.endswith(".toml"))
            if not found:
                raise _err(path, lines, [("sweep", "scenes")], f"[sweep] 'scenes': folder {p!r} holds no .toml scene file.",
                           key="[sweep] scenes")
            out.extend(found)
        elif os.path.isfile(p):
            out.append(p)
        else:
            raise _err(path, lines, [("sweep", "scenes")], f"[sweep] 'scenes': {p!r} is neither a scene file nor a "
                       "folder of them.", "[sweep] scenes")
    return list(dict.fromkeys(out))  # a scene listed twice is one scene


def _values(param: str, value, path: str, lines: dict, keys):
    """A swept key's values: an array (list), or a range {start, stop, num[, spacing = 'linear'|'log']} (:class:`_Range`)."""
    if isinstance(value, list):
        if not value:
            raise _err(path, lines, keys, f"[sweep] {param!r} must list at least one value; got an empty array.",
                       key=f"[sweep] {param}")
        return value
    if isinstance(value, dict):
        unknown = [k for k in value if k not in _RANGE_KEYS]
        if unknown or not all(k in value for k in ("start", "stop", "num")):
            raise _err(path, lines, keys, f"[sweep] {param!r}: a range is {{start = A, stop = B, num = N}} (optional "
                       f"spacing = 'linear' or 'log'); got keys {', '.join(map(repr, value))} instead."
                       + (suggest(unknown[0], list(_RANGE_KEYS)) if unknown else ""), key=f"[sweep] {param}")
        start, stop, num, spacing = value["start"], value["stop"], value["num"], value.get("spacing", "linear")
        ok = all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in (start, stop))
        if not ok or not isinstance(num, int) or isinstance(num, bool) or num < 1 or spacing not in ("linear", "log") or (
                spacing == "log" and (start <= 0 or stop <= 0)):
            raise _err(path, lines, keys, f"[sweep] {param!r} must be a range of finite numbers start, stop (both > 0 "
                       f"for spacing = 'log'), an integer num >= 1 and spacing 'linear' or 'log'; got {value!r} instead.",
                       SceneTypeError, f"[sweep] {param}")
        return _Range(start, stop, num, spacing)
    raise _err(path, lines, keys, f"[sweep] {param!r} must be an array of values or a range {{start, stop, num}}; got "
               f"{value!r} ({type(value).__name__}) instead.", SceneTypeError, f"[sweep] {param}")


def _params_of(table: dict, path: str, lines: dict):
    """The ``[sweep]`` table -> (mode, scene files or None, {param: (values, line keys)})."""
    from ..scene.parse import _keys_of, _known_keys_text, key_hint

    mode = table.get("mode", "product")
    if mode not in _MODES:
        raise _err(path, lines, [("sweep", "mode")], f"[sweep] 'mode' must be one of 'product', 'zip'; got {mode!r} "
                   f"instead.{suggest(str(mode), list(_MODES))}", key="[sweep] mode")
    scenes = _scene_files(table["scenes"], path, lines) if "scenes" in table else None
    flat = []
    for k, v in table.items():
        if k in ("mode", "scenes"):
            continue
        if "." not in k and isinstance(v, dict) and k in _TABLES:  # dotted keys: transduction.gamma_per_pa = [...]
            flat.extend((f"{k}.{k2}", v2, [("sweep", k, k2)]) for k2, v2 in v.items())
        else:
            flat.append((k, v, [("sweep", k), ("sweep", *k.split("."))]))
    params, settings = {}, {}
    for param, value, keys in flat:
        tbl, _, key = param.partition(".")
        if not key or tbl not in _TABLES:
            hint = suggest(tbl, list(_SWEEPABLE))
            raise _err(path, lines, keys, f"unknown key {param!r} in [sweep]; a swept key is \"table.key\" with table "
                       f"one of {', '.join(_SWEEPABLE)} (e.g. \"transduction.gamma_per_pa\"), or mode, scenes.{hint}",
                       key=f"[sweep] {param}")
        if tbl not in _SWEEPABLE:
            raise _err(path, lines, keys, f"[sweep] {param!r}: [{tbl}] cannot be swept (a sweep writes one table into "
                       "its own output folder; scenes are named by [scene] name).", key=f"[sweep] {param}")
        known = _keys_of(_TABLES[tbl][1])
        if key not in known:
            raise _err(path, lines, keys, f"[sweep] {param!r}: unknown key {key!r} in [{tbl}]; known keys are "
                       f"{_known_keys_text(_TABLES[tbl][1])}.{key_hint(key, None, known)}", key=f"[sweep] {param}")
        setting = (tbl, known[key][0].name)
        if setting in settings:
            raise _err(path, lines, keys, f"[sweep] {param!r} and {settings[setting]!r} sweep the same setting; keep one.",
                       key=f"[sweep] {param}")
        settings[setting] = param
        params[param] = (_values(param, value, path, lines, keys), keys)
    if mode == "zip" and params:
        n = {p: len(v) for p, (v, _) in params.items()}
        first = next(iter(n))
        for p, k in n.items():
            if k != n[first]:
                raise _err(path, lines, params[p][1], f"[sweep] mode = 'zip' pairs the i-th values of every key, so all "
                           f"must have as many; {p!r} has {k}, {first!r} has {n[first]}.", key=f"[sweep] {p}")
    return mode, scenes, params


def _n_combinations(params: dict, mode: str) -> int:
    """How many parameter sets :func:`_combinations` gives, counted without making them."""
    sizes = [len(v) for v, _ in params.values()]
    return (min(sizes) if mode == "zip" else math.prod(sizes)) if sizes else 1


def _combinations(params: dict, mode: str):
    """The parameter sets, one at a time (never a list of them all)."""
    names = list(params)
    if not names:
        yield {}
        return
    lists = [list(params[p][0]) for p in names]
    combos = zip(*lists) if mode == "zip" else itertools.product(*lists)
    for c in combos:
        yield dict(zip(names, c))


# ------------------------------------------------------------------------- building
def _apply(data: dict, pset: dict) -> dict:
    """The scene tables with a parameter set written in (a key giving the same setting in another unit is replaced)."""
    from ..scene.parse import _keys_of

    out = copy.deepcopy(data)
    for param, value in pset.items():
        tbl, _, key = param.partition(".")
        known = _keys_of(_TABLES[tbl][1])
        target = known[key][0].name
        sec = out.setdefault(tbl, {})
        if isinstance(sec, dict):
            for k in [k for k in sec if k in known and known[k][0].name == target]:
                del sec[k]
            sec[key] = value
    return out


_PREFIX = re.compile(r"^Scene file '.*?'(?:, line \d+)?: |^Scene: ")


def _build(data, lines, *, scene_path, base_dir, pset, params, sweep_path, sweep_lines):
    """One resolved scene; a refused swept value is reported at its [sweep] line."""
    from ..scene.defaults import resolve
    from ..scene.parse import scene_from_dict

    try:
        return resolve(scene_from_dict(_apply(data, pset), base_dir=base_dir, source=scene_path, _lines=lines))
    except SceneError as err:
        for param, value in pset.items():
            tbl, _, key = param.partition(".")
            if err.key in (f"[{tbl}] {key}", f"[{tbl}]") and key in str(err):
                msg = _PREFIX.sub("", str(err))
                raise _err(sweep_path, sweep_lines, params[param][1], f"[sweep] {param!r} = {value!r}: {msg}",
                           type(err), f"[sweep] {param}") from err
        raise


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str).encode()).hexdigest()


def _input_files(scene: Scene) -> list[str]:
    files = list(dict.fromkeys(p for p in scene.export.files if os.path.isfile(p)))
    for p in (scene.export.coordinates, scene.receptors.file, scene.synthesis.map, scene.fit.observed,
              scene.stimulus.file, scene.transduction.calibration, scene.spikes.zone_map):
        if p is not None and os.path.isfile(p):
            files.append(p)
    return files


def _sampling_of(scene: Scene, hashes: dict) -> tuple:
    """(the sampling group's digest, the task's input files as canonical JSON {path: sha256}) of a resolved scene."""
    from ..scene.stages import _hash_all

    files = _input_files(scene)
    hashes.update(_hash_all({p: hashes.get(p) for p in files}))
    d = scene.to_dict()
    group = _digest({"tables": {t: d[t] for t in _SAMPLING_TABLES},
                     "exports": [hashes[p] for p in dict.fromkeys(scene.export.files) if p in hashes],
                     "files": {p: hashes[p] for p in (scene.export.coordinates, scene.receptors.file) if p in hashes}})
    return group, json.dumps({p: hashes[p] for p in files}, sort_keys=True)


def _field_kind(param: str) -> str:
    from ..scene.parse import _keys_of

    tbl, _, key = param.partition(".")
    return _keys_of(_TABLES[tbl][1])[key][0].metadata["kind"]


class _Maker:
    """Makes the tasks of one scene of a sweep file, ~20 us each rather than a resolved scene's ~1 ms.

    A task's id and group need no resolved scene of its own: the id is a digest of what determines the
    scene (the tables as written, the parameter set as written, the scene's folder; and, so that a changed
    default changes every id, the resolved scene of its first parameter set) and of the files it reads; the
    group depends only on the swept keys of the sampling tables ([export], [receptors], [sampling], [region]:
    :func:`afferent.scene.resolve` fills them from themselves alone), the files only on the swept keys that
    name files. Both are taken from a scene resolved once per distinct value of those keys, and the task's
    own scene is built when it runs (:attr:`Task.scene`).
    """

    def __init__(self, base: _Base, mode, hashes: dict):
        self.base, self.hashes = base, hashes
        names = list(base.params)
        self.sampling = [p for p in names if p.partition(".")[0] in _SAMPLING_TABLES]
        self.files = [p for p in names if _field_kind(p) in ("path", "paths")]
        first = next(_combinations(base.params, mode or "product"))
        scene = base.build(first)  # checked by load_sweep (SweepSpec.probe_tasks)
        self.label = scene.info.name
        d = scene.to_dict()
        d["outputs"]["dir"] = None
        self.prefix = _digest({"tables": _apply(base.tables, dict.fromkeys(names)), "dir": os.path.dirname(base.scene_path),
                               "label": self.label, "first": d})
        self.groups: dict = {}  # sampling keys' values -> group
        self.inputs: dict = {}  # file keys' values -> input files (JSON)

    def task(self, pset: dict, index: int, scene: Scene | None = None) -> Task:
        skey = tuple(_key(pset[p]) for p in self.sampling)
        fkey = tuple(_key(pset[p]) for p in self.files)
        group, inputs = self.groups.get(skey), self.inputs.get(fkey)
        if group is None or inputs is None:
            try:
                scene = scene or self.base.build(pset)
            except SceneError as err:  # the task fails when it runs, with this error; its own group samples nothing
                group, inputs = "!" + _digest(str(err))[:15], self.inputs.get(fkey, "")
            else:
                group, inputs = _sampling_of(scene, self.hashes)
                self.groups[skey], self.inputs[fkey] = group, inputs
        text = f"{self.prefix}|{json.dumps(pset, separators=(',', ':'), default=str)}|{inputs}"
        return Task(id=hashlib.sha256(text.encode()).hexdigest()[:16], label=self.label, params=dict(pset),
                    group=group, index=index, base=self.base, built=scene)


def _key(value):
    """A swept value as a dictionary key (an array value is written as JSON)."""
    return json.dumps(value) if isinstance(value, (list, dict)) else (type(value).__name__, value)


def _check_outputs(scene: Scene, where: str) -> None:
    if not set(scene.outputs.want) & set(_AFFERENT_OUTPUTS):
        raise SceneError(f"{where}: a sweep tabulates per-afferent results, so [outputs] want must include one of "
                         f"{', '.join(map(repr, _AFFERENT_OUTPUTS))}; got {list(scene.outputs.want)!r} instead.",
                         path=scene.source, key="[outputs] want")


def _read_sweep_file(path: str):
    """One sweep (or scene) file -> (its lines, mode or None, params, [(scene file, tables, lines)])."""
    data, lines = _read_toml(path, "Sweep file")
    table = data.pop("sweep", None)
    if table is None:
        mode, scene_files, params = None, None, {}
    else:
        if not isinstance(table, dict):
            raise _err(path, lines, [("sweep",)], f"'sweep' must be a table ([sweep]); got {table!r} instead.",
                       SceneTypeError, "sweep")
        mode, scene_files, params = _params_of(table, path, lines)
    if scene_files is None:
        return lines, mode, params, [(path, data, lines)]
    extra = [t for t in data if t in _TABLES]
    if extra:
        raise _err(path, lines, [(extra[0],)], f"[sweep] 'scenes' lists the scenes, so the sweep file must not "
                   f"hold scene tables too; got [{extra[0]}]. Keep either the tables or 'scenes'.",
                   key=f"[{extra[0]}]")
    return lines, mode, params, [(f, *_read_toml(f, "Scene file")) for f in scene_files]


def _check_count(plans: list, max_tasks: int | None) -> int:
    """The sweep's task count (counted, not made); more than ``max_tasks`` is refused."""
    limit = MAX_TASKS if max_tasks is None else max_tasks
    if not isinstance(limit, int) or isinstance(limit, bool) or limit < 1:
        raise ValueError(f"'max_tasks' must be a positive integer; got {max_tasks!r} instead.")
    counts = [(path, len(bases) * _n_combinations(params, mode or "product"))
              for path, (_, mode, params, bases) in plans]
    total = sum(n for _, n in counts)
    if total > limit:
        path, n = max(counts, key=lambda c: c[1])
        raise SceneError(
            f"Sweep file {path!r} makes {n:,} tasks (scene files x parameter sets"
            + (f"; {total:,} in all" if total != n else "") + f"); a sweep runs at most {limit:,} unless told "
            "more (a guard against a sweep of many more tasks than meant). Sweep fewer values, or raise the limit: "
            f"max_tasks={total} (afferent sweep --max-tasks {total}).", path=path)
    return total


def load_sweep(sources, *, max_tasks: int | None = None) -> SweepSpec:
    """Read sweep files, scene files or folders of scene files into tasks (each checked as a scene).

    Parameters
    ----------
    sources : str, path-like, or a sequence of them
        A sweep file (scene tables plus ``[sweep]``, or ``[sweep] scenes = [...]`` with the
        parameter keys), a plain scene file (one task), or a folder (each ``.toml`` in it).
    max_tasks : int, optional
        Most tasks (default ``MAX_TASKS``, 1,000,000); counted, never made here: the tasks are
        made one at a time as they run (:meth:`SweepSpec.iter_tasks`).

    Returns
    -------
    SweepSpec

    Raises
    ------
    FileNotFoundError
        A source that does not exist.
    SceneError, SceneTypeError
        More than ``max_tasks`` tasks (counted before any is built).
        A bad ``[sweep]`` key or value (named with its file and line), a scene error, a
        swept value a scene refuses (at its ``[sweep]`` line), two scenes with one name: every
        listed value and each range's two ends are checked here (:meth:`SweepSpec.probe_tasks`);
        a value inside a range that a scene refuses fails its task when it runs.
    """
    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    files = []
    for s in sources:
        p = os.path.abspath(os.fspath(s))
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p) if f.endswith(".toml"))
            if not found:
                raise FileNotFoundError(f"Folder {p!r} holds no .toml scene or sweep file.")
            files.extend(found)
        else:
            files.append(p)
    if not files:
        raise ValueError("'sources' must name at least one sweep file, scene file or folder; got none.")
    files = list(dict.fromkeys(files))
    plans = [(path, _read_sweep_file(path)) for path in files]
    total = _check_count(plans, max_tasks)
    keys = list(dict.fromkeys(p for _, (_, _, params, _) in plans for p in params))
    modes = {mode for _, (_, mode, _, _) in plans if mode is not None}
    for _, (_, _, _, bases) in plans:
        for _, sdata, _ in bases:
            sdata.pop("sweep", None)
    spec = SweepSpec(plans=tuple((path, *plan) for path, plan in plans), keys=tuple(keys), sources=tuple(files),
                     mode=modes.pop() if len(modes) == 1 else "mixed" if modes else "product", n_tasks=total,
                     digest=_spec_digest(plans))
    by_label: dict = {}
    for t in spec.probe_tasks():  # every value written checked as a scene before anything runs
        by_label.setdefault(t.label, set()).add(t.scene.source)
    for label, srcs in by_label.items():
        if len(srcs) > 1:
            raise SceneError(f"Scenes {', '.join(map(repr, sorted(srcs)))} are all named {label!r}; the sweep's table "
                             "tells scenes apart by name: give each its own [scene] name.")
    return spec


def _spec_digest(plans: list) -> str:
    """sha256 of a sweep's definition: each sweep and scene file's content (sha256), the swept keys and values."""
    from ..export import file_sha256

    def values(v):
        return [v.start, v.stop, v.num, v.spacing] if isinstance(v, _Range) else v

    return _digest([{"file": path, "sha256": file_sha256(path), "mode": mode,
                     "params": [[p, values(v)] for p, (v, _) in params.items()],
                     "scenes": [[f, file_sha256(f)] for f, _, _ in bases]}
                    for path, (_, mode, params, bases) in plans])
