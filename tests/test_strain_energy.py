"""SED from stress and strain tensors: closed forms for every tool's conventions."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from afferent.strain_energy import (
    CANONICAL_ORDER,
    PRESETS,
    Convention,
    full_tensor,
    sed_equivalent,
    sed_exact,
    to_canonical,
)

E_PA, NU = 0.08e6, 0.48  # dermis (docs/method.md, "1. The FE skin model")
G_PA = E_PA / (2 * (1 + NU))


def hooke(eps6):
    """Isotropic linear elasticity: stress (canonical, Pa) from strain (canonical, tensor shear)."""
    lam = E_PA * NU / ((1 + NU) * (1 - 2 * NU))
    eps = full_tensor(eps6)
    sig = lam * np.trace(eps) * np.eye(3) + 2 * G_PA * eps
    return np.array([sig[0, 0], sig[1, 1], sig[2, 2], sig[0, 1], sig[1, 2], sig[0, 2]])


def test_uniaxial_tension_exact_and_equivalent_agree_with_closed_form():
    sigma = 123.4567  # Pa
    eps = np.array([sigma / E_PA, -NU * sigma / E_PA, -NU * sigma / E_PA, 0, 0, 0])
    stress = np.array([sigma, 0, 0, 0, 0, 0])
    expected = sigma**2 / (2 * E_PA)  # U = sigma^2 / 2E
    np.testing.assert_allclose(sed_exact(stress, eps), expected, rtol=1e-14)
    np.testing.assert_allclose(sed_equivalent(stress, eps, NU), expected, rtol=1e-14)


def test_pure_shear_exact_closed_form():
    tau = 31.7  # Pa, sigma_xy
    eps_xy = tau / (2 * G_PA)  # tensor shear
    stress = np.array([0, 0, 0, tau, 0, 0])
    strain = np.array([0, 0, 0, eps_xy, 0, 0])
    np.testing.assert_allclose(sed_exact(stress, strain), tau**2 / (2 * G_PA), rtol=1e-14)  # U = tau^2 / 2G


#: Each tool's 6-component layout as its documentation or source spells it, written out here
#: independently of afferent's PRESETS table (sources: the tools' manuals/source files named in
#: each preset's note): the component each position holds, and the factor on shear strain.
WRITTEN = {
    "abaqus": (("11", "22", "33", "12", "13", "23"), 2),   # S11 S22 S33 S12 S13 S23; LE engineering
    "ansys": (("X", "Y", "Z", "XY", "YZ", "XZ"), 2),       # SX SY SZ SXY SYZ SXZ; EPEL engineering
    "comsol": (("XX", "YY", "ZZ", "XY", "YZ", "XZ"), 1),   # solid.eXX ... solid.eXZ, tensor
    "febio": (("xx", "yy", "zz", "xy", "yz", "xz"), 1),    # plotfile mat3ds; Lagrange strain tensor
    "calculix-frd": (("XX", "YY", "ZZ", "XY", "YZ", "ZX"), 1),  # frd.c: SXX SYY SZZ SXY SYZ SZX
    "calculix-dat": (("xx", "yy", "zz", "xy", "xz", "yz"), 1),  # printout.f: sxx syy szz sxy sxz syz
    "sfepy": (("11", "22", "33", "12", "13", "23"), 2),    # cauchy_strain, shear doubled
    "code_aster": (("XX", "YY", "ZZ", "XY", "XZ", "YZ"), 1),  # SIXX SIYY SIZZ SIXY SIXZ SIYZ
    "lsdyna": (("xx", "yy", "zz", "xy", "yz", "xz"), 1),   # lasso d3plot order
    "elmer": (("xx", "yy", "zz", "xy", "yz", "xz"), 1),    # Stress_xx ... Stress_xz
    "vtk": (("XX", "YY", "ZZ", "XY", "YZ", "XZ"), 1),      # VTK symmetric tensor
    "kratos": (("XX", "YY", "ZZ", "XY", "YZ", "XZ"), 2),   # CAUCHY_STRESS_VECTOR Voigt; GREEN_LAGRANGE_STRAIN_VECTOR engineering
    "openfoam": (("XX", "XY", "XZ", "YY", "YZ", "ZZ"), 1),  # symmTensor.C componentNames xx xy xz yy yz zz
}
_AXIS = {"1": "x", "2": "y", "3": "z", "X": "x", "Y": "y", "Z": "z", "x": "x", "y": "y", "z": "z"}


def _canonical_name(label):
    pair = "".join(_AXIS[c] for c in (label * 2 if len(label) == 1 else label))
    return {"yx": "xy", "zy": "yz", "zx": "xz"}.get(pair, pair)


def test_every_preset_is_covered_by_the_written_layouts():
    assert set(WRITTEN) == set(PRESETS)


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_each_preset_puts_every_written_component_in_its_place(preset):
    """A state with six different values is written in the tool's layout (from WRITTEN, not from
    PRESETS); to_canonical must return each component in its canonical slot, shear halved where
    the tool writes engineering strain. A wrong order or shear entry in PRESETS fails here (the
    SED alone could not tell a consistent yz/xz swap)."""
    labels, shear_factor = WRITTEN[preset]
    strain = np.array([1.1e-3, -0.7e-3, 0.3e-3, 2.9e-3, -1.3e-3, 0.6e-3])  # canonical, tensor shear
    stress = hooke(strain)
    slot = [CANONICAL_ORDER.index(_canonical_name(lab)) for lab in labels]
    written_stress = stress[slot]
    written_strain = strain[slot] * np.where(np.array(slot) >= 3, shear_factor, 1)
    conv = PRESETS[preset]
    np.testing.assert_array_equal(to_canonical(written_stress, conv, is_strain=False), stress)
    np.testing.assert_allclose(to_canonical(written_strain, conv, is_strain=True), strain, rtol=1e-15)
    s, e = to_canonical(written_stress, conv, is_strain=False), to_canonical(written_strain, conv, is_strain=True)
    np.testing.assert_allclose(sed_exact(s, e), 0.5 * np.sum(full_tensor(stress) * full_tensor(strain)), rtol=1e-14)


def test_wrong_shear_convention_changes_the_energy():
    """Reading engineering shear as tensor shear doubles the shear energy: the convention matters."""
    conv_right = PRESETS["abaqus"]
    conv_wrong = Convention(conv_right.order, "tensor")
    strain = np.array([0, 0, 0, 1e-3, 0, 0])
    stress = hooke(strain)
    written = strain.copy()
    written[3:] *= 2  # abaqus writes gamma
    right = sed_exact(stress, to_canonical(written, conv_right, is_strain=True))
    wrong = sed_exact(stress, to_canonical(written, conv_wrong, is_strain=True))
    np.testing.assert_allclose(wrong, 2 * right, rtol=1e-14)


def test_equivalent_sed_ignores_hydrostatic_energy():
    p = 50.0
    stress = np.array([-p, -p, -p, 0, 0, 0])
    strain = stress / (3 * E_PA / (3 * (1 - 2 * NU)))  # eps = sigma / 3K
    assert sed_equivalent(stress, strain, NU) == pytest.approx(0.0, abs=1e-12)
    assert sed_exact(stress, strain) > 0


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1e-2, 1e-2), min_size=6, max_size=6))
def test_exact_sed_is_non_negative_and_frame_invariant(eps_list):
    strain = np.array(eps_list)
    stress = hooke(strain)
    u = sed_exact(stress, strain)
    assert u >= -1e-12 * max(1.0, abs(u))
    # rotate the frame: SED is invariant
    theta = 0.3
    R = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
    rot = lambda v: (lambda m: np.array([m[0, 0], m[1, 1], m[2, 2], m[0, 1], m[1, 2], m[0, 2]]))(R @ full_tensor(v) @ R.T)  # noqa: E731
    np.testing.assert_allclose(sed_exact(rot(stress), rot(strain)), u, rtol=1e-9, atol=1e-18)


def test_bad_convention_and_shapes_are_errors():
    with pytest.raises(ValueError, match=re.escape("'order' must be a permutation of")):
        Convention(("xx", "yy", "zz", "xy", "xy", "xz"), "tensor")
    with pytest.raises(ValueError, match=re.escape("Allowed values are 'tensor' and 'engineering', but got 'voigt' instead.")):
        Convention(CANONICAL_ORDER, "voigt")
    with pytest.raises(ValueError, match=re.escape("must have 6 components on its last axis; got shape (3,) instead.")):
        to_canonical([1, 2, 3], PRESETS["vtk"], is_strain=False)
    with pytest.raises(ValueError, match=re.escape("'poisson' must be in (-1, 0.5]; got 0.7 instead.")):
        sed_equivalent(np.zeros(6), np.zeros(6), 0.7)


def _mandel(t):
    """3x3 symmetric tensor -> Mandel 6-vector (xx yy zz, sqrt2 yz, sqrt2 xz, sqrt2 xy): a:b = m(a).m(b)."""
    r2 = np.sqrt(2.0)
    return np.array([t[0, 0], t[1, 1], t[2, 2], r2 * t[1, 2], r2 * t[0, 2], r2 * t[0, 1]])


def _from_mandel(m):
    r2 = np.sqrt(2.0)
    return np.array([[m[0], m[5] / r2, m[4] / r2], [m[5] / r2, m[1], m[3] / r2], [m[4] / r2, m[3] / r2, m[2]]])


def _canon(t):
    return np.array([t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[1, 2], t[0, 2]])


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), log_modulus=st.floats(2, 11), log_strain=st.floats(-9, -0.5),
       preset=st.sampled_from(sorted(PRESETS)))
def test_property_sed_from_tensors_is_non_negative_and_frame_invariant_under_every_preset(
        seed, log_modulus, log_strain, preset):
    """Any positive-definite (anisotropic) elasticity, moduli 100 Pa - 100 GPa, strains 1e-9 - 0.3,
    written in each tool's own layout (WRITTEN, not PRESETS) and read back through its preset:
    U = 1/2 sigma:eps equals the closed form 1/2 m(eps).C.m(eps) >= 0, and rotating the frame (both
    tensors by the same random rotation) leaves it unchanged."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((6, 6))
    c = 10.0**log_modulus * (a @ a.T + 0.05 * np.eye(6))  # Mandel stiffness, positive definite
    eps = rng.standard_normal((3, 3)) * 10.0**log_strain
    eps = (eps + eps.T) / 2
    sig = _from_mandel(c @ _mandel(eps))
    expected = 0.5 * _mandel(eps) @ c @ _mandel(eps)
    assert expected > 0
    labels, shear_factor = WRITTEN[preset]
    conv = PRESETS[preset]
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    for s3, e3 in ((sig, eps), (rot @ sig @ rot.T, rot @ eps @ rot.T)):
        slot = [CANONICAL_ORDER.index(_canonical_name(lab)) for lab in labels]
        written_s = _canon(s3)[slot]
        written_e = _canon(e3)[slot] * np.where(np.array(slot) >= 3, shear_factor, 1)
        u = sed_exact(to_canonical(written_s, conv, is_strain=False), to_canonical(written_e, conv, is_strain=True))
        np.testing.assert_allclose(u, expected, rtol=1e-9)
