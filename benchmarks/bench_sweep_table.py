"""Benchmark: gathering a sweep's table from its task records (issue 38): peak memory and time, this checkout
against another.

A sweep folder of ``--tasks`` task records is written (one row each, as a sweep of one afferent per
task; ``tasks/batch-*.jsonl`` files of 1,000 records, their order shuffled as a cluster's batches
arrive), then each checkout (``--tree DIR``: the folder whose ``afferent/`` runs, e.g. a ``git archive``
of main) gathers it in a fresh process into ``table.csv`` (``--format parquet``: ``table.parquet``):
the records read, the table written. Printed per run: wall time, the child's peak RSS above its RSS
after the imports (``ru_maxrss``), the load average; the checkouts interleaved ``--repeat`` times.

Run::

    python benchmarks/bench_sweep_table.py --tasks 100000 --tree /tmp/old --repeat 2
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shlex
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KEY = "transduction.gamma_per_pa"


def make_folder(folder: Path, n: int) -> Path:
    """A sweep folder of ``n`` 'ok' task records, one row each; returns the file of the tasks' ids (8 bytes each)."""
    (folder / "tasks").mkdir(parents=True)
    ids = [f"{random.Random(i).getrandbits(64):016x}" for i in range(n)]
    order = list(range(0, n, 1000))
    random.Random(0).shuffle(order)
    for lo in order:
        lines = []
        for i in range(lo, min(n, lo + 1000)):
            row = {"scene": "bench", "task": ids[i], KEY: 1e-3 + i * 1e-9, "afferent": "0", "position_m": 1e-3,
                   "peak_current_a": 1e-9, "profile_current_a": 1e-9, "profile_time_s": 2.1, "n_spikes": 12,
                   "rate_hz": 5.5, "first_spike_latency_s": 0.01, "mean_isi_s": 0.1, "cv_isi": 0.2,
                   "fit_r2_study": None, "fit_r2": None, "fit_ssd": None}
            lines.append(json.dumps({"task": ids[i], "index": i, "status": "ok", "rows": [row]}))
        (folder / "tasks" / f"batch-{lo:016x}.jsonl").write_text("\n".join(lines) + "\n")
    (folder / "ids.bin").write_bytes(b"".join(int(i, 16).to_bytes(8, sys.byteorder) for i in ids))
    return folder / "ids.bin"


CHILD = r"""
import inspect, json, os, resource, sys, time
import pandas  # noqa: F401 (its memory is not the table's)
if sys.argv[2] == "parquet":
    import pyarrow.parquet  # noqa: F401
from afferent._sweep import records
folder, fmt = sys.argv[1], sys.argv[2]
ids = records._Ids.of(open(os.path.join(folder, "ids.bin"), "rb").read())  # 8 bytes a task, no list of strings
def status(field):  # MB; VmHWM is this process's own peak (ru_maxrss keeps the parent's across the spawn)
    import re
    return int(re.search(field + r":\s+(\d+)", open("/proc/self/status").read()).group(1)) / 1024
open("/proc/self/clear_refs", "w").write("5")  # the peak starts again from here
base = status("VmRSS")
t = time.perf_counter()
if "table_format" in inspect.signature(records._gather).parameters:  # streamed (issue 38)
    path, rows, _, _ = records._gather(folder, ids, ["transduction.gamma_per_pa"], fmt)
else:  # held in memory, then written
    from afferent._sweep.table import write_table
    table, _ = records._gather(folder, ids, ["transduction.gamma_per_pa"])
    path, rows = write_table(table, folder, fmt), len(table)
wall = time.perf_counter() - t
peak = status("VmHWM")
print(json.dumps({"rows": rows, "wall_s": wall, "peak_mb": peak, "base_mb": base, "bytes": os.path.getsize(path)}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=int, default=100_000)
    ap.add_argument("--format", default="csv", choices=("csv", "parquet"))
    ap.add_argument("--tree", action="append", default=[], help="another checkout to compare (repeatable)")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-sweep-table-"))
    make_folder(work / "out", args.tasks)
    trees = [str(ROOT), *args.tree]
    print("command:", shlex.join([sys.executable, *sys.argv]))
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; {args.tasks} task records in "
          f"{work / 'out'} ({sum(f.stat().st_size for f in (work / 'out' / 'tasks').iterdir()) / 1e6:.0f} MB)")
    runs: dict = {t: [] for t in trees}
    for k in range(args.repeat):
        for tree in trees:
            out = subprocess.run([sys.executable, "-c", CHILD, str(work / "out"), args.format], capture_output=True,
                                 text=True, cwd=tree, env=dict(os.environ, PYTHONPATH=tree))
            if out.returncode:
                print(f"{tree}: failed\n{out.stderr[-2000:]}")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            runs[tree].append(r)
            print(f"round {k + 1} {tree}: {r['rows']} rows, {r['bytes'] / 1e6:.1f} MB table.{args.format}: "
                  f"{r['wall_s']:.1f} s wall, peak RSS {r['peak_mb']:.0f} MB ({r['peak_mb'] - r['base_mb']:.0f} MB above "
                  f"{r['base_mb']:.0f} MB after imports); load average {os.getloadavg()[0]:.2f}")
    for tree, rs in runs.items():
        if rs:
            print(f"median, {tree}: {statistics.median(r['wall_s'] for r in rs):.1f} s wall, "
                  f"{statistics.median(r['peak_mb'] - r['base_mb'] for r in rs):.0f} MB above the imports")


if __name__ == "__main__":
    main()
