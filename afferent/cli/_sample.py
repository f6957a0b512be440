"""Write the SED at receptor sites, in long form (one row per receptor and time step).

Columns: receptor, x_m, y_m, z_m, time_s, sed_pa (SI units). ``R.csv`` has columns x, y, z
(optional id) in the declared length unit.

Example::

    $ afferent sample sample_sed/block4/indent_0p88mm.vtu --receptors sample_sed/block4/receptors.csv \\
          --length-unit mm --sed-unit MPa --method linear -o sed_at_receptors.csv
"""

from __future__ import annotations

import argparse
import sys

from .._output import check_writable, write_csv
from .._tables import write_table
from itertools import chain

from .._interfaces import check_side
from ..io import iter_sed
from ..sampling import METHODS, sample_steps
from ._options import add_input_options, add_receptor_options, layout_from_args, add_output_options, input_kwargs, \
    add_side_option, reads, accepted, add_accept_option


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("exports", nargs="+", metavar="EXPORT", help="FE export file(s); several files are one time "
                                                                           "step each"))
    parser.add_argument("--method", choices=METHODS, default="linear", help="interpolate inside the mesh cells (linear) or take the nearest node (nearest)")
    parser.add_argument("--on-outside", choices=("raise", "warn", "nan"), default="raise", help="receptors outside the mesh: error (default) or NaN")
    add_side_option(parser)
    add_receptor_options(parser)
    add_input_options(parser)
    add_accept_option(parser)
    add_output_options(parser, what="output CSV (long form)", folder=False)


def run(args: argparse.Namespace) -> int:
    inputs = (*args.exports, args.receptors)
    check_writable(args.output, overwrite=args.overwrite, inputs=inputs)  # before the reading, not after
    # one step at a time: memory is one step of the mesh plus the result (iter_sed, sample_steps)
    raws = []  # the first step as read: --grid tips|bases are found on it (one read of the export)
    steps = iter_sed(args.exports if len(args.exports) > 1 else args.exports[0], accept=accepted(args),
                     on_first_raw=raws.append, **input_kwargs(args))
    first = next(steps)
    layout = layout_from_args(args, first, raws.pop())
    sed = sample_steps(chain([first], steps), layout, method=args.method, on_outside=args.on_outside,
                       side=check_side(args.side))
    # the table's columns written as pandas writes them (afferent._tables), without pandas' import (0.45 s)
    write_csv(sed.columns(), args.output, overwrite=args.overwrite, inputs=inputs, writer=lambda cols, p: write_table(p, cols))
    if not args.quiet:
        inside = sed.values[:, ~sed.outside]
        span = f"SED {inside.min():.4g} .. {inside.max():.4g} J/m^3" if inside.size else "no receptor inside the field"
        if sed.outside.any():
            span += f"; {int(sed.outside.sum())} receptor(s) outside the field written as NaN"
        if sed.interface:
            span += (f"; {sed.interface['n_on_interface']} on a material interface, side={sed.interface['side']!r} "
                     f"(sides differ by up to {sed.interface['max_spread']:.2g} x their mean)")
        print(f"wrote {args.output}: {layout.n_receptors} receptors x {sed.values.shape[0]} step(s), method={args.method} "
              f"({sed.placement}), {span}", file=sys.stderr)
    return 0
