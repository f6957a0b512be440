"""Benchmark of stage 6 (:func:`afferent.spiking.simulate_lif`): speed, memory and accuracy.

Run from the repository root::

    .venv/bin/python benchmarks/bench_spiking.py            # full: 12,500 afferents, 1 s
    .venv/bin/python benchmarks/bench_spiking.py --quick    # smaller, for a smoke test

Part 1 - the target workload: 12,500 afferents, 1 s, RA preset. The current is a
ramp-and-hold sampled every 1 ms (as an FE export would be; 1,001 samples x 12,500 afferents =
100 MB), with per-afferent plateau amplitudes drawn log-uniformly over the study's
afferent-current range 30 nA - 16 uA (see the spiking module docstring) and onsets jittered
over 0-20 ms. Engines: the exact one (event-driven, no time step; held and linear input; numba
and the numpy fallback) and the grid ones at dt = 0.1 ms (fast with numba and numpy, brian2).
Each runs in a fresh subprocess (so brian2's imports do not weigh on the others) and reports:

* wall time of ``simulate_lif`` (best of ``--repeat``; brian2 once) and its CPU time (user +
  system of every thread, median of the repeats: what a shared machine cannot inflate), after one warm-up call
  that loads numba's compiled loop (timed apart: compile, or load from the on-disk cache);
* peak memory allocated during the call, by tracemalloc (numpy buffers, including the spike
  buffers, which are allocated in Python) - the 100 MB input is allocated before and not
  counted;
* the process's peak resident memory (ru_maxrss) before and after the call: it includes the
  interpreter, imports and the input, and catches anything tracemalloc cannot see.

Part 2 - speed vs accuracy: engine x dt -> wall time and errors against the exact engine on a
subset of afferents (:func:`afferent.report.measure_spiking`, the measurement of ``afferent report``). Errors: median and max |t - t_exact| over rank-matched spikes (each
spike matched to the exact spike of the same rank; at high rates this accumulates the
per-interval bias of the grid), the fraction of afferents whose spike count differs, the
worst first-spike latency error, and the median relative error of the mean rate.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import subprocess
import sys
import time
import tracemalloc

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's afferent

from afferent.report import measure_spiking, synthetic_afferent_current  # noqa: E402
from afferent.spiking import LIF_PRESETS, simulate_lif  # noqa: E402

PARAMS = LIF_PRESETS["ra"]
DT = 1e-4
def workload(quick: bool):
    n_aff, duration = (1250, 0.2) if quick else (12_500, 1.0)
    times, current = synthetic_afferent_current(n_aff, duration=duration)  # ramp-and-hold, as in afferent report
    return n_aff, duration, times, current


def maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux


def measure_one(label: str, quick: bool, repeat: int) -> dict:
    """Run in a subprocess: time and memory of one engine (``ENGINE[:linear]``) on the Part 1 workload."""
    n_aff, duration, times, current = workload(quick)
    engine, _, hold = label.partition(":")
    hold = hold or "previous"

    def run():
        return simulate_lif(current, PARAMS, dt=DT, engine=engine, times=times, duration=duration, input_hold=hold)

    t0 = time.perf_counter()
    simulate_lif(np.full((2, 1), 1e-6), PARAMS, dt=DT, engine=engine, input_hold=hold)  # loads numba's loop
    warmup = time.perf_counter() - t0
    rss_before = maxrss_mb()
    tracemalloc.start()
    res = run()
    traced_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    rss_after = maxrss_mb()
    best, cpus = np.inf, []
    for _ in range(1 if engine == "brian2" else repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        res = run()
        best = min(best, time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    digest = hashlib.sha256()
    for train in res.spike_times:
        digest.update(np.asarray(train).tobytes() + b"|")
    return {
        "engine": label,
        "backend": res.backend,
        "wall_s": best,
        "cpu_s": float(np.median(cpus)),
        "warmup_s": warmup,
        "traced_peak_mb": traced_peak / 1e6,
        "rss_before_mb": rss_before,
        "rss_after_mb": rss_after,
        "spikes": int(res.n_spikes.sum()),
        "skipped": int(res.silent_skipped.size),
        "sha256": digest.hexdigest()[:16],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1,250 afferents, 0.2 s, small accuracy table")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-brian2", action="store_true")
    parser.add_argument("--one", metavar="ENGINE", help=argparse.SUPPRESS)  # internal: subprocess mode
    args = parser.parse_args(argv)

    if args.one:
        print(json.dumps(measure_one(args.one, args.quick, args.repeat)))
        return 0

    env = [f"PYTHONPATH={os.environ['PYTHONPATH']}"] if os.environ.get("PYTHONPATH") else []
    print("command:", " ".join([*env, "python", *sys.argv]))
    import afferent

    print("afferent from", os.path.dirname(afferent.__file__))
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    try:
        import numba

        print(f"numba {numba.__version__}")
    except ImportError:
        print("numba not installed")

    n_aff, duration, times, current = workload(args.quick)
    print(f"\n== Part 1: {n_aff} afferents, {duration:g} s; grid engines at dt = {DT * 1e3:g} ms "
          f"({int(round(duration / DT))} steps), exact engine without a step")
    print(f"input: {current.shape[0]} samples every 1 ms x {n_aff} afferents = {current.nbytes / 1e6:.0f} MB")
    engines = ["exact-numba", "exact-numba:linear", "exact-numpy", "exact-numpy:linear", "fast-numba", "fast-numpy"]
    engines += [] if args.no_brian2 else ["brian2"]
    rows = []
    for engine in engines:
        cmd = [sys.executable, __file__, "--one", engine, "--repeat", str(args.repeat)]
        cmd += ["--quick"] if args.quick else []
        out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1]
        rows.append(json.loads(out))
    print(
        f"\n{'engine':<19} {'wall s':>7} {'cpu s':>6} {'warm-up s':>9} {'traced peak MB':>14} {'RSS before MB':>13} "
        f"{'RSS after MB':>12} {'spikes':>9} {'skipped':>7}  spikes sha256"
    )
    for r in rows:
        print(
            f"{r['engine']:<19} {r['wall_s']:7.3f} {r['cpu_s']:6.3f} {r['warmup_s']:9.2f} {r['traced_peak_mb']:14.1f} "
            f"{r['rss_before_mb']:13.0f} {r['rss_after_mb']:12.0f} {r['spikes']:9d} {r['skipped']:7d}  {r['sha256']}"
        )
    grid = [r for r in rows if not r["engine"].startswith("exact")]
    print("grid engines give identical spike trains:", len({r["sha256"] for r in grid}) == 1)

    # ---- Part 2: accuracy (afferent report's measurement, afferent.report.measure_spiking) ----------
    n_sub = 50 if args.quick else 200
    sub = np.linspace(0, n_aff - 1, n_sub).astype(int)
    c2 = np.ascontiguousarray(current[:, sub])
    brian2_dts = () if args.no_brian2 else (1e-3, 1e-4, 1e-5) if args.quick else (1e-3, 1e-4)
    rows = measure_spiking(c2, times, duration, PARAMS, fast_dts=(1e-3, 1e-4, 1e-5, 1e-6), brian2_dts=brian2_dts, repeat=1)
    ref = rows[0]
    print(
        f"\n== Part 2: {n_sub} afferents, {duration:g} s; errors against the exact engine "
        f"({ref['backend']}: {ref['wall_s']:.3f} s, {ref['spikes']} spikes)"
    )
    print(
        f"{'dt ms':>6} {'engine':<11} {'wall s':>7} {'spike err med ms':>17} {'max ms':>8} {'count differs':>14} "
        f"{'latency err max ms':>19} {'rate err med':>13}"
    )
    for r in rows[1:]:
        if r.get("skipped"):
            print(f"{'-':>6} {r['engine']:<11}  (skipped: {r['skipped']})")
            continue
        label = "-" if r["dt_s"] is None else f"{r['dt_s'] * 1e3:g}"
        engine = r["engine"] if r["dt_s"] is not None else f"{r['engine']} (max |t - t_numba| {r['spike_err_max_s']:.1e} s)"
        print(
            f"{label:>6} {engine:<11} {r['wall_s']:7.3f} {r['spike_err_median_s'] * 1e3:17.6f} {r['spike_err_max_s'] * 1e3:8.4f} "
            f"{r['count_differs']:14.1%} {r['latency_err_max_s'] * 1e3:19.6f} {r['rate_err_median']:13.3%}"
        )
    if not args.no_brian2:
        print(f"(brian2 at dt < {min(brian2_dts) * 1e3:g} ms skipped: >= 10^5 Python-level steps; same spikes as 'fast')")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
