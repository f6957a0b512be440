"""Measure every speed-accuracy trade-off on this machine and write a Markdown report with plots.

Runs small versions of the benchmarks on the sample installed with the package and writes
``OUTDIR/report.md`` (tables, the machine and the versions), one PNG plot per knob and
``results.json`` (every figure, machine-readable). The knobs: sampling method (``linear`` vs
``nearest``: time, error on an analytic field), spiking engine and time step (``exact`` vs the
grid engines ``fast`` and ``brian2``: time, rate and spike-time error), receptor count (time,
profile error), calibration method (``rsm1``, ``rsm2``, ``least_squares``: evaluations, time,
parameter error) and reading a time series (whole vs streamed: time, peak memory).

The default size takes 20-30 s on two cores; ``--full`` runs larger sizes, closer to the
benchmark scripts' (``benchmarks/*.py`` in the source repository; about a minute).

Example::

    $ afferent report -o results/report
"""

from __future__ import annotations

import argparse
import sys


def add_args(parser: argparse.ArgumentParser) -> None:
    from ._options import add_output_options

    add_output_options(parser, what="output folder (created whole, or not at all)", metavar="OUTDIR")
    parser.add_argument("--full", action="store_true", help="larger sizes (about a minute on two cores) instead of the quick ones")


def run(args: argparse.Namespace) -> int:
    from ..report import run_report

    def say(msg: str) -> None:
        if not args.quiet:
            print(f"afferent report: {msg} ...", file=sys.stderr)

    command = "afferent " + " ".join(getattr(args, "argv", None) or ["report", "-o", args.output])
    results = run_report(args.output, size="full" if args.full else "quick", overwrite=args.overwrite,
                         command=command, progress=say)
    if not args.quiet:
        print(f"afferent report: wrote {args.output}/report.md in {results['wall_s']:.0f} s",
              file=sys.stderr)
    return 0
