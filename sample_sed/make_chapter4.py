#!/usr/bin/env python
"""Regenerate the chapter-4 samples in ``sample_sed/chapter4/``: two ridged blocks, four indenters.

The study's chapter 4 (docs/method.md, "Chapter 4: ridged blocks, four indenters, hot-spot maps")
compares a **3-D ridged** block (intermediate epidermal ridges with trapezoid apexes running along
z, and discrete dermal papillae between them along z) with a **2-D ridged** block (the same
intermediate ridges; the papillae even along z, i.e. continuous dermal ridges), each pressed
0.5 mm by four rigid frictionless indenters: a 2 x 2 mm solid bar, a gap indenter (two 0.5 x 2 mm
bars with a 1.0 mm gap between their inside edges), the gap indenter rotated 90 degrees, and a
2 mm diameter solid circle.

This script only builds the chapter-4 geometry and footprints; the layers, moduli, element,
bottom-edges restraint, solver, post-processing and VTU writer are those of ``make_samples.py``
(imported, not copied).  Elastic static solves: the hold's normalised maps (the viscoelastic
relaxation is not modelled here).

Units: mm, MPa, N (SED in MPa = 1e6 Pa).  Axes as in make_samples.py: x across the ridges,
y up (bottom at y = 0), z along the ridges.

Usage::

    python sample_sed/make_chapter4.py            # both models, four indenters -> sample_sed/chapter4/
    python sample_sed/make_chapter4.py --quick    # coarse smoke run into a temp dir
    python sample_sed/make_chapter4.py --model 3d --out DIR   # one model only

The geometry functions (``ch4_spec``, ``build_ch4_mesh``, ``INDENTERS``) take the model "3d" or
"2d" and are importable (``sys.path`` the ``sample_sed`` folder).
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_samples as ms  # noqa: E402  (one solver, one mesh builder, one writer)

# --------------------------------------------------------------------------------------
# Chapter-4 geometry (mm).  Every number the study does not give is a stated choice
# (sample_sed/README.md, "Chapter 4").
# --------------------------------------------------------------------------------------
MODELS = ("3d", "2d")
LENGTH = 4.84             # block size in x and z: 11 ridge pitches; the 10 x 10 tip table plus 0.44 mm
RIDGE_PITCH = ms.RIDGE_PITCH          # 0.44: intermediate ridges under the surface ridges, along x
APEX_HALF = 0.04          # intermediate-ridge apex: flat bottom 0.08 mm wide (trapezoid)
FLANK = 0.10              # horizontal run of each trapezoid flank (apex edge -> papilla top)
PAPILLA_LENGTH = 0.15     # papilla tip 0.15 mm above the intermediate-ridge apex
Y_APEX = ms.Y_INTERFACE   # 2.35: apex (deepest point) of the intermediate ridges = SA-I sites
Y_TIP = Y_APEX + PAPILLA_LENGTH       # 2.50: papilla tips = RA-I sites
PAP_PITCH_Z = ms.PAP_PITCH_Z          # 0.22: papillae along z (3-D model)
PAP_TOP_HALF_Z = 0.04     # papilla top 0.08 mm along z (0.16 mm along x: 2x longer across the ridges)
PAP_BASE_HALF_Z = 0.11    # papilla base 0.22 mm along z: neighbours meet at the apex level (V-grooves)
FINE_X = 1.32             # |x - xc| <= FINE_X: apexes resolved as trapezoids; outside: apex and tip lines only
FINE_Z = 1.10             # |z - zc| <= FINE_Z: papilla tops resolved (4 elements per 0.22 mm); outside: hats
TABLE_N = 10              # hot-spot table: 10 x 10 tips
TABLE_PITCH = 0.44        # table pitch in x and z (every second papilla along z: see README)
DEPTH = ms.DEPTH          # 0.5 mm

INDENTERS = {
    # name: (footprint(dx, dz) -> bool, nominal extent in mm, description)
    "bar": (lambda dx, dz: (np.abs(dx) <= 1.0 + ms.TOL) & (np.abs(dz) <= 1.0 + ms.TOL), 2.0,
            "solid bar 2 x 2 mm"),
    "gap": (lambda dx, dz: (np.abs(dx) >= 0.5 - ms.TOL) & (np.abs(dx) <= 1.0 + ms.TOL)
            & (np.abs(dz) <= 1.0 + ms.TOL), 2.0,
            "gap indenter: two 0.5 (x) x 2 (z) mm bars along the ridges, 1.0 mm gap in x"),
    "gap90": (lambda dx, dz: (np.abs(dz) >= 0.5 - ms.TOL) & (np.abs(dz) <= 1.0 + ms.TOL)
              & (np.abs(dx) <= 1.0 + ms.TOL), 2.0,
              "gap indenter rotated 90 degrees: two 2 (x) x 0.5 (z) mm bars across the ridges, 1.0 mm gap in z"),
    "circle": (lambda dx, dz: dx * dx + dz * dz <= 1.0 + ms.TOL, 2.0,
               "solid circle 2 mm in diameter (footprint: the surface nodes inside it)"),
}
EDGE_LINES = (0.5, 1.0)   # indenter edges (mm from the centre) that get grid lines in x and z


def trapezoid(d: np.ndarray, flat: float, run: float) -> np.ndarray:
    """1 on |d| <= flat, falling linearly to 0 at |d| = flat + run, 0 beyond (d, flat, run in mm)."""
    return np.clip((flat + run - np.abs(d)) / run, 0.0, 1.0)


def ridge_profile(x: np.ndarray, xc: float) -> np.ndarray:
    """Across the ridges: 0 on an intermediate-ridge apex (x = xc + k 0.44), 1 on the papilla tops between.

    Trapezoid: flat apex |dx| <= APEX_HALF, flanks of run FLANK, flat top 0.16 mm wide (x in mm).
    """
    dx = np.mod(x - xc + 0.5 * RIDGE_PITCH, RIDGE_PITCH) - 0.5 * RIDGE_PITCH
    return 1.0 - trapezoid(dx, APEX_HALF, FLANK)


def papilla_profile(z: np.ndarray, zc: float) -> np.ndarray:
    """Along the ridges (3-D model): 1 on a papilla top (z = zc + m 0.22, 0.08 mm long), 0 between papillae."""
    dz = np.mod(z - zc + 0.5 * PAP_PITCH_Z, PAP_PITCH_Z) - 0.5 * PAP_PITCH_Z
    return trapezoid(dz, PAP_TOP_HALF_Z, PAP_BASE_HALF_Z - PAP_TOP_HALF_Z)


def ch4_interface(model: str, xc: float, zc: float):
    """Epidermis/dermis interface y(x, z) (mm) of the ridged model "3d" or "2d"."""
    if model == "3d":
        return lambda x, z: Y_APEX + PAPILLA_LENGTH * ridge_profile(x, xc) * papilla_profile(z, zc)
    if model == "2d":
        return lambda x, z: Y_APEX + PAPILLA_LENGTH * ridge_profile(x, xc) + 0.0 * z
    raise ValueError(f"model: expected one of {MODELS}, got {model!r}")


def ch4_spec(quick: bool = False) -> ms.MeshSpec:
    """Element layers in y (the in-plane grid is ``grid_lines``); ``quick``: a coarse smoke mesh."""
    if quick:
        return ms.MeshSpec("chapter4", LENGTH, (2.0,), 0, 0, 0, 0, 0, 0,
                           n_sub=1, n_derm=3, n_epi=3, derm_ratio=1.8, epi_ratio=1.3)
    return ms.MeshSpec("chapter4", LENGTH, (2.0,), 0, 0, 0, 0, 0, 0,
                       n_sub=2, n_derm=4, n_epi=5, derm_ratio=1.6, epi_ratio=1.25)


def _with_edges(lines, c: float) -> np.ndarray:
    """Add the indenter-edge lines c +- EDGE_LINES to ``lines`` (sorted, unique to 1e-9 mm).

    A line within 0.015 mm of an edge line is dropped (no sliver elements; the lines this drops are
    mid-gap lines where the interface is flat at the apex level, so the geometry is unchanged).
    """
    edges = np.array([c + s * e for e in EDGE_LINES for s in (-1, 1)])
    lines = np.asarray(lines)[np.min(np.abs(np.asarray(lines)[:, None] - edges[None, :]), axis=1) > 0.015]
    return np.unique(np.round(np.concatenate([lines, edges]), 9))


def grid_lines(quick: bool = False):
    """(x lines, z lines) in mm; the same grid for both models (only the interface differs).

    x: for the apexes within FINE_X of the centre, lines at the apex centre and edges, the flank
    ends and the papilla tips (6 elements per 0.44 mm); farther out at the apexes and tips only
    (there the trapezoid is meshed as a hat). z: lines at every papilla tip and mid-gap, and within
    FINE_Z at the papilla-top edges (4 elements per 0.22 mm; farther out hats). Both also get the
    indenter edges at +-0.5 and +-1.0 mm. ``quick``: apexes, tips and mid-gaps only.
    """
    c = 0.5 * LENGTH
    k = np.arange(-6, 7)
    apex = c + k * RIDGE_PITCH
    xl = np.concatenate([apex, c + (k + 0.5) * RIDGE_PITCH])
    m = np.arange(-12, 13)
    tip = c + m * PAP_PITCH_Z
    zl = np.concatenate([tip, c + (m + 0.5) * PAP_PITCH_Z])
    if not quick:
        a = apex[np.abs(apex - c) <= FINE_X + ms.TOL]
        xl = np.concatenate([xl] + [a + s * h for h in (APEX_HALF, APEX_HALF + FLANK) for s in (-1, 1)])
        t = tip[np.abs(tip - c) <= FINE_Z + ms.TOL]
        zl = np.concatenate([zl, t - PAP_TOP_HALF_Z, t + PAP_TOP_HALF_Z])
    out = []
    for a in (xl, zl):
        a = _with_edges(a[(a > ms.TOL) & (a < LENGTH - ms.TOL)], c)
        out.append(np.concatenate([[0.0], a, [LENGTH]]))
    return out[0], out[1]


def table_coords(c: float, n: int = TABLE_N, pitch: float = TABLE_PITCH) -> np.ndarray:
    """n positions at ``pitch`` (mm) symmetric about ``c``: c +- pitch/2, c +- 3 pitch/2, ..."""
    return np.round(c + (np.arange(n) - 0.5 * (n - 1)) * pitch, 9)


def site_tables(sm: ms.SkinMesh):
    """(RA-I tips, SA-I bases): (n, 3) coordinates (mm) of the hot-spot tables, ordered by x then z.

    RA-I: the 10 x 10 papilla tips (y = Y_TIP) at x, z = c +- 0.22 ... +- 1.98.
    SA-I: the intermediate-ridge apexes (y = Y_APEX) at x = c + k 0.44, |k| <= 4 (9 columns: an
    apex line lies midway between two tip columns, so a symmetric table has 9 or 11), same z rows.
    """
    c = sm.xc
    tz = table_coords(c)
    tx = table_coords(c)
    bx = np.round(c + np.arange(-4, 5) * RIDGE_PITCH, 9)
    out = []
    for xs, y in ((tx, Y_TIP), (bx, Y_APEX)):
        X, Z = np.meshgrid(xs, tz, indexing="ij")
        nodes = ms.interface_nodes(sm, X.ravel(), Z.ravel())
        pts = sm.mesh.p[:, nodes].T.copy()
        assert np.allclose(pts[:, 1], y), "site not on the expected interface height"
        out.append((pts, nodes))
    return out


def all_sites(sm: ms.SkinMesh):
    """Every papilla tip and every apex point on the grid, at least one pitch (x 0.44, z 0.22 mm) from the side faces.

    Returns {"tips": (n, 3), "bases": (m, 3)} in mm: tips at x = c + (k + 1/2) 0.44, z = c + j 0.22;
    bases (intermediate-ridge apexes) at x = c + k 0.44 and the same z.
    """
    c, L = sm.xc, LENGTH
    k = np.arange(-6, 7)
    z = np.round(c + np.arange(-12, 13) * PAP_PITCH_Z, 9)
    z = z[(z >= PAP_PITCH_Z - ms.TOL) & (z <= L - PAP_PITCH_Z + ms.TOL)]
    res = {}
    for name, xs in (("tips", c + (k + 0.5) * RIDGE_PITCH), ("bases", c + k * RIDGE_PITCH)):
        xs = np.round(xs, 9)
        xs = xs[(xs >= RIDGE_PITCH - ms.TOL) & (xs <= L - RIDGE_PITCH + ms.TOL)]
        X, Z = np.meshgrid(xs, z, indexing="ij")
        res[name] = sm.mesh.p[:, ms.interface_nodes(sm, X.ravel(), Z.ravel())].T
    return res


def build_ch4_mesh(model: str, quick: bool = False) -> ms.SkinMesh:
    """The chapter-4 block of ``model`` "3d" or "2d"; ``tips``/``tip_nodes``: the 10 x 10 RA-I table."""
    xl, zl = grid_lines(quick)
    c = 0.5 * LENGTH
    sm = ms.layered_mesh(ch4_spec(quick), xl, zl, ch4_interface(model, c, c), c, c)
    (tips, tip_nodes), _ = site_tables(sm)
    sm.tips, sm.tip_nodes = tips, tip_nodes
    return sm


def write_sites(path: Path, pts: np.ndarray):
    """``id,x,y,z`` (mm), ids from 1, rows ordered by x then z."""
    with open(path, "w", newline="\n") as f:
        f.write("id,x,y,z\n")
        for i, (x, y, z) in enumerate(pts, start=1):
            f.write(f"{i},{x:.10g},{y:.10g},{z:.10g}\n")


def export_cropped(path: Path, sm: ms.SkinMesh, node_sed, cell_sed):
    """VTU of the hexahedra touching the epidermis/dermis interface (point and cell SED float32, MPa; layer).

    The whole interface (every tip and every apex) stays, so site finders see the full geometry; the
    nodal SED is the full mesh's (elements averaged before cropping).
    """
    import meshio

    full = meshio.Mesh(sm.mesh.p.T.astype(np.float64), [("hexahedron", ms._cells(sm))],
                       point_data={"SED": node_sed.astype(np.float32)},
                       cell_data={"SED": [cell_sed.astype(np.float32)], "layer": [sm.layer]})
    iface = np.flatnonzero(sm.node_j == sm.j_interface)
    small = ms.crop_to_receptors(full, iface)
    tmp = path.with_name(path.name + ".part.vtu")
    meshio.write(str(tmp), small, file_format="vtu", binary=True, compression="zlib")
    tmp.replace(path)
    return len(small.cells[0].data), len(small.points)


def tip_summary(sm, node_sed, nodes, pts):
    """Min/median/max (Pa) of the nodal SED at ``nodes`` and where the max is (mm from the centre)."""
    s = node_sed[nodes] * 1e6
    i = int(np.argmax(s))
    return {"min_Pa": float(s.min()), "median_Pa": float(np.median(s)), "max_Pa": float(s.max()),
            "max_at_dx_dz_mm": [round(float(pts[i, 0] - sm.xc), 6), round(float(pts[i, 2] - sm.zc), 6)]}


def run_model(model: str, out: Path, quick: bool, log=print) -> dict:
    """Mesh, assemble, solve the four indenters, export; returns the model's run record."""
    t0 = time.perf_counter()
    sm = build_ch4_mesh(model, quick)
    stats = ms.mesh_stats(sm)
    (tips, tip_nodes), (bases, base_nodes) = site_tables(sm)
    sites = all_sites(sm)
    log(f"[{model}] {stats['n_nodes']} nodes, {stats['n_elements']} hexahedra")
    prob = ms.Problem(sm, log=log)
    post = ms.Post(prob)
    mdir = out / f"ridged{model}"
    mdir.mkdir(parents=True, exist_ok=True)
    write_sites(mdir / "ra_sites.csv", tips)
    write_sites(mdir / "sa_sites.csv", bases)
    rec = {"mesh": stats, "mesh_s": round(time.perf_counter() - t0 - prob.t_assemble, 2),
           "assemble_s": round(prob.t_assemble, 2),
           "sites": {"ra_table": "ra_sites.csv (10 x 10 papilla tips, y = %.2f mm)" % Y_TIP,
                     "sa_table": "sa_sites.csv (9 x 10 intermediate-ridge apexes, y = %.2f mm)" % Y_APEX,
                     "all_tips_xyz_mm": np.round(sites["tips"], 6).tolist(),
                     "all_bases_xyz_mm": np.round(sites["bases"], 6).tolist()},
           "cases": {}}
    for name, (fp, extent, desc) in INDENTERS.items():
        u, sinfo = prob.solve(extent, DEPTH, footprint=fp)
        csed = post.cell_sed(u)
        nsed = post.nodal_sed(csed)
        n_cells, n_pts = export_cropped(mdir / f"{name}.vtu", sm, nsed, csed)
        sinfo.update(indenter=name, description=desc, exported_cells=n_cells, exported_nodes=n_pts,
                     file_bytes=(mdir / f"{name}.vtu").stat().st_size,
                     ra_table=tip_summary(sm, nsed, tip_nodes, tips),
                     sa_table=tip_summary(sm, nsed, base_nodes, bases))
        rec["cases"][name] = sinfo
        log(f"  {name}: {sinfo['cg_iterations']} CG its, {sinfo['solve_s']:.1f} s, F={sinfo['punch_force_N']:.4f} N, "
            f"RA-I max {sinfo['ra_table']['max_Pa']:.1f} Pa, SA-I max {sinfo['sa_table']['max_Pa']:.1f} Pa")
    rec["total_s"] = round(time.perf_counter() - t0, 1)
    return rec


def geometry_record() -> dict:
    """The stated geometry (mm) written to build_info.json."""
    return {"block_mm": [LENGTH, 3.1, LENGTH], "centre_xz_mm": [0.5 * LENGTH, 0.5 * LENGTH],
            "ridge_pitch_x": RIDGE_PITCH, "apex_half_width": APEX_HALF, "flank_run": FLANK,
            "papilla_length": PAPILLA_LENGTH, "y_apex_SA_I": Y_APEX, "y_tip_RA_I": Y_TIP,
            "papilla_pitch_z_3d": PAP_PITCH_Z, "papilla_top_half_z": PAP_TOP_HALF_Z,
            "papilla_base_half_z": PAP_BASE_HALF_Z, "fine_z_half_width": FINE_Z,
            "table": f"{TABLE_N} x {TABLE_N}, pitch {TABLE_PITCH} mm in x and z",
            "surface": "cosine ridges, crests over the intermediate-ridge apexes (make_samples.surface_y)",
            "indenters": {k: v[2] for k, v in INDENTERS.items()}, "depth_mm": DEPTH,
            "boundary": "bottom edges restrained (make_samples.Problem, bottom='edges')",
            "material": "linear elastic, make_samples.YOUNG / NU; static (the hold's normalised maps)"}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse mesh smoke run (into a temp dir)")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default sample_sed/chapter4)")
    ap.add_argument("--model", choices=MODELS, default=None, help="one model only")
    args = ap.parse_args(argv)
    if ms.pyamg is None:
        sys.exit("pyamg is required: pip install -e .[samples]")
    here = Path(__file__).resolve().parent
    out = args.out or (Path(tempfile.gettempdir()) / "afferent_chapter4_quick" if args.quick else here / "chapter4")
    out.mkdir(parents=True, exist_ok=True)
    print(f"output: {out}")
    info = {"generator": "sample_sed/make_chapter4.py" + (" --quick" if args.quick else ""),
            "versions": {"python": platform.python_version(), "scikit-fem": ms.skfem.__version__,
                         "meshio": ms.meshio.__version__, "numpy": np.__version__,
                         "scipy": ms.scipy.__version__, "pyamg": ms.pyamg.__version__},
            "units": {"length": "mm", "SED": "MPa (= 1e6 Pa)", "force": "N"},
            "geometry": geometry_record(), "models": {}}
    for model in MODELS:
        if args.model in (None, model):
            info["models"][model] = run_model(model, out, args.quick)
    name = "build_info.json" if args.model is None else f"build_info_{args.model}.json"
    (out / name).write_text(json.dumps(info, indent=1) + "\n")
    sizes = {p.relative_to(out).as_posix(): p.stat().st_size for p in sorted(out.rglob("*.vtu"))}
    print(f"VTU total {sum(sizes.values()) / 1e6:.2f} MB: {sizes}")


if __name__ == "__main__":
    main()
