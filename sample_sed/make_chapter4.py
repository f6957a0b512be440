#!/usr/bin/env python
"""Regenerate the chapter-4 samples in ``sample_sed/chapter4/``: two ridged blocks, four indenters.

The study's chapter 4 (docs/method.md, "Chapter 4: ridged blocks, four indenters, hot-spot maps")
compares a **3-D ridged** block with a **2-D ridged** block, each pressed 0.5 mm by four rigid
frictionless indenters: a 2 x 2 mm solid bar, a gap indenter (two 0.5 x 2 mm bars with a 1.0 mm gap
between their inside edges), the gap indenter rotated 90 degrees, and a 2 mm diameter solid circle.

The blocks as the study describes them: six fingerprints (surface ridges, pitch 0.44 mm along x) over
twelve intermediate ridges (pitch 0.22 mm along x, their apexes the SA-I sites); between neighbouring
intermediate ridges a row of **discrete dermal papillae**, concave-convex pegs (a cos^2 bump: convex
tip, concave foot) 0.22 mm along x by 0.11 mm along z at a pitch of 0.22 mm along z, 0.15 mm long
(tip 0.15 mm above the apex level), so that between two pegs of a row 0.11 mm of interface lies at the
apex level; twelve rows of twelve pegs, **144 papilla tips** (RA-I sites) around the centre. The 2-D
ridged block has the same intermediate ridges with the papillae even along z (continuous dermal
ridges of the same x profile). Numbers the study does not give are chosen, each with its reason, in
sample_sed/README.md ("Chapter 4").

Both blocks are mirror-symmetric about x = c and z = c (c the centre), and so are the bottom-edge
restraint and every indenter: each is solved on one quarter (x >= c, z >= c; symmetry planes held
normal to themselves), which is exact for this linear problem and four times cheaper, and the quarter's
element SED is mirrored onto the whole block before the nodal averages and the export.

Material: ``--material relaxed`` (default, the samples): the dermis and subcutis shear moduli relaxed to the end of the study's 2 s hold
by the Prony series of make_vibration.py (SKIN: G(t)/G0 at 2.05 s, the hold's end measured from the
middle of the 0.1 s ramp; the quasi-elastic approximation, bulk moduli unchanged, epidermis elastic):
the study's hot-spot maps are those of the hold. ``--material elastic``: the instantaneous moduli.

Units: mm, MPa, N (SED in MPa = 1e6 Pa).  Axes as in make_samples.py: x across the ridges,
y up (bottom at y = 0), z along the ridges.

Usage::

    python sample_sed/make_chapter4.py            # both models, four indenters -> sample_sed/chapter4/
    python sample_sed/make_chapter4.py --quick    # coarse smoke run into a temp dir
    python sample_sed/make_chapter4.py --model 3d --material elastic --out DIR
    python sample_sed/chapter4_reasons.py --solve  # the stated reasons for a 3-D/2-D difference, one at a time

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
MATERIALS = ("elastic", "relaxed")
LENGTH = 4.84             # block size in x and z: the 2.64 mm tip region plus 1.1 mm on each side
FINGERPRINT_PITCH = ms.RIDGE_PITCH    # 0.44: surface ridges (make_samples.surface_y), crests over x = c + k 0.44
RIDGE_PITCH = 0.22        # intermediate ridges along x: twelve under six fingerprints
PAP_PITCH_Z = ms.PAP_PITCH_Z          # 0.22: papillae along z (3-D model)
PAP_HALF_X = 0.5 * RIDGE_PITCH        # 0.11: a papilla's foot spans the x pitch, apex line to apex line
PAP_HALF_Z = ms.PAP_HALF_Z            # 0.055: a peg's foot 0.11 mm along z, 0.11 mm of apex-level interface between pegs
PAPILLA_LENGTH = 0.15     # papilla tip 0.15 mm above the intermediate-ridge apex
Y_APEX = ms.Y_INTERFACE   # 2.35: apex (deepest point) of the intermediate ridges = SA-I sites
Y_TIP = Y_APEX + PAPILLA_LENGTH       # 2.50: papilla tips = RA-I sites
N_SIDE = 6                # tips on each side of the centre, per direction: 12 x 12 = 144
FINE = N_SIDE * RIDGE_PITCH           # 1.32: |x - c|, |z - c| <= FINE resolved (6 elements per 0.22 mm)
TABLE_N = 10              # hot-spot table: the inner 10 x 10 of the 144 tips (every tip, pitch 0.22 mm)
TABLE_PITCH = RIDGE_PITCH
SA_COLUMNS = 9            # SA-I table: apex lines x = c + k 0.22, |k| <= 4, at the table's z rows
DEPTH = ms.DEPTH          # 0.5 mm
T_HOLD_END = 0.05 + 2.0   # s: the hold's end from the middle of the 0.1 s ramp (relaxed moduli)

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


def _offset(a: np.ndarray, c: float, pitch: float) -> np.ndarray:
    """Distance (mm) from ``a`` to the nearest of c + (k + 1/2) pitch, signed, in [-pitch/2, pitch/2)."""
    return np.mod(a - c, pitch) - 0.5 * pitch


def ch4_interface(model: str, xc: float, zc: float):
    """Epidermis/dermis interface y(x, z) (mm) of the ridged model "3d" or "2d".

    3-D: Y_APEX + 0.15 bump(dx / 0.11) bump(dz / 0.055), one peg per tip (x, z) = c + (k + 1/2) 0.22;
    2-D: Y_APEX + 0.15 bump(dx / 0.11), continuous dermal ridges along z (make_samples.bump: cos^2).
    """
    if model == "3d":
        return lambda x, z: Y_APEX + PAPILLA_LENGTH * ms.bump(_offset(x, xc, RIDGE_PITCH) / PAP_HALF_X) \
            * ms.bump(_offset(z, zc, PAP_PITCH_Z) / PAP_HALF_Z)
    if model == "2d":
        return lambda x, z: Y_APEX + PAPILLA_LENGTH * ms.bump(_offset(x, xc, RIDGE_PITCH) / PAP_HALF_X) + 0.0 * z
    raise ValueError(f"model: expected one of {MODELS}, got {model!r}")


def ch4_spec(quick: bool = False, refine: int = 1) -> ms.MeshSpec:
    """Element layers in y (the in-plane grid is ``grid_lines``); ``quick``: a coarse smoke mesh;
    ``refine``: every element split into refine^3 (the mesh-convergence check)."""
    if quick:
        return ms.MeshSpec("chapter4", LENGTH, (2.0,), 0, 0, 0, 0, 0, 0,
                           n_sub=1, n_derm=3, n_epi=3, derm_ratio=1.8, epi_ratio=1.3, refine=refine)
    return ms.MeshSpec("chapter4", LENGTH, (2.0,), 0, 0, 0, 0, 0, 0,
                       n_sub=2, n_derm=4, n_epi=5, derm_ratio=1.6, epi_ratio=1.25, refine=refine)


def _with_edges(lines, c: float) -> np.ndarray:
    """Add the indenter-edge lines c +- EDGE_LINES to ``lines`` (sorted, unique to 1e-9 mm), unless a line
    lies within 0.006 mm of one (that line is then the edge: at most 0.005 mm off). No line is removed:
    every one carries the geometry (apex, foot, tip)."""
    lines = np.asarray(lines)
    edges = np.array([c + s * e for e in EDGE_LINES for s in (-1, 1)])
    edges = edges[np.min(np.abs(edges[:, None] - lines[None, :]), axis=1) > 0.006]
    return np.unique(np.round(np.concatenate([lines, edges]), 9))


def grid_lines(quick: bool = False):
    """(x lines, z lines) in mm over the whole block, symmetric about the centre c; the same grid for
    both models (only the interface differs).

    x: within FINE of c, six elements per 0.22 mm (lines at the apexes c + k 0.22, the tips between, and
    two between each); outside, the apexes and tips only. z: within FINE, lines at mid-gap c + k 0.22,
    the peg feet (+-0.055 from a tip), the quarter points and the tip (four elements on a peg, two in the
    0.11 mm between pegs); outside, mid-gap, feet and tip. Both also get the indenter edges at +-0.5 and
    +-1.0 mm. ``quick``: apexes/tips and mid-gap/feet/tips everywhere.
    """
    c = 0.5 * LENGTH
    n = int(round(0.5 * LENGTH / RIDGE_PITCH)) + 1
    k = np.arange(-n, n + 1)
    per_x_fine = np.arange(6) / 6.0 * RIDGE_PITCH                  # apex, ..., tip at 3/6, ...
    per_x_coarse = np.array([0.0, 0.5]) * RIDGE_PITCH
    per_z_fine = np.array([0.0, 0.055, 0.0825, 0.11, 0.1375, 0.165])  # mid-gap, foot, quarter, tip, ...
    per_z_coarse = np.array([0.0, 0.055, 0.11, 0.165])
    out = []
    for fine, coarse in ((per_x_fine, per_x_coarse), (per_z_fine, per_z_coarse)):
        if quick:
            fine = coarse
        starts = c + k * RIDGE_PITCH
        a = np.concatenate([s0 + (fine if abs(s0 - c) < FINE - ms.TOL else coarse) for s0 in starts])
        a = np.concatenate([a, 2 * c - a])                          # mirror: the grid is symmetric about c
        a = np.unique(np.round(a, 9))
        a = _with_edges(a[(a > ms.TOL) & (a < LENGTH - ms.TOL)], c)
        out.append(np.concatenate([[0.0], a, [LENGTH]]))
    return out[0], out[1]


def tip_coords(c: float, n_side: int = N_SIDE) -> np.ndarray:
    """The 2 n_side tip positions along x or z (mm): c +- 0.11, c +- 0.33, ..., symmetric about c."""
    return np.round(c + (np.arange(2 * n_side) - n_side + 0.5) * RIDGE_PITCH, 9)


def site_tables(sm: ms.SkinMesh):
    """(RA-I tips, SA-I bases): (n, 3) coordinates (mm) and node indices of the hot-spot tables, by x then z.

    RA-I: the inner 10 x 10 of the 144 papilla tips (y = Y_TIP), every tip: x, z = c +- 0.11 ... +- 0.99.
    SA-I: the intermediate-ridge apexes (y = Y_APEX) at x = c + k 0.22, |k| <= 4, at the same z rows.
    """
    c = sm.xc
    tz = tip_coords(c, TABLE_N // 2)
    bx = np.round(c + np.arange(-(SA_COLUMNS // 2), SA_COLUMNS // 2 + 1) * RIDGE_PITCH, 9)
    out = []
    for xs, y in ((tz, Y_TIP), (bx, Y_APEX)):
        X, Z = np.meshgrid(xs, tz, indexing="ij")
        nodes = ms.interface_nodes(sm, X.ravel(), Z.ravel())
        pts = sm.mesh.p[:, nodes].T.copy()
        assert np.allclose(pts[:, 1], y), "site not on the expected interface height"
        out.append((pts, nodes))
    return out


def all_sites(sm: ms.SkinMesh):
    """The 144 papilla tips and the 13 x 12 apex points at their z rows: {"tips": (144, 3), "bases": (156, 3)} mm."""
    c = sm.xc
    z = tip_coords(c)
    res = {}
    for name, xs in (("tips", tip_coords(c)), ("bases", np.round(c + np.arange(-N_SIDE, N_SIDE + 1) * RIDGE_PITCH, 9))):
        X, Z = np.meshgrid(xs, z, indexing="ij")
        res[name] = sm.mesh.p[:, ms.interface_nodes(sm, X.ravel(), Z.ravel())].T
    return res


def build_ch4_mesh(model: str, quick: bool = False, refine: int = 1, quarter: bool = False) -> ms.SkinMesh:
    """The chapter-4 block of ``model`` "3d" or "2d"; ``tips``/``tip_nodes``: the RA-I table (None on a
    quarter); ``quarter``: only x >= c, z >= c (the symmetric quarter the solver works on)."""
    xl, zl = grid_lines(quick)
    c = 0.5 * LENGTH
    if quarter:
        xl, zl = xl[xl >= c - ms.TOL], zl[zl >= c - ms.TOL]
    sm = ms.layered_mesh(ch4_spec(quick, refine), xl, zl, ch4_interface(model, c, c), c, c)
    if not quarter:
        (tips, tip_nodes), _ = site_tables(sm)
        sm.tips, sm.tip_nodes = tips, tip_nodes
    return sm


def symmetry_planes(c: float):
    """Dofs held at zero on the quarter's symmetry planes: u_x on x = c, u_z on z = c (ms.Problem ``fixed``)."""
    return lambda X, comp: ((np.abs(X[0] - c) <= ms.TOL) & (comp == 0)) | ((np.abs(X[2] - c) <= ms.TOL) & (comp == 2))


def relaxed_moduli(sm: ms.SkinMesh):
    """Per-element (mu, kappa) in MPa with the dermis and subcutis shear moduli relaxed to T_HOLD_END (s) by
    make_vibration.SKIN (Prony), and the relaxation factor G(T_HOLD_END)/G0 (-)."""
    import make_vibration as mv  # the one Prony series of the samples (imported here: it imports this module)

    lam, mu = ms.lame(sm.layer)
    kappa = lam + 2.0 * mu / 3.0
    g = float(mv.relaxation(mv.SKIN, T_HOLD_END))
    visco = sm.layer != ms.LAYER_EPIDERMIS
    return np.where(visco, g * mu, mu), kappa, g


def cell_centroids(sm: ms.SkinMesh) -> np.ndarray:
    """(n_elements, 3) mean of each hexahedron's 8 nodes (mm)."""
    return sm.mesh.p[:, sm.mesh.t].mean(axis=1).T


def mirror_map(full: ms.SkinMesh, quarter: ms.SkinMesh) -> np.ndarray:
    """For each element of ``full``, the element of ``quarter`` that is its mirror image about x = c and z = c."""
    from scipy.spatial import cKDTree

    c = full.xc
    f = cell_centroids(full)
    f[:, 0], f[:, 2] = c + np.abs(f[:, 0] - c), c + np.abs(f[:, 2] - c)
    d, i = cKDTree(cell_centroids(quarter)).query(f)
    assert d.max() < 1e-7, f"quarter and full grids differ: a mirrored centroid {d.max():.3g} mm from every quarter element"
    return i


def write_sites(path: Path, pts: np.ndarray):
    """``id,x,y,z`` (mm), ids from 1, rows ordered by x then z."""
    with open(path, "w", newline="\n") as f:
        f.write("id,x,y,z\n")
        for i, (x, y, z) in enumerate(pts, start=1):
            f.write(f"{i},{x:.10g},{y:.10g},{z:.10g}\n")


def export_cropped(path: Path, sm: ms.SkinMesh, node_sed, cell_sed):
    """VTU of the hexahedra touching the epidermis/dermis interface within FINE + 0.22 mm of the centre
    (point and cell SED float32, MPa; layer): every tip and apex of the 12 x 12 region with a pitch of
    margin, so site finders see the full geometry there; the nodal SED is the full mesh's."""
    import meshio

    full = meshio.Mesh(sm.mesh.p.T.astype(np.float64), [("hexahedron", ms._cells(sm))],
                       point_data={"SED": node_sed.astype(np.float32)},
                       cell_data={"SED": [cell_sed.astype(np.float32)], "layer": [sm.layer]})
    p = sm.mesh.p
    near = (np.abs(p[0] - sm.xc) <= FINE + RIDGE_PITCH + ms.TOL) & (np.abs(p[2] - sm.zc) <= FINE + RIDGE_PITCH + ms.TOL)
    iface = np.flatnonzero((sm.node_j == sm.j_interface) & near)
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


def solve_model(model: str, quick: bool, indenters, material: str = "elastic", refine: int = 1, log=print):
    """Mesh the quarter and the whole block, solve ``indenters`` on the quarter, mirror.

    Yields (name, full SkinMesh, cell SED (MPa) on the whole block, element volumes (mm^3), solve record)."""
    if material not in MATERIALS:
        raise ValueError(f"material: expected one of {MATERIALS}, got {material!r}")
    t0 = time.perf_counter()
    full = build_ch4_mesh(model, quick, refine)
    q = build_ch4_mesh(model, quick, refine, quarter=True)
    m = mirror_map(full, q)
    moduli, g = None, 1.0
    if material == "relaxed":
        mu, kappa, g = relaxed_moduli(q)
        moduli = (mu, kappa)
    prob = ms.Problem(q, log=log, moduli=moduli, fixed=symmetry_planes(q.xc))
    if moduli is not None:  # the SED of the relaxed state: 1/2 sigma:eps with the relaxed moduli
        prob.mu, prob.lam = moduli[0], moduli[1] - 2.0 * moduli[0] / 3.0
    post = ms.Post(prob)
    setup = {"mesh": ms.mesh_stats(full) | {"quarter_elements": int(q.mesh.t.shape[1]), "quarter_dofs": int(prob.ndof)},
             "mesh_s": round(time.perf_counter() - t0 - prob.t_assemble, 2), "assemble_s": round(prob.t_assemble, 2),
             "material": material, "relaxation_factor": g}
    log(f"[{model}] {setup['mesh']['n_nodes']} nodes, {setup['mesh']['n_elements']} hexahedra; quarter "
        f"{setup['mesh']['quarter_elements']} hexahedra, {prob.ndof} dofs; {material}")
    for name in indenters:
        fp, extent, desc = INDENTERS[name]
        u, sinfo = prob.solve(extent, DEPTH, footprint=fp)
        sinfo["punch_force_N"] *= 4.0  # the whole block's: four quarters
        sinfo.update(indenter=name, description=desc)
        yield name, full, post.cell_sed(u)[m], post.vol[m], sinfo, setup


def run_model(model: str, out: Path, quick: bool, material: str = "relaxed", log=print) -> dict:
    """Solve the four indenters, export; returns the model's run record."""
    t0 = time.perf_counter()
    mdir = out / f"ridged{model}"
    mdir.mkdir(parents=True, exist_ok=True)
    rec = {"cases": {}}
    for name, sm, csed, vol, sinfo, setup in solve_model(model, quick, INDENTERS, material, log=log):
        if "mesh" not in rec:
            (tips, tip_nodes), (bases, base_nodes) = site_tables(sm)
            sites = all_sites(sm)
            write_sites(mdir / "ra_sites.csv", tips)
            write_sites(mdir / "sa_sites.csv", bases)
            rec.update(setup)
            rec["sites"] = {"ra_table": "ra_sites.csv (10 x 10 papilla tips, pitch 0.22 mm, y = %.2f mm)" % Y_TIP,
                            "sa_table": "sa_sites.csv (9 x 10 intermediate-ridge apexes, y = %.2f mm)" % Y_APEX,
                            "all_tips_xyz_mm": np.round(sites["tips"], 6).tolist(),
                            "all_bases_xyz_mm": np.round(sites["bases"], 6).tolist()}
        nsed = ms.nodal_average(sm.mesh, csed, vol)
        n_cells, n_pts = export_cropped(mdir / f"{name}.vtu", sm, nsed, csed)
        sinfo.update(exported_cells=n_cells, exported_nodes=n_pts, file_bytes=(mdir / f"{name}.vtu").stat().st_size,
                     ra_table=tip_summary(sm, nsed, tip_nodes, tips), sa_table=tip_summary(sm, nsed, base_nodes, bases))
        rec["cases"][name] = sinfo
        log(f"  {name}: {sinfo['cg_iterations']} CG its, {sinfo['solve_s']:.1f} s, F={sinfo['punch_force_N']:.4f} N, "
            f"RA-I max {sinfo['ra_table']['max_Pa']:.1f} Pa, SA-I max {sinfo['sa_table']['max_Pa']:.1f} Pa")
    rec["total_s"] = round(time.perf_counter() - t0, 1)
    return rec


def geometry_record() -> dict:
    """The stated geometry (mm) written to build_info.json."""
    return {"block_mm": [LENGTH, 3.1, LENGTH], "centre_xz_mm": [0.5 * LENGTH, 0.5 * LENGTH],
            "fingerprint_pitch_x": FINGERPRINT_PITCH, "intermediate_ridge_pitch_x": RIDGE_PITCH,
            "papilla": f"cos^2 peg (make_samples.bump), foot {2 * PAP_HALF_X} (x) x {2 * PAP_HALF_Z} (z) mm",
            "papilla_length": PAPILLA_LENGTH, "y_apex_SA_I": Y_APEX, "y_tip_RA_I": Y_TIP,
            "papilla_pitch_z_3d": PAP_PITCH_Z, "tips": f"{2 * N_SIDE} x {2 * N_SIDE} = {(2 * N_SIDE) ** 2}",
            "fine_half_width": FINE,
            "table": f"{TABLE_N} x {TABLE_N}, pitch {TABLE_PITCH} mm in x and z (every tip)",
            "surface": "cosine ridges, crests over x = c + k 0.44 (make_samples.surface_y)",
            "indenters": {k: v[2] for k, v in INDENTERS.items()}, "depth_mm": DEPTH,
            "boundary": "bottom edges restrained (make_samples.Problem, bottom='edges')",
            "solve": "one quarter (x >= c, z >= c) with symmetry planes; element SED mirrored onto the block",
            "material": "make_samples.YOUNG / NU; 'relaxed' (the samples): dermis and subcutis shear moduli x "
                        "G(2.05 s)/G0 of make_vibration.SKIN (quasi-elastic, the end of the 2 s hold); 'elastic': "
                        "instantaneous moduli; static"}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse mesh smoke run (into a temp dir)")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default sample_sed/chapter4)")
    ap.add_argument("--model", choices=MODELS, default=None, help="one model only")
    ap.add_argument("--material", choices=MATERIALS, default="relaxed",
                    help="relaxed (default: the end of the 2 s hold) or elastic (instantaneous moduli)")
    args = ap.parse_args(argv)
    if ms.pyamg is None:
        sys.exit("pyamg is required: pip install -e .[samples]")
    here = Path(__file__).resolve().parent
    out = args.out or (Path(tempfile.gettempdir()) / "afferent_chapter4_quick" if args.quick else here / "chapter4")
    out.mkdir(parents=True, exist_ok=True)
    print(f"output: {out}")
    info = {"generator": "sample_sed/make_chapter4.py" + (" --quick" if args.quick else "")
            + ("" if args.material == "relaxed" else f" --material {args.material}"),
            "versions": {"python": platform.python_version(), "scikit-fem": ms.skfem.__version__,
                         "meshio": ms.meshio.__version__, "numpy": np.__version__,
                         "scipy": ms.scipy.__version__, "pyamg": ms.pyamg.__version__},
            "units": {"length": "mm", "SED": "MPa (= 1e6 Pa)", "force": "N"},
            "geometry": geometry_record(), "models": {}}
    for model in MODELS:
        if args.model in (None, model):
            info["models"][model] = run_model(model, out, args.quick, args.material)
    name = "build_info.json" if args.model is None else f"build_info_{args.model}.json"
    (out / name).write_text(json.dumps(info, indent=1) + "\n")
    sizes = {p.relative_to(out).as_posix(): p.stat().st_size for p in sorted(out.rglob("*.vtu"))}
    print(f"VTU total {sum(sizes.values()) / 1e6:.2f} MB: {sizes}")


if __name__ == "__main__":
    main()
