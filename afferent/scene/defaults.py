"""Defaults and requirements: :func:`resolve` turns a scene as written into one that can run."""

from __future__ import annotations



import os
import re
from dataclasses import fields, replace
from pathlib import Path

from .._validation import suggest
from .schema import (_FILE_KEYS, _GRID_DEFAULTS, _GRID_KEYS, _RAMP_DEFAULTS, _RAMP_KEYS, _SINE_KEYS, _TABLES,
                     _TIPS_KEYS, MESH_GRIDS, OUTPUTS, Scene)

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
    err = o.error
    ex = _export(scene, o, err)
    rec = _receptors(scene, o, err, ex)
    tr = _transduction(scene, err)
    sy = _synthesis(scene, err)
    st = _stimulus(scene, o, err)
    info, out = _outputs(scene, err)
    af = _fill(scene.afferent)
    sp = _spikes(replace(scene, afferent=af), err, out)
    fi = _fit(scene, err, out, ex)
    _nwb(scene, err, out)
    resolved = replace(scene, info=info, export=ex, receptors=rec, sampling=_fill(scene.sampling), transduction=tr,
                       synthesis=sy, stimulus=st, spikes=sp, fit=fi, outputs=out, afferent=af, resolved=True)
    return resolved


def _export(scene: Scene, o, err):
    """[export]: defaults filled, requirements checked."""
    from ..units import length_factor, sed_factor, time_factor

    ex = _fill(scene.export)
    if not ex.files:
        raise err("export", None, "[export] must name the FE export: file = \"PATH\" (or files = [...], one per time step).")
    for name, checker in (("length_unit", length_factor), ("sed_unit", sed_factor), ("stress_unit", sed_factor),
                          ("modulus_unit", sed_factor), ("time_unit", time_factor)):
        _check_unit(scene, o, "export", name, checker)
    if ex.sed_from == "equivalent" and ex.poisson is None:
        raise err("export", "sed_from", "[export] sed_from = 'equivalent' needs 'poisson' (the study's skin: 0.48).")
    if ex.sed_from == "stress" and (ex.elastic is None) == (ex.materials is None):
        raise err("export", "sed_from", "[export] sed_from = 'stress' needs the elastic constants: elastic = [E, nu] "
                  "with modulus_unit, or materials = \"materials.csv\" (columns material, E, nu) - one of them.")
    return ex


def _receptors(scene: Scene, o, err, ex):
    """[receptors]: defaults filled, requirements checked."""
    from ..units import length_factor

    raw = scene.receptors
    rec = _fill(raw)
    if (rec.file is None) == (rec.grid is None):
        raise err("receptors", None, "[receptors] must give exactly one of 'file' (a receptor CSV) and 'grid' "
                  f"('tips', 'bases' or 'regular'); got {'both' if rec.file else 'neither'} instead.")
    if rec.file is not None:
        # with [outputs] hotspot_beside, the materials and pitches say how the sites beside the file's are found
        beside = _TIPS_KEYS + ("pitch_x_m", "pitch_z_m") if scene.outputs.hotspot_beside is not None else ()
        extra = [_given(scene, "receptors", k) for k in _GRID_KEYS + _TIPS_KEYS + ("rows",)
                 if getattr(raw, k) is not None and k not in beside]
        if extra:
            also = (" (material_array, upper, lower and the pitches also apply to the sites [outputs] hotspot_beside = "
                    "'tips' | 'bases' finds beside the file's)") if extra[0] in _TIPS_KEYS + ("pitch_x_mm", "pitch_z_mm",
                                                                                              "pitch_x_m", "pitch_z_m") else ""
            raise err("receptors", extra[0], f"[receptors] {extra[0]!r} applies to a generated grid, not to a receptor "
                      f"file{also}; remove it or use grid = ... instead of file.")
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
            raise err("receptors", bad[0], f"[receptors] {bad[0]!r} applies to grid = 'tips' or 'bases', not 'regular'.")
        rec = replace(rec, rows=rec.rows or "tips")
    else:  # tips, bases: found on the export
        bad = [_given(scene, "receptors", k) for k in _GRID_KEYS[:4] + ("rows",) if getattr(raw, k) is not None]
        if bad:
            raise err("receptors", bad[0], f"[receptors] {bad[0]!r} applies to grid = 'regular', not {rec.grid!r} "
                      f"(use [region] to restrict the {rec.grid}).")
    if rec.grid is not None and raw.length_unit is not None:
        raise err("receptors", "length_unit", "[receptors] 'length_unit' applies to a receptor file; a grid takes "
                  "lengths with their unit in the key (y_mm, pitch_x_mm).")
    if rec.grid is not None:
        rec = replace(rec, **{k: _GRID_DEFAULTS[k] for k in ("pitch_x_m", "pitch_z_m") if getattr(rec, k) is None})
    if rec.grid in MESH_GRIDS:
        rec = replace(rec, **{k: v for k, v in _GRID_DEFAULTS.items() if getattr(rec, k) is None})
    for name in ("pitch_x_m", "pitch_z_m"):
        if getattr(rec, name) is not None and getattr(rec, name) <= 0:
            key = _given(scene, "receptors", name)
            raise err("receptors", key, f"[receptors] {key!r} must be > 0; got {getattr(rec, name)!r} m instead.")
    return rec


def _transduction(scene: Scene, err):
    """[transduction]: defaults filled, requirements checked."""
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
    return tr


def _synthesis(scene: Scene, err):
    """[synthesis]: defaults filled, requirements checked."""
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
    return sy


def _stimulus(scene: Scene, o, err):
    """[stimulus]: defaults filled, requirements checked."""
    from ..units import length_factor, time_factor

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
            st = replace(st, dt_s=st.dt_s if st.dt_s is not None else _default_dt(st))
        if st.waveform == "sine":
            _check_sine_step(scene, st, err)
        st = replace(st, on_negative=st.on_negative or "raise")
    return st


#: Samples per period below which a sine waveform is refused (its peaks fall between samples).
SINE_SAMPLES_PER_PERIOD = 20


def _default_dt(st) -> float:
    """The waveform step when the scene gives none: 1 ms, or 1/20 of a sine's period when that is shorter (s)."""
    if st.waveform == "sine" and st.frequency_hz and st.frequency_hz > 0:
        return min(1e-3, 1.0 / (SINE_SAMPLES_PER_PERIOD * st.frequency_hz))
    return 1e-3


def _check_sine_step(scene: Scene, st, err) -> None:
    """A sine sampled more coarsely than 1/20 of its period: refused unless the scene accepts 'waveform-step'.

    At 80 Hz with 1 ms steps the peaks fall between samples, at another phase each cycle: the deepest
    sampled point of the last cycle was 0.984 x the first's in SED, an artefact of the sampling alone.
    1/20 of the period puts a sample on every peak and trough (the quarter period is 5 steps).
    """
    from .._validation import refuse_unless

    f = st.frequency_hz
    if not (f and f > 0 and st.dt_s and st.dt_s > 0):
        return  # the waveform itself refuses these, naming the key
    fit = 1.0 / (SINE_SAMPLES_PER_PERIOD * f)
    if st.dt_s <= fit * (1 + 1e-9):
        return
    key = _given(scene, "stimulus", "dt_s")
    unit = key.rsplit("_", 1)[1] if key.rsplit("_", 1)[-1] in ("s", "ms", "us") else "s"
    scale = {"s": 1.0, "ms": 1e3, "us": 1e6}[unit]
    refuse_unless("waveform-step", scene.info.accept, (
        f"[stimulus] {key!r} ({st.dt_s * scale:g} {unit}) samples the {f:g} Hz sine {1.0 / (f * st.dt_s):.3g} times a "
        f"period, fewer than {SINE_SAMPLES_PER_PERIOD}: its peaks fall between samples at another phase each cycle, "
        f"so the deepest sampled depth (and the SED, as its square) changes from cycle to cycle, an artefact of the "
        f"sampling; set [stimulus] {key!r} to {fit * scale:.4g} or less (1/{SINE_SAMPLES_PER_PERIOD} of the "
        f"{1e3 / f:.4g} ms period; left out, it is chosen so)"), cls=lambda m: err("stimulus", key, m), note=False)


def _outputs(scene: Scene, err):
    """[outputs]: defaults filled, requirements checked."""
    out = scene.outputs
    if not out.want:
        raise err("outputs", "want" if out.want is not None else None,
                  f"[outputs] must list what to produce: want = [...] with any of {', '.join(map(repr, OUTPUTS))}.")
    if set(out.want) == {"plots"}:
        raise err("outputs", "want", "[outputs] 'plots' draws the figures of the other outputs; add at least one of "
                  f"{', '.join(repr(w) for w in OUTPUTS if w != 'plots')}.")
    if "nwb" in out.want:
        from importlib.util import find_spec

        if find_spec("pynwb") is None:
            raise err("outputs", "want", "[outputs] 'nwb' writes spikes.nwb with pynwb, which is not installed: "
                      "pip install 'afferent-skin[nwb]'.")
    name = scene.info.name or (Path(scene.source).stem if scene.source else "scene")
    info = replace(scene.info, name=name)
    if info.accept is not None:
        from .._validation import check_accept

        try:
            check_accept(info.accept)
        except ValueError as e:
            raise err("scene", "accept", f"[scene] {e}") from None
    out = replace(out, dir=out.dir or os.path.abspath(os.path.join("results", name)), format=out.format or "netcdf")
    return info, _cycle_keys(scene, _hotspot_keys(scene, out, err), err)


def _wanted_for_keys(scene: Scene, out, err, output: str, keys) -> bool:
    """Whether ``output`` is wanted; if not, none of its [outputs] ``keys`` may be given (the error names the first)."""
    if output in out.want:
        return True
    given = [_given(scene, "outputs", k) for k in keys if getattr(out, k) is not None]
    if given:
        raise err("outputs", given[0], f"[outputs] {given[0]!r} applies to want = [..., {output!r}], which is not "
                  f"requested (want = {list(out.want)!r}).")
    return False


def _hotspot_keys(scene: Scene, out, err):
    """[outputs] hotspot_*: only with want 'hotspots'; threshold default 0.6, within 0..1; one second map at most."""
    if not _wanted_for_keys(scene, out, err, "hotspots", ("hotspot_threshold", "hotspot_beside", "hotspot_beside_file")):
        return out
    if out.hotspot_beside is not None and out.hotspot_beside_file is not None:
        raise err("outputs", "hotspot_beside_file", "[outputs] give at most one of 'hotspot_beside' (sites found on "
                  "the export) and 'hotspot_beside_file' (a site CSV) for the second hot-spot map; got both.")
    t = 0.6 if out.hotspot_threshold is None else out.hotspot_threshold
    if not 0.0 <= t <= 1.0:
        raise err("outputs", "hotspot_threshold", f"[outputs] 'hotspot_threshold' is a normalised SED and must be "
                  f"within 0..1; got {t!r} instead.")
    return replace(out, hotspot_threshold=float(t))


def _cycle_keys(scene: Scene, out, err):
    """[outputs] cycles_*: only with want 'cycles', which needs the frequency (> 0 Hz; default a [stimulus] sine's);
    the outline all three or none."""
    keys = ("cycles_frequency_hz", "cycles_x_range_m", "cycles_z_range_m", "cycles_edge_m")
    if not _wanted_for_keys(scene, out, err, "cycles", keys):
        return out
    f = out.cycles_frequency_hz
    sine = scene.stimulus.waveform == "sine" and f is None
    if not sine and (f is None or not f > 0):
        raise err("outputs", _given(scene, "outputs", "cycles_frequency_hz"), "[outputs] want 'cycles' needs the "
                  "periodic input's frequency 'cycles_frequency_hz' (> 0 Hz, e.g. cycles_frequency_hz = 20; a [stimulus] "
                  f"sine gives its own); got {f!r} instead.")
    outline = [k for k in keys[1:] if getattr(out, k) is not None]
    if outline and len(outline) < 3:
        missing = [_given(scene, "outputs", k) for k in keys[1:] if getattr(out, k) is None]
        raise err("outputs", _given(scene, "outputs", outline[0]), "[outputs] the indenter's outline for 'cycles' needs "
                  f"all of cycles_x_range, cycles_z_range and cycles_edge; missing {', '.join(map(repr, missing))}.")
    if outline and not out.cycles_edge_m >= 0:
        raise err("outputs", _given(scene, "outputs", "cycles_edge_m"), "[outputs] 'cycles_edge' is a distance and "
                  f"must be >= 0; got {out.cycles_edge_m!r} m instead.")
    return out


#: ISO 8601 duration (NWB Subject.age): 'P30Y', 'P2Y6M', 'P10D', 'PT12H'; a range is two joined by '/'
_ISO_DURATION = re.compile(r"P(?=\d|T\d)(\d+Y)?(\d+M)?(\d+W)?(\d+D)?(T(?=\d)(\d+H)?(\d+M)?(\d+(\.\d+)?S)?)?")


def _nwb(scene: Scene, err, out) -> None:
    """[nwb]: only with want 'nwb'; ``age`` an ISO 8601 duration (or a range of two)."""
    given = [f.name for f in fields(scene.nwb) if getattr(scene.nwb, f.name) is not None]
    if given and "nwb" not in out.want:
        raise err("nwb", _given(scene, "nwb", given[0]), f"[nwb] {_given(scene, 'nwb', given[0])!r} describes "
                  f"spikes.nwb, the output 'nwb', which is not requested (want = {list(out.want)!r}).")
    age = scene.nwb.age
    if age is not None and not all(_ISO_DURATION.fullmatch(a) for a in age.split("/", 1)):
        raise err("nwb", "age", f"[nwb] 'age' must be an ISO 8601 duration such as 'P30Y' (30 years) or 'P25Y/P35Y' "
                  f"(a range); got {age!r} instead.")


def class_overrides(scene: Scene) -> list:
    """The [spikes] keys (SI names) whose value in the resolved ``scene`` is not its afferent class's."""
    from ..classes import afferent_class

    preset = afferent_class(scene.afferent.afferent_class).spikes_defaults()
    return sorted(k for k, v in preset.items() if getattr(scene.spikes, k) != v)


def class_record(scene: Scene, site: str) -> dict:
    """The afferent class as run.json records it; warns when the receptors' ``site`` is another class's."""
    import warnings

    from ..classes import afferent_class
    from ..exceptions import AfferentWarning

    cls = afferent_class(scene.afferent.afferent_class)
    if msg := cls.sites_warning(site):
        warnings.warn(msg, AfferentWarning, stacklevel=3)
    return cls.record(class_overrides(scene))


#: [spikes] keys of the slowly-adapting (SA-I) input only.
_SLOWLY_ADAPTING_KEYS = ("static_gain", "rectify", "slow_gain_s", "slow_tau_s")


def _spikes(scene: Scene, err, out):
    """[spikes]: the afferent class's values where the scene gives none, defaults filled, requirements checked."""
    from ..classes import afferent_class

    preset = afferent_class(scene.afferent.afferent_class).spikes_defaults()
    if scene.spikes.input is not None and scene.spikes.input != preset.get("input"):
        # another input than the class's: the class's parameters of its own input do not apply
        preset = {k: v for k, v in preset.items() if k not in ("gain_s", "tau_s", *_SLOWLY_ADAPTING_KEYS)}
    sp = replace(scene.spikes, **{k: v for k, v in preset.items() if getattr(scene.spikes, k) is None})
    sp = _fill(sp)
    for name in _SLOWLY_ADAPTING_KEYS:
        if getattr(sp, name) is not None and sp.input != "slowly-adapting":
            key = _given(scene, "spikes", name)
            raise err("spikes", key, f"[spikes] {key!r} applies to input = 'slowly-adapting', not {sp.input!r}.")
    if sp.slow_tau_s is not None and sp.slow_gain_s is None:
        key = _given(scene, "spikes", "slow_tau_s")
        raise err("spikes", key, f"[spikes] {key!r} needs 'slow_gain_s', the gain of the slow rate component (s).")
    rate = [k for k in ("gain_s", "tau_s") if getattr(scene.spikes, k) is not None]
    if rate and sp.input == "static":  # the RA-I class's input, or given: a static input has no rate term
        key = _given(scene, "spikes", rate[0])
        whose = (f"the {scene.afferent.afferent_class} class's input" if scene.spikes.input is None
                 else "[spikes] 'input'")
        raise err("spikes", key, f"[spikes] {key!r} applies to input = 'rate-sensitive' or 'slowly-adapting', not "
                  f"'static' ({whose}), which has no rate term: every value of it gives the same spikes; set [spikes] "
                  f"'input' or leave {key!r} out.")
    if "spikes" in out.want:
        from ..spiking import LIF_PRESETS  # light: brian2 is imported only by the brian2 engine

        if sp.lif_preset not in LIF_PRESETS:
            raise err("spikes", "lif_preset", f"[spikes] 'lif_preset' must be one of {', '.join(map(repr, LIF_PRESETS))}; "
                      f"got {sp.lif_preset!r} instead.{suggest(sp.lif_preset, list(LIF_PRESETS))}")
        if sp.input != "static" and sp.gain_s is None:
            raise err("spikes", "input", f"[spikes] input = {sp.input!r} needs gain_s (A of input per A/s of rate).")
        if sp.dt_s <= 0:
            key = _given(scene, "spikes", "dt_s")
            raise err("spikes", key, f"[spikes] {key!r} must be > 0; got {sp.dt_s!r} s instead.")
        if sp.duration_s is not None and sp.duration_s <= 0:
            key = _given(scene, "spikes", "duration_s")
            raise err("spikes", key, f"[spikes] {key!r} must be > 0; got {sp.duration_s!r} s instead.")
        if sp.zones_per_afferent is not None and sp.zones_per_afferent < 1:
            raise err("spikes", "zones_per_afferent", "[spikes] 'zones_per_afferent' must be >= 1 (receptor groups per "
                      f"afferent); got {sp.zones_per_afferent!r} instead.")
        if sp.zone_map is not None and sp.zones_per_afferent is not None:
            raise err("spikes", "zone_map", "[spikes] give 'zone_map' (each receptor's zone) or 'zones_per_afferent' "
                      "(receptors split into groups along the afferent), not both.")
        if sp.branching == "zones" and sp.zones_per_afferent is None and sp.zone_map is None:
            from ..zones import DEFAULT_ZONES_PER_AFFERENT

            sp = replace(sp, zones_per_afferent=DEFAULT_ZONES_PER_AFFERENT)
    return sp


def _fit(scene: Scene, err, out, ex):
    """[fit]: defaults filled, requirements checked."""
    fi = _fill(scene.fit)
    if "fit" in out.want:
        if fi.observed is None:
            raise err("fit", None, "the 'fit' output needs [fit] observed = \"OBS.csv\" (columns position, response).")
        if fi.length_unit is None:
            if ex.length_unit is None:
                raise err("fit", "observed", "[fit] needs 'length_unit' (the unit of the observed positions).")
            fi = replace(fi, length_unit=ex.length_unit)
    return fi
