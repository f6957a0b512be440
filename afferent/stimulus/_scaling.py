"""Quasi-static SED over a waveform: d^2 scaling of one FE step, interpolation in a loading series, their checks.

:func:`scale_static`, :func:`interpolate_series`, :func:`scaling_record`, :func:`depth_scaling_error`
(documented in :mod:`afferent.stimulus`), and :func:`apply_waveform`, the stimulus stage that picks
one of the two for a run.
"""

from __future__ import annotations

from ..sampling import ReceptorSED

from .._typing import Accept, ArrayLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

import numbers
import warnings
from dataclasses import dataclass

import numpy as np

from .._validation import check_positive
from .._validation import plain as _plain
from ..exceptions import AfferentWarning
from ._waveforms import Waveform, _finite_1d

# --------------------------------------------------------------------------------------------
# Quasi-static scaling of one FE solution
# --------------------------------------------------------------------------------------------


def _static_row(sed, time_index):
    values = np.asarray(sed.values, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError(f"'sed.values' must be an array of shape (n_times, n_receptors); got shape {values.shape} instead.")
    n_t = values.shape[0]
    if time_index is None:
        if n_t != 1:
            raise ValueError(
                f"'sed' has {n_t} time steps; pass time_index to say which one is the static solution at depth "
                "d_ref (e.g. time_index=-1 for the last step of a loading series)."
            )
        return values[0]
    if isinstance(time_index, bool) or not isinstance(time_index, numbers.Integral):
        raise TypeError(f"'time_index' must be an int; got {_plain(time_index)!r} instead.")
    if not -n_t <= time_index < n_t:
        raise ValueError(
            f"'time_index' must be in [{-n_t}, {n_t - 1}] for {n_t} time step(s); got {_plain(time_index)!r} instead."
        )
    return values[int(time_index)]


def scale_static(sed: ReceptorSED, waveform: Waveform, *, d_ref: float, time_index: int | None = None) -> ReceptorSED:
    """SED over time from one static FE solution: ``SED(t) = SED_static (d(t) / d_ref)^2``.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptor sites in J/m^3 (= Pa) from a static solution at indentation depth
        ``d_ref``. NaN (receptors outside the field) stays NaN.
    waveform : Waveform
        Indentation depth d(t) in m.
    d_ref : float
        Depth in m of the static solution, > 0.
    time_index : int, optional
        Which step of ``sed`` is the static solution. Required when ``sed`` has more than one
        step, e.g. ``-1`` for the last step of a loading series.

    Returns
    -------
    ReceptorSED
        Values of shape (waveform.n_times, n_receptors) in J/m^3 at ``waveform.times`` (s),
        with the layout, method and outside mask of ``sed``.

    Raises
    ------
    TypeError
        If ``waveform`` is not a :class:`Waveform` or ``time_index`` not an int.
    ValueError
        If ``d_ref`` is not > 0, or ``sed`` has several steps and no ``time_index``.

    Warns
    -----
    AfferentWarning
        If the waveform goes deeper than ``d_ref``: the scaling then extrapolates beyond the FE
        solution, where the small-strain assumption is weakest.

    See Also
    --------
    depth_scaling_error : check the scaling on an FE loading series.

    Notes
    -----
    **Why d^2.** For a linear-elastic body under small strain whose boundary conditions are a
    prescribed displacement over a *fixed* contact region (a rigid flat punch already in full
    contact, no friction-driven slip), the displacement field is linear in the indentation
    depth: u(x; d) = (d / d_ref) u(x; d_ref). Strains and stresses scale with d, so the strain
    energy density ``1/2 sigma:eps`` scales with d^2, at every point and for both the exact
    and the study's "equivalent" SED (both are quadratic forms of the strain).

    **Where it is valid.** Linear elasticity (the study's chapter-5 model), small strain
    (indentation small next to the layer thicknesses, here 0.5 mm against 3.1 mm of skin),
    quasi-static loading (inertia negligible: the 0.1 s ramp is far slower than the block's
    elastic waves), and a contact area that does not change with depth (a flat punch in
    full contact from the start).

    **Where it is not.**

    - Hyperelastic materials or large strain: the response stiffens, SED grows faster than d^2.
    - A contact area that changes with depth: a spherical or rounded indenter (Hertz: force ~
      d^1.5, the contact radius grows as sqrt(d)), and also a flat punch on ridged skin
      before every ridge is touched (the first ~0.06 mm of the bundled sample).
    - Viscoelastic relaxation (chapter 4's Prony-series dermis and subcutis): the SED at a
      given depth depends on the loading history and relaxes during a hold. The static
      solution is then only the long-time (or the instantaneous) limit.
    - Frictional contact: stick/slip zones under the punch change with depth.
    - Any prescribed displacement that is not proportional to d. For example, a punch whose
      face is brought to a plane ``y_crest - d`` over a rough (ridged) surface gets
      ``u = d + (y_crest - y_surface)``, an offset that does not scale; the SED is then a
      full quadratic ``a d^2 + b d + c`` per point, not ``a d^2``. This is the case of the
      bundled series; :func:`depth_scaling_error` measures how far off d^2 it is. In
      ``sample_sed/block4/series_0p88mm`` (119 papilla tips), the last step (0.5 mm)
      predicts the 0.4, 0.3, 0.2 and 0.1 mm steps with relative L2 errors of 4.3 %,
      12 %, 30 % and 107 % over the receptors (120 % at 0.1 mm over the 51 tips of the
      ``spikes_ramp`` scene's region; measured with :func:`depth_scaling_error` on the
      series sampled at ``sample_sed/block4/receptors.csv``, depths 0-0.5 mm in 0.1 mm
      steps; the table of docs/method.md, recomputed by tests/test_doc_figures.py). The
      effective exponent is 2.18-2.43: the SED falls faster than d^2, because the ridge
      valleys are pushed by less than d (:ref:`method-scaling`). A
      per-receptor fit of ``a d^2 + b d + c`` to the full-contact steps (d >= 0.1 mm)
      reproduces them to 3e-7, the float32 precision of the export.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> from afferent.sampling import ReceptorSED
    >>> sed = ReceptorSED(np.array([[100.0, 40.0]]), np.array([0.0]),
    ...                   ReceptorLayout(np.zeros((2, 3)) + [[0, 0, 0], [1e-3, 0, 0]]), "linear",
    ...                   np.zeros(2, bool))
    >>> w = Waveform([0.0, 1.0, 2.0], [0.0, 0.25e-3, 0.5e-3])
    >>> scale_static(sed, w, d_ref=0.5e-3).values.tolist()
    [[0.0, 0.0], [25.0, 10.0], [100.0, 40.0]]
    """
    from ..sampling import ReceptorSED

    if not isinstance(waveform, Waveform):
        raise TypeError(f"'waveform' must be a Waveform; got {type(waveform).__name__} instead.")
    if not (hasattr(sed, "values") and hasattr(sed, "layout")) or isinstance(sed, np.ndarray):
        raise TypeError(f"'sed' must be a ReceptorSED (SED at receptor sites); got {type(sed).__name__} instead.")
    d_ref = check_positive("d_ref", d_ref, unit="m")
    static = _static_row(sed, time_index)
    if waveform.max_depth > d_ref * (1.0 + 1e-9):
        warnings.warn(
            f"The waveform reaches {waveform.max_depth:g} m, deeper than the static solution's d_ref = {d_ref:g} m: "
            "scale_static extrapolates the d^2 law beyond the FE solution.",
            AfferentWarning,
            stacklevel=2,
        )
    factor = (waveform.depth / d_ref) ** 2
    values = factor[:, None] * static[None, :]
    outside = np.asarray(getattr(sed, "outside", np.zeros(static.size, bool)), dtype=bool).copy()
    return ReceptorSED(values, waveform.times.copy(), sed.layout, getattr(sed, "method", "linear"), outside,
                       getattr(sed, "placement", ""))


#: Relative L2 error of the d^2 scaling, measured on an export's own loading series, above
#: which a run driven by that scaling is warned about.
SCALING_ERROR_WARN = 0.10

#: When the d^2 scaling is exact, in a line for run records (see :func:`scale_static`, Notes).
SCALING_VALIDITY = ("exact for linear elasticity under small strain, quasi-static loading and a contact area that "
                    "does not change with depth (a flat punch in full contact); not for hyperelastic or viscoelastic "
                    "skin, rounded indenters, or ridged skin before every ridge is touched")


def no_reference_step_message(n_steps: int, times) -> str:
    """The error for a waveform on a multi-step export without a reference step (one wording everywhere)."""
    t = np.asarray(times, dtype=float)
    return (
        f"A waveform scales one static FE step by (d / d_ref)^2, but the export has {n_steps} steps "
        f"(t = {t[0]:g} .. {t[-1]:g} s); say which step was solved at d_ref with reference_step=K (-1: the last, "
        "usually the deepest). A loading series can also be used as it is, without a waveform."
    )


def interpolate_series(sed: ReceptorSED, waveform: Waveform, *, series_depths: ArrayLike) -> ReceptorSED:
    """SED over time from a loading series: per receptor, linear in depth between the series' steps.

    Where the user has solved several depths, this follows the FE model itself instead of the
    d^2 law (:func:`scale_static`), which fails where the contact changes (107 % off at 0.1 mm on
    the bundled ridged-skin series).

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors for each step of the series, J/m^3.
    waveform : Waveform
        Indentation depth d(t) in m; it must stay within the series' depths.
    series_depths : array_like of shape (n_steps,)
        The depth of each step in m, strictly increasing.

    Returns
    -------
    ReceptorSED
        Values of shape (waveform.n_times, n_receptors) in J/m^3 at ``waveform.times``.

    Raises
    ------
    ValueError
        If the depths do not match the steps, do not increase, or the waveform leaves their range.
    """
    from ..sampling import ReceptorSED

    values = np.asarray(sed.values, dtype=np.float64)
    depths = np.asarray(series_depths, dtype=np.float64)
    if depths.shape != (values.shape[0],):
        raise ValueError(f"'series_depths' must give one depth (m) per export step ({values.shape[0]}); got shape "
                         f"{depths.shape} instead.")
    if depths.size < 2 or np.any(np.diff(depths) <= 0):
        raise ValueError(f"'series_depths' must increase strictly, in m; got {depths.tolist()!r} instead.")
    tol = 1e-9 * depths[-1]
    d = waveform.depth
    if d.min() < depths[0] - tol or d.max() > depths[-1] + tol:
        raise ValueError(
            f"The waveform's depth ({d.min():g}..{d.max():g} m) leaves the series' depths ({depths[0]:g}..{depths[-1]:g} m); "
            "the series is interpolated, never extrapolated."
        )
    d = np.clip(d, depths[0], depths[-1])
    k = np.clip(np.searchsorted(depths, d, side="right") - 1, 0, depths.size - 2)
    w = (d - depths[k]) / (depths[k + 1] - depths[k])
    out = values[k] * (1.0 - w)[:, None] + values[k + 1] * w[:, None]
    outside = np.asarray(getattr(sed, "outside", np.zeros(values.shape[1], bool)), dtype=bool).copy()
    return ReceptorSED(out, waveform.times.copy(), sed.layout, getattr(sed, "method", "linear"), outside)


def scaling_record(sed: ReceptorSED, waveform: Waveform, *, d_ref: float, reference_step: int = 0, series_depths: ArrayLike | None=None) -> dict:
    """What a run driven by :func:`scale_static` assumed, and its error where the export allows measuring it.

    Parameters
    ----------
    sed : ReceptorSED
        The SED sampled from the export (before scaling), J/m^3, one row per export step.
    waveform : Waveform
        The indentation depth d(t) in m that drives the scaling.
    d_ref : float
        Depth in m of the reference step.
    reference_step : int, default=0
        The export step used as the static solution.
    series_depths : array_like of shape (n_steps,), optional
        The indentation depth in m of every step of a loading-series export. With it, the
        scaling from the reference step is compared with the series' own steps
        (:func:`depth_scaling_error`).

    Returns
    -------
    dict
        ``law``, ``valid_if``, ``d_ref_m``, ``reference_step``, ``reference_time_s``,
        ``n_export_steps``, ``max_depth_m``, ``extrapolates`` (deeper than d_ref), and
        ``measured``: None (one static step, or no depths given: not measurable) or the per-step
        ``depths_m``, ``rel_error_l2``, ``exponent`` and ``max_error_in_range`` (the largest error
        at the steps whose depth the waveform visits).

    Warns
    -----
    AfferentWarning
        When the measured error exceeds :data:`SCALING_ERROR_WARN` at a depth the waveform visits.
    """
    n = int(np.asarray(sed.values).shape[0])
    k = int(reference_step) % n
    record = {
        "time_course": ("interpolated in depth between the series' steps, per receptor (interpolate_series); the "
                        "d^2 law below is measured, not used") if series_depths is not None else
                       "d^2 scaling of the reference step (scale_static)",
        "law": "SED(t) = SED_ref (d(t) / d_ref)^2", "valid_if": SCALING_VALIDITY, "d_ref_m": float(d_ref),
        "reference_step": k, "reference_time_s": float(np.asarray(sed.times)[k]), "n_export_steps": n,
        "max_depth_m": float(waveform.max_depth), "extrapolates": bool(waveform.max_depth > d_ref * (1 + 1e-9)),
        "measured": None,
    }
    if series_depths is None:
        record["measured_note"] = ("not measured: one static step" if n == 1 else
                                   "not measured: pass the depths of the series' steps (series_depths) to measure it")
        return record
    depths = np.asarray(series_depths, dtype=float)
    if depths.shape != (n,):
        raise ValueError(f"'series_depths' must give one depth (m) per export step ({n}); got shape {depths.shape} instead.")
    if not np.isclose(depths[k], d_ref, rtol=1e-6):
        raise ValueError(
            f"'series_depths' puts the reference step {k} at {depths[k]:g} m, but d_ref is {d_ref:g} m; they must agree."
        )
    chk = depth_scaling_error(sed, depths, ref_index=k)
    lo, hi = float(np.min(waveform.depth)), float(np.max(waveform.depth))
    visited = (depths > 0) & (depths >= lo - 1e-12) & (depths <= hi + 1e-12) & (np.arange(n) != k)
    err = chk.rel_error_l2
    worst = float(np.nanmax(err[visited])) if visited.any() else None
    record["measured"] = {"depths_m": depths.tolist(), "rel_error_l2": err.tolist(), "exponent": chk.exponent.tolist(),
                          "max_error_in_range": worst}
    if worst is not None and worst > SCALING_ERROR_WARN:
        j = int(np.flatnonzero(visited)[np.nanargmax(err[visited])])
        warnings.warn(
            f"The d^2 scaling of export step {k} (d_ref = {d_ref:g} m) is off by {100 * worst:.3g} % (relative L2) at "
            f"d = {depths[j]:g} m, a depth the waveform visits, measured on the export's own loading series: "
            "the SED there is not (d / d_ref)^2 x the reference (see scale_static, Notes); the time course is "
            "interpolated in depth between the series' steps instead.",
            AfferentWarning, stacklevel=2,
        )
    return record


@dataclass(frozen=True, eq=False)
class ScalingCheck:
    """How well ``SED(d) = SED_ref (d / d_ref)^2`` predicts an FE loading series.

    Parameters
    ----------
    depths : ndarray of shape (n_times,)
        Indentation depth of each step in m.
    ref_index : int
        The step used as the reference (non-negative index).
    rel_error_l2 : ndarray of shape (n_times,)
        ``||pred - fe||_2 / ||fe||_2`` over the receptors, per step (dimensionless); 0 at the
        reference; NaN where ``||fe||`` is 0 and the prediction is not.
    rel_error_max : ndarray of shape (n_times,)
        ``max |pred - fe| / max |fe|`` over the receptors, per step (dimensionless).
    exponent : ndarray of shape (n_times,)
        Effective power ``ln(||fe_k|| / ||fe_ref||) / ln(d_k / d_ref)`` (2 for exact d^2
        scaling); NaN at the reference and at d = 0.
    n_receptors : int
        Receptors compared (those with finite SED at every step).
    """

    depths: np.ndarray
    ref_index: int
    rel_error_l2: np.ndarray
    rel_error_max: np.ndarray
    exponent: np.ndarray
    n_receptors: int

    def to_dataframe(self) -> DataFrame:
        """One row per step: ``depth_m``, ``rel_error_l2``, ``rel_error_max``, ``exponent``."""
        import pandas as pd

        return pd.DataFrame({"depth_m": self.depths, "rel_error_l2": self.rel_error_l2,
                             "rel_error_max": self.rel_error_max, "exponent": self.exponent})

    def __repr__(self) -> str:
        others = np.arange(self.depths.size) != self.ref_index
        worst = np.nanmax(self.rel_error_l2[others]) if others.any() else 0.0
        return (
            f"<ScalingCheck: {self.depths.size} steps, reference d = {self.depths[self.ref_index]:g} m, "
            f"worst relative L2 error {worst:.3g}>"
        )


def depth_scaling_error(sed: ReceptorSED, depths: ArrayLike, *, ref_index: int = -1) -> ScalingCheck:
    """Check the d^2 scaling of :func:`scale_static` on an FE loading series.

    Each step k is predicted from the reference step as ``SED_ref (d_k / d_ref)^2`` and
    compared with the FE result.

    Parameters
    ----------
    sed : ReceptorSED
        SED at receptor sites in J/m^3 for a loading series (n_times >= 2 steps), e.g. sampled
        from ``sample_sed/block4/series_0p88mm/indent.pvd``.
    depths : array_like of shape (n_times,)
        Indentation depth of each step in m, >= 0 (for a ramp at constant speed:
        ``speed * times``).
    ref_index : int, default=-1
        The step that plays the static solution (the deepest, by default the last).

    Returns
    -------
    ScalingCheck
        Per-step relative errors and effective exponents.

    Raises
    ------
    ValueError
        If shapes disagree, a depth is negative, or the reference depth is 0.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> from afferent.sampling import ReceptorSED
    >>> v = np.array([[0.0, 0.0], [25.0, 10.0], [100.0, 40.0]])
    >>> sed = ReceptorSED(v, np.array([0.0, 0.5, 1.0]), ReceptorLayout(np.zeros((2, 3)) + [[0, 0, 0], [1e-3, 0, 0]]),
    ...                   "linear", np.zeros(2, bool))
    >>> depth_scaling_error(sed, [0.0, 0.25e-3, 0.5e-3]).rel_error_l2.tolist()
    [0.0, 0.0, 0.0]
    """
    values = np.asarray(sed.values, dtype=np.float64)
    if values.ndim != 2 or values.shape[0] < 2:
        raise ValueError(
            f"'sed' must be a loading series of shape (n_times >= 2, n_receptors); got shape {values.shape} instead."
        )
    d = _finite_1d("depths", depths, "m")
    if d.shape != (values.shape[0],):
        raise ValueError(
            f"'depths' must have one entry per step of 'sed' (n_times = {values.shape[0]}); got shape {d.shape} instead."
        )
    if np.any(d < 0):
        raise ValueError(f"'depths' must be >= 0 m; got {float(d[np.flatnonzero(d < 0)[0]])!r} instead.")
    n_t = values.shape[0]
    if isinstance(ref_index, bool) or not isinstance(ref_index, numbers.Integral) or not -n_t <= ref_index < n_t:
        raise ValueError(f"'ref_index' must be an int in [{-n_t}, {n_t - 1}]; got {_plain(ref_index)!r} instead.")
    ref = int(ref_index) % n_t
    if d[ref] <= 0:
        raise ValueError(f"The reference step's depth must be > 0 m; got {float(d[ref])!r} at step {ref} instead.")
    keep = np.all(np.isfinite(values), axis=0)
    fe = values[:, keep]
    pred = (d[:, None] / d[ref]) ** 2 * fe[ref][None, :]
    diff = pred - fe
    num_l2 = np.linalg.norm(diff, axis=1)
    den_l2 = np.linalg.norm(fe, axis=1)
    num_max = np.abs(diff).max(axis=1) if fe.shape[1] else np.zeros(n_t)
    den_max = np.abs(fe).max(axis=1) if fe.shape[1] else np.zeros(n_t)
    with np.errstate(divide="ignore", invalid="ignore"):
        l2 = np.where(den_l2 > 0, num_l2 / den_l2, np.where(num_l2 == 0, 0.0, np.nan))
        mx = np.where(den_max > 0, num_max / den_max, np.where(num_max == 0, 0.0, np.nan))
        expo = np.log(den_l2 / den_l2[ref]) / np.log(d / d[ref])
    expo[ref] = np.nan
    expo[~np.isfinite(expo)] = np.nan
    return ScalingCheck(d.copy(), ref, l2, mx, expo, int(keep.sum()))


#: How far (a factor either way) d_ref may lie from the waveform's deepest point before it is refused as a
#: likely unit slip: beyond it the (d / d_ref)^2 scaling multiplies the SED by less than 1/100 or more than 100.
D_REF_BAND = 10.0
#: SED (L2 over the receptors) of another step, over the reference step's, above which the reference is not
#: the deepest step of a series (steps of one hold, equal up to round-off, are alike).
DEEPER_STEP_RATIO = 1.05


def _as_mm(d: float) -> str:
    return f"{d * 1e3:.4g} mm"


def check_reference_step(sed, k: int, d_ref: float, series_depths=None, accept=None) -> None:
    """The reference step ``k`` of a multi-step export scaled by (d / d_ref)^2 must be its deepest step, the one
    of the largest SED (L2 over the receptors, which grows with depth): refused otherwise, unless ``accept``
    names 'reference-step'. A shallower step scaled to ``d_ref`` (m) gives too little SED. Not checked with
    ``series_depths`` (m): the series is then interpolated in depth, every step used."""
    from .._validation import refuse_unless

    values = np.asarray(sed.values, dtype=float)
    n = values.shape[0]
    if n < 2 or series_depths is not None:  # a series with depths is interpolated in depth, not scaled
        return
    times = np.asarray(sed.times, dtype=float)
    norm = np.sqrt(np.nansum(values ** 2, axis=1))
    deep = int(np.argmax(norm))
    if norm[deep] <= DEEPER_STEP_RATIO * norm[k]:
        return
    why = (f"step {deep} (t = {times[deep]:g} s) has {norm[deep] / norm[k]:.3g} x its SED (L2 over the receptors)"
           if norm[k] > 0 else f"it has no SED, step {deep} (t = {times[deep]:g} s) has")
    refuse_unless("reference-step", accept, (
        f"The reference step {k} (t = {times[k]:g} s) is not the deepest step of the export's {n}-step series: {why}; "
        f"scaled by (d / d_ref)^2 with d_ref = {_as_mm(d_ref)}, a shallower step gives too little SED (afferents "
        f"fall silent), the likely cause a step counted from 1 or from the other end; give the deepest step, "
        f"reference_step = {deep} or {deep - n} (--reference-step {deep - n})"), stacklevel=3)


def check_d_ref(waveform: Waveform, d_ref: float, accept=None) -> None:
    """``d_ref`` (m) more than :data:`D_REF_BAND` x from the waveform's deepest point: refused as a likely unit
    slip (a value in mm under a key in m), unless ``accept`` names 'd-ref'."""
    from .._validation import refuse_unless

    deepest = float(waveform.max_depth)
    if deepest <= 0 or 1 / D_REF_BAND <= d_ref / deepest <= D_REF_BAND:
        return
    ratio = d_ref / deepest
    near = min((d_ref * 10.0 ** e for e in (-6, -3, 3, 6)), key=lambda d: abs(np.log(d / deepest)))
    fits = (f"; {_as_mm(d_ref)} read in another unit is {_as_mm(near)}: d_ref_mm = {near * 1e3:.4g} "
            f"(--d-ref-mm {near * 1e3:.4g})" if 1 / D_REF_BAND <= near / deepest <= D_REF_BAND else "")
    refuse_unless("d-ref", accept, (
        f"d_ref ({_as_mm(d_ref)}) is {ratio:.4g} x the waveform's deepest point ({_as_mm(deepest)}): the SED of the "
        f"export is scaled by (d / d_ref)^2 <= {(1 / ratio) ** 2:.3g}, so the afferents "
        f"{'fall silent' if ratio > 1 else 'saturate'}, the likely cause d_ref written in the wrong unit (a value "
        f"in mm under a key in m){fits}; give the depth at which the export was solved"), stacklevel=3)


def apply_waveform(sed: ReceptorSED, waveform: Waveform, *, d_ref: float, reference_step: int | None = None,
                   series_depths: ArrayLike | None=None, accept: Accept=None) -> tuple:
    """The stimulus stage: SED sampled from the export -> SED over the waveform's times.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors as sampled from the export, J/m^3.
    waveform : afferent.stimulus.Waveform
        Indentation depth (m) over time (s).
    d_ref : float
        Indentation depth of the export's reference step, m.
    reference_step : int, optional
        The step solved at ``d_ref`` (-1: the last); required when the export has several.
    series_depths : array_like of shape (n_steps,), optional
        Depth in m of every step of a loading series: the time course is interpolated in depth
        between the steps (:func:`afferent.stimulus.interpolate_series`) instead of scaled by
        (d / d_ref)^2 (:func:`afferent.stimulus.scale_static`).
    accept : str or sequence of str, optional
        Checks whose unusual case is confirmed (``afferent._validation.ACCEPTS``):
        ``'reference-step'`` (a reference step that is not the deepest step of a series scaled by
        (d / d_ref)^2, the one of the largest SED), ``'d-ref'`` (``d_ref`` more than 10 x from the
        waveform's deepest point).

    Returns
    -------
    (ReceptorSED, dict)
        SED over the waveform's times, and :func:`afferent.stimulus.scaling_record` (the d^2
        law measured against the series, when given).

    Raises
    ------
    ValueError
        Several steps and no ``reference_step`` (:func:`afferent.stimulus.no_reference_step_message`);
        a reference step that is not the deepest or a ``d_ref`` more than 10 x from the waveform's
        deepest point, unless ``accept`` confirms it.
    """
    if reference_step is None and sed.values.shape[0] > 1:
        raise ValueError(no_reference_step_message(sed.values.shape[0], sed.times))
    step = 0 if reference_step is None else reference_step
    d_ref = check_positive("d_ref", d_ref, unit="m")
    n = int(np.asarray(sed.values).shape[0])
    if isinstance(step, numbers.Integral) and not isinstance(step, bool) and -n <= step < n:
        check_reference_step(sed, int(step) % n, d_ref, series_depths, accept)
    check_d_ref(waveform, d_ref, accept)
    scaling = scaling_record(sed, waveform, d_ref=d_ref, reference_step=step, series_depths=series_depths)
    timed = (interpolate_series(sed, waveform, series_depths=series_depths) if series_depths is not None
             else scale_static(sed, waveform, d_ref=d_ref, time_index=step))
    return timed, scaling
