"""Benchmark: a sweep of the sample exports x a grid of parameter sets, serial against Dask.

The sweep: the six static block4 exports (indenters 0.44 ... 2.00 mm), each driven by the study's
ramp-and-hold, rate-sensitive input and exact LIF spikes, over a 5 x 5 x 4 grid of the sigmoid's
slope gamma, the input's gain and its time constant: 6 x 100 = 600 tasks, six samplings.

Each engine runs in its own fresh Python process (peak memory is that process's, and its
children's for 'processes'), with an empty SED cache (every export is read and sampled).
Also measured, for the cluster estimate: the pickled size of one sampled group (what crosses
the network per export and worker), the mean task time, and the per-task overhead of Dask's
schedulers on empty tasks (local threads, and a distributed LocalCluster).

Run::

    python benchmarks/bench_sweep.py            # all engines (~1-2 min on 2 cores)
    python benchmarks/bench_sweep.py --quick    # 2 exports x 100 parameter sets
    python benchmarks/bench_sweep.py --repeat 3 # engines interleaved, 3 rounds: the machine may be shared
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLOCK4 = ROOT / "sample_sed" / "block4"
EXPORTS = ["indent_0p44mm.vtu", "indent_0p66mm.vtu", "indent_0p88mm.vtu", "indent_1p10mm.vtu", "indent_1p32mm.vtu",
           "indent_2p00mm.vtu"]
sys.path.insert(0, str(ROOT))  # measure this checkout's afferent, not whichever one is installed
ENGINES = ("serial", "threads", "processes", "localcluster")


def sweep_file(folder: Path, n_exports: int) -> Path:
    files = ", ".join(f'"{(BLOCK4 / e).as_posix()}"' for e in EXPORTS[:n_exports])
    p = folder / "bench_sweep.toml"
    p.write_text(f"""
[scene]
name = "bench"
[export]
file = "{(BLOCK4 / EXPORTS[0]).as_posix()}"
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
dt_ms = 1.0
[spikes]
input = "rate-sensitive"
gain_s = 0.2
[outputs]
want = ["spikes", "profiles"]
[sweep]
"export.file" = [{files}]
"transduction.gamma_per_pa" = {{start = 1e-3, stop = 2e-2, num = 5, spacing = "log"}}
"spikes.gain_ms" = {{start = 50, stop = 400, num = 5}}
"spikes.tau_ms" = [2.0, 5.0, 10.0, 20.0]
""")
    return p


def child(engine: str, src: str, out: str) -> None:
    """One engine in this (fresh) process; prints a JSON line."""
    os.environ["AFFERENT_CACHE_DIR"] = tempfile.mkdtemp(prefix="bench-sweep-cache-")
    from afferent._sweep import sweep

    t = time.perf_counter()
    if engine == "localcluster":
        import distributed

        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            t_up = time.perf_counter() - t
            res = sweep(src, out, scheduler=client, overwrite=True)
    else:
        t_up = 0.0
        res = sweep(src, out, scheduler=engine, overwrite=True)
    wall = time.perf_counter() - t
    ru_self, ru_kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    me, kids = ru_self.ru_maxrss / 1024, ru_kids.ru_maxrss / 1024
    cpu = ru_self.ru_utime + ru_self.ru_stime + ru_kids.ru_utime + ru_kids.ru_stime
    print(json.dumps({"engine": engine, "wall_s": wall, "startup_s": t_up, "tasks": res.n_tasks, "failed": res.n_failed,
                      "rows": len(res.table), "peak_mb": me, "cpu_s": cpu, "peak_children_mb": kids,
                      "task_s": res.record["task_seconds"], "batches": res.record["engine"].get("batches")}))


def overheads(n: int = 2000) -> dict:
    """Per-task scheduler overhead on empty tasks, s: dask threaded get and a distributed LocalCluster."""
    import distributed
    from dask.threaded import get

    dsk = {f"t{i}": (int, i) for i in range(n)}
    t = time.perf_counter()
    get(dsk, list(dsk), num_workers=2)
    local = (time.perf_counter() - t) / n
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        client.gather(client.map(int, range(50)))  # warm
        t = time.perf_counter()
        client.gather(client.map(int, range(1000, 1000 + n), pure=False))
        dist = (time.perf_counter() - t) / n
    return {"threads_per_task_s": local, "distributed_per_task_s": dist}


def sampled_bytes(src: Path) -> dict:
    """Pickled size of one sampling group's result (ReceptorSED + layout + record), bytes."""
    import pickle

    from afferent._sweep import engine, load_sweep

    spec = load_sweep(src)
    tasks = next(iter(spec.groups.values()))
    t = time.perf_counter()
    s = engine.sample(tasks[0], use_cache=False)
    t_sample = time.perf_counter() - t
    t = time.perf_counter()
    engine.run_task(tasks[0], s)  # the first spike run of a process loads the compiled LIF
    t0 = time.perf_counter()
    for task in tasks[1:21]:
        engine.run_task(task, s)
    return {"sampled_bytes": len(pickle.dumps(s)), "sed_values_bytes": int(s.sed.values.nbytes),
            "sed_shape": list(s.sed.values.shape), "sample_s": t_sample, "first_task_s": t0 - t,
            "task_s": (time.perf_counter() - t0) / 20}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 exports instead of 6")
    ap.add_argument("--engines", default=",".join(ENGINES))
    ap.add_argument("--repeat", type=int, default=1, help="rounds, engines interleaved (the median is reported)")
    ap.add_argument("--child", nargs=3, metavar=("ENGINE", "SWEEP", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(*args.child)
        return
    work = Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    src = sweep_file(work, 2 if args.quick else 6)
    print("command:", shlex.join([sys.executable, *sys.argv]))
    print(f"machine: {os.cpu_count()} cores; sweep {src} ({2 if args.quick else 6} exports x 100 parameter sets)")
    results, runs = [], {}
    for k in range(args.repeat):
        for engine in args.engines.split(","):
            out = subprocess.run([sys.executable, __file__, "--child", engine, str(src), str(work / f"out-{engine}")],
                                 capture_output=True, text=True, cwd=ROOT,
                                 env=dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))))
            if out.returncode:
                print(f"{engine}: failed\n{out.stderr[-2000:]}")
                continue
            r = json.loads(out.stdout.strip().splitlines()[-1])
            runs.setdefault(engine, []).append(r)
            print(f"round {k + 1} {engine:>12}: {r['wall_s']:6.2f} s wall ({r['startup_s']:.2f} s cluster start-up), "
                  f"CPU {r['cpu_s']:.1f} s, {r['tasks']} tasks ({r['failed']} failed, {r['batches']} batches), {r['rows']} "
                  f"rows, sum of task times {r['task_s']:.2f} s, peak RSS {r['peak_mb']:.0f} MB (children "
                  f"{r['peak_children_mb']:.0f} MB)")
    import statistics

    for engine, rs in runs.items():
        results.append(rs[0])
        walls = sorted(r["wall_s"] for r in rs)
        print(f"{engine:>12}: median {statistics.median(walls):.2f} s wall, min {walls[0]:.2f} s, over {len(rs)} rounds; "
              f"median CPU {statistics.median(r['cpu_s'] for r in rs):.1f} s; "
              f"peak RSS {max(r['peak_mb'] for r in rs):.0f} MB (+ children {max(r['peak_children_mb'] for r in rs):.0f} MB)")
    import pandas as pd

    from afferent._sweep import read_table

    tables = {r["engine"]: read_table(next((work / f"out-{r['engine']}").glob("table.*"))) for r in results}
    ref = tables.get("serial")
    if ref is not None:
        for name, t in tables.items():
            pd.testing.assert_frame_equal(t, ref)
        print("tables: identical across", ", ".join(tables))
    m = sampled_bytes(src)
    print(f"one sampled group: {m['sampled_bytes']} bytes pickled (SED {m['sed_shape']} = {m['sed_values_bytes']} bytes); "
          f"sampling {m['sample_s']:.3f} s; task {m['task_s'] * 1e3:.2f} ms (first in a process {m['first_task_s']:.2f} s)")
    o = overheads()
    print(f"scheduler overhead per empty task: dask threads {o['threads_per_task_s'] * 1e6:.0f} us, "
          f"distributed LocalCluster {o['distributed_per_task_s'] * 1e6:.0f} us")


if __name__ == "__main__":
    main()
