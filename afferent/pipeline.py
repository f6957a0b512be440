"""The stage order, in one place: sampling -> transduction -> synthesis [-> comparison].

::

    SEDField + ReceptorLayout --sample_sed--> ReceptorSED --transduce--> ReceptorCurrent
        --synthesize--> AfferentCurrent [--compare_profiles(observed)--> ProfileFit]

Each stage is also usable on its own; :func:`run_pipeline` only chains them, times them
and keeps every intermediate result, and :func:`run_spikes` adds the spikes
(:func:`afferent.spiking.spike_afferents`). This is the Python API's orchestrator; a scene
(:func:`afferent.scene.run_scene`, every command) runs the same stage functions. The stage
modules never import this one: :func:`~afferent.synthesis.make_branching` and
:func:`~afferent.synthesis.parse_synthesis` live in :mod:`afferent.synthesis`,
:func:`~afferent.stimulus.apply_waveform` in :mod:`afferent.stimulus` (still importable from
here).
"""

from __future__ import annotations

from .field import SEDField
from .stimulus._waveforms import Waveform
from .zones import Zones

from ._typing import Accept, ArrayLike, RngLike

import time
from dataclasses import dataclass, field

# the stage modules load numpy only; scipy and pandas load when a function below runs
from .profiles import Normalise, ObservedProfile, ProfileFit
from .receptors import ReceptorLayout
from .sampling import OnOutside, ReceptorSED, SamplingMethod
from .stimulus._adaptation import InputKind, Rectify
from .synthesis import AfferentCurrent, Branching
from .transduction import ReceptorCurrent, SaturationReport, SigmoidParams

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # afferent.spiking loads on first use (a SED-only run never imports it)
    from .spiking._drive import DriveMapping
    from .spiking._params import Engine, LIFParams

__all__ = ["PipelineResult", "run_pipeline", "run_spikes"]


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


def run_pipeline(
    field: SEDField,
    layout: ReceptorLayout,
    params: SigmoidParams,
    *,
    synthesis: str | Branching = "longitudinal",
    method: SamplingMethod = "linear",
    on_outside: OnOutside = "raise",
    observed: ObservedProfile | None = None,
    normalise: Normalise = "both",
    rng: RngLike=None,
    waveform: Waveform | None=None,
    d_ref: float | None = None,
    reference_step: int | None = None,
    series_depths: ArrayLike | None=None,
    accept: Accept=None,
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
        See :func:`afferent.synthesis.make_branching`.
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
    accept : str or sequence of str, optional
        The stimulus checks whose unusual case is confirmed (``'reference-step'``, ``'d-ref'``:
        :func:`afferent.stimulus.apply_waveform`).

    Returns
    -------
    PipelineResult
        With ``timings``: wall time of each stage in s.
    """
    from .profiles import compare_profiles, peak_step
    from .sampling import sample_sed
    from .stimulus import apply_waveform
    from .synthesis import make_branching, synthesize
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
                                      series_depths=series_depths, accept=accept)
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


def run_spikes(result: PipelineResult, lif: LIFParams, *, dt: float, engine: Engine = "auto", input: InputKind = "static",
               gain: float | None = None, tau: float | None = None, duration: float | None = None,
               drive: DriveMapping = "resistance", rheobase_multiple: float = 2.0,
               reference_current: float | None = None, static_gain: float | None = None,
               zones: Zones | None=None, rectify: Rectify | None = None, slow_gain: float | None = None,
               slow_tau: float | None = None) -> PipelineResult:
    """Add spikes to a pipeline result: input current -> leaky integrate-and-fire
    (:func:`afferent.spiking.spike_afferents` on the result's currents and branching).

    Parameters
    ----------
    result : PipelineResult
        From :func:`run_pipeline`.
    lif : afferent.spiking.LIFParams
    dt, engine, input, gain, tau, duration, drive, rheobase_multiple, reference_current, static_gain, rectify, slow_gain, slow_tau
        As :func:`afferent.spiking.spike_afferents` (``dt``, ``gain``, ``tau``, ``duration`` in
        s; ``reference_current`` in A).
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

    from .spiking import spike_afferents

    stage = spike_afferents(result.afferent, lif, dt=dt, engine=engine, input=input, current=result.current,
                            branching=result.branching, gain=gain, tau=tau, duration=duration, drive=drive,
                            rheobase_multiple=rheobase_multiple, reference_current=reference_current,
                            static_gain=static_gain, zones=zones, rectify=rectify, slow_gain=slow_gain,
                            slow_tau=slow_tau)
    return replace(result, input=stage.input, spikes=stage.spikes, timings={**result.timings, **stage.seconds},
                   drive=stage.drive, zones=zones)


#: Names that moved to their stage modules, importable from here as before (not re-documented here).
_MOVED = {"make_branching": "synthesis", "parse_synthesis": "synthesis", "SYNTHESES": "synthesis",
          "apply_waveform": "stimulus", "INPUTS": "spiking"}


def __getattr__(name: str):
    if name in _MOVED:
        from importlib import import_module

        return getattr(import_module(f"afferent.{_MOVED[name]}"), name)
    raise AttributeError(f"module 'afferent.pipeline' has no attribute {name!r}")
