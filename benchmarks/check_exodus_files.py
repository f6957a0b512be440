"""Re-run the Exodus II reader's checks on Exodus files one points it at (MOOSE's test files, say).

    python benchmarks/check_exodus_files.py DIR_OR_FILE ... [--young E --poisson NU]

For each ``.e``/``.exo``/``.ex2``/``.g`` file (a folder: every such file in it), read with
afferent's reader:

- **steps**: every time step is read (``time_whole`` of the file, read with scipy/h5py here);
- **node order**: the mid-nodes of quadratic cells (HEX20, TETRA10, WEDGE15) sit at their edges'
  midpoints in VTK's order after the reader's permutation (straight-edged meshes; the largest
  offset as a fraction of the edge length, which is 0 for a correct order);
- **shear** (with ``--young``/``--poisson``): for each set of six stress components and each set of
  six strain components of one location (``stress_*`` with ``elastic_strain_*``, ``strain_*``,
  ``straint_*``...), Hooke's law with tensor and with engineering shear; the convention whose shear
  residual is the smaller, and both residuals (relative to the largest stress);
- **energy** (with ``--young``/``--poisson``): every energy-like array (``elastic_energy``, ``sed``,
  ...) against 1/2 sigma:S:sigma of the stress of its location (no strain convention involved).

The Exodus facts in docs/fe-export.md that name MOOSE were checked this way on MOOSE's own test
files (docs/fe-export.md names them, their repositories and commits); the files are not kept
in this repository. Exit status 1 when a check fails, 0 otherwise.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from afferent.io import read_raw
from afferent.io._exodus import _NetCDF

SUFFIXES = (".e", ".exo", ".ex2", ".g")
COMPONENTS = (("xx",), ("yy",), ("zz",), ("xy", "yx"), ("yz", "zy"), ("xz", "zx"))
ENERGY_NAMES = ("elastic_energy", "strain_energy_density", "sed", "energy", "ener")


def files_of(paths) -> list[Path]:
    out = []
    for p in map(Path, paths):
        out += sorted(q for q in p.iterdir() if q.suffix in SUFFIXES) if p.is_dir() else [p]
    return out


def tensor_sets(arrays: dict) -> dict[tuple[str, str], np.ndarray]:
    """(prefix, location) -> (n_times, n, 6) in xx yy zz xy yz xz order, for every complete set of six."""
    out = {}
    for key, arr in arrays.items():
        base = key.split("@")[0]
        if not base.endswith("_xx"):
            continue
        prefix, suffix = base[:-3], key[len(base):]
        parts = []
        for spellings in COMPONENTS:
            found = [f"{prefix}_{s}{suffix}" for s in spellings if f"{prefix}_{s}{suffix}" in arrays]
            if not found:
                break
            parts.append(arrays[found[0]].values)
        if len(parts) == 6:
            out[(prefix, arr.location)] = np.stack(parts, -1)
    return out


def hooke(e: np.ndarray, young: float, nu: float, shear: str) -> np.ndarray:
    """Stress (.., 6) of an isotropic material from strain (.., 6) with tensor or engineering shear."""
    lam, g = young * nu / ((1 + nu) * (1 - 2 * nu)), young / (2 * (1 + nu))
    factor = 2 * g if shear == "tensor" else g
    return np.concatenate([lam * e[..., :3].sum(-1, keepdims=True) + 2 * g * e[..., :3], factor * e[..., 3:]], -1)


def energy_of_stress(s: np.ndarray, young: float, nu: float) -> np.ndarray:
    """1/2 sigma:S:sigma (complementary energy = strain energy density of a linear isotropic solid)."""
    g = young / (2 * (1 + nu))
    normal = (s[..., :3] ** 2).sum(-1) - 2 * nu * (s[..., 0] * s[..., 1] + s[..., 1] * s[..., 2] + s[..., 0] * s[..., 2])
    return normal / (2 * young) + (s[..., 3:] ** 2).sum(-1) / (2 * g)


def check_steps(path: Path, raw) -> tuple[bool, str]:
    nc = _NetCDF(str(path))
    try:
        times = nc.get("time_whole").ravel() if "time_whole" in nc else np.zeros(0)
    finally:
        nc.close()
    got = 0 if raw.times is None else raw.times.size
    return got == times.size, f"steps       {got} read, {times.size} in time_whole"


def check_node_order(raw) -> list[tuple[bool, str]]:
    from afferent._shape_functions import QUADRATIC, node_offsets

    out = []
    for ctype, conn in zip(raw.cells.cell_types if raw.cells else (), raw.cells.nodes if raw.cells else ()):
        if ctype not in QUADRATIC:  # a linear cell has no mid-nodes (its connectivity is kept for its shape functions)
            continue
        off = float(node_offsets(ctype, conn, raw.points).max())
        out.append((off < 1e-6, f"node order  {ctype}: largest mid-node offset {off:.3g} of the edge length"))
    return out


def check_shear(raw, young: float, nu: float) -> list[tuple[bool, str]]:
    sets, out = tensor_sets(raw.arrays), []
    for (sp, sloc), s in sets.items():
        if "stress" not in sp:
            continue
        scale = np.abs(s).max() or 1.0
        for (ep, eloc), e in sets.items():
            if "stress" in ep or eloc != sloc:
                continue
            res = {c: np.abs(hooke(e, young, nu, c) - s) / scale for c in ("tensor", "engineering")}
            normal = float(res["tensor"][..., :3].max())
            best = min(res, key=lambda c: res[c][..., 3:].max())
            shear_scale = float(np.abs(s[..., 3:]).max() / scale)
            out.append((normal < 1e-6, f"shear       {sp}_* vs {ep}_* ({sloc}): {best} shear; normal residual "
                                       f"{normal:.2g}, shear residual tensor {res['tensor'][..., 3:].max():.2g} / "
                                       f"engineering {res['engineering'][..., 3:].max():.2g} (shear stress up to "
                                       f"{shear_scale:.2g} of the largest)"))
    return out


def check_energy(raw, young: float, nu: float) -> list[tuple[bool, str]]:
    sets, out = tensor_sets(raw.arrays), []
    for key, arr in raw.arrays.items():
        if key.split("@")[0].lower() not in ENERGY_NAMES:
            continue
        for (sp, sloc), s in sets.items():
            if "stress" in sp and sloc == arr.location:
                w = energy_of_stress(s, young, nu)
                rel = float(np.abs(w - arr.values).max() / (np.abs(arr.values).max() or 1.0))
                out.append((rel < 1e-6, f"energy      {key!r} vs 1/2 sigma:S:sigma of {sp}_* ({sloc}): largest "
                                        f"difference {rel:.2g} of the largest energy"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", help="Exodus files or folders of them")
    ap.add_argument("--young", type=float, help="Young's modulus of the model's material (file units)")
    ap.add_argument("--poisson", type=float, help="Poisson's ratio of the model's material")
    args = ap.parse_args(argv)
    failed = False
    for path in files_of(args.paths):
        raw = read_raw(str(path))
        checks = [check_steps(path, raw), *check_node_order(raw)]
        if args.young is not None and args.poisson is not None:
            checks += check_shear(raw, args.young, args.poisson) + check_energy(raw, args.young, args.poisson)
        print(f"{path.name}: {raw.notes[0]}")
        for ok, text in checks:
            print(f"  {'ok  ' if ok else 'FAIL'} {text}")
            failed |= not ok
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
