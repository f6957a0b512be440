"""Time the ``zones`` branching model in the LIF engines against the ``sum`` model (docs/spikes.md).

N afferents x K zones, 1,001 samples at 1 ms of a ramp (0.1 s), hold and release (at 0.9 s), each
zone at a constant multiple (0.5-3 rheobases, random) of the ``ra`` preset's rheobase; the sum
model runs on the summed current of the same afferents. Kernels are compiled or loaded before
timing; each line is the min-max wall time of ``--repeat`` runs. Usage::

    python benchmarks/bench_zones.py [--afferents 2000] [--zones 4] [--repeat 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from afferent.spiking import LIF_PRESETS, simulate_lif  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--afferents", type=int, default=2000)
    ap.add_argument("--zones", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    p = LIF_PRESETS["ra"]
    n_aff, k = args.afferents, args.zones
    t = np.arange(1001) * 1e-3
    shape = (np.minimum(t / 0.1, 1.0) * (t < 0.9))[:, None]
    zc = shape * np.random.default_rng(0).uniform(0.5, 3.0, size=(1, n_aff * k)) * p.rheobase
    zones = np.repeat(np.arange(n_aff), k)
    summed = zc.reshape(t.size, n_aff, k).sum(axis=2)
    few = n_aff // 20  # the plain-Python back end on a twentieth of the afferents
    cases = [
        ("sum, exact-numba", lambda: simulate_lif(summed, p, times=t, engine="exact-numba")),
        ("zones, exact-numba", lambda: simulate_lif(zc, p, times=t, zones=zones, engine="exact-numba")),
        ("zones, fast (numpy), dt 0.1 ms", lambda: simulate_lif(zc, p, times=t, zones=zones, engine="fast", dt=1e-4)),
        (f"zones, exact-numpy (plain Python), {few} afferents",
         lambda: simulate_lif(zc[:, :few * k], p, times=t, zones=zones[:few * k], engine="exact-numpy")),
    ]
    simulate_lif(zc[:, :k], p, times=t, zones=zones[:k], engine="exact-numba")  # compile or load the kernels
    simulate_lif(summed[:, :1], p, times=t, engine="exact-numba")
    print(f"{n_aff} afferents x {k} zones, {t.size} samples")
    for name, run in cases:
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            res = run()
            times.append(time.perf_counter() - t0)
        print(f"  {name}: {min(times):.3f}-{max(times):.3f} s, {int(res.n_spikes.sum()):,} spikes")


if __name__ == "__main__":
    main()
