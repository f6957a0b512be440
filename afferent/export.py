"""Writing a run's results: CSV tables (pandas), PNG figures, a VTU of the receptor sites
(ParaView) and ``run.json``; all into a folder that appears whole or not at all.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
from importlib import metadata

import numpy as np

from ._output import atomic_dir

__all__ = ["write_pipeline_outputs", "file_sha256", "versions", "jsonable", "receptors_table", "write_receptor_vtu",
           "step_title", "profile_step_record"]


def file_sha256(path: str, chunk: int = 1 << 20) -> str:
    """SHA-256 of a file's content (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def versions() -> dict:
    """Versions of Python, afferent and its dependencies, for the run record."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for dist in ("afferent-skin", "numpy", "scipy", "pandas", "scikit-learn", "meshio", "matplotlib", "brian2", "pydoe"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = None
    return out


def jsonable(obj):
    """``obj`` made plain for :func:`json.dump`: numpy scalars and arrays to Python numbers and lists,
    tuples to lists, dict keys to str, non-finite floats to None (JSON has no NaN).

    Parameters
    ----------
    obj : object
        Nested dicts / lists / tuples of numbers, strings, numpy values.

    Returns
    -------
    object
        The same structure with only JSON types.
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


_jsonable = jsonable  # the name afferent.cli._calibrate imports


def receptors_table(result):
    """receptor, x_m, y_m, z_m, longitudinal, cross, time_s, sed_pa, current_a."""
    df = result.sed.to_dataframe(sections=True)
    df["current_a"] = result.current.values.reshape(-1)
    return df


def write_receptor_vtu(path: str, sed, *, current=None, time_index: int = -1) -> None:
    """Receptor sites as VTK vertices for ParaView: SED (Pa) [and current (A)] at ``time_index``,
    and the section labels.

    Parameters
    ----------
    path : str
    sed : ReceptorSED
    current : ReceptorCurrent, optional
    time_index : int, default=-1
    """
    import meshio

    layout = sed.layout
    n = layout.n_receptors
    data = {"sed_pa": np.asarray(sed.values)[time_index]}
    if current is not None:
        data["current_a"] = np.asarray(current.values)[time_index]
    data["longitudinal"] = layout.longitudinal.astype(np.int32)
    data["cross"] = layout.cross.astype(np.int32)
    meshio.write(path, meshio.Mesh(layout.positions, [("vertex", np.arange(n).reshape(-1, 1))], point_data=data),
                 file_format="vtu")


def profile_step_record(afferent, index: int) -> dict:
    """What the run record says about the step the static outputs show (figures, VTU, fit)."""
    times = getattr(afferent, "times", None)
    n = int(np.asarray(afferent.values).shape[0])
    return {"index": int(index) % max(n, 1), "time_s": None if times is None else float(times[index]), "n_steps": n,
            "chosen_as": "the step of the largest total afferent current (afferent.profiles.peak_step)"}


def step_title(what: str, times, index: int, n_steps: int) -> str:
    """A figure title that says which step it shows: 'SED ...' over 'step 51 of 2301, t = 0.1 s (peak)'."""
    if n_steps <= 1:
        return what
    t = "" if times is None else f", t = {float(times[index]):.4g} s"
    return f"{what}\nstep {int(index) % n_steps} of {n_steps}{t} (peak)"


def write_pipeline_outputs(result, outdir: str, *, record: dict, overwrite: bool = False, plots: bool = True) -> list[str]:
    """Write every output of a static pipeline run into ``outdir`` (atomically, as a whole).

    Files: ``receptors.csv``, ``afferents.csv``, ``fit.csv`` and ``profile_fit.csv`` (when a
    fit was made), ``waveform.csv`` (with a stimulus waveform), ``spikes.csv`` (afferent,
    spike_time_s) and ``spike_summary.csv`` (with spikes), ``receptors.vtu``, ``run.json``, and
    with ``plots`` the PNG figures ``sed_map.png`` (study fig. 5-5), ``profiles_x.png``
    (fig. 5-6), ``profiles_z.png`` (fig. 5-7), ``fit.png``, ``waveform.png``, ``raster.png``,
    ``rates.png`` and ``psth.png``.

    Returns
    -------
    list of str
        The files written (names inside ``outdir``).
    """
    written = []
    with atomic_dir(outdir, overwrite=overwrite) as tmp:
        def path(name):
            written.append(name)
            return os.path.join(tmp, name)

        receptors_table(result).to_csv(path("receptors.csv"), index=False)
        result.afferent.to_dataframe()[["afferent", "position_m", "time_s", "current_a"]].to_csv(path("afferents.csv"), index=False)
        if result.fit is not None:
            import pandas as pd

            fit = result.fit
            pd.DataFrame([{"synthesis": result.branching.kind, "normalise": fit.normalise, "r2_study": fit.r2_study,
                           "r2": fit.r2, "ssd": fit.ssd, "n_afferents": len(fit.predicted), "dropped": fit.dropped,
                           "time_s": fit.time}]).to_csv(path("fit.csv"), index=False)
            pd.DataFrame({"position_m": fit.positions, "predicted": fit.predicted, "observed": fit.observed}).to_csv(
                path("profile_fit.csv"), index=False)
        k = result.profile_index
        n_t = result.sed.values.shape[0]
        write_receptor_vtu(path("receptors.vtu"), result.sed, current=result.current, time_index=k)
        if result.waveform is not None:
            result.waveform.to_dataframe().to_csv(path("waveform.csv"), index=False)
        if result.spikes is not None:
            result.spikes.to_dataframe().to_csv(path("spikes.csv"), index=False)
            summary = result.spikes.summary().reset_index()
            summary.insert(1, "position_m", result.afferent.positions)
            summary.to_csv(path("spike_summary.csv"), index=False)
        if plots:
            from . import plotting
            from .synthesis import Branching, synthesize

            import matplotlib.pyplot as plt

            fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
            times = result.sed.times
            plotting.plot_sed_map(result.sed, ax=axes[0], time_index=k,
                                  title=step_title("SED at receptor sites", times, k, n_t))
            plotting.plot_sed_map(result.sed, ax=axes[1], normalise=True, threshold=0.6, time_index=k,
                                  title=step_title("normalised SED, hot spots >= 0.6", times, k, n_t))
            plotting.save_figure(fig, path("sed_map.png"))
            layout = result.sed.layout
            for axis, kind, name in (("x", "longitudinal", "profiles_x.png"), ("z", "cross", "profiles_z.png")):
                aff = result.afferent if result.branching.kind == kind else synthesize(
                    result.current, Branching.longitudinal(layout) if kind == "longitudinal" else Branching.cross(layout))
                ax = plotting.plot_section_profiles(result.sed, result.current, aff, axis=axis, time_index=k,
                                                    title=step_title(f"Profiles along {axis}", times, k, n_t))
                plotting.save_figure(ax, path(name))
            if result.fit is not None:
                plotting.save_figure(plotting.plot_fit(result.fit), path("fit.png"))
            if result.waveform is not None:
                plotting.save_figure(plotting.plot_waveform(result.waveform), path("waveform.png"))
            if result.spikes is not None:
                plotting.save_figure(plotting.plot_raster(result.spikes), path("raster.png"))
                plotting.save_figure(plotting.plot_rates(result.spikes, positions=result.afferent, waveform=result.waveform),
                                     path("rates.png"))
                bin_width = max(result.spikes.duration / 50, result.spikes.dt)
                plotting.save_figure(plotting.plot_psth(result.spikes, bin_width), path("psth.png"))
        full = dict(record)
        full.setdefault("versions", versions())
        full["saturation"] = {
            "fraction_sensitive": result.saturation.fraction_sensitive,
            "fraction_high": result.saturation.fraction_high,
            "fraction_low": result.saturation.fraction_low,
            "modulation": result.saturation.modulation,
            "gamma_sed_range": result.saturation.gamma_sed_range,
            "message": result.saturation.message,
        }
        if result.fit is not None:
            full["fit"] = {"r2_study": result.fit.r2_study, "r2": result.fit.r2, "ssd": result.fit.ssd,
                           "normalise": result.fit.normalise, "dropped": result.fit.dropped}
        if result.spikes is not None:
            sp = result.spikes
            full["spikes"] = {
                "engine": sp.engine, "backend": getattr(sp, "backend", None), "dt_s": sp.dt, "duration_s": sp.duration,
                "input": getattr(result.input, "kind", None), "input_level": getattr(result.input, "level", None),
                "n_spikes": int(sum(len(t) for t in sp.spike_times)),
                "silent_skipped": [str(sp.afferent_ids[i]) for i in sp.silent_skipped],
                "notes": list(getattr(sp, "notes", ())),
                "lif": {k: getattr(sp.params, k) for k in ("tau_m", "r_m", "v_rest", "v_thresh", "v_reset", "t_ref")},
                "drive": result.drive,
            }
        full["profile_step"] = profile_step_record(result.afferent, k)
        full["stage_seconds"] = result.timings
        full["outputs"] = sorted(written + ["run.json"])
        with open(path("run.json"), "w") as f:
            json.dump(jsonable(full), f, indent=2)
    return written
