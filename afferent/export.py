"""The one writer of results: a NetCDF-4 array file of the time courses, CSV tables, PNG
figures, a VTU of the receptor sites (ParaView), ``run.json``, and optionally an NWB file of the
spike trains; all into a folder that appears whole or not at all. :func:`load_results` reads a
folder back.

:func:`write_outputs` writes the tables and figures a run asks for: every command (``afferent
run``, ``sample``, ``sweep``, ``demo``) through :func:`afferent.scene.run_scene`, which also writes
``run.json``; a result computed in Python (:func:`afferent.pipeline.run_pipeline`) is written by
running its scene instead.
matplotlib is imported only when figures are wanted.

Files per output (``plots`` adds the PNGs):

======== ================================================== ===========================================
output   tables                                             figures
======== ================================================== ===========================================
sed_map  ``sed_map.csv`` (receptor, x_m, y_m, z_m,          ``sed_map.png`` (study fig. 5-5)
         longitudinal, cross, time_s, sed_pa)
currents ``currents.nc`` (NetCDF-4: sed_pa, current_a
         over (time, receptor); afferent_current_a over
         (time, afferent)) and ``currents.xdmf`` (its
         ParaView index); with ``results_format='csv'``
         ``receptors.csv`` and ``afferents.csv`` (long)
profiles ``profiles.csv`` (afferent, position_m, time_s,    ``profiles_x.png``, ``profiles_z.png``
         current_a at the profile step)                     (figs. 5-6, 5-7)
fit      ``fit.csv``, ``profile_fit.csv``                   ``fit.png``
spikes   ``spikes.csv``, ``spike_summary.csv``              ``raster.png``, ``rates.png``, ``psth.png``
vtu      ``receptors.vtu`` (sed_pa [, current_a], sections)
hotspots ``hotspots.csv`` (site_kind, site, x_m, z_m,       ``hotspots.png`` (study fig. 4-9; a second
         time_s, sed_pa, normalised, hot),                  site set beside: :mod:`afferent.hotspots`)
         ``hotspots.vtu`` (the maps at the sites)
cycles   ``cycles.csv`` (per cycle: deepest point, SED
         at the chosen site, spikes, rate;
         :mod:`afferent.cycles`)
======== ================================================== ===========================================

An export that states no step times and drives the run with its own steps numbers them 0, 1, ...: the
column ``time_s`` is then ``step`` (and ``currents.nc``'s ``time`` is in units ``1``): a column named
``time_s`` never holds step numbers.

With a stimulus waveform, ``waveform.csv`` (and ``waveform.png``) too; with spikes and pynwb
installed (the ``nwb`` extra) and the output ``nwb``, ``spikes.nwb`` (:func:`write_spikes_nwb`,
``afferent._nwb``). With ``currents`` as NetCDF, ``currents.xdmf`` beside ``currents.nc``: an index
ParaView opens as a time series of the receptor sites (``afferent._netcdf``); with ``hotspots``,
``hotspots.vtu`` (the maps at the sites).

Why NetCDF-4 for the time courses: measured on 595 receptors x 2301 steps
(sample_sed/block8, a 2.3 s ramp), the long ``receptors.csv`` took 44 s to write and 141 MB;
NetCDF-4 through xarray + h5netcdf 0.46 s and 2.0 MB (zlib level 1) or 1.0 s and 22 MB (none);
Zarr 1.3 s, 1.5 MB in 46 files. Written directly with h5netcdf, uncompressed: 0.085 s, 22 MB.
One NetCDF-4 file is read by xarray, MATLAB ``ncread``, R (ncdf4, RNetCDF) and any HDF5 tool
(VTK's ``vtkNetCDFReader``, ParaView's, lists its arrays); Zarr needs a Zarr library, which
MATLAB and R do not ship.
"""

from __future__ import annotations

from .profiles import ProfileFit
from .sampling import ReceptorSED
from .stimulus._waveforms import Waveform
from .synthesis import AfferentCurrent, Branching
from .transduction import ReceptorCurrent, SaturationReport

from ._typing import ArrayLike, PathLike
from collections.abc import Collection
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame
    import xarray as xr

import hashlib
import json
import os
import platform
from importlib import metadata
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Literal, get_args

if TYPE_CHECKING:  # afferent.spiking loads on first use (a SED-only run never imports it)
    from .spiking._trains import SpikeTrains

import numpy as np

from ._nwb import write_spikes_nwb
from ._tables import write_table

__all__ = ["write_outputs", "write_json", "file_sha256", "versions", "jsonable",
           "receptors_table", "write_receptor_vtu", "step_title", "profile_step_record", "results_dataset",
           "load_results", "RunResults", "RESULTS_FORMATS", "write_spikes_nwb"]

#: how the time courses are written: one NetCDF-4 array file, or long CSV tables
ResultsFormat = Literal["netcdf", "csv"]
RESULTS_FORMATS: tuple[str, ...] = get_args(ResultsFormat)


def file_sha256(path: str, chunk: int = 1 << 20) -> str:
    """SHA-256 of a file's content (hex); anything but a regular file (a FIFO, a device, a folder) is refused
    (:class:`~afferent.exceptions.SEDFormatError`) without reading or waiting on it."""
    from .io._files import open_regular

    h = hashlib.sha256()
    with open_regular(path) as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def versions() -> dict:
    """Versions of Python, afferent and its dependencies, for the run record."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for dist in ("afferent-skin", "numpy", "scipy", "pandas", "scikit-learn", "meshio", "matplotlib", "brian2", "pydoe",
                 "xarray", "h5netcdf", "h5py"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = None
    return out


def jsonable(obj: object) -> object:
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


class _SedAndCurrent(Protocol):  # a PipelineResult or SceneResult (this stage does not import the pipeline)
    sed: ReceptorSED
    current: ReceptorCurrent


def receptors_table(result: _SedAndCurrent) -> DataFrame:
    """receptor, x_m, y_m, z_m, longitudinal, cross, time_s, sed_pa, current_a."""
    df = result.sed.to_dataframe(sections=True)
    df["current_a"] = result.current.values.reshape(-1)
    return df


def write_receptor_vtu(path: str, sed: ReceptorSED, *, current: ReceptorCurrent | None=None, time_index: int = -1) -> None:
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


def profile_step_record(afferent: AfferentCurrent, index: int) -> dict:
    """What the run record says about the step the static outputs show (figures, VTU, fit)."""
    times = getattr(afferent, "times", None)
    n = int(np.asarray(afferent.values).shape[0])
    return {"index": int(index) % max(n, 1), "time_s": None if times is None else float(times[index]), "n_steps": n,
            "chosen_as": "the step of the largest total afferent current (afferent.profiles.peak_step)"}


def step_title(what: str, times: ArrayLike | None, index: int, n_steps: int, *, clock: str = "t", also: str = "") -> str:
    """A figure title that says which step it shows: 'SED ...' over 'step 51 of 2301, t = 0.1 s (peak)'.

    Steps are counted from 1 (the last of 5 is 'step 5 of 5'); ``index`` is 0-based (negative counts from the end).
    ``clock`` names the time (e.g. 'FE time' for an export's own steps beside a stimulus' t); ``also`` is appended.
    """
    if n_steps <= 1:
        return what
    t = "" if times is None else f", {clock} = {float(times[index]):.4g} s"
    return f"{what}\nstep {int(index) % n_steps + 1} of {n_steps}{t} (peak){also}"


def write_json(path: str, data: dict) -> None:
    """JSON with numpy scalars/arrays and non-finite floats made plain (NaN -> null)."""
    with open(path, "w") as f:
        json.dump(jsonable(data), f, indent=2)


def write_outputs(folder: str, *, want: Collection[str], plots: bool, sed_static: ReceptorSED, sed: ReceptorSED, current: ReceptorCurrent | None=None, branching: Branching | None=None, afferent: AfferentCurrent | None=None,
                  fit: ProfileFit | None=None, waveform: Waveform | None=None, spikes: SpikeTrains | None=None, drive: dict | None=None, saturation: SaturationReport | None=None,
                  profile_index: int = -1, results_format: ResultsFormat = "netcdf", sed_beside: ReceptorSED | None=None,
                  hotspot_threshold: float = 0.6, cycles: DataFrame | None=None, figures: Any=None, nwb: dict | None=None) -> list[str]:
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
    results_format : {'netcdf', 'csv'}, default='netcdf'
        The time courses of ``currents``: ``currents.nc`` (:func:`results_dataset`) or the long
        tables ``receptors.csv`` and ``afferents.csv``.
    sed_beside : ReceptorSED, optional
        ``hotspots``: SED at a second site set (J/m^3), mapped beside ``sed_static``'s sites.
    hotspot_threshold : float, default=0.6
        ``hotspots``: normalised SED from which a site is a hot spot.
    cycles : DataFrame, optional
        ``cycles``: the table of :func:`afferent.cycles.receptor_cycles` (written as ``cycles.csv``).
    figures : FigureProcess or SameProcess, optional
        Who draws the figures (``afferent._figure_process``): a second process, handed them before
        the tables are written and waited for after; default: this process, after the tables.
    nwb : dict, optional
        ``nwb``: what ``spikes.nwb`` says beside the spikes (:func:`write_spikes_nwb`'s ``context``:
        the afferent class, the spikes' record, the scene's ``[nwb]`` table).
    """
    written: list[str] = []

    def path(name: str) -> str:
        written.append(name)
        return os.path.join(folder, name)

    if plots:  # the figures' objects, to a second process now (drawn while the tables are written) or kept
        from ._figure_process import SameProcess

        figures = SameProcess("write_outputs called without a figure process") if figures is None else figures
        figures.draw(folder, want, dict(sed_static=sed_static, sed=sed, current=current, branching=branching,
                                        afferent=afferent, fit=fit, waveform=waveform, spikes=spikes,
                                        profile_index=profile_index))

    time_s = "step" if getattr(sed, "numbered", False) else "time_s"  # never step numbers under time_s
    if "sed_map" in want:
        write_table(path("sed_map.csv"), sed_static.columns(sections=True))
    if "currents" in want:
        _write_currents(path, sed, current, afferent, results_format)
    if "profiles" in want:
        t = afferent.times[profile_index] if afferent.times is not None else np.nan
        write_table(path("profiles.csv"), {"afferent": afferent.afferent_ids, "position_m": afferent.positions,
                                           time_s: np.full(len(afferent.positions), t, dtype=float),
                                           "current_a": np.asarray(afferent.values)[profile_index]})
    if "fit" in want and fit is not None:
        row = {"synthesis": branching.kind, "normalise": fit.normalise, "r2_study": fit.r2_study, "r2": fit.r2,
               "ssd": fit.ssd, "n_afferents": len(fit.predicted), "dropped": fit.dropped,
               time_s: np.nan if fit.time is None else fit.time}
        write_table(path("fit.csv"), {k: [v] for k, v in row.items()})  # None (unknown) as an empty cell, as pandas
        positions = np.full(len(fit.predicted), np.nan) if fit.positions is None else fit.positions
        write_table(path("profile_fit.csv"), {"position_m": positions, "predicted": fit.predicted,
                                              "observed": fit.observed})
    if "spikes" in want and spikes is not None:
        write_table(path("spikes.csv"), spikes.table())
        summary = spikes.summary_table()
        write_table(path("spike_summary.csv"), {"afferent": summary.pop("afferent"), "position_m": afferent.positions,
                                                **summary})
    if "nwb" in want and spikes is not None:
        write_spikes_nwb(path("spikes.nwb"), spikes, afferent, waveform=waveform, context=nwb)
    if "vtu" in want:
        if current is not None:
            write_receptor_vtu(path("receptors.vtu"), sed, current=current, time_index=profile_index)
        else:  # SED only: its own step of the largest total SED
            write_receptor_vtu(path("receptors.vtu"), sed_static,
                               time_index=int(np.argmax(np.nansum(np.asarray(sed_static.values), axis=1))))
    if "hotspots" in want:  # hotspots.png drawn here, not by _figures: while a figure process draws the other
        # figures this process would only wait for it; moved there, the run took up to 0.2 s longer (benchmarks/
        # bench_run.py's export with 'hotspots': its 8 figures outlasted the tables by ~0.9 s)
        from .hotspots import write_hotspots

        write_hotspots(path, sed_static, sed_beside, threshold=hotspot_threshold, plots=plots)
    if "cycles" in want and cycles is not None:
        cycles.to_csv(path("cycles.csv"), index=False)
    if waveform is not None:
        write_table(path("waveform.csv"), waveform.table())
    if plots:
        written += figures.result()
    return written


def _write_currents(path, sed, current, afferent, results_format: str) -> None:
    """The time courses of receptors and afferents: ``currents.nc``, or ``receptors.csv`` + ``afferents.csv``."""
    if results_format not in RESULTS_FORMATS:
        raise ValueError(f"results_format must be one of {', '.join(map(repr, RESULTS_FORMATS))}; "
                         f"got {results_format!r}.")
    if results_format == "csv":
        receptors_table(SimpleNamespace(sed=sed, current=current)).to_csv(path("receptors.csv"), index=False)
        table = afferent.to_dataframe()[["afferent", "position_m", "time_s", "current_a"]]
        if getattr(sed, "numbered", False):  # step numbers of an export without times: not seconds
            table = table.rename(columns={"time_s": "step"})
        table.to_csv(path("afferents.csv"), index=False)
        return
    from ._netcdf import RESULTS_NC, RESULTS_XDMF, results_variables, write_netcdf, write_xdmf_index

    variables, attrs = results_variables(sed, current, afferent)
    write_netcdf(path(RESULTS_NC), variables, attrs)
    write_xdmf_index(path(RESULTS_XDMF), variables, RESULTS_NC)


def results_dataset(sed: ReceptorSED, current: ReceptorCurrent | None=None, afferent: AfferentCurrent | None=None) -> xr.Dataset:
    """The time courses of a run as an :class:`xarray.Dataset` (what ``currents.nc`` holds).

    Dimensions ``time``, ``receptor`` and ``afferent``; CF attributes ``units`` and
    ``long_name`` on every variable.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors over the run's times (J/m^3 = Pa).
    current : ReceptorCurrent, optional
        Receptor currents (A) at the same times.
    afferent : AfferentCurrent, optional
        Afferent currents (A) at the same times.

    Returns
    -------
    xarray.Dataset
        Variables ``sed_pa`` (time, receptor) in J m-3, ``current_a`` (time, receptor) in A,
        ``afferent_current_a`` (time, afferent) in A; coordinates ``time`` (s; ``standard_name``
        time, ``axis`` T), ``receptor`` and ``afferent`` (integers: the id where every id is an
        integer, else the 0-based position; ``ds.sel(receptor=1)``), ``receptor_id`` and
        ``afferent_id`` (the ids as the tables write them), ``x_m``, ``y_m``, ``z_m`` (m),
        ``longitudinal``, ``cross`` (section ids) and ``position_m`` (m, along the afferents' axis).
    """
    from ._netcdf import dataset_from_variables, results_variables

    return dataset_from_variables(*results_variables(sed, current, afferent))


@dataclass(frozen=True)
class RunResults:
    """A run's output folder read back by :func:`load_results`.

    Attributes
    ----------
    dataset : xarray.Dataset
        The time courses (:func:`results_dataset`); only netCDF attributes, so
        ``dataset.to_netcdf(path)`` writes it as it is.
    tables : dict
        Each CSV table's name (``'spikes'`` for ``spikes.csv``) -> :class:`pandas.DataFrame`.
    run : dict
        ``run.json``, the run record.
    folder : str
        The folder read.
    """

    dataset: object
    tables: dict
    run: dict
    folder: str

    def __repr__(self) -> str:
        sizes = ", ".join(f"{k}: {v}" for k, v in self.dataset.sizes.items()) or "no time courses"
        return f"<RunResults {self.folder!r}: {sizes}; tables {', '.join(self.tables) or 'none'}>"


def load_results(folder: PathLike) -> RunResults:
    """A run's output folder read back: the time courses as an :class:`xarray.Dataset`, the tables as pandas.

    Parameters
    ----------
    folder : str or path-like
        An output folder of ``afferent run`` (or of :func:`afferent.scene.run_scene`).

    Returns
    -------
    RunResults
        ``.dataset``: ``currents.nc`` (:func:`results_dataset`) when present, else the same built
        from the long ``receptors.csv`` / ``afferents.csv`` of ``results_format='csv'`` (an empty
        Dataset when the run wrote neither); ``.tables``: each CSV table's name (e.g.
        ``'spikes'``) -> :class:`pandas.DataFrame`; ``.run``: ``run.json``. The dataset holds
        only netCDF attributes: ``load_results(folder).dataset.to_netcdf(path)`` writes it.

    Raises
    ------
    FileNotFoundError
        ``folder`` is not a folder, or holds no ``run.json``.
    SEDFormatError
        A damaged file (``afferent._run_folder``): ``run.json`` not a UTF-8 JSON object, a table not UTF-8
        CSV or without its columns or numbers, ``currents.nc`` not a readable netCDF-4 file (or a folder).
        Or one of its files is not a regular file (a FIFO, a device: refused before it is opened), or
        ``currents.nc`` holds an HDF5 external link or a variable stored in other files (afferent writes
        it self-contained; nothing outside the folder is read).
        Or ``currents.nc`` is damaged or not the run's: a dimension other than ``run.json``
        records (receptors, afferents, steps), a variable larger than its dimensions, values
        its file does not store; checked before anything is read.

    """
    from ._netcdf import RESULTS_NC
    from ._run_folder import dataset_from_csv, read_results_nc, read_run_record, read_run_table

    folder = os.fspath(folder)
    record = read_run_record(folder)
    nc = os.path.join(folder, RESULTS_NC)
    ds = read_results_nc(nc, record) if os.path.lexists(nc) else dataset_from_csv(folder)
    tables = {}
    for name in sorted(os.listdir(folder)):
        if name.endswith(".csv") and name not in ("receptors.csv", "afferents.csv"):
            tables[name[:-4]] = read_run_table(os.path.join(folder, name), what="a table afferent wrote", rows=False)
    return RunResults(dataset=ds, tables=tables, run=record, folder=folder)


#: The PNGs :func:`_figures` can draw, in the order it draws them.
FIGURE_ORDER = ("sed_map.png", "profiles_x.png", "profiles_z.png", "fit.png", "waveform.png", "raster.png", "rates.png",
                "psth.png")


def _figures(path, want, *, sed_static, sed, current, branching, afferent, fit, waveform, spikes, profile_index,
             only=None, skip=frozenset()):
    """Draw the run's PNGs (:func:`write_outputs`), in this order; ``only`` / ``skip``: the PNG names to draw /
    to leave out (the figure process and the run each draw a part: afferent._figure_process.RUN_DRAWS)."""
    from . import plotting

    def drawn(name: str) -> bool:
        return (only is None or name in only) and name not in skip

    if "sed_map" in want and drawn("sed_map.png"):
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
        # the export's own steps: the same step as the profiles when no stimulus rescaled them, else
        # the export step of the largest total SED (the static solution a waveform scales)
        same = sed_static is sed
        k = profile_index if same else int(np.argmax(np.nansum(np.asarray(sed_static.values), axis=1)))
        n_t, times = sed_static.values.shape[0], sed_static.times
        # a stimulus has its own clock: the export's time is named 'FE time' beside the stimulus' peak t
        kw = {} if same else dict(clock="FE time", also=f";\nthe stimulus peaks at t = {float(sed.times[profile_index]):.4g} s")
        plotting.plot_sed_map(sed_static, ax=axes[0], time_index=k, title=step_title("SED at receptor sites", times, k, n_t, **kw))
        plotting.plot_sed_map(sed_static, ax=axes[1], normalise=True, threshold=0.6, time_index=k,
                              title=step_title("normalised SED, hot spots >= 0.6", times, k, n_t, **kw))
        plotting.save_figure(fig, path("sed_map.png"))
    if "profiles" in want:
        from .synthesis import Branching, synthesize

        layout = sed.layout
        for axis, kind, name in (("x", "longitudinal", "profiles_x.png"), ("z", "cross", "profiles_z.png")):
            if not drawn(name):
                continue
            aff = afferent if branching.kind == kind else synthesize(
                current, Branching.longitudinal(layout) if kind == "longitudinal" else Branching.cross(layout))
            ax = plotting.plot_section_profiles(sed, current, aff, axis=axis, time_index=profile_index,
                                                title=step_title(f"Profiles along {axis}", sed.times, profile_index,
                                                                 sed.values.shape[0]))
            plotting.save_figure(ax, path(name))
    if "fit" in want and fit is not None and drawn("fit.png"):
        plotting.save_figure(plotting.plot_fit(fit), path("fit.png"))
    if waveform is not None and drawn("waveform.png"):
        plotting.save_figure(plotting.plot_waveform(waveform), path("waveform.png"))
    if "spikes" in want and spikes is not None:
        if drawn("raster.png"):
            plotting.save_figure(plotting.plot_raster(spikes), path("raster.png"))
        if drawn("rates.png"):
            plotting.save_figure(plotting.plot_rates(spikes, positions=afferent, waveform=waveform), path("rates.png"))
        if drawn("psth.png"):
            plotting.save_figure(plotting.plot_psth(spikes, max(spikes.duration / 50, spikes.dt)), path("psth.png"))
