"""``spikes.nwb``: the spike trains as a Neurodata Without Borders file (pynwb; the ``nwb`` extra), written by
:func:`afferent.export.write_outputs` for the output ``nwb``.

What the file holds, and why (issue 37, checked with nwbinspector 0.7.2, pynapple and Neo's NWBIO):

- the Units table: one row per afferent, ``spike_times`` (s) and ``obs_intervals`` (the simulated window),
  its ``resolution`` (s: ``dt`` for the grid engines; for the exact engine, which has no grid and finds each
  threshold crossing to float64 precision, the spacing of float64 numbers at the end of the window), the
  afferent id also as ``_name`` (the column Neo's NWBIO reads as a spike train's ``name``), position and LIF
  parameters;
- epochs: the stimulus phases (:meth:`afferent.stimulus.Waveform.phases`, tagged 'loading', 'hold',
  'unloading', 'off') within the simulated window, else one epoch 'simulated' over it, so that rates over an
  interval (pynapple) use the simulated time, not the span of the spikes;
- the waveform as a stimulus ``TimeSeries`` (indentation depth, m) when a waveform drove the run;
- the description names the afferent class, the engine, the input mode and the drive; ``stimulus_notes``
  gives the input's and the drive's parameters;
- the scene's ``[nwb]`` table (:class:`afferent.scene.schema.NwbSpec`): subject, experimenter, institution,
  lab, keywords, experiment description. What it leaves out is listed in ``run.json`` (``nwb.missing``);
  nwbinspector then names it too (a missing subject is its CRITICAL finding).
"""

from __future__ import annotations

from .stimulus._waveforms import Waveform
from .synthesis import AfferentCurrent



import json

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # afferent.spiking loads on first use (a SED-only run never imports it)
    from .spiking._trains import SpikeTrains

import numpy as np

__all__ = ["write_spikes_nwb", "nwb_missing", "resolution"]

#: [nwb] keys -> what nwbinspector (0.7.2) checks; the file lacks what the scene leaves out
_WANTED = ("subject_id", "species", "sex", "age", "experimenter", "institution", "keywords", "description")


def resolution(spikes) -> float:
    """The smallest difference between two spike times the run can give, in s: ``dt`` on a grid; for the exact
    engine (``dt`` 0) the spacing of float64 numbers at the end of the simulated window."""
    if spikes.dt > 0:
        return float(spikes.dt)
    return float(np.spacing(abs(float(spikes.t_start) + float(spikes.duration))))


def nwb_missing(meta) -> list[str]:
    """The ``[nwb]`` keys ``meta`` (an NwbSpec, or None) does not give, of those nwbinspector looks for."""
    return [k for k in _WANTED if meta is None or getattr(meta, k, None) in (None, ())]


def _describe(aclass: str, spikes, record: dict) -> str:
    kind = record.get("input") or "static"
    drive = (record.get("drive") or {}).get("mapping", "resistance")
    return (f"afferent: simulated {aclass} tactile afferent spike trains (leaky integrate-and-fire, {spikes.engine} "
            f"engine; input {kind!r}, drive {drive!r})")


def write_spikes_nwb(path: str, spikes: SpikeTrains, afferent: AfferentCurrent, *, waveform: Waveform | None=None, context: dict | None=None) -> None:
    """Spike trains as an NWB file (pynwb): one row of the Units table per afferent.

    Columns beside ``spike_times`` (s) and ``obs_intervals`` (the simulated span, s):
    ``afferent`` (id), ``_name`` (the id again, which Neo reads as the train's name), ``position_m``
    (m, along ``position_axis``), the LIF parameters ``tau_m_s``, ``r_m_ohm``, ``v_rest_v``,
    ``v_thresh_v``, ``v_reset_v``, ``t_ref_s`` (SI), and ``skipped_silent`` (not simulated:
    provably silent). The table's ``resolution`` (s) is the engine's ``dt``; for the exact engine, the spacing of
    float64 numbers at the end of the simulated window (each crossing found to float64 precision). Readable by pynwb,
    pynapple, Neo (Elephant) and NWB Widgets.

    Parameters
    ----------
    path : str
        The file to write (inside a folder ``afferent._output.atomic_dir`` is creating).
    spikes : SpikeTrains
        From :func:`afferent.spiking.simulate_lif`.
    afferent : AfferentCurrent
        The afferents simulated (positions in m).
    waveform : Waveform, optional
        The indentation waveform (m over s) that drove the run: a stimulus TimeSeries and the epochs.
    context : dict, optional
        ``afferent_class`` (name), ``spikes`` (run.json's ``spikes`` record: input, its parameters, the
        drive) and ``metadata`` (the scene's ``[nwb]`` table, an NwbSpec); without it the class is
        unnamed and no metadata is written.
    """
    from datetime import datetime, timezone
    from uuid import uuid4

    from pynwb import NWBHDF5IO, NWBFile, TimeSeries
    from pynwb.file import Subject

    from . import __version__

    context = context or {}
    record = context.get("spikes") or {}
    meta = context.get("metadata")
    aclass = context.get("afferent_class") or "(class not stated)"
    t0 = float(getattr(spikes, "t_start", 0.0))
    t1 = t0 + float(spikes.duration)
    res = resolution(spikes)
    how = (f"dt of the {spikes.engine} engine's grid" if spikes.dt > 0 else
           "exact engine: no grid, each threshold crossing found to float64 precision; the spacing of float64 "
           "numbers at the end of the simulated window")
    given = {k: getattr(meta, k) for k in ("description", "experimenter", "institution", "lab", "keywords")
             if meta is not None and getattr(meta, k) not in (None, ())}
    subject = {k: getattr(meta, k) for k in ("subject_id", "species", "sex", "age", "subject_description")
               if meta is not None and getattr(meta, k) is not None}
    nwb = NWBFile(session_description=_describe(aclass, spikes, record), identifier=str(uuid4()),
                  session_start_time=datetime.now(timezone.utc),
                  source_script=f"afferent-skin {__version__}", source_script_file_name="afferent",
                  experiment_description=given.get("description"), experimenter=given.get("experimenter"),
                  institution=given.get("institution"), lab=given.get("lab"),
                  keywords=list(given["keywords"]) if "keywords" in given else None,
                  stimulus_notes=json.dumps({"input": record.get("input"), "input_params": record.get("input_params"),
                                             "drive": {k: v for k, v in (record.get("drive") or {}).items()
                                                       if not isinstance(v, list)}}),
                  notes=f"engine {spikes.engine} ({getattr(spikes, 'backend', '')}), dt {spikes.dt:g} s (0: exact, no "
                        f"grid), duration {spikes.duration:g} s from t = {t0:g} s; Units resolution {res:g} s ({how})",
                  subject=Subject(**{("description" if k == "subject_description" else k): v
                                     for k, v in subject.items()}) if subject else None)
    _units(nwb, spikes, afferent, res, how, t0, t1)
    if waveform is not None:
        times = np.asarray(waveform.times, dtype=float)
        step = np.diff(times)  # evenly sampled: a rate, as NWB prefers (nwbinspector's check_regular_timestamps)
        clock = ({"starting_time": float(times[0]), "rate": 1.0 / float(step.mean())}
                 if step.size > 1 and np.allclose(step, step.mean(), rtol=1e-9, atol=0.0) else {"timestamps": times})
        nwb.add_stimulus(TimeSeries(name="indentation_depth", data=np.asarray(waveform.depth, dtype=float), unit="m",
                                    description=f"indentation depth of the {waveform.kind} waveform that drove the "
                                                "run (waveform.csv)", **clock))
    phases = [(name, max(a, t0), min(b, t1)) for name, a, b in waveform.phases()] if waveform is not None else []
    phases = [p for p in phases if p[2] > p[1]] or [("simulated", t0, t1)]
    for name, a, b in phases:
        nwb.add_epoch(start_time=a, stop_time=b, tags=[name])
    with NWBHDF5IO(path, "w") as io:
        io.write(nwb)


def _units(nwb, spikes, afferent, res: float, how: str, t0: float, t1: float) -> None:
    """The Units table: one row per afferent (see :func:`write_spikes_nwb`)."""
    from pynwb.misc import Units

    lif = spikes.params
    cols = {"afferent": "afferent id", "_name": "afferent id (the column Neo's NWBIO reads as a spike train's name)",
            "position_m": f"afferent position along {afferent.axis}, m",
            "tau_m_s": "membrane time constant, s", "r_m_ohm": "membrane resistance, ohm",
            "v_rest_v": "resting potential, V", "v_thresh_v": "threshold, V", "v_reset_v": "reset potential, V",
            "t_ref_s": "refractory period, s", "skipped_silent": "not simulated: provably silent (run.json spikes)"}
    nwb.units = Units(name="units", description=f"simulated afferents, one per row; resolution: {how}", resolution=res)
    for name, doc in cols.items():
        nwb.add_unit_column(name=name, description=doc)
    silent = set(np.asarray(spikes.silent_skipped, dtype=int).tolist())
    for i, times in enumerate(spikes.spike_times):
        aid = str(spikes.afferent_ids[i])
        nwb.add_unit(spike_times=np.asarray(times, dtype=float), obs_intervals=[[t0, t1]], afferent=aid, _name=aid,
                     position_m=float(afferent.positions[i]), tau_m_s=float(lif.tau_m), r_m_ohm=float(lif.r_m),
                     v_rest_v=float(lif.v_rest), v_thresh_v=float(lif.v_thresh), v_reset_v=float(lif.v_reset),
                     t_ref_s=float(lif.t_ref), skipped_silent=i in silent)
