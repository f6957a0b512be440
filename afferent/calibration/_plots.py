"""Figures of a calibration: the final profile fit and the ssd per iteration.

matplotlib is imported inside the functions only. Each takes ``ax=None`` (a new figure) and
returns the Axes; positions are shown in mm, the data stay SI. Legends sit beside the Axes
(:func:`afferent.plotting.legend_beside`), never over the points.
"""

from __future__ import annotations

from .result import CalibrationResult

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from matplotlib.axes import Axes

import numpy as np

__all__ = ["plot_calibrated_profile", "plot_calibrated_profiles", "plot_ssd_history"]


def _axes(ax, figsize):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def plot_calibrated_profile(result: CalibrationResult, *, ax: Axes | None=None, title: str | None=None) -> Axes:
    """Predicted (calibrated) against observed profile, as compared.

    Parameters
    ----------
    result : CalibrationResult
        Its ``fit`` holds the profiles (normalised as ``result.normalise`` says) and the
        afferent positions in m (plotted in mm).
    ax : matplotlib Axes, optional
    title : str, optional
        Default: method, synthesis, ssd and R^2 (study).

    Returns
    -------
    matplotlib Axes
    """
    from ..plotting import legend_beside

    ax = _axes(ax, (5.5, 3.8))
    fit = result.fit
    x = _positions_mm(fit)
    ax.plot(x, fit.observed, "ko", label="observed")
    ax.plot(x, fit.predicted, "-", lw=2, label="calibrated")
    _profile_axes(ax, result)
    p = result.params
    ax.set_title(title or (
        f"{result.method}, {result.synthesis}: ssd {result.ssd:.3g}, R² (study) {result.r2_study:.3f}\n"
        f"alpha {p.alpha:.3g} A, gamma {p.gamma:.3g} 1/Pa, lambda {p.lambda_:.4g} Pa"
    ), fontsize="small")
    legend_beside(ax)  # beside the Axes, never over a point
    return ax


def _positions_mm(fit):
    """A fit's profile positions in mm, or the afferents' indices where it has none."""
    return fit.positions * 1e3 if fit.positions is not None else np.arange(len(fit.predicted))


#: plot_calibrated_profiles: the other methods' lines, in turn (thinner than the best's, dashed: none hides another)
_OTHER_STYLES = (dict(ls="--", marker="s", ms=4, mfc="none"), dict(ls=":", marker="D", ms=4, mfc="none"),
                 dict(ls="-.", marker="v", ms=4, mfc="none"))


def plot_calibrated_profiles(results: dict, *, ax: Axes | None=None, title: str | None=None) -> Axes:
    """Every method's calibrated profile against the observed one, the best by the ssd drawn first and named.

    Parameters
    ----------
    results : dict of str -> CalibrationResult
        Results of several methods on the same data (``afferent calibrate --method all``, or a method and
        its least-squares reference); each ``fit`` holds the profiles as compared (normalised as
        ``normalise`` says) and the afferent positions in m (plotted in mm).
    ax : matplotlib Axes, optional
    title : str, optional
        Default: the best method (:func:`afferent.calibration.best_method`: lowest ssd), its synthesis,
        ssd, R^2 (study) and parameters.

    Returns
    -------
    matplotlib Axes
        The observed points, the best method's line (wide, solid, labelled ``'<method>: ssd <ssd> (best)'``),
        then each other method's (thin, dashed, ``'<method>: ssd <ssd>'``).
    """
    from ..plotting import legend_beside
    from .compare import best_method

    ax = _axes(ax, (6.2, 3.8))
    best = best_method(results)
    order = [best] + [m for m in results if m != best]
    r = results[best]
    x = _positions_mm(r.fit)
    ax.plot(x, r.fit.observed, "ko", label="observed")
    for i, m in enumerate(order):
        fit = results[m].fit
        xm = _positions_mm(fit)
        style = dict(ls="-", lw=2.5, color="tab:blue") if i == 0 else dict(lw=1.2, color=f"C{i}", **_OTHER_STYLES[(i - 1) % 3])
        ax.plot(xm, fit.predicted, label=f"{m}: ssd {results[m].ssd:.3g}" + (" (best)" if i == 0 else ""), **style)
    _profile_axes(ax, r)
    p = r.params
    ax.set_title(title or (
        f"best by ssd: {best}, {r.synthesis}: ssd {r.ssd:.3g}, R² (study) {r.r2_study:.3f}\n"
        f"alpha {p.alpha:.3g} A, gamma {p.gamma:.3g} 1/Pa, lambda {p.lambda_:.4g} Pa"
    ), fontsize="small")
    legend_beside(ax)  # beside the Axes, never over a point
    return ax


def _profile_axes(ax, result) -> None:
    """The x and y labels of a calibrated profile: afferent position along the synthesis' axis (mm), response."""
    axis = "x" if result.synthesis in ("longitudinal", "map", "random") else "z"
    ax.set_xlabel(f"afferent position {axis} (mm)" if result.fit.positions is not None else "afferent")
    norm = result.normalise in ("both", "prediction")
    ax.set_ylabel("response (normalised)" if norm else "response")


def plot_ssd_history(result: CalibrationResult, *, ax: Axes | None=None, title: str | None=None) -> Axes:
    """ssd of every evaluated point (grey) and of each iteration's best point (line), by evaluation.

    Parameters
    ----------
    result : CalibrationResult
        Uses ``design_runs`` (``evaluation``, ``ssd``) and ``iterations`` (``evaluations``, ``ssd``).
    ax : matplotlib Axes, optional
    title : str, optional

    Returns
    -------
    matplotlib Axes
        Logarithmic y axis when every ssd is > 0.
    """
    from ..plotting import legend_beside

    ax = _axes(ax, (5.5, 3.8))
    runs = result.design_runs
    it = result.iterations
    if len(runs):
        usable = ~runs["degenerate"].to_numpy(bool)
        ax.plot(runs["evaluation"][usable], runs["ssd"][usable], ".", color="0.7", ms=4, label="evaluated points")
        if (~usable).any():
            ax.plot(runs["evaluation"][~usable], runs["ssd"][~usable], "x", color="tab:red", ms=4,
                    label="degenerate (flat prediction)")
    ax.plot(it["evaluations"], it["ssd"], "o-", color="tab:blue", drawstyle="steps-post", label="best after each iteration")
    ssd_all = np.concatenate([runs["ssd"].to_numpy(float) if len(runs) else np.array([]), it["ssd"].to_numpy(float)])
    if ssd_all.size and np.all(ssd_all > 0):
        ax.set_yscale("log")
    ax.set_xlabel("model evaluations")
    ax.set_ylabel("ssd")
    ax.set_title(title or f"{result.method}: {result.n_iterations} iteration(s), {result.n_evaluations} evaluations",
                 fontsize="small")
    legend_beside(ax)  # beside the Axes, never over a point
    return ax
