#!/usr/bin/env python
"""Regenerate the finite-element sample data in ``sample_sed/``.

A linear-elastic, three-layer block of fingertip skin (docs/method.md, "1. The FE skin model") with
fingerprint ridges on the surface and dermal papillae on the epidermis/dermis
interface is indented by a rigid, frictionless flat square punch.  As in the study, only the four
edges of the bottom face are restrained (``--bottom face`` fixes the whole bottom face instead, the
condition of the sample before issue 21, for comparison).  The problem is
solved with scikit-fem (trilinear 8-node hexahedra with selective reduced integration
on a structured, mapped mesh; AMG-preconditioned CG from pyamg), post-processed to element-centroid stress/strain/SED and nodal SED, and exported
with meshio in the formats listed in ``sample_sed/README.md``.

Units: mm, MPa, N (so SED is in MPa = mJ/mm^3; 1 MPa = 1e6 J/m^3 = 1e6 Pa).
Axes: x across the ridges, y up (thickness, bottom at y = 0), z along the ridges.

Usage::

    python sample_sed/make_samples.py            # full data set into sample_sed/
    python sample_sed/make_samples.py --quick    # coarse smoke run into a temp dir
    python sample_sed/make_samples.py --check-mesh      # + 2x-refined mesh comparison
    python sample_sed/make_samples.py --packaged # only rewrite afferent/data/sample/ (a crop, no solve)
    python sample_sed/make_samples.py --only block4 --out DIR   # one block only (DIR: not sample_sed/)

Requirements: ``pip install -e .[samples]`` (scikit-fem, pyamg, meshio, numpy, scipy).
The run is deterministic (fixed solver settings; pyamg's random start vectors seeded).  The only
run-dependent text is the date line of the COMSOL-style CSV (set SOURCE_DATE_EPOCH
to pin it) and the timings in build_info.json.
"""
from __future__ import annotations

import os

# Single-threaded BLAS: the solver is sparse (pyamg/scipy); threaded BLAS only adds
# oversubscription on a shared 2-core machine and run-to-run bit differences.
for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse
import datetime as _dt
import json
import platform
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import meshio
import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg  # noqa: F401  (sp.linalg)
import skfem
from skfem import Basis, BilinearForm, ElementHex1, ElementVector, Functional, MeshHex
from skfem.helpers import ddot, sym_grad, trace
from skfem.io.meshio import to_meshio

try:
    import pyamg
except ImportError:  # pragma: no cover - pyamg is in the `samples` extra
    pyamg = None

# --------------------------------------------------------------------------------------
# Model constants (docs/method.md, "1. The FE skin model").  Lengths mm, moduli MPa.
# --------------------------------------------------------------------------------------
LAYER_EPIDERMIS, LAYER_DERMIS, LAYER_SUBCUTIS = 1, 2, 3
LAYER_NAMES = {1: "epidermis", 2: "dermis", 3: "subcutis"}
YOUNG = {LAYER_EPIDERMIS: 0.136, LAYER_DERMIS: 0.08, LAYER_SUBCUTIS: 0.034}  # MPa
NU = 0.48

T_SUBCUTIS, T_DERMIS, T_EPIDERMIS = 1.0, 1.35, 0.75
Y_DERMIS_BOTTOM = T_SUBCUTIS                      # 1.00 mm
Y_INTERFACE = T_SUBCUTIS + T_DERMIS               # 2.35 mm: base of the papillae
Y_SURFACE = Y_INTERFACE + T_EPIDERMIS             # 3.10 mm: nominal (mean) surface

RIDGE_PITCH = 0.44        # surface ridges, along x; they run along z
RIDGE_RELIEF = 0.06       # peak-to-valley of the cosine surface relief

PAP_PITCH_X = 0.44        # one papilla row per ridge, rows run along z
PAP_PITCH_Z = 0.22
PAP_HALF_X = 0.11         # footprint 0.22 (x) x 0.11 (z)
PAP_HALF_Z = 0.055
PAP_HEIGHT = 0.10         # apex 0.10 mm above the interface base -> y_tip = 2.45 mm

DEPTH = 0.5               # punch displacement
BLOCK4_WIDTHS = (0.44, 0.66, 0.88, 1.10, 1.32, 2.00)
BLOCK8_WIDTHS = (4.00,)
SERIES_WIDTH = 0.88
SERIES_TIMES = np.round(np.arange(6) * 0.02, 10)        # s
SERIES_DEPTHS = np.round(SERIES_TIMES / 0.1 * DEPTH, 10)  # 0, 0.1, ..., 0.5 mm

CG_TOL = 1e-10            # relative residual of the preconditioned CG
LU_CACHE = 6              # sparse LU factorizations kept (solver='lu')
TOL = 1e-9                # geometric tolerance (mm)
CENTROID_RULE = (np.full((3, 1), 0.5), np.array([1.0]))   # skfem's reference hex is [0, 1]^3


def width_tag(w: float) -> str:
    """0.88 -> '0p88mm'."""
    return f"{w:.2f}".replace(".", "p") + "mm"


# --------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------
def bump(s: np.ndarray) -> np.ndarray:
    """Smooth (C1) 1-D bump: cos^2(pi s / 2) on |s| < 1, 0 outside; bump(0) = 1."""
    s = np.asarray(s, dtype=float)
    return np.where(np.abs(s) < 1.0, np.cos(0.5 * np.pi * s) ** 2, 0.0)


def surface_y(x: np.ndarray, xc: float) -> np.ndarray:
    """Skin surface: cosine ridges, crests at x = xc + k * RIDGE_PITCH."""
    return Y_SURFACE + 0.5 * RIDGE_RELIEF * np.cos(2.0 * np.pi * (x - xc) / RIDGE_PITCH)


def interface_y(x: np.ndarray, z: np.ndarray, xc: float, zc: float) -> np.ndarray:
    """Epidermis/dermis interface: flat base at Y_INTERFACE plus one papilla per cell.

    Papilla tips at (xc + k * PAP_PITCH_X, zc + m * PAP_PITCH_Z), i.e. each papilla row
    lies directly under a ridge crest (see README for the anatomical simplification).
    """
    dx = np.mod(x - xc + 0.5 * PAP_PITCH_X, PAP_PITCH_X) - 0.5 * PAP_PITCH_X
    dz = np.mod(z - zc + 0.5 * PAP_PITCH_Z, PAP_PITCH_Z) - 0.5 * PAP_PITCH_Z
    return Y_INTERFACE + PAP_HEIGHT * bump(dx / PAP_HALF_X) * bump(dz / PAP_HALF_Z)


def graded(n: int, ratio: float, grow: str) -> np.ndarray:
    """n+1 parameters in [0, 1]; element sizes a geometric series with `ratio`.

    grow='up': sizes increase with the parameter (finest at 0); 'down': finest at 1.
    """
    h = ratio ** np.arange(n, dtype=float)
    if grow == "down":
        h = h[::-1]
    s = np.concatenate([[0.0], np.cumsum(h)])
    return s / s[-1]


def axis_lines(length, centre, pitch, half, fine_rows, n_half_in, n_gap, required):
    """Grid lines of one in-plane axis (x or z).

    Papilla "rows" sit at centre + k * pitch.  For |k| <= fine_rows a line goes through
    the tip, the papilla footprint (tip +- half) is split into 2 * n_half_in elements
    and the gap between footprints into n_gap elements.  Elsewhere (coarse zone) only
    the tips and the gap mid-points are lines.  `required` lines (indenter edges) are
    enforced by moving the nearest non-tip line onto them (if close) or inserting them.
    """
    kmax = int(np.ceil(length / pitch)) + 1
    lines, tips = [], []
    gap = pitch - 2.0 * half
    for k in range(-kmax, kmax + 1):
        tip = centre + k * pitch
        tips.append(tip)
        if abs(k) <= fine_rows:
            lines.extend(tip + np.linspace(-half, half, 2 * n_half_in + 1))
            lines.extend(tip + half + gap * np.arange(1, n_gap) / n_gap)
            lines.extend(tip - half - gap * np.arange(1, n_gap) / n_gap)
        else:
            lines.extend([tip - 0.5 * pitch, tip, tip + 0.5 * pitch])
    lines = np.unique(np.round(np.asarray(lines), 9))

    def h_local(a, i):
        return min(a[i] - a[i - 1] if i > 0 else np.inf, a[i + 1] - a[i] if i < len(a) - 1 else np.inf)

    # clip to the block and drop lines too close to the side faces
    lines = lines[(lines > TOL) & (lines < length - TOL)]
    lines = np.concatenate([[0.0], lines, [length]])
    keep = np.ones(len(lines), bool)
    for i in (1, len(lines) - 2):
        if 0 < i < len(lines) - 1:
            other = 0 if i == 1 else len(lines) - 1
            spacing = abs(lines[i + (1 if i == 1 else -1)] - lines[i])
            if abs(lines[i] - lines[other]) < 0.4 * spacing:
                keep[i] = False
    lines = lines[keep]
    tips = np.round(np.asarray(tips), 9)
    for r in sorted(required):
        r = round(r, 9)
        if np.min(np.abs(lines - r)) < TOL:
            continue
        order = np.argsort(np.abs(lines - r))
        moved = False
        for i in order[:3]:
            is_tip = np.min(np.abs(tips - lines[i])) < TOL
            if is_tip or i == 0 or i == len(lines) - 1:
                continue
            if abs(lines[i] - r) < 0.4 * h_local(lines, i):
                lines[i] = r
                moved = True
            break
        if not moved:
            lines = np.sort(np.append(lines, r))
    return np.asarray(lines, dtype=float)


@dataclass
class MeshSpec:
    name: str
    length: float                 # block size in x and z
    widths: tuple
    fine_rows_x: int              # papilla rows (each side of the centre) in the fine zone
    fine_rows_z: int
    n_half_in_x: int              # elements per papilla half-footprint
    n_gap_x: int
    n_half_in_z: int
    n_gap_z: int
    n_sub: int                    # element layers per tissue layer
    n_derm: int
    n_epi: int
    derm_ratio: float = 1.5       # geometric grading (finest at the interface)
    epi_ratio: float = 1.2
    refine: int = 1               # split every element into refine^3 (mesh-convergence check)


@dataclass
class SkinMesh:
    spec: MeshSpec
    mesh: MeshHex
    layer: np.ndarray             # (n_elem,) 1 epidermis, 2 dermis, 3 subcutis
    node_j: np.ndarray            # (n_nodes,) node layer index in y (0 = bottom)
    j_interface: int
    j_top: int
    xc: float
    zc: float
    xlines: np.ndarray
    zlines: np.ndarray
    tips: np.ndarray = field(default=None)        # (n_tip, 3) receptor coordinates
    tip_nodes: np.ndarray = field(default=None)   # (n_tip,) node index of each tip


def subdivide(a: np.ndarray, r: int) -> np.ndarray:
    """Split every interval of the sorted array `a` into r equal parts."""
    if r == 1:
        return a
    f = np.arange(r) / r
    return np.concatenate([(a[:-1, None] + np.diff(a)[:, None] * f[None, :]).ravel(), a[-1:]])


def layered_mesh(spec: MeshSpec, xl: np.ndarray, zl: np.ndarray, interface, xc: float, zc: float) -> SkinMesh:
    """Structured hexahedral mesh on the grid lines ``xl`` x ``zl`` (mm), layered in y.

    Each column's nodes lie between the bottom (y = 0), the dermis bottom, the
    epidermis/dermis interface ``interface(x, z)`` (mm) and the ridged surface ``surface_y``, so
    the layer interfaces and the surface are node surfaces and each element lies in one layer.
    ``spec`` gives the element layers per tissue layer, their grading and ``refine``. The
    receptor tips (``tips``, ``tip_nodes``) are left for the caller to set.
    """
    r = spec.refine
    xl, zl = subdivide(xl, r), subdivide(zl, r)
    ny = r * (spec.n_sub + spec.n_derm + spec.n_epi)
    m0 = MeshHex.init_tensor(xl, np.arange(ny + 1, dtype=float), zl)
    p = m0.p.copy()
    j = np.rint(p[1]).astype(int)
    x, z = p[0], p[2]
    y_int = interface(x, z)
    y_srf = surface_y(x, xc)
    s_sub = subdivide(np.linspace(0.0, 1.0, spec.n_sub + 1), r)
    s_derm = subdivide(graded(spec.n_derm, spec.derm_ratio, "down"), r)   # finest at the interface
    s_epi = subdivide(graded(spec.n_epi, spec.epi_ratio, "up"), r)        # finest at the interface
    j1, j2 = r * spec.n_sub, r * (spec.n_sub + spec.n_derm)
    y = np.empty_like(x)
    a = j <= j1
    y[a] = Y_DERMIS_BOTTOM * s_sub[j[a]]
    b = (j > j1) & (j <= j2)
    y[b] = Y_DERMIS_BOTTOM + (y_int[b] - Y_DERMIS_BOTTOM) * s_derm[j[b] - j1]
    c = j > j2
    y[c] = y_int[c] + (y_srf[c] - y_int[c]) * s_epi[j[c] - j2]
    p[1] = y
    mesh = MeshHex(p, m0.t)
    jb = j[mesh.t].min(axis=0)
    layer = np.where(jb < j1, LAYER_SUBCUTIS, np.where(jb < j2, LAYER_DERMIS, LAYER_EPIDERMIS))
    return SkinMesh(spec, mesh, layer.astype(np.int32), j, j2, ny, xc, zc, xl, zl)


def interface_nodes(sm: SkinMesh, x, z) -> np.ndarray:
    """Index of the epidermis/dermis interface node at each (x, z) (mm); KeyError if not a node."""
    p = sm.mesh.p
    iface = np.flatnonzero(sm.node_j == sm.j_interface)
    key = {(round(p[0, n], 7), round(p[2, n], 7)): n for n in iface}
    return np.array([key[(round(a_, 7), round(b_, 7))] for a_, b_ in zip(x, z)], dtype=np.int64)


def build_mesh(spec: MeshSpec) -> SkinMesh:
    L = spec.length
    xc = zc = 0.5 * L
    req = sorted({xc + s * 0.5 * w for w in spec.widths for s in (-1, 1)})
    xl = axis_lines(L, xc, PAP_PITCH_X, PAP_HALF_X, spec.fine_rows_x,
                    spec.n_half_in_x, spec.n_gap_x, req)
    zl = axis_lines(L, zc, PAP_PITCH_Z, PAP_HALF_Z, spec.fine_rows_z,
                    spec.n_half_in_z, spec.n_gap_z, req)
    sm = layered_mesh(spec, xl, zl, lambda x, z: interface_y(x, z, xc, zc), xc, zc)
    p = sm.mesh.p
    # papilla tips (receptor sites) at least one pitch from the side faces
    kx = np.arange(-int(L / PAP_PITCH_X) - 1, int(L / PAP_PITCH_X) + 2)
    kz = np.arange(-int(L / PAP_PITCH_Z) - 1, int(L / PAP_PITCH_Z) + 2)
    tx = np.round(xc + kx * PAP_PITCH_X, 9)
    tz = np.round(zc + kz * PAP_PITCH_Z, 9)
    tx = tx[(tx >= PAP_PITCH_X - TOL) & (tx <= L - PAP_PITCH_X + TOL)]
    tz = tz[(tz >= PAP_PITCH_Z - TOL) & (tz <= L - PAP_PITCH_Z + TOL)]
    TX, TZ = np.meshgrid(tx, tz, indexing="ij")        # ordered by x, then z
    TX, TZ = TX.ravel(), TZ.ravel()
    nodes = interface_nodes(sm, TX, TZ)
    sm.tips = p[:, nodes].T.copy()
    sm.tip_nodes = nodes
    assert np.allclose(sm.tips[:, 1], Y_INTERFACE + PAP_HEIGHT)
    return sm


def mesh_stats(sm: SkinMesh) -> dict:
    m = sm.mesh
    p = m.p[:, m.t]                                  # (3, 8, nel)
    # edge lengths along the three logical directions of the tensor-product hex
    # skfem's MeshHex node order (init_tensor): pairs differing in one index
    ex = np.linalg.norm(p[:, 2] - p[:, 0], axis=0)   # x-direction edge
    ey = np.linalg.norm(p[:, 1] - p[:, 0], axis=0)   # y-direction edge
    ez = np.linalg.norm(p[:, 3] - p[:, 0], axis=0)   # z-direction edge
    hmin_edge = float(np.min([ex.min(), ey.min(), ez.min()]))
    return {
        "n_nodes": int(m.p.shape[1]),
        "n_elements": int(m.t.shape[1]),
        "n_dofs": int(3 * m.p.shape[1]),
        "n_x_elements": int(len(sm.xlines) - 1),
        "n_z_elements": int(len(sm.zlines) - 1),
        "n_y_elements": int(sm.j_top),
        "y_elements_per_layer": {"subcutis": sm.spec.refine * sm.spec.n_sub,
                                 "dermis": sm.spec.refine * sm.spec.n_derm,
                                 "epidermis": sm.spec.refine * sm.spec.n_epi},
        "x_spacing_min_max_mm": [float(np.diff(sm.xlines).min()), float(np.diff(sm.xlines).max())],
        "z_spacing_min_max_mm": [float(np.diff(sm.zlines).min()), float(np.diff(sm.zlines).max())],
        "y_edge_min_max_mm": [float(ey.min()), float(ey.max())],
        "smallest_edge_mm": hmin_edge,
        "elements_per_layer": {LAYER_NAMES[k]: int(np.sum(sm.layer == k)) for k in (1, 2, 3)},
        "n_receptors": int(len(sm.tips)),
    }


# --------------------------------------------------------------------------------------
# FE problem
# --------------------------------------------------------------------------------------
def lame(layer: np.ndarray):
    E = np.vectorize(YOUNG.get)(layer).astype(float)
    lam = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU))
    mu = E / (2.0 * (1.0 + NU))
    return lam, mu


@BilinearForm
def elasticity(u, v, w):
    eu, ev = sym_grad(u), sym_grad(v)
    return 2.0 * w.mu * ddot(eu, ev) + w.lam * trace(eu) * trace(ev)


@BilinearForm
def elasticity_dev(u, v, w):
    """Deviatoric part 2 mu dev(eps(u)) : dev(eps(v))."""
    eu, ev = sym_grad(u), sym_grad(v)
    return 2.0 * w.mu * (ddot(eu, ev) - trace(eu) * trace(ev) / 3.0)


@BilinearForm
def elasticity_vol(u, v, w):
    """Volumetric part kappa tr(eps(u)) tr(eps(v)), kappa = lambda + 2 mu / 3."""
    return w.kappa * trace(sym_grad(u)) * trace(sym_grad(v))


def stiffness(mesh, element, mu, kappa, integration: str = "sri"):
    """Stiffness matrix (CSR, N/mm) of ``mesh`` with per-element shear modulus ``mu`` and bulk modulus
    ``kappa`` (MPa, arrays of n_elements): deviatoric 2x2x2 Gauss, volumetric one point (``sri``) or
    the whole form with 2x2x2 Gauss (``full``, where lambda = kappa - 2 mu / 3).

    The one assembly of the elasticity form in the sample generators, assembled in element chunks to
    bound the memory of the COO triplets.
    """
    mu, kappa = np.asarray(mu, dtype=float), np.asarray(kappa, dtype=float)
    nel = mesh.t.shape[1]
    nbfun = Basis(mesh, element, elements=np.arange(1), intorder=2).Nbfun
    chunk = max(1, int(2.0e7 // nbfun ** 2))
    K = None
    for c0 in range(0, nel, chunk):
        idx = np.arange(c0, min(nel, c0 + chunk))
        b2 = Basis(mesh, element, elements=idx, intorder=2)
        n2 = b2.X.shape[-1]
        if integration == "full":
            lam = kappa - 2.0 * mu / 3.0
            Kc = elasticity.assemble(b2, lam=np.repeat(lam[idx, None], n2, 1),
                                     mu=np.repeat(mu[idx, None], n2, 1))
        elif integration == "sri":
            b1 = Basis(mesh, element, elements=idx, quadrature=CENTROID_RULE)
            Kc = elasticity_dev.assemble(b2, mu=np.repeat(mu[idx, None], n2, 1)) + \
                elasticity_vol.assemble(b1, kappa=kappa[idx, None])
        else:
            raise ValueError(integration)
        K = Kc.tocsr() if K is None else K + Kc.tocsr()
    return K


def square_footprint(width: float):
    """Footprint of the centred square punch of side ``width`` (mm), edges included."""
    h = 0.5 * width + TOL
    return lambda dx, dz: (np.abs(dx) <= h) & (np.abs(dz) <= h)


class Problem:
    """Stiffness matrix and AMG-CG solver of one mesh.

    integration='sri' (default): selective reduced integration of the trilinear hexahedron,
    deviatoric term with 2x2x2 Gauss points, volumetric (bulk) term with one point at the
    element centre (the mean-dilatation / B-bar idea Abaqus uses for its fully integrated
    C3D8); removes the volumetric locking of nu = 0.48 without hourglass modes.
    integration='full': plain 2x2x2 Gauss integration of the whole form (for comparison).
    """

    def __init__(self, sm: SkinMesh, integration: str = "sri", log=print, bottom: str = "edges",
                 moduli=None, solver: str = "amg", fixed=None):
        """``moduli``: optional per-element (mu, kappa) in MPa replacing the layers' elastic values
        (the viscoelastic generator, make_vibration.py, passes its own); ``solver``: 'amg' (CG with
        AMG, the static samples) or 'lu' (sparse LU kept per Dirichlet set, many steps on a small mesh);
        ``fixed``: optional function (dof locations (3, n) mm, dof components (n,) 0/1/2) -> boolean mask
        of further dofs held at zero (the symmetry planes of a quarter model, make_chapter4.py)."""
        if solver not in ("amg", "lu"):
            raise ValueError(f"solver: expected 'amg' or 'lu', got {solver!r}")
        self.solver = solver
        self.sm = sm
        self.log = log
        self.integration = integration
        self.bottom = bottom
        t0 = time.perf_counter()
        self.element = ElementVector(ElementHex1())
        self.basis = Basis(sm.mesh, self.element, intorder=2)
        lam, mu = lame(sm.layer)
        self.lam, self.mu = lam, mu
        kappa = lam + 2.0 * mu / 3.0
        if moduli is not None:
            mu_k, kappa_k = moduli
        else:
            mu_k, kappa_k = mu, kappa
        self.K = stiffness(sm.mesh, self.element, mu_k, kappa_k, integration)
        self.t_assemble = time.perf_counter() - t0
        self.ndof = self.K.shape[0]
        nd = self.basis.nodal_dofs                 # (3, n_nodes) vertex dofs
        self.vdofs = nd
        self.dofloc = self.basis.doflocs           # (3, ndof) location of every dof
        comp = np.full(self.ndof, -1, dtype=int)   # displacement component of every dof (0, 1, 2)
        for k in range(3):
            comp[nd[k]] = k
        assert comp.min() >= 0, "a dof that is not a vertex dof"
        self.comp = comp
        m = sm.mesh
        fj = sm.node_j[m.facets]
        bottom_f = np.flatnonzero(np.all(fj == 0, axis=0))
        top_f = np.flatnonzero(np.all(fj == sm.j_top, axis=0))
        self.bottom_dofs = np.asarray(self.basis.get_dofs(bottom_f).all(), dtype=np.int64)
        if bottom == "edges":
            # the study's condition: only the four edges of the bottom face are restrained
            # (all components); the rest of the bottom face is free
            X = self.dofloc[:, self.bottom_dofs]
            L = 2.0 * sm.xc
            on_edge = (np.abs(X[0]) <= TOL) | (np.abs(X[0] - L) <= TOL) | \
                (np.abs(X[2]) <= TOL) | (np.abs(X[2] - L) <= TOL)
            self.bottom_dofs = self.bottom_dofs[on_edge]
        elif bottom != "face":
            raise ValueError(bottom)
        if fixed is not None:
            self.bottom_dofs = np.union1d(self.bottom_dofs,
                                          np.flatnonzero(fixed(self.dofloc, self.comp))).astype(np.int64)
        self.top_ydofs = np.asarray(self.basis.get_dofs(top_f).all("u^2"), dtype=np.int64)
        self._ml_cache = {}
        log(f"  assembled K: {self.ndof} dofs, nnz {self.K.nnz}, {self.t_assemble:.1f} s")

    def top_dofs_in(self, footprint):
        """y-dofs of the surface nodes inside ``footprint(dx, dz)`` (mm from the block centre, boolean)."""
        X = self.dofloc[:, self.top_ydofs]
        return self.top_ydofs[footprint(X[0] - self.sm.xc, X[2] - self.sm.zc)]

    def top_dofs_in_square(self, width: float):
        """y-dofs of surface dofs whose (x, z) lies inside the centred square (inclusive)."""
        return self.top_dofs_in(square_footprint(width))

    def _amg_solve(self, A, b, start, key):
        """CG with smoothed-aggregation AMG on the eliminated system; the hierarchy of the last
        Dirichlet set is kept. Returns (u, CG iterations, setup seconds)."""
        t1 = time.perf_counter()
        if key in self._ml_cache:
            ml = self._ml_cache[key]
            t_setup = 0.0
        else:
            # pyamg estimates spectral radii from np.random start vectors: seed it so
            # that every solve is reproducible bit for bit, whatever ran before
            np.random.seed(20240521)
            ml = pyamg.smoothed_aggregation_solver(
                A.tobsr(blocksize=(3, 3)), B=self.rigid_body_modes(np.arange(self.ndof)),
                symmetry="symmetric", smooth="energy", max_coarse=1000)
            self._ml_cache = {key: ml}
            t_setup = time.perf_counter() - t1
        res = []
        u = ml.solve(b, x0=start, tol=CG_TOL, accel="cg", maxiter=3000, residuals=res)
        return u, len(res) - 1, t_setup

    def _lu_solve(self, mask, b, x0, key):
        """Sparse LU (SuperLU, COLAMD) of the free-dof block, kept for the last LU_CACHE Dirichlet
        sets (the many time steps of make_vibration.py on a small mesh). Returns (u, 0, factor seconds)."""
        t1 = time.perf_counter()
        free = np.flatnonzero(~mask)
        lu = self._ml_cache.get(key)
        if lu is None:
            lu = sp.linalg.splu(self.K[free][:, free].tocsc(), permc_spec="COLAMD")
            while len(self._ml_cache) >= LU_CACHE:
                self._ml_cache.pop(next(iter(self._ml_cache)))
            self._ml_cache[key] = lu
        t_setup = time.perf_counter() - t1
        u = x0.copy()
        u[free] = lu.solve(b[free])
        return u, 0, t_setup

    def set_stiffness(self, K):
        """Replace the stiffness matrix (same mesh and dofs) and forget the cached solvers."""
        self.K = K
        self._ml_cache = {}

    def rigid_body_modes(self, idx):
        X = self.dofloc[:, idx] - np.array([[self.sm.xc], [Y_SURFACE / 2], [self.sm.zc]])
        c = self.comp[idx]
        B = np.zeros((len(idx), 6))
        for k in range(3):
            B[c == k, k] = 1.0
        x, y, z = X
        # rotations about z, x, y
        B[c == 0, 3], B[c == 1, 3] = -y[c == 0], x[c == 1]
        B[c == 1, 4], B[c == 2, 4] = -z[c == 1], y[c == 2]
        B[c == 2, 5], B[c == 0, 5] = -x[c == 2], z[c == 0]
        return B

    def solve(self, width: float, depth: float, footprint=None, f=None, guess=None):
        """Punch of `width` (mm) pressed `depth` (mm): returns (u, info).

        ``footprint(dx, dz)`` (boolean, mm from the block centre) gives the indenter's shape; by
        default the centred square of side ``width``. ``f``: optional nodal force vector (N) on the
        free dofs (the viscoelastic history force of make_vibration.py); ``guess``: optional start
        vector of the CG (its prescribed dofs are reset).
        """
        t0 = time.perf_counter()
        top = self.top_dofs_in(footprint or square_footprint(width))
        y_top = self.dofloc[1, top]
        y_crest = float(surface_y(np.array([self.sm.xc]), self.sm.xc)[0])  # highest ridge top
        plane = y_crest - depth
        # full contact under the footprint: every surface node that the punch plane reaches
        # (all of them once depth >= RIDGE_RELIEF) is brought to the plane.
        touched = y_top >= plane - TOL
        top, y_top = top[touched], y_top[touched]
        D = np.concatenate([self.bottom_dofs, top])
        x0 = np.zeros(self.ndof)
        x0[top] = plane - y_top
        f = np.zeros(self.ndof) if f is None else f
        key = tuple(np.sort(D))
        u = x0.copy()
        iters = 0
        if np.any(x0 != 0.0) or np.any(f != 0.0):
            # symmetric elimination of the Dirichlet dofs, keeping the 3x3 nodal block
            # structure (dofs of a node are consecutive) so that AMG aggregates nodes
            mask = np.zeros(self.ndof, bool)
            mask[D] = True
            keep = sp.diags((~mask).astype(float))
            A = (keep @ self.K @ keep + sp.diags(mask.astype(float))).tocsr()
            b = f - self.K @ x0
            b[mask] = x0[mask]
            start = x0.copy()
            if guess is not None:
                start[~mask] = guess[~mask]
            if self.solver == "lu":
                u, iters, t_setup = self._lu_solve(mask, b, x0, key)
            else:
                u, iters, t_setup = self._amg_solve(A, b, start, key)
            relres = float(np.linalg.norm(A @ u - b) / np.linalg.norm(b))
            u[mask] = x0[mask]
        else:
            t_setup, relres = 0.0, 0.0
        r = self.K @ u - f                           # reaction forces (N)
        info = {
            "width_mm": width, "depth_mm": depth, "plane_y_mm": plane,
            "n_contact_nodes": int(len(top)),
            "cg_iterations": iters, "relative_residual": relres,
            "amg_setup_s": round(t_setup, 3),
            "punch_force_N": float(-r[top].sum()),
            "solve_s": round(time.perf_counter() - t0, 3),
        }
        return u, info


# --------------------------------------------------------------------------------------
# Post-processing: everything at the element centroid, evaluated by scikit-fem
# --------------------------------------------------------------------------------------

@Functional
def _sed_form(w):
    E = sym_grad(w.u)
    S = 2.0 * w.mu * E + w.lam * trace(E) * np.eye(3)[:, :, None, None]
    return 0.5 * ddot(S, E)


@Functional
def _one(w):
    return 1.0 + 0.0 * w.x[0]


class Post:
    def __init__(self, prob: Problem):
        self.prob = prob
        mesh = prob.sm.mesh
        self.bc = Basis(mesh, prob.element, quadrature=CENTROID_RULE)
        self.lam1 = prob.lam[:, None]
        self.mu1 = prob.mu[:, None]
        self.detJ_c = _one.elemental(self.bc)                  # |J| at the centroid
        vb = Basis(mesh, ElementHex1(), intorder=2)
        self.vol = _one.elemental(vb)                          # true element volumes
        self.centroid = self.bc.global_coordinates().value[:, :, 0].T   # (nel, 3)

    def tensors(self, u):
        """Centroid strain and stress tensors, (nel, 3, 3) each (MPa for stress)."""
        uc = self.bc.interpolate(u)
        eps = sym_grad(uc)[:, :, :, 0]                          # (3, 3, nel)
        tr = eps[0, 0] + eps[1, 1] + eps[2, 2]
        sig = 2.0 * self.prob.mu * eps + self.prob.lam * tr * np.eye(3)[:, :, None]
        return np.moveaxis(sig, -1, 0), np.moveaxis(eps, -1, 0)

    def cell_sed(self, u):
        """0.5 sigma:eps at the centroid, computed by a scikit-fem Functional (MPa)."""
        integ = _sed_form.elemental(self.bc, u=u, lam=self.lam1, mu=self.mu1)
        return integ / self.detJ_c

    def nodal_sed(self, cell_sed):
        """Volume-weighted average of the adjacent elements' centroid SED."""
        return nodal_average(self.prob.sm.mesh, cell_sed, self.vol)


def nodal_average(mesh, cell_value: np.ndarray, vol: np.ndarray, cells=None) -> np.ndarray:
    """Volume-weighted average at each node of ``mesh`` of the adjacent elements' values (all, or only those
    ``cells``, a boolean mask, says: one material's side of an interface); NaN at nodes with no such element.
    ``vol``: element volumes (mm^3)."""
    t = mesh.t
    w = vol if cells is None else np.where(cells, vol, 0.0)
    n = mesh.p.shape[1]
    num = np.bincount(t.ravel(), weights=np.repeat((w * cell_value)[None, :], t.shape[0], 0).ravel(), minlength=n)
    den = np.bincount(t.ravel(), weights=np.repeat(w[None, :], t.shape[0], 0).ravel(), minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / den


VOIGT = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]   # Abaqus: 11 22 33 12 13 23


def to_abaqus(sig, eps):
    S = np.stack([sig[:, i, j] for i, j in VOIGT], axis=1)
    E = np.stack([eps[:, i, j] * (1.0 if i == j else 2.0) for i, j in VOIGT], axis=1)
    return S, E


# --------------------------------------------------------------------------------------
# Export
# --------------------------------------------------------------------------------------
def _cells(sm: SkinMesh):
    return to_meshio(sm.mesh, encode_cell_data=False).cells[0].data.astype(np.int32)


def write_vtu(path: Path, sm: SkinMesh, point_data=None, cell_data=None):
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh = meshio.Mesh(
        np.ascontiguousarray(sm.mesh.p.T, dtype=np.float64),
        [("hexahedron", _cells(sm))],
        point_data=point_data or {},
        cell_data={k: [v] for k, v in (cell_data or {}).items()},
    )
    meshio.write(str(path), mesh, file_format="vtu", binary=True, compression="zlib")


def write_pvd(path: Path, files, times):
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    for f, t in zip(files, times):
        lines.append(f'    <DataSet timestep="{t:g}" group="" part="0" file="{f}"/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    path.write_text("\n".join(lines))


def write_receptors(path: Path, sm: SkinMesh):
    with open(path, "w", newline="\n") as f:
        f.write("id,x,y,z\n")
        for i, (x, y, z) in enumerate(sm.tips, start=1):
            f.write(f"{i},{x:.10g},{y:.10g},{z:.10g}\n")


def write_comsol_csv(path: Path, sm: SkinMesh, node_sed, region):
    p = sm.mesh.p
    sel = region(p)
    date = _dt.datetime.fromtimestamp(int(os.environ["SOURCE_DATE_EPOCH"]), _dt.timezone.utc) \
        if "SOURCE_DATE_EPOCH" in os.environ else _dt.datetime.now(_dt.timezone.utc)
    head = [
        "% Model,skin_block4.py",
        f"% Version,scikit-fem {skfem.__version__}",
        f"% Date,{date.strftime('%b %d %Y, %H:%M')}",
        "% Dimension,3",
        f"% Nodes,{int(sel.sum())}",
        "% Expressions,1",
        "% Description,Strain energy density",
        "% Length unit,mm",
        "% x,y,z,solid.Ws (J/m^3)",
    ]
    idx = np.flatnonzero(sel)
    with open(path, "w", newline="\n") as f:
        f.write("\n".join(head) + "\n")
        for n in idx:
            f.write(f"{p[0, n]:.10g},{p[1, n]:.10g},{p[2, n]:.10g},{node_sed[n] * 1e6:.10g}\n")
    return int(sel.sum())


def write_abaqus_csv(path: Path, centroid, S, E, sel):
    idx = np.flatnonzero(sel)
    with open(path, "w", newline="\n") as f:
        f.write("Element,X,Y,Z,S11,S22,S33,S12,S13,S23,E11,E22,E33,E12,E13,E23\n")
        for e in idx:
            vals = ",".join(f"{v:.9e}" for v in np.concatenate([S[e], E[e]]))
            c = centroid[e]
            f.write(f"{e + 1},{c[0]:.8g},{c[1]:.8g},{c[2]:.8g},{vals}\n")
    return int(len(idx))


# --------------------------------------------------------------------------------------
# Physical checks
# --------------------------------------------------------------------------------------
def dermis_side_sed(sm: SkinMesh, post: Post, cell_sed):
    """At each tip node: the volume-weighted mean SED of the dermis elements touching it (one material's side
    of the interface, where the nodal value averages epidermis and dermis; MPa)."""
    return nodal_average(sm.mesh, cell_sed, post.vol, sm.layer == LAYER_DERMIS)[sm.tip_nodes]


def receptor_checks(sm: SkinMesh, post: Post, u, cell_sed, node_sed, width):
    tips, tn = sm.tips, sm.tip_nodes
    h = 0.5 * width
    dxe = np.abs(tips[:, 0] - sm.xc) - h       # signed distance to the edge (<0 inside)
    dze = np.abs(tips[:, 2] - sm.zc) - h
    near = (dxe <= PAP_PITCH_X + TOL) & (dze <= PAP_PITCH_X + TOL)
    sed_pa = node_sed[tn] * 1e6
    sed_derm = dermis_side_sed(sm, post, cell_sed) * 1e6
    i_max = int(np.argmax(np.where(near, sed_pa, -np.inf)))
    out = {
        "n_receptors_near": int(near.sum()),
        "near_definition": "tips with |x-xc| and |z-zc| <= w/2 + 0.44 mm",
        "tip_node_SED_Pa": {"min": float(sed_pa[near].min()), "median": float(np.median(sed_pa[near])),
                            "max": float(sed_pa[near].max())},
        "dermis_side_SED_Pa": {"min": float(sed_derm[near].min()),
                               "median": float(np.median(sed_derm[near])),
                               "max": float(sed_derm[near].max())},
        "max_at": {"x": float(tips[i_max, 0]), "z": float(tips[i_max, 2]),
                   "dx_from_edge_mm": float(dxe[i_max]), "dz_from_edge_mm": float(dze[i_max]),
                   "SED_Pa": float(sed_pa[i_max])},
    }
    # profile across x through the centre (z = zc), receptor level
    row = np.abs(tips[:, 2] - sm.zc) < TOL
    order = np.argsort(tips[row, 0])
    px = tips[row, 0][order]
    ps = sed_pa[row][order]
    out["profile_x_tips"] = {"x": [float(v) for v in px], "SED_Pa": [round(float(v), 4) for v in ps]}
    # same at every interface node along z = zc (finer)
    iface = np.flatnonzero((sm.node_j == sm.j_interface) & (np.abs(sm.mesh.p[2] - sm.zc) < TOL))
    iface = iface[np.argsort(sm.mesh.p[0, iface])]
    fx, fs = sm.mesh.p[0, iface], node_sed[iface] * 1e6
    out["profile_x_interface"] = {"x": [round(float(v), 4) for v in fx],
                                  "SED_Pa": [round(float(v), 4) for v in fs]}
    out["interchange_zone_tips"] = interchange(px, ps, sm.xc)
    out["interchange_zone_interface"] = interchange(fx, fs, sm.xc)
    return out


def interchange(x, s, xc):
    """Peak-valley-peak across the centre: a local max on each side above the centre value."""
    centre = int(np.argmin(np.abs(x - xc)))
    left, right = s[:centre], s[centre + 1:]
    if len(left) == 0 or len(right) == 0:
        return {"present": False}
    il, ir = int(np.argmax(left)), centre + 1 + int(np.argmax(right))
    valley = float(s[il:ir + 1].min())
    present = bool(s[il] > s[centre] and s[ir] > s[centre])
    return {"present": present, "left_peak": [float(x[il]), float(s[il])],
            "right_peak": [float(x[ir]), float(s[ir])], "centre": [float(x[centre]), float(s[centre])],
            "valley_min": valley,
            "valley_to_peak_ratio": float(s[centre] / max(s[il], s[ir]))}


def patch_test():
    """Uniaxial-stress patch test on a distorted 3x3x3 hex block (dermis material, SRI).

    Rollers on x=0, y=0, z=0, top pressed by 10 %: the exact solution is linear, which
    trilinear hexahedra reproduce exactly on any mesh, so the centroid SED must equal
    E eps^2 / 2 to round-off.  Checks the form, the Lame parameters and the SED Functional.
    """
    m = MeshHex.init_tensor(*(np.linspace(0.0, 1.0, 4),) * 3)
    p = m.p.copy()
    inner = np.all((p > 1e-9) & (p < 1 - 1e-9), axis=0)
    p[:, inner] += 0.08 * np.array([[1.0], [-0.7], [0.5]]) * np.sin(7.0 * p[:, inner].sum(0))
    m = MeshHex(p, m.t)
    e = ElementVector(ElementHex1())
    basis = Basis(m, e, intorder=2)
    E = YOUNG[LAYER_DERMIS]
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    kappa = lam + 2 * mu / 3
    K = stiffness(m, e, np.full(m.t.shape[1], mu), np.full(m.t.shape[1], kappa))
    nd = basis.nodal_dofs
    D = np.concatenate([nd[0, p[0] < 1e-9], nd[1, p[1] < 1e-9], nd[2, p[2] < 1e-9],
                        nd[1, p[1] > 1 - 1e-9]])
    x0 = np.zeros(K.shape[0])
    strain = -0.1
    x0[nd[1, p[1] > 1 - 1e-9]] = strain
    free = np.setdiff1d(np.arange(K.shape[0]), D)
    u = x0.copy()
    u[free] = sp.linalg.spsolve(K[free][:, free].tocsc(), -(K[free][:, D] @ x0[D]))
    bc = Basis(m, e, quadrature=CENTROID_RULE)
    sed = _sed_form.elemental(bc, u=u, lam=lam, mu=mu) / _one.elemental(bc)
    exact = 0.5 * E * strain ** 2
    return float(np.max(np.abs(sed - exact)) / exact)


# --------------------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------------------
def specs(quick: bool):
    if quick:
        b4 = MeshSpec("block4", 4.0, BLOCK4_WIDTHS, fine_rows_x=3, fine_rows_z=5,
                      n_half_in_x=1, n_gap_x=1, n_half_in_z=1, n_gap_z=1,
                      n_sub=1, n_derm=3, n_epi=3, derm_ratio=1.8, epi_ratio=1.3)
        b8 = MeshSpec("block8", 8.0, BLOCK8_WIDTHS, fine_rows_x=5, fine_rows_z=10,
                      n_half_in_x=1, n_gap_x=1, n_half_in_z=1, n_gap_z=1,
                      n_sub=1, n_derm=3, n_epi=3, derm_ratio=1.8, epi_ratio=1.3)
    else:
        b4 = MeshSpec("block4", 4.0, BLOCK4_WIDTHS, fine_rows_x=3, fine_rows_z=5,
                      n_half_in_x=2, n_gap_x=2, n_half_in_z=1, n_gap_z=2,
                      n_sub=2, n_derm=6, n_epi=6, derm_ratio=1.5, epi_ratio=1.2)
        b8 = MeshSpec("block8", 8.0, BLOCK8_WIDTHS, fine_rows_x=5, fine_rows_z=10,
                      n_half_in_x=1, n_gap_x=2, n_half_in_z=1, n_gap_z=2,
                      n_sub=2, n_derm=5, n_epi=5, derm_ratio=1.6, epi_ratio=1.25)
    return b4, b8


# --------------------------------------------------------------------------------------
# The small sample shipped inside the package (afferent/data/sample/): a crop of the files
# above, so that `afferent demo` runs from an installed wheel.
# --------------------------------------------------------------------------------------
PACKAGED_DIR = Path(__file__).resolve().parents[1] / "afferent" / "data" / "sample"
PACKAGED_STATIC = [("block4", f"indent_{width_tag(w)}.vtu") for w in BLOCK4_WIDTHS] + \
                  [("block8", f"indent_{width_tag(w)}.vtu") for w in BLOCK8_WIDTHS]
PACKAGED_SERIES = ("block4", f"series_{width_tag(SERIES_WIDTH)}")


def receptor_nodes(points: np.ndarray, receptors_csv: Path) -> np.ndarray:
    """Index of the mesh node at each receptor of ``receptors_csv`` (``id,x,y,z`` in mm).

    Every receptor is a papilla-tip node (``write_receptors``); one farther than ``TOL`` mm
    from every node is an error.
    """
    from scipy.spatial import cKDTree

    xyz = np.loadtxt(receptors_csv, delimiter=",", skiprows=1, ndmin=2)[:, 1:4]
    dist, idx = cKDTree(points).query(xyz)
    if dist.max() > TOL:
        raise ValueError(f"{receptors_csv}: receptor {int(np.argmax(dist)) + 1} is {dist.max():.3g} mm from the "
                         f"nearest mesh node; expected every receptor on a node (<= {TOL} mm).")
    return idx


def crop_to_receptors(mesh: meshio.Mesh, tip_nodes: np.ndarray, *, drop=("U",)) -> meshio.Mesh:
    """The hexahedra of ``mesh`` that have a node of ``tip_nodes`` among their 8 corners, and their nodes.

    Nodes and elements keep their order in the full mesh (renumbered from 0). Every value is
    copied, none recomputed: the nodal SED stays the average over the elements of the full
    mesh. Each receptor node keeps all the elements around it, so sampling at a receptor (point
    or cell values, 'linear' or 'nearest', cells averaged to nodes) sees what it sees in the
    full mesh. Arrays named in ``drop`` are left out.
    """
    (block,) = mesh.cells
    hexes = block.data
    keep = np.isin(hexes, tip_nodes).any(axis=1)
    used = np.unique(hexes[keep])
    new_index = np.full(len(mesh.points), -1, dtype=np.int64)
    new_index[used] = np.arange(used.size)
    return meshio.Mesh(
        mesh.points[used],
        [(block.type, new_index[hexes[keep]].astype(np.int32))],
        point_data={k: v[used] for k, v in mesh.point_data.items() if k not in drop},
        cell_data={k: [v[0][keep]] for k, v in mesh.cell_data.items() if k not in drop},
    )


def write_packaged_sample(src: Path, dst: Path = PACKAGED_DIR) -> dict:
    """Write the packaged sample ``dst`` (replaced whole) from the full sample ``src``.

    ``dst`` gets the layout of ``src`` for the files ``afferent demo`` reads: every
    single-indenter VTU (block4 and block8), the 0.88 mm loading series (its PVD copied),
    both ``receptors.csv`` and ``scenes/spikes_ramp.toml`` (copied). Each VTU is cropped by
    :func:`crop_to_receptors` and written as zlib-compressed binary VTU, as ``write_vtu`` does.
    ``dst/README.md`` states the derivation and the size and sha256 of every file.
    Returns {relative path: (size in bytes, sha256 hex, sha256 hex of the file of ``src`` it comes from)}.
    """
    import hashlib
    import shutil

    if dst.exists():
        shutil.rmtree(dst)
    sblk, sdir = PACKAGED_SERIES
    jobs = list(PACKAGED_STATIC) + [(sblk, f"{sdir}/{p.name}") for p in sorted((src / sblk / sdir).glob("indent_*.vtu"))]
    tips, kept = {}, {}
    for blk, name in jobs:
        full = meshio.read(src / blk / name)
        if blk not in tips:
            tips[blk] = receptor_nodes(full.points, src / blk / "receptors.csv")
            (dst / blk).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src / blk / "receptors.csv", dst / blk / "receptors.csv")
        small = crop_to_receptors(full, tips[blk])
        at = receptor_nodes(small.points, src / blk / "receptors.csv")
        assert np.array_equal(small.point_data["SED"][at], full.point_data["SED"][tips[blk]]), name
        (dst / blk / name).parent.mkdir(parents=True, exist_ok=True)
        meshio.write(str(dst / blk / name), small, file_format="vtu", binary=True, compression="zlib")
        kept[blk] = (len(small.cells[0].data), len(full.cells[0].data), len(small.points), len(full.points))
        print(f"  {blk}/{name}: {kept[blk][0]} of {kept[blk][1]} hexahedra, {kept[blk][2]} of {kept[blk][3]} nodes")
    shutil.copyfile(src / sblk / sdir / "indent.pvd", dst / sblk / sdir / "indent.pvd")
    (dst / "scenes").mkdir()
    (dst / "scenes" / "spikes_ramp.toml").write_text(
        "# Copied from sample_sed/scenes/spikes_ramp.toml by `make_samples.py --packaged`: the paths below\n"
        "# resolve inside this packaged sample, whose files are crops of sample_sed/ (README.md).\n"
        + (src / "scenes" / "spikes_ramp.toml").read_text())
    def sha256(path):
        return hashlib.sha256(path.read_bytes()).hexdigest()

    kept.update(write_packaged_chapter4(src, dst))
    files = {p.relative_to(dst).as_posix(): (p.stat().st_size, sha256(p), source_sha256(src, p.relative_to(dst).as_posix()))
             for p in sorted(dst.rglob("*")) if p.is_file()}
    (dst / "README.md").write_text(packaged_readme(files, kept))
    print(f"packaged sample: {len(files)} files, {sum(f[0] for f in files.values())} bytes -> {dst}")
    return files


def source_sha256(src: Path, name: str) -> str:
    """sha256 (hex) of what packaged file ``name`` was made from: the file of the same path in ``src``, except for
    a vibration series (``vibration/<series>/vib.xdmf`` or ``vib.h5``), made from ``vib.pvd`` and its step VTUs:
    the sha256 of their bytes in a row (the PVD first, then the VTUs in the PVD's order)."""
    import hashlib
    import xml.etree.ElementTree as ET

    path = Path(src) / name
    if not (name.startswith("vibration/") and path.name in ("vib.xdmf", "vib.h5")):
        return hashlib.sha256(path.read_bytes()).hexdigest()
    pvd = path.parent / "vib.pvd"
    h = hashlib.sha256(pvd.read_bytes())
    for d in ET.parse(pvd).getroot().iter("DataSet"):
        h.update((path.parent / d.get("file")).read_bytes())
    return h.hexdigest()


def write_packaged_chapter4(src: Path, dst: Path) -> dict:
    """The chapter-4 part of the packaged sample (what ``afferent demo``'s chapter-4 findings read).

    * ``chapter4/ridged{3d,2d}/``: each indenter's VTU cropped by :func:`crop_to_receptors` to the
      RA-I and SA-I sites of its tables (``ra_sites.csv``, ``sa_sites.csv``, copied);
    * ``vibration/``: ``receptors.csv`` copied; each series ``{3d,2d}_{f}Hz/vib.pvd`` (one VTU per step)
      becomes one XDMF time series ``vib.xdmf`` + ``vib.h5`` (meshio's TimeSeriesWriter) holding, for every
      step, the cell ``SED`` and cell ``layer`` of the **8 hexahedra around each tip** (every hexahedron of the
      cropped series) and no point SED: sampling at a tip, on the dermis side (``side=2``, what
      afferent.findings reads) or averaged across the layers (cell SED averaged to the nodes by volume), sees
      the cells it sees in the full series; the point SED on these hexahedra' nodes would more than double
      the size. The PVD's step times are kept.

    Returns {folder: (hexahedra kept, of, nodes kept, of)} of the first file of each folder.
    """
    import os
    import shutil
    import xml.etree.ElementTree as ET

    kept, src, dst = {}, Path(src).resolve(), Path(dst).resolve()
    c4 = src / "chapter4"
    if not c4.is_dir():
        return kept
    for model in sorted(p.name for p in c4.iterdir() if p.is_dir()):
        (dst / "chapter4" / model).mkdir(parents=True)
        nodes = None
        for name in ("ra_sites.csv", "sa_sites.csv"):
            shutil.copyfile(c4 / model / name, dst / "chapter4" / model / name)
        for vtu in sorted((c4 / model).glob("*.vtu")):
            full = meshio.read(vtu)
            if nodes is None:
                nodes = np.concatenate([receptor_nodes(full.points, c4 / model / n) for n in ("ra_sites.csv", "sa_sites.csv")])
            small = crop_to_receptors(full, nodes)
            meshio.write(str(dst / "chapter4" / model / vtu.name), small, file_format="vtu", binary=True, compression="zlib")
            kept.setdefault(f"chapter4/{model}", (len(small.cells[0].data), len(full.cells[0].data), len(small.points),
                                                  len(full.points)))
    vib = src / "vibration"
    if not vib.is_dir():
        return kept
    (dst / "vibration").mkdir()
    shutil.copyfile(vib / "receptors.csv", dst / "vibration" / "receptors.csv")
    here = Path.cwd()
    for series in sorted(p for p in vib.iterdir() if (p / "vib.pvd").is_file()):
        steps = [(float(d.get("timestep")), d.get("file")) for d in ET.parse(series / "vib.pvd").getroot().iter("DataSet")]
        first = meshio.read(series / steps[0][1])
        tips = receptor_nodes(first.points, vib / "receptors.csv")
        hexes = first.cells[0].data
        if not {"SED", "layer"} <= set(first.cell_data):
            raise ValueError(f"{series / steps[0][1]}: expected cell data 'SED' and 'layer' (make_vibration.py "
                             f"writes them); got {sorted(first.cell_data)}")
        around = np.flatnonzero(np.isin(hexes, tips).any(axis=1))
        out = dst / "vibration" / series.name
        out.mkdir()
        os.chdir(out)  # meshio names the .h5 relative to the working folder
        try:
            with meshio.xdmf.TimeSeriesWriter("vib.xdmf") as w:
                w.write_points_cells(first.points, [("hexahedron", hexes[around].astype(np.int32))])
                for t, name in steps:
                    m = meshio.read(series / name)
                    w.write_data(t, cell_data={k: [m.cell_data[k][0][around]] for k in ("SED", "layer")})
        finally:
            os.chdir(here)
        kept.setdefault("vibration", (len(around), len(hexes), len(first.points), len(first.points)))
    return kept


def packaged_readme(files: dict, kept: dict) -> str:
    """README.md of the packaged sample: what it is, how it was derived, size and sha256 of each file.

    ``kept``: {block: (hexahedra kept, of, nodes kept, of)}.
    """
    def spaced(n):
        return f"{n:,}".replace(",", " ")

    counts = "\n".join(f"  * {blk}: {spaced(c)} of {spaced(cf)} hexahedra, {spaced(n)} of {spaced(nf)} nodes."
                       for blk, (c, cf, n, nf) in kept.items())

    rows = "\n".join(f"| `{name}` | {spaced(size)} | `{sha}` | `{src_sha}` |" for name, (size, sha, src_sha) in files.items())
    total = spaced(sum(f[0] for f in files.values()))
    return f"""\
# The sample shipped with afferent (`afferent/data/sample/`)

A crop of the finite-element sample of the source repository (`sample_sed/`, made by
`sample_sed/make_samples.py`): real scikit-fem solutions for a block of fingertip skin in three
linear-elastic layers (epidermis, dermis, subcutis). The surface carries fingerprint ridges and
the epidermis/dermis interface carries dermal papillae. Rigid flat square punches indent it by
0.5 mm; as in the study, only the four edges of its bottom face are restrained. `afferent demo`
runs on this crop, so the demo also works from an installed wheel.
The full sample (28 MB) and its description (`sample_sed/README.md`: model, mesh, solver,
checks) stay in the source repository.

Units as in the full sample: coordinates in mm, SED in MPa (read with `length_unit="mm"`,
`sed_unit="MPa"`).

## How it was derived

`write_packaged_sample` in `sample_sed/make_samples.py` wrote it from the committed
`sample_sed/` files. A full `make_samples.py` run also rewrites it at the end. To rewrite only
this crop:

```
pip install -e .[samples]
python sample_sed/make_samples.py --packaged
```

* The layout and file names are those of `sample_sed/`, for the files the demo reads:
  * the six single-indenter VTUs of `block4/` (0.44-2.00 mm) and `block8/indent_4p00mm.vtu`;
  * the 0.88 mm loading series `block4/series_0p88mm/` (6 steps, t = 0 ... 0.1 s,
    d = 0 ... 0.5 mm), with its PVD copied;
  * both `receptors.csv` (copied: 119 and 595 papilla tips);
  * `scenes/spikes_ramp.toml` (copied, with a two-line header);
  * for the chapter-4 findings (`afferent.findings`): `chapter4/ridged{{3d,2d}}/` (the four
    indenters' VTUs cropped to the RA-I and SA-I sites of `ra_sites.csv` and `sa_sites.csv`,
    both copied) and `vibration/` (`receptors.csv` copied; each series `{{3d,2d}}_{{f}}Hz/` as one
    XDMF time series `vib.xdmf` + `vib.h5` holding every step of the series' PVD, at its times,
    with the cell `SED` and `layer` of the 8 hexahedra around each tip and no point SED: sampling
    at the tips, on the dermis side or averaged, sees the full series' cells; `write_packaged_chapter4`). For these two files the
    "source sha256" is that of the series' `vib.pvd` and its step VTUs, their bytes in a row
    (`source_sha256`).
* Each VTU keeps only the hexahedra that have a receptor (papilla-tip) node among their 8
  corners (the 2 x 2 x 2 elements around each tip: 4 in the dermis, 4 in the epidermis) and
  the nodes of those elements. Nodes and elements keep their order in the full mesh,
  renumbered from 0. Kept:
{counts}
* Every value is copied, none is recomputed. The nodal `SED` stays the average over the
  elements of the full mesh. The arrays are those of the full files (point `SED`, cell `SED`,
  cell `layer`) without the displacement `U`.
* Every receptor node keeps all the elements around it. So the SED sampled at the receptors
  equals the full sample's, with point or cell values and with 'linear' or 'nearest' sampling.
  `tests/test_wheel.py` checks this file by file. It also checks that `afferent demo` gives
  the same `summary.csv` on this crop and on the full sample.
* Away from the receptors the field is absent: use the full sample for maps of the field.
* meshio writes the VTUs as binary with zlib compression, like the full sample.

## Files

"source sha256" is that of the `sample_sed/` file of the same path (for `scenes/spikes_ramp.toml`:
before the header was added) at the time of writing.

| file | bytes | sha256 | source sha256 |
|---|---|---|---|
{rows}

Total {total} bytes (README.md not counted).
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="coarse mesh smoke run (into a temp dir)")
    ap.add_argument("--out", type=Path, default=None, help="output folder")
    ap.add_argument("--integration", choices=("sri", "full"), default="sri",
                    help="hexahedron integration: selective reduced (default) or full 2x2x2")
    ap.add_argument("--bottom", choices=("edges", "face"), default="edges",
                    help="bottom restraint: the study's bottom edges (default) or the whole bottom face "
                         "(the sample before issue 21, for comparison)")
    ap.add_argument("--only", choices=("block4", "block8"), default=None,
                    help="solve one block only (timing and comparison runs; use with --out)")
    ap.add_argument("--check-mesh", action="store_true",
                    help="also solve the 0.88 mm case on the block4 mesh refined 2x in every "
                         "direction and compare (slow, ~8x the elements)")
    ap.add_argument("--packaged", action="store_true",
                    help="only rewrite the packaged sample afferent/data/sample/ from the existing sample_sed/ files "
                         "(no FE solve)")
    args = ap.parse_args(argv)
    here = Path(__file__).resolve().parent
    if args.packaged:
        write_packaged_sample(here)
        return
    if pyamg is None:
        sys.exit("pyamg is required: pip install -e .[samples]")
    out = args.out or (Path(tempfile.gettempdir()) / "afferent_sample_sed_quick" if args.quick else here)
    if args.only and out == here:
        sys.exit("--only writes one block and its own build_info.json: give --out DIR (not sample_sed/)")
    out.mkdir(parents=True, exist_ok=True)
    T0 = time.perf_counter()
    print(f"output: {out}")
    info = {
        "generator": "sample_sed/make_samples.py" + (" --quick" if args.quick else ""),
        "versions": {"python": platform.python_version(), "scikit-fem": skfem.__version__,
                     "meshio": meshio.__version__, "numpy": np.__version__,
                     "scipy": scipy.__version__, "pyamg": pyamg.__version__},
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "units": {"length": "mm", "stress": "MPa", "SED": "MPa (= mJ/mm^3 = 1e6 J/m^3)",
                  "force": "N", "time": "s"},
        "element": {"type": "8-node trilinear hexahedron (skfem ElementHex1, vector)",
                    "integration": args.integration,
                    "integration_note": "sri: deviatoric 2x2x2 Gauss, volumetric 1 point (centre)"},
        "boundary": {"bottom": args.bottom,
                     "note": "edges: the four edges of the bottom face (y = 0) fixed in x, y, z; "
                             "face: the whole bottom face fixed"},
        "solver": {"method": "CG + smoothed-aggregation AMG (pyamg), rigid-body near-nullspace",
                   "relative_residual_tol": CG_TOL},
        "blocks": {},
    }
    pt = patch_test()
    info["patch_test_uniaxial_SED_max_rel_error"] = pt
    print(f"patch test (uniaxial stress, distorted hexes): max rel. SED error {pt:.2e}")
    assert pt < 1e-8, "patch test failed"
    b4, b8 = specs(args.quick)
    timings = {}
    for spec in (b4, b8):
        if args.only and spec.name != args.only:
            continue
        print(f"[{spec.name}] building mesh")
        t0 = time.perf_counter()
        sm = build_mesh(spec)
        stats = mesh_stats(sm)
        timings[f"{spec.name}_mesh_s"] = round(time.perf_counter() - t0, 2)
        print(f"  {stats['n_nodes']} nodes, {stats['n_elements']} hexahedra, "
              f"{stats['n_receptors']} receptors, smallest edge {stats['smallest_edge_mm']:.4f} mm")
        prob = Problem(sm, integration=args.integration, bottom=args.bottom)
        post = Post(prob)
        timings[f"{spec.name}_assemble_s"] = round(prob.t_assemble, 2)
        bdir = out / spec.name
        bdir.mkdir(parents=True, exist_ok=True)
        write_receptors(bdir / "receptors.csv", sm)
        binfo = {"mesh": stats, "cases": {}}
        for w in spec.widths:
            u, sinfo = prob.solve(w, DEPTH)
            t1 = time.perf_counter()
            sig, eps = post.tensors(u)
            csed = post.cell_sed(u)
            nsed = post.nodal_sed(csed)
            # consistency: 1/2 sigma:eps from the exported Voigt tensors vs the cell SED
            S, E = to_abaqus(sig, eps)
            sed_t = 0.5 * np.sum(S * E, axis=1)
            scale = max(np.abs(csed).max(), 1e-300)
            cons = float(np.max(np.abs(sed_t - csed)) / scale)
            mask = csed > 1e-3 * scale
            cons_rel = float(np.max(np.abs(sed_t[mask] - csed[mask]) / csed[mask]))
            tag = width_tag(w)
            write_vtu(bdir / f"indent_{tag}.vtu", sm,
                      point_data={"SED": nsed.astype(np.float64), "U": u[prob.vdofs].T.astype(np.float32)},
                      cell_data={"SED": csed.astype(np.float64), "layer": sm.layer})
            chk = receptor_checks(sm, post, u, csed, nsed, w)
            chk["tensor_vs_cell_SED_max_abs_diff_over_max_SED"] = cons
            chk["tensor_vs_cell_SED_max_rel_diff_(cells_with_SED>1e-3*max)"] = cons_rel
            chk["max_cell_SED_Pa"] = float(csed.max() * 1e6)
            chk["min_cell_SED_Pa"] = float(csed.min() * 1e6)
            sinfo["post_export_s"] = round(time.perf_counter() - t1, 3)
            binfo["cases"][tag] = {"solve": sinfo, "checks": chk}
            ts = chk["tip_node_SED_Pa"]
            print(f"  w={w:.2f} mm: {sinfo['cg_iterations']} CG its, solve {sinfo['solve_s']:.1f} s, "
                  f"F={sinfo['punch_force_N']:.4f} N | receptor SED (Pa) min/med/max "
                  f"{ts['min']:.1f}/{ts['median']:.1f}/{ts['max']:.1f}, max at dx_edge="
                  f"{chk['max_at']['dx_from_edge_mm']:+.3f} dz_edge={chk['max_at']['dz_from_edge_mm']:+.3f}"
                  f" | interchange(tips)={chk['interchange_zone_tips'].get('present')}"
                  f" | 1/2 S:E vs SED max rel diff {cons_rel:.2e}")
            if spec.name == "block4" and abs(w - SERIES_WIDTH) < TOL:
                u_088 = u
                write_vtu(bdir / f"indent_{tag}_tensors.vtu", sm,
                          cell_data={"S": S.astype(np.float64), "E": E.astype(np.float64),
                                     "layer": sm.layer})
                c = sm.xc
                n_csv = write_comsol_csv(
                    bdir / f"indent_{tag}_comsol.csv", sm, nsed,
                    lambda p: (p[1] >= 1.8 - TOL) & (np.abs(p[0] - c) <= 1.5 + TOL)
                    & (np.abs(p[2] - c) <= 1.5 + TOL))
                cen = post.centroid
                sel = (np.abs(cen[:, 0] - c) <= 1.0) & (np.abs(cen[:, 2] - c) <= 1.0) & \
                      (cen[:, 1] >= 2.1) & (cen[:, 1] <= 2.9)
                n_ab = write_abaqus_csv(bdir / f"indent_{tag}_abaqus_elements.csv", cen, S, E, sel)
                binfo["csv_rows"] = {"comsol_nodes": n_csv, "abaqus_elements": n_ab}
        if spec.name == "block4":
            sdir = bdir / f"series_{width_tag(SERIES_WIDTH)}"
            sdir.mkdir(parents=True, exist_ok=True)
            files, series = [], []
            for k, (t, d) in enumerate(zip(SERIES_TIMES, SERIES_DEPTHS)):
                u, sinfo = prob.solve(SERIES_WIDTH, float(d))
                csed = post.cell_sed(u)
                nsed = post.nodal_sed(csed)
                fname = f"indent_{k:03d}.vtu"
                write_vtu(sdir / fname, sm, point_data={"SED": nsed.astype(np.float32)})
                files.append(fname)
                tipsed = nsed[sm.tip_nodes] * 1e6
                series.append({"t_s": float(t), "depth_mm": float(d), "cg_iterations": sinfo["cg_iterations"],
                               "solve_s": sinfo["solve_s"], "punch_force_N": sinfo["punch_force_N"],
                               "n_contact_nodes": sinfo["n_contact_nodes"],
                               "max_receptor_SED_Pa": float(tipsed.max())})
                print(f"  series t={t:.2f} s d={d:.1f} mm: solve {sinfo['solve_s']:.1f} s, "
                      f"F={sinfo['punch_force_N']:.4f} N, max receptor SED {tipsed.max():.1f} Pa")
                if k == len(SERIES_TIMES) - 1:
                    binfo["series_last_step_vs_single_case_max_abs_U_diff_mm"] = float(np.abs(u - u_088).max())
            write_pvd(sdir / "indent.pvd", files, SERIES_TIMES)
            binfo["series"] = series
            if args.check_mesh:
                binfo["mesh_check"] = mesh_check(sm, prob, post, u_088, args.integration)
        info["blocks"][spec.name] = binfo
        del prob, post
    timings["total_s"] = round(time.perf_counter() - T0, 1)
    info["timings"] = timings
    info["files"] = {str(p.relative_to(out)): p.stat().st_size
                     for blk in (b4.name, b8.name) for p in sorted((out / blk).rglob("*"))
                     if p.is_file() and p.suffix in (".vtu", ".pvd", ".csv")}
    info["total_size_MB"] = round(sum(info["files"].values()) / 1e6, 2)
    (out / "build_info.json").write_text(json.dumps(info, indent=1) + "\n")
    print(f"total {timings['total_s']:.1f} s, data {info['total_size_MB']} MB -> {out}")
    if out == here and not args.only:
        write_packaged_sample(out)


def normalised_difference(sm, n1, n2):
    """The tips near the punch (as compare_tips), each mesh's SED over its own largest there: the median and
    largest |difference| (dimensionless, of 1), and whether the largest is at the same tip."""
    near = (np.abs(sm.tips[:, 0] - sm.xc) <= 0.88) & (np.abs(sm.tips[:, 2] - sm.zc) <= 0.88)
    a, b = n1[near] / n1[near].max(), n2[near] / n2[near].max()
    return {"median_abs_diff": float(np.median(np.abs(a - b))), "max_abs_diff": float(np.abs(a - b).max()),
            "same_peak_tip": bool(np.argmax(a) == np.argmax(b))}


def compare_tips(sm, n1, n2, f1, f2, label1, label2):
    t1, t2 = n1 * 1e6, n2 * 1e6
    near = (np.abs(sm.tips[:, 0] - sm.xc) <= 0.88) & (np.abs(sm.tips[:, 2] - sm.zc) <= 0.88)
    return {
        "punch_force_N": {label1: f1, label2: f2},
        "receptors_compared": int(near.sum()),
        "receptor_tip_SED_Pa": {
            f"{label1}_median": float(np.median(t1[near])), f"{label2}_median": float(np.median(t2[near])),
            f"{label1}_max": float(t1[near].max()), f"{label2}_max": float(t2[near].max()),
            "median_rel_diff": float(np.median(np.abs(t1[near] - t2[near]) / t2[near])),
            "max_rel_diff": float(np.max(np.abs(t1[near] - t2[near]) / t2[near]))},
    }


def mesh_check(sm, prob1, post1, u1, integration):
    """Solve the 0.88 mm case on the same mesh refined 2x in x, y and z; compare at the tips."""
    from dataclasses import replace
    print("  [check] 0.88 mm case on the block4 mesh refined 2x")
    sm2 = build_mesh(replace(sm.spec, refine=2))
    prob2 = Problem(sm2, integration=integration)
    u2, s2 = prob2.solve(SERIES_WIDTH, DEPTH)
    post2 = Post(prob2)
    c2, c1 = post2.cell_sed(u2), post1.cell_sed(u1)
    n2, n1 = post2.nodal_sed(c2)[sm2.tip_nodes], post1.nodal_sed(c1)[sm.tip_nodes]
    assert np.allclose(sm.tips, sm2.tips)
    _, s1 = prob1.solve(SERIES_WIDTH, DEPTH)
    res = {"refined_mesh": mesh_stats(sm2), "refined_cg_iterations": s2["cg_iterations"],
           "refined_solve_s": s2["solve_s"],
           **compare_tips(sm, n1, n2, s1["punch_force_N"], s2["punch_force_N"], "mesh", "refined")}
    # what the study compares: the profiles' shape (each normalised by its own largest value), and one
    # material's side of the interface (the nodal value averages the two layers over the adjacent elements)
    d1, d2 = dermis_side_sed(sm, post1, c1), dermis_side_sed(sm2, post2, c2)
    res["dermis_side"] = compare_tips(sm, d1, d2, s1["punch_force_N"], s2["punch_force_N"], "mesh", "refined")[
        "receptor_tip_SED_Pa"]
    res["normalised_tip_SED"] = normalised_difference(sm, n1, n2)
    print("  [check]", json.dumps(res))
    return res


if __name__ == "__main__":
    main()
