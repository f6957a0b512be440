#!/usr/bin/env python
"""Regenerate the viscoelastic vibration series in ``sample_sed/vibration/`` (the study's figs. 4-10/4-11).

The chapter-4 ridged blocks of ``make_chapter4.py`` (3-D and 2-D ridged; its geometry imported: twelve
intermediate ridges, 144 papilla tips, pitch 0.22 mm) with the layers, moduli, bottom-edge restraint,
stiffness assembly and solver of ``make_samples.py`` (imported, not copied), pressed by the 2 x 2 mm
plane, solved on the symmetric quarter x >= c, z >= c (block, restraint and plane are mirror-symmetric;
the symmetry planes held normal to themselves, make_chapter4.symmetry_planes), with the receptors the
quarter's 5 x 5 tips of the RA-I table (x, z = c + 0.11 ... 0.99 mm), and with the dermis and the
subcutis made **linear viscoelastic**: a Prony series on the shear modulus,

    G(t) = G0 (1 - sum_i g_i (1 - exp(-t / tau_i))),

the bulk modulus K elastic (constant), the epidermis linear elastic. G0 is the *instantaneous*
modulus, E / (2 (1 + nu)) of the layer table (ANSYS' convention for TB,PRONY, the tool of the
study's chapter 4); the long-term modulus is G0 g_inf, g_inf = 1 - sum_i g_i.

Time integration: the standard recursive update of the hereditary integral (internal variables),
exact for a strain that is linear within each step, implicit in time. With the deviatoric strain
e(t), the shear stress is s = 2 G0 (g_inf e + sum_i g_i h_i), h_i(t) = int_0^t exp(-(t-s)/tau_i) de/ds ds,
and over a step dt

    h_i(n+1) = a_i h_i(n) + b_i (e(n+1) - e(n)),   a_i = exp(-dt/tau_i),  b_i = (1 - a_i) tau_i / dt.

Because every viscoelastic layer shares the same g_i, tau_i and the strain is linear in the
displacement, h_i = e(H_i) for a displacement-like vector H_i that obeys the same recursion; the
step is then one linear solve with the algorithmic shear modulus G0 (g_inf + sum_i g_i b_i) in the
viscoelastic layers and the history force -K_v sum_i g_i (a_i H_i(n) - b_i u(n)), K_v the deviatoric
stiffness of the viscoelastic layers with G0 (no quadrature-point state to store). Quasi-static (no
inertia), small strain, the plane's contact area prescribed as in make_samples.py.

Units: mm, MPa, N, s (SED in MPa). Usage::

    python sample_sed/make_vibration.py            # the 8 series into sample_sed/vibration/
    python sample_sed/make_vibration.py --quick    # 2 cycles, one frequency pair, into a temp dir, and
                                                   # the quarter against the whole block (7 steps)

Requirements: ``pip install -e .[samples]`` (scikit-fem, pyamg). README: sample_sed/README.md,
section "Vibration series".
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass, replace  # noqa: E402
from pathlib import Path  # noqa: E402

import meshio  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import make_chapter4 as mc  # noqa: E402  (the chapter-4 ridged geometry and indenters)
import make_samples as ms  # noqa: E402

# --------------------------------------------------------------------------------------
# The material: a Prony series on the shear modulus
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Prony:
    """Relative Prony coefficients ``g`` (-) and relaxation times ``tau`` (s) of the shear modulus."""

    g: tuple
    tau: tuple
    source: str = ""

    def __post_init__(self):
        if len(self.g) != len(self.tau) or not self.g:
            raise ValueError(f"Prony: g {self.g} and tau {self.tau} must be non-empty and of equal length")
        if min(self.g) < 0 or sum(self.g) >= 1 or min(self.tau) <= 0:
            raise ValueError(f"Prony: expected g_i >= 0 with sum < 1 and tau_i > 0 s, got g {self.g}, tau {self.tau}")

    @property
    def g_inf(self) -> float:
        """Long-term fraction G(inf) / G0 (-)."""
        return 1.0 - float(sum(self.g))


# The set used for the samples (sample_sed/README.md, "Vibration series", "Material and time integration"):
# relaxation times from Pawluk & Howe 1999, weights from Wang et al. 2015 (see SOURCE); one set for dermis and subcutis.
SOURCE = (
    "tau_1 = 0.07 s, tau_2 = 1.4 s: the two slower of the three time constants (about 4 ms, 70 ms "
    "and 1.4 s) of the reduced relaxation function fitted to in vivo ramp-and-hold indentations of "
    "the human fingerpad by a flat probe (0-2 N) in D. T. V. Pawluk and R. D. Howe, 'Dynamic lumped "
    "element response of the human fingerpad', J. Biomech. Eng. 121(2):178-183, 1999 (abstract); "
    "g_inf = 0.28: the steady-state residual stress ratio of skin in compression (one-term QLV "
    "fits, 0.28 +/- 0.13 over thickness) in Y. Wang et al., 'Compressive viscoelasticity of freshly "
    "excised mouse skin ...', PLoS ONE 10(3):e0120897, 2015 (abstract); the relaxing part 0.72 "
    "split equally between the two terms. Not a published two-term fit: the coefficients of "
    "Pawluk & Howe's table and the study's own fitted values were not available; one set for "
    "dermis and subcutis.")
SKIN = Prony(g=(0.36, 0.36), tau=(0.07, 1.4), source=SOURCE)


def relaxation(prony: Prony, t) -> np.ndarray:
    """G(t) / G0 (-) at times ``t`` (s)."""
    t = np.asarray(t, dtype=float)[..., None]
    return 1.0 - np.sum(np.asarray(prony.g) * (1.0 - np.exp(-t / np.asarray(prony.tau))), axis=-1)


def complex_modulus(prony: Prony, omega) -> np.ndarray:
    """G*(omega) / G0 (-, complex) at angular frequencies ``omega`` (rad/s)."""
    w = np.asarray(omega, dtype=float)[..., None]
    iwt = 1j * w * np.asarray(prony.tau)
    return prony.g_inf + np.sum(np.asarray(prony.g) * iwt / (1.0 + iwt), axis=-1)


@dataclass(frozen=True)
class Hereditary:
    """The recursive update of one time step ``dt`` (s): a_i = exp(-dt/tau_i), b_i = (1 - a_i) tau_i / dt."""

    prony: Prony
    dt: float

    @property
    def a(self) -> np.ndarray:
        return np.exp(-self.dt / np.asarray(self.prony.tau))

    @property
    def b(self) -> np.ndarray:
        return (1.0 - self.a) * np.asarray(self.prony.tau) / self.dt

    @property
    def algorithmic(self) -> float:
        """Algorithmic shear modulus over G0 (-): the stiffness of the step's linear solve."""
        return self.prony.g_inf + float(np.sum(np.asarray(self.prony.g) * self.b))

    def history(self, H: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """sum_i g_i (a_i H_i - b_i u_prev) (mm): times -K_v, the history force of the next step."""
        g, a, b = np.asarray(self.prony.g), self.a, self.b
        return np.tensordot(g * a, H, axes=1) - float(np.sum(g * b)) * u_prev

    def update(self, H: np.ndarray, u: np.ndarray, u_prev: np.ndarray) -> np.ndarray:
        """H_i(n+1) = a_i H_i(n) + b_i (u(n+1) - u(n)); ``H`` is (n_terms, n_dofs) in mm."""
        return self.a[:, None] * H + self.b[:, None] * (u - u_prev)[None, :]

    def shear_field(self, H: np.ndarray, u: np.ndarray) -> np.ndarray:
        """g_inf u + sum_i g_i H_i (mm): its deviatoric strain times 2 G0 is the shear stress."""
        return self.prony.g_inf * u + np.tensordot(np.asarray(self.prony.g), H, axes=1)


def hereditary_step(rule: Hereditary, Kv, H: np.ndarray, u_prev: np.ndarray, solve):
    """One implicit step: ``solve(f)`` must return the displacement (mm) of the system whose stiffness
    is the elastic part plus ``rule.algorithmic`` times ``Kv`` (N/mm, the deviatoric stiffness of the
    viscoelastic material with G0), loaded by the history force f (N) and the step's prescribed
    displacements. Returns (u, H) of the new time."""
    f = -(Kv @ rule.history(H, u_prev))
    u = solve(f)
    return u, rule.update(H, u, u_prev)


# --------------------------------------------------------------------------------------
# The viscoelastic punch problem on a skin mesh
# --------------------------------------------------------------------------------------
class ViscoPunch:
    """Time stepping of the punch on ``sm`` (a make_samples SkinMesh).

    The dermis and subcutis relax by ``prony``, the epidermis is elastic; the bulk modulus is
    elastic everywhere. The two stiffness matrices (elastic part, and the deviatoric part of the
    viscoelastic layers with G0) are assembled once; :meth:`start` combines them for a step ``dt``.
    """

    def __init__(self, sm, prony: Prony, integration: str = "sri", fixed=None, solver: str = "lu"):
        """``fixed``, ``solver``: as make_samples.Problem (``fixed``: the symmetry planes of a quarter,
        make_chapter4.symmetry_planes)."""
        self.sm = sm
        self.prony = prony
        lam, mu = ms.lame(sm.layer)
        kappa = lam + 2.0 * mu / 3.0
        self.visco = sm.layer != ms.LAYER_EPIDERMIS
        self.mu0, self.kappa = mu, kappa
        self.prob = ms.Problem(sm, integration=integration, moduli=(np.where(self.visco, 0.0, mu), kappa),
                               log=lambda *a: None, solver=solver, fixed=fixed)
        self.K_rest = self.prob.K
        self.Kv = ms.stiffness(sm.mesh, self.prob.element, np.where(self.visco, mu, 0.0),
                               np.zeros_like(kappa), integration)
        self.post = ms.Post(self.prob)

    def start(self, dt: float) -> "ViscoPunch":
        """From rest (u = 0, no history), with time step ``dt`` (s)."""
        self.step_rule = Hereditary(self.prony, dt)
        self.prob.set_stiffness(self.K_rest + self.step_rule.algorithmic * self.Kv)
        n = self.prob.ndof
        self.H = np.zeros((len(self.prony.g), n))
        self.u = np.zeros(n)
        return self

    def step(self, width: float, depth: float):
        """Advance one step to the punch depth ``depth`` (mm): returns (u, solve info)."""
        info = {}

        def solve(f):
            u, info_ = self.prob.solve(width, depth, footprint=FOOTPRINT, f=f, guess=self.u)
            info.update(info_)
            return u

        self.u, self.H = hereditary_step(self.step_rule, self.Kv, self.H, self.u, solve)
        return self.u, info

    def cell_sed(self) -> np.ndarray:
        """Stored (recoverable) strain energy density at every element centroid (MPa): see :func:`stored_sed`."""
        return stored_sed(self.post.bc, self.u, self.H, self.prony, self.mu0, self.kappa, self.visco)


def _dev_sq(bc, v) -> np.ndarray:
    """|dev eps(v)|^2 and tr eps(v) at the one-point basis ``bc`` (one value per element)."""
    from skfem.helpers import sym_grad

    e = sym_grad(bc.interpolate(v))[:, :, :, 0]                   # (3, 3, nel)
    tr = np.trace(e)
    dev = e - tr / 3.0 * np.eye(3)[:, :, None]
    return np.einsum("ijk,ijk->k", dev, dev), tr


def stored_sed(bc, u, H, prony: Prony, mu0, kappa, visco) -> np.ndarray:
    """Strain energy density stored in the springs (MPa), at the one-point basis ``bc``.

    Viscoelastic layers (the generalized Maxwell model of the Prony series, arm i with the elastic
    deviatoric strain e(H_i)): W = K tr(eps)^2 / 2 + G0 (g_inf |dev eps|^2 + sum_i g_i |dev e(H_i)|^2),
    the recoverable energy (Abaqus' SENER for viscoelastic materials); >= 0, unlike 1/2 sigma:eps,
    which turns negative where the relaxed stress opposes the strain while unloading. Elastic
    layers: W = 1/2 sigma:eps = G |dev eps|^2 + K tr(eps)^2 / 2.
    """
    d2, tr = _dev_sq(bc, u)
    dev_w = np.where(visco, prony.g_inf, 1.0) * d2
    for g, Hi in zip(prony.g, H):
        dev_w = dev_w + np.where(visco, g * _dev_sq(bc, Hi)[0], 0.0)
    return 0.5 * kappa * tr ** 2 + mu0 * dev_w


# --------------------------------------------------------------------------------------
# The samples
# --------------------------------------------------------------------------------------
AMPLITUDE = 0.5                    # mm: deepest point of every cycle
WIDTH = 2.0                        # mm: the 2 x 2 mm plane (make_chapter4's "bar" footprint)
FOOTPRINT = mc.INDENTERS["bar"][0]
FREQUENCIES = (20.0, 30.0, 50.0, 80.0)   # Hz
STEPS_PER_PERIOD = 20
CYCLES = 3
#: The two waveforms (issue 35, item 2). ``sine`` (default) follows the thesis's own example of a deepest point,
#: t = 0.005 s at 50 Hz = T/4: the plane starts at the skin and moves as A sin(2 pi f t), so it is deepest at
#: t = (k + 1/4) / f with peak velocity 2 pi f A; while the plane is above the undeformed surface (d < 0) it
#: touches nothing (the contact opens, as a contact analysis does; the skin is free). ``haversine`` is the
#: earlier reading, A (1 - cos) / 2, deepest at T/2 with half the peak velocity, which the example contradicts.
WAVEFORMS = {
    "sine": "d(t) = A sin(2 pi f t), A = 0.5 mm, from rest: deepest at t = (k + 1/4) / f (the thesis's example: "
            "t = 0.005 s at 50 Hz); for d < 0 the plane is above the skin and touches nothing (contact open)",
    "haversine": "d(t) = A (1 - cos(2 pi f t)) / 2, A = 0.5 mm: from rest, 0 -> 0.5 mm -> 0 each cycle, deepest at "
                 "t = (k + 1/2) / f",
}
WAVEFORM_KIND = "sine"
WAVEFORM = WAVEFORMS[WAVEFORM_KIND]


def depth(t, f: float, kind: str | None = None) -> np.ndarray:
    """Punch depth (mm, > 0 into the skin) at times ``t`` (s) of the waveform ``kind`` (:data:`WAVEFORMS`)."""
    phase = 2.0 * np.pi * f * np.asarray(t, dtype=float)
    if (kind or WAVEFORM_KIND) == "sine":
        return AMPLITUDE * np.sin(phase)
    return AMPLITUDE * 0.5 * (1.0 - np.cos(phase))


#: The grid: make_chapter4's coarse grid (``build_ch4_mesh(model, quick=True)``: 30,240 hexahedra on the whole
#: block, 7,560 on the quarter, 27,600 dofs; one sparse LU of the step's matrix ~8 s, a step ~0.2 s). Its
#: production grid (quick=False: 120,384 / 30,096 hexahedra, 102,312 dofs on the quarter) was measured and not
#: taken: one LU 525 s and 7.6 GB (two per series), AMG-CG ~20 s a step (sample_sed/README.md, "Vibration series").
QUICK_GRID = True


def build_model(model: str, quick: bool = False):
    """The symmetric quarter (x >= c, z >= c) of the chapter-4 ridged block "3d" or "2d" of make_chapter4.py
    (its geometry, imported) on the grid :data:`QUICK_GRID`, with the quarter's share of the RA-I table as
    receptors (:func:`quarter_tips`). The block, its bottom-edge restraint and the 2 x 2 mm plane are
    mirror-symmetric about x = c and z = c, so the quarter with its symmetry planes held
    (make_chapter4.symmetry_planes) is exact. ``quick`` changes nothing here: the quick run takes fewer cycles
    and frequencies instead."""
    return quarter_tips(mc.build_ch4_mesh(model, quick=QUICK_GRID, quarter=True))


def quarter_tips(sm):
    """``sm`` (a quarter x >= c, z >= c) with the papilla tips of make_chapter4's RA-I table that lie on it as
    receptors: x, z = c + 0.11, 0.33, ..., 0.99 mm (make_chapter4.tip_coords: pitch 0.22 mm), 5 x 5, ordered by
    x then z; each a node of the epidermis/dermis interface at the tip height."""
    t = mc.tip_coords(sm.xc, mc.TABLE_N // 2)
    t = t[t >= sm.xc - ms.TOL]
    X, Z = np.meshgrid(t, t, indexing="ij")
    nodes = ms.interface_nodes(sm, X.ravel(), Z.ravel())
    tips = sm.mesh.p[:, nodes].T.copy()
    assert np.allclose(tips[:, 1], mc.Y_TIP), "a table tip is not at the papilla tip height"
    return replace(sm, tips=tips, tip_nodes=nodes)


def dermis_side(sm, cell_sed: np.ndarray, vol: np.ndarray) -> np.ndarray:
    """SED (MPa) at the receptor nodes of ``sm``: the volume-weighted mean over their adjacent **dermis**
    elements (what afferent.sample_sed(..., side=2) reads from the cell SED of the export)."""
    return ms.nodal_average(sm.mesh, cell_sed, vol, cells=sm.layer == ms.LAYER_DERMIS)[sm.tip_nodes]


def write_cropped(path: Path, sm, node_sed: np.ndarray, cell_sed: np.ndarray) -> None:
    """One step on the hexahedra around the receptors of ``sm`` (crop_to_receptors): point SED (the
    volume-weighted average of the adjacent elements), cell SED (MPa, float32) and cell ``layer`` (int32,
    1 epidermis, 2 dermis, 3 subcutis), written to a temporary name and renamed."""
    full = meshio.Mesh(np.ascontiguousarray(sm.mesh.p.T), [("hexahedron", ms._cells(sm))],
                       point_data={"SED": node_sed.astype(np.float32)},
                       cell_data={"SED": [cell_sed.astype(np.float32)], "layer": [sm.layer.astype(np.int32)]})
    small = ms.crop_to_receptors(full, sm.tip_nodes)
    tmp = path.with_name(path.stem + ".part.vtu")
    meshio.write(str(tmp), small, file_format="vtu", binary=True, compression="zlib")
    os.replace(tmp, path)


def run_series(vp: ViscoPunch, f: float, out: Path, cycles: int, force_factor: float = 4.0) -> dict:
    """One frequency: solve every step, write the PVD series, return the run record of the series.
    ``force_factor``: the whole block's punch force over the solved part's (4 on the quarter)."""
    dt = 1.0 / (f * STEPS_PER_PERIOD)
    t0 = time.perf_counter()
    vp.start(dt)
    sm = vp.sm
    t_setup = time.perf_counter() - t0
    times = np.round(np.arange(cycles * STEPS_PER_PERIOD + 1) * dt, 12)
    out.mkdir(parents=True, exist_ok=True)
    files, steps = [], []
    for k, t in enumerate(times):
        d = float(depth(t, f))
        u, info = vp.step(WIDTH, d)
        csed = vp.cell_sed()
        nsed = vp.post.nodal_sed(csed)
        name = f"vib_{k:03d}.vtu"
        write_cropped(out / name, sm, nsed, csed)
        files.append(name)
        tips = dermis_side(sm, csed, vp.post.vol) * 1e6
        steps.append({"t_s": float(t), "depth_mm": d, "punch_force_N": force_factor * info["punch_force_N"],
                      "factor_s": info["amg_setup_s"], "solve_s": info["solve_s"],
                      "tip_SED_Pa": [round(float(v), 6) for v in tips]})
    ms.write_pvd(out / "vib.pvd", files, times)
    return {"frequency_Hz": f, "dt_s": dt, "n_steps": len(times), "setup_s": round(t_setup, 2),
            "solve_and_write_s": round(time.perf_counter() - t0 - t_setup, 2),
            "lu_factorizations_s": round(sum(s_["factor_s"] for s_ in steps), 2),
            "algorithmic_shear_over_G0": vp.step_rule.algorithmic, "steps": steps}


def deepest_summary(sm, series: dict) -> dict:
    """SED (Pa, the dermis side) at the edge tip with the largest SED at the last deepest point, per cycle's
    deepest point."""
    steps = series["steps"]
    at = STEPS_PER_PERIOD // 4 if WAVEFORM_KIND == "sine" else STEPS_PER_PERIOD // 2   # the waveform's deepest step
    deep = [k for k in range(len(steps)) if k % STEPS_PER_PERIOD == at]
    tips = sm.tips
    edge = edge_tips(tips, sm.xc, sm.zc)
    last = np.asarray(steps[deep[-1]]["tip_SED_Pa"])
    i = int(np.flatnonzero(edge)[np.argmax(last[edge])])
    return {"site": {"index": i, "x": float(tips[i, 0]), "z": float(tips[i, 2])},
            "deepest_t_s": [steps[k]["t_s"] for k in deep],
            "site_SED_Pa": [steps[k]["tip_SED_Pa"][i] for k in deep],
            "max_tip_SED_Pa": [max(steps[k]["tip_SED_Pa"]) for k in deep],
            "force_N": [steps[k]["punch_force_N"] for k in deep],
            "min_force_N": min(s["punch_force_N"] for s in steps)}


#: The band around the plane's outline the site is chosen from (mm): one tip pitch (make_chapter4.RIDGE_PITCH,
#: 0.22), as the package chooses it (afferent.findings.VIBRATION_EDGE_MM, the vibration scenes' cycles_edge_mm).
EDGE_BAND = mc.RIDGE_PITCH


def edge_tips(tips: np.ndarray, xc: float, zc: float) -> np.ndarray:
    """Tips within EDGE_BAND (mm) of the plane's outline (the rule of afferent.cycles.edge_sites)."""
    h, w = 0.5 * WIDTH, EDGE_BAND + ms.TOL
    dx, dz = np.abs(tips[:, 0] - xc) - h, np.abs(tips[:, 2] - zc) - h
    return ((np.abs(dx) <= w) & (dz <= w)) | ((np.abs(dz) <= w) & (dx <= w))


def quarter_check(model: str, f: float, n_steps: int, log=print) -> dict:
    """The quarter against the whole block: the first ``n_steps`` steps at ``f`` (Hz) solved on both (the whole
    block by AMG-CG: its sparse LU would take ~10 min and ~8 GB), the dermis-side SED at the quarter's tips and
    the whole block's punch force compared. Returns the largest differences, relative to the largest tip SED
    and to the force, of every step."""
    q = build_model(model)
    whole = mc.build_ch4_mesh(model, quick=QUICK_GRID)
    key = {(round(x, 7), round(z, 7)): n for n, (x, z) in zip(whole.tip_nodes, whole.tips[:, [0, 2]])}
    whole = replace(whole, tips=q.tips, tip_nodes=np.array([key[(round(x, 7), round(z, 7))] for x, z in q.tips[:, [0, 2]]]))
    dt = 1.0 / (f * STEPS_PER_PERIOD)
    runs = {}
    for name, sm, fixed, solver, factor in (("quarter", q, mc.symmetry_planes(q.xc), "lu", 4.0),
                                            ("whole", whole, None, "amg", 1.0)):
        t0 = time.perf_counter()
        vp = ViscoPunch(sm, SKIN, fixed=fixed, solver=solver).start(dt)
        sed, force = [], []
        for k in range(n_steps):
            _, info = vp.step(WIDTH, float(depth(k * dt, f)))
            sed.append(dermis_side(sm, vp.cell_sed(), vp.post.vol) * 1e6)
            force.append(factor * info["punch_force_N"])
        runs[name] = (np.array(sed), np.array(force), round(time.perf_counter() - t0, 1))
        log(f"  [{model} {f:g} Hz, {n_steps} steps] {name}: {runs[name][2]} s")
    (sq, fq, tq), (sw, fw, tw) = runs["quarter"], runs["whole"]
    return {"model": model, "frequency_Hz": f, "n_steps": n_steps, "quarter_s": tq, "whole_s": tw,
            "max_tip_SED_Pa": float(sw.max()),
            "tip_SED_max_abs_diff_over_max": float(np.abs(sq - sw).max() / sw.max()),
            "force_max_abs_diff_over_max": float(np.abs(fq - fw).max() / np.abs(fw).max())}


def main(argv=None):
    global WAVEFORM_KIND, WAVEFORM
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse mesh, 2 cycles at 20 and 80 Hz, into a temp dir")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default sample_sed/vibration)")
    ap.add_argument("--models", nargs="+", choices=mc.MODELS, default=list(mc.MODELS))
    ap.add_argument("--frequencies", nargs="+", type=float, default=None, help="Hz")
    ap.add_argument("--check-quarter", type=int, default=None, metavar="N",
                    help="also solve the first N steps at the first frequency on the whole block and compare with the "
                         "quarter (written to quarter_check.json; default with --quick: 7 steps)")
    ap.add_argument("--waveform", choices=list(WAVEFORMS), default=WAVEFORM_KIND,
                    help="sine: the thesis's example (deepest at T/4, default); haversine: the earlier reading")
    args = ap.parse_args(argv)
    WAVEFORM_KIND, WAVEFORM = args.waveform, WAVEFORMS[args.waveform]
    here = Path(__file__).resolve().parent
    out = args.out or (Path(tempfile.gettempdir()) / "afferent_vibration_quick" if args.quick else here / "vibration")
    freqs = args.frequencies or ((20.0, 80.0) if args.quick else FREQUENCIES)
    cycles = 2 if args.quick else CYCLES
    out.mkdir(parents=True, exist_ok=True)
    info = run_info(args.quick, freqs, cycles)
    n_check = args.check_quarter if args.check_quarter is not None else (7 if args.quick else 0)
    if n_check > 0:
        chk = quarter_check(args.models[0], freqs[0], n_check)
        print(f"quarter vs whole block ({chk['model']}, {chk['frequency_Hz']:g} Hz, {n_check} steps): tip SED "
              f"{chk['tip_SED_max_abs_diff_over_max']:.2g}, force {chk['force_max_abs_diff_over_max']:.2g} "
              "(largest difference over the largest value)", flush=True)
        (out / "quarter_check.json").write_text(json.dumps(chk, indent=1) + "\n")
    for model in args.models:
        t0 = time.perf_counter()
        sm = build_model(model)
        if model == args.models[0]:
            ms.write_receptors(out / "receptors.csv", sm)
        vp = ViscoPunch(sm, SKIN, fixed=mc.symmetry_planes(sm.xc))
        whole = mc.build_ch4_mesh(model, quick=QUICK_GRID)
        binfo = {"mesh": ms.mesh_stats(sm) | {"solved": "quarter x >= c, z >= c (symmetry planes held)",
                                              "whole_block_elements": int(whole.mesh.t.shape[1]),
                                              "whole_block_nodes": int(whole.mesh.p.shape[1])},
                 "mesh_and_assembly_s": round(time.perf_counter() - t0, 2), "series": {}}
        for f in freqs:
            tag = f"{model}_{f:g}Hz"
            rec = run_series(vp, f, out / tag, cycles)
            rec["deepest"] = deepest_summary(sm, rec)
            binfo["series"][tag] = rec
            d = rec["deepest"]
            print(f"[{tag}] {rec['n_steps']} steps, solve+write {rec['solve_and_write_s']} s "
                  f"(LU {rec['lu_factorizations_s']} s); "
                  f"site ({d['site']['x']:.2f}, {d['site']['z']:.2f}) SED at deepest points "
                  f"{', '.join(f'{v:.1f}' for v in d['site_SED_Pa'])} Pa; min force {d['min_force_N']:.4f} N",
                  flush=True)
        info["models"][model] = binfo
    old = out / "build_info.json"
    if old.is_file():   # a run of the other model into the same folder: keep its record
        for k, v in json.loads(old.read_text()).get("models", {}).items():
            info["models"].setdefault(k, v)
    info["files"] = {p.relative_to(out).as_posix(): p.stat().st_size for p in sorted(out.rglob("*"))
                     if p.is_file() and p.suffix in (".vtu", ".pvd", ".csv")}
    info["total_size_MB"] = round(sum(info["files"].values()) / 1e6, 2)
    tmp = out / "build_info.json.part"
    tmp.write_text(json.dumps(info, indent=1) + "\n")
    os.replace(tmp, out / "build_info.json")
    print(f"data {info['total_size_MB']} MB -> {out}")


def run_info(quick: bool, freqs, cycles: int) -> dict:
    """The run record's header: versions, material, waveform, time steps, closed-form moduli."""
    import pyamg
    import scipy
    import skfem

    w = 2.0 * np.pi * np.asarray(freqs)
    gs = complex_modulus(SKIN, w)
    return {
        "generator": "sample_sed/make_vibration.py" + (" --quick" if quick else ""),
        "versions": {"python": platform.python_version(), "scikit-fem": skfem.__version__,
                     "meshio": meshio.__version__, "numpy": np.__version__, "scipy": scipy.__version__,
                     "pyamg": pyamg.__version__},
        "units": {"length": "mm", "stress": "MPa", "SED": "MPa", "force": "N", "time": "s"},
        "material": {"prony_g": list(SKIN.g), "prony_tau_s": list(SKIN.tau), "g_inf": SKIN.g_inf,
                     "applies_to": "dermis and subcutis (shear modulus); epidermis elastic; bulk modulus elastic",
                     "G0": "instantaneous: E / (2 (1 + nu)) of the layer table", "source": SKIN.source,
                     "abs_G_star_over_G0": {f"{f:g}Hz": float(abs(g)) for f, g in zip(freqs, gs)},
                     "loss_angle_deg": {f"{f:g}Hz": float(np.degrees(np.angle(g))) for f, g in zip(freqs, gs)}},
        "waveform": WAVEFORM, "width_mm": WIDTH, "steps_per_period": STEPS_PER_PERIOD, "cycles": cycles,
        "sed": "stored (recoverable) strain energy density at the element centroid (stored_sed: springs of "
               "the generalized Maxwell model; 1/2 sigma:eps in the elastic epidermis): cell data SED float32 in "
               "MPa with cell data layer (int32, 1 epidermis, 2 dermis, 3 subcutis); averaged to the nodes "
               "(volume-weighted, as make_samples.py): point data SED float32 in MPa",
        "tip_SED_Pa": "at each receptor, the dermis side: volume-weighted mean of the cell SED of its adjacent "
                      "dermis elements (afferent.sample_sed(..., side=2) on the cell data)",
        "punch_force_N": "the whole block's (4 x the quarter's)",
        "geometry": "make_chapter4.py (build_ch4_mesh, quick grid), solved on the quarter x >= c, z >= c; "
                    "receptors: the quarter's 5 x 5 tips of the RA-I table, x, z = c + 0.11 ... 0.99 mm",
        "crop": "hexahedra with a receptor (papilla-tip) node among their corners (make_samples.crop_to_receptors)",
        "site": "the edge tip (within 0.22 mm of the plane's outline) with the largest dermis-side SED at the "
                "last deepest point",
        "models": {},
    }


if __name__ == "__main__":
    main()
