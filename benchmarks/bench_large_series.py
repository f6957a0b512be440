"""Benchmark: a 1,000,000-point, 50-step series through ``afferent sample`` and a spikes scene.

Run:  python benchmarks/bench_large_series.py [--points 1000000] [--steps 10 50] [--data DIR]

A structured hexahedral block (4 x 3.1 x 4 mm, ~``--points`` nodes) carries a smooth analytic SED
field scaled by the load step, SED_k = (k / (N - 1)) x S(x, y, z) (quadratic in a depth that grows
linearly, as a loading series of an indentation), written twice:

* a ParaView ``.pvd`` of binary, zlib-compressed VTUs, one per step (what ParaView, FEBio, SfePy,
  ccx2paraview write);
* one XDMF/HDF5 time series (meshio's ``TimeSeriesWriter``: the mesh once, one dataset per step).

For each format and each step count (a PVD / XDMF listing the first N steps), every command runs
in its own process under ``/usr/bin/time`` (wall time, peak resident memory):

* ``bare``: the same arrays read with meshio alone (``meshio.read`` of every VTU; the XDMF's mesh
  once and each step's data with meshio's ``TimeSeriesReader``, which uses h5py) - the floor;
* ``afferent sample`` of the series at 150 receptors;
* ``afferent run`` of a scene with spikes (ramp-and-hold through the series' depths, 3
  longitudinal afferents, exact spiking).

Targets (issue 14): ``afferent sample`` within 1.2x the bare read; peak memory about one step's
mesh plus the per-receptor results, the same for 10 and 50 steps.

``--vs-h5py`` (issue 23: XDMF streaming within 1.1x of h5py): in one process, CPU time, in turn 11
times each after a warm-up, the XDMF series read step by step by afferent's reader
(``afferent.io.iter_sed``'s raw steps: the mesh once, then each step's attributes, with every check)
against h5py alone reading the same datasets (the mesh's two datasets, then each step's) the usual
way (``f[name][()]``) and by its low-level API (``h5d.open`` and one ``H5Dread`` into ``np.empty``:
the floor), and ``afferent.io.iter_sed`` (SI units, the checks of each step) beside them; the ratios
of the medians, per step after the first against both h5py reads. Default for this mode:
``--points 300000 --steps 20``. The data is written once into
``--data`` (default: a temporary folder; ~1.4 GB at 1e6 points and 50 steps) and reused when the
folder already holds it.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # this checkout's afferent (the commands timed are the installed ones)
BIN = Path(sys.executable).parent


def analytic(p_mm):
    x, y, z = p_mm.T
    return 1e-4 * (1 + 0.5 * np.sin(2 * np.pi * x / 0.88) * np.cos(2 * np.pi * z / 0.88)) * np.exp(y / 3.1)  # MPa


def make_data(folder: Path, points: int, steps: int) -> tuple[int, int]:
    """Write the PVD's VTUs and the XDMF/HDF5 series (steps 0..steps-1) unless already there."""
    import meshio

    from afferent.report import hex_block

    n = max(2, round(points ** (1 / 3))) - 1
    pts, hexes = hex_block(n, n, n, size=(4.0, 3.1, 4.0))
    stamp = folder / f"done_{len(pts)}_{steps}"
    if stamp.exists():
        return len(pts), len(hexes)
    folder.mkdir(parents=True, exist_ok=True)
    base = analytic(pts)
    t = time.perf_counter()
    for k in range(steps):
        meshio.write(folder / f"step_{k:03d}.vtu",
                     meshio.Mesh(pts, [("hexahedron", hexes)], point_data={"SED": base * k / (steps - 1)}),
                     binary=True, compression="zlib")
    cwd = os.getcwd()
    os.chdir(folder)  # meshio 5.3's TimeSeriesWriter writes its .h5 into the working directory
    try:
        with meshio.xdmf.TimeSeriesWriter("series.xdmf") as w:
            w.write_points_cells(pts, [("hexahedron", hexes)])
            for k in range(steps):
                w.write_data(float(k), point_data={"SED": base * k / (steps - 1)})
    finally:
        os.chdir(cwd)
    rng = np.random.default_rng(0)
    rec = np.column_stack([rng.uniform(0.2, 3.8, 150), np.full(150, 2.9), rng.uniform(0.2, 3.8, 150)])
    rec[:, 0] = np.repeat(np.linspace(0.5, 3.5, 3), 50)  # three longitudinal sections
    np.savetxt(folder / "receptors.csv", rec, delimiter=",", header="x,y,z", comments="")
    stamp.touch()
    print(f"# wrote {steps} steps in {time.perf_counter() - t:.0f} s into {folder}")
    return len(pts), len(hexes)


def pvd(folder: Path, n: int) -> Path:
    p = folder / f"series_{n}.pvd"
    rows = "\n".join(f'    <DataSet timestep="{k}" file="step_{k:03d}.vtu"/>' for k in range(n))
    p.write_text(f'<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n{rows}\n'
                 "  </Collection>\n</VTKFile>\n")
    return p


def xdmf(folder: Path, n: int) -> Path:
    """The XDMF listing only the first n steps (same .h5)."""
    import re

    text = (folder / "series.xdmf").read_text()
    opening = re.search(r'<Grid Name="TimeSeries_meshio"[^>]*>', text)
    grids = re.findall(r"<Grid>.*?</Grid>", text, flags=re.S)
    mesh = re.search(r'<Grid Name="mesh".*?</Grid>', text, flags=re.S).group(0)
    if len(grids) < n:
        raise SystemExit(f"series.xdmf has {len(grids)} grids, fewer than {n}")
    p = folder / f"series_{n}.xdmf"
    p.write_text(text[:opening.end()] + "".join(grids[:n]) + "</Grid>" + mesh + "</Domain></Xdmf>\n")
    return p


BARE_VTU = "import meshio,sys\nfor p in sys.argv[1:]: meshio.read(p)"
BARE_XDMF = textwrap.dedent("""
    import meshio, sys
    with meshio.xdmf.TimeSeriesReader(sys.argv[1]) as r:
        points, cells = r.read_points_cells()
        for k in range(r.num_steps):
            r.read_data(k)
""")


def _h5py_alone(path: Path, paths: list[str], low_level: bool = False) -> int:
    """Read every dataset of ``paths`` (``file.h5:/name``, mesh first) with h5py alone; returns the values read.

    ``low_level``: by h5py's low-level API (``h5d.open``, then one ``H5Dread`` of the whole dataset into
    ``np.empty``: no ``Dataset`` object, no zero-filled buffer), the floor of any reader; else by h5py's
    high-level ``f[name][()]``, the usual way. As a stream's consumer does, the mesh is kept and each
    step's array is held until the next one is read (an array freed at once lets the allocator hand the
    same pages back for the next step, which a consumer that uses the step does not see).
    """
    import h5py
    from h5py import h5d, h5s

    n, files, held = 0, {}, []
    for k, item in enumerate(paths):
        name, dataset = item.split(":", 1)
        h5 = files.get(name) or files.setdefault(name, h5py.File(path.parent / name, "r"))
        if low_level:
            dsid = h5d.open(h5.id, dataset.encode())
            values = np.empty(dsid.shape, dsid.dtype)
            dsid.read(h5s.ALL, h5s.ALL, values)
        else:
            values = np.asarray(h5[dataset][()])
        held = held[:2] + [values]  # the mesh's two arrays, and the last step
        n += values.size
    for f in files.values():
        f.close()
    return n


#: rounds of --vs-h5py: a step differs from h5py by ~0.1-0.3 ms, the whole series by 10-20 ms of noise under load
ROUNDS = 11


def vs_h5py(folder: Path, steps: int) -> None:
    """afferent's streamed XDMF read against h5py alone on the same datasets (CPU time, interleaved).

    Each reader runs on the series' first step alone and on all ``steps``: the difference is the
    streaming of steps 2..N (the mesh and the first step are read in both), printed beside the
    whole read.
    """
    import statistics
    import warnings
    import xml.etree.ElementTree as ET

    from afferent.exceptions import AfferentWarning
    from afferent.io import _raw_steps, iter_sed

    def datasets(export):
        root = ET.parse(export).getroot()
        mesh = [i.text.strip() for g in root.iter("Grid") if g.get("Name") == "mesh" for i in g.iter("DataItem")]
        data = [i.text.strip() for g in root.iter("Grid") if g.get("Name") != "mesh" and g.find("Grid") is None
                for a in g.iter("Attribute") for i in a.iter("DataItem")]  # the leaf grids: one per step
        return mesh + data

    def raw(export):
        _, it = _raw_steps(str(export), None, False)
        return sum(1 for _ in it)

    def sed(export):
        with warnings.catch_warnings():  # step 0 is all zero (the undeformed state): its warning, once a round
            warnings.simplefilter("ignore", AfferentWarning)
            return sum(1 for _ in iter_sed(str(export), length_unit="mm", sed_unit="MPa"))

    exports = {1: xdmf(folder, 1), steps: xdmf(folder, steps)}
    items = {n: datasets(e) for n, e in exports.items()}
    runs = {(what, n): fn for n, e in exports.items() for what, fn in (
        ("h5py alone", lambda e=e, n=n: _h5py_alone(e, items[n])),
        ("h5py low-level", lambda e=e, n=n: _h5py_alone(e, items[n], low_level=True)),
        ("afferent raw steps", lambda e=e: raw(e)), ("afferent iter_sed", lambda e=e: sed(e)))}
    for fn in runs.values():  # warm-up: imports, the page cache
        fn()
    times = {k: [] for k in runs}
    for _ in range(ROUNDS):
        for k, fn in runs.items():
            t = time.process_time()
            fn()
            times[k].append(time.process_time() - t)
    print(f"# {exports[steps].name}: {steps} steps; h5py reads the {len(items[steps]) - steps} mesh datasets and the "
          f"{steps} step datasets; CPU s, medians of {ROUNDS} rounds; per step = (whole - first step alone) / {steps - 1}")
    print(f"{'reader':20} {'whole s':>8} {'vs h5py':>8} {'steps 2..N s':>13} {'per step ms':>12} {'vs h5py':>8} "
          f"{'vs low-level':>13}")
    med = {k: statistics.median(v) for k, v in times.items()}
    rest = {what: med[(what, steps)] - med[(what, 1)] for what, _ in med}
    for what in ("h5py alone", "h5py low-level", "afferent raw steps", "afferent iter_sed"):
        whole = med[(what, steps)]
        print(f"{what:20} {whole:8.3f} {whole / med[('h5py alone', steps)]:8.2f} {rest[what]:13.3f} "
              f"{1e3 * rest[what] / (steps - 1):12.2f} {rest[what] / rest['h5py alone']:8.2f} "
              f"{rest[what] / rest['h5py low-level']:13.2f}")


def timed(cmd: list[str], env=None) -> tuple[float, float]:
    """(wall s, peak RSS MB) of one command, from /usr/bin/time."""
    out = subprocess.run(["/usr/bin/time", "-f", "%e %M", *cmd], capture_output=True, text=True, env=env)
    if out.returncode != 0:
        raise SystemExit(f"failed: {' '.join(cmd)}\n{out.stderr[-2000:]}")
    wall, rss = out.stderr.strip().splitlines()[-1].split()
    return float(wall), float(rss) / 1024


SCENE = """
[export]
file = "{export}"
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = "{receptors}"
length_unit = "mm"
[transduction]
params = "start"
[synthesis]
kind = "longitudinal"
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5
reference_step = -1
series_depths_mm = {depths}
depth_mm = 0.5
speed_mm_per_s = 5.0
hold_s = 0.5
post_s = 0.1
dt_ms = 1.0
[spikes]
lif_preset = "ra"
input = "rate-sensitive"
gain_s = 0.2
tau_ms = 5.0
[outputs]
want = ["spikes"]
"""


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=None, help="default 1,000,000 (300,000 with --vs-h5py)")
    ap.add_argument("--steps", type=int, nargs="+", default=None, help="default 10 50 (20 with --vs-h5py)")
    ap.add_argument("--vs-h5py", action="store_true", help="time the XDMF reader in-process against h5py alone")
    ap.add_argument("--data", type=Path, default=None, help="folder for the generated series (kept)")
    ap.add_argument("--no-scene", action="store_true", help="skip the spikes scene")
    args = ap.parse_args(argv)
    if args.vs_h5py:
        args.points, args.steps = args.points or 300_000, args.steps or [20]
        folder = args.data or Path(tempfile.gettempdir()) / f"afferent_large_vs_h5py_{args.points}_{max(args.steps)}"
        print(f"# command: python benchmarks/bench_large_series.py --vs-h5py --points {args.points} --steps "
              f"{max(args.steps)}{'' if args.data is None else f' --data {args.data}'}; load average {os.getloadavg()}")
        make_data(folder, args.points, max(args.steps))
        return vs_h5py(folder, max(args.steps))
    args.points, args.steps = args.points or 1_000_000, args.steps or [10, 50]
    folder = args.data or Path(tempfile.mkdtemp(prefix="afferent_large_"))
    n_pts, n_cells = make_data(folder, args.points, max(args.steps))
    env = dict(os.environ, MPLBACKEND="Agg")
    print(f"# {n_pts:,} points, {n_cells:,} hexahedra; VTU step {os.path.getsize(folder / 'step_000.vtu') / 1e6:.1f} MB "
          f"(zlib), HDF5 {os.path.getsize(folder / 'series.h5') / 1e6:.0f} MB for {max(args.steps)} steps")
    print(f"# command: python benchmarks/bench_large_series.py --points {args.points} --steps "
          f"{' '.join(map(str, args.steps))}{'' if args.data is None else f' --data {args.data}'}")
    print(f"# machine: {os.cpu_count()} cores; python {sys.version.split()[0]}")
    print(f"{'format':6} {'steps':>5} {'what':18} {'wall s':>8} {'s/step':>8} {'peak MB':>8} {'vs bare':>8}")
    work = Path(tempfile.mkdtemp(prefix="afferent_large_out_"))
    receptors = folder / "receptors.csv"
    for fmt in ("pvd", "xdmf"):
        for n in args.steps:
            export = pvd(folder, n) if fmt == "pvd" else xdmf(folder, n)
            if fmt == "pvd":
                bare = timed([sys.executable, "-c", BARE_VTU, *[str(folder / f"step_{k:03d}.vtu") for k in range(n)]])
            else:
                bare = timed([sys.executable, "-c", BARE_XDMF, str(export)])
            out = work / f"{fmt}_{n}.csv"
            samp = timed([str(BIN / "afferent"), "sample", str(export), "--receptors", str(receptors), "--length-unit",
                          "mm", "--sed-unit", "MPa", "-o", str(out), "--quiet"], env)
            rows = [("bare meshio/h5py", bare), ("afferent sample", samp)]
            if not args.no_scene:
                scene = work / f"{fmt}_{n}.toml"
                depths = [round(0.5 * k / (n - 1), 6) for k in range(n)]
                scene.write_text(SCENE.format(export=export, receptors=receptors, depths=depths))
                rows.append(("scene with spikes", timed([str(BIN / "afferent"), "run", str(scene), "-o",
                                                         str(work / f"{fmt}_{n}_scene")], env)))
            for what, (wall, rss) in rows:
                print(f"{fmt:6} {n:5d} {what:18} {wall:8.2f} {wall / n:8.3f} {rss:8.0f} {wall / bare[0]:8.2f}")
    shutil.rmtree(work, ignore_errors=True)
    if args.data is None:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
