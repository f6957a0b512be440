"""Figures a reader of the study would recognise; the only module that imports matplotlib.

Every function takes ``ax=None`` (a new figure when None) and returns the Axes. Lengths are
shown in mm and SED in Pa (= J/m^3) on the axes; the data stay SI.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_sed_map", "plot_sed_profile", "save_figure"]


def _axes(ax, figsize=(5.0, 4.2)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def plot_sed_map(sed, *, time_index: int = -1, ax=None, normalise: bool = False, threshold: float | None = None,
                 title: str | None = None):
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
    label = "SED (Pa = J/m$^3$)"
    if normalise:
        span = np.nanmax(v) - np.nanmin(v)
        v = (v - np.nanmin(v)) / span if span > 0 else np.zeros_like(v)
        label = "normalised SED"
    sc = ax.scatter(pos_mm[:, 0], pos_mm[:, 2], c=v, s=28, cmap="viridis", edgecolors="none")
    if normalise and threshold is not None:
        hot = v >= threshold
        ax.scatter(pos_mm[hot, 0], pos_mm[hot, 2], s=60, facecolors="none", edgecolors="crimson", linewidths=1.0,
                   label=f">= {threshold:g}")
        ax.legend(loc="upper right", fontsize="small")
    ax.figure.colorbar(sc, ax=ax, label=label)
    ax.set_xlabel("x, across ridges (mm)")
    ax.set_ylabel("z, along ridges (mm)")
    ax.set_aspect("equal")
    t = sed.times[time_index]
    ax.set_title(title or f"SED at receptor sites, t = {t:g} s")
    return ax


def plot_sed_profile(sed, *, axis: str = "x", time_index: int = -1, ax=None, label: str | None = None, normalise: bool = False):
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
        ax.legend(fontsize="small")
    return ax


def save_figure(ax_or_fig, path: str, *, overwrite: bool = False, dpi: int = 150) -> str:
    """Save a figure as PNG atomically (temporary name, then renamed) and close it."""
    import matplotlib.pyplot as plt

    from ._output import atomic_file

    fig = getattr(ax_or_fig, "figure", ax_or_fig)
    with atomic_file(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return path
