"""The spike and stimulus figures of :mod:`afferent.plotting` (raster, rates per phase, PSTH, waveform).

Imported into :mod:`afferent.plotting`, whose names they are (``plotting.plot_rates``); matplotlib is
imported inside the functions only. Times in s, positions in m (shown in mm), rates in Hz.
"""

from __future__ import annotations

from .stimulus._waveforms import Waveform
from .synthesis import AfferentCurrent

from ._typing import ArrayLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from matplotlib.axes import Axes
    from pandas import DataFrame

if TYPE_CHECKING:  # afferent.spiking loads on first use (a SED-only run never imports it)
    from .spiking._trains import SpikeTrains

import numpy as np

from .plotting import _axes, legend_beside

#: Above this many afferents the raster's y axis shows indices, not names.
MAX_RASTER_LABELS = 30


def plot_raster(spikes: SpikeTrains, ax: Axes | None=None, *, color: str = "k", title: str | None = None) -> Axes:
    """Spike raster: one row per afferent, one tick per spike.

    Parameters
    ----------
    spikes : SpikeTrains
        From :func:`afferent.spiking.simulate_lif`; spike times in s.
    ax : matplotlib Axes, optional
    color : str, default='k'
    title : str, optional

    Returns
    -------
    matplotlib Axes
        x: time (s) over the simulated window; y: afferent (names when at most
        :data:`MAX_RASTER_LABELS`, else indices).

    Examples
    --------
    >>> ax = plot_raster(trains)  # doctest: +SKIP
    """
    ax = _axes(ax)
    n = spikes.n_afferents
    if n:
        ax.eventplot(list(spikes.spike_times), lineoffsets=np.arange(n), linelengths=0.8, colors=color,
                     linewidths=0.8)
    ax.set_xlim(spikes.t_start, spikes.t_start + spikes.duration)
    ax.set_ylim(-0.6, max(n, 1) - 0.4)
    if 0 < n <= MAX_RASTER_LABELS:
        ax.set_yticks(np.arange(n))
        ax.set_yticklabels([str(i) for i in spikes.afferent_ids])
        ax.set_ylabel("afferent")
    else:
        ax.set_ylabel("afferent (index)")
    ax.set_xlabel("time (s)")
    ax.set_title(title or f"{int(spikes.n_spikes.sum())} spikes, {n} afferents")
    return ax


def rate_table(spikes: SpikeTrains, waveform: Waveform | None=None, positions: ArrayLike | AfferentCurrent | None=None) -> DataFrame:
    """The numbers ``rates.png`` shows, one row per afferent: the rate in each stimulus phase
    (when a waveform is given: loading, hold, unloading, off; :meth:`Waveform.phases`), the mean
    over the whole window and the peak instantaneous rate, all in Hz.

    Parameters
    ----------
    spikes : SpikeTrains
    waveform : Waveform, optional
        The stimulus; its phases split the window.
    positions : array_like or AfferentCurrent, optional
        Afferent positions in m (a column ``position_m``).

    Returns
    -------
    pandas.DataFrame
        Columns ``afferent``, [``position_m``], ``<phase>_hz`` per phase (``loading_hz``,
        ``hold_hz``, ...; a phase that repeats, as in a sinusoid, is pooled: its spikes over its
        total time), ``mean_hz``, ``peak_instantaneous_hz``.
    """
    import pandas as pd

    return pd.DataFrame(_rate_columns(spikes, waveform, positions))


def _rate_columns(spikes, waveform=None, positions=None) -> dict:
    """:func:`rate_table`'s columns (name -> array, in order) without pandas: :func:`plot_rates` draws them, and the
    figure process (``afferent._figure_process``) need not import pandas (~0.3 s)."""
    df = {"afferent": np.asarray(spikes.afferent_ids)}
    if positions is not None:
        df["position_m"] = np.asarray(getattr(positions, "positions", positions), dtype=float)
    if waveform is not None:
        spans: dict[str, list] = {}
        for name, t0, t1 in waveform.phases():
            lo, hi = max(t0, spikes.t_start), min(t1, spikes.t_start + spikes.duration)
            if hi > lo:
                spans.setdefault(name, []).append((lo, hi))
        for name, parts in spans.items():
            n = sum(spikes.rates_between(lo, hi) * (hi - lo) for lo, hi in parts)
            total = sum(hi - lo for lo, hi in parts)
            df[f"{name}_hz"] = n / total
    df["mean_hz"] = np.asarray(spikes.rates())
    df["peak_instantaneous_hz"] = np.asarray(spikes.peak_rate())
    return df


#: rates.png: the phases' markers and colours (hollow, cycled when a waveform has more than four phases) and the
#: peak instantaneous rate's (a filled crimson star): no phase looks like the peak (the 'off' phase was a red
#: triangle beside the peak's crimson one).
PHASE_MARKERS = "osDv"
PHASE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple")
PEAK_STYLE = {"marker": "*", "color": "crimson"}


def plot_rates(spikes: SpikeTrains, positions: ArrayLike | AfferentCurrent | None=None, ax: Axes | None=None, *, waveform: Waveform | None=None, label: str | None = None, title: str | None = None) -> Axes:
    """Firing rate of each afferent: per stimulus phase, the window mean, and the peak
    instantaneous rate (1 / shortest ISI), against position when given.

    A rate-sensitive RA-I afferent fires bursts at the onset and the release of a ramp-and-hold
    and nothing through the hold: its window mean (e.g. 30 Hz) hides 300-400 Hz bursts, which
    the peak instantaneous rate and the loading/unloading rates show. Each phase is a hollow marker
    in its own colour (``PHASE_MARKERS``, ``PHASE_COLOURS``), the peak a filled crimson
    star, each named in the legend.

    Parameters
    ----------
    spikes : SpikeTrains
    positions : array_like of shape (n_afferents,) or AfferentCurrent, optional
        Afferent coordinate in m (an object with ``positions``, e.g. the AfferentCurrent or
        InputCurrent that was simulated, is accepted; its ``axis`` names the x label). Without
        it the rates are plotted against the afferent index.
    ax : matplotlib Axes, optional
    waveform : Waveform, optional
        Splits the window into its phases (:func:`rate_table`).
    label : str, optional
        Legend label of the window mean.
    title : str, optional

    Returns
    -------
    matplotlib Axes
        x: position (mm) or afferent index; y: rate (Hz).

    Raises
    ------
    ValueError
        If ``positions`` does not have one entry per afferent.
    """
    ax = _axes(ax, figsize=(7.5, 4.2))
    rates = spikes.rates()
    axis = getattr(positions, "axis", None)
    if positions is not None and hasattr(positions, "positions"):
        positions = positions.positions
    if positions is None:
        x = np.arange(rates.size)
        ax.set_xlabel("afferent (index)")
    else:
        x = np.asarray(positions, dtype=float)
        if x.shape != rates.shape:
            raise ValueError(
                f"'positions' must have one entry per afferent (n_afferents = {rates.size}), in m; "
                f"got shape {x.shape} instead."
            )
        x = x * 1e3
        ax.set_xlabel(f"{axis or 'position'} (mm)")
    table = _rate_columns(spikes, waveform)
    order = np.argsort(x)
    phases = [c for c in table if c.endswith("_hz") and c not in ("mean_hz", "peak_instantaneous_hz")]
    for j, col in enumerate(phases):  # later phases drawn smaller and dashed: equal rates (0 Hz) stay visible
        ax.plot(x[order], np.asarray(table[col])[order], PHASE_MARKERS[j % 4] + ("-" if j == 0 else "--"), mfc="none",
                ms=9 - 1.5 * (j % 4), color=PHASE_COLOURS[j % 4], label=f"{col[:-3]} phase")
    ax.plot(x[order], table["mean_hz"][order], "k:", lw=1.5, label=label or "mean over the window")
    ax.plot(x[order], table["peak_instantaneous_hz"][order], ls="-.", ms=8, label="peak instantaneous (1 / shortest ISI)",
            **PEAK_STYLE)
    ax.set_ylabel("rate (Hz)")
    legend_beside(ax)
    ax.set_title(title or f"firing rates over {spikes.duration:g} s")
    return ax


def plot_psth(spikes: SpikeTrains, bin_width: float, ax: Axes | None=None, *, label: str | None = None, title: str | None = None) -> Axes:
    """Population peri-stimulus time histogram (mean rate per afferent in each bin).

    Parameters
    ----------
    spikes : SpikeTrains
    bin_width : float
        Bin width in s (see :meth:`SpikeTrains.psth`).
    ax : matplotlib Axes, optional
    label : str, optional
    title : str, optional

    Returns
    -------
    matplotlib Axes
        x: time (s); y: rate (Hz per afferent).

    Raises
    ------
    ValueError
        If ``bin_width`` is not > 0 s.
    """
    rate, edges = spikes.psth(bin_width)
    ax = _axes(ax)
    ax.stairs(rate, edges, fill=True, alpha=0.6, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("rate per afferent (Hz)")
    ax.set_xlim(edges[0], edges[-1])
    if label:
        legend_beside(ax)  # beside the Axes: the bars fill it
    ax.set_title(title or f"PSTH, {bin_width * 1e3:g} ms bins")
    return ax


def plot_waveform(waveform: Waveform, ax: Axes | None=None, *, title: str | None = None) -> Axes:
    """Indentation depth over time.

    Parameters
    ----------
    waveform : Waveform
        Times in s, depth in m (shown in mm).
    ax : matplotlib Axes, optional
    title : str, optional

    Returns
    -------
    matplotlib Axes
        x: time (s); y: depth (mm).
    """
    ax = _axes(ax, figsize=(5.5, 2.8))
    ax.plot(waveform.times, waveform.depth * 1e3, "-", lw=1.2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("depth (mm)")
    ax.set_ylim(bottom=0)
    ax.set_title(title or f"{waveform.kind} waveform")
    return ax
