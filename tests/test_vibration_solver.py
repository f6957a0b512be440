"""The viscoelastic time stepping of sample_sed/make_vibration.py against closed forms.

A homogeneous block of one viscoelastic material (Prony series on the shear modulus, bulk modulus
elastic), assembled and stepped by the generator's own functions (``make_samples.stiffness``,
``Hereditary``, ``hereditary_step``), solved with scipy's sparse LU:

* simple shear held after a one-step ramp relaxes as the exact convolution of G(t) with that ramp,
  which is G(t - dt/2) to O(dt^2) and tends to G0 g_inf;
* uniaxial stress under a sinusoidal strain reaches the steady state of the complex modulus,
  E*(w) = 9 K G*(w) / (3 K + G*(w)), in amplitude and phase. The lateral faces are free, so the
  history force of the step (not only the stress recursion) decides the answer.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

skfem = pytest.importorskip("skfem", reason="scikit-fem is part of the [test] extra")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sample_sed"))
import make_samples as ms  # noqa: E402
import make_vibration as mv  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402
from skfem import Basis, ElementHex1, ElementVector, MeshHex  # noqa: E402
from skfem.helpers import sym_grad  # noqa: E402

G0, KAPPA = 0.05, 0.6                      # MPa
PRONY = mv.Prony(g=(0.3, 0.4), tau=(0.005, 0.02))


def block(n=2):
    mesh = MeshHex.init_tensor(*(np.linspace(0.0, 1.0, n + 1),) * 3)
    element = ElementVector(ElementHex1())
    nel = mesh.t.shape[1]
    K_rest = ms.stiffness(mesh, element, np.zeros(nel), np.full(nel, KAPPA))
    Kv = ms.stiffness(mesh, element, np.full(nel, G0), np.zeros(nel))
    basis = Basis(mesh, element, intorder=2)
    bc = Basis(mesh, element, quadrature=ms.CENTROID_RULE)
    return mesh, basis, bc, K_rest, Kv


def run(rule, K_rest, Kv, D, prescribed, n_steps, keep_history=False):
    """Step from rest; ``prescribed(k)`` gives the values of the dofs ``D`` at step k (mm)."""
    K = (K_rest + rule.algorithmic * Kv).tocsr()
    n = K.shape[0]
    free = np.setdiff1d(np.arange(n), D)
    lu = sla.splu(K[free][:, free].tocsc())
    H, u = np.zeros((len(rule.prony.g), n)), np.zeros(n)
    out, hist = [], []
    for k in range(1, n_steps + 1):
        x = np.zeros(n)
        x[D] = prescribed(k)

        def solve(f, x=x):
            v = x.copy()
            v[free] = lu.solve(f[free] - K[free][:, D] @ x[D])
            return v

        u, H = mv.hereditary_step(rule, Kv, H, u, solve)
        out.append((u, rule.shear_field(H, u)))
        hist.append(H)
    return (out, hist) if keep_history else out


def stress(bc, u, us):
    """Centroid stress (MPa), (3, 3, nel): 2 G0 dev eps(us) + K tr eps(u) I."""
    eps = sym_grad(bc.interpolate(u))[:, :, :, 0]
    es = sym_grad(bc.interpolate(us))[:, :, :, 0]
    dev = es - np.trace(es) / 3.0 * np.eye(3)[:, :, None]
    return 2.0 * G0 * dev + KAPPA * np.trace(eps) * np.eye(3)[:, :, None]


def test_simple_shear_relaxes_as_the_prony_series():
    mesh, basis, bc, K_rest, Kv = block()
    dt, gamma = 5e-4, 0.01
    rule = mv.Hereditary(PRONY, dt)
    X = basis.doflocs
    D = basis.get_dofs().all()                     # every boundary dof: a homogeneous simple shear
    comp = np.zeros(basis.N, int)
    comp[basis.nodal_dofs[1]], comp[basis.nodal_dofs[2]] = 1, 2
    target = np.where(comp[D] == 0, gamma * X[1, D], 0.0)
    steps, Hs = run(rule, K_rest, Kv, D, lambda k: target, 400, keep_history=True)
    t = dt * np.arange(1, 401)
    tau_xy = np.array([stress(bc, u, us)[0, 1].mean() for u, us in steps])
    # the ramp over the first step, then held: (1/dt) int_0^dt G(t - s) ds, exactly
    g, tau = np.asarray(PRONY.g), np.asarray(PRONY.tau)
    exact = G0 * gamma * (PRONY.g_inf + np.sum(g * tau / dt * (np.exp(-(t[:, None] - dt) / tau)
                                                               - np.exp(-t[:, None] / tau)), axis=1))
    np.testing.assert_allclose(tau_xy, exact, rtol=1e-9)
    # and that is G(t) of the Prony series, shifted by half a step
    np.testing.assert_allclose(tau_xy, G0 * gamma * mv.relaxation(PRONY, t - dt / 2), rtol=2e-3)
    assert tau_xy[-1] == pytest.approx(G0 * gamma * PRONY.g_inf, rel=1e-3)   # t = 10 tau_2
    # the stored energy: G0 gamma^2 / 2 (g_inf + sum g_i b_i^2) after the ramp, G0 g_inf gamma^2 / 2 relaxed
    nel = mesh.t.shape[1]
    sed = [mv.stored_sed(bc, u, H, PRONY, np.full(nel, G0), np.full(nel, KAPPA), np.ones(nel, bool))
           for (u, _), H in zip(steps, Hs)]
    w0 = G0 * gamma ** 2 / 2 * (PRONY.g_inf + np.sum(np.asarray(PRONY.g) * rule.b ** 2))
    np.testing.assert_allclose(sed[0], w0, rtol=1e-9)
    np.testing.assert_allclose(sed[-1], G0 * PRONY.g_inf * gamma ** 2 / 2, rtol=1e-3)
    assert min(s.min() for s in sed) >= 0


def test_sinusoidal_uniaxial_stress_follows_the_complex_modulus():
    mesh, basis, bc, K_rest, Kv = block()
    f, per, periods = 50.0, 100, 10                 # 10 periods = 10 tau_2: the transient is gone
    w, dt, eps0 = 2 * np.pi * f, 1.0 / (f * per), 0.01
    rule = mv.Hereditary(PRONY, dt)
    X, nd = basis.doflocs, basis.nodal_dofs
    p = mesh.p
    rollers = np.concatenate([nd[0, p[0] < 1e-9], nd[1, p[1] < 1e-9], nd[2, p[2] < 1e-9]])
    top = nd[1, p[1] > 1 - 1e-9]
    D = np.concatenate([rollers, top])
    steps = run(rule, K_rest, Kv, D, lambda k: np.concatenate(
        [np.zeros(len(rollers)), eps0 * np.sin(w * k * dt) * X[1, top]]), per * periods)
    t = dt * np.arange(1, per * periods + 1)[-per:]
    syy = np.array([stress(bc, u, us)[1, 1].mean() for u, us in steps[-per:]])
    A = np.column_stack([np.sin(w * t), np.cos(w * t)])
    a, b = np.linalg.lstsq(A, syy, rcond=None)[0]
    gs = G0 * mv.complex_modulus(PRONY, w)
    E_star = 9 * KAPPA * gs / (3 * KAPPA + gs)
    assert np.hypot(a, b) / eps0 == pytest.approx(abs(E_star), rel=2e-3)
    assert np.arctan2(b, a) == pytest.approx(np.angle(E_star), abs=3e-3)
    # the lateral faces moved: the effective Poisson ratio differs from the instantaneous one
    E0 = 9 * KAPPA * G0 / (3 * KAPPA + G0)
    assert abs(abs(E_star) - E0) / E0 > 0.05


def test_moduli_closed_forms_and_bad_prony():
    assert mv.relaxation(PRONY, 0.0) == pytest.approx(1.0)
    assert mv.relaxation(PRONY, 1e3) == pytest.approx(PRONY.g_inf)
    assert mv.complex_modulus(PRONY, 1e9) == pytest.approx(1.0, rel=1e-6)
    assert mv.complex_modulus(PRONY, 0.0) == pytest.approx(PRONY.g_inf)
    # storage modulus rises with frequency for any Prony series
    assert np.all(np.diff(mv.complex_modulus(mv.SKIN, 2 * np.pi * np.array([20, 30, 50, 80])).real) > 0)
    with pytest.raises(ValueError, match=r"sum < 1"):
        mv.Prony(g=(0.6, 0.5), tau=(0.1, 1.0))
    with pytest.raises(ValueError, match=r"equal length"):
        mv.Prony(g=(0.3,), tau=(0.1, 1.0))


def test_the_waveform_follows_the_thesis_example():
    """Issue 35, item 2: the thesis's example deepest point is t = 0.005 s at 50 Hz (T/4); the generator's default
    waveform, A sin(2 pi f t) from rest, is deepest there (the earlier haversine, deepest at T/2, fails this)."""
    t = np.linspace(0.0, 0.02, 401)
    assert t[np.argmax(mv.depth(t, 50.0))] == pytest.approx(0.005, abs=1e-9)
    assert mv.depth(np.array([0.005]), 50.0)[0] == pytest.approx(mv.AMPLITUDE)
    assert mv.depth(np.array([0.015]), 50.0)[0] < 0  # plane above the skin: make_samples.Problem touches nothing
    assert t[np.argmax(mv.depth(t, 50.0, "haversine"))] == pytest.approx(0.01, abs=1e-9)


def test_the_series_receptors_are_the_quarters_table_tips_and_the_edge_band_one_pitch():
    """The new chapter-4 block (tips every 0.22 mm) solved on its quarter x, z >= c: the receptors are the RA-I table's
    tips there (c + 0.11 ... 0.99 mm, 5 x 5, by x then z) and the edge tips those within one pitch (0.22 mm) of the
    plane's outline: the rows at c + 0.99 (0.01 mm inside it), not those at c + 0.77 (0.23 mm inside)."""
    import make_chapter4 as mc

    sm = mv.build_model("3d")
    c = sm.xc
    t = c + np.array([0.11, 0.33, 0.55, 0.77, 0.99])
    np.testing.assert_allclose(sm.tips[:, 0], np.repeat(t, 5), atol=1e-9)
    np.testing.assert_allclose(sm.tips[:, 2], np.tile(t, 5), atol=1e-9)
    np.testing.assert_allclose(sm.tips[:, 1], mc.Y_TIP)
    assert sm.mesh.p[0].min() == pytest.approx(c) and sm.mesh.t.shape[1] == 7560
    edge = mv.edge_tips(sm.tips, c, c)
    assert np.flatnonzero(edge).tolist() == [4, 9, 14, 19, 20, 21, 22, 23, 24]
