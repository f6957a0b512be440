"""The scene schema: one frozen dataclass per TOML table, units in key names, and where each key sits.

Each section's field names are the SI keys (``x_range_m``, ``dt_s``); :data:`_QUANTITIES`
lists the unit suffixes a key may carry instead (``x_range_mm``), converted by
:mod:`afferent.scene.parse`. tomllib gives no positions, so :func:`key_lines` finds the line
of every table and key by scanning the text, for errors that name the line.
"""

from __future__ import annotations

from .._typing import PathLike

import os
import re
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

from ..classes import AFFERENT_CLASSES, DEFAULT_CLASS
from ..exceptions import AfferentError
from ..io import FORMATS

#: What a scene can ask for (``[outputs] want``).
OUTPUTS = ("sed_map", "currents", "profiles", "fit", "spikes", "plots", "vtu", "nwb", "hotspots", "cycles")

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

    def __init__(self, message: str, *, path: PathLike | None=None, key: str | None=None, line: int | None=None) -> None:
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
    """``[scene]``: a name (default: the file's stem), a free-text description, and the checks it confirms
    (``accept``: names of :data:`afferent._validation.ACCEPTS`)."""

    name: str | None = _f("str")
    description: str | None = _f("str")
    accept: tuple | None = _f("strs", doc="checks whose unusual case the scene confirms, by name "
                                          "(afferent._validation.ACCEPTS; afferent run --accept)")


@dataclass(frozen=True)
class ExportSpec:
    """``[export]``: the FE export(s) and how to read them (the options of :func:`afferent.read_sed`)."""

    files: tuple | None = _f("paths", aliases=("file",), doc="export file(s), one per time step")
    length_unit: str | None = _f("str")
    sed_unit: str | None = _f("str")
    stress_unit: str | None = _f("str")
    time_unit: str | None = _f("str")
    sed_from: str | None = _f("choice", "field", choices=("field", "exact", "equivalent", "stress"))
    poisson: float | None = _f("number")
    elastic: tuple | None = _f("numbers", doc="sed_from = 'stress', homogeneous model: [E, nu], E in modulus_unit")
    modulus_unit: str | None = _f("str", doc="unit of E in elastic or in the materials table")
    materials: str | None = _f("path", doc="sed_from = 'stress': CSV of material (id), E, nu")
    material_array: str | None = _f("str", doc="the export's material-id array the materials table is looked up with")
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
    allow_outside_files: bool | None = _f("bool", False, doc="read the files the export points to even outside its "
                                                              "folder (refused by default)")

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
#: grid values whose sites are found on the export's interface (:func:`afferent.receptors.sites_from_export` kind)
MESH_GRIDS = ("tips", "bases")


@dataclass(frozen=True)
class ReceptorSpec:
    """``[receptors]``: a receptor CSV (``file``) or generated sites: ``grid`` = 'tips' (RA-I papilla tips) or
    'bases' (SA-I intermediate-ridge bases) found on the export, or 'regular' (a grid of papilla or ridge-base rows)."""

    file: str | None = _f("path")
    length_unit: str | None = _f("str", doc="unit of the CSV's x, y, z; default [export] length_unit")
    grid: str | None = _f("choice", choices=("tips", "bases", "regular"))
    rows: str | None = _f("choice", choices=("tips", "bases"),
                          doc="regular grid: papilla rows (RA-I, default 'tips') or ridge-base rows ('bases', SA-I)")
    y_m: float | None = _f("number", quantity="length")
    pitch_x_m: float | None = _f("number", quantity="length", doc="grids; default 0.44 mm (ridge pitch)")
    pitch_z_m: float | None = _f("number", quantity="length", doc="grids; default 0.22 mm (papilla pitch)")
    x_range_m: tuple | None = _f("pair", quantity="length")
    z_range_m: tuple | None = _f("pair", quantity="length")
    origin_m: tuple | None = _f("pair", quantity="length", doc="(x0, z0): a point of a regular grid")
    material_array: str | None = _f("str", doc="tips, bases; default 'layer'")
    upper: object = _f("int_or_ints", doc="tips, bases; default 1 (epidermis)")
    lower: object = _f("int_or_ints", doc="tips, bases; default 2 (dermis)")


@dataclass(frozen=True)
class SamplingSpec:
    """``[sampling]``: how SED is sampled at the receptors (:func:`afferent.sample_sed`)."""

    method: str | None = _f("choice", "linear", choices=("linear", "nearest"))
    on_outside: str | None = _f("choice", "raise", choices=("raise", "warn", "nan"))
    side: object = _f("side", "average", doc="receptors on a material interface: 'average' or a material id")


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
    """``[synthesis]``: receptor -> afferent grouping (:func:`afferent.synthesis.make_branching`)."""

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
    """``[spikes]``: input current and leaky integrate-and-fire (:func:`afferent.spiking.spike_afferents`)."""

    engine: str | None = _f("choice", "auto", choices=_ENGINES)
    dt_s: float | None = _f("number", 1e-4, quantity="time")
    lif_preset: str | None = _f("str", "ra")
    tau_m_s: float | None = _f("number", quantity="time")
    r_m_ohm: float | None = _f("number", quantity="resistance")
    v_rest_v: float | None = _f("number", quantity="voltage")
    v_thresh_v: float | None = _f("number", quantity="voltage")
    v_reset_v: float | None = _f("number", quantity="voltage")
    t_ref_s: float | None = _f("number", quantity="time")
    input: str | None = _f("choice", "static", choices=("static", "rate-sensitive", "slowly-adapting"))
    drive: str | None = _f("choice", "resistance", choices=("resistance", "rheobase"),
                           doc="current -> membrane: through r_m as is, or the largest current -> k x rheobase")
    rheobase_multiple: float | None = _f("number", 2.0, doc="drive = 'rheobase': the reference current's multiple")
    reference_current_a: float | None = _f("number", quantity="current", doc="drive = 'rheobase': default the largest")
    gain_s: float | None = _f("number", quantity="time")
    tau_s: float | None = _f("number", quantity="time")
    duration_s: float | None = _f("number", quantity="time")
    branching: str | None = _f("choice", "sum", choices=("sum", "zones"),
                               doc="receptor currents -> spikes: summed into one LIF per afferent, or one LIF per "
                                   "spike-initiation zone (the first zone at threshold fires and resets all)")
    zones_per_afferent: int | None = _f("int", doc="branching = 'zones': receptor groups per afferent, split along "
                                                   "it; default 4")
    zone_map: str | None = _f("path", doc="branching = 'zones': CSV receptor, zone naming each receptor's zone "
                                          "(instead of zones_per_afferent)")
    static_gain: float | None = _f("number", doc="input = 'slowly-adapting': gain k_s on the static current")
    rectify: str | None = _f("choice", choices=("sum", "components"),
                             doc="input = 'slowly-adapting': rectify the sum of the terms (default) or each term, as "
                                 "the cited SA-I model code does")
    slow_gain_s: float | None = _f("number", quantity="time",
                                   doc="input = 'slowly-adapting': gain of a second, slow rate component (s)")
    slow_tau_s: float | None = _f("number", quantity="time",
                                  doc="input = 'slowly-adapting': time constant of the slow component (s); default 0.2")


@dataclass(frozen=True)
class AfferentSpec:
    """``[afferent]``: the afferent class (``class = "SA-I"``), a preset of the ``[spikes]`` keys the
    scene leaves out (:mod:`afferent.classes`)."""

    afferent_class: str | None = _f("choice", DEFAULT_CLASS, choices=tuple(AFFERENT_CLASSES), aliases=("class",))


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
    """``[outputs]``: what to produce (``want``, from :data:`OUTPUTS`), where (``dir``), and how the
    time courses are written (``format``: ``'netcdf'``, one ``currents.nc``, or ``'csv'``, long tables)."""

    want: tuple | None = _f("outputs", choices=OUTPUTS)
    dir: str | None = _f("path")
    format: str | None = _f("choice", "netcdf", choices=("netcdf", "csv"))
    hotspot_threshold: float | None = _f("number", 0.6, doc="hotspots: hot spots are normalised SED >= this (0..1)")
    hotspot_beside: str | None = _f("choice", choices=("tips", "bases"),
                                    doc="hotspots: a second map beside [receptors]' sites, of the sites found on the export")
    hotspot_beside_file: str | None = _f("path", doc="hotspots: a second map, of the sites of this CSV "
                                                     "(unit: [receptors] length_unit, else [export] length_unit)")
    cycles_frequency_hz: float | None = _f("number", quantity="frequency",
                                           doc="cycles: the periodic input's frequency (required with want 'cycles')")
    cycles_x_range_m: tuple | None = _f("pair", quantity="length", doc="cycles: the indenter's outline in x")
    cycles_z_range_m: tuple | None = _f("pair", quantity="length", doc="cycles: the indenter's outline in z")
    cycles_edge_m: float | None = _f("number", quantity="length",
                                     doc="cycles: sites within this of the outline are near the edge")


@dataclass(frozen=True)
class NwbSpec:
    """``[nwb]``: who and what ``spikes.nwb`` (output ``nwb``) describes, as the NWB standard asks
    (nwbinspector checks each; ``afferent._nwb``). Only with want ``nwb``."""

    description: str | None = _f("str", doc="the experiment's description (NWB experiment_description)")
    experimenter: tuple | None = _f("strs", doc="names, 'Last, First'")
    institution: str | None = _f("str")
    lab: str | None = _f("str")
    keywords: tuple | None = _f("strs")
    subject_id: str | None = _f("str", doc="the subject (the skin modelled): an id")
    species: str | None = _f("str", doc="Latin binomial ('Homo sapiens') or an NCBI taxonomy URL")
    sex: str | None = _f("choice", choices=("M", "F", "U", "O"), doc="M, F, U (unknown) or O (other)")
    age: str | None = _f("str", doc="ISO 8601 duration: 'P30Y', 'P25Y/P35Y' for a range")
    subject_description: str | None = _f("str", doc="e.g. which finger, which FE model")


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
    "afferent": ("afferent", AfferentSpec),
    "nwb": ("nwb", NwbSpec),
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
    info, export, receptors, sampling, region, transduction, synthesis, stimulus, spikes, fit, outputs, afferent, nwb
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
    afferent: AfferentSpec = field(default_factory=AfferentSpec)
    nwb: NwbSpec = field(default_factory=NwbSpec)
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

    @property
    def input_files(self) -> tuple:
        """Every file the scene names (its own file, exports, coordinates, materials, receptors, calibration, map,
        waveform, observed profile, zone map): an output may not be, hold or lie inside one of them."""
        paths = (self.source, *(self.export.files or ()), self.export.coordinates, self.export.materials,
                 self.receptors.file,
                 self.outputs.hotspot_beside_file,
                 self.transduction.calibration, self.synthesis.map, self.stimulus.file, self.fit.observed,
                 self.spikes.zone_map)
        return tuple(p for p in paths if p)

    def with_output(self, path: PathLike) -> "Scene":
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

