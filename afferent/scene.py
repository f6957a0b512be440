"""Scenes: a whole experiment described once in a TOML file, run with the least work that answers it.

::

    scene.toml --load_scene--> Scene (checked, defaults filled) --plan--> stages needed by the outputs
               --run_scene--> only those stages --> OUTDIR/ (requested outputs + run.json)

A scene names the FE export(s) and their units, the receptor sites, a region of interest,
the transduction parameters (or a calibration result), the synthesis, the stimulus
waveform for a static export, the spiking engine and parameters, and the outputs wanted.
A full example, every key with its default (``#`` marks optional keys)::

    [scene]                       # optional
    name = "ramp"                 # default: the file's stem
    description = "0.88 mm indenter, ramp-and-hold"

    [export]
    file = "../block4/indent_0p88mm.vtu"   # or files = ["step0.vtu", "step1.vtu"] (one per time step)
    length_unit = "mm"            # required unless the file states it (as for read_sed)
    sed_unit = "MPa"
    # stress_unit, time_unit, sed_from = "field"|"exact"|"equivalent", poisson, preset, shear,
    # location = "point"|"cell", sed_column, stress_columns, strain_columns, coord_columns,
    # times = [..] (in time_unit), coordinates = "nodes.csv", on_nan = "raise"|"drop",
    # negative_tolerance = 0.25 (accepted negative SED / largest SED), format

    [receptors]                   # exactly one of file / grid
    file = "../block4/receptors.csv"
    length_unit = "mm"            # default: [export] length_unit
    # grid = "tips"               # papilla tips on the export's epidermis/dermis interface
    #   material_array = "layer", upper = 1, lower = 2, pitch_x_mm = 0.44, pitch_z_mm = 0.22
    # grid = "regular"            # ridge/papilla grid at height y (x/z extent: the export's)
    #   y_mm = 2.45, pitch_x_mm = 0.44, pitch_z_mm = 0.22, x_range_mm = [..], z_range_mm = [..], origin_mm = [x0, z0]

    [sampling]
    method = "linear"             # or "nearest"
    on_outside = "raise"          # or "warn", "nan"

    [region]                      # region of interest; default: everything
    x_range_mm = [1.5, 2.5]       # across the ridges
    z_range_mm = [0.0, 4.0]       # along the ridges

    [transduction]                # one of: params, alpha/gamma/lambda, calibration; default params = "start"
    params = "start"              # the study's table 5.2 row: "start", "longitudinal", "cross"
    # alpha_a = 2.46e-8           # (or alpha_ma) saturation current; with params: overrides that row's value
    # gamma_per_pa = 4.6e-3
    # lambda_pa = 300.0
    # calibration = "calibration/result.json"   # written by `afferent calibrate`
    # calibration_synthesis = "longitudinal"     # which synthesis of a two-synthesis result (default: its best)

    [synthesis]
    kind = "longitudinal"         # "cross", "map" (map = "map.csv"), "random" (receptors_per_afferent = 13, seed = 0)

    [stimulus]                    # optional; for a static export
    waveform = "ramp"             # "ramp", "sine" or "file"
    d_ref_mm = 0.5                # required: indentation depth of the static export (SED scales as (d/d_ref)^2)
    depth_mm = 0.5                # ramp (defaults: the study's 0.5 mm at 5 mm/s held 2 s)
    speed_mm_per_s = 5.0
    hold_s = 2.0
    # release = true, pre_s = 0.0, post_s = 0.1, dt_ms = 1.0
    # sine: frequency_hz, amplitude_mm, duration_s [, offset_mm, dt_ms, on_negative]
    # file: file = "depth.csv", length_unit = "mm" [, time_unit = "s", on_negative]

    [spikes]
    engine = "auto"               # = "exact"; "exact-numba", "exact-numpy", "fast" (grid, dt_ms), "brian2"
    dt_ms = 0.1
    lif_preset = "ra"             # afferent.spiking.LIF_PRESETS; any field overridable:
    # tau_m_ms, r_m_ohm, v_rest_mv, v_thresh_mv, v_reset_mv, t_ref_ms
    input = "rate-sensitive"      # or "static" (default)
    gain_s = 0.2                  # required for rate-sensitive
    # tau_ms = 5.0
    duration_s = 1.0              # default: the stimulus (1 s for a single static step)

    [fit]                         # required by the 'fit' output
    # observed = "observed.csv", length_unit = "mm", normalise = "both", position_column, response_column

    [outputs]
    want = ["currents", "profiles", "spikes", "plots"]   # of: sed_map currents profiles fit spikes plots vtu
    # dir = "results/ramp"        # default: results/<scene name> in the current folder

**Units live in key names.** A length is given as ``<name>_m``, ``<name>_mm`` or
``<name>_um``; a time as ``_s``, ``_ms`` or ``_us``; a speed as ``_m_per_s`` or
``_mm_per_s``; a voltage as ``_v`` or ``_mv``; a current as ``_a``, ``_ma``, ``_ua`` or
``_na``. Inside, everything is SI, and :meth:`Scene.to_dict` (the record) uses the SI key
(``x_range_m``). **Paths** given in a scene are relative to the scene file's folder.

**Errors name the key and its line.** An unknown table or key, or a value of the wrong type,
raises :class:`SceneError` (a ``ValueError``; :class:`SceneTypeError`, also a
``TypeError``, for a wrong type) whose message starts ``Scene file 'PATH', line N:``.
tomllib returns plain dicts without positions, so the line is found by scanning the text:
table headers (``[name]``, ``[[name]]``) set the current table, and the first ``key =`` (bare,
quoted or dotted) under it is the key's line; lines inside multi-line strings and arrays are
skipped. A key written inside an inline table is reported at the line of the table's own key.

**Least work.** :func:`plan` maps the wanted outputs to stages (``sed_map`` and ``vtu`` need
reading and sampling; ``currents`` and ``profiles`` add stimulus, transduction and synthesis;
``fit`` adds the comparison; ``spikes`` adds input and spiking). :func:`run_scene` runs only
those; imports follow (an SED map never imports brian2 nor, without ``plots``, matplotlib).
Only receptors inside the region are sampled (and the mesh is cropped to them before the
point location), only afferents they feed are built, and with ``duration_s`` shorter than the
stimulus only that span is transduced and simulated when no other output needs the rest.
Sampled SED is cached on disk (:mod:`afferent.cache`): a re-run with other transduction,
synthesis or spiking parameters reads nothing. ``run.json`` records what ran, how long it
took, what was skipped and why.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
import time
import tomllib
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field, fields, replace
from decimal import Decimal
from pathlib import Path

from ._validation import suggest
from .exceptions import AfferentError
from .export import profile_step_record
from .io import FORMATS

__all__ = [
    "Scene",
    "SceneError",
    "SceneTypeError",
    "SceneResult",
    "load_scene",
    "parse_scene",
    "scene_from_dict",
    "resolve",
    "plan",
    "run_scene",
    "run_scene_cli",
    "OUTPUTS",
    "STAGES",
]

#: What a scene can ask for (``[outputs] want``).
OUTPUTS = ("sed_map", "currents", "profiles", "fit", "spikes", "plots", "vtu")
#: The computing stages, in order; a run executes the subset :func:`plan` returns.
STAGES = ("reading", "sampling", "stimulus", "transduction", "synthesis", "comparison", "input", "spiking")

_CURRENT_STAGES = ("reading", "sampling", "stimulus", "transduction", "synthesis")
#: output -> stages it needs
NEEDS = {
    "sed_map": ("reading", "sampling"),
    "vtu": ("reading", "sampling"),
    "currents": _CURRENT_STAGES,
    "profiles": _CURRENT_STAGES,
    "fit": _CURRENT_STAGES + ("comparison",),
    "spikes": _CURRENT_STAGES + ("input", "spiking"),
    "plots": (),
}

#: Spiking engines (mirrors :data:`afferent.spiking.ENGINES`, kept here so that checking a
#: scene does not import the spiking module).
_ENGINES = ("auto", "exact", "exact-numba", "exact-numpy", "fast", "fast-numba", "fast-numpy", "brian2")

#: quantity -> (SI suffix, {suffix: power of ten to SI})
_QUANTITIES = {
    "length": ("m", {"m": 0, "mm": -3, "um": -6}),
    "time": ("s", {"s": 0, "ms": -3, "us": -6}),
    "speed": ("m_per_s", {"m_per_s": 0, "mm_per_s": -3, "um_per_s": -6}),
    "frequency": ("hz", {"hz": 0, "khz": 3}),
    "voltage": ("v", {"v": 0, "mv": -3}),
    "resistance": ("ohm", {"ohm": 0, "kohm": 3, "megaohm": 6}),
    "current": ("a", {"a": 0, "ma": -3, "ua": -6, "na": -9}),
}
_UNIT_WORDS = {"length": "m", "time": "s", "speed": "m/s", "frequency": "Hz", "voltage": "V", "resistance": "Ohm",
               "current": "A"}


# ------------------------------------------------------------------------------- errors
class SceneError(AfferentError, ValueError):
    """A scene that cannot be run: unknown key, bad value, missing requirement.

    Attributes ``path`` (scene file or None), ``key`` (``'[table] key'`` or None) and ``line``
    (1-based line in the file, or None) say where.
    """

    def __init__(self, message: str, *, path=None, key=None, line=None):
        super().__init__(message)
        self.path, self.key, self.line = path, key, line


class SceneTypeError(SceneError, TypeError):
    """A scene value of the wrong type (also a ``TypeError``)."""


# ---------------------------------------------------------------------- key positions
_BARE = r"[A-Za-z0-9_-]+"
_QUOTED = r"\"(?:[^\"\\]|\\.)*\"|'[^']*'"
_KEYPART = rf"(?:{_BARE}|{_QUOTED})"
_DOTTED = rf"{_KEYPART}(?:\s*\.\s*{_KEYPART})*"
_HEADER_RE = re.compile(rf"^\s*\[\[?\s*({_DOTTED})\s*\]\]?\s*(?:#.*)?$")
_KEY_RE = re.compile(rf"^\s*({_DOTTED})\s*=")


def _split_dotted(text: str) -> tuple[str, ...]:
    return tuple(p[1:-1] if p[0] in "\"'" else p for p in re.findall(_KEYPART, text))


def _bracket_depth(text: str) -> int:
    """Net count of '[' minus ']' outside strings and comments (for multi-line arrays)."""
    depth, quote, i = 0, None, 0
    while i < len(text):
        c = text[i]
        if quote:
            if c == "\\" and quote == '"':
                i += 1
            elif c == quote:
                quote = None
        elif c in "\"'":
            quote = c
        elif c == "#":
            break
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        i += 1
    return depth


def key_lines(text: str) -> dict[tuple[str, ...], int]:
    """Map each table header and key of a TOML text to its 1-based line.

    ``('spikes',)`` is the line of the ``[spikes]`` header, ``('spikes', 'dt_ms')`` that of
    ``dt_ms = ...`` under it. tomllib gives no positions, so this scans the text (see the
    module docstring for the rules). The first occurrence wins.
    """
    out: dict[tuple[str, ...], int] = {}
    table: tuple[str, ...] = ()
    multiline: str | None = None
    depth = 0
    for n, line in enumerate(text.splitlines(), 1):
        if multiline:
            if line.count(multiline) % 2 == 1:
                multiline = None
            continue
        if depth > 0:
            depth += _bracket_depth(line)
            continue
        m = _HEADER_RE.match(line)
        if m:
            table = _split_dotted(m.group(1))
            out.setdefault(table, n)
            continue
        m = _KEY_RE.match(line)
        if m:
            out.setdefault(table + _split_dotted(m.group(1)), n)
            rest = line[m.end():]
            for q in ('"""', "'''"):
                if rest.count(q) % 2 == 1:
                    multiline = q
                    break
            else:
                depth = max(_bracket_depth(rest), 0)
    return out


@dataclass(frozen=True)
class _Origin:
    """Where a scene came from: for messages (path, key lines) and relative paths (base_dir)."""

    path: str | None
    base_dir: str
    lines: dict
    #: table -> {SI field name: key as written (e.g. 'dt_ms')}
    given: dict = field(default_factory=dict)

    def line(self, table: str, key: str | None = None) -> int | None:
        if key is not None and (table, key) in self.lines:
            return self.lines[(table, key)]
        return self.lines.get((table,))

    def where(self, table: str | None = None, key: str | None = None) -> tuple[str, int | None]:
        n = self.line(table, key) if table else (self.lines.get((key,)) if key else None)
        if self.path is None:
            return "Scene", n
        return (f"Scene file {self.path!r}" + (f", line {n}" if n else "")), n

    def error(self, table, key, message, *, cls=SceneError):
        where, n = self.where(table, key)
        label = f"[{table}] {key}" if table and key else (f"[{table}]" if table else key)
        return cls(f"{where}: {message}", path=self.path, key=label, line=n)


# ------------------------------------------------------------------------- the schema
def _f(kind: str, default=None, *, quantity: str | None = None, choices: tuple = (), aliases: tuple = (), doc: str = ""):
    """A scene key: dataclass default None (= not given); ``default`` is filled in by :func:`resolve`."""
    return field(default=None, metadata={"kind": kind, "default": default, "quantity": quantity,
                                         "choices": choices, "aliases": aliases, "doc": doc})


@dataclass(frozen=True)
class SceneInfo:
    """``[scene]``: a name (default: the file's stem) and a free-text description."""

    name: str | None = _f("str")
    description: str | None = _f("str")


@dataclass(frozen=True)
class ExportSpec:
    """``[export]``: the FE export(s) and how to read them (the options of :func:`afferent.read_sed`)."""

    files: tuple | None = _f("paths", aliases=("file",), doc="export file(s), one per time step")
    length_unit: str | None = _f("str")
    sed_unit: str | None = _f("str")
    stress_unit: str | None = _f("str")
    time_unit: str | None = _f("str")
    sed_from: str | None = _f("choice", "field", choices=("field", "exact", "equivalent"))
    poisson: float | None = _f("number")
    preset: str | None = _f("str")
    shear: str | None = _f("choice", choices=("tensor", "engineering"))
    location: str | None = _f("choice", choices=("point", "cell"))
    sed_column: object = _f("str_or_strs")
    stress_columns: object = _f("str_or_strs")
    strain_columns: object = _f("str_or_strs")
    coord_columns: tuple | None = _f("strs")
    times: tuple | None = _f("numbers")
    coordinates: str | None = _f("path")
    on_nan: str | None = _f("choice", "raise", choices=("raise", "drop"))
    negative_tolerance: float | None = _f("number", 0.25, doc="accepted negative SED, relative to the largest SED")
    format: str | None = _f("choice", choices=tuple(FORMATS))

    def read_kwargs(self) -> dict:
        """Keyword arguments for :func:`afferent.read_sed` (without ``progress``)."""
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "files"}
        for name in ("sed_column", "stress_columns", "strain_columns"):
            if isinstance(kw[name], tuple) and len(kw[name]) == 1:
                kw[name] = kw[name][0]
        return kw


_GRID_KEYS = ("y_m", "x_range_m", "z_range_m", "origin_m", "pitch_x_m", "pitch_z_m")
_GRID_DEFAULTS = {"pitch_x_m": 0.44e-3, "pitch_z_m": 0.22e-3, "material_array": "layer", "upper": 1, "lower": 2}
_TIPS_KEYS = ("material_array", "upper", "lower")


@dataclass(frozen=True)
class ReceptorSpec:
    """``[receptors]``: a receptor CSV (``file``) or a generated ``grid`` ('tips' or 'regular')."""

    file: str | None = _f("path")
    length_unit: str | None = _f("str", doc="unit of the CSV's x, y, z; default [export] length_unit")
    grid: str | None = _f("choice", choices=("tips", "regular"))
    y_m: float | None = _f("number", quantity="length")
    pitch_x_m: float | None = _f("number", quantity="length", doc="grids; default 0.44 mm (ridge pitch)")
    pitch_z_m: float | None = _f("number", quantity="length", doc="grids; default 0.22 mm (papilla pitch)")
    x_range_m: tuple | None = _f("pair", quantity="length")
    z_range_m: tuple | None = _f("pair", quantity="length")
    origin_m: tuple | None = _f("pair", quantity="length", doc="(x0, z0): a point of a regular grid")
    material_array: str | None = _f("str", doc="tips; default 'layer'")
    upper: object = _f("int_or_ints", doc="tips; default 1 (epidermis)")
    lower: object = _f("int_or_ints", doc="tips; default 2 (dermis)")


@dataclass(frozen=True)
class SamplingSpec:
    """``[sampling]``: how SED is sampled at the receptors (:func:`afferent.sample_sed`)."""

    method: str | None = _f("choice", "linear", choices=("linear", "nearest"))
    on_outside: str | None = _f("choice", "raise", choices=("raise", "warn", "nan"))


@dataclass(frozen=True)
class RegionSpec:
    """``[region]``: the region of interest in the skin plane; a missing range is unbounded."""

    x_range_m: tuple | None = _f("pair", quantity="length")
    z_range_m: tuple | None = _f("pair", quantity="length")

    @property
    def bounded(self) -> bool:
        return self.x_range_m is not None or self.z_range_m is not None


@dataclass(frozen=True)
class TransductionSpec:
    """``[transduction]``: the sigmoid's parameters, a study row, or a calibration result."""

    params: str | None = _f("choice", choices=("start", "longitudinal", "cross"))
    alpha_a: float | None = _f("number", quantity="current")
    gamma_per_pa: float | None = _f("number")
    lambda_pa: float | None = _f("number")
    calibration: str | None = _f("path")
    calibration_synthesis: str | None = _f("str")


@dataclass(frozen=True)
class SynthesisSpec:
    """``[synthesis]``: receptor -> afferent grouping (:func:`afferent.pipeline.make_branching`)."""

    kind: str | None = _f("choice", "longitudinal", choices=("longitudinal", "cross", "map", "random"))
    map: str | None = _f("path")
    receptors_per_afferent: int | None = _f("int")
    seed: int | None = _f("int", 0)


_RAMP_KEYS = ("depth_m", "speed_m_per_s", "hold_s", "release", "pre_s", "post_s")
_SINE_KEYS = ("frequency_hz", "amplitude_m", "offset_m", "duration_s")
_FILE_KEYS = ("file", "length_unit", "time_unit")
_RAMP_DEFAULTS = {"depth_m": 0.5e-3, "speed_m_per_s": 5e-3, "hold_s": 2.0, "release": True, "pre_s": 0.0, "post_s": 0.1}


@dataclass(frozen=True)
class StimulusSpec:
    """``[stimulus]``: the indentation waveform driving a static export (:mod:`afferent.stimulus`)."""

    waveform: str | None = _f("choice", choices=("ramp", "sine", "file"))
    d_ref_m: float | None = _f("number", quantity="length")
    depth_m: float | None = _f("number", quantity="length")
    speed_m_per_s: float | None = _f("number", quantity="speed")
    hold_s: float | None = _f("number", quantity="time")
    release: bool | None = _f("bool")
    pre_s: float | None = _f("number", quantity="time")
    post_s: float | None = _f("number", quantity="time")
    frequency_hz: float | None = _f("number", quantity="frequency")
    amplitude_m: float | None = _f("number", quantity="length")
    offset_m: float | None = _f("number", quantity="length")
    duration_s: float | None = _f("number", quantity="time")
    dt_s: float | None = _f("number", quantity="time")
    file: str | None = _f("path")
    length_unit: str | None = _f("str")
    time_unit: str | None = _f("str")
    on_negative: str | None = _f("choice", choices=("raise", "clip"))
    reference_step: int | None = _f("int", doc="the export step solved at d_ref; required when the export has several")
    series_depths_m: tuple | None = _f("numbers", quantity="length",
                                       doc="depth of every step of a loading-series export: measures the d^2 scaling")


_LIF_FIELDS = ("tau_m_s", "r_m_ohm", "v_rest_v", "v_thresh_v", "v_reset_v", "t_ref_s")


@dataclass(frozen=True)
class SpikesSpec:
    """``[spikes]``: input current and leaky integrate-and-fire (:func:`afferent.pipeline.run_spikes`)."""

    engine: str | None = _f("choice", "auto", choices=_ENGINES)
    dt_s: float | None = _f("number", 1e-4, quantity="time")
    lif_preset: str | None = _f("str", "ra")
    tau_m_s: float | None = _f("number", quantity="time")
    r_m_ohm: float | None = _f("number", quantity="resistance")
    v_rest_v: float | None = _f("number", quantity="voltage")
    v_thresh_v: float | None = _f("number", quantity="voltage")
    v_reset_v: float | None = _f("number", quantity="voltage")
    t_ref_s: float | None = _f("number", quantity="time")
    input: str | None = _f("choice", "static", choices=("static", "rate-sensitive"))
    drive: str | None = _f("choice", "resistance", choices=("resistance", "rheobase"),
                           doc="current -> membrane: through r_m as is, or the largest current -> k x rheobase")
    rheobase_multiple: float | None = _f("number", 2.0, doc="drive = 'rheobase': the reference current's multiple")
    reference_current_a: float | None = _f("number", quantity="current", doc="drive = 'rheobase': default the largest")
    gain_s: float | None = _f("number", quantity="time")
    tau_s: float | None = _f("number", quantity="time")
    duration_s: float | None = _f("number", quantity="time")


@dataclass(frozen=True)
class FitSpec:
    """``[fit]``: the recorded profile the 'fit' output compares with (:func:`afferent.profiles.read_observed`)."""

    observed: str | None = _f("path")
    length_unit: str | None = _f("str")
    normalise: str | None = _f("choice", "both", choices=("both", "prediction", "observation", "neither"))
    position_column: str | None = _f("str", "position")
    response_column: str | None = _f("str", "response")


@dataclass(frozen=True)
class OutputSpec:
    """``[outputs]``: what to produce (``want``, from :data:`OUTPUTS`) and where (``dir``)."""

    want: tuple | None = _f("outputs", choices=OUTPUTS)
    dir: str | None = _f("path")


#: TOML table -> Scene field
_TABLES = {
    "scene": ("info", SceneInfo),
    "export": ("export", ExportSpec),
    "receptors": ("receptors", ReceptorSpec),
    "sampling": ("sampling", SamplingSpec),
    "region": ("region", RegionSpec),
    "transduction": ("transduction", TransductionSpec),
    "synthesis": ("synthesis", SynthesisSpec),
    "stimulus": ("stimulus", StimulusSpec),
    "spikes": ("spikes", SpikesSpec),
    "fit": ("fit", FitSpec),
    "outputs": ("outputs", OutputSpec),
}
_TABLE_OF_FIELD = {attr: table for table, (attr, _) in _TABLES.items()}


@dataclass(frozen=True)
class Scene:
    """One experiment: what to read, where the receptors are, what to compute, what to write.

    Build it with :func:`load_scene` (a TOML file), :func:`parse_scene` (TOML text) or
    :func:`scene_from_dict`; each section is a frozen dataclass whose field names are the
    SI keys (``x_range_m``, ``dt_s``). A field left ``None`` was not given; :func:`resolve`
    fills the defaults and checks what each requested output needs.

    Attributes
    ----------
    info, export, receptors, sampling, region, transduction, synthesis, stimulus, spikes, fit, outputs
        The ``[scene]``, ``[export]``, ... tables.
    source : str or None
        The scene file (absolute path), if read from one.
    resolved : bool
        True once :func:`resolve` has filled defaults and checked requirements.
    """

    export: ExportSpec = field(default_factory=ExportSpec)
    receptors: ReceptorSpec = field(default_factory=ReceptorSpec)
    outputs: OutputSpec = field(default_factory=OutputSpec)
    info: SceneInfo = field(default_factory=SceneInfo)
    sampling: SamplingSpec = field(default_factory=SamplingSpec)
    region: RegionSpec = field(default_factory=RegionSpec)
    transduction: TransductionSpec = field(default_factory=TransductionSpec)
    synthesis: SynthesisSpec = field(default_factory=SynthesisSpec)
    stimulus: StimulusSpec = field(default_factory=StimulusSpec)
    spikes: SpikesSpec = field(default_factory=SpikesSpec)
    fit: FitSpec = field(default_factory=FitSpec)
    source: str | None = None
    resolved: bool = False
    origin: _Origin = field(default_factory=lambda: _Origin(None, os.getcwd(), {}), compare=False, repr=False)

    def to_dict(self) -> dict:
        """The scene as plain JSON-ready tables, keys in SI (``x_range_m``); ``None`` = not given / not used.

        ``scene_from_dict(scene.to_dict())`` gives back an equal scene.
        """
        out = {}
        for table, (attr, _) in _TABLES.items():
            sec = getattr(self, attr)
            out[table] = {f.name: _plain_json(getattr(sec, f.name)) for f in fields(sec)}
        return out

    def with_output(self, path) -> "Scene":
        """The same scene writing into ``path`` (relative to the current folder)."""
        return replace(self, outputs=replace(self.outputs, dir=os.path.abspath(os.fspath(path))))

    def __repr__(self) -> str:
        name = self.info.name or (Path(self.source).stem if self.source else "scene")
        want = ", ".join(self.outputs.want or ()) or "nothing yet"
        files = ", ".join(os.path.basename(f) for f in (self.export.files or ())) or "no export"
        return f"<Scene {name!r}: {files} -> {want}{'' if self.resolved else ' (unresolved)'}>"


def _plain_json(v):
    if isinstance(v, tuple):
        return [_plain_json(x) for x in v]
    return v


# ---------------------------------------------------------------------------- parsing
def _keys_of(cls) -> dict[str, tuple]:
    """Accepted key -> (dataclass field, power of ten to SI or None)."""
    out = {}
    for f in fields(cls):
        q = f.metadata.get("quantity")
        if q:
            si, units = _QUANTITIES[q]
            base = f.name[: -len(si) - 1]
            for suffix, exp in units.items():
                out[f"{base}_{suffix}"] = (f, exp)
        else:
            out[f.name] = (f, None)
        for alias in f.metadata.get("aliases", ()):
            out[alias] = (f, None)
    return out


def _known_keys_text(cls) -> str:
    parts = []
    for f in fields(cls):
        q = f.metadata.get("quantity")
        if q:
            si, units = _QUANTITIES[q]
            parts.append(f"{f.name[: -len(si) - 1]}_<{'|'.join(units)}>")
        else:
            parts.append(f.name)
    return ", ".join(parts)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _scale(v, exp):
    """``v * 10**exp`` as an exact decimal shift (0.68 mm -> 0.00068 m, the float nearest 0.68e-3)."""
    if exp in (None, 0):
        return float(v)
    return float(Decimal(repr(float(v))).scaleb(exp))


def _type_name(v) -> str:
    return {"str": "a string", "int": "an integer", "float": "a number", "bool": "a boolean", "list": "an array",
            "dict": "a table"}.get(type(v).__name__, type(v).__name__)


def _convert(value, f, exp, *, origin: _Origin, table: str, key: str):
    md = f.metadata
    kind, choices = md["kind"], md["choices"]
    q = md.get("quantity")
    unit = ""
    if q:  # the unit as written in the key: 'dt_ms' -> ' in ms'
        written = max((u for u in _QUANTITIES[q][1] if key.endswith("_" + u)), key=len)
        unit = f" in {written.replace('_per_', '/')}"

    def bad_type(expect):
        return origin.error(table, key, f"[{table}] {key!r} must be {expect}; got {value!r} ({_type_name(value)}) instead.",
                            cls=SceneTypeError)

    def bad_value(expect, hint=""):
        return origin.error(table, key, f"[{table}] {key!r} must be {expect}; got {value!r} instead.{hint}")

    def finite(v):
        if isinstance(v, float) and not math.isfinite(v):
            raise bad_value(f"a finite number{unit}")
        return v

    def path(v):
        p = Path(os.path.expanduser(v))
        return os.path.normpath(str(p if p.is_absolute() else Path(origin.base_dir) / p))

    if kind in ("str", "choice"):
        if not isinstance(value, str):
            raise bad_type("a string" + (f", one of {', '.join(map(repr, choices))}" if choices else ""))
        if kind == "choice" and value not in choices:
            raise bad_value(f"one of {', '.join(map(repr, choices))}", suggest(value, choices))
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise bad_type("true or false")
        return value
    if kind == "int":
        if not isinstance(value, int) or isinstance(value, bool):
            raise bad_type("an integer")
        return value
    if kind == "number":
        if not _is_number(value):
            raise bad_type(f"a number{unit}")
        return _scale(finite(value), exp)
    if kind == "path":
        if not isinstance(value, str) or not value:
            raise bad_type("a path (a non-empty string)")
        return path(value)
    if kind == "paths":
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not items or not all(isinstance(v, str) and v for v in items):
            raise bad_type("a path or a non-empty array of paths")
        return tuple(path(v) for v in items)
    if kind in ("strs", "outputs"):
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise bad_type("an array of strings")
        if kind == "outputs":
            for v in value:
                if v not in choices:
                    raise origin.error(table, key, f"[{table}] {key!r} must list outputs among "
                                       f"{', '.join(map(repr, choices))}; got {v!r} instead.{suggest(v, choices)}")
            if not value:
                raise bad_value(f"a non-empty array of outputs among {', '.join(map(repr, choices))}")
            return tuple(dict.fromkeys(value))
        return tuple(value)
    if kind == "str_or_strs":
        if isinstance(value, str):
            return value
        if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
            raise bad_type("a string or an array of strings")
        return tuple(value)
    if kind == "numbers":
        if not isinstance(value, list) or not all(_is_number(v) for v in value):
            raise bad_type(f"an array of numbers{unit}")
        return tuple(_scale(finite(v), exp) for v in value)
    if kind == "pair":
        if not isinstance(value, list) or len(value) != 2 or not all(_is_number(v) for v in value):
            raise bad_type(f"a pair [min, max] of numbers{unit}")
        lo, hi = (_scale(finite(v), exp) for v in value)
        if lo > hi and f.name != "origin_m":
            raise bad_value(f"a pair [min, max]{unit} with min <= max")
        return (lo, hi)
    if kind == "int_or_ints":
        ok = (isinstance(value, int) and not isinstance(value, bool)) or (
            isinstance(value, list) and value and all(isinstance(v, int) and not isinstance(v, bool) for v in value))
        if not ok:
            raise bad_type("an integer or an array of integers")
        return value if isinstance(value, int) else tuple(value)
    raise AssertionError(kind)  # pragma: no cover - schema bug


def _parse_table(cls, data: dict, *, origin: _Origin, table: str):
    keys = _keys_of(cls)
    values, given_as = {}, {}
    for key, value in data.items():
        if key not in keys:
            hint = suggest(key, list(keys))
            raise origin.error(table, key, f"unknown key {key!r} in [{table}]; known keys are {_known_keys_text(cls)}.{hint}")
        f, exp = keys[key]
        if f.name in values:
            raise origin.error(table, key, f"[{table}] {key!r} and {given_as[f.name]!r} give the same setting; keep one.")
        values[f.name] = _convert(value, f, exp, origin=origin, table=table, key=key)
        given_as[f.name] = key
    return cls(**values), given_as


def scene_from_dict(data: dict, *, base_dir=None, source=None, _lines=None) -> Scene:
    """Build a :class:`Scene` from tables (as :func:`tomllib.loads` or :meth:`Scene.to_dict` give them).

    Parameters
    ----------
    data : dict
        ``{'export': {...}, 'receptors': {...}, ...}``; ``None`` values count as not given.
    base_dir : str or path-like, optional
        Folder that relative paths are resolved against; default the current folder.
    source : str, optional
        The scene file, for messages.

    Returns
    -------
    Scene
        Not yet resolved (see :func:`resolve`).

    Raises
    ------
    SceneError, SceneTypeError
        Unknown table or key; a value of the wrong type or out of its choices.
    """
    origin = _Origin(None if source is None else os.fspath(source), os.path.abspath(os.fspath(base_dir or os.getcwd())),
                     dict(_lines or {}))
    if not isinstance(data, dict):
        raise SceneTypeError(f"A scene must be a table of tables; got {_type_name(data)} instead.")
    sections, given = {}, {}
    for table, value in data.items():
        if table not in _TABLES:
            if isinstance(value, dict):
                hint = suggest(table, list(_TABLES))
                raise origin.error(table, None, f"unknown table [{table}]; known tables are "
                                   f"{', '.join(f'[{t}]' for t in _TABLES)}.{hint}")
            hint = suggest(table, list(_TABLES))
            raise origin.error(None, table, f"unknown key {table!r} outside any table; a scene holds only the tables "
                               f"{', '.join(f'[{t}]' for t in _TABLES)}.{hint}")
        if not isinstance(value, dict):
            raise origin.error(None, table, f"{table!r} must be a table ([{table}]); got {value!r} "
                               f"({_type_name(value)}) instead.", cls=SceneTypeError)
        attr, cls = _TABLES[table]
        clean = {k: v for k, v in value.items() if v is not None}
        sections[attr], given[table] = _parse_table(cls, clean, origin=origin, table=table)
    origin.given.update(given)
    return Scene(**sections, source=origin.path, origin=origin)


def parse_scene(text: str, *, base_dir=None, source=None) -> Scene:
    """Parse a scene from TOML text (relative paths against ``base_dir``); see :func:`load_scene`."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        where = f"Scene file {os.fspath(source)!r}" if source else "Scene"
        raise SceneError(f"{where} is not valid TOML: {err}.", path=source) from err
    return scene_from_dict(data, base_dir=base_dir, source=source, _lines=key_lines(text))


def load_scene(path, *, resolve_defaults: bool = True) -> Scene:
    """Read a scene file (TOML, read with :mod:`tomllib`).

    Parameters
    ----------
    path : str or path-like
        The ``.toml`` file. Relative paths inside it are resolved against its folder.
    resolve_defaults : bool, default=True
        Fill defaults and check requirements (:func:`resolve`); False returns the scene as written.

    Returns
    -------
    Scene

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SceneError, SceneTypeError
        Invalid TOML; an unknown table or key, a wrong type or a bad value (the message names
        the key and its line); a requirement missing (e.g. ``[export] file``).

    Examples
    --------
    >>> scene = load_scene("sample_sed/scenes/sed_map.toml")  # doctest: +SKIP
    >>> plan(scene)  # doctest: +SKIP
    ['reading', 'sampling']
    """
    path = os.path.abspath(os.fspath(path))
    if not os.path.isfile(path):
        raise FileNotFoundError(f"Scene file {path!r} not found.")
    with open(path, "rb") as f:
        raw = f.read()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SceneError(f"Scene file {path!r} must be UTF-8 text (TOML); it is not: {err}.", path=path) from err
    scene = parse_scene(text, base_dir=os.path.dirname(path), source=path)
    return resolve(scene) if resolve_defaults else scene


# -------------------------------------------------------------------------- resolving
def _given(scene: Scene, table: str, name: str) -> str:
    """The key as the user wrote it (``dt_ms``) for field ``name`` of ``table``, else the SI key."""
    return scene.origin.given.get(table, {}).get(name, name)


def _fill(sec):
    """Fill the schema defaults of a section (fields still None)."""
    updates = {f.name: f.metadata["default"] for f in fields(sec)
               if getattr(sec, f.name) is None and f.metadata["default"] is not None}
    return replace(sec, **updates) if updates else sec


def _check_unit(scene, origin, table, name, checker):
    value = getattr(getattr(scene, _TABLES[table][0]), name)
    if value is None:
        return
    try:
        checker(value)
    except ValueError as err:
        key = _given(scene, table, name)
        raise origin.error(table, key, f"[{table}] {key!r}: {err}") from err


def resolve(scene: Scene) -> Scene:
    """Fill defaults and check that the scene can produce what it asks for.

    Defaults: those documented in the module docstring; ``[receptors] length_unit`` and ``[fit]
    length_unit`` from ``[export] length_unit``; ``params = "start"`` when no transduction
    parameter is given; ``[outputs] dir`` = ``results/<name>`` in the current folder.
    Idempotent.

    Raises
    ------
    SceneError
        A requirement missing or contradictory (no export; both or neither of receptor
        ``file`` / ``grid``; a waveform without ``d_ref``; keys that have no effect, such as
        ``depth_mm`` without a waveform; ...), with the key and line where one applies.
    """
    if scene.resolved:
        return scene
    o = scene.origin
    from .units import length_factor, sed_factor, time_factor

    err = o.error
    # [export]
    ex = _fill(scene.export)
    if not ex.files:
        raise err("export", None, "[export] must name the FE export: file = \"PATH\" (or files = [...], one per time step).")
    for name, checker in (("length_unit", length_factor), ("sed_unit", sed_factor), ("stress_unit", sed_factor),
                          ("time_unit", time_factor)):
        _check_unit(scene, o, "export", name, checker)
    if ex.sed_from == "equivalent" and ex.poisson is None:
        raise err("export", "sed_from", "[export] sed_from = 'equivalent' needs 'poisson' (the study's skin: 0.48).")
    # [receptors]
    raw = scene.receptors
    rec = _fill(raw)
    if (rec.file is None) == (rec.grid is None):
        raise err("receptors", None, "[receptors] must give exactly one of 'file' (a receptor CSV) and 'grid' "
                  f"('tips' or 'regular'); got {'both' if rec.file else 'neither'} instead.")
    if rec.file is not None:
        extra = [_given(scene, "receptors", k) for k in _GRID_KEYS + _TIPS_KEYS if getattr(raw, k) is not None]
        if extra:
            raise err("receptors", extra[0], f"[receptors] {extra[0]!r} applies to a generated grid, not to a receptor "
                      "file; remove it or use grid = ... instead of file.")
        if rec.length_unit is None:
            if ex.length_unit is None:
                raise err("receptors", "file", "[receptors] needs 'length_unit' (the unit of the CSV's x, y, z): "
                          "[export] declares none to default to.")
            rec = replace(rec, length_unit=ex.length_unit)
        _check_unit(replace(scene, receptors=rec), o, "receptors", "length_unit", length_factor)
    elif rec.grid == "regular":
        if rec.y_m is None:
            raise err("receptors", "grid", "[receptors] grid = 'regular' needs the receptors' height: y_mm = H (or y_m).")
        bad = [_given(scene, "receptors", k) for k in _TIPS_KEYS if getattr(raw, k) is not None]
        if bad:
            raise err("receptors", bad[0], f"[receptors] {bad[0]!r} applies to grid = 'tips', not 'regular'.")
    else:  # tips
        bad = [_given(scene, "receptors", k) for k in _GRID_KEYS[:4] if getattr(raw, k) is not None]
        if bad:
            raise err("receptors", bad[0], f"[receptors] {bad[0]!r} applies to grid = 'regular', not 'tips' "
                      "(use [region] to restrict the tips).")
    if rec.grid is not None and raw.length_unit is not None:
        raise err("receptors", "length_unit", "[receptors] 'length_unit' applies to a receptor file; a grid takes "
                  "lengths with their unit in the key (y_mm, pitch_x_mm).")
    if rec.grid is not None:
        rec = replace(rec, pitch_x_m=rec.pitch_x_m or _GRID_DEFAULTS["pitch_x_m"],
                      pitch_z_m=rec.pitch_z_m or _GRID_DEFAULTS["pitch_z_m"])
    if rec.grid == "tips":
        rec = replace(rec, **{k: v for k, v in _GRID_DEFAULTS.items() if getattr(rec, k) is None})
    for name in ("pitch_x_m", "pitch_z_m"):
        if getattr(rec, name) is not None and getattr(rec, name) <= 0:
            key = _given(scene, "receptors", name)
            raise err("receptors", key, f"[receptors] {key!r} must be > 0; got {getattr(rec, name)!r} m instead.")
    # [transduction]
    tr = scene.transduction
    explicit = {k: getattr(tr, k) for k in ("alpha_a", "gamma_per_pa", "lambda_pa") if getattr(tr, k) is not None}
    if tr.calibration is not None:
        if tr.params is not None or explicit:
            key = "params" if tr.params is not None else _given(scene, "transduction", next(iter(explicit)))
            raise err("transduction", key, f"[transduction] {key!r} and 'calibration' both set the parameters; keep one.")
    else:
        if tr.calibration_synthesis is not None:
            raise err("transduction", "calibration_synthesis",
                      "[transduction] 'calibration_synthesis' applies only with 'calibration'.")
        if tr.params is None:
            if not explicit:
                tr = replace(tr, params="start")
            elif len(explicit) < 3:
                missing = [k for k in ("alpha_a", "gamma_per_pa", "lambda_pa") if k not in explicit]
                raise err("transduction", None, f"[transduction] is missing {', '.join(map(repr, missing))}: give all "
                          "three of alpha_a, gamma_per_pa, lambda_pa, or params = 'start'|'longitudinal'|'cross' "
                          "(which they then override).")
    # [synthesis]
    sy = _fill(scene.synthesis)
    if sy.kind == "map" and sy.map is None:
        raise err("synthesis", "kind",
                  "[synthesis] kind = 'map' needs map = \"FILE.csv\" (columns receptor, afferent[, weight]).")
    if sy.kind != "map" and sy.map is not None:
        raise err("synthesis", "map", f"[synthesis] 'map' applies to kind = 'map', not {sy.kind!r}.")
    if sy.kind == "random":
        if sy.receptors_per_afferent is None or sy.receptors_per_afferent < 1:
            raise err("synthesis", "kind", "[synthesis] kind = 'random' needs receptors_per_afferent = N (N >= 1).")
    elif sy.receptors_per_afferent is not None:
        raise err("synthesis", "receptors_per_afferent",
                  f"[synthesis] 'receptors_per_afferent' applies to kind = 'random', not {sy.kind!r}.")
    # [stimulus]
    st = scene.stimulus
    given_st = [f.name for f in fields(st) if getattr(st, f.name) is not None and f.name != "waveform"]
    if st.waveform is None:
        if given_st:
            key = _given(scene, "stimulus", given_st[0])
            raise err("stimulus", key, f"[stimulus] {key!r} has no effect without 'waveform' ('ramp', 'sine' or 'file').")
    else:
        own = {"ramp": _RAMP_KEYS, "sine": _SINE_KEYS, "file": _FILE_KEYS}[st.waveform]
        common = ("d_ref_m", "dt_s", "on_negative", "reference_step", "series_depths_m")
        foreign = [k for k in given_st if k not in own + common]
        if foreign:
            key = _given(scene, "stimulus", foreign[0])
            raise err("stimulus", key, f"[stimulus] {key!r} does not apply to waveform = {st.waveform!r}.")
        if st.waveform == "file" and st.dt_s is not None:
            raise err("stimulus", _given(scene, "stimulus", "dt_s"),
                      "[stimulus] 'dt' does not apply to waveform = 'file' (the file has its own times).")
        if st.d_ref_m is None:
            raise err("stimulus", "waveform", "[stimulus] a waveform needs d_ref_mm (or d_ref_m): the indentation depth "
                      "at which the static export was solved (SED scales as (d / d_ref)^2).")
        if st.waveform == "ramp":
            st = replace(st, **{k: v for k, v in _RAMP_DEFAULTS.items() if getattr(st, k) is None})
        elif st.waveform == "sine":
            missing = [k for k in ("frequency_hz", "amplitude_m", "duration_s") if getattr(st, k) is None]
            if missing:
                raise err("stimulus", "waveform", f"[stimulus] waveform = 'sine' needs {', '.join(missing)} "
                          "(lengths and times may carry other units: amplitude_mm, duration_ms).")
        else:
            if st.file is None or st.length_unit is None:
                raise err("stimulus", "waveform", "[stimulus] waveform = 'file' needs file = \"PATH.csv\" (columns "
                          "time, depth) and length_unit (the depth unit).")
            st = replace(st, time_unit=st.time_unit or "s")
            _check_unit(replace(scene, stimulus=st), o, "stimulus", "length_unit", length_factor)
            _check_unit(replace(scene, stimulus=st), o, "stimulus", "time_unit", time_factor)
        if st.waveform != "file":
            st = replace(st, dt_s=st.dt_s if st.dt_s is not None else 1e-3)
        st = replace(st, on_negative=st.on_negative or "raise")
    # [outputs]
    out = scene.outputs
    if not out.want:
        raise err("outputs", "want" if out.want is not None else None,
                  f"[outputs] must list what to produce: want = [...] with any of {', '.join(map(repr, OUTPUTS))}.")
    if set(out.want) == {"plots"}:
        raise err("outputs", "want", "[outputs] 'plots' draws the figures of the other outputs; add at least one of "
                  f"{', '.join(repr(w) for w in OUTPUTS if w != 'plots')}.")
    name = scene.info.name or (Path(scene.source).stem if scene.source else "scene")
    info = replace(scene.info, name=name)
    out = replace(out, dir=out.dir or os.path.abspath(os.path.join("results", name)))
    # [spikes]
    sp = _fill(scene.spikes)
    if "spikes" in out.want:
        from .spiking import LIF_PRESETS  # light: brian2 is imported only by the brian2 engine

        if sp.lif_preset not in LIF_PRESETS:
            raise err("spikes", "lif_preset", f"[spikes] 'lif_preset' must be one of {', '.join(map(repr, LIF_PRESETS))}; "
                      f"got {sp.lif_preset!r} instead.{suggest(sp.lif_preset, list(LIF_PRESETS))}")
        if sp.input == "rate-sensitive" and sp.gain_s is None:
            raise err("spikes", "input", "[spikes] input = 'rate-sensitive' needs gain_s (A of input per A/s of rate).")
        if sp.dt_s <= 0:
            key = _given(scene, "spikes", "dt_s")
            raise err("spikes", key, f"[spikes] {key!r} must be > 0; got {sp.dt_s!r} s instead.")
        if sp.duration_s is not None and sp.duration_s <= 0:
            key = _given(scene, "spikes", "duration_s")
            raise err("spikes", key, f"[spikes] {key!r} must be > 0; got {sp.duration_s!r} s instead.")
    # [fit]
    fi = _fill(scene.fit)
    if "fit" in out.want:
        if fi.observed is None:
            raise err("fit", None, "the 'fit' output needs [fit] observed = \"OBS.csv\" (columns position, response).")
        if fi.length_unit is None:
            if ex.length_unit is None:
                raise err("fit", "observed", "[fit] needs 'length_unit' (the unit of the observed positions).")
            fi = replace(fi, length_unit=ex.length_unit)
    resolved = replace(scene, info=info, export=ex, receptors=rec, sampling=_fill(scene.sampling), transduction=tr,
                       synthesis=sy, stimulus=st, spikes=sp, fit=fi, outputs=out, resolved=True)
    return resolved


# ---------------------------------------------------------------------------- planning
def plan(scene: Scene) -> list[str]:
    """The stages (from :data:`STAGES`, in order) that the scene's wanted outputs need.

    ``sed_map`` / ``vtu`` -> reading, sampling; ``currents`` / ``profiles`` -> + stimulus (only
    with a waveform), transduction, synthesis; ``fit`` -> + comparison; ``spikes`` -> + input,
    spiking. At run time a cache hit may skip reading and sampling as well.

    Examples
    --------
    >>> plan(load_scene("sample_sed/scenes/sed_map.toml"))  # doctest: +SKIP
    ['reading', 'sampling']
    """
    scene = resolve(scene)
    need = set()
    for w in scene.outputs.want:
        need.update(NEEDS[w])
    if scene.stimulus.waveform is None:
        need.discard("stimulus")
    return [s for s in STAGES if s in need]


def skip_reasons(scene: Scene) -> dict[str, str]:
    """Why each stage :func:`plan` leaves out is not run (stage -> sentence)."""
    scene = resolve(scene)
    planned = plan(scene)
    want = list(scene.outputs.want)
    out = {}
    for s in STAGES:
        if s in planned:
            continue
        if s == "stimulus" and "transduction" in planned:
            out[s] = "the scene has no [stimulus] waveform: the export's own time steps are used"
            continue
        users = [w for w, stages in NEEDS.items() if s in stages and w != "plots"]
        which = repr(users[0]) if len(users) == 1 else "any of " + ", ".join(map(repr, users))
        out[s] = f"not needed: the requested outputs {want} do not include {which}"
    return out


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class SceneResult:
    """What :func:`run_scene` computed and wrote.

    Attributes
    ----------
    scene : Scene
        The resolved scene.
    output : str
        The output folder.
    files : tuple of str
        Files written into it (``run.json`` included).
    record : dict
        The content of ``run.json``.
    stages : dict
        Executed step -> wall time in s (the computing stages of :data:`STAGES` plus
        'hashing', 'receptors', 'cache' and 'writing').
    skipped : dict
        Stage of :data:`STAGES` not executed -> why.
    cache_hit : bool or None
        Whether the sampled SED came from the cache (None: the cache was not used).
    sed : ReceptorSED or None
        SED at the receptors as sampled from the export (J/m^3).
    current, afferent, fit, spikes, waveform
        Receptor currents, afferent currents, profile fit, spike trains and the waveform,
        or None when not computed.
    warnings : tuple of str
        Warnings raised during the run (also re-emitted).
    """

    scene: Scene
    output: str
    files: tuple
    record: dict
    stages: dict
    skipped: dict
    cache_hit: bool | None
    sed: object = None
    current: object = None
    afferent: object = None
    fit: object = None
    spikes: object = None
    waveform: object = None
    warnings: tuple = ()

    def __repr__(self) -> str:
        ran = ", ".join(f"{k} {v:.3g} s" for k, v in self.stages.items())
        skipped = ", ".join(self.skipped) or "nothing"
        return (f"<SceneResult {self.scene.info.name!r} -> {self.output}: ran {ran}; skipped {skipped}"
                f"; cache {'hit' if self.cache_hit else 'miss' if self.cache_hit is False else 'off'}>")


class _Steps:
    """Wall time of each executed step, in order."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    @contextmanager
    def __call__(self, name: str):
        t = time.perf_counter()
        yield
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t


# -------------------------------------------------------------------------- run helpers
def _in_region(layout, region: RegionSpec):
    import numpy as np

    mask = np.ones(layout.n_receptors, bool)
    for axis, rng in ((0, region.x_range_m), (2, region.z_range_m)):
        if rng is not None:
            c = layout.positions[:, axis]
            mask &= (c >= rng[0] - 1e-9) & (c <= rng[1] + 1e-9)  # 1 nm: float noise of unit conversions
    return mask


def _restrict(layout, scene: Scene, info: dict):
    """The layout inside the region; ``info`` gets the counts."""
    info["n_receptors_total"] = int(layout.n_receptors)
    if not scene.region.bounded:
        info["n_receptors_in_region"] = int(layout.n_receptors)
        return layout
    mask = _in_region(layout, scene.region)
    n = int(mask.sum())
    info["n_receptors_in_region"] = n
    if n == 0:
        lo, hi = layout.positions.min(axis=0) * 1e3, layout.positions.max(axis=0) * 1e3
        raise scene.origin.error("region", None, "[region] must contain at least one receptor; got none of the "
                                 f"{layout.n_receptors} receptors (x [{lo[0]:.4g}, {hi[0]:.4g}] mm, "
                                 f"z [{lo[2]:.4g}, {hi[2]:.4g}] mm) inside it instead.")
    return layout if n == layout.n_receptors else layout.subset(mask)


def _layout_before_reading(scene: Scene):
    """The receptor layout when it does not depend on the export (a file, a regular grid with ranges), else None."""
    rec = scene.receptors
    if rec.file is not None:
        from .receptors import read_receptors

        return read_receptors(rec.file, length_unit=rec.length_unit)
    if rec.grid == "regular" and rec.x_range_m is not None and rec.z_range_m is not None:
        from .receptors import grid_layout

        return grid_layout(x_range=rec.x_range_m, z_range=rec.z_range_m, y=rec.y_m, pitch_x=rec.pitch_x_m,
                           pitch_z=rec.pitch_z_m, origin=rec.origin_m)
    return None


def _layout_from_field(scene: Scene, field):
    """Receptors found on the export: papilla tips, or a regular grid over the export's extent."""
    rec = scene.receptors
    pitch = dict(pitch_x=rec.pitch_x_m, pitch_z=rec.pitch_z_m)
    if rec.grid == "tips":
        from .receptors import tips_from_export

        files = [f for f in field.provenance.files if not f.lower().endswith(".pvd")] or list(field.provenance.files)
        unit = field.provenance.units.get("length")
        # the region is applied afterwards (as interface_tips' own ranges would be: last), to count what it leaves out
        return tips_from_export(files[0], length_unit=unit, material_array=rec.material_array, upper=rec.upper,
                                lower=rec.lower, **pitch)
    from .receptors import grid_layout

    lo, hi = field.bounds
    x_range = rec.x_range_m or (lo[0] + rec.pitch_x_m / 2, hi[0] - rec.pitch_x_m / 2)
    z_range = rec.z_range_m or (lo[2] + rec.pitch_z_m / 2, hi[2] - rec.pitch_z_m / 2)
    return grid_layout(x_range=x_range, z_range=z_range, y=rec.y_m, origin=rec.origin_m, **pitch)


def _crop(field, positions, method: str):
    """The field with only the cells whose bounding box reaches the receptors' box (point location is exact).

    Not done for cell data with 'linear' sampling: averaging cells to nodes needs every cell
    around a node.
    """
    import numpy as np

    from .field import Cells, SEDField

    if field.cells is None or (field.location == "cell" and method == "linear") or not len(positions):
        return field, None
    lo_f, hi_f = field.bounds
    margin = 1e-3 * float(np.max(hi_f - lo_f))
    lo, hi = positions.min(axis=0) - margin, positions.max(axis=0) + margin
    tet = field.cells.tetra
    # Cohen-Sutherland outcodes: bit 2k (2k+1) set when a node lies below (above) the box on axis k; a
    # tetrahedron misses the box exactly when its four nodes share a bit (all on one side of one face).
    code = np.zeros(field.n_points, np.uint8)
    for ax in range(3):
        code |= (field.points[:, ax] < lo[ax]).astype(np.uint8) << (2 * ax)
        code |= (field.points[:, ax] > hi[ax]).astype(np.uint8) << (2 * ax + 1)
    shared = code[tet[:, 0]] & code[tet[:, 1]] & code[tet[:, 2]] & code[tet[:, 3]]
    keep = shared == 0
    if keep.all():
        return field, None
    cells = Cells(tet[keep], field.cells.parent[keep], field.cells.n_cells, field.cells.cell_types)
    cropped = SEDField(field.points, field.sed, field.times, field.location, cells, field.provenance)
    return cropped, {"tetra_total": int(tet.shape[0]), "tetra_searched": int(keep.sum())}


def _params(scene: Scene, inputs: dict):
    """SigmoidParams and where they came from."""
    from .transduction import STUDY_PARAMS, SigmoidParams

    tr = scene.transduction
    if tr.calibration is not None:
        path = tr.calibration
        if not os.path.isfile(path):
            raise FileNotFoundError(f"Calibration result {path!r} ([transduction] calibration) not found.")
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as err:
            raise SceneError(f"Calibration result {path!r} must be the JSON written by 'afferent calibrate' "
                             f"(CalibrationResult.to_dict()); it could not be read: {err}.") from err
        chosen = None
        if isinstance(data, dict) and "params" not in data and isinstance(data.get("syntheses"), dict):
            chosen = tr.calibration_synthesis or data.get("best_synthesis")
            if chosen not in data["syntheses"]:
                raise SceneError(f"Calibration result {path!r} holds syntheses {', '.join(map(repr, data['syntheses']))}; "
                                 f"[transduction] calibration_synthesis must name one; got {chosen!r} instead.")
            data = data["syntheses"][chosen]
        p = data.get("params") if isinstance(data, dict) else None
        if not isinstance(p, dict) or not all(k in p for k in ("alpha_a", "gamma_per_pa", "lambda_pa")):
            raise SceneError(f"Calibration result {path!r} must hold 'params' with alpha_a, gamma_per_pa and "
                             "lambda_pa (CalibrationResult.to_dict()); it does not.")
        inputs[path] = None
        params = SigmoidParams(p["alpha_a"], p["gamma_per_pa"], p["lambda_pa"])
        return params, {"source": "calibration", "file": path, "synthesis": chosen or data.get("synthesis"),
                        "method": data.get("method"), "ssd": data.get("ssd")}
    explicit = {"alpha": tr.alpha_a, "gamma": tr.gamma_per_pa, "lambda_": tr.lambda_pa}
    if tr.params is not None:
        base = STUDY_PARAMS[tr.params]
        vals = {k: (getattr(base, k) if v is None else v) for k, v in explicit.items()}
        over = [k for k, v in explicit.items() if v is not None]
        src = f"study table 5.2, {tr.params!r} row" + (f", overriding {', '.join(over)}" if over else "")
        return SigmoidParams(**vals), {"source": src}
    return SigmoidParams(**explicit), {"source": "scene"}


def _waveform(scene: Scene):
    from . import stimulus

    st = scene.stimulus
    if st.waveform == "ramp":
        return stimulus.ramp_and_hold(st.depth_m, st.speed_m_per_s, st.hold_s, release=st.release, dt=st.dt_s,
                                      pre=st.pre_s, post=st.post_s)
    if st.waveform == "sine":
        return stimulus.sinusoid(st.frequency_hz, st.amplitude_m, offset=st.offset_m, duration=st.duration_s,
                                 dt=st.dt_s, on_negative=st.on_negative)
    return stimulus.read_waveform(st.file, length_unit=st.length_unit, time_unit=st.time_unit,
                                  on_negative=st.on_negative)


def _trim(waveform, duration: float):
    """The waveform up to ``t0 + duration`` (plus the first sample at or after it); (waveform, trimmed?)."""
    import numpy as np

    from .stimulus import Waveform

    t_end = waveform.times[0] + duration
    k = int(np.searchsorted(waveform.times, t_end, side="left"))
    n = max(min(k + 1, waveform.n_times), 2)
    if n >= waveform.n_times:
        return waveform, False
    params = dict(waveform.parameters)
    params["trimmed_to_s"] = float(duration)
    notes = tuple(waveform.notes) + (f"trimmed to the simulated {duration:g} s ({n} of {waveform.n_times} samples)",)
    return Waveform(waveform.times[:n], waveform.depth[:n], kind=waveform.kind, parameters=params, notes=notes), True


def _branching(scene: Scene, layout, full_ids):
    """Branching on the region's receptors; a map is restricted to the rows of receptors inside."""
    from .synthesis import Branching

    sy = scene.synthesis
    if sy.kind == "longitudinal":
        return Branching.longitudinal(layout), {}
    if sy.kind == "cross":
        return Branching.cross(layout), {}
    if sy.kind == "random":
        return Branching.random(layout, sy.receptors_per_afferent, rng=sy.seed), {}
    if full_ids is None or len(full_ids) == layout.n_receptors:
        return Branching.from_map(sy.map, layout), {}
    from ._tables import read_table

    df, cols = read_table(sy.map, what="Branching map file", expected="receptor, afferent[, weight]", as_text=True)
    rcol = cols.get("receptor")
    if rcol is None:
        return Branching.from_map(sy.map, layout), {}  # its own message about the columns
    rec = df[rcol].astype(str).str.strip()
    inside = set(layout.ids.tolist())
    known = set(map(str, full_ids))
    unknown = [r for r in dict.fromkeys(rec.tolist()) if r not in known]
    if unknown:
        return Branching.from_map(sy.map, layout), {}  # reports the unknown ids with the file name
    keep = rec.isin(inside)
    acol = cols.get("afferent")
    cut = 0
    if acol is not None:
        aff = df[acol].astype(str).str.strip()
        partial = aff[keep].unique()
        cut = int(sum(1 for a in partial if not keep[aff == a].all()))
    if cut:
        from .exceptions import AfferentWarning

        warnings.warn(f"{cut} afferent(s) of the branching map {sy.map!r} have receptors both inside and outside "
                      "[region]; their currents count only the receptors inside.", AfferentWarning, stacklevel=3)
    return Branching.from_map(df[keep].reset_index(drop=True), layout), {
        "map_rows_outside_region": int((~keep).sum()), "afferents_cut_by_region": cut}


def _hash_all(paths: dict) -> dict:
    from .export import file_sha256

    return {p: (h if h is not None else file_sha256(p)) for p, h in paths.items()}


# ------------------------------------------------------------------------------- run
def run_scene(scene: Scene, *, overwrite: bool = False, cache_dir=None, progress: bool = False,
              use_cache: bool = True, record_extra: dict | None = None) -> SceneResult:
    """Run a scene: only the stages its outputs need, on the receptors of its region; write outputs and run.json.

    Parameters
    ----------
    scene : Scene
        From :func:`load_scene` (resolved here if it is not yet).
    overwrite : bool, default=False
        Replace an existing output folder. Without it an existing folder is an error, raised
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

    Returns
    -------
    SceneResult

    Raises
    ------
    OutputExistsError
        The output folder exists and ``overwrite`` is False.
    SceneError
        As :func:`resolve`; a region with no receptor; an unreadable calibration result.
    FileNotFoundError, SEDFormatError, UnitError, FieldCoverageError, ValueError
        From the stages (reading, receptors, sampling, ...).

    Notes
    -----
    ``run.json`` holds: ``scene`` (as resolved), ``scene_file`` (path, sha256), ``plan``,
    ``inputs`` (every file read, with its sha256), ``versions``, ``stages`` (executed steps
    and wall times in s), ``skipped`` (stage -> why), ``cache``, ``receptors`` (counts in and
    out of the region), ``field`` (the export's provenance), ``transduction``,
    ``saturation``, ``fit``, ``spikes``, ``time_span``, ``warnings``, ``outputs``,
    ``started_utc`` and ``wall_seconds``.
    """
    from datetime import datetime, timezone

    from ._output import atomic_dir, check_writable

    t_run = time.perf_counter()
    started = datetime.now(timezone.utc).isoformat(timespec="seconds")
    scene = resolve(scene)
    outdir = scene.outputs.dir
    if not os.path.lexists(outdir):
        os.makedirs(os.path.dirname(outdir), exist_ok=True)  # e.g. results/ of results/<name>; <name> comes whole
    check_writable(outdir, overwrite=overwrite, what="Output folder")
    planned = plan(scene)
    skipped = skip_reasons(scene)
    want = set(scene.outputs.want)
    steps = _Steps()
    record: dict = {}
    inputs: dict = {}  # path -> sha256 (None until hashed)
    comp: dict = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _compute(scene, planned, skipped, steps, record, inputs, comp, cache_dir=cache_dir, use_cache=use_cache,
                 progress=progress)
        files: list[str] = []
        with atomic_dir(outdir, overwrite=overwrite) as tmp:
            from . import _scene_outputs

            with steps("writing"):
                files = _scene_outputs.write_outputs(tmp, want=want, plots="plots" in want, **comp["out"])
            full = _record(scene, planned, skipped, steps, record, inputs, caught, files, started, t_run, record_extra)
            _scene_outputs.write_json(os.path.join(tmp, "run.json"), full)
            files.append("run.json")
    messages = _reemit(caught)
    return SceneResult(
        scene=scene, output=outdir, files=tuple(files), record=full, stages=dict(steps.seconds), skipped=dict(skipped),
        cache_hit=record.get("cache", {}).get("hit"), sed=comp.get("sed_static"), current=comp.get("current"),
        afferent=comp.get("afferent"), fit=comp.get("fit"), spikes=comp.get("spikes"), waveform=comp.get("waveform"),
        warnings=tuple(messages),
    )


_QUIET_CATEGORIES = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


def _reemit(caught) -> list[str]:
    messages = []
    for w in caught:
        if not issubclass(w.category, _QUIET_CATEGORIES):
            messages.append(str(w.message))
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return messages


def _record(scene, planned, skipped, steps, record, inputs, caught, files, started, t_run, extra) -> dict:
    from . import __version__
    from .export import file_sha256, versions

    full = {
        "afferent_scene": 1,
        "afferent": __version__,
        "started_utc": started,
        "scene_file": None if scene.source is None else {"path": scene.source, "sha256": file_sha256(scene.source)},
        "scene": scene.to_dict(),
        "plan": planned,
        "inputs": _hash_all(inputs),
        "versions": versions(),
        "stages": [{"stage": k, "seconds": v} for k, v in steps.seconds.items()],
        "skipped": [{"stage": k, "reason": v} for k, v in skipped.items()],
    }
    full.update(record)
    full["warnings"] = [{"category": w.category.__name__, "message": " ".join(str(w.message).split())}
                        for w in caught if not issubclass(w.category, _QUIET_CATEGORIES)]
    full["outputs"] = sorted(files + ["run.json"])
    full["wall_seconds"] = time.perf_counter() - t_run
    if extra:
        full.update(extra)
    return full


def _compute(scene, planned, skipped, steps, record, inputs, comp, *, cache_dir, use_cache, progress):
    """Run the planned stages; fill ``comp`` (results), ``record`` (run.json entries), ``inputs``."""

    from .cache import SEDCache, export_files, positions_digest, sampling_key

    ex, rec = scene.export, scene.receptors
    region_info: dict = {"region": {"x_range_m": scene.region.x_range_m, "z_range_m": scene.region.z_range_m}}
    # -- hashing: every input the planned stages read (content hashes key the cache and go into the record)
    with steps("hashing"):
        from .io import _format_of

        exp_files = export_files(ex.files)
        for p in ex.files:
            if not os.path.exists(p):
                raise FileNotFoundError(f"SED file {p!r} ([export] file) not found.")
        hashes = _hash_all({p: None for p in exp_files})
        inputs.update(hashes)
        extra_files = [ex.coordinates, rec.file]
        if "synthesis" in planned and scene.synthesis.kind == "map":
            extra_files.append(scene.synthesis.map)
        if "comparison" in planned:
            extra_files.append(scene.fit.observed)
        if "stimulus" in planned and scene.stimulus.waveform == "file":
            extra_files.append(scene.stimulus.file)
        for p in extra_files:
            if p is not None and os.path.isfile(p):
                inputs[p] = None
        inputs.update(_hash_all(inputs))
    # -- receptors known before reading (file / regular grid with ranges), restricted to the region
    full_layout = None
    with steps("receptors"):
        full_layout = _layout_before_reading(scene)
        layout = None if full_layout is None else _restrict(full_layout, scene, region_info)
    method = scene.sampling.method
    read_opts = ex.read_kwargs()
    if read_opts.get("coordinates"):
        read_opts["coordinates"] = inputs.get(read_opts["coordinates"])
    if layout is not None:
        rkey = {"positions_sha256": positions_digest(layout.positions), "n": int(layout.n_receptors)}
    else:
        rkey = {"found_on_export": {k: _plain_json(getattr(rec, k)) for k in
                                    ("grid", "y_m", "pitch_x_m", "pitch_z_m", "x_range_m", "z_range_m", "origin_m",
                                     "material_array", "upper", "lower")},
                "region": {"x_range_m": _plain_json(scene.region.x_range_m),
                           "z_range_m": _plain_json(scene.region.z_range_m)}}
    # each file the reader opens: (the reader its name selects, or 'member' of a .pvd/.xdmf; content hash)
    readers = [(_format_of(p, ex.format) if p in ex.files else "member", hashes[p]) for p in exp_files]
    key = sampling_key(exports=readers, read_options=read_opts, receptors=rkey, method=method)
    cache = SEDCache(cache_dir) if use_cache else None
    cache_info: dict = {"enabled": bool(use_cache), "key": key}
    entry = None
    if cache is not None:
        cache_info["dir"] = str(cache.directory)
        with steps("cache"):
            entry = cache.get(key, positions=None if layout is None else layout.positions)
        cache_info["hit"] = entry is not None
        if entry is None:
            cache_info["miss"] = cache.last_miss
    if entry is not None:
        sed = entry.to_receptor_sed(layout)
        if layout is None:
            layout = sed.layout
            region_info.update(entry.meta.get("region_info", {}))
        from .sampling import report_outside

        report_outside(sed.layout, sed.outside, scene.sampling.on_outside, where="from the sampling cache",
                       hint="Set [sampling] on_outside = 'nan' or 'warn' to continue.", stacklevel=4)
        why = (f"cache hit: SED at these {layout.n_receptors} receptors was sampled before from identical export "
               f"content with the same read options and method (key {key[:12]}, {entry.path})")
        skipped["reading"] = skipped["sampling"] = why
        record["field"] = dict(entry.meta.get("field", {}), from_cache=True)
        record["sampling"] = {"method": sed.method, "placement": sed.placement}
    else:
        from .io import read_sed
        from .sampling import build_sampler, sample_sed

        with steps("reading"):
            field = read_sed(list(ex.files) if len(ex.files) > 1 else ex.files[0], progress=progress, **ex.read_kwargs())
        record["field"] = dict(field.provenance.to_dict(), n_points=int(field.n_points),
                               n_cells=int(field.cells.n_cells) if field.cells is not None else 0,
                               n_times=int(field.n_times))
        if layout is None:
            with steps("receptors"):
                full_layout = _layout_from_field(scene, field)
                layout = _restrict(full_layout, scene, region_info)
        with steps("sampling"):
            cropped, crop_info = _crop(field, layout.positions, method)
            sampler = build_sampler(cropped, layout, method=method)
            sed = sample_sed(field, layout, method=method, on_outside=scene.sampling.on_outside, sampler=sampler)
        record["sampling"] = {"method": sed.method, "placement": sed.placement}
        if crop_info:
            record["sampling"]["mesh_cropped_to_receptors"] = crop_info
        del field, cropped, sampler
        if cache is not None:
            with steps("cache"):
                try:
                    path = cache.put(key, sed, meta={"field": record["field"], "region_info": {
                        k: v for k, v in region_info.items() if k != "region"}})
                    cache_info["written"] = str(path)
                except OSError as err:  # a read-only or full cache disk must not fail the run
                    cache_info["write_error"] = str(err)
    record["cache"] = cache_info
    region_info["n_receptors_sampled"] = int(layout.n_receptors)
    record["receptors"] = {"source": rec.file or f"grid = {rec.grid!r}", **region_info}
    comp["sed_static"] = sed
    out = {"sed_static": sed, "sed": sed, "current": None, "branching": None, "afferent": None, "fit": None,
           "waveform": None, "spikes": None, "profile_index": -1}
    comp["out"] = out
    if "transduction" not in planned:
        return
    # -- stimulus
    from .pipeline import PipelineResult, run_spikes
    from .synthesis import synthesize
    from .transduction import saturation_report, transduce

    span = {}
    if "stimulus" in planned:
        from .stimulus import interpolate_series, no_reference_step_message, scale_static, scaling_record

        st = scene.stimulus
        if st.reference_step is None and sed.values.shape[0] > 1:
            where = f"Scene file {scene.source!r}" if scene.source else "Scene"
            raise SceneError(f"{where}: [stimulus] " + no_reference_step_message(sed.values.shape[0], sed.times)
                             .replace("reference_step=K", "reference_step = K"), path=scene.source, key="[stimulus] reference_step")
        step = 0 if st.reference_step is None else st.reference_step
        with steps("stimulus"):
            waveform = _waveform(scene)
            span["waveform_s"] = [float(waveform.times[0]), float(waveform.times[-1])]
            time_resolved = {"currents", "profiles", "fit"} & set(scene.outputs.want)
            dur = scene.spikes.duration_s
            if "spiking" in planned and dur is not None and not time_resolved:
                waveform, trimmed = _trim(waveform, dur)
                if trimmed:
                    span["trimmed_to_s"] = [float(waveform.times[0]), float(waveform.times[-1])]
                    span["why"] = (f"only spikes are wanted and [spikes] duration is {dur:g} s: the stimulus beyond it "
                                   "is neither transduced nor simulated")
            record["stimulus"] = {"scaling": scaling_record(sed, waveform, d_ref=st.d_ref_m, reference_step=step,
                                                            series_depths=st.series_depths_m)}
            sed_t = (interpolate_series(sed, waveform, series_depths=st.series_depths_m) if st.series_depths_m is not None
                     else scale_static(sed, waveform, d_ref=st.d_ref_m, time_index=step))
        comp["waveform"] = out["waveform"] = waveform
        out["sed"] = sed_t
    else:
        sed_t = sed
    params, source = _params(scene, inputs)
    inputs.update(_hash_all(inputs))
    with steps("transduction"):
        current = transduce(sed_t, params)
        sat = saturation_report(sed_t, params)
    record["transduction"] = {"alpha_a": params.alpha, "gamma_per_pa": params.gamma, "lambda_pa": params.lambda_, **source}
    record["saturation"] = {"fraction_sensitive": sat.fraction_sensitive, "fraction_high": sat.fraction_high,
                            "fraction_low": sat.fraction_low, "modulation": sat.modulation,
                            "gamma_sed_range": sat.gamma_sed_range, "message": sat.message}
    with steps("synthesis"):
        full_ids = None if full_layout is None else full_layout.ids
        branching, map_info = _branching(scene, layout, full_ids)
        afferent = synthesize(current, branching)
    record["synthesis"] = {"kind": branching.kind, "n_afferents": int(branching.n_afferents), **map_info}
    from .profiles import peak_step

    profile_index = peak_step(afferent)
    out.update(current=current, branching=branching, afferent=afferent, profile_index=profile_index)
    comp.update(current=current, afferent=afferent)
    record["profile_step"] = profile_step_record(afferent, profile_index)
    if afferent.times is not None:
        record["profile_time_s"] = float(afferent.times[profile_index])
    if "comparison" in planned:
        from .profiles import compare_profiles, read_observed

        fi = scene.fit
        with steps("comparison"):
            observed = read_observed(fi.observed, length_unit=fi.length_unit, position_column=fi.position_column,
                                     response_column=fi.response_column)
            fit = compare_profiles(afferent, observed, normalise=fi.normalise, time_index=profile_index)
        out["fit"] = comp["fit"] = fit
        record["fit"] = {"r2_study": fit.r2_study, "r2": fit.r2, "ssd": fit.ssd, "normalise": fit.normalise,
                         "dropped": fit.dropped, "time_s": fit.time}
    if "spiking" in planned:
        from .spiking import LIFParams

        sp = scene.spikes
        lif = LIFParams.from_preset(sp.lif_preset)
        over = {f[: f.rfind("_")]: getattr(sp, f) for f in _LIF_FIELDS if getattr(sp, f) is not None}
        if over:
            lif = replace(lif, **over)
        duration = sp.duration_s
        if duration is None and afferent.n_times == 1:
            duration = 1.0
        pr = PipelineResult(sed_t, current, branching, afferent, sat, out["fit"], {}, waveform=out["waveform"])
        pr = run_spikes(pr, lif, dt=sp.dt_s, engine=sp.engine, input=sp.input, gain=sp.gain_s, tau=sp.tau_s,
                        duration=duration, drive=sp.drive, rheobase_multiple=sp.rheobase_multiple,
                        reference_current=sp.reference_current_a)
        steps.seconds["input"] = pr.timings["input"]
        steps.seconds["spiking"] = pr.timings["spiking"]
        spikes = pr.spikes
        out["spikes"] = comp["spikes"] = spikes
        out["drive"] = pr.input
        span["simulated_s"] = float(spikes.duration)
        record["spikes"] = {
            "engine": spikes.engine, "backend": getattr(spikes, "backend", None), "dt_s": spikes.dt,
            "duration_s": spikes.duration, "input": getattr(pr.input, "kind", None),
            "n_afferents": int(spikes.n_afferents), "n_spikes": int(sum(len(t) for t in spikes.spike_times)),
            "silent_skipped": [str(spikes.afferent_ids[i]) for i in spikes.silent_skipped],
            "notes": list(getattr(spikes, "notes", ())),
            "lif": {k: getattr(lif, k) for k in ("tau_m", "r_m", "v_rest", "v_thresh", "v_reset", "t_ref")},
            "drive": pr.drive,
        }
    if span:
        record["time_span"] = span


# --------------------------------------------------------------------------------- CLI
def run_scene_cli(path, *, output=None, overwrite: bool = False, quiet: bool = False, cache_dir=None,
                  use_cache: bool = True) -> int:
    """``afferent run SCENE.toml``: load, run, summarise on stderr; returns the exit code (0).

    Parameters
    ----------
    path : str or path-like
        The scene file.
    output : str or path-like, optional
        Output folder, overriding ``[outputs] dir`` (relative to the current folder).
    overwrite : bool, default=False
        Replace an existing output folder.
    quiet : bool, default=False
        No summary, no progress bars, no warnings printed (they are still in run.json).
    cache_dir : str or path-like, optional
        Sampled-SED cache folder (default ``$AFFERENT_CACHE_DIR`` or ``~/.cache/afferent``).
    use_cache : bool, default=True

    Raises
    ------
    The errors of :func:`load_scene` and :func:`run_scene`; :func:`afferent.cli.main` turns
    them into ``afferent: error: ...`` and exit code 2.
    """
    scene = load_scene(path)
    if output is not None:
        scene = scene.with_output(output)
    argv = [os.fspath(path)] + (["-o", os.fspath(output)] if output is not None else []) + (
        ["--overwrite"] if overwrite else [])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_scene(scene, overwrite=overwrite, cache_dir=cache_dir, use_cache=use_cache,
                           progress=not quiet and sys.stderr.isatty(),
                           record_extra={"command": "afferent run " + " ".join(argv)})
    if quiet:
        return 0
    err = sys.stderr
    print(f"afferent run: wrote {result.output}: {', '.join(sorted(result.files))}", file=err)
    ran = ", ".join(f"{k} {v:.2f} s" for k, v in result.stages.items())
    print(f"  ran: {ran}", file=err)
    if result.skipped:
        print("  skipped: " + "; ".join(f"{k} ({v})" for k, v in _merge_reasons(result.skipped)), file=err)
    rec = result.record.get("receptors", {})
    if scene.region.bounded:
        print(f"  region: {rec.get('n_receptors_in_region')} of {rec.get('n_receptors_total')} receptors", file=err)
    if result.spikes is not None:
        sp = result.record["spikes"]
        print(f"  spikes: {sp['n_spikes']} from {sp['n_afferents']} afferents in {sp['duration_s']:g} s "
              f"({sp['engine']}, {sp['input']} input)", file=err)
    sat = result.record.get("saturation")
    if sat:
        print(f"  transduction: {sat['fraction_sensitive']:.1%} of receptor samples in the sigmoid's sensitive range, "
              f"currents vary by {sat['modulation']:.3g} of their mean across receptors "
              f"(gamma x SED range {sat['gamma_sed_range']:.3g})", file=err)
    if result.fit is not None:
        print(f"  fit: R2(study) {result.fit.r2_study:.3f}, R2 {result.fit.r2:.3f}, ssd {result.fit.ssd:.3g}", file=err)
    for msg in dict.fromkeys(str(w.message) for w in caught if not issubclass(w.category, _QUIET_CATEGORIES)):
        print(f"afferent: warning: {' '.join(msg.split())}", file=err)
    return 0


def _merge_reasons(skipped: dict):
    """Group stages skipped for the same reason: [('a, b', reason), ...]."""
    groups: dict[str, list[str]] = {}
    for stage, why in skipped.items():
        groups.setdefault(why, []).append(stage)
    return [(", ".join(stages), why) for why, stages in groups.items()]
