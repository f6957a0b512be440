"""Run the pipeline: SED at receptors -> receptor currents -> afferent currents [-> fit] [-> spikes].

``afferent run SCENE.toml`` runs a scene file instead (see afferent.scene). Both spellings are
one route: the options below build the same afferent.scene.Scene a TOML file would
(scene_from_args), and afferent.scene.run_scene runs it: only the stages its
outputs need, sampled SED cached on disk (``--no-cache``: neither read nor written), one
writer, one run.json record.

Writes into OUTDIR (the scene outputs currents, profiles, sed_map, vtu [, fit] [, spikes] [, plots]):
currents.nc (NetCDF-4: sed_pa and current_a over time x receptor, afferent_current_a over
time x afferent, positions and section ids as coordinates, units as attributes; read it with
afferent.load_results(OUTDIR).dataset, xarray, MATLAB ncread or R ncdf4), currents.xdmf (its index: ParaView
opens the receptor sites over time; --results-format csv writes the long tables receptors.csv and
afferents.csv instead of both), profiles.csv (the profile step), sed_map.csv (SED
sampled from the export), fit.csv and profile_fit.csv with --observed, receptors.vtu
(ParaView), run.json (the record), and the figures sed_map.png, profiles_x.png,
profiles_z.png [, fit.png].

With --spikes, also spikes.csv (afferent, spike_time_s), spike_summary.csv (rate, first-spike
latency, ISI per afferent), with --nwb spikes.nwb (the nwb extra; docs/outputs.md), raster.png,
rates.png and psth.png; a static export can be driven by
--waveform (SED scaled by (d/d_ref)^2, valid for linear elasticity with a fixed contact area).

The figures are drawn in a second process while the run reads and writes its tables (with two
or more usable cores); AFFERENT_FIGURE_PROCESS=0 draws them in the run's own process; run.json
says which (figures: process same or separate).

Transduction parameters are in SI: --alpha in A (the study's table is in mA:
2.46e-5 mA = 2.46e-8 A), --gamma in 1/Pa, --lambda in Pa; or --params start|longitudinal|cross
for the study's table-5.2 rows.

Example::

    $ afferent run sample_sed/block4/indent_0p88mm.vtu --receptors sample_sed/block4/receptors.csv \\
          --length-unit mm --sed-unit MPa --synthesis longitudinal --params start -o results/run1
    $ afferent run sample_sed/block4/indent_0p88mm.vtu --receptors sample_sed/block4/receptors.csv \\
          --length-unit mm --sed-unit MPa --params start --waveform ramp:0.5,5,2 --d-ref-mm 0.5 \\
          --spikes --input rate-sensitive --gain-s 0.2 -o results/ramp
    $ afferent run sample_sed/scenes/profiles.toml -o results/scene
"""

from __future__ import annotations

import argparse

import os
import shlex

from ._options import add_accept_option, add_input_options, add_output_options, add_receptor_options, grid_option, \
    input_kwargs, unit_type, after_prefix, reads

# the stage modules (pandas, scipy) load when the run needs them, not to parse the command line
SYNTHESES = ("longitudinal", "cross", "map:FILE", "random:N")  # afferent.synthesis.SYNTHESES
METHODS = ("linear", "nearest")  # afferent.sampling.METHODS
STUDY_ROWS = ("start", "longitudinal", "cross")  # the keys of afferent.transduction.STUDY_PARAMS
CLASSES = ("RA-I", "SA-I")  # the keys of afferent.classes.AFFERENT_CLASSES


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("exports", nargs="+", metavar="EXPORT",
                              help="FE export file(s) (several files are one time step each), or one SCENE.toml"))
    parser.add_argument("--method", choices=METHODS, default="linear", help="sampling: interpolate in the mesh cells, or nearest node")
    parser.add_argument("--on-outside", choices=("raise", "warn", "nan"), default="raise",
                        help="receptors outside the mesh: an error (raise), or NaN in the SED tables and left out of "
                             "every stage from transduction on, with a warning naming them and the afferents they "
                             "shorten (warn, nan; run.json 'outside')")
    reads(parser.add_argument("--synthesis", default="longitudinal", metavar="|".join(SYNTHESES),
                              help="receptor -> afferent grouping (default longitudinal)"), after_prefix("map:"),
          what="Branching map file")
    parser.add_argument("--seed", type=int, default=0, help="seed for --synthesis random:N")
    g = parser.add_argument_group("transduction (sigmoid) parameters, SI units")
    g.add_argument("--params", choices=STUDY_ROWS, help="the study's table-5.2 row")
    g.add_argument("--alpha", type=float, metavar="A", help="saturation current, A")
    g.add_argument("--gamma", type=float, metavar="G", help="slope, 1/Pa")
    g.add_argument("--lambda", dest="lambda_", type=float, metavar="L", help="midpoint SED, Pa")
    g = parser.add_argument_group("comparison with a recording")
    reads(g.add_argument("--observed", metavar="OBS.csv", help="recorded profile: columns position, response"),
          what="Observed profile file")
    g.add_argument("--observed-unit", metavar="U", type=unit_type("length"), help="length unit of the observed positions (m, mm, um); required with --observed")
    g.add_argument("--normalise", choices=("both", "prediction", "observation", "neither"), default="both",
                   help="what is min-max normalised before comparing (the study: both)")
    g = parser.add_argument_group("stimulus over time (for a static export)")
    reads(g.add_argument("--waveform", metavar="SPEC",
                         help="indentation depth over time: 'ramp:DEPTH_MM,SPEED_MM_PER_S,HOLD_S' (ramp-and-hold with "
                              "release), 'sine:FREQ_HZ,AMPLITUDE_MM,DURATION_S', or a CSV 'FILE' with columns time, depth"),
          lambda v: () if v.strip().partition(":")[0] in ("ramp", "sine") else (v.strip(),), what="Waveform file")
    g.add_argument("--waveform-unit", default="mm", metavar="U", type=unit_type("length"), help="depth unit of a waveform CSV (default mm; time in s)")
    g.add_argument("--reference-step", type=int, metavar="K",
                   help="with --waveform on a multi-step export: the step solved at --d-ref-mm (-1: the last); required there")
    g.add_argument("--series-depths-mm", metavar="D0,D1,...",
                   help="depth (mm) of every step of a loading-series export: the d^2 scaling is measured against it "
                        "and recorded in run.json")
    g.add_argument("--d-ref-mm", type=float, metavar="D", help="indentation depth of the static export, mm (SED scales as (d/d_ref)^2)")
    g.add_argument("--waveform-dt-ms", type=float, metavar="DT",
                   help="sampling step of ramp/sine waveforms, ms (default 1, or 1/20 of a sine's period when shorter)")
    _add_spike_args(parser)
    add_accept_option(parser)
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    parser.add_argument("--results-format", choices=("netcdf", "csv"),
                        help="time courses of receptors and afferents: one NetCDF-4 file currents.nc (default) or the "
                             "long tables receptors.csv and afferents.csv ([outputs] format; --format names the export's)")
    parser.add_argument("--nwb", action="store_true",
                        help="with --spikes, also spikes.nwb (Neurodata Without Borders; needs pip install "
                             "'afferent-skin[nwb]'); subject, experimenter and the like come from a scene's [nwb] "
                             "table (docs/outputs.md)")
    parser.add_argument("--no-cache", action="store_true",
                        help="neither read nor write the sampled-SED cache ($AFFERENT_CACHE_DIR or ~/.cache/afferent)")
    add_receptor_options(parser, required=False)
    add_input_options(parser)
    add_output_options(parser, what="output folder (created whole, or not at all); for a scene, overrides its [outputs] dir",
                       required=False)
    parser.set_defaults(_options=parser._actions)


def _add_spike_args(parser: argparse.ArgumentParser) -> None:
    """The options of the spiking stage (leaky integrate-and-fire)."""
    g = parser.add_argument_group("spikes (leaky integrate-and-fire)")
    g.add_argument("--spikes", action="store_true", help="simulate spikes: writes spikes.csv and spike_summary.csv")
    g.add_argument("--engine", default="auto", choices=("auto", "exact", "exact-numba", "exact-numpy", "fast", "fast-numba", "fast-numpy", "brian2"),
                   help="spiking engine: exact (default; event-driven, exact spike times, no time step), fast (on the "
                        "--dt-ms grid) or brian2 (the grid reference; same spikes as fast)")
    g.add_argument("--dt-ms", type=float, default=0.1, help="LIF time step of the grid engines fast and brian2, ms (default 0.1; exact has none)")
    g.add_argument("--class", dest="afferent_class", choices=CLASSES,
                   help="afferent class (afferent.classes; default RA-I, the study's): a preset of the options below "
                        "that are not given; also with a SCENE.toml, replacing its [afferent] class")
    g.add_argument("--lif-preset", help="LIF parameter set (afferent.spiking.LIF_PRESETS; default: the class's, 'ra')")
    g.add_argument("--input", choices=("static", "rate-sensitive", "slowly-adapting"),
                   help="static: the sigmoid current (the study, the default; fires through a hold); rate-sensitive: "
                        "RA-I adaptation, fires at onset and offset (needs --gain-s); slowly-adapting: SA-I static "
                        "plus rate (the SA-I class's)")
    g.add_argument("--gain-s", type=float, help="gain of the rate term of an adapting input, s (A of input per A/s)")
    g.add_argument("--tau-ms", type=float, help="time constant of the rate term, ms (default 5; SA-I class 8)")
    g.add_argument("--static-gain", type=float, help="slowly-adapting input: gain on the static current (default 1)")
    g.add_argument("--drive", choices=("resistance", "rheobase"),
                   help="current -> membrane: through the preset's r_m as is (default), or rescaled so that the largest "
                        "input current is --rheobase-multiple x the rheobase (the SA-I class's)")
    g.add_argument("--rheobase-multiple", type=float, metavar="K",
                   help="with --drive rheobase: the largest current becomes K x the rheobase (default 2; SA-I class 10)")
    g.add_argument("--duration-s", type=float, help="simulated time, s (default: the stimulus; 1 s for a static export)")
    g.add_argument("--branching", choices=("sum", "zones"),
                   help="sum: an afferent's receptor currents summed into one LIF (the study; default); zones: one LIF "
                        "per spike-initiation zone, the first at threshold fires the afferent and resets all its zones")
    g.add_argument("--zones-per-afferent", type=int, metavar="K",
                   help="with --branching zones: each afferent's receptors split into K groups along it (default 4)")
    reads(g.add_argument("--zone-map", metavar="ZONES.csv",
                         help="with --branching zones: each receptor's zone (columns receptor, zone) instead of "
                              "--zones-per-afferent"), what="Zone map file")


def _transduction_table(args) -> dict:
    """[transduction]: a study row (--params) with overrides, or all three of --alpha --gamma --lambda."""
    given = {k: getattr(args, k) for k in ("alpha", "gamma", "lambda_") if getattr(args, k) is not None}
    if args.params is None:
        missing = [f"--{k.rstrip('_')}" for k in ("alpha", "gamma", "lambda_") if k not in given]
        if missing:
            raise ValueError(
                f"Transduction parameters {', '.join(missing)} are missing: give --alpha A --gamma G --lambda L "
                f"(A, 1/Pa, Pa) or --params one of {', '.join(STUDY_ROWS)}."
            )
    keys = {"alpha": "alpha_a", "gamma": "gamma_per_pa", "lambda_": "lambda_pa"}
    return {"params": args.params, **{keys[k]: v for k, v in given.items()}}


def _numbers(text: str, flag: str, unit: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",")]
    except ValueError as err:
        raise ValueError(f"{flag} must be comma-separated numbers ({unit}); got {text!r} instead.") from err


def _stimulus_table(args) -> dict | None:
    """[stimulus] from --waveform 'ramp:D,S,H' | 'sine:F,A,T' | FILE and --d-ref-mm, --reference-step, ..."""
    if not args.waveform:
        if args.series_depths_mm is not None:
            raise ValueError("--series-depths-mm applies to --waveform (it measures the d^2 scaling); add --waveform.")
        return None
    spec = args.waveform.strip()
    kind, _, rest = spec.partition(":")
    if kind in ("ramp", "sine") and rest:
        try:
            values = [float(v) for v in rest.split(",")]
        except ValueError as err:
            raise ValueError(f"--waveform {spec!r}: the values after '{kind}:' must be numbers.") from err
        if len(values) != 3:
            raise ValueError(f"--waveform {kind}: needs 3 comma-separated values; got {len(values)} in {spec!r} instead.")
        names = ("depth_mm", "speed_mm_per_s", "hold_s") if kind == "ramp" else ("frequency_hz", "amplitude_mm", "duration_s")
        table = {"waveform": kind, **dict(zip(names, values)), "dt_ms": args.waveform_dt_ms}
    else:
        table = {"waveform": "file", "file": spec, "length_unit": args.waveform_unit}
    if args.d_ref_mm is None:
        raise ValueError("--waveform needs --d-ref-mm, the indentation depth (mm) at which the static export was solved.")
    table.update(d_ref_mm=args.d_ref_mm, reference_step=args.reference_step)
    if args.series_depths_mm is not None:
        table["series_depths_mm"] = _numbers(args.series_depths_mm, "--series-depths-mm", "mm")
    return table


def _receptors_table(args) -> dict:
    """[receptors] from --receptors / --grid tips|bases|y=H; lengths carry their unit in the key, as in a scene file."""
    if args.receptors is not None:
        unit = args.receptor_unit or args.length_unit
        if unit is None:
            raise ValueError("--receptors needs the unit of R.csv's x, y, z: --receptor-unit U or --length-unit U "
                             "(the receptors are read before the export, to key the sampled-SED cache).")
        return {"file": args.receptors, "length_unit": unit}
    spec = args.grid.strip()
    pitch = {k: grid_option(args, k) for k in ("pitch_x_mm", "pitch_z_mm")}
    if spec in ("tips", "bases"):
        return {"grid": spec, **{k: grid_option(args, k) for k in ("material_array", "upper", "lower")}, **pitch}
    if spec.startswith("y="):
        try:
            y = float(spec[2:])
        except ValueError as err:
            raise ValueError(f"--grid y=H needs a number H in the export's length unit; got {spec!r} instead.") from err
        unit = {"µm": "um", "micron": "um"}.get(args.length_unit, args.length_unit)
        if unit is None:
            raise ValueError("--grid y=H needs --length-unit: H is in the export's length unit.")
        if unit not in ("m", "mm", "um"):
            from ..units import length_factor

            y, unit = y * length_factor(unit), "m"
        return {"grid": "regular", f"y_{unit}": y, **pitch}
    raise ValueError(f"--grid must be 'tips', 'bases' or 'y=H'; got {args.grid!r} instead.")


def _synthesis_table(args) -> dict:
    from ..synthesis import parse_synthesis

    kind, n = parse_synthesis(args.synthesis)
    table = {"kind": kind, "seed": args.seed}
    if kind == "map":
        table["map"] = args.synthesis.partition(":")[2]
    if kind == "random":
        table["receptors_per_afferent"] = n
    return table


def _spikes_table(args) -> dict | None:
    if not args.spikes:
        if args.input not in (None, "static"):
            raise ValueError(f"--input {args.input} applies to spikes: add --spikes.")
        if args.branching not in (None, "sum") or args.zones_per_afferent is not None or args.zone_map is not None:
            raise ValueError("--branching, --zones-per-afferent and --zone-map apply to spikes: add --spikes.")
        return None
    if args.input == "rate-sensitive" and args.gain_s is None:
        raise ValueError("--input rate-sensitive needs --gain-s (s): how much input current (A) per A/s of rate.")
    for flag, value in (("--zones-per-afferent", args.zones_per_afferent), ("--zone-map", args.zone_map)):
        if value is not None and args.branching != "zones":
            raise ValueError(f"{flag} applies to --branching zones; add --branching zones.")
    # options not given stay out: the afferent class (--class) or the scene defaults fill them
    return {"engine": args.engine, "dt_ms": args.dt_ms, "lif_preset": args.lif_preset, "input": args.input,
            "gain_s": args.gain_s, "tau_ms": args.tau_ms, "static_gain": args.static_gain, "drive": args.drive,
            "rheobase_multiple": args.rheobase_multiple, "duration_s": args.duration_s, "branching": args.branching,
            "zones_per_afferent": args.zones_per_afferent, "zone_map": args.zone_map}


#: scene key -> the option that sets it, to say a scene's complaint in the command's words
_FLAGS = {
    ("export", "file"): "EXPORT", ("export", "files"): "EXPORT", ("receptors", "length_unit"): "--receptor-unit",
    ("receptors", "file"): "--receptors", ("receptors", "grid"): "--grid", ("sampling", "method"): "--method",
    ("sampling", "on_outside"): "--on-outside", ("synthesis", "kind"): "--synthesis", ("stimulus", "waveform"): "--waveform",
    ("stimulus", "d_ref_mm"): "--d-ref-mm", ("stimulus", "reference_step"): "--reference-step",
    ("stimulus", "series_depths_mm"): "--series-depths-mm", ("stimulus", "dt_ms"): "--waveform-dt-ms",
    ("spikes", "lif_preset"): "--lif-preset", ("spikes", "dt_ms"): "--dt-ms", ("spikes", "duration_s"): "--duration-s",
    ("spikes", "gain_s"): "--gain-s", ("spikes", "tau_ms"): "--tau-ms", ("spikes", "static_gain"): "--static-gain",
    ("afferent", "class"): "--class", ("fit", "observed"): "--observed",
    ("spikes", "zones_per_afferent"): "--zones-per-afferent", ("spikes", "branching"): "--branching",
    ("spikes", "zone_map"): "--zone-map", ("spikes", "input"): "--input",
    ("fit", "length_unit"): "--observed-unit",
}


def _in_cli_words(message: str) -> str:
    """A scene's message about its keys, reworded with the options of ``afferent run``."""
    message = message.removeprefix("Scene: ")
    message = message.replace("[scene] 'accept'", "--accept")
    for (table, key), flag in _FLAGS.items():
        message = message.replace(f"[{table}] {key!r}", flag).replace(f"[{table}] {key}", flag)
    keys = [key for _, key in _FLAGS]
    for (_, key), flag in _FLAGS.items():
        if keys.count(key) == 1:  # a bare 'key' only where it names one option
            message = message.replace(repr(key), flag)
    for table in ("export", "receptors", "sampling", "transduction", "synthesis", "stimulus", "spikes", "fit", "outputs"):
        message = message.replace(f"[{table}] ", "")
    return message


def scene_from_args(args):
    """The :class:`afferent.scene.Scene` that ``afferent run EXPORT ... -o OUT`` describes (resolved).

    Options map onto scene keys with their unit in the key (``--d-ref-mm 0.5`` -> ``[stimulus]
    d_ref_mm = 0.5``), so the numbers are converted to SI exactly as a scene file's are; writing
    the same tables into a TOML file gives the same run (``tests/test_pipeline.py`` checks the
    tables byte for byte). Outputs: currents, profiles, sed_map, vtu, and fit with
    ``--observed``, spikes with ``--spikes``, plots unless ``--no-plots``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of ``afferent run``.

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        Missing or contradictory options, in the command's words.
    """
    from ..scene import SceneError, resolve, scene_from_dict

    if args.receptors is None and args.grid is None:
        raise ValueError("afferent run needs the receptor sites: --receptors R.csv or --grid tips|y=H (or a SCENE.toml).")
    if args.output is None:
        raise ValueError("afferent run needs an output folder: -o OUTDIR.")
    read = input_kwargs(args)
    read.pop("progress")
    export = {"files": list(args.exports), **{k: v for k, v in read.items() if v is not None}}
    want = ["currents", "profiles", "sed_map", "vtu"]
    accept = [c.strip() for a in (args.accept or ()) for c in a.split(",") if c.strip()] or None
    tables = {"scene": {"name": os.path.basename(os.path.normpath(args.output)), "accept": accept}, "export": export,
              "receptors": _receptors_table(args), "sampling": {"method": args.method, "on_outside": args.on_outside},
              "transduction": _transduction_table(args), "synthesis": _synthesis_table(args),
              "afferent": {"class": args.afferent_class}}
    stimulus, spikes = _stimulus_table(args), _spikes_table(args)
    if stimulus is not None:
        tables["stimulus"] = stimulus
    if spikes is not None:
        tables["spikes"], want = spikes, want + ["spikes"] + (["nwb"] if getattr(args, "nwb", False) else [])
    elif getattr(args, "nwb", False):
        raise ValueError("--nwb writes the spike trains: it needs --spikes.")
    if args.observed:
        if args.observed_unit is None:
            raise ValueError("--observed needs --observed-unit, the length unit of the observed positions (e.g. mm); "
                             "afferent never guesses a unit.")
        tables["fit"] = {"observed": args.observed, "length_unit": args.observed_unit, "normalise": args.normalise}
        want.append("fit")
    tables["outputs"] = {"want": want + ([] if args.no_plots else ["plots"]), "dir": args.output,
                         "format": args.results_format}
    try:
        return resolve(scene_from_dict(tables, base_dir=os.getcwd()))
    except SceneError as err:
        raise ValueError(_in_cli_words(str(err))) from err


#: What ``afferent run SCENE.toml`` takes besides the file: where and how to write, and the two overrides.
SCENE_FILE_OPTIONS = ("output", "overwrite", "quiet", "no_cache", "results_format", "afferent_class")


def _refuse_options_a_scene_sets(args: argparse.Namespace) -> None:
    """``afferent run SCENE.toml --dt-ms 0.5``: the scene file says how to run, so any option other than
    :data:`SCENE_FILE_OPTIONS` given with it would be ignored; it is refused instead, named with the key to set."""
    given = [a for a in getattr(args, "_options", ()) if a.option_strings and a.dest not in SCENE_FILE_OPTIONS
             and a.dest != "help" and getattr(args, a.dest, a.default) != a.default]
    if given:
        flags = ", ".join(max(a.option_strings, key=len) for a in given)
        raise ValueError(f"afferent run {args.exports[0]}: a scene file sets how the run goes, so {flags} would be "
                         f"ignored; set it in the scene file (see docs/scenes.md) or run without the file. With a "
                         f"scene file, afferent run takes -o/--output, --overwrite, --quiet, --no-cache, "
                         f"--results-format and --class.")


def run(args: argparse.Namespace) -> int:
    from ..scene import run_scene_cli

    argv = getattr(args, "argv", None)
    command = None if argv is None else "afferent " + shlex.join(argv)
    if len(args.exports) == 1 and args.exports[0].lower().endswith(".toml"):
        scene = args.exports[0]
        _refuse_options_a_scene_sets(args)
        if getattr(args, "results_format", None) is not None or getattr(args, "afferent_class", None) is not None:
            from dataclasses import replace

            from ..scene import load_scene, resolve

            scene = load_scene(scene, resolve_defaults=False)
            if args.results_format is not None:
                scene = replace(scene, outputs=replace(scene.outputs, format=args.results_format))
            if args.afferent_class is not None:
                scene = replace(scene, afferent=replace(scene.afferent, afferent_class=args.afferent_class))
            scene = resolve(scene)
        return run_scene_cli(scene, output=args.output, overwrite=args.overwrite, quiet=args.quiet,
                             use_cache=not args.no_cache, command=command)
    from ._main import _WORDS, speak_cli

    return run_scene_cli(scene_from_args(args), overwrite=args.overwrite, quiet=args.quiet,
                         use_cache=not args.no_cache, command=command,
                         speak=lambda m: speak_cli(m, _WORDS["flags"], _WORDS["choices"]))
