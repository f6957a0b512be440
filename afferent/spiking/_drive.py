"""How an afferent current becomes the LIF's drive (rheobase mapping), and what the LIF made of it."""

from __future__ import annotations

import numpy as np

from .._validation import check_positive
from ._params import LIFParams
from ._trains import SpikeTrains

# How an input current becomes the drive: see DRIVE_MAPPINGS in afferent.spiking (documented there).
DRIVE_MAPPINGS = ("resistance", "rheobase")
#: Fraction of the 1 / t_ref ceiling at which a rate counts as saturated by the LIF.
CEILING_FRACTION = 0.9

def rheobase_scale(values, lif: LIFParams, *, multiple: float, reference: float | None = None) -> tuple[float, float]:
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


def drive_report(input_values, lif: LIFParams, spikes: SpikeTrains) -> dict:
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

