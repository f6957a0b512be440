"""SED from stress and strain tensors, for exports that carry no SED array (stage 1b).

::

    stress (..., 6) + strain (..., 6) --sed_exact / sed_equivalent--> SED (...) in J/m^3

Internally tensors are 6-vectors in the order ``xx yy zz xy yz xz`` with *tensor* shear
(eps_xy = (du/dy + dv/dx) / 2). FE tools differ in component order and in whether shear
strain is the tensor or the engineering value gamma = 2 eps; a :class:`Convention` says which,
and :data:`PRESETS` holds the conventions of the common tools, each with its source in the
preset's ``note`` ([V] the tool's own source, manual or files, [3P] third-party material,
[UNVERIFIED]; see :ref:`fe-presets` and :ref:`fe-what-is-verified`).

Two formulas (:ref:`method-sed`):

- ``'exact'``: the linear-elastic strain energy density U = 1/2 sigma_ij eps_ij.
- ``'equivalent'``: the study's equivalent SED (Glinka), U ~ 1/2 sigma_e eps_e with the von
  Mises stress sigma_e from principal stresses and
  eps_e = 1/(1+nu) sqrt(((e1-e2)^2 + (e2-e3)^2 + (e3-e1)^2) / 2) from principal strains.

And from stress alone, with the elastic constants (``'stress'``, :func:`sed_from_stress`):
U = (1 + nu)/(2E) sigma:sigma - nu/(2E) tr(sigma)^2, the linear-elastic, small-strain SED of an
isotropic material.
"""

from __future__ import annotations

from ._typing import ArrayLike

from dataclasses import dataclass

import numpy as np

from ._validation import check_option

__all__ = ["Convention", "PRESETS", "CANONICAL_ORDER", "to_canonical", "sed_exact", "sed_equivalent", "sed_from_stress", "full_tensor"]

#: Internal component order.
CANONICAL_ORDER: tuple[str, ...] = ("xx", "yy", "zz", "xy", "yz", "xz")


@dataclass(frozen=True)
class Convention:
    """How a tool orders the six components and writes shear strain.

    Parameters
    ----------
    order : tuple of 6 str
        Component order of 6-component arrays, e.g. ``('xx','yy','zz','xy','xz','yz')`` for
        Abaqus 11 22 33 12 13 23. ``'zx'`` is accepted for ``'xz'``.
    shear : {'tensor', 'engineering'}
        Shear strain as written: tensor eps_ij, or engineering gamma_ij = 2 eps_ij.
    note : str
        Source and verification status ([V], [3P] or [UNVERIFIED]; see :ref:`fe-presets`).
    """

    order: tuple[str, ...]
    shear: str
    note: str = ""

    def __post_init__(self):
        order = tuple("xz" if c == "zx" else c for c in self.order)
        if sorted(order) != sorted(CANONICAL_ORDER):
            raise ValueError(f"'order' must be a permutation of {CANONICAL_ORDER}; got {self.order!r} instead.")
        check_option("shear", self.shear, ("tensor", "engineering"))
        object.__setattr__(self, "order", order)


_VOIGT_VTK = ("xx", "yy", "zz", "xy", "yz", "xz")
_VOIGT_ABQ = ("xx", "yy", "zz", "xy", "xz", "yz")

#: Conventions of common FE tools for 6-component arrays (:ref:`fe-presets`, tool by tool in docs/fe-export.md).
#: Named columns (S12, EPXZ, solid.eXY, ...) are matched by name; the order only matters
#: for unnamed 6-component arrays.
PRESETS: dict[str, Convention] = {
    "abaqus": Convention(_VOIGT_ABQ, "engineering", "S11 S22 S33 S12 S13 S23; LE/E engineering shear [3P]"),
    "ansys": Convention(_VOIGT_VTK, "engineering", "X Y Z XY YZ XZ [V, pymapdl-reader, MAPDL listings]; "
                                                   "EPEL engineering shear [V, Theory Ref. 2.1.1]"),
    "comsol": Convention(_VOIGT_VTK, "tensor", "solid.eXY etc. Green-Lagrange, tensor shear [V]"),
    "febio": Convention(_VOIGT_VTK, "tensor", "plotfile xx yy zz xy yz xz (implied for .xplt); Lagrange strain tensor shear [V]"),
    "calculix-frd": Convention(("xx", "yy", "zz", "xy", "yz", "zx"), "tensor", ".frd / ccx2paraview XX YY ZZ XY YZ ZX; tensor shear [V]"),
    "calculix-dat": Convention(_VOIGT_ABQ, "tensor", ".dat sxx syy szz sxy sxz syz; tensor shear [V]"),
    "sfepy": Convention(_VOIGT_ABQ, "engineering", "cauchy_strain 11 22 33 12 13 23, shear doubled [V]"),
    "code_aster": Convention(_VOIGT_ABQ, "tensor", "SIXX SIYY SIZZ SIXY SIXZ SIYZ, EPXX ... EPYZ [V, catalogue]; "
                                                   "tensor shear [V, eps1mc.f halves the B-matrix shear]; MED read by name"),
    "lsdyna": Convention(_VOIGT_VTK, "tensor", "xx yy zz xy yz xz [V, lasso]; tensor shear [3P]"),
    "elmer": Convention(_VOIGT_VTK, "tensor", "Stress_xx yy zz xy yz xz; tensor shear [V]"),
    "kratos": Convention(_VOIGT_VTK, "engineering",
                         "CAUCHY_STRESS_VECTOR, GREEN_LAGRANGE_STRAIN_VECTOR xx yy zz xy yz xz; engineering shear [V]"),
    "vtk": Convention(_VOIGT_VTK, "tensor", "VTK symmetric-tensor order XX YY ZZ XY YZ XZ [UNVERIFIED]; shear assumed tensor"),
    "openfoam": Convention(("xx", "xy", "xz", "yy", "yz", "zz"), "tensor",
                           "symmTensor XX XY XZ YY YZ ZZ (the upper triangle row by row) [V, symmTensor.C componentNames]; "
                           "tensor shear [UNVERIFIED]"),
}


def to_canonical(values: ArrayLike, convention: Convention, *, is_strain: bool) -> np.ndarray:
    """Reorder a (..., 6) array to ``xx yy zz xy yz xz`` and halve engineering shear strain.

    Parameters
    ----------
    values : array_like of shape (..., 6)
        Components in ``convention.order``; stress in Pa, strain dimensionless.
    convention : Convention
        Order and shear convention of ``values``.
    is_strain : bool
        Whether ``values`` is a strain (only strain shear is ever engineering).

    Returns
    -------
    ndarray of shape (..., 6)
        Canonical order, tensor shear.
    """
    values = np.asarray(values, dtype=float)
    if values.shape[-1] != 6:
        raise ValueError(f"A tensor array must have 6 components on its last axis; got shape {values.shape} instead.")
    idx = [convention.order.index(c) for c in CANONICAL_ORDER]
    out = values[..., idx]
    if is_strain and convention.shear == "engineering":
        out = out.copy()
        out[..., 3:] *= 0.5
    return out


def full_tensor(v6: ArrayLike) -> np.ndarray:
    """(..., 6) canonical components -> (..., 3, 3) symmetric tensors."""
    v6 = np.asarray(v6, dtype=float)
    xx, yy, zz, xy, yz, xz = np.moveaxis(v6, -1, 0)
    return np.stack(
        [np.stack([xx, xy, xz], -1), np.stack([xy, yy, yz], -1), np.stack([xz, yz, zz], -1)], -2
    )


def sed_exact(stress: ArrayLike, strain: ArrayLike) -> np.ndarray:
    """Linear-elastic strain energy density U = 1/2 sigma_ij eps_ij.

    Parameters
    ----------
    stress : array_like of shape (..., 6)
        Cauchy stress, canonical order ``xx yy zz xy yz xz``, in Pa.
    strain : array_like of shape (..., 6)
        Small strain, canonical order, **tensor** shear, dimensionless.

    Returns
    -------
    ndarray of shape (...)
        SED in J/m^3 (= Pa).

    Examples
    --------
    Uniaxial tension sigma_xx = 2 Pa, eps_xx = 0.5 gives U = 0.5 J/m^3:

    >>> float(sed_exact([2, 0, 0, 0, 0, 0], [0.5, 0, 0, 0, 0, 0]))
    0.5
    """
    s = np.asarray(stress, dtype=float)
    e = np.asarray(strain, dtype=float)
    normal = np.einsum("...i,...i->...", s[..., :3], e[..., :3])
    shear = np.einsum("...i,...i->...", s[..., 3:], e[..., 3:])
    return 0.5 * (normal + 2.0 * shear)


def _equivalent(principal: np.ndarray) -> np.ndarray:
    p1, p2, p3 = np.moveaxis(principal, -1, 0)
    return np.sqrt(0.5 * ((p1 - p2) ** 2 + (p2 - p3) ** 2 + (p3 - p1) ** 2))


def sed_equivalent(stress: ArrayLike, strain: ArrayLike, poisson: ArrayLike) -> np.ndarray:
    """The study's equivalent SED, U ~ 1/2 sigma_e eps_e (:ref:`method-sed`, after Glinka).

    Parameters
    ----------
    stress : array_like of shape (..., 6)
        Cauchy stress, canonical order, in Pa.
    strain : array_like of shape (..., 6)
        Small strain, canonical order, tensor shear, dimensionless.
    poisson : float or array_like of shape (...)
        Poisson's ratio nu of the material at each point, in (-1, 0.5].

    Returns
    -------
    ndarray of shape (...)
        Equivalent SED in J/m^3. For a uniaxial stress state in an isotropic material it
        equals the exact SED; under hydrostatic load it is 0 (it ignores volumetric energy).
    """
    nu = np.asarray(poisson, dtype=float)
    if np.any(~np.isfinite(nu)) or np.any(nu <= -1) or np.any(nu > 0.5):
        raise ValueError(f"'poisson' must be in (-1, 0.5]; got {poisson!r} instead.")
    s_principal = np.linalg.eigvalsh(full_tensor(stress))
    e_principal = np.linalg.eigvalsh(full_tensor(strain))
    sigma_e = _equivalent(s_principal)
    eps_e = _equivalent(e_principal) / (1.0 + nu)
    return 0.5 * sigma_e * eps_e


def sed_from_stress(stress: ArrayLike, young: ArrayLike, poisson: ArrayLike) -> np.ndarray:
    """Linear-elastic SED of an isotropic material from its stress alone (small strain).

    U = (1 + nu)/(2E) sigma:sigma - nu/(2E) tr(sigma)^2, which is 1/2 sigma:eps with
    eps = ((1 + nu) sigma - nu tr(sigma) I) / E (Hooke's law inverted).

    Parameters
    ----------
    stress : array_like of shape (..., 6)
        Cauchy stress, canonical order ``xx yy zz xy yz xz``, in Pa.
    young : float or array_like of shape (...)
        Young's modulus E of the material at each value, in Pa (> 0).
    poisson : float or array_like of shape (...)
        Poisson's ratio nu, in (-1, 0.5] (0.5: incompressible, the volumetric energy is 0).

    Returns
    -------
    ndarray of shape (...)
        SED in J/m^3.

    Examples
    --------
    Uniaxial stress 2 Pa in a material of E = 4 Pa: sigma^2 / (2E) = 0.5 J/m^3:

    >>> float(sed_from_stress([2, 0, 0, 0, 0, 0], 4.0, 0.3))
    0.5
    """
    s = np.asarray(stress, dtype=float)
    e = np.asarray(young, dtype=float)
    nu = np.asarray(poisson, dtype=float)
    if np.any(~np.isfinite(e)) or np.any(e <= 0):
        raise ValueError(f"'young' must be finite and > 0 Pa; got {young!r} instead.")
    if np.any(~np.isfinite(nu)) or np.any(nu <= -1) or np.any(nu > 0.5):
        raise ValueError(f"'poisson' must be in (-1, 0.5]; got {poisson!r} instead.")
    squares = np.sum(s[..., :3] ** 2, axis=-1) + 2.0 * np.sum(s[..., 3:] ** 2, axis=-1)
    trace = np.sum(s[..., :3], axis=-1)
    return ((1.0 + nu) * squares - nu * trace ** 2) / (2.0 * e)
