"""The result of :func:`afferent.spiking.simulate_lif`: :class:`SpikeTrains` (spike times per afferent, in s)."""

from __future__ import annotations

from .._typing import ArrayLike
from collections.abc import Iterable
from typing import Any
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .._validation import check_positive
from ._params import LIFParams

def spread_counts(counts: np.ndarray, cols: np.ndarray, n_afferents: int) -> np.ndarray:
    """Spike count per afferent from the engines' flat output: ``counts[j]`` spikes for afferent
    ``cols[j]`` (``cols`` increasing), none for the afferents not in ``cols`` (silent). The flat
    spike times, grouped by simulated afferent, are then grouped by afferent as they stand."""
    out = np.zeros(n_afferents, np.int64)
    out[cols] = counts
    return out


def _readonly(a: np.ndarray) -> np.ndarray:
    if not a.flags.c_contiguous:
        a = np.ascontiguousarray(a)
    if a.flags.writeable:
        a = a.view()
        a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class SpikeTrains:
    """Spike times of a population of afferents, from :func:`simulate_lif`.

    The spikes are stored flat, as brian2's ``SpikeMonitor`` stores them: ``t``, every
    spike time in s, and ``i``, the afferent (0-based position) of each spike; here grouped
    by afferent, each afferent's spikes in time order. ``spike_times`` gives one array per
    afferent, as views into ``t`` made on first use (``train`` gives one).

    Parameters
    ----------
    t : ndarray of shape (n_spikes,)
        Spike times in s: afferent 0's, then afferent 1's, ..., each sorted. Exact engine: the
        threshold crossing times, in ``[t_start, t_start + duration)``. Grid engines:
        ``t_start + k dt`` for whole steps ``k``, a spike stamped at the start of the step in
        which V crossed threshold.
    counts : ndarray of int, shape (n_afferents,)
        Number of spikes of each afferent (they sum to ``t.size``).
    afferent_ids : ndarray of shape (n_afferents,)
        Identifier of each afferent (the current's ``afferent_ids`` if it has them, else
        ``0 .. n_afferents - 1``).
    duration : float
        Simulated time in s (a whole number of steps on a grid; as asked with the exact engine).
    dt : float
        Time step in s; ``0.0`` for the exact engine, which has no grid.
    engine : str
        ``'exact'``, ``'fast'`` or ``'brian2'``.
    backend : str
        What ran: ``'numba'`` or ``'numpy'`` for the exact and fast engines, ``'brian2-numpy'``
        for brian2.
    silent_skipped : ndarray of int
        Positions (0-based columns of the current) of afferents that were not simulated
        because they are provably silent: ``r_m max(I) <= v_thresh - v_rest`` over the
        simulated window (see the Spikes page of the documentation, docs/spikes.md). The grid
        engines keep a margin of a few rounding errors so the skip never disagrees with a
        simulation; the exact engine, which fires only where the drive exceeds
        ``v_thresh - v_rest``, needs none.
    params : LIFParams
        The neuron parameters used.
    t_start : float, default=0.0
        Time of the first step in s (the current's first sample time).
    notes : tuple of str
        Remarks recorded by the simulation (refractory rounding, unused input samples, ...).

    Notes
    -----
    Arrays are read-only; the object compares by identity (``eq=False``).
    ``from_trains`` builds one from one array of spike times per afferent.
    """

    t: np.ndarray
    counts: np.ndarray
    afferent_ids: np.ndarray
    duration: float
    dt: float
    engine: str
    backend: str
    silent_skipped: np.ndarray
    params: LIFParams
    t_start: float = 0.0
    notes: tuple = field(default_factory=tuple)

    def __post_init__(self):
        object.__setattr__(self, "t", _readonly(np.asarray(self.t, dtype=np.float64)))
        object.__setattr__(self, "counts", _readonly(np.asarray(self.counts, dtype=np.int64)))
        object.__setattr__(self, "afferent_ids", _readonly(np.asarray(self.afferent_ids)))
        object.__setattr__(self, "silent_skipped", _readonly(np.asarray(self.silent_skipped, dtype=np.int64)))
        if self.t.ndim != 1 or self.counts.ndim != 1 or int(self.counts.sum()) != self.t.size:
            raise ValueError(
                f"'counts' must be one spike count per afferent summing to the number of spike times "
                f"{self.t.size}; got shape {self.counts.shape} summing to {int(self.counts.sum())} instead."
            )
        if self.afferent_ids.shape != self.counts.shape:
            raise ValueError(
                f"'afferent_ids' must be an array of shape (n_afferents,) = ({self.counts.size},); "
                f"got shape {self.afferent_ids.shape} instead."
            )

    @classmethod
    def from_trains(cls, spike_times: Iterable[ArrayLike], **fields: Any) -> "SpikeTrains":
        """From one sorted array of spike times in s per afferent; ``fields`` as the constructor's."""
        trains = [np.asarray(x, dtype=np.float64).ravel() for x in spike_times]
        t = np.concatenate(trains) if trains else np.empty(0)
        return cls(t=t, counts=np.array([x.size for x in trains], dtype=np.int64), **fields)

    @cached_property
    def _offsets(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(self.counts)])

    @property
    def i(self) -> np.ndarray:
        """Afferent (0-based position) of each spike of ``t``, ndarray of int64."""
        return np.repeat(np.arange(self.n_afferents), self.counts)

    def train(self, k: int) -> np.ndarray:
        """Spike times in s of the afferent at position ``k`` (a read-only view into ``t``)."""
        lo, hi = self._offsets[k], self._offsets[k + 1]
        return self.t[lo:hi]

    @cached_property
    def spike_times(self) -> tuple:
        """One sorted array of spike times in s per afferent (read-only views into ``t``)."""
        return tuple(np.split(self.t, self._offsets[1:-1]))

    @property
    def n_afferents(self) -> int:
        """Number of afferents (simulated or skipped)."""
        return self.counts.size

    @property
    def n_spikes(self) -> np.ndarray:
        """Spike count per afferent, ndarray of shape (n_afferents,)."""
        return self.counts.copy()

    @property
    def simulated(self) -> np.ndarray:
        """Boolean mask of shape (n_afferents,): True where the afferent was simulated."""
        mask = np.ones(self.n_afferents, dtype=bool)
        mask[self.silent_skipped] = False
        return mask

    def rates(self) -> np.ndarray:
        """Mean firing rate over the simulated window, in Hz: ``n_spikes / duration``."""
        return self.n_spikes / self.duration

    def rates_between(self, t0: float, t1: float) -> np.ndarray:
        """Mean rate of each afferent over [t0, t1) in s, in Hz (NaN for an empty interval)."""
        if not t1 > t0:
            return np.full(self.n_afferents, np.nan)
        inside = (self.t >= t0) & (self.t < t1)
        return np.bincount(self.i[inside], minlength=self.n_afferents).astype(float) / (t1 - t0)

    def peak_rate(self) -> np.ndarray:
        """Peak instantaneous rate of each afferent, 1 / (shortest inter-spike interval), in Hz;
        0 below two spikes. Bursts at a ramp's onset show here, not in the window mean."""
        i = self.i
        isi = np.diff(self.t)
        isi[i[1:] != i[:-1]] = np.inf  # from one afferent's last spike to the next one's first
        shortest = np.full(self.n_afferents, np.inf)
        np.minimum.at(shortest, i[1:], isi)
        return np.where(self.counts >= 2, 1.0 / shortest, 0.0)

    def first_spike_latency(self) -> np.ndarray:
        """Time from ``t_start`` to each afferent's first spike in s; NaN if it never fired."""
        first = np.full(self.n_afferents, np.nan)
        fired = self.counts > 0
        first[fired] = self.t[self._offsets[:-1][fired]] - self.t_start
        return first

    def isi(self) -> tuple:
        """Inter-spike intervals in s: one array of length ``n_spikes - 1`` per afferent."""
        return tuple(np.diff(t) for t in self.spike_times)

    def psth(self, bin_width: float) -> tuple[np.ndarray, np.ndarray]:
        """Population peri-stimulus time histogram.

        Parameters
        ----------
        bin_width : float
            Bin width in s; the last bin is cut at the end of the window.

        Returns
        -------
        rate_hz : ndarray of shape (n_bins,)
            Mean rate per afferent in each bin, in Hz (spikes / (n_afferents * bin width)).
        edges : ndarray of shape (n_bins + 1,)
            Bin edges in s, from ``t_start`` to ``t_start + duration``.
        """
        bin_width = check_positive("bin_width", bin_width, unit="s")
        n_bins = max(int(np.ceil(self.duration / bin_width - 1e-9)), 1)
        edges = self.t_start + np.minimum(np.arange(n_bins + 1) * bin_width, self.duration)
        counts, _ = np.histogram(self.t, bins=edges)
        denom = max(self.n_afferents, 1) * np.diff(edges)
        return counts / denom, edges

    def table(self) -> dict:
        """Every spike as columns (no pandas): ``afferent`` (ids, str) and ``spike_time_s`` (s), sorted
        by afferent; what :meth:`to_dataframe` holds and ``spikes.csv`` lists."""
        return {"afferent": np.repeat(self.afferent_ids, self.n_spikes), "spike_time_s": self.t}

    def to_dataframe(self) -> DataFrame:
        """Tidy table of every spike: columns ``afferent`` and ``spike_time_s``, sorted by afferent."""
        import pandas as pd

        return pd.DataFrame(self.table())

    def summary_table(self) -> dict:
        """One entry per afferent, as columns (no pandas): ``afferent`` (ids) then the columns of
        :meth:`summary`; what ``spike_summary.csv`` lists (with the afferents' positions)."""
        isis = self.isi()
        mean_isi = np.array([d.mean() if d.size >= 1 else np.nan for d in isis])
        cv_isi = np.array([d.std() / d.mean() if d.size >= 2 else np.nan for d in isis])
        return {
            "afferent": np.asarray(self.afferent_ids),
            "n_spikes": self.n_spikes,
            "rate_hz": self.rates(),
            "first_spike_latency_s": self.first_spike_latency(),
            "mean_isi_s": mean_isi,
            "cv_isi": cv_isi,
            "simulated": self.simulated,
        }

    def summary(self) -> DataFrame:
        """One row per afferent, as a DataFrame indexed by ``afferent``.

        Columns: ``n_spikes``; ``rate_hz``; ``first_spike_latency_s`` (NaN if it never fired);
        ``mean_isi_s`` (NaN below 2 spikes); ``cv_isi``, the standard deviation over the mean
        of the ISIs (NaN below 3 spikes); ``simulated`` (False for afferents skipped as
        provably silent).
        """
        import pandas as pd

        columns = self.summary_table()
        index = pd.Index(columns.pop("afferent"), name="afferent")
        return pd.DataFrame(columns, index=index)

    def __repr__(self) -> str:
        return (
            f"<SpikeTrains: {self.n_afferents} afferents ({self.silent_skipped.size} skipped as silent), "
            f"{int(self.n_spikes.sum())} spikes in {self.duration:g} s, engine {self.engine!r} ({self.backend}), "
            + (f"dt={self.dt:g} s>" if self.dt else "no grid>")
        )

