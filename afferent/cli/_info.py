"""Describe what an FE export holds, and how afferent would read it.

Points, cells, arrays and their components, time steps, bounds, SED range, the columns
afferent recognises, the units it would use (and whether the file states them), coincident
points and material ids, and a hint when magnitudes look like another unit. With
``--receptors`` or ``--grid tips|bases|y=H``: what the sites are (RA-I papilla tips, SA-I
ridge bases, or as given in a file), which materials meet at the receptors and what the side
choice (``afferent sample --side``) does to their SED (the export is then read: declare its units).

Example::

    $ afferent info sample_sed/block4/indent_0p88mm.vtu
    $ afferent info tests/data/dealii/indent_block.vtu --receptors tests/data/dealii/receptors.csv \\
          --length-unit mm --sed-unit MPa
    $ afferent info sample_sed/block4/indent_0p88mm.vtu --grid tips
"""

from __future__ import annotations

import argparse

from ..io import describe_raw, read_raw
from ._options import accepted, add_accept_option, add_input_options, add_receptor_options, input_kwargs, \
    layout_from_args, reads, show_progress

describe = describe_raw  # the name notebooks/01_read_fe_export.ipynb imports


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("exports", nargs="+", metavar="EXPORT", help="FE export file(s); several files are one time "
                                                                           "step each"))
    add_receptor_options(parser, required=False)  # say what the sites are, which materials meet there, what --side does
    parser.add_argument("--method", choices=("linear", "nearest"), default="linear", help="sampling method for --receptors")
    add_input_options(parser)
    add_accept_option(parser)


def run(args: argparse.Namespace) -> int:
    source = args.exports if len(args.exports) > 1 else args.exports[0]
    raw = first = read_raw(source, format=args.format, progress=show_progress(args),
                           allow_outside_files=args.allow_outside_files)
    if args.coordinates is not None:  # a table of labels (a MAPDL PRNSOL listing, a report): its NLIST / node table
        from ..io._find_arrays import join_coordinates

        raw = join_coordinates(raw, args.coordinates)
    print("\n".join(describe_raw(raw)))
    if args.receptors is not None or args.grid is not None:
        from .._interfaces import interface_lines
        from ..io import sed_from_raw
        from ..receptors import describe_sites

        read = {k: v for k, v in input_kwargs(args).items() if k not in ("format", "progress")}
        field = sed_from_raw(first, accept=accepted(args), **read)  # the export as read above: read once
        layout = layout_from_args(args, field, first)
        print(describe_sites(layout))
        print("\n".join(interface_lines(field, layout, method=args.method)))
    return 0
