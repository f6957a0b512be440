"""Calibration of the transduction sigmoid (alpha, gamma, lambda) against a recorded afferent profile.

::

    ReceptorSED + ObservedProfile --calibrate(...)--> CalibrationResult
        objective: transduce -> synthesize -> compare_profiles(...).ssd at one time step

Methods:

- ``'rsm1'`` (default): the study's response-surface procedure - two-level full factorial +
  centre design (9 runs, pydoe) in coded parameters (5 % increments), first-order fit
  (scikit-learn ``LinearRegression``), steepest-descent steps while the ssd decreases,
  re-centre, repeat (:mod:`.design`, :mod:`.surface`, :mod:`.rsm`).
- ``'rsm2'``: second-order surface (central composite or Box-Behnken design,
  ``Pipeline(PolynomialFeatures(2), LinearRegression())``, canonical analysis).
- ``'least_squares'``: the reference, :func:`scipy.optimize.least_squares` on the residual
  vector (:mod:`.reference`).

Two things the study left implicit are reported, not hidden: with min-max normalisation of
the prediction alpha cancels out of the ssd (``CalibrationResult.no_effect``), and a
parameter set may saturate every receptor (``CalibrationResult.saturation``).

Modules: :mod:`.entry` (:func:`~afferent.calibration.calibrate`), :mod:`.objective` (the model evaluation and its
closed-form Jacobian), :mod:`.rsm`, :mod:`.reference`, :mod:`.result`
(:class:`CalibrationResult`), :mod:`.conditioning` (identifiability), :mod:`.compare` (several methods or
groupings at once), :mod:`.design`, :mod:`.surface`, and the figures of a result.
"""

from __future__ import annotations

from ._plots import plot_calibrated_profile, plot_calibrated_profiles, plot_ssd_history
from .compare import SynthesisComparison, best_method, compare_methods, compare_syntheses, methods_table
from .design import box_behnken, central_composite, decode, encode, factorial_design, increments
from .entry import METHODS, calibrate
from .conditioning import IDENTIFIABLE_COND, identifiability
from .reference import DEFAULT_N_STARTS
from .result import STATUSES, CalibrationResult
from .rsm import DEFAULT_MAX_ITER, DEFAULT_MAX_STEPS, DEFAULT_TOL
from .surface import canonical_analysis, fit_first_order, make_response_surface

__all__ = [
    "calibrate",
    "CalibrationResult",
    "STATUSES",
    "compare_methods",
    "methods_table",
    "best_method",
    "compare_syntheses",
    "SynthesisComparison",
    "plot_calibrated_profile",
    "plot_calibrated_profiles",
    "plot_ssd_history",
    "identifiability",
    "IDENTIFIABLE_COND",
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
