"""Calibration of the transduction sigmoid (alpha, gamma, lambda) against recordings (METHOD.md section 6).

::

    ReceptorSED + ObservedProfile --calibrate(...)--> CalibrationResult
        objective: transduce -> synthesize -> compare_profiles(...).ssd at one time step

Methods:

- ``'rsm1'`` (default): the study's response-surface procedure - two-level full factorial +
  centre design (9 runs, pydoe) in coded parameters (5 % increments), first-order fit
  (scikit-learn ``LinearRegression``), steepest-descent steps while the ssd decreases,
  re-centre, repeat (:mod:`.design`, :mod:`.surface`).
- ``'rsm2'``: second-order surface (central composite or Box-Behnken design,
  ``Pipeline(PolynomialFeatures(2), LinearRegression())``, canonical analysis).
- ``'least_squares'``: the reference, :func:`scipy.optimize.least_squares` on the residual
  vector, multi-start, seeded.

Two things the study left implicit are reported, not hidden: with min-max normalisation of
the prediction alpha cancels out of the ssd (``CalibrationResult.no_effect``), and a
parameter set may saturate every receptor (``CalibrationResult.saturation``).
"""

from __future__ import annotations

from ._loop import (
    DEFAULT_MAX_ITER,
    DEFAULT_MAX_STEPS,
    DEFAULT_N_STARTS,
    DEFAULT_TOL,
    METHODS,
    CalibrationResult,
    SynthesisComparison,
    calibrate,
    compare_methods,
    compare_syntheses,
)
from .design import box_behnken, central_composite, decode, encode, factorial_design, increments
from .surface import canonical_analysis, fit_first_order, make_response_surface

__all__ = [
    "calibrate",
    "CalibrationResult",
    "compare_methods",
    "compare_syntheses",
    "SynthesisComparison",
    "METHODS",
    "DEFAULT_TOL",
    "DEFAULT_MAX_ITER",
    "DEFAULT_MAX_STEPS",
    "DEFAULT_N_STARTS",
    "factorial_design",
    "central_composite",
    "box_behnken",
    "encode",
    "decode",
    "increments",
    "fit_first_order",
    "make_response_surface",
    "canonical_analysis",
]
