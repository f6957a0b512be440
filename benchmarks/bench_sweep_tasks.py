"""Benchmark: the cost of making a sweep's tasks (issue 38), first run and resume, this checkout against another.

The sweep: the sample's static 0.88 mm export with its receptors, under the study's ramp-and-hold,
rate-sensitive input, over a product of the sigmoid's slope gamma (100 values, a log range) and the
input's gain (``--tasks`` / 100 values): ``--tasks`` tasks in one sampling group. Nothing is run: what
is timed is what the process that dispatches a sweep does per task before any worker starts,

* ``make``: :meth:`SweepSpec.iter_tasks` over the first ``--tasks`` tasks (each task's id and group);
* ``resume``: the task stream of a re-run into a folder where every task is done
  (``afferent._sweep.records._windows`` with every id done: each task made, its id checked, skipped);
* ``--read``: what a re-run reads first, the done tasks of the folder (``afferent._sweep._prepare``: ids and
  input hashes, ``records._done_records``), from a folder of ``--tasks`` records written in batches of 64 (the
  first task run for real, its record copied under each task's id), with each batch's index
  (``tasks/index-*.json``) and without (every record read, as before the indexes); this checkout only.

Each measurement runs in a fresh Python process per checkout (``--tree DIR``: the folder whose
``afferent/`` package runs, e.g. a ``git archive`` of main), the checkouts interleaved ``--repeat``
times (the machine may be shared: the load average is printed). A checkout that makes a task in ~1 ms
makes at most ``--cap`` tasks (the per-task cost is flat: the stream holds one window at a time).

Run::

    python benchmarks/bench_sweep_tasks.py --tasks 100000 --tree /tmp/old --repeat 3
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLOCK4 = ROOT / "sample_sed" / "block4"


def sweep_file(folder: Path, n: int) -> Path:
    p = folder / f"bench_sweep_tasks_{n}.toml"
    p.write_text(f"""
[scene]
name = "bench"
[export]
file = "{(BLOCK4 / 'indent_0p88mm.vtu').as_posix()}"
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = "{(BLOCK4 / 'receptors.csv').as_posix()}"
[transduction]
params = "start"
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5
depth_mm = 0.5
speed_mm_per_s = 5.0
hold_s = 2.0
[spikes]
input = "rate-sensitive"
gain_s = 0.2
[outputs]
want = ["spikes", "profiles"]
[sweep]
"transduction.gamma_per_pa" = {{start = 1e-3, stop = 2e-2, num = 100, spacing = "log"}}
"spikes.gain_ms" = {{start = 50, stop = 400, num = {max(1, n // 100)}}}
""")
    return p


CHILD = r"""
import itertools, json, resource, sys, time
from afferent._sweep import load_sweep
from afferent._sweep import records
src, n = sys.argv[1], int(sys.argv[2])
t = time.perf_counter()
spec = load_sweep(src, max_tasks=10**7)
load = time.perf_counter() - t
def clock():
    return time.perf_counter(), time.process_time()
w, c = clock()
ids = [t.id for t in itertools.islice(spec.iter_tasks(), n)]
w1, c1 = clock()
made = len(ids)
class Head:  # the first `made` tasks of the spec: the resume stream over them
    def iter_tasks(self):
        return itertools.islice(spec.iter_tasks(), made)
done = records._Ids(ids)
counts = {"skipped": 0, "groups": 0}
w2, c2 = clock()
left = sum(1 for _ in records._windows(Head(), done, bytearray(), counts))
w3, c3 = clock()
assert left == 0 and counts["skipped"] == made, (left, counts)
print(json.dumps({"tasks": made, "load_s": load, "make_wall_s": w1 - w, "make_cpu_s": c1 - c,
                  "resume_wall_s": w3 - w2, "resume_cpu_s": c3 - c2,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


READ = r"""
import itertools, json, os, sys, time
from afferent._sweep import load_sweep, engine, records, _inputs_unchanged
src, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
spec = load_sweep(src, max_tasks=10**7)
tasks = list(itertools.islice(spec.iter_tasks(), n))
first = engine.run_batch(engine.sample(tasks[0], None, False), tasks[:1])[0]
assert first[1] == "ok", first[3][:300]
os.makedirs(os.path.join(out, "tasks"))
for k in range(0, len(tasks), 64):
    items = [(t.id, "ok", 0.0, first[3].replace(tasks[0].id, t.id), first[4]) for t in tasks[k:k + 64]]
    import hashlib
    name = hashlib.sha256(",".join(i[0] for i in items).encode()).hexdigest()[:16]
    batch = os.path.join(out, "tasks", f"batch-{name}.jsonl")
    with open(batch, "w") as f:
        f.write("".join(i[3] + "\n" for i in items))
    with open(os.path.join(out, "tasks", f"index-{name}.json"), "w") as f:
        json.dump(records.index_of(batch, items), f, separators=(",", ":"))
def done():
    hashes = {}
    t = time.perf_counter(), time.process_time()
    ids = [i for i, inputs in records._done_records(out) if _inputs_unchanged(inputs, hashes)]
    assert len(ids) == len(tasks), len(ids)
    return time.perf_counter() - t[0], time.process_time() - t[1]
size = sum(os.path.getsize(os.path.join(out, "tasks", f)) for f in os.listdir(os.path.join(out, "tasks")) if f.endswith("l"))
index = sum(os.path.getsize(os.path.join(out, "tasks", f)) for f in os.listdir(os.path.join(out, "tasks")) if f.endswith("n"))
w_i, c_i = done()
for f in os.listdir(os.path.join(out, "tasks")):
    if f.startswith("index-"):
        os.remove(os.path.join(out, "tasks", f))
w_s, c_s = done()
print(json.dumps({"tasks": len(tasks), "record_bytes": len(first[3]), "batches_mb": size / 1e6, "indexes_mb": index / 1e6,
                  "index_wall_s": w_i, "index_cpu_s": c_i, "scan_wall_s": w_s, "scan_cpu_s": c_s}))
"""


def read(src: Path, n: int, work: Path, repeat: int) -> None:
    """The ``--read`` measurement (module docstring), ``repeat`` times in fresh processes of this checkout."""
    import shutil

    rs = []
    for k in range(repeat):
        out = work / f"read-{k}"
        p = subprocess.run([sys.executable, "-c", READ, str(src), str(n), str(out)], capture_output=True, text=True,
                           cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)))
        shutil.rmtree(out, ignore_errors=True)
        if p.returncode:
            print(f"read: failed\n{p.stderr[-2000:]}")
            return
        r = json.loads(p.stdout.strip().splitlines()[-1])
        rs.append(r)
        print(f"read round {k + 1}: {r['tasks']} done tasks ({r['record_bytes']} B a record; batches {r['batches_mb']:.0f} "
              f"MB, indexes {r['indexes_mb']:.2f} MB): from the indexes {r['index_wall_s'] / r['tasks'] * 1e3:.4f} ms/task "
              f"wall ({r['index_cpu_s'] / r['tasks'] * 1e3:.4f} CPU), every record read {r['scan_wall_s'] / r['tasks'] * 1e3:.4f} "
              f"ms/task wall ({r['scan_cpu_s'] / r['tasks'] * 1e3:.4f} CPU); load average {os.getloadavg()[0]:.2f}")
    m = {k: statistics.median(r[k] / r["tasks"] for r in rs) * 1e3
         for k in ("index_wall_s", "index_cpu_s", "scan_wall_s", "scan_cpu_s")}
    print(f"read median over {len(rs)} rounds: indexes {m['index_wall_s']:.4f} ms/task wall ({m['index_cpu_s']:.4f} CPU), "
          f"records {m['scan_wall_s']:.4f} ms/task wall ({m['scan_cpu_s']:.4f} CPU): "
          f"{m['scan_cpu_s'] / m['index_cpu_s']:.0f}x CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=int, default=100_000, help="tasks of the sweep (a product of 100 x tasks/100)")
    ap.add_argument("--tree", action="append", default=[], help="another checkout to compare (repeatable)")
    ap.add_argument("--cap", type=int, default=3000, help="most tasks made by a checkout slower than 0.2 ms a task")
    ap.add_argument("--repeat", type=int, default=3, help="rounds, checkouts interleaved (the median is reported)")
    ap.add_argument("--read", action="store_true", help="measure reading a resumed folder's done tasks instead")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-sweep-tasks-"))
    src = sweep_file(work, args.tasks)
    trees = [str(ROOT), *args.tree]
    print("command:", shlex.join([sys.executable, *sys.argv]))
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} (1 min); sweep {src}")
    if args.read:
        return read(src, args.tasks, work, args.repeat)
    def run(tree, n):
        out = subprocess.run([sys.executable, "-c", CHILD, str(src), str(n)], capture_output=True, text=True,
                             cwd=tree, env=dict(os.environ, PYTHONPATH=tree))
        if out.returncode:
            print(f"{tree}: failed\n{out.stderr[-2000:]}")
            return None
        return json.loads(out.stdout.strip().splitlines()[-1])

    runs: dict = {t: [] for t in trees}
    slow = {}  # an untimed first run of 300 tasks per checkout: which make more than --cap tasks
    for tree in trees:
        r = run(tree, 300)
        slow[tree] = r is None or r["make_cpu_s"] / r["tasks"] > 2e-4
    for k in range(args.repeat):
        for tree in trees:
            r = run(tree, min(args.cap, args.tasks) if slow[tree] else args.tasks)
            if r is None:
                continue
            runs[tree].append(r)
            print(f"round {k + 1} {tree}: {r['tasks']} tasks: make {r['make_wall_s'] / r['tasks'] * 1e3:.4f} ms/task wall "
                  f"({r['make_cpu_s'] / r['tasks'] * 1e3:.4f} CPU), resume {r['resume_wall_s'] / r['tasks'] * 1e3:.4f} "
                  f"ms/task wall ({r['resume_cpu_s'] / r['tasks'] * 1e3:.4f} CPU); load_sweep {r['load_s']:.2f} s; "
                  f"peak RSS {r['peak_mb']:.0f} MB; load average {os.getloadavg()[0]:.2f}")
    med = {}
    for tree, rs in runs.items():
        if not rs:
            continue
        med[tree] = {k: statistics.median(r[k] / r["tasks"] for r in rs) * 1e3
                     for k in ("make_wall_s", "make_cpu_s", "resume_wall_s", "resume_cpu_s")}
        m = med[tree]
        print(f"median over {len(rs)} rounds, {tree}: make {m['make_wall_s']:.4f} ms/task wall ({m['make_cpu_s']:.4f} "
              f"CPU), resume {m['resume_wall_s']:.4f} ms/task wall ({m['resume_cpu_s']:.4f} CPU); 10^6 tasks: make "
              f"{m['make_wall_s'] * 1e3 / 60:.1f} min wall, resume {m['resume_wall_s'] * 1e3 / 60:.1f} min")
    if len(med) > 1 and str(ROOT) in med:
        for tree in trees[1:]:
            if tree in med:
                a, b = med[str(ROOT)], med[tree]
                print(f"ratio {tree} / this checkout: make {b['make_cpu_s'] / a['make_cpu_s']:.0f}x CPU "
                      f"({b['make_wall_s'] / a['make_wall_s']:.0f}x wall), resume {b['resume_cpu_s'] / a['resume_cpu_s']:.0f}x "
                      f"CPU ({b['resume_wall_s'] / a['resume_wall_s']:.0f}x wall)")


if __name__ == "__main__":
    main()
