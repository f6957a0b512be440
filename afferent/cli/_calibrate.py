"""Calibrate the receptor sigmoid (alpha, gamma, lambda) against a recorded afferent profile (RSM by default).

Input: SED_AT_RECEPTORS.csv as written by ``afferent sample`` (long form: receptor, x_m, y_m,
z_m, time_s, sed_pa; SI units; sections are recomputed from the positions) and a recorded
profile OBS.csv (columns position, response; positions in --observed-unit, required).
The profile of the last time step is compared (--time-index to choose another).

Methods: rsm1 (default; the study's two-level factorial + centre design, first-order fit,
steepest descent at 5 % increments), rsm2 (second-order surface, central composite design),
least_squares (scipy reference with the closed-form Jacobian; seeded random restarts only when
the first start fails) or all. Unless --no-reference, the least-squares reference is also run
and reported beside the chosen method.

--start is alpha,gamma,lambda in A, 1/Pa, Pa (the study's table is in mA:
2.46e-5 mA = 2.46e-8 A), or a table-5.2 row name: start (default), longitudinal, cross.

Writes into OUTDIR (created whole, or not at all): iterations.csv (iteration, alpha, gamma,
lambda, ssd, evaluations: the study's table 5.2 for your data), design_runs.csv (every
evaluated point), coefficients.csv (fitted surface per iteration), comparison.csv
(method, ssd, R2, model and Jacobian evaluations, status, parameters), result.json (best_method: the
lowest ssd), profile.png (calibrated vs observed: every method that ran, the best by the ssd named in the
title and legend) and ssd.png (ssd per evaluation); each other method's folder OUTDIR/METHOD holds its
own tables, profile.png and ssd.png. With --synthesis both: one such folder per grouping
(OUTDIR/longitudinal, OUTDIR/cross), plus OUTDIR/syntheses.csv and OUTDIR/result.json.

Example::

    $ afferent calibrate sed_at_receptors.csv --observed recording.csv --observed-unit mm \\
          --synthesis longitudinal --method rsm1 -o results/calibration
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings


from ..exceptions import AfferentWarning
from ..sampling import read_receptor_sed
from ..transduction import STUDY_PARAMS, SigmoidParams
from ._options import add_output_options, show_progress, unit_type, after_prefix, reads

_METHOD_CHOICES = ("rsm1", "rsm2", "least_squares", "all")


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("sed", metavar="SED_AT_RECEPTORS.csv", help="SED at the receptors, as written by 'afferent "
                                                                           "sample'"))
    reads(parser.add_argument("--observed", required=True, metavar="OBS.csv", help="recorded profile: columns position, "
                                                                                   "response"), what="Observed profile file")
    parser.add_argument("--observed-unit", required=True, metavar="U", type=unit_type("length"),
                        help="length unit of the observed positions (m, mm, um); required, as everywhere: never guessed")
    reads(parser.add_argument("--synthesis", default="longitudinal", metavar="longitudinal|cross|both|map:FILE|random:N",
                              help="receptor -> afferent grouping; 'both' calibrates longitudinal and cross-sections "
                                   "(default longitudinal)"), after_prefix("map:"), what="Branching map file")
    parser.add_argument("--start", default="start", metavar="ALPHA,GAMMA,LAMBDA",
                        help="start point in A, 1/Pa, Pa, or a table-5.2 row: start (default), longitudinal, cross")
    parser.add_argument("--method", choices=_METHOD_CHOICES, default="rsm1", help="calibration method (default rsm1, the study's)")
    parser.add_argument("--normalise", choices=("both", "prediction", "observation", "neither"), default="both",
                        help="what is min-max normalised before comparing (the study: both; alpha then has no effect)")
    g = parser.add_argument_group("loop settings (defaults: the study's)")
    g.add_argument("--increment", type=float, default=0.05, help="coding step as a fraction of the base value (default 0.05)")
    g.add_argument("--tol", type=float, default=None, help="relative ssd decrease per iteration that ends the loop (default 1e-3)")
    g.add_argument("--max-iter", type=int, default=None, help="iteration budget (default 50)")
    g.add_argument("--max-steps", type=int, default=None, help="descent steps per iteration (default 100)")
    g.add_argument("--refine", type=int, default=0, help="halve the increments up to N times when an iteration stalls (default 0: the study)")
    g.add_argument("--time-index", type=int, default=-1, help="time step compared, Python indexing (default -1, the last)")
    g.add_argument("--on-outside", choices=("raise", "drop"), default="raise",
                   help="afferents outside the observed positions: error (default) or leave them out")
    g.add_argument("--seed", type=int, default=0, help="seed for the least-squares starts and --synthesis random:N (default 0)")
    g.add_argument("--no-reference", action="store_true", help="do not run the least-squares reference beside the method")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    add_output_options(parser, what="output folder (created whole, or not at all)")


# ------------------------------------------------------------------------------ reading
def parse_start(text: str) -> SigmoidParams:
    """``'alpha,gamma,lambda'`` (A, 1/Pa, Pa) or a table-5.2 row name -> SigmoidParams."""
    text = str(text).strip()
    if text in STUDY_PARAMS:
        return STUDY_PARAMS[text]
    parts = [p.strip() for p in text.split(",")]
    try:
        if len(parts) != 3:
            raise ValueError
        a, g, lam = (float(p) for p in parts)
    except ValueError as err:
        raise ValueError(
            f"--start must be ALPHA,GAMMA,LAMBDA in A, 1/Pa, Pa (e.g. 2.46e-8,4.6e-3,300) or one of "
            f"{', '.join(STUDY_PARAMS)}; got {text!r} instead."
        ) from err
    return SigmoidParams(a, g, lam)


# ------------------------------------------------------------------------------ writing
def _write_tables(result, folder: str, *, plots: bool, beside: dict | None = None) -> list[str]:
    """The tables of one method's ``result`` into ``folder``; with ``plots`` its profile.png (every method of
    ``beside`` drawn with it, the best by the ssd named: :func:`afferent.calibration.plot_calibrated_profiles`)
    and ssd.png."""
    written = []
    result.iterations.to_csv(os.path.join(folder, "iterations.csv"), index=False)
    result.design_runs.to_csv(os.path.join(folder, "design_runs.csv"), index=False)
    result.coefficients.to_csv(os.path.join(folder, "coefficients.csv"), index=False)
    written += ["iterations.csv", "design_runs.csv", "coefficients.csv"]
    if plots:
        from ..calibration import plot_calibrated_profile, plot_calibrated_profiles, plot_ssd_history
        from ..plotting import save_figure

        save_figure(plot_calibrated_profiles(beside) if beside and len(beside) > 1 else plot_calibrated_profile(result),
                    os.path.join(folder, "profile.png"))
        save_figure(plot_ssd_history(result), os.path.join(folder, "ssd.png"))
        written += ["profile.png", "ssd.png"]
    return written


def _comparison(results: dict):
    from ..calibration import methods_table

    return methods_table(results).drop(columns=["params"])


def _record(results: dict, primary: str, extra: dict) -> dict:
    from ..calibration import best_method
    from ..export import jsonable

    main = results[primary]
    out = dict(extra)
    out.update(main.to_dict())
    out["units"] = {"alpha": "A", "gamma": "1/Pa", "lambda": "Pa", "positions": "m", "ssd": "square of the compared profiles"}
    out["best_method"] = best_method(results)  # by the ssd, the criterion every method minimises
    out["comparison"] = [
        {"method": m, "ssd": r.ssd, "r2_study": r.r2_study, "r2": r.r2, "evaluations": r.n_evaluations,
         "jacobian_evaluations": r.n_jacobian_evaluations,
         "params": {"alpha_a": r.params.alpha, "gamma_per_pa": r.params.gamma, "lambda_pa": r.params.lambda_},
         "success": r.success, "status": r.status, "no_effect": list(r.no_effect)}
        for m, r in results.items()
    ]
    ref = results.get("least_squares")
    if ref is not None and primary != "least_squares":
        out["reference"] = {"method": "least_squares", "ssd": ref.ssd, "evaluations": ref.n_evaluations,
                            "jacobian_evaluations": ref.n_jacobian_evaluations,
                            "ssd_excess_of_" + primary: main.ssd - ref.ssd}
    return jsonable(out)


def _write_one(results: dict, primary: str, folder: str, *, plots: bool, extra: dict) -> None:
    _write_tables(results[primary], folder, plots=plots, beside=results)
    for m, r in results.items():
        if m != primary:
            sub = os.path.join(folder, m)
            os.makedirs(sub)
            _write_tables(r, sub, plots=plots)
    _comparison(results).to_csv(os.path.join(folder, "comparison.csv"), index=False)
    with open(os.path.join(folder, "result.json"), "w") as f:
        json.dump(_record(results, primary, extra), f, indent=2)


def _cost(result) -> str:
    """'N evaluations' or 'N evaluations + M Jacobian evaluations'."""
    jac = f" + {result.n_jacobian_evaluations} Jacobian evaluations" if result.n_jacobian_evaluations else ""
    return f"{result.n_evaluations} evaluations{jac}"


# ---------------------------------------------------------------------------------- run
def run(args: argparse.Namespace) -> int:
    from .._output import atomic_dir, check_writable
    from ..calibration import calibrate
    from ..export import file_sha256
    from ..profiles import read_observed

    check_writable(args.output, overwrite=args.overwrite, inputs=(args.sed, args.observed), folder=True)
    start = parse_start(args.start)
    sed = read_receptor_sed(args.sed)
    observed = read_observed(args.observed, length_unit=args.observed_unit)
    spec = args.synthesis.strip()
    syntheses = ("longitudinal", "cross") if spec == "both" else (spec,)
    primary = "rsm1" if args.method == "all" else args.method
    methods = [primary]
    if args.method == "all":
        methods += ["least_squares", "rsm2"]
    elif not args.no_reference and primary != "least_squares":
        methods.append("least_squares")
    kwargs = dict(start=start, increment=args.increment, normalise=args.normalise, refine=args.refine,
                  time_index=args.time_index, on_outside=args.on_outside, rng=args.seed, progress=show_progress(args))
    for key in ("tol", "max_iter", "max_steps"):
        if getattr(args, key) is not None:
            kwargs[key] = getattr(args, key)
    caught = []
    all_results = {}
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always", AfferentWarning)
        for syn in syntheses:
            all_results[syn] = {m: calibrate(sed, observed, synthesis=syn, method=m, **kwargs) for m in methods}
        caught = [str(x.message) for x in w if issubclass(x.category, AfferentWarning)]
    extra = {
        "inputs": {args.sed: file_sha256(args.sed), args.observed: file_sha256(args.observed)},
        "options": {"synthesis": args.synthesis, "method": args.method, "normalise": args.normalise,
                    "observed_unit": args.observed_unit, "start": {"alpha_a": start.alpha, "gamma_per_pa": start.gamma,
                                                                  "lambda_pa": start.lambda_},
                    "increment": args.increment, "refine": args.refine, "time_index": args.time_index,
                    "seed": args.seed, **{k: kwargs[k] for k in ("tol", "max_iter", "max_steps") if k in kwargs}},
    }
    plots = not args.no_plots
    with atomic_dir(args.output, overwrite=args.overwrite, inputs=(args.sed, args.observed)) as tmp:
        if len(syntheses) == 1:
            _write_one(all_results[syntheses[0]], primary, tmp, plots=plots, extra=extra)
        else:
            import pandas as pd

            from ..export import jsonable

            rows = []
            for syn, results in all_results.items():
                sub = os.path.join(tmp, syn)
                os.makedirs(sub)
                _write_one(results, primary, sub, plots=plots, extra={**extra, "synthesis_folder": syn})
                r = results[primary]
                rows.append({"synthesis": syn, "method": primary, "ssd": r.ssd, "r2_study": r.r2_study, "r2": r.r2,
                             "alpha": r.params.alpha, "gamma": r.params.gamma, "lambda": r.params.lambda_,
                             "evaluations": r.n_evaluations, "jacobian_evaluations": r.n_jacobian_evaluations,
                             "success": r.success, "status": r.status,
                             "fraction_sensitive": r.saturation.fraction_sensitive})
            table = pd.DataFrame(rows)
            table.to_csv(os.path.join(tmp, "syntheses.csv"), index=False)
            best = table.loc[table["ssd"].idxmin(), "synthesis"]
            with open(os.path.join(tmp, "result.json"), "w") as f:
                json.dump(jsonable({**extra, "method": primary, "best_synthesis": best,
                                     "syntheses": {syn: _record(res, primary, {}) for syn, res in all_results.items()}}),
                          f, indent=2)
    if not args.quiet:
        _print_results(all_results, primary, caught, args.output)
    return 0


def _print_results(all_results: dict, primary: str, caught: list, output: str) -> None:
    """Per synthesis: the chosen method's result, the others' ssd and cost, the best by the ssd; then the warnings."""
    from ..calibration import best_method

    for syn, results in all_results.items():
        r = results[primary]
        p = r.params
        line = (f"{syn}, {primary}: ssd {r.ssd:.4g} (R2 study {r.r2_study:.3f}) in {_cost(r)}; "
                f"alpha {p.alpha:.4g} A, gamma {p.gamma:.4g} 1/Pa, lambda {p.lambda_:.4g} Pa")
        for m, ref in results.items():
            if m != primary:
                line += f" | {m}: ssd {ref.ssd:.4g} in {_cost(ref)}"
        if len(results) > 1:
            line += f" | best by ssd: {best_method(results)} (profile.png draws every method)"
        print(line, file=sys.stderr)
        print(f"  {_say(r.message)}", file=sys.stderr)
    for msg in dict.fromkeys(caught):
        print(f"afferent: warning: {_say(msg)}", file=sys.stderr)
    print(f"wrote {output}", file=sys.stderr)


def _say(msg: str) -> str:
    """A status or warning on one line, the library's keywords (refine=N, method='rsm2') as this command's flags."""
    from ._main import _WORDS, speak_cli

    return speak_cli(" ".join(msg.split()), _WORDS["flags"], _WORDS["choices"])
