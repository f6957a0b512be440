"""Tabulate hot-spot maps of several runs: how well each tells its indenter apart, and one summary page.

RUN_DIR... are output folders of ``afferent run`` whose scenes want ``hotspots`` (each holds
``hotspots.csv``; the run's label is its scene name). Runs are compared within groups
(``--group NAME=PATTERN``, a shell-style pattern on the labels, repeatable; default one group
of all runs), per site set (the ``map`` column: e.g. the RA-I and the SA-I sites), on the
min-max normalised SED (docs/method.md, "Chapter 4").

Writes into OUT: ``distances.csv`` (group, map, a, b, distance = 1 - Pearson r of the two
maps), ``accuracy.csv`` (a nearest-centroid classifier over the group's maps with Gaussian noise
of --noise in normalised units, --trials copies per map, seed 0; chance = 1 / maps),
``summary.png`` (every map; a row per group and site set) and ``distances.png`` (one matrix per
group and site set).

Example (the chapter-4 samples)::

    $ for s in sample_sed/scenes/chapter4/*.toml; do afferent run "$s" -o "results/chapter4/$(basename "$s" .toml)"; done
    $ afferent hotspots results/chapter4/* -o results/chapter4_summary --group 3d='ridged3d_*' --group 2d='ridged2d_*'
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

from ._options import add_run_comparison_options, reads


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("runs", nargs="+", metavar="RUN_DIR", help="output folders of runs wanting 'hotspots'"))
    add_run_comparison_options(parser, verb="compare")
    parser.add_argument("--noise", default="0.1,0.3,0.5", metavar="S[,S...]",
                        help="classifier noise, standard deviation(s) in normalised SED units (default 0.1,0.3,0.5)")
    parser.add_argument("--trials", type=int, default=2000, metavar="N", help="noisy copies per map (default 2000)")
    parser.add_argument("--threshold", type=float, default=0.6, metavar="T",
                        help="hot spots drawn from this normalised SED (default 0.6, the study's)")


def _groups(specs):
    if not specs:
        return None
    out = {}
    for spec in specs:
        name, sep, pattern = spec.partition("=")
        if not sep or not name or not pattern:
            raise ValueError(f"--group must be NAME=PATTERN (e.g. 3d='ridged3d_*'); got {spec!r} instead.")
        out[name] = pattern
    return out


def run(args: argparse.Namespace) -> int:
    from .._output import atomic_dir
    from ..hotspots import compare_runs, group_runs, read_hotspot_runs
    from ..plotting import plot_distance_table, plot_hotspot_summary, save_figure

    if not 0.0 <= args.threshold <= 1.0:
        raise ValueError(f"--threshold is a normalised SED and must be within 0..1; got {args.threshold!r} instead.")
    groups = _groups(args.group)
    try:
        noises = [float(v) for v in str(args.noise).split(",")]
    except ValueError:
        raise ValueError(f"--noise must be comma-separated numbers; got {args.noise!r} instead.") from None
    runs = read_hotspot_runs(args.runs)
    import pandas as pd

    parts = []
    for k, s in enumerate(noises):
        with warnings.catch_warnings():
            if k:  # what compare_runs warns of (a run left out) is the same at every noise level: said once
                warnings.simplefilter("ignore")
            parts.append(compare_runs(runs, groups, noise=s, trials=args.trials))
    dist, acc = parts[0][0], pd.concat([a for _, a in parts], ignore_index=True)
    with atomic_dir(args.output, overwrite=args.overwrite) as tmp:
        dist.to_csv(os.path.join(tmp, "distances.csv"), index=False)
        acc.to_csv(os.path.join(tmp, "accuracy.csv"), index=False)
        members = group_runs(list(runs), groups)
        save_figure(plot_hotspot_summary(runs, members, threshold=args.threshold), os.path.join(tmp, "summary.png"))
        _distance_figure(dist, members, os.path.join(tmp, "distances.png"), plot_distance_table, save_figure)
    if not args.quiet:
        print(f"afferent hotspots: wrote {args.output}: distances.csv, accuracy.csv, summary.png, distances.png",
              file=sys.stderr)
        print(acc.to_string(index=False))
    return 0


def _distance_figure(dist, members, path, plot_distance_table, save_figure) -> None:
    """One distance matrix per group and site set, side by side."""
    import matplotlib.pyplot as plt
    import pandas as pd

    panels = list(dist.groupby(["group", "map"], sort=False))
    fig, axes = plt.subplots(1, max(1, len(panels)), figsize=(4.8 * max(1, len(panels)), 4.4), layout="constrained",
                             squeeze=False)
    for ax, ((g, kind), d) in zip(axes[0], panels):
        labels = members[g]
        m = pd.DataFrame(0.0, index=labels, columns=labels)
        for row in d.itertuples():
            m.loc[row.a, row.b] = m.loc[row.b, row.a] = row.distance
        plot_distance_table(m, ax=ax, title=f"{g}, {kind}: 1 - r")
    save_figure(fig, path)
