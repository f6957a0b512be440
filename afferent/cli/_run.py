"""Run the static pipeline: SED at receptors -> receptor currents -> afferent currents [-> fit].

Writes into OUTDIR: receptors.csv (receptor, x_m, y_m, z_m, section ids, time_s, sed_pa,
current_a), afferents.csv (afferent, position_m, time_s, current_a), fit.csv and
profile_fit.csv with --observed, receptors.vtu (ParaView), run.json (the record), and the
figures sed_map.png, profiles_x.png, profiles_z.png [, fit.png].

Transduction parameters are in SI: --alpha in A (the study's table is in mA:
2.46e-5 mA = 2.46e-8 A), --gamma in 1/Pa, --lambda in Pa; or --params start|longitudinal|cross
for the study's table-5.2 rows.

Example::

    $ afferent run sample_sed/block4/indent_0p88mm.vtu --receptors sample_sed/block4/receptors.csv \\
          --length-unit mm --sed-unit MPa --synthesis longitudinal --params start -o results/run1
"""

from __future__ import annotations

import argparse
import sys

from ..export import file_sha256, write_pipeline_outputs
from ..io import read_sed
from ..pipeline import SYNTHESES, run_pipeline
from ..profiles import read_observed
from ..sampling import METHODS
from ..transduction import STUDY_PARAMS, SigmoidParams
from ._options import add_input_options, add_receptor_options, layout_from_args, add_output_options, add_quiet, input_kwargs


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("exports", nargs="+", metavar="EXPORT", help="FE export file(s); several files are one time step each")
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
    g.add_argument("--observed-unit", metavar="U", help="length unit of the observed positions (default: the export's)")
    g.add_argument("--normalise", choices=("both", "prediction", "observation", "neither"), default="both",
                   help="what is min-max normalised before comparing (the study: both)")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    add_receptor_options(parser)
    add_input_options(parser)
    add_output_options(parser, what="output folder (created whole, or not at all)")
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


def run(args: argparse.Namespace) -> int:
    params = params_from_args(args)
    exports = args.exports if len(args.exports) > 1 else args.exports[0]
    field = read_sed(exports, **input_kwargs(args))
    unit = field.provenance.units.get("length")
    layout = layout_from_args(args, field)
    observed = None
    if args.observed:
        observed = read_observed(args.observed, length_unit=args.observed_unit or unit)
    result = run_pipeline(field, layout, params, synthesis=args.synthesis, method=args.method,
                          on_outside=args.on_outside, observed=observed, normalise=args.normalise, rng=args.seed)
    files = list(field.provenance.files) + ([args.receptors] if args.receptors else []) + ([args.observed] if args.observed else [])
    record = {
        "command": "afferent " + " ".join(sys.argv[1:]) if sys.argv and sys.argv[0].endswith("afferent") else None,
        "inputs": {f: file_sha256(f) for f in files},
        "field": field.provenance.to_dict(),
        "receptors": {"file": args.receptors, "grid": args.grid, "length_unit": unit, "n": layout.n_receptors},
        "transduction": {"alpha_a": params.alpha, "gamma_per_pa": params.gamma, "lambda_pa": params.lambda_},
        "synthesis": args.synthesis, "sampling": args.method, "normalise": args.normalise,
    }
    write_pipeline_outputs(result, args.output, record=record, overwrite=args.overwrite, plots=not args.no_plots)
    if not args.quiet:
        msg = f"wrote {args.output}: {layout.n_receptors} receptors -> {result.afferent.n_afferents} afferents ({args.synthesis})"
        if result.fit is not None:
            msg += f"; R2(study) {result.fit.r2_study:.3f}, R2 {result.fit.r2:.3f}, ssd {result.fit.ssd:.3g}"
        print(msg, file=sys.stderr)
        if result.saturation.saturated:
            print(f"afferent: warning: {result.saturation.message}", file=sys.stderr)
    return 0
