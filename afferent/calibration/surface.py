"""Response surfaces of the calibration objective (the ssd), in coded parameters.

::

    coded design (n_runs, 3) + ssd (n_runs,) --fit_first_order--> FirstOrderFit --steepest_descent--> dchi
                                              --make_response_surface().fit--> Pipeline --canonical_analysis--> CanonicalAnalysis

- First order (the study's model; steps 3 and 4 of the procedure listed in
  :func:`~afferent.calibration.calibrate`): ``ssd ~ b0 + sum_k b_k chi_k``, fitted by
  :class:`sklearn.linear_model.LinearRegression`; the steepest-descent step is
  ``dchi_k = -b_k / |b_max|``.
- Second order (an extra method): ``ssd ~ b0 + chi^T b + chi^T B chi`` as scikit-learn's own
  ``Pipeline(PolynomialFeatures(2), LinearRegression())``; :func:`canonical_analysis` finds
  the stationary point ``chi_s = -B^-1 b / 2`` and the eigenvalues of ``B`` (all > 0: a
  minimum; all < 0: a maximum; mixed signs: a saddle; some ~0: a ridge).

Every quantity here is in coded units (dimensionless), and the response in the unit of the
objective (ssd: dimensionless for normalised profiles).
"""

from __future__ import annotations

from .._typing import ArrayLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from sklearn.pipeline import Pipeline

from dataclasses import dataclass

import numpy as np

from ..exceptions import CalibrationError

__all__ = [
    "NO_EFFECT_RTOL",
    "FirstOrderFit",
    "fit_first_order",
    "steepest_descent",
    "make_response_surface",
    "quadratic_coefficients",
    "CanonicalAnalysis",
    "canonical_analysis",
    "surface_minimum",
]

#: A coefficient whose magnitude is at most this fraction of the largest one is "no effect":
#: with min-max normalisation of the prediction, alpha cancels out exactly and its
#: coefficient is rounding noise (~1e-16 relative); a real effect is many orders larger.
NO_EFFECT_RTOL = 1e-6


def _xy(coded, response):
    X = np.asarray(coded, dtype=float)
    y = np.asarray(response, dtype=float)
    if X.ndim != 2 or y.shape != (X.shape[0],):
        raise ValueError(
            f"'coded' must be of shape (n_runs, n_factors) and 'response' of shape (n_runs,); "
            f"got {X.shape} and {y.shape} instead."
        )
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise ValueError("'coded' and 'response' must be finite; got NaN or inf instead.")
    return X, y


@dataclass(frozen=True)
class FirstOrderFit:
    """A fitted first-order model ``response ~ intercept + coef . chi``.

    Parameters
    ----------
    intercept : float
        b0, in the response's unit.
    coef : ndarray of shape (n_factors,)
        b_k, in the response's unit per coded unit.
    r2 : float
        Coefficient of determination of the fit on the design runs (1 for a plane; low values
        flag curvature or interaction the first-order model cannot follow). NaN-free: 1.0
        for a constant response.
    no_effect : ndarray of shape (n_factors,), bool
        ``|b_k| <= NO_EFFECT_RTOL * max |b|`` (all True when every b_k is 0).
    model : sklearn.linear_model.LinearRegression
        The fitted estimator.
    """

    intercept: float
    coef: np.ndarray
    r2: float
    no_effect: np.ndarray
    model: object


def fit_first_order(coded: ArrayLike, response: ArrayLike, *, rtol: float = NO_EFFECT_RTOL) -> FirstOrderFit:
    """Fit ``response ~ b0 + sum_k b_k chi_k`` by least squares (``LinearRegression``).

    Parameters
    ----------
    coded : array_like of shape (n_runs, n_factors)
        Coded design points (dimensionless), e.g. :func:`~afferent.calibration.design.factorial_design`.
    response : array_like of shape (n_runs,)
        Objective at each run (ssd; dimensionless for normalised profiles).
    rtol : float, default=1e-6
        Relative threshold for ``no_effect``.

    Returns
    -------
    FirstOrderFit

    Raises
    ------
    ValueError
        If shapes disagree or a value is not finite.
    CalibrationError
        If there are fewer runs than coefficients (n_factors + 1).

    Examples
    --------
    >>> from afferent.calibration.design import factorial_design
    >>> X = factorial_design(3)
    >>> fit = fit_first_order(X, 1.0 + X @ [0.0, -2.0, 0.5])
    >>> np.round(fit.coef, 12).tolist(), fit.no_effect.tolist()
    ([0.0, -2.0, 0.5], [True, False, False])
    """
    from sklearn.linear_model import LinearRegression

    X, y = _xy(coded, response)
    if X.shape[0] < X.shape[1] + 1:
        raise CalibrationError(
            f"A first-order fit of {X.shape[1]} factors needs at least {X.shape[1] + 1} runs; got {X.shape[0]} instead."
        )
    model = LinearRegression().fit(X, y)
    coef = np.asarray(model.coef_, dtype=float)
    pred = model.predict(X)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 if ss_tot == 0.0 else 1.0 - float(np.sum((y - pred) ** 2)) / ss_tot
    bmax = float(np.max(np.abs(coef))) if coef.size else 0.0
    no_effect = np.abs(coef) <= rtol * bmax if bmax > 0 else np.ones(coef.shape, bool)
    return FirstOrderFit(float(model.intercept_), coef, r2, no_effect, model)


def steepest_descent(coef: ArrayLike, *, no_effect: ArrayLike | None=None) -> np.ndarray:
    """The study's step direction in coded units: ``dchi_k = -b_k / |b_max|`` (steepest descent on the plane).

    Parameters
    ----------
    coef : array_like of shape (n_factors,)
        First-order coefficients b_k.
    no_effect : array_like of shape (n_factors,), bool, optional
        Factors whose coefficient is rounding noise: their step is set to exactly 0, so a
        parameter that does not act on the objective is not moved by noise.

    Returns
    -------
    ndarray of shape (n_factors,)
        Coded step; the largest component is -sign(b_max) with magnitude 1. All zeros when
        every coefficient is 0.

    Examples
    --------
    >>> steepest_descent([0.5, -2.0, 1.0]).tolist()
    [-0.25, 1.0, -0.5]
    """
    b = np.asarray(coef, dtype=float)
    if no_effect is not None:
        b = np.where(np.asarray(no_effect, bool), 0.0, b)
    bmax = float(np.max(np.abs(b))) if b.size else 0.0
    return np.zeros_like(b) if bmax == 0.0 else -b / bmax


def make_response_surface(degree: int = 2) -> Pipeline:
    """The second-order response surface: ``Pipeline(PolynomialFeatures(degree), LinearRegression())``.

    ``PolynomialFeatures(include_bias=False)``: the intercept is ``LinearRegression``'s.

    Parameters
    ----------
    degree : int, default=2
        Polynomial degree in the coded parameters.

    Returns
    -------
    sklearn.pipeline.Pipeline
        Unfitted; steps ``'poly'`` and ``'ols'``.
    """
    from sklearn.linear_model import LinearRegression
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import PolynomialFeatures

    return Pipeline([("poly", PolynomialFeatures(degree=degree, include_bias=False)), ("ols", LinearRegression())])


def quadratic_coefficients(surface: Pipeline) -> tuple[float, np.ndarray, np.ndarray]:
    """``(b0, b, B)`` of a fitted degree-2 surface, ``y = b0 + chi^T b + chi^T B chi``.

    Parameters
    ----------
    surface : sklearn.pipeline.Pipeline
        Fitted :func:`make_response_surface` (degree 2).

    Returns
    -------
    b0 : float
        Intercept (response unit).
    b : ndarray of shape (n_factors,)
        Linear coefficients.
    B : ndarray of shape (n_factors, n_factors)
        Symmetric matrix of the quadratic form: ``B_kk`` the pure quadratic coefficient,
        ``B_kl = B_lk`` half the interaction coefficient.
    """
    poly = surface.named_steps["poly"]
    ols = surface.named_steps["ols"]
    powers = np.asarray(poly.powers_)
    if powers.max() > 2:
        raise ValueError(f"'surface' must be of degree 2; got degree {int(powers.sum(axis=1).max())} instead.")
    n = powers.shape[1]
    b = np.zeros(n)
    B = np.zeros((n, n))
    for p, c in zip(powers, np.asarray(ols.coef_, dtype=float)):
        idx = np.flatnonzero(p)
        if p.sum() == 1:
            b[idx[0]] = c
        elif idx.size == 1:  # x_k^2
            B[idx[0], idx[0]] = c
        else:  # x_k x_l
            B[idx[0], idx[1]] = B[idx[1], idx[0]] = c / 2.0
    return float(ols.intercept_), b, B


@dataclass(frozen=True)
class CanonicalAnalysis:
    """Canonical analysis of a second-order surface ``y = b0 + chi^T b + chi^T B chi``.

    Parameters
    ----------
    stationary_point : ndarray of shape (n_factors,)
        ``chi_s = -B^-1 b / 2`` in coded units; NaN-free: for a singular ``B`` (a ridge) the
        least-squares solution is given and ``kind`` is ``'ridge'``.
    stationary_value : float
        Predicted response at ``chi_s``.
    eigenvalues : ndarray of shape (n_factors,)
        Eigenvalues of ``B``, ascending (response unit per coded unit squared).
    eigenvectors : ndarray of shape (n_factors, n_factors)
        Columns are the canonical axes.
    kind : {'minimum', 'maximum', 'saddle', 'ridge'}
        All eigenvalues > 0, all < 0, mixed signs, or some |eigenvalue| <= ``rtol`` x the largest.
    b0 : float
    b : ndarray of shape (n_factors,)
    B : ndarray of shape (n_factors, n_factors)
        The surface's coefficients (see :func:`quadratic_coefficients`).
    """

    stationary_point: np.ndarray
    stationary_value: float
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    kind: str
    b0: float
    b: np.ndarray
    B: np.ndarray


def canonical_analysis(surface: Pipeline, *, rtol: float = 1e-9) -> CanonicalAnalysis:
    """Stationary point and curvature of a fitted second-order surface.

    Parameters
    ----------
    surface : sklearn.pipeline.Pipeline
        Fitted :func:`make_response_surface` of degree 2.
    rtol : float, default=1e-9
        An eigenvalue with ``|lambda_i| <= rtol * max |lambda|`` counts as zero (a ridge).

    Returns
    -------
    CanonicalAnalysis

    Examples
    --------
    >>> X = np.array([[a, b] for a in (-1, 0, 1) for b in (-1, 0, 1)], float)
    >>> y = (X[:, 0] - 0.3) ** 2 + 2 * (X[:, 1] + 0.2) ** 2
    >>> can = canonical_analysis(make_response_surface().fit(X, y))
    >>> np.round(can.stationary_point, 9).tolist(), can.kind
    ([0.3, -0.2], 'minimum')
    """
    b0, b, B = quadratic_coefficients(surface)
    eigval, eigvec = np.linalg.eigh(B)
    scale = float(np.max(np.abs(eigval))) if eigval.size else 0.0
    zero = np.abs(eigval) <= rtol * scale if scale > 0 else np.ones(eigval.shape, bool)
    if zero.any():
        kind = "ridge"
        xs = -0.5 * np.linalg.lstsq(B, b, rcond=None)[0] if scale > 0 else np.zeros_like(b)
    else:
        xs = -0.5 * np.linalg.solve(B, b)
        kind = "minimum" if np.all(eigval > 0) else "maximum" if np.all(eigval < 0) else "saddle"
    value = float(b0 + xs @ b + xs @ B @ xs)
    return CanonicalAnalysis(xs, value, eigval, eigvec, kind, b0, b, B)


def surface_minimum(surface: Pipeline, *, radius: float) -> np.ndarray:
    """Coded point minimising the fitted surface inside the box ``|chi_k| <= radius``.

    The stationary point when it is a minimum inside the box; otherwise the box-constrained
    minimum found by :func:`scipy.optimize.minimize` (L-BFGS-B, analytic gradient) started
    from the centre and from every vertex of the box (the best is kept; deterministic).

    Parameters
    ----------
    surface : sklearn.pipeline.Pipeline
        Fitted :func:`make_response_surface` of degree 2.
    radius : float
        Half-width of the box in coded units (> 0), e.g. the design's axial distance.

    Returns
    -------
    ndarray of shape (n_factors,)
        Coded point.
    """
    from itertools import product

    from scipy.optimize import minimize

    b0, b, B = quadratic_coefficients(surface)
    can = canonical_analysis(surface)
    if can.kind == "minimum" and np.all(np.abs(can.stationary_point) <= radius):
        return can.stationary_point

    def f(x):
        return float(b0 + x @ b + x @ B @ x), b + 2.0 * B @ x

    n = b.size
    starts = [np.zeros(n)] + [radius * np.array(v, float) for v in product((-1.0, 1.0), repeat=n)]
    best_x, best_f = np.zeros(n), f(np.zeros(n))[0]
    for x0 in starts:
        res = minimize(f, x0, jac=True, method="L-BFGS-B", bounds=[(-radius, radius)] * n,
                       options={"ftol": 1e-15, "gtol": 1e-12})
        if res.fun < best_f - 1e-15 * max(abs(best_f), 1.0):
            best_x, best_f = np.asarray(res.x, dtype=float), float(res.fun)
    return best_x
