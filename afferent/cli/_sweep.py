"""Run a sweep: scenes x parameter sets on Dask, each export sampled once, one tidy table.

SWEEP is a scene file with a [sweep] table (swept keys "table.key" = [values] or
{start, stop, num}; mode = "product" or "zip"; or scenes = [...] / a folder), a plain scene
file, or a folder of scene files; several may be given.

Writes into OUT: table.csv (table.parquet with --table-format parquet), one row per scene x parameter set
x afferent (rate, first-spike latency, spike count, peak and profile current, fit R2 and ssd;
NaN where the scene's outputs do not compute it); ``tasks/batch-*.jsonl``, one record per task
as a JSON line (failed ones with their error); sweep.json, the sweep's record. A re-run into OUT resumes: tasks
done are skipped, failed ones retried. Exit code 1 when a task failed (the others are kept).

Scheduler: Dask's local multiprocessing scheduler by default, one process per core (measured
faster than threads, whose tasks contend for the GIL; 'threads' and 'serial' too), or
--scheduler tcp://HOST:8786 for a running Dask cluster. Without Dask installed
(pip install 'afferent-skin[dask]') the sweep runs serially, same results.

Example::

    $ afferent sweep sample_sed/scenes/sweep_gamma.toml -o results/sweep_gamma
    $ afferent sweep sample_sed/scenes/sweep_gamma.toml -o results/sweep_gamma --scheduler tcp://10.0.0.5:8786
"""

from __future__ import annotations

import argparse
import shlex
import sys

from ._options import add_output_options, show_progress, reads


def add_args(parser: argparse.ArgumentParser) -> None:
    reads(parser.add_argument("sources", nargs="+", metavar="SWEEP",
                              help="sweep file (a scene with [sweep]), scene file(s) or folder(s) of them"))
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="'processes' (default), 'threads', 'serial', or a Dask scheduler address (tcp://HOST:PORT)")
    parser.add_argument("--batch-size", type=int, metavar="N",
                        help="tasks per Dask task (default: about four batches per worker thread)")
    parser.add_argument("--max-tasks", type=int, metavar="N",
                        help="most tasks the sweep may have (default 1,000,000; counted before any is made)")
    parser.add_argument("--table-format", choices=("csv", "parquet"), default="csv",
                        help="the table's format: table.csv (default) or table.parquet (typed columns; needs pyarrow)")
    parser.add_argument("--no-cache", action="store_true",
                        help="neither read nor write the sampled-SED cache ($AFFERENT_CACHE_DIR or ~/.cache/afferent)")
    add_output_options(parser, what="output folder (table, tasks/, sweep.json); an existing one of the same sweep is resumed")


def run(args: argparse.Namespace) -> int:
    from .._sweep import sweep

    if args.batch_size is not None and args.batch_size < 1:
        raise ValueError(f"--batch-size must be a positive integer; got {args.batch_size} instead.")
    argv = getattr(args, "argv", None)
    command = None if argv is None else "afferent " + shlex.join(argv)
    res = sweep(args.sources, args.output, scheduler=args.scheduler, overwrite=args.overwrite,
                use_cache=not args.no_cache, batch_size=args.batch_size, progress=show_progress(args),
                record_extra={"command": command}, max_tasks=args.max_tasks, table_format=args.table_format)
    if not args.quiet:
        eng = res.record.get("engine", {})
        print(f"afferent sweep: wrote {args.output}: {res.table_path.rsplit('/', 1)[-1]} ({res.n_rows} rows), "
              f"tasks/, sweep.json", file=sys.stderr)
        print(f"  tasks: {res.n_tasks} ({res.n_ran} run, {res.n_skipped} done before, {res.n_failed} failed) on "
              f"{eng.get('kind')}; {res.record['n_sampling_groups']} export sampling(s); "
              f"{res.record['wall_seconds']:.2f} s", file=sys.stderr)
    for f in res.failures:
        print(f"afferent: warning: task {f['task']} ({f['scene']}, {f['params']}) failed: {f['error']}", file=sys.stderr)
    return 1 if res.n_failed else 0
