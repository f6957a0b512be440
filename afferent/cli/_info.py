"""Describe what an FE export holds, and how afferent would read it.

Points, cells, arrays and their components, time steps, bounds, SED range, the columns
afferent recognises, the units it would use (and whether the file states them), and a hint
when magnitudes look like another unit.

Example::

    $ afferent info sample_sed/block4/indent_0p88mm.vtu
"""

from __future__ import annotations

import argparse

from ..io import FORMATS, describe_raw, read_raw
from ._options import add_quiet, show_progress

describe = describe_raw  # the name notebooks/01_read_fe_export.ipynb imports


def add_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("exports", nargs="+", metavar="EXPORT", help="FE export file(s); several files are one time step each")
    parser.add_argument("--format", choices=tuple(FORMATS), help="file format, when the extension does not tell")
    add_quiet(parser)


def run(args: argparse.Namespace) -> int:
    raw = read_raw(args.exports if len(args.exports) > 1 else args.exports[0], format=args.format, progress=show_progress(args))
    print("\n".join(describe_raw(raw)))
    return 0
