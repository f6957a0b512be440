"""Run the pipeline: SED at receptors -> receptor currents -> afferent currents [-> fit] [-> spikes].

``afferent run SCENE.toml`` runs a scene file instead (see afferent.scene): only the stages its
outputs need, with sampled SED cached on disk and a run.json record.

Writes into OUTDIR: receptors.csv (receptor, x_m, y_m, z_m, section ids, time_s, sed_pa,
current_a), afferents.csv (afferent, position_m, time_s, current_a), fit.csv and
profile_fit.csv with --observed, receptors.vtu (ParaView), run.json (the record), and the
figures sed_map.png, profiles_x.png, profiles_z.png [, fit.png].

With --spikes, also spikes.csv (afferent, spike_time_s), spike_summary.csv (rate, first-spike
latency, ISI per afferent), raster.png, rates.png and psth.png; a static export can be driven by
--waveform (SED scaled by (d/d_ref)^2, valid for linear elasticity with a fixed contact area).

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
import sys

from ..export import file_sha256, write_pipeline_outputs
from ..io import read_sed
from ..pipeline import SYNTHESES, run_pipeline, run_spikes
from ..profiles import read_observed
from ..sampling import METHODS
from ..transduction import STUDY_PARAMS, SigmoidParams
from ._options import add_input_options, add_receptor_options, layout_from_args, add_output_options, add_quiet, input_kwargs


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("exports", nargs="+", metavar="EXPORT",
                        help="FE export file(s) (several files are one time step each), or one SCENE.toml")
    parser.add_argument("--method", choices=METHODS, default="linear", help="sampling: interpolate in the mesh cells, or nearest node")
    parser.add_argument("--on-outside", choices=("raise", "warn", "nan"), default="raise", help="receptors outside the mesh")
    parser.add_argument("--synthesis", default="longitudinal", metavar="|".join(SYNTHESES),
                        help="receptor -> afferent grouping (default longitudinal)")
    parser.add_argument("--seed", type=int, default=0, help="seed for --synthesis random:N")
    g = parser.add_argument_group("transduction (sigmoid) parameters, SI units")
    g.add_argument("--params", choices=tuple(STUDY_PARAMS), help="the study's table-5.2 row")
    g.add_argument("--alpha", type=float, metavar="A", help="saturation current, A")
    g.add_argument("--gamma", type=float, metavar="G", help="slope, 1/Pa")
    g.add_argument("--lambda", dest="lambda_", type=float, metavar="L", help="midpoint SED, Pa")
    g = parser.add_argument_group("comparison with a recording")
    g.add_argument("--observed", metavar="OBS.csv", help="recorded profile: columns position, response")
    g.add_argument("--observed-unit", metavar="U", help="length unit of the observed positions (m, mm, um); required with --observed")
    g.add_argument("--normalise", choices=("both", "prediction", "observation", "neither"), default="both",
                   help="what is min-max normalised before comparing (the study: both)")
    g = parser.add_argument_group("stimulus over time (for a static export)")
    g.add_argument("--waveform", metavar="SPEC",
                   help="indentation depth over time: 'ramp:DEPTH_MM,SPEED_MM_PER_S,HOLD_S' (ramp-and-hold with release), "
                        "'sine:FREQ_HZ,AMPLITUDE_MM,DURATION_S', or a CSV 'FILE' with columns time, depth")
    g.add_argument("--waveform-unit", default="mm", metavar="U", help="depth unit of a waveform CSV (default mm; time in s)")
    g.add_argument("--reference-step", type=int, metavar="K",
                   help="with --waveform on a multi-step export: the step solved at --d-ref-mm (-1: the last); required there")
    g.add_argument("--series-depths-mm", metavar="D0,D1,...",
                   help="depth (mm) of every step of a loading-series export: the d^2 scaling is measured against it "
                        "and recorded in run.json")
    g.add_argument("--d-ref-mm", type=float, metavar="D", help="indentation depth of the static export, mm (SED scales as (d/d_ref)^2)")
    g.add_argument("--waveform-dt-ms", type=float, default=1.0, help="sampling step of ramp/sine waveforms, ms (default 1)")
    g = parser.add_argument_group("spikes (leaky integrate-and-fire)")
    g.add_argument("--spikes", action="store_true", help="simulate spikes: writes spikes.csv and spike_summary.csv")
    g.add_argument("--engine", default="auto", choices=("auto", "exact", "exact-numba", "exact-numpy", "fast", "fast-numba", "fast-numpy", "brian2"),
                   help="spiking engine: exact (default; event-driven, exact spike times, no time step), fast (on the "
                        "--dt-ms grid) or brian2 (the grid reference; same spikes as fast)")
    g.add_argument("--dt-ms", type=float, default=0.1, help="LIF time step of the grid engines fast and brian2, ms (default 0.1; exact has none)")
    g.add_argument("--lif-preset", default="ra", help="LIF parameter set (afferent.spiking.LIF_PRESETS; default 'ra')")
    g.add_argument("--input", choices=("static", "rate-sensitive"), default="static",
                   help="static: the sigmoid current (the study; fires through a hold); rate-sensitive: RA-I adaptation, "
                        "fires at onset and offset (needs --gain-s)")
    g.add_argument("--gain-s", type=float, help="gain of the rate-sensitive input, s (A of input per A/s)")
    g.add_argument("--tau-ms", type=float, help="time constant of the rate-sensitive input, ms (default 5)")
    g.add_argument("--drive", choices=("resistance", "rheobase"), default="resistance",
                   help="current -> membrane: through the preset's r_m as is (default), or rescaled so that the largest "
                        "input current is --rheobase-multiple x the rheobase")
    g.add_argument("--rheobase-multiple", type=float, default=2.0, metavar="K",
                   help="with --drive rheobase: the largest current becomes K x the rheobase (default 2)")
    g.add_argument("--duration-s", type=float, help="simulated time, s (default: the stimulus; 1 s for a static export)")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    add_receptor_options(parser, required=False)
    add_input_options(parser)
    add_output_options(parser, what="output folder (created whole, or not at all); for a scene, overrides its [outputs] dir",
                       required=False)
    add_quiet(parser)


def params_from_args(args) -> SigmoidParams:
    given = {k: getattr(args, k) for k in ("alpha", "gamma", "lambda_") if getattr(args, k) is not None}
    if args.params is not None:
        base = STUDY_PARAMS[args.params]
        return SigmoidParams(given.get("alpha", base.alpha), given.get("gamma", base.gamma), given.get("lambda_", base.lambda_))
    missing = [f"--{k.rstrip('_')}" for k in ("alpha", "gamma", "lambda_") if k not in given]
    if missing:
        raise ValueError(
            f"Transduction parameters {', '.join(missing)} are missing: give --alpha A --gamma G --lambda L "
            f"(A, 1/Pa, Pa) or --params one of {', '.join(STUDY_PARAMS)}."
        )
    return SigmoidParams(given["alpha"], given["gamma"], given["lambda_"])


def waveform_from_args(args):
    """The :class:`afferent.stimulus.Waveform` that ``--waveform`` describes, or None."""
    if not args.waveform:
        return None
    from .. import stimulus

    spec = args.waveform.strip()
    kind, _, rest = spec.partition(":")
    dt = args.waveform_dt_ms * 1e-3
    if kind in ("ramp", "sine") and rest:
        try:
            values = [float(v) for v in rest.split(",")]
        except ValueError as err:
            raise ValueError(f"--waveform {spec!r}: the values after '{kind}:' must be numbers.") from err
        if len(values) != 3:
            raise ValueError(f"--waveform {kind}: needs 3 comma-separated values; got {len(values)} in {spec!r} instead.")
        if kind == "ramp":
            depth_mm, speed_mm_s, hold_s = values
            return stimulus.ramp_and_hold(depth_mm * 1e-3, speed_mm_s * 1e-3, hold_s, dt=dt, post=0.1)
        freq, amp_mm, dur = values
        return stimulus.sinusoid(freq, amp_mm * 1e-3, duration=dur, dt=dt)
    return stimulus.read_waveform(spec, length_unit=args.waveform_unit)


def _series_depths(args):
    if args.series_depths_mm is None:
        return None
    if args.waveform is None:
        raise ValueError("--series-depths-mm applies to --waveform (it measures the d^2 scaling); add --waveform.")
    try:
        return [float(d) * 1e-3 for d in args.series_depths_mm.split(",")]
    except ValueError as err:
        raise ValueError(f"--series-depths-mm must be comma-separated numbers (mm); got {args.series_depths_mm!r} instead.") from err


def run(args: argparse.Namespace) -> int:
    if len(args.exports) == 1 and args.exports[0].lower().endswith(".toml"):
        from ..scene import run_scene_cli

        return run_scene_cli(args.exports[0], output=args.output, overwrite=args.overwrite, quiet=args.quiet)
    if args.receptors is None and args.grid is None:
        raise ValueError("afferent run needs the receptor sites: --receptors R.csv or --grid tips|y=H (or a SCENE.toml).")
    if args.output is None:
        raise ValueError("afferent run needs an output folder: -o OUTDIR.")
    params = params_from_args(args)
    waveform = waveform_from_args(args)
    if waveform is not None and args.d_ref_mm is None:
        raise ValueError("--waveform needs --d-ref-mm, the indentation depth (mm) at which the static export was solved.")
    if args.input == "rate-sensitive" and not args.spikes:
        raise ValueError("--input rate-sensitive applies to spikes: add --spikes.")
    exports = args.exports if len(args.exports) > 1 else args.exports[0]
    field = read_sed(exports, **input_kwargs(args))
    unit = field.provenance.units.get("length")
    layout = layout_from_args(args, field)
    observed = None
    if args.observed:
        if args.observed_unit is None:
            raise ValueError("--observed needs --observed-unit, the length unit of the observed positions (e.g. mm); "
                             "afferent never guesses a unit.")
        observed = read_observed(args.observed, length_unit=args.observed_unit)
    result = run_pipeline(field, layout, params, synthesis=args.synthesis, method=args.method,
                          on_outside=args.on_outside, observed=observed, normalise=args.normalise, rng=args.seed,
                          waveform=waveform, d_ref=None if args.d_ref_mm is None else args.d_ref_mm * 1e-3,
                          reference_step=args.reference_step, series_depths=_series_depths(args))
    if args.spikes:
        from ..spiking import LIFParams

        lif = LIFParams.from_preset(args.lif_preset)
        duration = args.duration_s
        if duration is None and result.afferent.n_times == 1:
            duration = 1.0
        result = run_spikes(result, lif, dt=args.dt_ms * 1e-3, engine=args.engine, input=args.input, gain=args.gain_s,
                            tau=None if args.tau_ms is None else args.tau_ms * 1e-3, duration=duration,
                            drive=args.drive, rheobase_multiple=args.rheobase_multiple)
    files = list(field.provenance.files) + ([args.receptors] if args.receptors else []) + ([args.observed] if args.observed else [])
    record = {
        "command": "afferent " + " ".join(sys.argv[1:]) if sys.argv and sys.argv[0].endswith("afferent") else None,
        "inputs": {f: file_sha256(f) for f in files},
        "field": field.provenance.to_dict(),
        "receptors": {"file": args.receptors, "grid": args.grid, "length_unit": unit, "n": layout.n_receptors},
        "transduction": {"alpha_a": params.alpha, "gamma_per_pa": params.gamma, "lambda_pa": params.lambda_},
        "synthesis": args.synthesis, "sampling": {"method": result.sed.method, "placement": result.sed.placement},
        "normalise": args.normalise,
        "waveform": None if waveform is None else {"spec": args.waveform, "kind": waveform.kind,
                                                   "parameters": dict(waveform.parameters), "d_ref_m": args.d_ref_mm * 1e-3,
                                                   "scaling": result.scaling},
    }
    write_pipeline_outputs(result, args.output, record=record, overwrite=args.overwrite, plots=not args.no_plots)
    if not args.quiet:
        msg = f"wrote {args.output}: {layout.n_receptors} receptors -> {result.afferent.n_afferents} afferents ({args.synthesis})"
        if result.fit is not None:
            msg += f"; R2(study) {result.fit.r2_study:.3f}, R2 {result.fit.r2:.3f}, ssd {result.fit.ssd:.3g}"
        print(msg, file=sys.stderr)
        if result.spikes is not None:
            n = sum(len(t) for t in result.spikes.spike_times)
            grid = f", dt {args.dt_ms:g} ms" if result.spikes.dt else ", no grid"
            print(f"spikes: {n} in {result.spikes.duration:g} s ({result.spikes.engine}{grid}, "
                  f"{args.input} input); {len(result.spikes.silent_skipped)} afferent(s) provably silent, not simulated",
                  file=sys.stderr)
        print(result.saturation.summary(), file=sys.stderr)  # a warning, if any, was printed once by transduce
    return 0
