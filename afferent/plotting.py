"""Figures a reader of the study would recognise; with _plot_spikes.py and calibration/_plots.py, the only modules importing matplotlib.

Every function takes ``ax=None`` (a new figure when None) and returns the Axes. Lengths are
shown in mm and SED in Pa (= J/m^3) on the axes; the data stay SI.
"""

from __future__ import annotations

from .profiles import ProfileFit
from .sampling import ReceptorSED
from .synthesis import AfferentCurrent
from .transduction import ReceptorCurrent

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from matplotlib.axes import Axes
    from pandas import DataFrame
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend

import numpy as np

__all__ = [
    "plot_sed_map", "plot_sed_profile", "plot_section_profiles", "plot_fit",
    "plot_raster", "plot_rates", "rate_table", "plot_psth", "plot_waveform", "save_figure", "legend_beside",
    "plot_hotspots", "plot_hotspot_maps", "plot_hotspot_summary", "plot_distance_table",
    "plot_frequency",
]


def _axes(ax, figsize=(5.0, 4.2)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def plot_sed_map(sed: ReceptorSED, *, time_index: int = -1, ax: Axes | None=None, normalise: bool = False, threshold: float | None = None,
                 title: str | None = None) -> Axes:
    """SED over the receptor sites, seen from above (x across the ridges, z along them).

    The study's figure 5-5 (normalised hot-spot map, threshold 0.6) with ``normalise=True,
    threshold=0.6``.

    Parameters
    ----------
    sed : ReceptorSED
        SED at receptor sites, J/m^3.
    time_index : int, default=-1
        Which time step to show.
    ax : matplotlib Axes, optional
    normalise : bool, default=False
        Min-max normalise the SED over the receptors (dimensionless colour scale).
    threshold : float, optional
        With ``normalise``, outline the receptors at or above this normalised value.
    title : str, optional

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    v = np.asarray(sed.values[time_index], dtype=float)
    pos_mm = sed.layout.positions * 1e3
    label = "SED (Pa = J/m³)"
    if normalise:
        span = np.nanmax(v) - np.nanmin(v)
        v = (v - np.nanmin(v)) / span if span > 0 else np.zeros_like(v)
        label = "normalised SED"
    sc = ax.scatter(pos_mm[:, 0], pos_mm[:, 2], c=v, s=28, cmap="viridis", edgecolors="none")
    if normalise and threshold is not None:
        hot = v >= threshold
        ax.scatter(pos_mm[hot, 0], pos_mm[hot, 2], s=60, facecolors="none", edgecolors="crimson", linewidths=1.0,
                   label=f">= {threshold:g}")
        # named in the x label, not in a legend box (which would sit on receptors)
    ax.figure.colorbar(sc, ax=ax, label=label)
    ax.set_xlabel("x, across ridges (mm)" + (f"\nred rings: normalised SED >= {threshold:g}"
                                              if normalise and threshold is not None else ""))
    ax.set_ylabel("z, along ridges (mm)")
    ax.set_aspect("equal")
    t = sed.times[time_index]
    ax.set_title(title or f"SED at receptor sites, t = {t:g} s")
    return ax


def plot_hotspots(table: DataFrame, *, threshold: float, ax: Axes | None=None, title: str | None = None) -> Axes:
    """A hot-spot map (the study's fig. 4-9): every site a grey dot, the hot ones coloured by normalised SED.

    ``table``: :func:`afferent.hotspots.hotspot_table` (x_m, z_m, normalised); ``threshold``: the
    colour scale starts there (normalised SED 0..1). Seen from above: x across the ridges, z along them.
    """
    ax = _axes(ax, figsize=(4.2, 4.0))
    x, z = table["x_m"].to_numpy() * 1e3, table["z_m"].to_numpy() * 1e3
    v = table["normalised"].to_numpy()
    hot = v >= threshold
    ax.scatter(x, z, s=8, c="0.8", edgecolors="none")
    sc = ax.scatter(x[hot], z[hot], c=v[hot], s=46, cmap="inferno_r", vmin=threshold, vmax=1.0, edgecolors="k",
                    linewidths=0.3)
    ax.figure.colorbar(sc, ax=ax, label=f"normalised SED (>= {threshold:g})", shrink=0.8)
    ax.set_xlabel("x, across ridges (mm)")
    ax.set_ylabel("z, along ridges (mm)")
    ax.set_aspect("equal")
    ax.set_title(title or f"hot spots: {int(hot.sum())} of {len(v)} sites")
    return ax


def plot_hotspot_maps(tables: Sequence[DataFrame], *, threshold: float, title: str = "") -> Figure:
    """The ``hotspots.png`` figure: one hot-spot map per table, side by side (e.g. RA-I beside SA-I)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tables), figsize=(4.4 * len(tables), 4.2), layout="constrained", squeeze=False)
    for ax, t in zip(axes[0], tables):
        n_hot = int(t["hot"].sum())
        plot_hotspots(t, threshold=threshold, ax=ax,
                      title=f"{t['map'].iloc[0]}: {n_hot} of {len(t)} sites >= {threshold:g}")
    if title:
        fig.suptitle(title)
    return fig


def plot_frequency(summary: DataFrame, *, title: str | None = None) -> Figure:
    """The study's fig. 4-11 beside fig. 4-12: SED at the site at the deepest points, and mean rate, vs frequency.

    ``summary``: :func:`afferent.cycles.frequency_summary` (SED in Pa, frequency and rate in Hz); a line per
    group (model), the first cycle's deepest point dashed, the last's solid, its legend naming each run's own
    last cycle (``_last_cycles``). Both axes start at zero: a few-percent change between frequencies or
    cycles looks as small as it is. Returns the Figure.
    """
    import matplotlib.pyplot as plt

    fig, (ax_sed, ax_rate) = plt.subplots(1, 2, figsize=(10.5, 4.0), layout="constrained")
    for i, (g, t) in enumerate(summary.groupby("group", sort=False)):
        color = f"C{i}"
        ax_sed.plot(t["frequency_hz"], t["sed_first_pa"], "o--", color=color, label=f"{g}, 1st deepest point")
        ax_sed.plot(t["frequency_hz"], t["sed_last_pa"], "s-", color=color,
                    label=f"{g}, last deepest point: {_last_cycles(t['frequency_hz'], t['n_cycles'])}")
        ax_rate.plot(t["frequency_hz"], t["rate_hz"], "o-", color=color, label=g)
    freqs = sorted(set(summary["frequency_hz"]))
    for ax in (ax_sed, ax_rate):
        ax.set_xticks(freqs, [f"{f:g}" for f in freqs])
        ax.set_xlabel("frequency (Hz)")
        ax.grid(alpha=0.3)
        ax.set_ylim(bottom=0.0)
    ax_sed.set_ylabel("SED at the site (Pa)")
    ax_sed.set_title("SED at the RA-I site at the deepest points", fontsize="medium")
    ax_rate.set_ylabel("mean rate (spikes/s per afferent)")
    ax_rate.set_title("mean RA-I rate over the cycles", fontsize="medium")
    legend_beside(ax_sed)
    legend_beside(ax_rate)
    fig.suptitle(title or "SED and rate vs frequency")
    return fig


def _last_cycles(frequency_hz, n_cycles) -> str:
    """'cycle 3' when every run of a group has 3 cycles, else each run's own: 'cycle 3 at 20, 30 Hz, 5 at 50 Hz'."""
    by_n: dict[int, list[float]] = {}
    for f, n in zip(frequency_hz, n_cycles):
        by_n.setdefault(int(n), []).append(float(f))
    if len(by_n) == 1:
        return f"cycle {next(iter(by_n))}"
    return "cycle " + ", ".join(f"{n} at {', '.join(f'{f:g}' for f in fs)} Hz" for n, fs in by_n.items())


def plot_hotspot_summary(runs: dict, groups: dict, *, threshold: float) -> Figure:
    """Every run's hot-spot maps on one page: a row per group and site set (``map``), a column per run of the group.

    ``runs``: {label: hotspots.csv table}; ``groups``: {group: [labels]} (:func:`afferent.hotspots.group_runs`).
    """
    import matplotlib.pyplot as plt

    rows = [(g, k, labels) for g, labels in groups.items()
            for k in dict.fromkeys(k for lb in labels for k in runs[lb]["map"])]
    n_col = max(len(labels) for _, _, labels in rows)
    fig, axes = plt.subplots(len(rows), n_col, figsize=(3.3 * n_col, 3.0 * len(rows)), layout="constrained",
                             squeeze=False)
    for r, (g, kind, labels) in enumerate(rows):
        for c in range(n_col):
            ax = axes[r, c]
            t = runs[labels[c]] if c < len(labels) else None
            if t is None or kind not in set(t["map"]):
                ax.set_axis_off()
                continue
            t = t[t["map"] == kind]
            hot = t["normalised"].to_numpy() >= threshold
            ax.scatter(t["x_m"] * 1e3, t["z_m"] * 1e3, s=4, c="0.8", edgecolors="none")
            sc = ax.scatter(t["x_m"][hot] * 1e3, t["z_m"][hot] * 1e3, c=t["normalised"][hot], s=22, cmap="inferno_r",
                            vmin=threshold, vmax=1.0, edgecolors="k", linewidths=0.2)
            ax.set_aspect("equal")
            ax.set_title(f"{labels[c]}\n{kind}: {int(hot.sum())} >= {threshold:g}", fontsize="small")
            ax.tick_params(labelsize="x-small")
        axes[r, 0].set_ylabel(f"{g}: z (mm)", fontsize="small")
    fig.colorbar(sc, ax=axes, label=f"normalised SED (>= {threshold:g})", shrink=0.5)
    fig.supxlabel("x, across the ridges (mm)", fontsize="small")
    return fig


def plot_distance_table(table: DataFrame, *, ax: Axes | None=None, title: str | None = None) -> Axes:
    """A square table of map distances (1 - r, 0..2) as a labelled colour matrix with the values written in."""
    ax = _axes(ax, figsize=(4.6, 4.0))
    d = table.to_numpy(dtype=float)
    im = ax.imshow(d, cmap="magma_r", vmin=0.0, vmax=max(1.0, float(np.nanmax(d))))
    labels = [str(v) for v in table.index]
    ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize="small")
    ax.set_yticks(range(len(labels)), labels, fontsize="small")
    for i in range(d.shape[0]):
        for j in range(d.shape[1]):
            ax.text(j, i, f"{d[i, j]:.2f}", ha="center", va="center", fontsize="x-small",
                    color="w" if d[i, j] > 0.6 * max(1.0, float(np.nanmax(d))) else "k")
    ax.figure.colorbar(im, ax=ax, label="1 - r (map distance)", shrink=0.8)
    ax.set_title(title or "map distance")
    return ax


def plot_sed_profile(sed: ReceptorSED, *, axis: str = "x", time_index: int = -1, ax: Axes | None=None, label: str | None = None, normalise: bool = False) -> Axes:
    """SED along one axis through the receptor grid: the mean over each section line.

    ``axis='x'`` averages each longitudinal section (same x) and plots it against x;
    ``axis='z'`` does the same for cross-sections against z.

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax, figsize=(5.5, 3.6))
    kind = "longitudinal" if axis == "x" else "cross"
    labels = sed.layout.longitudinal if axis == "x" else sed.layout.cross
    v = np.asarray(sed.values[time_index], dtype=float)
    mean = np.bincount(labels, weights=v) / np.bincount(labels)
    x_mm = sed.layout.section_positions(kind) * 1e3
    if normalise:
        span = mean.max() - mean.min()
        mean = (mean - mean.min()) / span if span > 0 else np.zeros_like(mean)
    ax.plot(x_mm, mean, marker="o", ms=3, label=label)
    ax.set_xlabel(f"{axis} (mm)")
    ax.set_ylabel("normalised SED" if normalise else "mean SED over section (Pa)")
    if label:
        legend_beside(ax)  # beside the Axes: several profiles fill it
    return ax


def legend_beside(ax: Axes, *, title: str | None = None) -> Legend | None:
    """The legend of ``ax`` (and of its twin Axes) to the right of it, never over its data.

    When the figure lays itself out (``layout='constrained'``, as every figure made here) and
    holds only ``ax`` and its twins, or ``ax`` has a twin (whose labels take its right side), the
    legend is the figure's, right of everything; else it is the Axes' legend, just right of the
    Axes. ``title`` (a note) heads the box. Called again for the same Axes (a function that adds
    a labelled curve to a given Axes each time), it replaces the box it made before.
    """
    fig = ax.figure
    group = [a for a in fig.axes if a is ax or ax.get_shared_x_axes().joined(a, ax)]
    handles, labels = [], []
    for a in group:
        h, lab = a.get_legend_handles_labels()
        handles, labels = handles + h, labels + lab
        if a.get_legend() is not None:
            a.get_legend().remove()
    for old in [leg for leg in fig.legends if getattr(leg, "_afferent_beside", None) in group]:
        old.remove()
    style = dict(fontsize="small", title=title, title_fontsize="x-small", alignment="left")
    engine = fig.get_layout_engine()
    if (len(group) == len(fig.axes) or len(group) > 1) and engine is not None and type(engine).__name__ == "ConstrainedLayoutEngine":
        leg = fig.legend(handles, labels, loc="outside right center", **style)
        leg._afferent_beside = ax
        return leg
    return ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, **style)


PNG_COMPRESS_LEVEL = 1  #: zlib level of the PNGs :func:`save_figure` writes (0-9)


def save_figure(ax_or_fig: Axes | Figure, path: str, *, overwrite: bool = False, dpi: int = 150) -> str:
    """Save a figure as PNG atomically (temporary name, then renamed) and close it.

    The figure is laid out once, at ``dpi`` (dots per inch), and drawn once: matplotlib's
    ``savefig`` on a laid-out figure draws it twice (once to lay it out, drawing nothing,
    then to render), which costs ~10 % more CPU for the same pixels.

    zlib level ``PNG_COMPRESS_LEVEL`` (1, not Pillow's 6): on the 7 figures of
    benchmarks/bench_run.py, encoding 0.12 s instead of 0.18 s (the run waits for its figures),
    587 kB instead of 527 kB; the same pixels.
    """
    import matplotlib.pyplot as plt

    from ._output import atomic_file

    fig = getattr(ax_or_fig, "figure", ax_or_fig)
    engine = fig.get_layout_engine()
    if engine is not None:
        fig.set_dpi(dpi)  # the layout depends on the text's pixel sizes
        engine.execute(fig)
        fig.set_layout_engine(None)  # keep the positions just computed: savefig draws once
        if fig.get_layout_engine() is not None:  # rcParams ask every figure for a layout: savefig's own way
            fig.set_layout_engine(engine)
    with atomic_file(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    plt.close(fig)
    return path


def _warm_up() -> None:
    """Select the Agg backend, import pyplot and draw a small laid-out figure to memory (fonts, renderer):
    the figure process (``afferent._figure_process``) does so while the run reads, before its figures arrive."""
    import io

    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1.5), layout="constrained")
    ax.plot([0, 1], [0, 1])
    ax.set_title("t")
    fig.savefig(io.BytesIO(), format="png", dpi=50)
    plt.close(fig)


def _central_line(layout, axis: str):
    """:func:`afferent.receptors.central_line` under its former private name (afferent/cli/_demo.py imports it)."""
    from .receptors import central_line

    return central_line(layout, axis)


def _norm(v):
    v = np.asarray(v, dtype=float)
    span = np.nanmax(v) - np.nanmin(v)
    return (v - np.nanmin(v)) / span if span > 0 else np.zeros_like(v)


#: Profiles with this few points are shown raw beside the normalised curve (min-max normalising
#: 2 or 3 values yields a fixed 0-1 or 0-1-0 shape that carries no information).
FEW_POINTS = 3


def plot_section_profiles(sed: ReceptorSED, current: ReceptorCurrent, afferent: AfferentCurrent | None=None, *, axis: str = "x", time_index: int = -1, ax: Axes | None=None, title: str | None=None,
                          scale: str = "normalised") -> Axes:
    """SED, receptor current and afferent current along one axis, on one axes: min-max normalised, or magnitudes.

    The study's figures 5-6 (``axis='x'``, across the ridges, with longitudinal-section
    afferents) and 5-7 (``axis='z'``, along the ridges, with cross-section afferents). The
    receptor curves are the receptors on the grid line through the middle of the layout.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptor sites, J/m^3 (Pa).
    current : ReceptorCurrent
        Receptor currents, A.
    afferent : AfferentCurrent, optional
        Plotted against its positions when its axis is ``axis``; currents in A.
    axis : {'x', 'z'}
    time_index : int, default=-1
    scale : {'normalised', 'magnitude'}, default='normalised'
        ``'normalised'``: every curve min-max normalised to 0..1 (the study's figures: shapes compared).
        ``'magnitude'``: the SED in Pa on the left axis, the receptor and afferent currents in nA on the
        right one, both from zero: how large the SED and the currents are, not only where they peak.

    Returns
    -------
    matplotlib Axes
        The left (SED or normalised) axis; in ``'magnitude'`` its twin holds the currents.

    Raises
    ------
    ValueError
        ``scale`` is not one of the two.
    """
    if scale not in ("normalised", "magnitude"):
        raise ValueError(f"scale must be 'normalised' or 'magnitude'; got {scale!r} instead.")
    ax = _axes(ax, figsize=(8.5, 3.8))
    from .receptors import central_line

    idx, coord, at = central_line(sed.layout, axis)
    other = "z" if axis == "x" else "x"
    norm = scale == "normalised"
    show = _norm if norm else (lambda v: np.asarray(v, dtype=float) * 1e9)  # currents A -> nA
    cur_ax = ax if norm else ax.twinx()
    note = None
    if afferent is not None and getattr(afferent, "axis", axis) == axis:
        # drawn first, wide and pale: the receptor curves on top stay visible where they coincide
        order = np.argsort(afferent.positions)
        raw = np.asarray(afferent.values[time_index, order], dtype=float)
        cur_ax.plot(afferent.positions[order] * 1e3, show(raw), "^-", ms=9, lw=6, alpha=0.35, color="tab:green",
                    label=f"afferent current ({afferent.kind} sections)" + ("" if norm else ", nA"))
        if norm and raw.size <= FEW_POINTS:
            # min-max normalising 2 or 3 values always gives 0-1 or 0-1-0: show the values themselves
            twin = ax.twinx()
            twin.plot(afferent.positions[order] * 1e3, raw * 1e9, "^:", ms=6, color="crimson", label="afferent current (nA)")
            twin.set_ylabel("afferent current, raw (nA)", color="crimson")
            note = (f"only {raw.size} afferents: their min-max\nnormalised profile is 0-1 by construction;\n"
                    "the raw currents are on the right axis")
    sed_line = np.asarray(sed.values[time_index, idx], dtype=float)
    ax.plot(coord * 1e3, _norm(sed_line) if norm else sed_line, "o-", ms=7, mfc="none", color="tab:blue",
            label=f"SED (receptors at {other} = {at * 1e3:.2f} mm)" + ("" if norm else ", Pa"))
    cur_ax.plot(coord * 1e3, show(current.values[time_index, idx]), "s--", ms=3, color="tab:orange",
                label="receptor current" + ("" if norm else ", nA"))
    ax.set_xlabel(f"{axis}, {'across' if axis == 'x' else 'along'} the ridges (mm)")
    if norm:
        ax.set_ylabel("normalised (min-max)")
        ax.set_ylim(-0.05, 1.1)
    else:
        ax.set_ylabel("SED at the receptors (Pa)", color="tab:blue")
        cur_ax.set_ylabel("current (nA)", color="tab:orange")
        ax.set_ylim(bottom=0.0)
        cur_ax.set_ylim(bottom=0.0)
    legend_beside(ax, title=note)
    ax.set_title(title or f"Profiles along {axis}" + ("" if norm else ": magnitudes"))
    return ax


def plot_fit(fit: ProfileFit, *, ax: Axes | None=None, title: str | None=None) -> Axes:
    """Predicted against observed profile (as compared: normalised per ``fit.normalise``).

    When a min-max normalised profile varies by less than ``afferent.profiles.SMALL_VARIATION`` (10 %) before
    normalising, the legend says by how much: its 0..1 (and the R^2) stretch a small contrast.
    """
    ax = _axes(ax, figsize=(7.5, 3.6))
    x = fit.positions * 1e3 if fit.positions is not None else np.arange(len(fit.predicted))
    ax.plot(x, fit.observed, "ko", label="observed")
    ax.plot(x, fit.predicted, "-", lw=2, label="predicted")
    ax.set_xlabel("afferent position (mm)" if fit.positions is not None else "afferent")
    ax.set_ylabel("response (normalised)" if fit.normalise != "neither" else "response")
    ax.set_title(title or f"R² (study) = {fit.r2_study:.3f}, R² = {fit.r2:.3f}, ssd = {fit.ssd:.3g}")
    legend_beside(ax, title=_stretch_note(fit))
    return ax


def _stretch_note(fit) -> str | None:
    """'min-max normalised: predicted varies by 1.4 %, observed by 5 % (stretched to 0..1)' or None."""
    from .profiles import stretched

    small = stretched(fit) if getattr(fit, "variation", None) is not None else {}
    if not small:
        return None
    return ("min-max normalised; before that\n" + ", ".join(f"{k} varies by {100 * v:.2g} %" for k, v in small.items())
            + "\n(stretched to 0..1, R² with it)")


# the spike and stimulus figures live beside this module (size); they are this module's names
from ._plot_spikes import MAX_RASTER_LABELS, _rate_columns, plot_psth, plot_raster, plot_rates, plot_waveform, rate_table  # noqa: E402,F401
