"""The stage order, in one place: sampling -> transduction -> synthesis [-> comparison].

::

    SEDField + ReceptorLayout --sample_sed--> ReceptorSED --transduce--> ReceptorCurrent
        --synthesize--> AfferentCurrent [--compare_profiles(observed)--> ProfileFit]

Each stage is also usable on its own; :func:`run_pipeline` only chains them, times them
and keeps every intermediate result.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

from typing import TYPE_CHECKING

from ._validation import check_option
from .exceptions import AfferentWarning

if TYPE_CHECKING:  # the stage modules (scipy, pandas) load when a function below runs, not on import
    from .profiles import ObservedProfile, ProfileFit
    from .receptors import ReceptorLayout
    from .sampling import ReceptorSED
    from .synthesis import AfferentCurrent, Branching
    from .transduction import ReceptorCurrent, SaturationReport, SigmoidParams

__all__ = ["PipelineResult", "run_pipeline", "apply_waveform", "run_spikes", "make_branching", "parse_synthesis", "SYNTHESES", "INPUTS"]

SYNTHESES = ("longitudinal", "cross", "map:FILE", "random:N")


def parse_synthesis(spec: str) -> tuple[str, int | None]:
    """Split a synthesis spelling into its kind and, for ``'random:N'``, N.

    Parameters
    ----------
    spec : str
        ``'longitudinal'``, ``'cross'``, ``'map:FILE'`` or ``'random:N'``.

    Returns
    -------
    (str, int or None)
        The kind (``'longitudinal'``, ``'cross'``, ``'map'``, ``'random'``) and N (None but for random).

    Raises
    ------
    ValueError
        An unknown kind, or N not a whole number.
    """
    kind, _, arg = str(spec).partition(":")
    check_option("synthesis", kind if not arg else f"{kind}:", ("longitudinal", "cross", "map:", "random:"))
    if kind != "random":
        return kind, None
    try:
        return kind, int(arg)
    except ValueError as err:
        raise ValueError(f"'synthesis' random:N needs a whole number of receptors per afferent; got {arg!r} instead.") from err


def make_branching(spec: str | Branching, layout: ReceptorLayout, *, rng=None) -> Branching:
    """A :class:`Branching` from its command-line spelling.

    Parameters
    ----------
    spec : str or Branching
        ``'longitudinal'`` (sections parallel to the ridges, profile vs x), ``'cross'``
        (sections across the ridges, profile vs z), ``'map:FILE'`` (CSV receptor,
        afferent[,weight]) or ``'random:N'`` (N receptors per afferent, seeded by ``rng``).
    layout : ReceptorLayout
    rng : None, int or numpy.random.Generator
        Seed for ``'random:N'``.
    """
    from .synthesis import Branching

    if isinstance(spec, Branching):
        return spec
    kind, n = parse_synthesis(spec)
    if kind == "longitudinal":
        return Branching.longitudinal(layout)
    if kind == "cross":
        return Branching.cross(layout)
    if kind == "map":
        return Branching.from_map(str(spec).partition(":")[2], layout)
    return Branching.random(layout, n, rng=rng)


@dataclass(frozen=True)
class PipelineResult:
    """Every intermediate of one run of the static pipeline (SI units throughout)."""

    sed: ReceptorSED
    current: ReceptorCurrent
    branching: Branching
    afferent: AfferentCurrent
    saturation: SaturationReport
    fit: ProfileFit | None = None
    timings: dict = field(default_factory=dict)
    waveform: object | None = None
    input: object | None = None
    spikes: object | None = None
    scaling: dict | None = None
    profile_index: int = 0
    drive: dict | None = None
    zones: object | None = None


def apply_waveform(sed: ReceptorSED, waveform, *, d_ref: float, reference_step: int | None = None,
                   series_depths=None) -> tuple[ReceptorSED, dict]:
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

    Returns
    -------
    (ReceptorSED, dict)
        SED over the waveform's times, and :func:`afferent.stimulus.scaling_record` (the d^2
        law measured against the series, when given).

    Raises
    ------
    ValueError
        Several steps and no ``reference_step`` (:func:`afferent.stimulus.no_reference_step_message`).
    """
    from .stimulus import interpolate_series, no_reference_step_message, scale_static, scaling_record

    if reference_step is None and sed.values.shape[0] > 1:
        raise ValueError(no_reference_step_message(sed.values.shape[0], sed.times))
    step = 0 if reference_step is None else reference_step
    scaling = scaling_record(sed, waveform, d_ref=d_ref, reference_step=step, series_depths=series_depths)
    timed = (interpolate_series(sed, waveform, series_depths=series_depths) if series_depths is not None
             else scale_static(sed, waveform, d_ref=d_ref, time_index=step))
    return timed, scaling


def run_pipeline(
    field,
    layout: ReceptorLayout,
    params: SigmoidParams,
    *,
    synthesis: str | Branching = "longitudinal",
    method: str = "linear",
    on_outside: str = "raise",
    observed: ObservedProfile | None = None,
    normalise: str = "both",
    rng=None,
    waveform=None,
    d_ref: float | None = None,
    reference_step: int | None = None,
    series_depths=None,
) -> PipelineResult:
    """SED field -> receptor SED -> receptor current -> afferent current [-> fit].

    Parameters
    ----------
    field : SEDField
        SED in J/m^3.
    layout : ReceptorLayout
        Receptor sites in m.
    params : SigmoidParams
        Transduction parameters (alpha A, gamma 1/Pa, lambda Pa).
    synthesis : str or Branching, default='longitudinal'
        See :func:`make_branching`.
    method, on_outside : str
        Sampling options (:func:`afferent.sample_sed`).
    observed : ObservedProfile, optional
        A recorded profile to compare the afferent profile with, at the step of the largest
        total afferent current (:func:`afferent.profiles.peak_step`; ``profile_index``).
    normalise : {'both', 'prediction', 'observation', 'neither'}
        What is min-max normalised before comparing.
    rng : None, int or Generator
        Seed for random branching.
    waveform : afferent.stimulus.Waveform, optional
        Indentation depth over time for a static export: the sampled SED is scaled by
        (d(t) / d_ref)^2 (:func:`afferent.stimulus.scale_static`, valid for linear elasticity
        with a fixed contact area).
    d_ref : float, optional
        Indentation depth of the static export in m (required with ``waveform``).
    reference_step : int, optional
        Which step of a multi-step export was solved at ``d_ref`` (required with ``waveform``
        when the export has several steps; -1 for the last).
    series_depths : array_like of shape (n_steps,), optional
        Depth in m of each step of a loading-series export: the time course is then interpolated
        in depth between the series' steps (:func:`afferent.stimulus.interpolate_series`) instead
        of scaled by d^2, and the d^2 law is measured against the series and recorded in
        ``scaling`` (:func:`afferent.stimulus.scaling_record`).

    Returns
    -------
    PipelineResult
        With ``timings``: wall time of each stage in s.
    """
    from .profiles import compare_profiles, peak_step
    from .sampling import sample_sed
    from .synthesis import synthesize
    from .transduction import saturation_report, transduce

    timings = {}
    t = time.perf_counter()
    sed = sample_sed(field, layout, method=method, on_outside=on_outside)
    timings["sampling"] = time.perf_counter() - t
    if waveform is not None:
        if d_ref is None:
            raise ValueError("A waveform needs d_ref, the indentation depth (m) of the static export; got d_ref=None.")
        t = time.perf_counter()
        sed, scaling = apply_waveform(sed, waveform, d_ref=d_ref, reference_step=reference_step,
                                      series_depths=series_depths)
        timings["stimulus"] = time.perf_counter() - t
    t = time.perf_counter()
    current = transduce(sed, params)
    sat = saturation_report(sed, params)
    timings["transduction"] = time.perf_counter() - t
    t = time.perf_counter()
    branching = make_branching(synthesis, layout, rng=rng)
    afferent = synthesize(current, branching)
    timings["synthesis"] = time.perf_counter() - t
    profile_index = peak_step(afferent)
    fit = None
    if observed is not None:
        t = time.perf_counter()
        fit = compare_profiles(afferent, observed, normalise=normalise, time_index=profile_index)
        timings["comparison"] = time.perf_counter() - t
    return PipelineResult(sed, current, branching, afferent, sat, fit, timings, waveform=waveform,
                          scaling=scaling if waveform is not None else None, profile_index=profile_index)


INPUTS = ("static", "rate-sensitive", "slowly-adapting")
# input -> mode of stimulus.adapting_input
_ADAPTATION_OF_INPUT = {"rate-sensitive": "rectified-rate", "slowly-adapting": "static-plus-rate"}


def run_spikes(result: PipelineResult, lif, *, dt: float, engine: str = "auto", input: str = "static",
               gain: float | None = None, tau: float | None = None, duration: float | None = None,
               drive: str = "resistance", rheobase_multiple: float = 2.0,
               reference_current: float | None = None, static_gain: float | None = None,
               zones=None) -> PipelineResult:
    """Add spikes to a pipeline result: input current -> leaky integrate-and-fire.

    Parameters
    ----------
    result : PipelineResult
        From :func:`run_pipeline`.
    lif : afferent.spiking.LIFParams
    dt : float
        LIF time step in s.
    engine : {'auto', 'fast', 'brian2', ...}
        See :func:`afferent.spiking.simulate_lif`.
    input : {'static', 'rate-sensitive'}, default='static'
        ``'static'``: the afferent current itself (the study's sigmoid of SED; fires through a
        hold). ``'rate-sensitive'``: each receptor's current adapts on its own
        (:func:`afferent.stimulus.adapting_input`, rectified rate of change, fires at onset
        and offset), then the inputs are summed into afferents. ``'slowly-adapting'``: the
        same per receptor with the SA-I static-plus-rate input (mode ``'static-plus-rate'``:
        fires through a hold, faster during the ramp; docs/classes.md).
    gain : float, optional
        Gain of the rate term in s (required for both adapting inputs).
    tau : float, optional
        Time constant of the rate in s (default that of ``adapting_input``).
    duration : float, optional
        Simulated time in s; default: to the last sample (``dt`` past it for a single sample).
    drive : {'resistance', 'rheobase'}, default='resistance'
        How the input current becomes the membrane drive (:data:`afferent.spiking.DRIVE_MAPPINGS`):
        through ``r_m`` as is, or rescaled so that ``reference_current`` (default: the largest
        input current) is ``rheobase_multiple`` x the rheobase.
    rheobase_multiple : float, default=2.0
        With ``drive='rheobase'``: the reference current's multiple of the rheobase.
    reference_current : float, optional
        With ``drive='rheobase'``: the reference current in A (default the run's largest
        afferent current; with ``zones``, the largest sum of an afferent's zone currents, so that
        ``sum`` and ``zones`` runs of the same scene share one scale).
    zones : afferent.zones.Zones, optional
        The ``zones`` branching model (:func:`afferent.zones.split_zones` of
        ``result.branching``): the input is synthesized per zone and each zone drives its own
        LIF; the afferent fires when one of its zones does, and all reset
        (:func:`afferent.spiking.simulate_lif`). Default None: the ``sum`` model, the study's.
    static_gain : float, optional
        With ``input='slowly-adapting'``: the dimensionless gain on the static current (default 1).

    Returns
    -------
    PipelineResult
        ``result`` with ``input`` (the current fed to the LIF, tagged with its kind; one column per
        zone with ``zones``), ``spikes`` (per afferent), ``zones``, and ``drive``: the mapping used
        and :func:`afferent.spiking.drive_report` (per afferent drive / rheobase, of its strongest
        zone with ``zones``, predicted and simulated rates; a warning when every afferent sits at
        the 1 / t_ref ceiling or all are silent).

    Warns
    -----
    AfferentWarning
        When all afferents fire at >= 90 % of 1 / t_ref, or none fires.
    """
    from dataclasses import replace

    from . import stimulus
    from .spiking import DRIVE_MAPPINGS, drive_report, rheobase_scale, simulate_lif

    check_option("input", input, INPUTS)
    _check_zones(zones, result.branching)
    timings = dict(result.timings)
    t = time.perf_counter()
    target = result.branching if zones is None else zones.branching
    if input == "static":
        from .synthesis import synthesize

        drive_current = stimulus.static_input(result.afferent if zones is None else synthesize(result.current, target))
    else:
        if gain is None:
            raise ValueError(f"input={input!r} needs gain= (s): how much input current (A) per A/s of rate.")
        kw = {} if tau is None else {"tau": tau}
        if static_gain is not None:
            kw["static_gain"] = static_gain
        drive_current = stimulus.adapting_input(result.current, gain=gain, mode=_ADAPTATION_OF_INPUT[input],
                                                **kw).synthesize(target)
    check_option("drive", drive, DRIVE_MAPPINGS)
    mapping = {"mapping": drive, "r_m_ohm": lif.r_m, "rheobase_a": lif.rheobase}
    if drive == "rheobase":
        summed = drive_current.values if zones is None else _afferent_sums(drive_current.values, zones)
        scale, ref = rheobase_scale(summed, lif, multiple=rheobase_multiple, reference=reference_current)
        drive_current = replace(drive_current, values=drive_current.values * scale)
        mapping.update(rheobase_multiple=rheobase_multiple, reference_current_a=ref, scale=scale)
    timings["input"] = time.perf_counter() - t
    if duration is None:
        times = result.afferent.times
        duration = float(times[-1] - times[0]) if times is not None and len(times) > 1 else None
    t = time.perf_counter()
    spikes = simulate_lif(drive_current, lif, dt=dt, engine=engine, duration=duration, zones=zones)
    timings["spiking"] = time.perf_counter() - t
    report = drive_report(drive_current.values if zones is None else _strongest_zone(drive_current.values, zones), lif,
                          spikes)
    if report["warning"]:
        warnings.warn(report["warning"], AfferentWarning, stacklevel=2)
    return replace(result, input=drive_current, spikes=spikes, timings=timings, drive={**mapping, **report}, zones=zones)


def _check_zones(zones, branching) -> None:
    """``zones`` must divide the afferents of ``branching`` (None: the sum model)."""
    if zones is None:
        return
    if not (hasattr(zones, "parent") and hasattr(zones, "branching") and hasattr(zones, "afferent")):
        raise TypeError(f"'zones' must be an afferent.zones.Zones; got {type(zones).__name__} instead.")
    if not (zones.parent.n_afferents == branching.n_afferents
            and (zones.parent.afferent_ids == branching.afferent_ids).all()):
        raise ValueError("'zones' must divide the afferents of the result's branching; build them with "
                         "afferent.zones.split_zones(result.branching, layout, k).")


def _afferent_sums(values, zones):
    """Each afferent's current (A, (n_times, n_afferents)) as the sum of its zones' (``values``)."""
    from .zones import zone_indicator

    return (zone_indicator(zones).T @ values.T).T


def _strongest_zone(values, zones):
    """Peak current (A) of each afferent's strongest zone, shape (1, n_afferents), for the drive report."""
    import numpy as np

    out = np.zeros(zones.parent.n_afferents)
    if values.size:
        np.maximum.at(out, zones.afferent, values.max(axis=0))
    return out[None, :]
