"""Benchmark: ``afferent run`` on a real 117,649-node CalculiX export (issue 23).

Make the export once (needs CalculiX ``ccx`` on the PATH and ``ccx2paraview``, which needs vtk;
about a minute on two cores, ~60 MB)::

    python benchmarks/bench_run.py --make [--data DIR] [--ccx2paraview PATH]

then time the run (each repeat a fresh process, as a user runs it)::

    python benchmarks/bench_run.py [--data DIR] [--repeats 5]

The model (mm / N / s: stresses and ENER in MPa): a 4.2 x 3.1 x 4.2 mm skin block (x across the
ridges, y up, z along them) of 48 x 48 x 48 C3D8 hexahedra (49^3 = 117,649 nodes), linear elastic
E = 0.1 MPa, nu = 0.45, bottom face y = 0 fixed, the nodes of a 1.32 x 1.32 mm patch at the centre
of the top face pushed down 0.5 mm (one linear ``*STATIC`` step; the iterative Cholesky solver).
ccx writes U, S, E and ENER (extrapolated to the nodes) to ``skin_block.frd``; ``ccx2paraview
skin_block.frd vtu`` converts it to ``skin_block.vtu`` as users open it in ParaView, and that VTU is
what ``afferent run`` reads. The data folder (default ``~/.cache/afferent-bench/run``, or
``$AFFERENT_BENCH_DIR/run``) is outside the repository; ``--make`` rewrites it.

The run timed: 171 receptors on the ridge/papilla grid at y = 2.6 mm (``--grid y=2.6``), the
study's start parameters, a ramp-and-hold waveform of the indentation, spikes (exact engine),
every figure and the default outputs (currents.nc, CSV tables, receptors.vtu, run.json)::

    afferent run skin_block.vtu --grid y=2.6 --length-unit mm --sed-unit MPa --params start \\
        --waveform ramp:0.5,5,2 --d-ref-mm 0.5 --spikes --input rate-sensitive --gain-s 0.2 \\
        --no-cache -o OUT --overwrite

It prints, per repeat, the whole process's wall and CPU time (user + system, from the operating
system's accounting of the finished child) and the stage timings the run records in run.json
(``timings_s``), then the medians; and the same command with ``--no-plots`` for the figures'
share. Each row says where the run drew its figures (run.json ``figures``: a second process,
afferent/_figure_process.py, only with an idle core and an export of 16 MB or more; set
``AFFERENT_FIGURE_PROCESS=1`` or ``0`` in the environment to force either). Target (issue 23):
<= 3 s for the whole run with plots, <= 1 s for the plots.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
SIZE_MM = (4.2, 3.1, 4.2)
CELLS = 48                 # per axis
INDENTER_MM = 1.32         # square patch side
DEPTH_MM = 0.5
E_MPA, NU = 0.1, 0.45
RUN_ARGS = ["--grid", "y=2.6", "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start",
            "--waveform", "ramp:0.5,5,2", "--d-ref-mm", "0.5", "--spikes", "--input", "rate-sensitive",
            "--gain-s", "0.2", "--no-cache"]


def default_data() -> Path:
    base = os.environ.get("AFFERENT_BENCH_DIR") or os.path.join(os.path.expanduser("~"), ".cache", "afferent-bench")
    return Path(base) / "run"


def _lines(ids, per_line: int = 16) -> str:
    rows = [", ".join(map(str, ids[i:i + per_line])) for i in range(0, len(ids), per_line)]
    return ",\n".join(rows)


def write_deck(path: Path, n: int = CELLS) -> int:
    """The CalculiX input deck of the skin block; returns the node count."""
    axes = [np.linspace(0.0, s, n + 1) for s in SIZE_MM]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    pts = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
    idx = np.arange(1, len(pts) + 1).reshape(n + 1, n + 1, n + 1)
    lo, hi = slice(None, -1), slice(1, None)
    # C3D8: face 1-4 at the lower y, counter-clockwise seen from below (x then z), 5-8 above it
    corners = [idx[lo, lo, lo], idx[lo, lo, hi], idx[hi, lo, hi], idx[hi, lo, lo],
               idx[lo, hi, lo], idx[lo, hi, hi], idx[hi, hi, hi], idx[hi, hi, lo]]
    els = np.stack([c.ravel() for c in corners], axis=1)
    ids = idx.ravel()
    bottom = ids[np.abs(pts[:, 1]) < 1e-9]
    cx, cz = SIZE_MM[0] / 2, SIZE_MM[2] / 2
    half = INDENTER_MM / 2 + 1e-9
    top = ids[(np.abs(pts[:, 1] - SIZE_MM[1]) < 1e-9) & (np.abs(pts[:, 0] - cx) <= half) & (np.abs(pts[:, 2] - cz) <= half)]
    with open(path, "w") as f:
        f.write(f"** afferent bench_run: skin block {n}^3 C3D8, mm/N/s\n*NODE, NSET=NALL\n")
        f.writelines(f"{i}, {x:.10g}, {y:.10g}, {z:.10g}\n" for i, (x, y, z) in zip(ids, pts))
        f.write("*ELEMENT, TYPE=C3D8, ELSET=EALL\n")
        f.writelines(f"{j}, " + ", ".join(map(str, e)) + "\n" for j, e in enumerate(els.tolist(), start=1))
        f.write("*NSET, NSET=BOTTOM\n" + _lines(bottom.tolist()) + "\n")
        f.write("*NSET, NSET=PATCH\n" + _lines(top.tolist()) + "\n")
        f.write(f"*MATERIAL, NAME=DERMIS\n*ELASTIC\n{E_MPA}, {NU}\n*SOLID SECTION, ELSET=EALL, MATERIAL=DERMIS\n")
        f.write("*BOUNDARY\nBOTTOM, 1, 3\nPATCH, 1, 1\nPATCH, 3, 3\n")
        f.write(f"*STEP\n*STATIC, SOLVER=ITERATIVE CHOLESKY\n*BOUNDARY\nPATCH, 2, 2, {-DEPTH_MM:.6g}\n")
        f.write("*NODE FILE\nU\n*EL FILE\nS, E, ENER\n*END STEP\n")
    return len(pts)


def make(data: Path, ccx2paraview: str) -> Path:
    """Solve the deck with ccx and convert the .frd to VTU with ccx2paraview; returns the VTU."""
    data.mkdir(parents=True, exist_ok=True)
    n_nodes = write_deck(data / "skin_block.inp")
    env = dict(os.environ, OMP_NUM_THREADS="2")
    t0 = time.perf_counter()
    subprocess.run(["ccx", "-i", "skin_block"], cwd=data, check=True, stdout=subprocess.DEVNULL, env=env)
    t1 = time.perf_counter()
    subprocess.run([ccx2paraview, "skin_block.frd", "vtu"], cwd=data, check=True, stdout=subprocess.DEVNULL)
    t2 = time.perf_counter()
    vtu = data / "skin_block.vtu"
    if not vtu.is_file():  # ccx2paraview names a single-increment result after the job
        found = sorted(data.glob("skin_block*.vtu"))
        found[0].rename(vtu)
    print(f"# {n_nodes} nodes; ccx {t1 - t0:.1f} s, ccx2paraview {t2 - t1:.1f} s; {vtu} "
          f"{vtu.stat().st_size / 1e6:.1f} MB")
    print(f"# command: cd {data} && ccx -i skin_block && {ccx2paraview} skin_block.frd vtu")
    return vtu


def _timed(cmd: list, env: dict) -> tuple[float, float]:
    """Wall and CPU (user + system, the process and the children it waited for) seconds of ``cmd``."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _digest(folder: Path) -> str:
    """sha256 (first 12 hex) of every output but the PNGs, run.json and the NetCDF (whose HDF5 holds times)."""
    import hashlib

    h = hashlib.sha256()
    for f in sorted(folder.iterdir()):
        if f.suffix in (".csv", ".vtu"):
            h.update(f.name.encode() + f.read_bytes())
    return h.hexdigest()[:12]


def bench(vtu: Path, repeats: int, plots: bool) -> list[dict]:
    """Run the command ``repeats`` times (after one untimed run); one row per run."""
    work = Path(tempfile.mkdtemp(prefix="bench_run_"))
    out = work / "out"
    exe = shutil.which("afferent", path=str(BIN)) or "afferent"
    cmd = [exe, "run", str(vtu), *RUN_ARGS, *([] if plots else ["--no-plots"]), "-o", str(out), "--overwrite"]
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    rows = []
    try:
        subprocess.run(cmd, env=env, check=True, capture_output=True)  # numba's cache, the OS's file cache
        for _ in range(repeats):
            wall, cpu = _timed(cmd, env)
            record = json.loads((out / "run.json").read_text())
            stages = {s["stage"]: s["seconds"] for s in record["stages"]}
            rows.append({"wall": wall, "cpu": cpu, "stages": stages, "digest": _digest(out),
                         "figures": record.get("figures")})
    finally:
        shutil.rmtree(work)
    print(f"# command: PYTHONPATH={ROOT} MPLBACKEND=Agg " + " ".join(cmd).replace(str(out), "OUT"))
    return rows


def report(rows: list[dict], label: str) -> None:
    names = list(rows[0]["stages"])
    print(f"{label:<9} {'wall s':>7} {'cpu s':>7}  " + " ".join(f"{n[:9]:>9}" for n in names) + "  outputs")
    for r in rows:
        fig = r.get("figures") or {}
        where = "" if not fig else f"  figures: {fig['process']} process, " + ", ".join(
            f"{k} {fig[k]:.2f} s" for k in ("start_s", "seconds", "waited_s") if k in fig)
        print(f"{'':<9} {r['wall']:7.2f} {r['cpu']:7.2f}  " + " ".join(f"{r['stages'][n]:9.3f}" for n in names)
              + f"  {r['digest']}{where}")
    med = {n: statistics.median(r["stages"][n] for r in rows) for n in names}
    print(f"{'median':<9} {statistics.median(r['wall'] for r in rows):7.2f} {statistics.median(r['cpu'] for r in rows):7.2f}  "
          + " ".join(f"{med[n]:9.3f}" for n in names))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--make", action="store_true", help="solve the model with ccx and convert it (ccx2paraview)")
    ap.add_argument("--data", type=Path, default=default_data(), help="folder of the export (default %(default)s)")
    ap.add_argument("--ccx2paraview", default=shutil.which("ccx2paraview") or "ccx2paraview",
                    help="the ccx2paraview command (default: on the PATH)")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    vtu = args.data / "skin_block.vtu"
    if args.make:
        make(args.data, args.ccx2paraview)
        return
    if not vtu.is_file():
        if not (shutil.which("ccx") and shutil.which(args.ccx2paraview)):
            print(f"# bench_run skipped: {vtu} not found, and making it needs ccx and ccx2paraview on the PATH "
                  f"(then: python benchmarks/bench_run.py --make --data {args.data})")
            return
        make(args.data, args.ccx2paraview)
    print(f"# {os.uname().nodename}: {os.cpu_count()} CPUs, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with_plots = bench(vtu, args.repeats, plots=True)
    without = bench(vtu, args.repeats, plots=False)
    report(with_plots, "plots")
    report(without, "no plots")
    share = statistics.median(r["wall"] for r in with_plots) - statistics.median(r["wall"] for r in without)
    share_cpu = statistics.median(r["cpu"] for r in with_plots) - statistics.median(r["cpu"] for r in without)
    print(f"# plots: {share:.2f} s wall, {share_cpu:.2f} s CPU (median with plots - median without); "
          f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
