"""Coded experimental designs for the response-surface (RSM) calibration, from pydoe.

::

    base SigmoidParams --increments--> dxi --decode(design, base, dxi)--> parameter sets to evaluate

Each transduction parameter xi_k (alpha in A, gamma in 1/Pa, lambda in Pa) is *coded*
around a base point,

    chi_k = (xi_k - xi_k,base) / dxi_k,    dxi_k = increment * |xi_k,base|   (the study: 5 %),

so a design in coded units (levels -1, 0, +1, ...) is the same for every base point. The
designs come from pydoe (``import pydoe``; the maintained successor of pyDOE/pyDOE2, which
exposes ``ff2n``, ``fullfact``, ``ccdesign``, ``bbdesign`` and ``repeat_center`` at the top
level):

- :func:`factorial_design`, the study's design: two-level full factorial (``pydoe.ff2n``)
  plus centre run(s): 2^3 + 1 = 9 runs for 3 factors, enough for
  the first-order model ``ssd ~ b0 + sum_k b_k chi_k``.
- :func:`central_composite` (``pydoe.ccdesign``) and :func:`box_behnken` (``pydoe.bbdesign``)
  for the second-order surface. pydoe replicates the centre run by default (4 + 4 for a
  central composite design, 3 for Box-Behnken) to estimate pure error; the objective here is
  deterministic, so replicates would repeat the same number: one centre run is the default.

pydoe is imported inside the functions (it takes ~1 s to import), so ``import
afferent.calibration`` stays fast.
"""

from __future__ import annotations

from .._typing import ArrayLike

import numbers
from typing import Literal, get_args

import numpy as np

from .._validation import check_option
from .._validation import plain as _plain
from ..transduction import SigmoidParams

__all__ = [
    "PARAMETERS",
    "UNITS",
    "DEFAULT_INCREMENT",
    "factorial_design",
    "central_composite",
    "box_behnken",
    "make_design",
    "DESIGNS",
    "increments",
    "encode",
    "decode",
    "params_to_vector",
    "vector_to_params",
]

#: The calibrated parameters, in the order of every coded vector and design column.
PARAMETERS = ("alpha", "gamma", "lambda")
#: Their SI units.
UNITS = {"alpha": "A", "gamma": "1/Pa", "lambda": "Pa"}
#: The study's increment: dxi_k = 5 % of the base value (the first step of its RSM procedure).
DEFAULT_INCREMENT = 0.05


def _check_n(n_factors) -> int:
    if isinstance(n_factors, bool) or not isinstance(n_factors, numbers.Integral):
        raise TypeError(f"'n_factors' must be an int; got {_plain(n_factors)!r} instead.")
    if n_factors < 1:
        raise ValueError(f"'n_factors' must be >= 1; got {_plain(n_factors)!r} instead.")
    return int(n_factors)


def _check_center(center, minimum: int = 0) -> int:
    if isinstance(center, bool) or not isinstance(center, numbers.Integral):
        raise TypeError(f"'center' must be an int (number of centre runs); got {_plain(center)!r} instead.")
    if center < minimum:
        raise ValueError(f"'center' must be >= {minimum}; got {_plain(center)!r} instead.")
    return int(center)


def factorial_design(n_factors: int = 3, *, center: int = 1) -> np.ndarray:
    """Two-level full factorial design plus centre runs, in coded units (the study's design).

    ``pydoe.ff2n(n_factors)`` (all 2^n combinations of -1 and +1, in pydoe's standard order)
    followed by ``center`` rows of zeros.

    Parameters
    ----------
    n_factors : int, default=3
        Number of coded parameters (alpha, gamma, lambda: 3).
    center : int, default=1
        Number of centre runs (the study: 1).

    Returns
    -------
    ndarray of shape (2**n_factors + center, n_factors)
        Coded levels (dimensionless).

    Examples
    --------
    >>> factorial_design(3).shape
    (9, 3)
    """
    import pydoe

    n = _check_n(n_factors)
    c = _check_center(center)
    return np.vstack([np.asarray(pydoe.ff2n(n), dtype=float), np.zeros((c, n))])


def central_composite(n_factors: int = 3, *, center: int = 1, alpha: str = "rotatable",
                      face: str = "circumscribed") -> np.ndarray:
    """Central composite design in coded units (``pydoe.ccdesign``).

    The 2^n factorial points, ``center`` centre runs, and 2n axial ("star") points at coded
    distance ``(2**n) ** 0.25`` (rotatable; 1.682 for n = 3) or as ``alpha``/``face`` ask.

    Parameters
    ----------
    n_factors : int, default=3
        Number of coded parameters.
    center : int, default=1
        Centre runs (all in the factorial block; pydoe's default is 4 + 4, useful only for a
        noisy response).
    alpha : {'rotatable', 'orthogonal'}, default='rotatable'
        How pydoe places the axial points.
    face : {'circumscribed', 'inscribed', 'faced'}, default='circumscribed'
        pydoe's ``face``: axial points outside the cube (ccc), the cube shrunk inside the
        axial points (cci), or axial points on the faces (ccf, distance 1).

    Returns
    -------
    ndarray of shape (2**n_factors + center + 2 * n_factors, n_factors)
        Coded levels; 15 runs for 3 factors with the defaults.

    Examples
    --------
    >>> central_composite(3).shape
    (15, 3)
    """
    import pydoe

    n = _check_n(n_factors)
    if n < 2:
        raise ValueError(f"A central composite design needs 'n_factors' >= 2; got {n} instead.")
    c = _check_center(center)
    check_option("alpha", alpha, ("rotatable", "orthogonal"))
    check_option("face", face, ("circumscribed", "inscribed", "faced"))
    return np.asarray(pydoe.ccdesign(n, center=(c, 0), alpha=alpha, face=face), dtype=float)


def box_behnken(n_factors: int = 3, *, center: int = 1) -> np.ndarray:
    """Box-Behnken design in coded units (``pydoe.bbdesign``): edge mid-points plus centre runs.

    Parameters
    ----------
    n_factors : int, default=3
        Number of coded parameters, >= 3.
    center : int, default=1
        Number of centre runs (pydoe's default for 3 factors is 3).

    Returns
    -------
    ndarray of shape (n_runs, n_factors)
        Coded levels -1, 0, +1; 13 runs for 3 factors with ``center=1``.

    Examples
    --------
    >>> box_behnken(3).shape
    (13, 3)
    """
    import pydoe

    n = _check_n(n_factors)
    if n < 3:
        raise ValueError(f"A Box-Behnken design needs 'n_factors' >= 3; got {n} instead.")
    c = _check_center(center, minimum=1)
    return np.asarray(pydoe.bbdesign(n, center=c), dtype=float)


#: design name -> function(n_factors, center=1) returning coded runs.
DesignName = Literal["factorial", "ccd", "bbd"]
DESIGNS = dict(zip(get_args(DesignName), (factorial_design, central_composite, box_behnken), strict=True))


def make_design(name: str, n_factors: int = 3) -> np.ndarray:
    """The coded design called ``name`` ('factorial', 'ccd' or 'bbd') with one centre run.

    Parameters
    ----------
    name : {'factorial', 'ccd', 'bbd'}
        Two-level factorial + centre (first order), central composite or Box-Behnken
        (second order).
    n_factors : int, default=3
        Number of coded parameters.

    Returns
    -------
    ndarray of shape (n_runs, n_factors)
        Coded levels (dimensionless).
    """
    check_option("design", name, tuple(DESIGNS))
    return DESIGNS[name](n_factors)


def _vector(name: str, v, n: int | None = None) -> np.ndarray:
    arr = np.asarray(v, dtype=float)
    if arr.ndim != 1 or (n is not None and arr.size != n):
        want = f"({n},)" if n is not None else "(n_factors,)"
        raise ValueError(f"{name!r} must be a vector of shape {want}; got shape {arr.shape} instead.")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name!r} must be finite; got {arr.tolist()!r} instead.")
    return arr


def increments(base: ArrayLike | SigmoidParams, increment: ArrayLike=DEFAULT_INCREMENT, *, floor: ArrayLike | None=None) -> np.ndarray:
    """Coding steps ``dxi_k = increment_k * max(|xi_k,base|, floor_k)``, in each parameter's unit.

    Parameters
    ----------
    base : array_like of shape (n_factors,) or SigmoidParams
        Base point (alpha A, gamma 1/Pa, lambda Pa).
    increment : float or array_like of shape (n_factors,), default=0.05
        Fraction of the base value (the study: 5 %), in (0, 1).
    floor : array_like of shape (n_factors,), optional
        Smallest magnitude the fraction is taken of (same units as ``base``), so a parameter
        passing through zero (lambda can change sign) keeps a usable step. Default 0.

    Returns
    -------
    ndarray of shape (n_factors,)
        dxi in each parameter's unit, > 0.

    Raises
    ------
    ValueError
        If ``increment`` is not in (0, 1), or a step is 0 (a base value of 0 without floor).

    Examples
    --------
    >>> increments([2.46e-8, 4.6e-3, 300.0]).tolist()
    [1.23e-09, 0.00023, 15.0]
    """
    b = _vector("base", params_to_vector(base) if isinstance(base, SigmoidParams) else base)
    inc = np.broadcast_to(np.asarray(increment, dtype=float), b.shape)
    if not np.all((inc > 0) & (inc < 1)):
        raise ValueError(f"'increment' must be a fraction in (0, 1), e.g. 0.05 for 5 %; got {_plain(increment)!r} instead.")
    mag = np.abs(b) if floor is None else np.maximum(np.abs(b), np.abs(_vector("floor", floor, b.size)))
    step = inc * mag
    if not np.all(step > 0):
        k = int(np.flatnonzero(~(step > 0))[0])
        name = PARAMETERS[k] if b.size == len(PARAMETERS) else f"factor {k}"
        raise ValueError(
            f"The coding step of {name!r} must be > 0; got 0 (base value {b[k]!r}) instead. "
            "Increments are a fraction of the base value: start from a non-zero value."
        )
    return step


def encode(values: ArrayLike, base: ArrayLike, step: ArrayLike) -> np.ndarray:
    """Physical -> coded: ``chi = (xi - base) / step``.

    Parameters
    ----------
    values : array_like of shape (n_runs, n_factors) or (n_factors,)
        Parameter values (alpha A, gamma 1/Pa, lambda Pa).
    base, step : array_like of shape (n_factors,)
        Base point and coding steps (:func:`increments`), same units.

    Returns
    -------
    ndarray, same shape as ``values``
        Coded values (dimensionless).

    Examples
    --------
    >>> encode([315.0], [300.0], [15.0]).tolist()
    [1.0]
    """
    return (np.asarray(values, dtype=float) - np.asarray(base, dtype=float)) / np.asarray(step, dtype=float)


def decode(coded: ArrayLike, base: ArrayLike, step: ArrayLike) -> np.ndarray:
    """Coded -> physical: ``xi = base + chi * step`` (the inverse of :func:`encode`).

    Parameters
    ----------
    coded : array_like of shape (n_runs, n_factors) or (n_factors,)
        Coded values (dimensionless).
    base, step : array_like of shape (n_factors,)
        Base point and coding steps, in each parameter's unit.

    Returns
    -------
    ndarray, same shape as ``coded``
        Parameter values (alpha A, gamma 1/Pa, lambda Pa).

    Examples
    --------
    >>> decode([-1.0], [300.0], [15.0]).tolist()
    [285.0]
    """
    return np.asarray(base, dtype=float) + np.asarray(coded, dtype=float) * np.asarray(step, dtype=float)


def params_to_vector(params: SigmoidParams) -> np.ndarray:
    """``[alpha (A), gamma (1/Pa), lambda (Pa)]`` of a :class:`SigmoidParams`."""
    if not isinstance(params, SigmoidParams):
        raise TypeError(f"'params' must be a SigmoidParams; got {type(params).__name__} instead.")
    return np.array([params.alpha, params.gamma, params.lambda_], dtype=float)


def vector_to_params(vec: ArrayLike) -> SigmoidParams:
    """:class:`SigmoidParams` from ``[alpha (A), gamma (1/Pa), lambda (Pa)]``."""
    a, g, lam = (float(v) for v in np.asarray(vec, dtype=float).reshape(3))
    return SigmoidParams(alpha=a, gamma=g, lambda_=lam)
