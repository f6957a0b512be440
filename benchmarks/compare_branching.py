"""Compare the ``sum`` and ``zones`` branching models on the sample's indenter profiles (docs/spikes.md).

For every square indenter of the FE sample (``sample_sed/block4`` 0.44-2.00 mm, ``block8`` 4 mm)
it runs ``afferent run`` with the study's start parameters, longitudinal sections and spikes
(static export, 1 s), once per branching model, and reads each run's ``run.json``: the rate of
every afferent (longitudinal section, across x) and the afferent current. It prints a
Markdown table: per indenter and model, the number of peaks across x of the current that drives
the LIFs (sum: the afferent current; zones: the afferent's strongest zone's), counted as the
demo counts them (``afferent.cli._demo.count_peaks``, 5 % prominence), and the valley
(:func:`valley`: the lowest value between the two halves' maxima over the smaller maximum; 1 =
no dip, 0 = silent between two peaks) of that current and of the rate. Rates are spike counts
over 1 s, so they are whole hertz: two equal maxima one hertz above the centre are a valley of
0.998, not an interchange zone.

The drive is ``--drive rheobase --rheobase-multiple K``: the largest afferent (summed) current of
the run is K rheobases for every model ("same membrane scale": the models differ only in how the
receptors' currents reach the membrane, so a zone, which sees part of the current, is driven
less); each zones run is repeated with the multiple that puts its strongest zone at K rheobases
("strongest zone at K rheobases": the profiles' shapes compared at a matched firing level).
Usage::

    python benchmarks/compare_branching.py [--sample-dir sample_sed] [--multiple 4] [--zones 4 1000]
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from afferent.cli._demo import CASES, count_peaks  # noqa: E402


def valley(profile) -> float:
    """Lowest value between the largest value of the left half and that of the right half (the centre in
    the right half), over the smaller of the two: 1 = no dip between them, 0 = silent between two peaks;
    NaN for an all-zero profile."""
    p = np.asarray(profile, dtype=float)
    half = p.size // 2
    i, j = int(np.argmax(p[:half])), half + int(np.argmax(p[half:]))
    low = min(p[i], p[j])
    return float(p[i:j + 1].min() / low) if low > 0 else float("nan")


def run_case(sample: Path, block: str, file: str, model: list[str], multiple: float, out: Path) -> tuple[dict, str, float]:
    cmd = ["afferent", "run", f"{sample}/{block}/{file}", "--receptors", f"{sample}/{block}/receptors.csv",
           "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start", "--spikes", "--drive", "rheobase",
           "--rheobase-multiple", f"{multiple:g}", *model, "--no-plots", "-q", "-o", str(out)]
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "afferent", *cmd[1:]], check=True)
    return json.loads((out / "run.json").read_text()), shlex.join(cmd), time.perf_counter() - t


def _row(width: float, label: str, rec: dict) -> str:
    d = rec["spikes"]["drive"]
    rate, cur = np.array(d["rate_hz"]), np.array(d["peak_current_a"])
    return (f"| {width:.2f} mm | {label} | {max(d['drive_over_rheobase']):.3g} | {count_peaks(cur)} | {valley(cur):.2f} "
            f"| {valley(rate):.2f} | {' '.join(f'{r:.0f}' for r in rate)} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sample-dir", default=str(ROOT / "sample_sed"))
    ap.add_argument("--multiple", type=float, default=4.0, help="rheobases of the largest afferent current")
    ap.add_argument("--zones", type=int, nargs="+", default=[4, 1000], help="zones per afferent to compare (1000: one per receptor)")
    args = ap.parse_args()
    k_max = args.multiple
    print("| indenter | model | strongest LIF input / rheobase | peaks (current) | valley (current) | valley (rate) "
          "| rates across x, Hz |")
    print("|---|---|---|---|---|---|---|")
    commands, seconds = [], []

    def go(name, block, file, flags, multiple, tag):
        rec, cmd, sec = run_case(Path(args.sample_dir), block, file, flags, multiple, Path(tmp) / f"{name}-{tag}")
        commands.append(cmd)
        seconds.append(sec)
        return rec

    with tempfile.TemporaryDirectory() as tmp:
        for name, block, file, width in CASES:
            print(_row(width, "sum", go(name, block, file, [], k_max, "sum")))
            for k in args.zones:
                flags = ["--branching", "zones", "--zones-per-afferent", str(k)]
                rec = go(name, block, file, flags, k_max, f"z{k}")
                zr = rec["spikes"]["zones"]
                what = "one zone per receptor" if zr["receptors_per_zone"] == [1, 1] else f"{k} zones"
                print(_row(width, f"zones, {what}, same membrane scale", rec))
                ratio = max(rec["spikes"]["drive"]["drive_over_rheobase"])  # strongest zone, in rheobases
                rec = go(name, block, file, flags, k_max * k_max / ratio, f"z{k}m")
                print(_row(width, f"zones, {what}, strongest zone at {k_max:g} rheobases", rec))
    print(f"\n{len(commands)} runs, {min(seconds):.2f}-{max(seconds):.2f} s each (wall, interpreter start included). "
          f"First and last commands:\n    {commands[0]}\n    {commands[-1]}")


if __name__ == "__main__":
    main()
