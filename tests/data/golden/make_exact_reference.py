"""Regenerate exact_quick.npz: the exact engine's spikes on bench_spiking --quick's workload.

The workload: afferent.report.synthetic_afferent_current(1250, duration=0.2) (1,250 ramp-and-hold
afferent currents, 1 ms samples) through simulate_lif(..., engine='exact-numba', LIF_PRESETS['ra'],
duration=0.2) with input_hold 'previous' and 'linear'. Stored: every afferent's spike count, and the
spike times of every 10th afferent (k % 10 == 0) in s.

Origin: written by this script with afferent at 12e06a9 + issue 32 (the afferent-by-afferent
kernel of issue 23), numba 0.68.1, numpy 2.3.5, on an AMD EPYC with AVX2 + FMA and no AVX-512.
The same counts (95,301 and 95,581 spikes) as the sample-by-sample kernel before issue 23 on a
CPU with AVX-512 (its sha256 pin); the numpy back end agrees to 7.8e-15 relative here. The
test (tests/test_spiking_exact.py) compares counts exactly and times to 1e-12 relative: the bits
of exp/log differ between CPUs, so no float bits are pinned.

    python tests/data/golden/make_exact_reference.py
"""

from pathlib import Path

import numpy as np

from afferent.report import synthetic_afferent_current
from afferent.spiking import LIF_PRESETS, simulate_lif

OUT = Path(__file__).with_name("exact_quick.npz")
EVERY = 10


def main() -> None:
    times, cur = synthetic_afferent_current(1250, duration=0.2)
    data = {}
    for hold in ("previous", "linear"):
        res = simulate_lif(cur, LIF_PRESETS["ra"], engine="exact-numba", times=times, duration=0.2, input_hold=hold)
        kept = [np.asarray(t) for t in res.spike_times[::EVERY]]
        data[f"{hold}_counts"] = np.asarray(res.counts, dtype=np.int32)
        data[f"{hold}_times"] = np.concatenate(kept)
        print(f"{hold}: {int(res.counts.sum())} spikes, {data[f'{hold}_times'].size} stored")
    np.savez_compressed(OUT, **data)
    print(f"wrote {OUT} ({OUT.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main()
