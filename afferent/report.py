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

import dataclasses
import os
import platform
import tempfile
import time
import tracemalloc
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["SIZES", "ReportSize", "machine_info", "best_time", "hex_block", "manufactured_sed", "papilla_sites",
           "measure_sampling", "synthetic_afferent_current", "spike_errors", "measure_spiking",
           "per_papilla_layout", "measure_receptor_count", "CALIBRATION_METHODS", "CALIBRATION_TRUTHS", "measure_calibration",
           "block_dims", "write_series", "measure_series", "headline", "run_report"]

#: Half-width (m) of a square around each papilla tip, in x and z, that lies inside the packaged
#: sample's crop (the elements kept around a tip reach 0.04-0.055 mm from it; measured).
PATCH_HALF_WIDTH = 0.04e-3


@dataclass(frozen=True)
class ReportSize:
    """How much work each measurement of the report does.

    Attributes
    ----------
    name : str
        ``'tiny'`` (the test's), ``'quick'`` (the default of ``afferent report``) or ``'full'``.
    repeat : int
        Timed runs per measurement; the fastest is kept.
    sampling_sites : int
        Random sites at which the sampling error is measured.
    spiking_afferents : int
        Afferents of the synthetic ramp-and-hold current.
    spiking_duration : float
        Simulated time in s.
    fast_dts, brian2_dts : tuple of float
        Time steps in s at which the grid engines run (``brian2_dts`` empty: brian2 not run).
    per_papilla : tuple of int
        Receptors per papilla tip compared (the last, the densest, is the reference).
    calibration_truths : int
        How many of :data:`CALIBRATION_TRUTHS` are fitted.
    series_points : int
        Approximate number of nodes of the generated series' mesh.
    series_steps : tuple of int
        Step counts of the generated series (each read whole and streamed).
    """

    name: str
    repeat: int
    sampling_sites: int
    spiking_afferents: int
    spiking_duration: float
    fast_dts: tuple
    brian2_dts: tuple
    per_papilla: tuple
    calibration_truths: int
    series_points: int
    series_steps: tuple


#: The sizes of the report: ``'quick'`` is ``afferent report``'s default, ``'full'`` its ``--full``.
SIZES = {
    "tiny": ReportSize("tiny", 1, 500, 20, 1.0, (1e-3, 1e-4), (1e-3,), (1, 2, 4), 1, 8_000, (2, 6)),
    "quick": ReportSize("quick", 3, 2000, 200, 1.0, (1e-3, 1e-4, 1e-5, 1e-6), (1e-3, 1e-4), (1, 2, 4, 8, 16), 2,
                        100_000, (5, 40)),
    "full": ReportSize("full", 3, 10_000, 200, 1.0, (1e-3, 2e-4, 1e-4, 2e-5, 1e-5, 1e-6), (1e-3, 1e-4, 1e-5),
                       (1, 2, 4, 8, 16, 32), 2, 270_000, (10, 50)),
}


# ---- machine ---------------------------------------------------------------------------------

def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _ram_bytes() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def _version(module: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(module)
    except PackageNotFoundError:
        return None


def machine_info() -> dict:
    """The machine and the versions a measurement ran with.

    Returns
    -------
    dict
        ``cpus`` (logical CPUs), ``cpu_model`` (from ``/proc/cpuinfo``, or None), ``ram_gb``
        (physical memory in GB, 1e9 bytes, or None), ``platform``, and ``versions``: python,
        numpy, scipy, brian2, numba (None when not installed), afferent.
    """
    from . import __version__

    ram = _ram_bytes()
    versions = {"python": platform.python_version()}
    versions.update({name: _version(name) for name in ("numpy", "scipy", "brian2", "numba", "matplotlib")})
    versions["afferent"] = __version__
    return {"cpus": os.cpu_count(), "cpu_model": _cpu_model(), "ram_gb": None if ram is None else ram / 1e9,
            "platform": platform.platform(), "versions": versions}


def best_time(fn, repeat: int = 3):
    """Run ``fn()`` ``repeat`` times; returns (fastest wall time in s, the last result)."""
    best, out = np.inf, None
    for _ in range(max(1, int(repeat))):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _sample_dir() -> Path:
    from .cli._demo import packaged_sample_dir

    return packaged_sample_dir()


def _read_sample(name: str):
    from .io import read_sed
    from .receptors import read_receptors

    block = _sample_dir() / "block4"
    return (read_sed(str(block / name), length_unit="mm", sed_unit="MPa"),
            read_receptors(block / "receptors.csv", length_unit="mm"))


# ---- sampling --------------------------------------------------------------------------------

def manufactured_sed(points) -> np.ndarray:
    """A smooth manufactured SED in Pa at ``points`` (m): a 4 kPa bump, 0.5 mm standard width,
    centred at x = z = 2 mm and decaying with depth below y = 2.45 mm over 0.5 mm (the size and
    scale of the sample's field at the receptors, but known everywhere)."""
    x, y, z = (np.asarray(points, dtype=float) * 1e3).T
    return 4000.0 * np.exp(-((x - 2) ** 2 + (z - 2) ** 2) / (2 * 0.5**2)) * np.exp((y - 2.45) / 0.5)


def papilla_sites(layout, n: int, *, rng=0) -> np.ndarray:
    """``n`` random sites (m) inside the sample's mesh: each within +-0.04 mm in x and z of a
    random papilla tip of ``layout`` and 0.02-0.05 mm below it (the packaged sample keeps the
    elements around each tip; these offsets stay inside them at every tip, measured)."""
    rng = np.random.default_rng(rng)
    tips = layout.positions[rng.integers(0, layout.n_receptors, n)]
    lo = np.array([-PATCH_HALF_WIDTH, -0.05e-3, -PATCH_HALF_WIDTH])
    hi = np.array([PATCH_HALF_WIDTH, -0.02e-3, PATCH_HALF_WIDTH])
    return tips + rng.uniform(lo, hi, (n, 3))


def measure_sampling(field, layout, exact, *, methods=("linear", "nearest"), repeat: int = 3) -> list[dict]:
    """Time and error of each sampling method against known values.

    Parameters
    ----------
    field : SEDField
        A field whose SED (J/m^3) follows a known function; every time step is sampled.
    layout : ReceptorLayout
        Sites in m, inside the mesh.
    exact : ndarray of shape (n_receptors,) or (n_times, n_receptors)
        The known SED at the sites in J/m^3 (broadcast against the sampled values).
    methods : tuple of str
        Sampling methods (:func:`afferent.sampling.build_sampler`).
    repeat : int
        Timed runs; the fastest is kept.

    Returns
    -------
    list of dict
        Per method: ``method``, ``receptors``, ``weights_s`` (building the weights, once),
        ``per_step_s`` (applying them, per time step), ``err_median``, ``err_p95``, ``err_max``
        (relative errors |sampled - exact| / exact) and ``abs_err_max_pa``, ``abs_err_rms_pa``.
    """
    from .sampling import build_sampler

    rows = []
    for method in methods:
        t_w, sampler = best_time(lambda: build_sampler(field, layout, method=method), repeat)
        if sampler.outside.any():
            raise ValueError(f"measure_sampling: {int(sampler.outside.sum())} of {layout.n_receptors} sites lie outside "
                             "the field's mesh; the error is measured at sites inside it only.")
        t_a, values = best_time(lambda: sampler.apply(field.sed), max(repeat, 5))
        err = values - exact
        rel = np.abs(err) / np.abs(exact)
        rows.append({"method": method, "receptors": layout.n_receptors, "weights_s": t_w,
                     "per_step_s": t_a / field.sed.shape[0], "err_median": float(np.median(rel)),
                     "err_p95": float(np.percentile(rel, 95)), "err_max": float(rel.max()),
                     "abs_err_max_pa": float(np.abs(err).max()), "abs_err_rms_pa": float(np.sqrt(np.mean(err**2)))})
    return rows


# ---- spiking ---------------------------------------------------------------------------------

def synthetic_afferent_current(n_afferents: int, *, duration: float = 1.0, sample_dt: float = 1e-3, rng=0):
    """A ramp-and-hold afferent current per afferent: ramp (100 ms), hold (500 ms), release
    (100 ms), rest; plateau amplitudes log-uniform over 30 nA - 16 uA (the study's afferent-current
    range), onsets jittered over 0-20 ms.

    Returns
    -------
    times : ndarray of shape (n_times,)
        Sample times in s, every ``sample_dt``.
    current : ndarray of shape (n_times, n_afferents)
        Current in A.
    """
    rng = np.random.default_rng(rng)
    times = np.arange(int(round(duration / sample_dt)) + 1) * sample_dt
    amp = np.exp(rng.uniform(np.log(3e-8), np.log(1.6e-5), n_afferents))
    onset = rng.uniform(0.0, 0.02, n_afferents)
    # clip(t / 0.1, 0, 1) - clip((t - 0.6) / 0.1, 0, 1), times amp; in place (two buffers at most)
    current = np.subtract.outer(times, onset)
    release = current - 0.6
    for buf in (current, release):
        np.divide(buf, 0.1, out=buf)
        np.clip(buf, 0.0, 1.0, out=buf)
    current -= release
    del release
    current *= amp
    return times, current


def spike_errors(trains, ref) -> dict:
    """Errors of spike trains against reference trains of the same afferents.

    Returns
    -------
    dict
        ``spike_err_median_s`` and ``spike_err_max_s``: |t - t_ref| over rank-matched spikes
        (each spike matched to the reference spike of the same rank), s; ``count_differs``:
        fraction of afferents whose spike count differs; ``latency_err_max_s``: worst
        first-spike latency error, s; ``rate_err_median`` and ``rate_err_max``: relative error of
        the mean rate over the afferents the reference makes fire.
    """
    lat = np.abs(trains.first_spike_latency() - ref.first_spike_latency())
    fired = ref.n_spikes > 0
    rate_err = np.abs(trains.rates() - ref.rates())[fired] / ref.rates()[fired]
    errs, mismatched = [], 0
    for a, b in zip(trains.spike_times, ref.spike_times):
        mismatched += a.size != b.size
        k = min(a.size, b.size)
        errs.append(np.abs(a[:k] - b[:k]))
    errs = np.concatenate(errs) if errs else np.empty(0)
    return {"spike_err_median_s": float(np.median(errs)) if errs.size else 0.0,
            "spike_err_max_s": float(errs.max()) if errs.size else 0.0,
            "count_differs": mismatched / max(len(trains.spike_times), 1),
            "latency_err_max_s": float(np.nanmax(lat)) if np.isfinite(lat).any() else 0.0,
            "rate_err_median": float(np.median(rate_err)) if rate_err.size else 0.0,
            "rate_err_max": float(rate_err.max()) if rate_err.size else 0.0}


def _has_brian2() -> bool:
    try:
        import brian2  # noqa: F401
    except Exception:  # noqa: BLE001 - brian2 can fail to import in several ways (numpy too new)
        return False
    return True


def measure_spiking(current, times, duration: float, params, *, fast_dts=(1e-3, 1e-4, 1e-5), brian2_dts=(1e-3,),
                    repeat: int = 3) -> list[dict]:
    """Time and spike errors of each engine and time step against the exact engine.

    Parameters
    ----------
    current : ndarray of shape (n_times, n_afferents)
        Afferent current in A, sampled at ``times``.
    times : ndarray of shape (n_times,)
        Sample times in s.
    duration : float
        Simulated time in s.
    params : LIFParams
        Neuron parameters.
    fast_dts, brian2_dts : tuple of float
        Time steps in s at which ``'fast'`` and ``'brian2'`` run; brian2 is left out (a row
        with ``skipped``) when it does not import.
    repeat : int
        Timed runs (brian2: one); the fastest is kept.

    Returns
    -------
    list of dict
        Per run: ``engine``, ``backend``, ``dt_s`` (None for the exact engines), ``wall_s``,
        ``spikes``, and the errors of :func:`spike_errors` against ``engine='exact'`` (numba
        if installed): the first row is the reference itself, then the exact engine's other
        backend (numpy) when numba is installed, then the grid engines.
    """
    from .spiking import simulate_lif

    warm = np.full((2, 1), 1e-6)
    simulate_lif(warm, params, dt=1e-4, engine="exact")  # numba compiles (or loads) its loops: not timed
    simulate_lif(warm, params, dt=1e-4, engine="fast")
    t_ref, ref = best_time(lambda: simulate_lif(current, params, engine="exact", times=times, duration=duration), repeat)
    rows = [{"engine": "exact", "backend": ref.backend, "dt_s": None, "wall_s": t_ref, "spikes": int(ref.n_spikes.sum()),
             **spike_errors(ref, ref)}]
    cases = [("exact-numpy", None)] if ref.backend == "numba" else []  # the other backend of the same engine
    cases += [("fast", dt) for dt in fast_dts]
    brian2 = bool(brian2_dts) and _has_brian2()
    if brian2:
        simulate_lif(warm, params, dt=1e-4, engine="brian2")  # imports and code generation: not timed
        cases += [("brian2", dt) for dt in brian2_dts]
    for engine, dt in cases:
        n = 1 if engine == "brian2" else repeat
        wall, res = best_time(lambda: simulate_lif(current, params, dt=dt, engine=engine, times=times,
                                                   duration=duration), n)
        rows.append({"engine": engine, "backend": res.backend, "dt_s": dt, "wall_s": wall,
                     "spikes": int(res.n_spikes.sum()), **spike_errors(res, ref)})
    if brian2_dts and not brian2:
        rows.append({"engine": "brian2", "backend": None, "dt_s": None, "wall_s": None, "spikes": None,
                     "skipped": "brian2 does not import"})
    return rows


# ---- receptor count --------------------------------------------------------------------------

def per_papilla_layout(tips, k: int):
    """``k`` receptor sites per papilla tip, spread along the ridges (z) over +-0.04 mm of the tip
    (one site: the tip itself); each keeps its tip's section labels. Positions in m."""
    from .receptors import ReceptorLayout

    dz = np.linspace(-PATCH_HALF_WIDTH, PATCH_HALF_WIDTH, k) if k > 1 else np.zeros(1)
    pos = np.repeat(tips.positions, k, axis=0)
    pos[:, 2] += np.tile(dz, tips.n_receptors)
    return ReceptorLayout(pos, longitudinal=np.repeat(tips.longitudinal, k), cross=np.repeat(tips.cross, k))


def measure_receptor_count(field, tips, per_papilla=(1, 2, 4, 8, 16), *, params=None, repeat: int = 3) -> list[dict]:
    """Time and afferent-profile error against the receptor count.

    Parameters
    ----------
    field : SEDField
        SED in J/m^3.
    tips : ReceptorLayout
        The papilla tips (m); ``k`` sites are put around each (:func:`per_papilla_layout`).
    per_papilla : tuple of int
        Receptors per tip; the last is the reference.
    params : SigmoidParams, optional
        Transduction; default the study's start parameters.
    repeat : int
        Timed runs; the fastest is kept.

    Returns
    -------
    list of dict
        Per count: ``per_papilla``, ``receptors``, ``sampling_s`` (locating the sites and
        sampling), ``transduce_synthesize_s`` (longitudinal synthesis), ``profile_error`` (max
        difference of the min-max normalised profile of mean current per receptor against the
        reference's) and ``current_error`` (max relative difference of that mean current).
    """
    from .profiles import minmax_normalise
    from .sampling import sample_sed
    from .synthesis import Branching, synthesize
    from .transduction import STUDY_PARAMS, transduce

    params = STUDY_PARAMS["start"] if params is None else params
    rows, profiles = [], {}
    for k in per_papilla:
        layout = per_papilla_layout(tips, k)
        t_s, sed = best_time(lambda: sample_sed(field, layout), repeat)
        t_r, aff = best_time(lambda: synthesize(transduce(sed, params), Branching.longitudinal(layout)), repeat)
        profiles[k] = aff.values[-1] / np.bincount(layout.longitudinal)  # mean current per receptor, A
        rows.append({"per_papilla": k, "receptors": layout.n_receptors, "sampling_s": t_s, "transduce_synthesize_s": t_r})
    ref = profiles[per_papilla[-1]]
    for row in rows:
        p = profiles[row["per_papilla"]]
        row["profile_error"] = float(np.max(np.abs(minmax_normalise(p) - minmax_normalise(ref))))
        row["current_error"] = float(np.max(np.abs(p - ref) / ref))
    return rows


# ---- calibration -----------------------------------------------------------------------------

#: The calibration methods compared: label -> keyword arguments of :func:`afferent.calibration.calibrate`.
CALIBRATION_METHODS = {
    "rsm1": dict(method="rsm1"),
    "rsm2": dict(method="rsm2"),
    "least_squares (2-point, 4 starts)": dict(method="least_squares", jac="2-point", restarts="always"),
    "least_squares": dict(method="least_squares"),
}


#: Known parameters (alpha A, gamma 1/Pa, lambda Pa) of the noise-free profiles fitted.
CALIBRATION_TRUTHS = ((3e-8, 2e-3, 900.0), (3e-8, 5e-3, 600.0))


def measure_calibration(sed, truths=CALIBRATION_TRUTHS, *, methods=None, normalise=("both", "neither"),
                        repeat: int = 3) -> list[dict]:
    """Evaluations, time and parameter errors of each calibration method on noise-free profiles.

    For each known parameter set the model's own longitudinal profile (transduce -> synthesize,
    last time step) is the observed profile; each method starts from the study's start
    parameters and fits it, compared min-max normalised (``'both'``: gamma and lambda fitted)
    and un-normalised (``'neither'``: alpha too).

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors in J/m^3.
    truths : tuple of (alpha A, gamma 1/Pa, lambda Pa)
        Known parameters.
    methods : dict, optional
        Label -> keyword arguments of ``calibrate``; default :data:`CALIBRATION_METHODS`.
    normalise : tuple of str
        Comparison modes.
    repeat : int
        Timed runs; the fastest is kept.

    Returns
    -------
    list of dict
        Per truth, mode and method: ``truth`` (label), ``normalise``, ``method``,
        ``evaluations`` (model evaluations), ``jacobian_evaluations``, ``time_s``, ``ssd``,
        ``status``, and ``err_alpha``, ``err_gamma``, ``err_lambda`` (relative error of the
        fitted parameter; None for a parameter with no effect, e.g. alpha when normalised).
    """
    from .calibration import calibrate
    from .profiles import ObservedProfile
    from .synthesis import Branching, synthesize
    from .transduction import SigmoidParams, transduce

    methods = CALIBRATION_METHODS if methods is None else methods
    rows = []
    for alpha, gamma, lambda_ in truths:
        truth = SigmoidParams(alpha, gamma, lambda_)
        aff = synthesize(transduce(sed, truth), Branching.longitudinal(sed.layout))
        observed = ObservedProfile(aff.positions, aff.values[-1])
        for mode in normalise:
            for label, kwargs in methods.items():
                def fit():
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        return calibrate(sed, observed, normalise=mode, **kwargs)

                t, res = best_time(fit, repeat)
                fitted = {"alpha": res.params.alpha, "gamma": res.params.gamma, "lambda": res.params.lambda_}
                known = {"alpha": alpha, "gamma": gamma, "lambda": lambda_}
                rows.append({"truth": f"gamma {gamma:g}/Pa, lambda {lambda_:g} Pa", "normalise": mode, "method": label,
                             "evaluations": int(res.n_evaluations), "jacobian_evaluations": int(res.n_jacobian_evaluations),
                             "time_s": t, "ssd": float(res.ssd), "status": res.status,
                             **{f"err_{p}": (None if p in res.no_effect else abs(fitted[p] / known[p] - 1)) for p in known}})
    return rows


# ---- series reading --------------------------------------------------------------------------

def hex_block(nx: int, ny: int, nz: int, size=(4.0, 3.1, 4.0)):
    """A structured hexahedral block from the origin to ``size`` (VTK node order).

    Returns
    -------
    points : ndarray of shape ((nx+1)(ny+1)(nz+1), 3)
        Coordinates in the unit of ``size``.
    hexes : ndarray of shape (nx ny nz, 8)
        Node indices of each hexahedron: the face at z = k counter-clockwise, then z = k + 1.
    """
    xs, ys, zs = (np.linspace(0.0, s, n + 1) for s, n in zip(size, (nx, ny, nz)))
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))

    def nid(a, b, c):
        return (a * (ny + 1) + b) * (nz + 1) + c

    hexes = np.column_stack([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                             nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)])
    return points, hexes


def block_dims(n_points: int, size=(4.0, 3.1, 4.0)) -> tuple[int, int, int]:
    """Cells per side (nx, ny, nz) of a block of ``size`` with about ``n_points`` nodes, cubic cells."""
    n = (n_points / float(np.prod(size))) ** (1 / 3)
    return tuple(max(2, round(n * s)) - 1 for s in size)


def write_series(folder, n_points: int, n_steps: int) -> list[str]:
    """Write a loading series of binary, zlib-compressed VTUs of a 4 x 3.1 x 4 mm hexahedral
    block of about ``n_points`` nodes (coordinates mm, SED MPa): step k carries
    (k + 1) / n_steps x the manufactured field of :func:`manufactured_sed` (centred on the block)."""
    import meshio

    points, hexes = hex_block(*block_dims(n_points))
    base = manufactured_sed(points * 1e-3 + [0.0, 2.45e-3 - 3.1e-3, 0.0]) / 1e6
    paths = []
    for k in range(n_steps):
        path = os.path.join(folder, f"step_{k:03d}.vtu")
        meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": (k + 1) / n_steps * base}),
                     binary=True, compression="zlib")
        paths.append(path)
    return paths


def measure_series(paths, layout, *, repeat: int = 1) -> list[dict]:
    """Time and peak memory of sampling a VTU series read whole against streamed.

    Parameters
    ----------
    paths : list of str
        The series' files (coordinates mm, SED MPa).
    layout : ReceptorLayout
        Receptor sites in m.
    repeat : int
        Timed runs; the fastest is kept (memory from a separate, traced run).

    Returns
    -------
    list of dict
        ``how`` (``'read_sed + sample_sed'`` or ``'iter_sed + sample_steps'``), ``steps``,
        ``points``, ``wall_s``, ``peak_mb`` (tracemalloc peak during the call, MB) and
        ``max_diff_pa`` (largest difference from the whole read's values, J/m^3; 0 expected).
    """
    from .io import iter_sed, read_sed
    from .sampling import sample_sed, sample_steps

    def whole():
        field = read_sed(paths, length_unit="mm", sed_unit="MPa")
        return sample_sed(field, layout), field.n_points

    def streamed():
        return sample_steps(iter_sed(paths, length_unit="mm", sed_unit="MPa"), layout), None

    rows, reference = [], None
    for how, fn in (("read_sed + sample_sed", whole), ("iter_sed + sample_steps", streamed)):
        wall, (sed, n_points) = best_time(fn, repeat)
        tracemalloc.start()
        try:
            fn()
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        reference = sed.values if reference is None else reference
        rows.append({"how": how, "steps": len(paths), "points": n_points, "wall_s": wall, "peak_mb": peak / 1e6,
                     "max_diff_pa": float(np.max(np.abs(sed.values - reference)))})
    rows[1]["points"] = rows[0]["points"]
    return rows


# ---- the report ------------------------------------------------------------------------------

def _measure_all(size: ReportSize, work: str, say) -> dict:
    from .receptors import ReceptorLayout
    from .sampling import sample_sed
    from .spiking import LIF_PRESETS

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
    from .spiking import simulate_lif

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


def _fmt_s(s) -> str:
    if s is None:
        return "-"
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def _fmt_rel(x) -> str:
    if x is None:
        return "-"
    return "0" if x == 0 else f"{x:.2%}" if x >= 1e-3 else f"{x:.1e}"


def _table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def headline(results: dict) -> dict:
    """The report's headline figures (those the README quotes), from :func:`run_report`'s results."""
    samp = {r["method"]: r for r in results["sampling"]}
    spk = {(r["engine"], r["dt_s"]): r for r in results["spiking"] if r.get("wall_s") is not None}
    cal = [r for r in results["calibration"] if r["normalise"] == "both"]
    out = {"linear_err_max": samp["linear"]["err_max"], "nearest_err_max": samp["nearest"]["err_max"],
           "linear_err_median": samp["linear"]["err_median"], "nearest_err_median": samp["nearest"]["err_median"],
           "exact_wall_s": spk["exact", None]["wall_s"]}
    for dt in (1e-3, 1e-4, 1e-5):
        if ("fast", dt) in spk:
            out[f"fast_{dt:g}_rate_err"] = spk["fast", dt]["rate_err_median"]
            out[f"fast_{dt:g}_wall_s"] = spk["fast", dt]["wall_s"]
        if ("brian2", dt) in spk:
            out[f"brian2_{dt:g}_wall_s"] = spk["brian2", dt]["wall_s"]
    for label in ("rsm1", "least_squares"):
        mine = [r for r in cal if r["method"] == label]
        out[f"{label}_evaluations"] = max(r["evaluations"] for r in mine)
        out[f"{label}_err_max"] = max(max(r[f"err_{p}"] or 0 for p in ("alpha", "gamma", "lambda")) for r in mine)
    return out


def _log_axis(ax, values, axis: str = "y") -> None:
    """Log scale on ``axis`` if ``values`` hold a positive finite number (else matplotlib refuses)."""
    v = np.asarray([x for x in values if x is not None], dtype=float)
    if np.any(np.isfinite(v) & (v > 0)):
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def _plots(results: dict, folder: str) -> dict:
    from matplotlib.figure import Figure  # figures outside pyplot: any backend, nothing left open

    from .plotting import save_figure

    def subplots(height):
        fig = Figure(figsize=(10, height), layout="constrained")
        return fig, fig.subplots(1, 2)

    names = {}
    # sampling
    rows = results["sampling"]
    fig, (ax_e, ax_t) = subplots(3.4)
    x = np.arange(len(rows))
    for j, (key, label) in enumerate((("err_median", "median"), ("err_p95", "95th percentile"), ("err_max", "max"))):
        ax_e.bar(x + (j - 1) * 0.27, [r[key] for r in rows], 0.27, label=label)
    ax_e.set_xticks(x, [r["method"] for r in rows])
    _log_axis(ax_e, [r[k] for r in rows for k in ("err_median", "err_p95", "err_max")])
    ax_e.set_ylabel("relative error of the sampled SED")
    ax_e.legend(fontsize="small")
    ax_t.bar(x - 0.2, [r["weights_s"] * 1e3 for r in rows], 0.4, label="weights (once)")
    ax_t.bar(x + 0.2, [r["per_step_s"] * 1e3 for r in rows], 0.4, label="per time step")
    ax_t.set_xticks(x, [r["method"] for r in rows])
    _log_axis(ax_t, [r[k] for r in rows for k in ("weights_s", "per_step_s")])
    ax_t.set_ylabel("time (ms)")
    ax_t.legend(fontsize="small")
    names["sampling"] = save_figure(fig, os.path.join(folder, "sampling.png"))
    # spiking
    rows = [r for r in results["spiking"] if r.get("wall_s") is not None]
    exact = rows[0]
    fig, (ax_t, ax_e) = subplots(3.6)
    for engine, marker in (("fast", "o"), ("brian2", "s")):
        part = [r for r in rows if r["engine"] == engine]
        if part:
            ax_t.loglog([r["dt_s"] * 1e3 for r in part], [r["wall_s"] for r in part], marker + "-", label=engine)
    ax_t.axhline(exact["wall_s"], color="k", ls=":", label="exact (no dt)")
    ax_t.set_xlabel("dt (ms)")
    ax_t.set_ylabel("wall time (s)")
    ax_t.legend(fontsize="small")
    fast = [r for r in rows if r["engine"] == "fast"]
    dts = np.array([r["dt_s"] * 1e3 for r in fast])
    for key, label, marker in (("rate_err_median", "rate, median relative error", "o-"),
                               ("spike_err_median_s", "spike time, median error (s)", "^-"),
                               ("latency_err_max_s", "first-spike latency, max error (s)", "s-")):
        vals = np.array([r[key] for r in fast], dtype=float)
        ax_e.loglog(dts, np.where(vals > 0, vals, np.nan), marker, label=label)
    ax_e.set_xlabel("dt (ms), fast engine (brian2: the same spikes)")
    ax_e.set_ylabel("error against the exact engine")
    ax_e.legend(fontsize="small")
    names["spiking"] = save_figure(fig, os.path.join(folder, "spiking.png"))
    # receptors
    rows = results["receptors"]
    fig, (ax_t, ax_e) = subplots(3.4)
    n = [r["receptors"] for r in rows]
    ax_t.loglog(n, [r["sampling_s"] * 1e3 for r in rows], "o-", label="sampling (locating + weights)")
    ax_t.loglog(n, [r["transduce_synthesize_s"] * 1e3 for r in rows], "s-", label="transduction + synthesis")
    ax_t.set_xlabel("receptors")
    ax_t.set_ylabel("time (ms)")
    ax_t.legend(fontsize="small")
    ax_e.semilogx(n[:-1], [r["profile_error"] for r in rows[:-1]], "o-", label="normalised profile")
    ax_e.semilogx(n[:-1], [r["current_error"] for r in rows[:-1]], "s-", label="mean current per receptor")
    ax_e.set_xlabel("receptors")
    ax_e.set_ylabel(f"max error vs {rows[-1]['per_papilla']} per papilla")
    ax_e.legend(fontsize="small")
    names["receptors"] = save_figure(fig, os.path.join(folder, "receptors.png"))
    # calibration
    rows = results["calibration"]
    fig, (ax_n, ax_e) = subplots(4.2)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    cases = list(dict.fromkeys((r["truth"], r["normalise"]) for r in rows))
    x = np.arange(len(methods))
    w = 0.8 / len(cases)
    for j, case in enumerate(cases):
        part = [next(r for r in rows if (r["truth"], r["normalise"]) == case and r["method"] == m) for m in methods]
        label = f"{case[0]}, normalise {case[1]}"
        ax_n.bar(x + (j - (len(cases) - 1) / 2) * w, [r["evaluations"] for r in part], w, label=label)
        worst = [max(r[f"err_{p}"] or 0 for p in ("alpha", "gamma", "lambda")) for r in part]
        ax_e.bar(x + (j - (len(cases) - 1) / 2) * w, np.maximum(worst, 1e-16), w, label=label)
    for ax in (ax_n, ax_e):
        ax.set_xticks(x, [m.replace(" (", "\n(") for m in methods], fontsize="small")
        ax.set_yscale("log")  # evaluations >= 1; errors floored at 1e-16 above
    ax_n.set_ylabel("model evaluations")
    ax_e.set_ylabel("largest relative parameter error")
    fig.legend(*ax_n.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize="small")
    names["calibration"] = save_figure(fig, os.path.join(folder, "calibration.png"))
    # series
    rows = results["series"]
    fig, (ax_t, ax_m) = subplots(3.4)
    for how, marker in (("read_sed + sample_sed", "o-"), ("iter_sed + sample_steps", "s-")):
        part = [r for r in rows if r["how"] == how]
        ax_t.plot([r["steps"] for r in part], [r["wall_s"] for r in part], marker, label=how)
        ax_m.plot([r["steps"] for r in part], [r["peak_mb"] for r in part], marker, label=how)
    ax_t.set_ylabel("wall time (s)")
    ax_m.set_ylabel("peak traced memory (MB)")
    for ax in (ax_t, ax_m):
        ax.set_xlabel(f"time steps ({rows[0]['points']:,}-node mesh)")
        ax.set_ylim(bottom=0)
        ax.legend(fontsize="small")
    names["series"] = save_figure(fig, os.path.join(folder, "series.png"))
    return {k: os.path.basename(v) for k, v in names.items()}


#: The report's sections, in order: (key, title).
SECTIONS = (("machine", "Machine and versions"), ("sampling", "Sampling method"),
            ("spiking", "Spiking engine and time step"), ("receptors", "Receptor count"),
            ("calibration", "Calibration method"), ("series", "Reading a time series"), ("headline", "Headline figures"))


def _markdown(results: dict, size: ReportSize, png: dict, command: str) -> str:
    m = results["machine"]
    v = m["versions"]
    t = results["timings"]
    out = [f"# afferent speed and accuracy report ({size.name})", "",
           f"Written by `{command}` in {results['wall_s']:.0f} s. Every figure below was measured in that run, on this "
           "machine; times are the fastest of the timed runs (wall clock). Each section states the size of its "
           "measurement and how long it took; `afferent report --full` runs the larger sizes of the benchmark "
           "scripts (`benchmarks/*.py` in the source repository).", ""]
    out += ["## Machine and versions", "",
            _table(["what", "value"], [
                ["CPUs", m["cpus"]], ["CPU model", m["cpu_model"] or "not readable"],
                ["RAM", "not readable" if m["ram_gb"] is None else f"{m['ram_gb']:.1f} GB"],
                ["platform", m["platform"]],
                *[[name, ver or "absent"] for name, ver in v.items()]]), ""]
    # sampling
    s = {r["method"]: r for r in results["sampling"]}
    out += ["## Sampling method", "",
            f"A manufactured SED (a smooth 4 kPa bump, known everywhere) on the mesh of the packaged sample "
            f"(`block4/indent_0p88mm.vtu`, {results['mesh_points']:,} nodes), sampled at {s['linear']['receptors']:,} random "
            f"sites within 0.04 mm (x, z) of the papilla tips and 0.02-0.05 mm below them; errors are relative to the exact value ({_t(t, 'sampling')}).", "",
            _table(["method", "weights (once)", "per time step", "median error", "95th pct", "max error"],
                   [[r["method"], _fmt_s(r["weights_s"]), _fmt_s(r["per_step_s"]), _fmt_rel(r["err_median"]),
                     _fmt_rel(r["err_p95"]), _fmt_rel(r["err_max"])] for r in results["sampling"]]), "",
            f"![sampling]({png['sampling']})", "",
            "`linear` (the default) interpolates in the mesh's own cells; `nearest` takes one node's value. Both "
            "locate every site once; applying the weights per step costs almost nothing either way.", ""]
    # spiking
    rows = results["spiking"]
    cf = results["closed_form"]
    out += ["## Spiking engine and time step", "",
            f"A synthetic ramp-and-hold current (ramp 100 ms, hold 500 ms, release 100 ms; plateaus 30 nA - 16 uA, "
            f"sampled every 1 ms) drives {size.spiking_afferents} afferents for {size.spiking_duration:g} s through the RA "
            "leaky integrate-and-fire preset. Errors are against `engine='exact'` (the default: event-driven, no time "
            f"step, exact spike times), rank-matched spike by spike ({_t(t, 'spiking')}).", "",
            _table(["engine", "backend", "dt", "wall time", "spikes", "rate error (median)", "rate error (max)",
                    "spike time error (median)", "count differs", "first-spike error (max)"],
                   [[r["engine"], r["backend"] or "-", "none" if r["dt_s"] is None else f"{r['dt_s'] * 1e3:g} ms",
                     _fmt_s(r["wall_s"]), r["spikes"] if r["spikes"] is not None else "-",
                     *(["skipped: " + r["skipped"], "", "", "", ""] if "skipped" in r else
                       [_fmt_rel(r["rate_err_median"]), _fmt_rel(r["rate_err_max"]), _fmt_s(r["spike_err_median_s"]),
                        _fmt_rel(r["count_differs"]), _fmt_s(r["latency_err_max_s"])])] for r in rows]), "",
            f"![spiking]({png['spiking']})", "",
            f"Check against the closed form: a constant current of 3 rheobases ({cf['current_a'] * 1e9:.3g} nA) fires at "
            f"{cf['closed_form_hz']:.3f} Hz; the exact engine gives {cf['exact_hz']:.3f} Hz over 1 s (a whole number of "
            "spikes). The grid engines' errors fall about in proportion to dt; `fast` and `brian2` give the same spikes "
            "on the same grid.", ""]
    # receptors
    rows = results["receptors"]
    out += ["## Receptor count", "",
            f"The 1.32 mm indenter (`block4/indent_1p32mm.vtu`), k receptors per papilla tip spread along the ridge "
            f"over +-0.04 mm of the tip (119 tips), longitudinal synthesis with the study's start parameters; errors "
            f"of each longitudinal profile (mean current per receptor) against {rows[-1]['per_papilla']} per papilla "
            f"({_t(t, 'receptors')}).", "",
            _table(["per papilla", "receptors", "sampling", "transduction + synthesis", "normalised profile error",
                    "current error"],
                   [[r["per_papilla"], r["receptors"], _fmt_s(r["sampling_s"]), _fmt_s(r["transduce_synthesize_s"]),
                     _fmt_rel(r["profile_error"]), _fmt_rel(r["current_error"])] for r in rows]), "",
            f"![receptors]({png['receptors']})", ""]
    # calibration
    rows = results["calibration"]
    out += ["## Calibration method", "",
            "Noise-free longitudinal profiles of known parameters (alpha 3e-8 A) on the SED of the 1.32 mm indenter at "
            "the 119 receptors, fitted from the study's start parameters, compared min-max normalised (`both`: gamma "
            f"and lambda fitted) and un-normalised (`neither`: alpha too) ({_t(t, 'calibration')}).", "",
            _table(["profile", "normalise", "method", "evaluations", "Jacobians", "time", "status", "error alpha",
                    "error gamma", "error lambda"],
                   [[r["truth"], r["normalise"], r["method"], r["evaluations"], r["jacobian_evaluations"],
                     _fmt_s(r["time_s"]), r["status"], _fmt_rel(r["err_alpha"]), _fmt_rel(r["err_gamma"]),
                     _fmt_rel(r["err_lambda"])] for r in rows]), "",
            f"![calibration]({png['calibration']})", "",
            "RSM (the study's procedure) stops where its linear or quadratic surface stops improving: its profile "
            "matches closely (small ssd) but gamma and lambda can sit elsewhere on the ridge along which the profile "
            "barely changes. Least squares with the closed-form Jacobian (the default `least_squares`) reaches the known "
            "parameters to rounding in the fewest evaluations; the 2-point, 4-start variant is the same fit without "
            "the Jacobian.", ""]
    # series
    rows = results["series"]
    out += ["## Reading a time series", "",
            f"A generated series of binary, zlib-compressed VTUs ({rows[0]['points']:,}-node hexahedral block, "
            f"{', '.join(str(n) for n in size.series_steps)} steps) sampled at 150 receptors: read whole then sampled, "
            f"against streamed one step at a time ({_t(t, 'series')}). Memory: peak of Python-level allocations "
            "(tracemalloc).", "",
            _table(["how", "steps", "wall time", "peak memory", "max difference"],
                   [[r["how"], r["steps"], _fmt_s(r["wall_s"]), f"{r['peak_mb']:.1f} MB", f"{r['max_diff_pa']:.2g} Pa"]
                    for r in rows]), "",
            f"![series]({png['series']})", ""]
    h = results["headline"]
    lines = [f"- sampling error, max (median): linear {_fmt_rel(h['linear_err_max'])} ({_fmt_rel(h['linear_err_median'])}), "
             f"nearest {_fmt_rel(h['nearest_err_max'])} ({_fmt_rel(h['nearest_err_median'])})",
             f"- spiking, {size.spiking_afferents} afferents x {size.spiking_duration:g} s: exact {_fmt_s(h['exact_wall_s'])}"
             + "".join(f"; fast at {dt:g} ms {_fmt_s(h[f'fast_{dt / 1e3:g}_wall_s'])}, rate error "
                       f"{_fmt_rel(h[f'fast_{dt / 1e3:g}_rate_err'])}" for dt in (1, 0.1, 0.01)
                       if f"fast_{dt / 1e3:g}_wall_s" in h)
             + "".join(f"; brian2 at {dt:g} ms {_fmt_s(h[f'brian2_{dt / 1e3:g}_wall_s'])}" for dt in (1, 0.1)
                       if f"brian2_{dt / 1e3:g}_wall_s" in h),
             f"- calibration (normalised, noise-free): rsm1 up to {h['rsm1_evaluations']} evaluations, parameter error up "
             f"to {_fmt_rel(h['rsm1_err_max'])}; least_squares up to {h['least_squares_evaluations']} evaluations, "
             f"error up to {_fmt_rel(h['least_squares_err_max'])}"]
    ser = {(r["how"], r["steps"]): r for r in results["series"]}
    n = max(size.series_steps)
    lines.append(f"- series of {n} steps: read whole {ser['read_sed + sample_sed', n]['peak_mb']:.0f} MB, streamed "
                 f"{ser['iter_sed + sample_steps', n]['peak_mb']:.0f} MB peak")
    out += ["## Headline figures", "", *lines, ""]
    return "\n".join(out)


def _t(timings: dict, key: str) -> str:
    return f"measured in {timings[key]:.1f} s"


def run_report(output, *, size: str | ReportSize = "quick", overwrite: bool = False, command: str | None = None,
               progress=None) -> dict:
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

    from ._output import atomic_dir, check_writable
    from .export import jsonable

    if isinstance(size, str):
        if size not in SIZES:
            raise ValueError(f"'size' must be one of {sorted(SIZES)}; got {size!r} instead.")
        size = SIZES[size]
    output = os.fspath(output)
    check_writable(output, overwrite=overwrite, what="Output folder")  # before minutes of measuring
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
