"""Compare the vibration runs: SED at the RA-I site at each cycle's deepest point, and the mean rate, vs frequency.

RUN_DIR... are output folders of ``afferent run`` whose scenes want ``cycles`` (each holds
``cycles.csv``, written by afferent.cycles; the run's label is its scene name, read as ``afferent
hotspots`` reads runs), or of ``afferent sweep`` (every task of its scenes that want ``cycles``, from
the task records). The frequency of each run is its ``cycles.csv`` column ``frequency_hz``,
the scene's ``[outputs] cycles_frequency_hz``. Runs are grouped by ``--group NAME=PATTERN`` (a
shell-style pattern on the labels, repeatable; default one group of all runs), e.g. one per model.

Writes into OUT: ``frequency.csv`` (one row per group and run: frequency, SED at the site at the
first and the last cycle's deepest point, their ratio to the group's lowest frequency, the mean
rate over the cycles) and ``frequency.png`` (the study's fig. 4-11 beside fig. 4-12: SED at the
deepest points vs frequency, first and last cycle, and mean rate vs frequency, a line per group, both axes
from zero, the legend naming each run's last cycle).

Example (the vibration samples)::

    $ for s in sample_sed/scenes/vibration/*.toml; do afferent run "$s" -o "results/vibration/$(basename "$s" .toml)"; done
    $ afferent cycles results/vibration/* -o results/vibration_frequency --group 3d='ridged3d_*' --group 2d='ridged2d_*'

or, from the sweep of the eight scenes::

    $ afferent sweep sample_sed/scenes/sweep_vibration.toml -o results/vibration_sweep
    $ afferent cycles results/vibration_sweep -o results/vibration_frequency --group 3d='ridged3d_*' --group 2d='ridged2d_*'
"""

from __future__ import annotations

import argparse
import os
import sys

from ._options import add_run_comparison_options, reads


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="output folders of runs (or sweeps) wanting "
                                                                         "'cycles'"))
    add_run_comparison_options(parser, verb="draw")


def run(args: argparse.Namespace) -> int:
    from .._output import atomic_dir
    from ..cycles import frequency_summary
    from ..hotspots import group_runs
    from ..plotting import plot_frequency, save_figure
    from ._hotspots import _groups

    runs = read_cycle_runs(args.runs)
    summary = frequency_summary(runs, group_runs(list(runs), _groups(args.group)))
    with atomic_dir(args.output, overwrite=args.overwrite) as tmp:
        summary.to_csv(os.path.join(tmp, "frequency.csv"), index=False)
        save_figure(plot_frequency(summary), os.path.join(tmp, "frequency.png"))
    if not args.quiet:
        print(f"afferent cycles: wrote {args.output}: frequency.csv, frequency.png", file=sys.stderr)
        print(summary.to_string(index=False))
    return 0


def read_cycle_runs(folders) -> dict:
    """{label: cycles table} of ``afferent run`` output folders (their ``cycles.csv``, read by
    :func:`afferent.hotspots.read_run_tables`) and ``afferent sweep`` output folders (holding ``sweep.json``:
    every finished task's table, from its record ``cycles``, labelled by its scene name). A sweep without a
    task that wants ``cycles``, or one label twice, are errors naming the folder."""
    from ..cycles import CYCLE_CHECKS
    from ..hotspots import read_run_tables

    runs = {}
    for folder in folders:
        if os.path.isfile(os.path.join(folder, "sweep.json")):
            found = _sweep_tables(folder)
            if not found:
                raise ValueError(f"{folder!r}: a sweep with no finished task wanting 'cycles'; add 'cycles' to its "
                                 "scenes' [outputs] want.")
        else:
            found = read_run_tables([folder], "cycles.csv", "cycles", CYCLE_CHECKS)
        for label, table in sorted(found.items()):
            if label in runs:
                raise ValueError(f"{folder!r}: a second run named {label!r}; give runs of distinct scene names.")
            runs[label] = table
    return runs


def _sweep_tables(folder: str) -> dict:
    """{scene name: cycles table} of the finished tasks of the sweep in ``folder`` that want ``cycles``; a record
    whose table is not a table (columns of equal length) is an error naming the task."""
    import pandas as pd

    from .._sweep.records import _iter_records

    found = {}
    for rec in _iter_records(folder):
        cycles = rec.get("record", {}).get("cycles") if isinstance(rec.get("record"), dict) else None
        if rec.get("status") != "ok" or not isinstance(cycles, dict) or "table" not in cycles:
            continue
        try:
            found[str(rec.get("scene"))] = pd.DataFrame(cycles["table"])
        except (ValueError, TypeError) as err:
            raise ValueError(f"{folder!r}: the record of task {rec['task']} holds a 'cycles' table that is not a "
                             f"table of columns ({err}); expected the record afferent sweep writes.") from err
    return found
