"""Measure every speed-accuracy trade-off on the packaged sample and write a Markdown report.

One measuring function per knob a user turns; ``afferent report -o DIR`` runs all of them at a
chosen size (:data:`SIZES`) and writes ``DIR/report.md`` with one PNG plot per knob, and the
benchmark scripts under ``benchmarks/`` call the same functions at their larger sizes:

- :func:`measure_sampling`: ``'linear'`` vs ``'nearest'`` sampling, time of the weights (once)
  and per time step, error against an analytic (manufactured) field on the sample's mesh;
- :func:`measure_spiking`: the event-driven ``'exact'`` engine (the default) against the grid
  engines ``'fast'`` and ``'brian2'`` at several time steps: time, rate and spike-time errors;
- :func:`measure_receptor_count`: receptors per papilla, time and afferent-profile error
  against the densest count;
- :func:`measure_calibration`: ``rsm1``, ``rsm2`` and ``least_squares`` on noise-free profiles
  of known parameters: model evaluations, time, parameter errors;
- :func:`measure_series`: a time series read whole (:func:`afferent.io.read_sed` then
  :func:`afferent.sampling.sample_sed`) against streamed (:func:`afferent.io.iter_sed` then
  :func:`afferent.sampling.sample_steps`): time and peak memory.

Times are wall-clock seconds, the fastest of ``repeat`` runs (the others carry noise from
whatever else the machine does); memory is the peak of Python-level allocations (numpy
buffers included) measured by Python's ``tracemalloc``, in MB (1e6 bytes). Everything runs on the
sample installed with the package (``afferent/data/sample/``), so the report works from a wheel.
"""

from __future__ import annotations

from .._typing import PathLike
from collections.abc import Callable

import dataclasses
import os
import tempfile
import time

import numpy as np

from . import measure as _measure
from .measure import (
    ReportSize, _read_sample, best_time, block_dims, hex_block, machine_info, manufactured_sed, measure_calibration,
    measure_receptor_count, measure_sampling, measure_series, measure_spiking, papilla_sites, per_papilla_layout,
    spike_errors, synthetic_afferent_current, write_series,
)
from .render import SECTIONS, _markdown, _plots, headline

__all__ = ["SIZES", "ReportSize", "machine_info", "best_time", "hex_block", "manufactured_sed", "papilla_sites",
           "measure_sampling", "synthetic_afferent_current", "spike_errors", "measure_spiking",
           "per_papilla_layout", "measure_receptor_count", "CALIBRATION_METHODS", "CALIBRATION_TRUTHS", "measure_calibration",
           "block_dims", "write_series", "measure_series", "SECTIONS", "headline", "run_report"]

# defined here too (the same objects), so the API reference documents them with the package
#: The report's sizes by name ('tiny' for the test, 'quick' by default, 'full' with ``--full``).
SIZES: dict[str, ReportSize] = _measure.SIZES
#: The calibration methods compared, by label, with the keyword arguments of ``calibrate``.
CALIBRATION_METHODS: dict = _measure.CALIBRATION_METHODS
#: The known (alpha A, gamma 1/Pa, lambda Pa) of the noise-free calibration profiles.
CALIBRATION_TRUTHS: tuple = _measure.CALIBRATION_TRUTHS


def run_report(output: PathLike, *, size: str | ReportSize = "quick", overwrite: bool = False, command: str | None = None,
               progress: Callable[[str], None] | None=None) -> dict:
    """Measure every knob at ``size`` and write ``output/report.md``, its PNG plots and ``results.json``.

    Parameters
    ----------
    output : str or path
        Folder to write; created whole, or not at all (written under a temporary name, then renamed).
    size : {'tiny', 'quick', 'full'} or ReportSize
        How much work (:data:`SIZES`).
    overwrite : bool
        Replace an existing ``output``; otherwise an existing one is an error.
    command : str, optional
        The command line to state in the report (default ``afferent report -o OUTPUT``).
    progress : callable, optional
        Called with a short message before each measurement.

    Returns
    -------
    dict
        The measurements (rows per knob, ``machine``, ``timings`` in s per knob, ``wall_s`` the
        whole run in s, ``headline``).

    Raises
    ------
    OutputExistsError
        If ``output`` exists and ``overwrite`` is False.
    """
    import json

    from .._output import atomic_dir, check_writable
    from ..export import jsonable

    if isinstance(size, str):
        if size not in SIZES:
            raise ValueError(f"'size' must be one of {sorted(SIZES)}; got {size!r} instead.")
        size = SIZES[size]
    output = os.fspath(output)
    check_writable(output, overwrite=overwrite, what="Output folder", folder=True)  # before minutes of measuring
    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="afferent-report-") as work:
        results = _measure_all(size, work, say)
    results["machine"] = machine_info()
    results["size"] = dataclasses.asdict(size)
    results["headline"] = headline(results)
    command = command or f"afferent report -o {output}"
    with atomic_dir(output, overwrite=overwrite) as tmp:
        png = _plots(results, tmp)
        results["wall_s"] = time.perf_counter() - t0  # measuring and plotting (not the imports before)
        with open(os.path.join(tmp, "report.md"), "w", encoding="utf-8") as f:
            f.write(_markdown(results, size, png, command))
        with open(os.path.join(tmp, "results.json"), "w", encoding="utf-8") as f:
            json.dump(jsonable(results), f, indent=1)
    return results


def _measure_all(size: ReportSize, work: str, say) -> dict:
    from ..receptors import ReceptorLayout
    from ..sampling import sample_sed
    from ..spiking import LIF_PRESETS

    timings, results = {}, {}
    field, tips = _read_sample("indent_0p88mm.vtu")
    results["mesh_points"] = field.n_points

    t0 = time.perf_counter()
    say("sampling")
    manufactured = dataclasses.replace(field, sed=manufactured_sed(field.points)[None, :])
    sites = ReceptorLayout(papilla_sites(tips, size.sampling_sites, rng=6))
    results["sampling"] = measure_sampling(manufactured, sites, manufactured_sed(sites.positions), repeat=size.repeat)
    timings["sampling"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    say("spiking engines")
    times, current = synthetic_afferent_current(size.spiking_afferents, duration=size.spiking_duration)
    params = LIF_PRESETS["ra"]
    results["spiking"] = measure_spiking(current, times, size.spiking_duration, params, fast_dts=size.fast_dts,
                                         brian2_dts=size.brian2_dts, repeat=size.repeat)
    from ..spiking import simulate_lif

    constant = np.full((2, 1), 3 * params.rheobase)
    results["closed_form"] = {"current_a": float(constant[0, 0]),
                              "closed_form_hz": float(params.steady_rate(constant[0])[0]),
                              "exact_hz": float(simulate_lif(constant, params, dt=0.5, duration=1.0, engine="exact").rates()[0])}
    timings["spiking"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    say("receptor count")
    field132, _ = _read_sample("indent_1p32mm.vtu")
    results["receptors"] = measure_receptor_count(field132, tips, size.per_papilla, repeat=size.repeat)
    timings["receptors"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    say("calibration")
    sed132 = sample_sed(field132, tips)
    results["calibration"] = measure_calibration(sed132, CALIBRATION_TRUTHS[:size.calibration_truths],
                                                 repeat=min(size.repeat, 2))
    timings["calibration"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    say("series reading")
    rng = np.random.default_rng(0)
    sites = ReceptorLayout(np.column_stack([rng.uniform(0.2, 3.8, 150), np.full(150, 2.9), rng.uniform(0.2, 3.8, 150)]) * 1e-3)
    rows = []
    for n in size.series_steps:
        folder = os.path.join(work, f"series_{n}")
        os.makedirs(folder)
        rows += measure_series(write_series(folder, size.series_points, n), sites)
    results["series"] = rows
    timings["series"] = time.perf_counter() - t0
    results["timings"] = timings
    return results
