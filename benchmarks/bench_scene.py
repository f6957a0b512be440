"""Benchmark: a scene with a small region of interest against the full scene, on a large export.

Run:  python benchmarks/bench_scene.py [--points 270000] [--size-mm 16] [--roi-mm 2] [--engine auto]

A structured hexahedral block of ``--size-mm`` x 3.1 x ``--size-mm`` mm with about
``--points`` nodes and a smooth SED bump is written to a temporary VTU (mm / MPa), with
receptors on the study's papilla grid (0.44 x 0.22 mm) over its whole top at y = 2.35 mm
(a fingertip-sized patch: ~2,600 receptors for 16 mm). Two scenes ask for the same outputs
(afferent profiles and spikes under the study's ramp-and-hold, rate-sensitive input, no
figures): the *full* scene models every receptor; the *ROI* scene only a ``--roi-mm``
square region at the bump. Each runs cold (empty sampled-SED cache) and warm (cache hit,
e.g. a re-run with other transduction or spiking parameters). A warm-up run first loads the
modules and compiles numba, so no timed run pays for it.

Printed: wall time of each run, the stages that ran with their times, receptors and
afferents modelled, and the ROI/full ratio.

``--shell`` measures instead what a user waits for at the prompt (issue 11, target <= 1 s):
``afferent run SCENE.toml -o OUT`` timed by ``/usr/bin/time -f %e``, interpreter start and
imports included, for the bundled ``sample_sed/scenes/spikes_ramp.toml`` asking only for
spikes (``want = ["spikes"]``, its region: 3 afferents). Runs ``--repeats`` times each with a
warm sampled-SED cache and with an empty one (reading and sampling the series), and prints
the median wall and user+sys CPU time, the load average (the machine may be shared: wall
times under load are upper bounds) and the exact command. ``--tree DIR`` runs the package of
another checkout (e.g. the commit before a change) for a before/after comparison. Modules run
from compiled bytecode, as from an installed package (pip writes the ``.pyc`` files at install;
an editable install on first import): ``PYTHONDONTWRITEBYTECODE`` is dropped and the ``.pyc``
files go to a temporary ``PYTHONPYCACHEPREFIX``, written by the untimed first run (without
them every run compiles the package's ~25k lines: +0.2-0.3 s CPU).

Run:  python benchmarks/bench_scene.py --shell [--repeats 5] [--tree DIR]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import meshio
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # this checkout's afferent

from afferent.report import hex_block  # noqa: E402
from afferent.scene import load_scene, run_scene  # noqa: E402


def synthetic_export(folder: str, n_points: int, size: float) -> str:
    h = 3.1
    n = (n_points / (size * size * h)) ** (1 / 3)  # nodes per mm
    nx = nz = max(2, round(n * size)) - 1
    ny = max(2, round(n * h)) - 1
    points, hexes = hex_block(nx, ny, nz, size=(size, h, size))
    x, y, z = points.T
    c = size / 2
    sed = 3e-2 * np.exp(-((x - c) ** 2 + (z - c) ** 2) / 0.6) * y / h  # MPa; peak 3e4 Pa, as the bundled sample
    path = os.path.join(folder, "block.vtu")
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}), binary=True,
                 compression="zlib")
    return path


def receptor_grid(folder: str, size: float, y: float = 2.35) -> str:
    xs = np.arange(0.22, size - 0.2, 0.44)
    zs = np.arange(0.11, size - 0.1, 0.22)
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    path = os.path.join(folder, "receptors.csv")
    with open(path, "w") as f:
        f.write("x,y,z\n")
        for a, b in zip(X.ravel(), Z.ravel()):
            f.write(f"{a:.6f},{y},{b:.6f}\n")
    return path


def scene_text(export: str, receptors: str, *, region: tuple | None, engine: str) -> str:
    lo, hi = region or (None, None)
    reg = "" if region is None else f"[region]\nx_range_mm = [{lo}, {hi}]\nz_range_mm = [{lo}, {hi}]\n"
    return f"""
[export]
file = {export!r}
length_unit = "mm"
sed_unit = "MPa"

[receptors]
file = {receptors!r}

{reg}
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5

[spikes]
engine = {engine!r}
input = "rate-sensitive"
gain_s = 0.2

[outputs]
want = ["profiles", "spikes"]
"""


ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def spikes_only_scene(folder: str, engine: str = "auto") -> str:
    """The bundled spikes_ramp scene asking only for spikes (with ``engine``), with absolute paths, in ``folder``."""
    src = os.path.join(ROOT, "sample_sed", "scenes", "spikes_ramp.toml")
    block4 = os.path.abspath(os.path.join(ROOT, "sample_sed", "block4"))
    lines = []
    for line in open(src).read().splitlines():
        if line.startswith("want ="):
            line = 'want = ["spikes"]'
        if line.startswith("engine ="):
            line = f"engine = {engine!r}"
        lines.append(line.replace('"../block4', f'"{block4}'))
    path = os.path.join(folder, "spikes_only.toml")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def shell(repeats: int, tree: str, engine: str) -> None:
    import statistics
    import subprocess

    work = tempfile.mkdtemp(prefix="bench_scene_shell.")
    scene = spikes_only_scene(work, engine)
    base = [sys.executable, "-m", "afferent", "run", scene, "-o", os.path.join(work, "out"), "--overwrite", "-q"]
    warm = os.path.join(work, "cache")
    env = dict(os.environ, AFFERENT_CACHE_DIR=warm, MPLBACKEND="Agg", PYTHONPYCACHEPREFIX=os.path.join(work, "pyc"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    subprocess.run(base, env=env, check=True, cwd=tree)  # fills the caches: sampled SED, numba's, bytecode; not timed
    print(f"# package: {os.path.abspath(tree)}/afferent (python -m afferent, run from that folder); [spikes] engine = {engine!r}; "
          f"bytecode in {env['PYTHONPYCACHEPREFIX']}")
    for label in ("warm cache", "cold cache"):
        cmd = ["/usr/bin/time", "-f", "%e %U %S", *base]
        walls, cpus = [], []
        for k in range(repeats):
            cache = warm if label == "warm cache" else os.path.join(work, f"cold{k}")  # empty: read + sample
            done = subprocess.run(cmd, env=dict(env, AFFERENT_CACHE_DIR=cache), check=True, cwd=tree,
                                  capture_output=True, text=True)
            e, u, s = map(float, done.stderr.strip().splitlines()[-1].split())
            walls.append(e)
            cpus.append(u + s)
        print(f"# command: cd {tree} && AFFERENT_CACHE_DIR={cache} PYTHONPYCACHEPREFIX={env['PYTHONPYCACHEPREFIX']} "
              f"{' '.join(cmd)}")
        print(f"{label:<11} wall {statistics.median(walls):.2f} s median of {repeats} "
              f"(min {min(walls):.2f}, max {max(walls):.2f}); user+sys {statistics.median(cpus):.2f} s; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    for code in ("pass", "import numpy", "import pandas", "import scipy.sparse, scipy.special"):  # the references
        walls, cpus = [], []
        for _ in range(repeats):
            done = subprocess.run(["/usr/bin/time", "-f", "%e %U %S", sys.executable, "-c", code], env=env,
                                  check=True, capture_output=True, text=True)
            e, u, s = map(float, done.stderr.strip().splitlines()[-1].split())
            walls.append(e)
            cpus.append(u + s)
        print(f"{'python -c ' + repr(code):<45} wall {statistics.median(walls):.2f} s, user+sys "
              f"{statistics.median(cpus):.2f} s (medians of {repeats})")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--shell", action="store_true", help="time `afferent run` of a spikes-only scene from the shell")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--tree", default=ROOT, help="with --shell: the folder whose afferent/ package runs (to compare)")
    ap.add_argument("--points", type=int, default=270_000)
    ap.add_argument("--size-mm", type=float, default=16.0)
    ap.add_argument("--roi-mm", type=float, default=2.0)
    ap.add_argument("--engine", default="auto")
    args = ap.parse_args(argv)
    if args.shell:
        return shell(args.repeats, args.tree, args.engine)
    print(f"# command: python benchmarks/bench_scene.py {' '.join(sys.argv[1:]) if argv is None else ' '.join(argv)}")
    work = tempfile.mkdtemp(prefix="bench_scene.")
    t = time.perf_counter()
    export = synthetic_export(work, args.points, args.size_mm)
    receptors = receptor_grid(work, args.size_mm)
    mesh = meshio.read(export)
    print(f"# export: {mesh.points.shape[0]:,} nodes, {len(mesh.cells[0].data):,} hexahedra, "
          f"{os.path.getsize(export) / 1e6:.1f} MB; written in {time.perf_counter() - t:.1f} s")
    c = args.size_mm / 2
    roi = (c - args.roi_mm / 2, c + args.roi_mm / 2)
    scenes = {}
    for name, region in (("full", None), ("roi", roi)):
        path = os.path.join(work, f"{name}.toml")
        with open(path, "w") as f:
            f.write(scene_text(export, receptors, region=region, engine=args.engine))
        scenes[name] = load_scene(path)
    cache = os.path.join(work, "cache")
    run_scene(scenes["roi"].with_output(os.path.join(work, "warmup")), use_cache=False)  # imports, numba JIT
    print(f"{'run':<10} {'cache':>5} {'receptors':>9} {'afferents':>9} {'spikes':>6} {'wall_s':>7}  stages (s)")
    walls = {}
    for name, label in (("full", "full"), ("roi", "roi"), ("roi", "roi warm"), ("full", "full warm")):
        t = time.perf_counter()
        res = run_scene(scenes[name].with_output(os.path.join(work, label.replace(" ", "_"))), cache_dir=cache)
        wall = time.perf_counter() - t
        walls[label] = wall
        stages = " ".join(f"{k}={v:.2f}" for k, v in res.stages.items())
        print(f"{label:<10} {'hit' if res.cache_hit else 'miss':>5} {res.sed.layout.n_receptors:>9} "
              f"{res.afferent.n_afferents:>9} {res.record['spikes']['n_spikes']:>6} {wall:>7.2f}  {stages}")
    print(f"# ROI / full: cold {walls['roi'] / walls['full']:.3f}, warm {walls['roi warm'] / walls['full warm']:.3f}, "
          f"ROI warm / full cold {walls['roi warm'] / walls['full']:.3f}")
    print(f"# files in {work}")


if __name__ == "__main__":
    main()
