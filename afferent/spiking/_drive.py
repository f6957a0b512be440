"""How an afferent current becomes the LIF's drive (rheobase mapping), what the LIF made of it, and
:func:`spike_afferents`, the stages 'input' and 'spiking' of a run in order."""

from __future__ import annotations

from ..synthesis import AfferentCurrent, Branching
from ..transduction import ReceptorCurrent
from ..zones import Zones

from .._typing import ArrayLike

import time
import warnings
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from .._validation import check_option, check_positive
from ..exceptions import AfferentWarning
from ..stimulus._adaptation import InputKind, Rectify
from ._params import Engine, LIFParams
from ._trains import SpikeTrains

# How an input current becomes the drive: see DRIVE_MAPPINGS in afferent.spiking (documented there).
DriveMapping = Literal["resistance", "rheobase"]
DRIVE_MAPPINGS: tuple[str, ...] = get_args(DriveMapping)
#: Fraction of the 1 / t_ref ceiling at which a rate counts as saturated by the LIF.
CEILING_FRACTION = 0.9

def rheobase_scale(values: ArrayLike, lif: LIFParams, *, multiple: float, reference: float | None = None) -> tuple[float, float]:
    """Factor that maps a reference current to ``multiple`` x the LIF's rheobase.

    Parameters
    ----------
    values : array_like
        The input currents in A (to find the reference when none is given).
    lif : LIFParams
        Its rheobase ``(v_thresh - v_rest) / r_m`` in A is the target unit.
    multiple : float
        How many rheobases the reference current becomes, > 0 (2: the strongest afferent fires
        at about 1 / (t_ref + tau_m ln 2)).
    reference : float, optional
        The reference current in A; default the largest |value|.

    Returns
    -------
    (scale, reference) : tuple of float
        Multiply the currents by ``scale`` (dimensionless); ``reference`` in A.
    """
    multiple = check_positive("multiple", multiple, unit="rheobases")
    ref = float(np.max(np.abs(np.asarray(values, dtype=float)))) if reference is None else float(reference)
    if not ref > 0:
        return 1.0, ref
    return multiple * lif.rheobase / ref, ref


def drive_report(input_values: ArrayLike, lif: LIFParams, spikes: SpikeTrains) -> dict:
    """What the LIF made of its drive, per afferent, and whether the rates carry information.

    Parameters
    ----------
    input_values : array_like of shape (n_times, n_afferents)
        The current fed to the LIF, in A (after any mapping).
    lif : LIFParams
    spikes : SpikeTrains

    Returns
    -------
    dict
        Per afferent (lists): ``peak_current_a``, ``drive_over_rheobase`` (r_m I_peak over
        v_thresh - v_rest), ``predicted_rate_hz`` (the closed-form rate of a constant I_peak),
        ``rate_hz`` (simulated mean), ``peak_instantaneous_hz``; and ``ceiling_hz`` (1 / t_ref),
        ``all_at_ceiling`` (every afferent's peak instantaneous rate >= 90 % of it),
        ``all_silent``, ``warning`` (a sentence, or None).
    """
    v = np.asarray(input_values, dtype=float)
    peak = np.max(v, axis=0) if v.size else np.zeros(spikes.n_afferents)
    ratio = peak / lif.rheobase
    ceiling = 1.0 / lif.t_ref if lif.t_ref > 0 else float("inf")
    inst = spikes.peak_rate()
    all_ceiling = bool(spikes.n_afferents and np.all(inst >= CEILING_FRACTION * ceiling))
    all_silent = bool(spikes.n_afferents and np.all(spikes.n_spikes == 0))
    warning = None
    if all_ceiling:
        warning = (f"All {spikes.n_afferents} afferents fire at >= {CEILING_FRACTION:.0%} of 1/t_ref ({ceiling:.4g} Hz): "
                   f"their drive is {ratio.min():.3g}-{ratio.max():.3g} x the rheobase, so the rates carry no information "
                   "about the SED pattern. Map the current to the membrane with drive 'rheobase' (the largest current -> "
                   "k x the rheobase) or choose r_m for these currents.")
    elif all_silent:
        warning = (f"All {spikes.n_afferents} afferents are silent: their drive peaks at {ratio.max():.3g} x the rheobase "
                   "(< 1 never fires). Map the current with drive 'rheobase' or choose r_m for these currents.")
    return {
        "peak_current_a": peak.tolist(), "drive_over_rheobase": ratio.tolist(),
        "predicted_rate_hz": lif.steady_rate(peak).tolist(), "rate_hz": spikes.rates().tolist(),
        "peak_instantaneous_hz": inst.tolist(), "ceiling_hz": ceiling, "all_at_ceiling": all_ceiling,
        "all_silent": all_silent, "warning": warning,
    }



#: What the LIF is given (:func:`spike_afferents`): the afferent current itself, the rate-sensitive input
#: (RA-I), or the slowly adapting static-plus-rate input (SA-I; docs/classes.md).
INPUTS: tuple[str, ...] = get_args(InputKind)
#: input -> mode of :func:`afferent.stimulus.adapting_input`
_ADAPTATION_OF_INPUT = {"rate-sensitive": "rectified-rate", "slowly-adapting": "static-plus-rate"}


@dataclass(frozen=True)
class SpikeStage:
    """What :func:`spike_afferents` made of an afferent current.

    Attributes
    ----------
    input : afferent.stimulus.InputCurrent
        The current fed to the LIF in A (after any drive mapping), tagged with its kind.
    spikes : SpikeTrains
    drive : dict
        The mapping used (``mapping``, ``r_m_ohm``, ``rheobase_a``, and with 'rheobase' its
        multiple, reference current in A and scale) and :func:`drive_report`.
    seconds : dict
        Wall time of the stages 'input' and 'spiking', s.
    zones : afferent.zones.Zones or None
        The spike-initiation zones the LIF ran on (None: the ``sum`` model).
    """

    input: object
    spikes: SpikeTrains
    drive: dict
    seconds: dict
    zones: object = None


def spike_afferents(afferent: AfferentCurrent, lif: LIFParams, *, dt: float, engine: Engine = "auto", input: InputKind = "static",
                    current: ReceptorCurrent | None=None, branching: Branching | None=None, gain: float | None = None, tau: float | None = None,
                    duration: float | None = None, drive: DriveMapping = "resistance", rheobase_multiple: float = 2.0,
                    reference_current: float | None = None, static_gain: float | None = None,
                    zones: Zones | None=None, rectify: Rectify | None = None, slow_gain: float | None = None,
                    slow_tau: float | None = None) -> SpikeStage:
    """The stages 'input' and 'spiking': the input current -> its drive mapping -> leaky integrate-and-fire.

    Parameters
    ----------
    afferent : afferent.synthesis.AfferentCurrent
        Afferent currents in A over times in s.
    lif : LIFParams
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
    current : afferent.transduction.ReceptorCurrent, optional
        Receptor currents in A (required for the adapting inputs and for ``zones``).
    branching : afferent.synthesis.Branching, optional
        The grouping that made ``afferent`` (required for the rate-sensitive input).
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
    static_gain : float, optional
        With ``input='slowly-adapting'``: the gain of the static term (dimensionless; default
        that of ``adapting_input``).
    rectify, slow_gain, slow_tau : optional
        With ``input='slowly-adapting'``: how the terms are rectified (``'sum'``, default, or
        ``'components'``) and a second rate component (gain in s, time constant in s), as
        :func:`afferent.stimulus.adapting_input`.
    zones : afferent.zones.Zones, optional
        The ``zones`` branching model (:func:`afferent.zones.split_zones` of ``branching``): the
        input is synthesized per zone and each zone drives its own LIF; the afferent fires when
        one of its zones does, and all reset (:func:`afferent.spiking.simulate_lif`). Default
        None: the ``sum`` model, the study's.

    Returns
    -------
    SpikeStage

    Warns
    -----
    AfferentWarning
        When all afferents fire at >= 90 % of 1 / t_ref, or none fires.
    """
    from dataclasses import replace

    from .. import stimulus
    from . import simulate_lif

    check_option("input", input, INPUTS)
    _check_zones(zones, branching)
    seconds = {}
    t = time.perf_counter()
    target = branching if zones is None else zones.branching
    if input == "static":
        from ..synthesis import synthesize

        drive_current = stimulus.static_input(afferent if zones is None else synthesize(current, target))
    else:
        if gain is None:
            raise ValueError(f"input={input!r} needs gain= (s): how much input current (A) per A/s of rate.")
        kw = {} if tau is None else {"tau": tau}
        for key, value in (("static_gain", static_gain), ("rectify", rectify), ("slow_gain", slow_gain),
                           ("slow_tau", slow_tau)):
            if value is not None:
                kw[key] = value
        drive_current = stimulus.adapting_input(current, gain=gain, mode=_ADAPTATION_OF_INPUT[input],
                                                **kw).synthesize(target)
    check_option("drive", drive, DRIVE_MAPPINGS)
    mapping = {"mapping": drive, "r_m_ohm": lif.r_m, "rheobase_a": lif.rheobase}
    if drive == "rheobase":
        summed = drive_current.values if zones is None else _afferent_sums(drive_current.values, zones)
        scale, ref = rheobase_scale(summed, lif, multiple=rheobase_multiple, reference=reference_current)
        drive_current = replace(drive_current, values=drive_current.values * scale)
        mapping.update(rheobase_multiple=rheobase_multiple, reference_current_a=ref, scale=scale)
    seconds["input"] = time.perf_counter() - t
    if duration is None:
        times = afferent.times
        duration = float(times[-1] - times[0]) if times is not None and len(times) > 1 else None
    t = time.perf_counter()
    spikes = simulate_lif(drive_current, lif, dt=dt, engine=engine, duration=duration, zones=zones)
    seconds["spiking"] = time.perf_counter() - t
    report = drive_report(drive_current.values if zones is None else _strongest_zone(drive_current.values, zones),
                          lif, spikes)
    if report["warning"]:
        warnings.warn(report["warning"], AfferentWarning, stacklevel=3)
    return SpikeStage(drive_current, spikes, {**mapping, **report}, seconds, zones)


def _check_zones(zones, branching) -> None:
    """``zones`` must divide the afferents of ``branching`` (None: the sum model)."""
    if zones is None:
        return
    if not (hasattr(zones, "parent") and hasattr(zones, "branching") and hasattr(zones, "afferent")):
        raise TypeError(f"'zones' must be an afferent.zones.Zones; got {type(zones).__name__} instead.")
    if branching is None or not (zones.parent.n_afferents == branching.n_afferents
                                 and (zones.parent.afferent_ids == branching.afferent_ids).all()):
        raise ValueError("'zones' must divide the afferents of the result's branching; build them with "
                         "afferent.zones.split_zones(result.branching, layout, k).")


def _afferent_sums(values, zones):
    """Each afferent's current (A, (n_times, n_afferents)) as the sum of its zones' (``values``)."""
    from ..zones import zone_indicator

    return (zone_indicator(zones).T @ values.T).T


def _strongest_zone(values, zones):
    """Peak current (A) of each afferent's strongest zone, shape (1, n_afferents), for the drive report."""
    out = np.zeros(zones.parent.n_afferents)
    if values.size:
        np.maximum.at(out, zones.afferent, values.max(axis=0))
    return out[None, :]
