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
    # stress_unit, time_unit, sed_from = "field"|"exact"|"equivalent"|"stress", poisson, preset, shear,
    # elastic = [E, nu] or materials = "materials.csv" (sed_from = "stress"), modulus_unit, material_array,
    # location = "point"|"cell", sed_column, stress_columns, strain_columns, coord_columns,
    # times = [..] (in time_unit), coordinates = "nodes.csv", on_nan = "raise"|"drop",
    # negative_tolerance = 0.25 (accepted negative SED / largest SED), format,
    # allow_outside_files = false (true: the files the export points to may lie outside its folder)

    [receptors]                   # exactly one of file / grid
    file = "../block4/receptors.csv"
    length_unit = "mm"            # default: [export] length_unit
    # grid = "tips"               # RA-I: papilla tips on the export's epidermis/dermis interface
    #   material_array = "layer", upper = 1, lower = 2, pitch_x_mm = 0.44, pitch_z_mm = 0.22
    # grid = "bases"              # SA-I: intermediate-ridge bases on that interface (same keys)
    # grid = "regular"            # ridge/papilla grid at height y (x/z extent: the export's)
    #   y_mm = 2.45, pitch_x_mm = 0.44, pitch_z_mm = 0.22, x_range_mm = [..], z_range_mm = [..], origin_mm = [x0, z0],
    #   rows = "tips"             # papilla rows (RA-I), or "bases": ridge-base rows half a pitch across x (SA-I)

    [sampling]
    method = "linear"             # or "nearest"
    on_outside = "raise"          # or "warn", "nan": outside the field, NaN SED, left out from transduction on

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

**One route.** ``afferent run EXPORT ...`` builds the same :class:`Scene` from its options
(:func:`afferent.cli._run.scene_from_args`) and runs it through :func:`run_scene`: one planner,
one executor, one writer, one run record for both spellings of a run.

The package's modules::

    schema    the tables as frozen dataclasses, unit suffixes, TOML key lines, SceneError
    parse     TOML text / plain tables -> Scene (units converted, types checked)
    defaults  defaults and requirements (resolve)
    planning  wanted outputs -> stages, and why the others are skipped
    stages    what each stage needs from a scene (layouts, region, crop, parameters, waveform)
    run       the executor: stages in order, the SED cache, run_scene, run_scene_cli
    record    run.json and the printed summary

The writer is :func:`afferent.export.write_outputs`; ``afferent demo`` runs one scene per
indenter of the sample through :func:`run_scene` as well. The stages are the stage modules' own
functions (:func:`afferent.stimulus.apply_waveform`, :func:`afferent.synthesis.make_branching`,
:func:`afferent.spiking.spike_afferents`, ...); none of them imports this package.
"""

from __future__ import annotations

from .parse import load_scene, parse_scene, scene_from_dict
from .planning import NEEDS, STAGES, plan, skip_reasons
from .defaults import resolve
from .run import SceneResult, run_scene, run_scene_cli
from .schema import _ENGINES, OUTPUTS, Scene, SceneError, SceneTypeError, key_lines  # noqa: F401 (_ENGINES: tests)

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
    "skip_reasons",
    "run_scene",
    "run_scene_cli",
    "key_lines",
    "OUTPUTS",
    "STAGES",
    "NEEDS",
]
