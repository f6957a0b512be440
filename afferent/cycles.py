"""Per-cycle deepest points of a periodic series (the study's vibration, fig. 4-11) and SED vs frequency.

A run whose skin is pressed periodically (an export's own steps of a vibration at frequency f,
or a stimulus waveform) is cut into **cycles** ``[t0 + k T, t0 + (k + 1) T)``, T = 1 / f, t0 the
first step's time, k = 0 .. floor((t_end - t0) / T) - 1 (whole cycles only; the last one also
takes the step at its end). In each cycle the **deepest point** is the step of the largest total
SED over all sites (the rule the hot-spot maps use for "the deepest step", :mod:`afferent.hotspots`).

The **site** whose SED the table follows is chosen by one rule (docs/method.md, "Chapter 4"):
the site with the largest SED at the **last** cycle's deepest point, among the sites **near the
indenter's edge** when the scene gives the indenter's outline (a rectangle x_range x z_range and
a band half-width w: a site is near the edge when it lies within w of one of the rectangle's
sides, measured across that side, and not further than w beyond the other pair of sides), else
among all sites.

Spikes (optional) are counted per cycle over all afferents; ``rate_hz`` = spikes / (afferents x T),
the mean rate of an afferent over that cycle.

:func:`cycle_table` is a pure function of arrays; :func:`receptor_cycles` applies it to a run's
ReceptorSED and SpikeTrains (the ``cycles`` output, ``cycles.csv``); :func:`frequency_summary`
tabulates the ``cycles.csv`` of several runs against frequency for ``afferent cycles``.
"""

from __future__ import annotations

from .sampling import ReceptorSED

from ._typing import ArrayLike
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

if TYPE_CHECKING:  # afferent.spiking loads on first use (a SED-only run never imports it)
    from .spiking._trains import SpikeTrains

import numpy as np

__all__ = ["cycle_bounds", "edge_sites", "cycle_table", "receptor_cycles", "frequency_summary", "CYCLE_COLUMNS",
           "CYCLE_CHECKS"]

#: the columns of ``cycles.csv`` (SI units)
CYCLE_COLUMNS = ("cycle", "frequency_hz", "t_start_s", "t_end_s", "deepest_step", "deepest_time_s", "site",
                 "site_x_m", "site_z_m", "sed_pa", "max_sed_pa", "spikes", "n_afferents", "rate_hz")

#: What a cycles table read back must hold (``afferent._run_folder.check_table``): every column of
#: :data:`CYCLE_COLUMNS`, the site's coordinates, spikes and rate empty when not known, at least one cycle.
CYCLE_CHECKS = {"finite": ("cycle", "frequency_hz", "t_start_s", "t_end_s", "deepest_step", "deepest_time_s", "sed_pa",
                           "n_afferents"),
                "numbers": ("site_x_m", "site_z_m", "max_sed_pa", "spikes", "rate_hz"), "columns": ("site",)}


def cycle_bounds(times_s: ArrayLike, frequency_hz: float) -> np.ndarray:
    """Start times (s) of the whole cycles within ``times_s``, and the end of the last: shape (n_cycles + 1,).

    Raises ``ValueError`` for a frequency that is not > 0 or a series shorter than one cycle.
    """
    t = np.asarray(times_s, dtype=float).ravel()
    f = float(frequency_hz)
    if not np.isfinite(f) or f <= 0:
        raise ValueError(f"cycle frequency must be a number > 0 Hz; got {frequency_hz!r}.")
    period = 1.0 / f
    span = float(t[-1] - t[0]) if t.size else 0.0
    n = int(np.floor(span / period * (1 + 1e-9) + 1e-9))
    if n < 1:
        raise ValueError(f"a {f:g} Hz cycle lasts {period:.6g} s but the series spans {span:.6g} s "
                         f"({t.size} steps): not one whole cycle; check the frequency ([outputs] cycles_frequency_hz).")
    return t[0] + period * np.arange(n + 1)


def edge_sites(positions_m: ArrayLike, x_range_m: tuple[float, float], z_range_m: tuple[float, float], band_m: float) -> np.ndarray:
    """Mask of the sites within ``band_m`` (m) of a rectangle's outline (x_range_m x z_range_m, m) in the x-z plane.

    A site is near the edge when ``|dx| <= w`` and ``dz <= w``, or ``|dz| <= w`` and ``dx <= w``, with
    dx = |x - x_c| - half width (signed distance beyond the x sides), dz likewise, w = ``band_m``.
    """
    p = np.asarray(positions_m, dtype=float)
    (x0, x1), (z0, z1), w = sorted(x_range_m), sorted(z_range_m), float(band_m)
    tol = 1e-9 + 1e-9 * w
    dx = np.abs(p[:, 0] - 0.5 * (x0 + x1)) - 0.5 * (x1 - x0)
    dz = np.abs(p[:, 2] - 0.5 * (z0 + z1)) - 0.5 * (z1 - z0)
    return ((np.abs(dx) <= w + tol) & (dz <= w + tol)) | ((np.abs(dz) <= w + tol) & (dx <= w + tol))


def cycle_table(times_s: ArrayLike, sed_pa: ArrayLike, frequency_hz: float, *, positions_m: ArrayLike | None=None, ids: Sequence[str] | None=None, candidates: ArrayLike | None=None,
                spike_times: ArrayLike | None=None, n_afferents: int = 0) -> DataFrame:
    """One row per whole cycle (:data:`CYCLE_COLUMNS`, a pandas DataFrame) and the chosen site's index.

    Parameters
    ----------
    times_s : array (n_t,)
        Step times in s, increasing.
    sed_pa : array (n_t, n_sites)
        SED in Pa (J/m^3) at every step and site.
    frequency_hz : float
        The periodic input's frequency in Hz (> 0).
    positions_m : array (n_sites, 3), optional
        Site coordinates in m (``site_x_m``, ``site_z_m``); NaN without.
    ids : sequence of str, optional
        Site ids (default '0', '1', ...).
    candidates : bool array (n_sites,), optional
        The sites the chosen one is taken from (:func:`edge_sites`); default all. None of them: ValueError.
    spike_times : array of spike times in s (all afferents together), optional
        Counted per cycle into ``spikes``; ``rate_hz`` = spikes / (n_afferents T). Without: both NaN.
    n_afferents : int
        The afferents ``spike_times`` come from.
    """
    import pandas as pd

    t = np.asarray(times_s, dtype=float).ravel()
    v = np.asarray(sed_pa, dtype=float).reshape(t.size, -1)
    bounds = cycle_bounds(t, frequency_hz)
    n_cyc, period = bounds.size - 1, 1.0 / float(frequency_hz)
    eps = 1e-9 * period
    deep = []
    for k in range(n_cyc):
        hi = bounds[k + 1] + (eps if k == n_cyc - 1 else -eps)
        steps = np.flatnonzero((t >= bounds[k] - eps) & (t < hi))
        if steps.size == 0:
            raise ValueError(f"cycle {k + 1} ({bounds[k]:.6g} .. {bounds[k + 1]:.6g} s) holds no step; the series' "
                             f"steps are too coarse for {float(frequency_hz):g} Hz.")
        deep.append(int(steps[np.argmax(np.nansum(v[steps], axis=1))]))
    cand = np.ones(v.shape[1], bool) if candidates is None else np.asarray(candidates, bool)
    if not cand.any():
        raise ValueError(f"no site near the indenter's edge among the {v.shape[1]} sites; widen the band "
                         "([outputs] cycles_edge_m) or check the outline (cycles_x_range_m, cycles_z_range_m).")
    site = int(np.flatnonzero(cand)[np.nanargmax(v[deep[-1]][cand])])
    ids = np.arange(v.shape[1]).astype(str) if ids is None else np.asarray(ids).astype(str)
    pos = np.full((v.shape[1], 3), np.nan) if positions_m is None else np.asarray(positions_m, dtype=float)
    if spike_times is None:
        counts = np.full(n_cyc, np.nan)
    else:
        st = np.asarray(spike_times, dtype=float).ravel()
        edges = bounds.copy()
        edges[-1] += eps
        counts = np.histogram(st, bins=edges)[0].astype(float)
    rate = counts / (max(int(n_afferents), 1) * period) if spike_times is not None and n_afferents else counts * np.nan
    return pd.DataFrame({
        "cycle": np.arange(1, n_cyc + 1), "frequency_hz": float(frequency_hz), "t_start_s": bounds[:-1],
        "t_end_s": bounds[1:], "deepest_step": deep, "deepest_time_s": t[deep], "site": ids[site],
        "site_x_m": pos[site, 0], "site_z_m": pos[site, 2], "sed_pa": v[deep, site], "max_sed_pa": np.nanmax(v[deep], axis=1),
        "spikes": counts, "n_afferents": int(n_afferents), "rate_hz": rate}, columns=list(CYCLE_COLUMNS)), site


def receptor_cycles(sed: ReceptorSED, frequency_hz: float, *, x_range_m: tuple[float, float] | None=None, z_range_m: tuple[float, float] | None=None, edge_m: float | None=None, spikes: SpikeTrains | None=None) -> tuple[DataFrame, dict]:
    """The ``cycles`` output of a run: (:func:`cycle_table` of a ReceptorSED (J/m^3) and SpikeTrains, its record).

    ``x_range_m``, ``z_range_m`` (m): the indenter's outline; ``edge_m`` (m): the band half-width. All three or
    none (then the site is the largest at the last deepest point among all sites). The record (run.json
    ``cycles``) says the frequency, the rule, the site and its position, the candidates' count.
    """
    layout = sed.layout
    outline = (x_range_m, z_range_m, edge_m)
    cand = None if all(o is None for o in outline) else edge_sites(layout.positions, x_range_m, z_range_m, edge_m)
    times = np.asarray(sed.times, dtype=float) if sed.times is not None else np.arange(np.shape(sed.values)[0], dtype=float)
    st, n_aff = None, 0
    if spikes is not None:
        st, n_aff = np.concatenate([np.asarray(s, float) for s in spikes.spike_times] or [np.zeros(0)]), int(spikes.n_afferents)
    table, site = cycle_table(times, sed.values, frequency_hz, positions_m=layout.positions, ids=layout.ids,
                              candidates=cand, spike_times=st, n_afferents=n_aff)
    rule = ("the site with the largest SED at the last cycle's deepest point" + (
        "" if cand is None else f", among the {int(cand.sum())} sites within {edge_m:g} m of the indenter's outline "
        f"x {list(map(float, x_range_m))} m, z {list(map(float, z_range_m))} m"))
    record = {"frequency_hz": float(frequency_hz), "n_cycles": int(len(table)),
              "deepest_point": "per cycle, the step of the largest total SED over all sites",
              "site_rule": rule, "site": str(table["site"].iloc[0]), "site_index": site,
              "site_position_m": [float(v) for v in layout.positions[site]],
              "candidates": None if cand is None else [str(i) for i in np.asarray(layout.ids)[cand]],
              "spikes_counted": spikes is not None, "table": table.to_dict("list")}
    return table, record


def frequency_summary(runs: dict, groups: dict) -> DataFrame:
    """SED at the deepest points and mean rate vs frequency: one row per group and run, by frequency.

    ``runs``: {label: cycles.csv table}; ``groups``: {group: [labels]} (:func:`afferent.hotspots.group_runs`).
    The frequency is each table's ``frequency_hz`` (the scene's ``[outputs] cycles_frequency_hz``). Columns:
    ``group, run, frequency_hz, site, n_cycles, sed_first_pa, sed_last_pa`` (SED at the site at the first and
    the last cycle's deepest point, Pa), ``first_vs_lowest, last_vs_lowest`` (each over the group's lowest
    frequency's), ``spikes`` (all cycles), ``rate_hz`` (mean of the cycles' rates, Hz). Two runs of a group at
    one frequency, or a table that fails :data:`CYCLE_CHECKS` or ``_check_cycles``, are errors naming them.
    """
    import pandas as pd

    rows = []
    for g, labels in groups.items():
        seen = {}
        for lb in labels:
            t = _check_cycles(runs[lb], lb)
            f = float(t["frequency_hz"].iloc[0])
            if f in seen:
                raise ValueError(f"group {g!r}: runs {seen[f]!r} and {lb!r} are both at {f:g} Hz; one run per "
                                 "frequency in a group (use --group to separate the models).")
            seen[f] = lb
            rows.append({"group": g, "run": lb, "frequency_hz": f, "site": str(t["site"].iloc[0]),
                         "n_cycles": len(t), "sed_first_pa": float(t["sed_pa"].iloc[0]),
                         "sed_last_pa": float(t["sed_pa"].iloc[-1]), "spikes": float(t["spikes"].sum(min_count=1)),
                         "rate_hz": float(t["rate_hz"].mean())})
    out = pd.DataFrame(rows).sort_values(["group", "frequency_hz"], kind="stable", key=_group_order(list(groups)))
    for col in ("first", "last"):
        lowest = out.groupby("group")[f"sed_{col}_pa"].transform("first")
        out.insert(out.columns.get_loc("spikes"), f"{col}_vs_lowest", out[f"sed_{col}_pa"] / lowest)
    return out.reset_index(drop=True)


def _check_cycles(table, label: str):
    """``table`` checked as a cycles table of run ``label``: :data:`CYCLE_CHECKS`, one frequency > 0 (Hz) in every
    row, spikes and rates >= 0 (or empty: not counted)."""
    from ._run_folder import check_table

    where, what = f"run {label!r}: the cycles table", "the table of the 'cycles' output (afferent.cycles.CYCLE_COLUMNS)"
    t = check_table(table, where=where, what=what, **CYCLE_CHECKS)
    f = t["frequency_hz"].to_numpy()
    if not (f[0] > 0 and (f == f[0]).all()):
        raise ValueError(f"{where}: column 'frequency_hz' must hold one frequency > 0 Hz in every row; got "
                         f"{sorted(set(f.tolist()))} instead.")
    for c in ("spikes", "rate_hz"):
        if (t[c] < 0).any():
            raise ValueError(f"{where}: column {c!r} must be >= 0 (or empty: not counted); got {float(t[c].min())!r} "
                             f"in cycle {int(t['cycle'][t[c].idxmin()])} instead.")
    return t


def _group_order(names):
    """Sort key: groups in the order given, frequencies ascending."""
    def key(col):
        return col.map({n: i for i, n in enumerate(names)}) if col.name == "group" else col
    return key
