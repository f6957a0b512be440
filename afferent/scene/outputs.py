"""The one writer of ``afferent run``: the outputs a scene asks for, and nothing else.

A variant of :func:`afferent.export.write_pipeline_outputs` that accepts partial results
(SED only, no spikes, ...) and writes into a folder the caller made (the scene's
:func:`~afferent._output.atomic_dir`). Tables and the receptor VTU reuse
:mod:`afferent.export`; matplotlib is imported only when plots are wanted.

Files per output (``plots`` adds the PNGs):

=========== ================================================ ===========================================
output      tables                                           figures
=========== ================================================ ===========================================
sed_map     ``sed_map.csv`` (receptor, x_m, y_m, z_m,        ``sed_map.png`` (study fig. 5-5)
            longitudinal, cross, time_s, sed_pa)
currents    ``receptors.csv`` (+ current_a), ``afferents.csv``
profiles    ``profiles.csv`` (afferent, position_m, time_s,   ``profiles_x.png``, ``profiles_z.png``
            current_a at the profile step)                   (figs. 5-6, 5-7)
fit         ``fit.csv``, ``profile_fit.csv``                 ``fit.png``
spikes      ``spikes.csv``, ``spike_summary.csv``            ``raster.png``, ``rates.png``, ``psth.png``
vtu         ``receptors.vtu`` (sed_pa [, current_a], sections)
=========== ================================================ ===========================================

With a stimulus waveform, ``waveform.csv`` (and ``waveform.png``) too.
"""

from __future__ import annotations

import json
import os
from types import SimpleNamespace

import numpy as np

from ..export import jsonable, receptors_table, step_title, write_receptor_vtu

__all__ = ["write_outputs", "write_json", "write_receptor_vtu"]


def write_json(path: str, data: dict) -> None:
    """JSON with numpy scalars/arrays and non-finite floats made plain (NaN -> null)."""
    with open(path, "w") as f:
        json.dump(jsonable(data), f, indent=2)


def write_outputs(folder: str, *, want, plots: bool, sed_static, sed, current=None, branching=None, afferent=None,
                  fit=None, waveform=None, spikes=None, drive=None, saturation=None,
                  profile_index: int = -1) -> list[str]:
    """Write the tables and figures of ``want`` into ``folder``; returns the file names written.

    Parameters
    ----------
    folder : str
        An existing (temporary) folder.
    want : set of str
        Requested outputs (:data:`afferent.scene.OUTPUTS`).
    plots : bool
        Also draw the figures of those outputs.
    sed_static : ReceptorSED
        SED sampled from the export (J/m^3).
    sed : ReceptorSED
        SED over the stimulus' times (``sed_static`` without a waveform).
    current, branching, afferent, fit, waveform, spikes, drive, saturation : optional
        Later stages' results, None when not computed (``drive`` and ``saturation`` are in
        run.json, not written here).
    profile_index : int
        Time step of the profiles, the fit and the VTU's currents (the step of the largest
        total afferent current).
    """
    written: list[str] = []

    def path(name: str) -> str:
        written.append(name)
        return os.path.join(folder, name)

    if "sed_map" in want:
        sed_static.to_dataframe(sections=True).to_csv(path("sed_map.csv"), index=False)
    if "currents" in want:
        receptors_table(SimpleNamespace(sed=sed, current=current)).to_csv(path("receptors.csv"), index=False)
        afferent.to_dataframe()[["afferent", "position_m", "time_s", "current_a"]].to_csv(path("afferents.csv"), index=False)
    if "profiles" in want:
        import pandas as pd

        t = afferent.times[profile_index] if afferent.times is not None else np.nan
        pd.DataFrame({"afferent": afferent.afferent_ids, "position_m": afferent.positions, "time_s": t,
                      "current_a": np.asarray(afferent.values)[profile_index]}).to_csv(path("profiles.csv"), index=False)
    if "fit" in want and fit is not None:
        import pandas as pd

        pd.DataFrame([{"synthesis": branching.kind, "normalise": fit.normalise, "r2_study": fit.r2_study, "r2": fit.r2,
                       "ssd": fit.ssd, "n_afferents": len(fit.predicted), "dropped": fit.dropped, "time_s": fit.time}]
                     ).to_csv(path("fit.csv"), index=False)
        pd.DataFrame({"position_m": fit.positions, "predicted": fit.predicted, "observed": fit.observed}).to_csv(
            path("profile_fit.csv"), index=False)
    if "spikes" in want and spikes is not None:
        spikes.to_dataframe().to_csv(path("spikes.csv"), index=False)
        summary = spikes.summary().reset_index()
        summary.insert(1, "position_m", afferent.positions)
        summary.to_csv(path("spike_summary.csv"), index=False)
    if "vtu" in want:
        if current is not None:
            write_receptor_vtu(path("receptors.vtu"), sed, current=current, time_index=profile_index)
        else:  # SED only: its own step of the largest total SED
            write_receptor_vtu(path("receptors.vtu"), sed_static,
                               time_index=int(np.argmax(np.nansum(np.asarray(sed_static.values), axis=1))))
    if waveform is not None:
        waveform.to_dataframe().to_csv(path("waveform.csv"), index=False)
    if plots:
        _figures(path, want, sed_static=sed_static, sed=sed, current=current, branching=branching, afferent=afferent,
                 fit=fit, waveform=waveform, spikes=spikes, profile_index=profile_index)
    return written


def _figures(path, want, *, sed_static, sed, current, branching, afferent, fit, waveform, spikes, profile_index):
    from .. import plotting

    if "sed_map" in want:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
        # the export's own steps: the same step as the profiles when no stimulus rescaled them, else
        # the export step of the largest total SED (the static solution a waveform scales)
        same = sed_static is sed
        k = profile_index if same else int(np.argmax(np.nansum(np.asarray(sed_static.values), axis=1)))
        n_t, times = sed_static.values.shape[0], sed_static.times
        plotting.plot_sed_map(sed_static, ax=axes[0], time_index=k, title=step_title("SED at receptor sites", times, k, n_t))
        plotting.plot_sed_map(sed_static, ax=axes[1], normalise=True, threshold=0.6, time_index=k,
                              title=step_title("normalised SED, hot spots >= 0.6", times, k, n_t))
        plotting.save_figure(fig, path("sed_map.png"))
    if "profiles" in want:
        from ..synthesis import Branching, synthesize

        layout = sed.layout
        for axis, kind, name in (("x", "longitudinal", "profiles_x.png"), ("z", "cross", "profiles_z.png")):
            aff = afferent if branching.kind == kind else synthesize(
                current, Branching.longitudinal(layout) if kind == "longitudinal" else Branching.cross(layout))
            ax = plotting.plot_section_profiles(sed, current, aff, axis=axis, time_index=profile_index,
                                                title=step_title(f"Profiles along {axis}", sed.times, profile_index,
                                                                 sed.values.shape[0]))
            plotting.save_figure(ax, path(name))
    if "fit" in want and fit is not None:
        plotting.save_figure(plotting.plot_fit(fit), path("fit.png"))
    if waveform is not None:
        plotting.save_figure(plotting.plot_waveform(waveform), path("waveform.png"))
    if "spikes" in want and spikes is not None:
        plotting.save_figure(plotting.plot_raster(spikes), path("raster.png"))
        plotting.save_figure(plotting.plot_rates(spikes, positions=afferent, waveform=waveform), path("rates.png"))
        bin_width = max(spikes.duration / 50, spikes.dt)
        plotting.save_figure(plotting.plot_psth(spikes, bin_width), path("psth.png"))
