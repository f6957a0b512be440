"""The measurements of :mod:`afferent.report`: one function per knob, the report's sizes, the machine."""

from __future__ import annotations

import os
import platform
import time
import tracemalloc
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._typing import PathLike, RngLike
from ..field import SEDField
from ..profiles import Normalise
from ..receptors._layout import ReceptorLayout
from ..sampling import ReceptorSED, SamplingMethod
from ..spiking._params import LIFParams
from ..spiking._trains import SpikeTrains
from ..transduction import SigmoidParams

__all__ = ["SIZES", "ReportSize", "machine_info", "best_time", "hex_block", "manufactured_sed", "papilla_sites",
           "measure_sampling", "synthetic_afferent_current", "spike_errors", "measure_spiking",
           "per_papilla_layout", "measure_receptor_count", "CALIBRATION_METHODS", "CALIBRATION_TRUTHS", "measure_calibration",
           "block_dims", "write_series", "measure_series"]

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
    from .. import __version__

    ram = _ram_bytes()
    versions = {"python": platform.python_version()}
    versions.update({name: _version(name) for name in ("numpy", "scipy", "brian2", "numba", "matplotlib")})
    versions["afferent"] = __version__
    return {"cpus": os.cpu_count(), "cpu_model": _cpu_model(), "ram_gb": None if ram is None else ram / 1e9,
            "platform": platform.platform(), "versions": versions}


def best_time(fn: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    """Run ``fn()`` ``repeat`` times; returns (fastest wall time in s, the last result)."""
    best, out = np.inf, None
    for _ in range(max(1, int(repeat))):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _sample_dir() -> Path:
    from ..cli._demo import packaged_sample_dir

    return packaged_sample_dir()


def _read_sample(name: str):
    from ..io import read_sed
    from ..receptors import read_receptors

    block = _sample_dir() / "block4"
    return (read_sed(str(block / name), length_unit="mm", sed_unit="MPa"),
            read_receptors(block / "receptors.csv", length_unit="mm"))


# ---- sampling --------------------------------------------------------------------------------

def manufactured_sed(points: np.ndarray) -> np.ndarray:
    """A smooth manufactured SED in Pa at ``points`` (m): a 4 kPa bump, 0.5 mm standard width,
    centred at x = z = 2 mm and decaying with depth below y = 2.45 mm over 0.5 mm (the size and
    scale of the sample's field at the receptors, but known everywhere)."""
    x, y, z = (np.asarray(points, dtype=float) * 1e3).T
    return 4000.0 * np.exp(-((x - 2) ** 2 + (z - 2) ** 2) / (2 * 0.5**2)) * np.exp((y - 2.45) / 0.5)


def papilla_sites(layout: ReceptorLayout, n: int, *, rng: RngLike=0) -> np.ndarray:
    """``n`` random sites (m) inside the sample's mesh: each within +-0.04 mm in x and z of a
    random papilla tip of ``layout`` and 0.02-0.05 mm below it (the packaged sample keeps the
    elements around each tip; these offsets stay inside them at every tip, measured)."""
    rng = np.random.default_rng(rng)
    tips = layout.positions[rng.integers(0, layout.n_receptors, n)]
    lo = np.array([-PATCH_HALF_WIDTH, -0.05e-3, -PATCH_HALF_WIDTH])
    hi = np.array([PATCH_HALF_WIDTH, -0.02e-3, PATCH_HALF_WIDTH])
    return tips + rng.uniform(lo, hi, (n, 3))


def measure_sampling(field: SEDField, layout: ReceptorLayout, exact: np.ndarray, *, methods: Sequence[SamplingMethod]=("linear", "nearest"), repeat: int = 3) -> list[dict]:
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
    from ..sampling import build_sampler

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

def synthetic_afferent_current(n_afferents: int, *, duration: float = 1.0, sample_dt: float = 1e-3, rng: RngLike=0) -> tuple[np.ndarray, np.ndarray]:
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


def spike_errors(trains: SpikeTrains, ref: SpikeTrains) -> dict:
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
    from ..spiking._brian2 import import_brian2

    try:
        import_brian2()
    except Exception:  # noqa: BLE001 - brian2 can fail to import in several ways (numpy too new)
        return False
    return True


def measure_spiking(current: np.ndarray, times: np.ndarray, duration: float, params: LIFParams, *, fast_dts: Sequence[float]=(1e-3, 1e-4, 1e-5), brian2_dts: Sequence[float]=(1e-3,),
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
    from ..spiking import simulate_lif

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

def per_papilla_layout(tips: ReceptorLayout, k: int) -> ReceptorLayout:
    """``k`` receptor sites per papilla tip, spread along the ridges (z) over +-0.04 mm of the tip
    (one site: the tip itself); each keeps its tip's section labels. Positions in m."""

    dz = np.linspace(-PATCH_HALF_WIDTH, PATCH_HALF_WIDTH, k) if k > 1 else np.zeros(1)
    pos = np.repeat(tips.positions, k, axis=0)
    pos[:, 2] += np.tile(dz, tips.n_receptors)
    return ReceptorLayout(pos, longitudinal=np.repeat(tips.longitudinal, k), cross=np.repeat(tips.cross, k))


def measure_receptor_count(field: SEDField, tips: ReceptorLayout, per_papilla: Sequence[int]=(1, 2, 4, 8, 16), *, params: SigmoidParams | None=None, repeat: int = 3) -> list[dict]:
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
    from ..profiles import minmax_normalise
    from ..sampling import sample_sed
    from ..synthesis import Branching, synthesize
    from ..transduction import STUDY_PARAMS, transduce

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


def measure_calibration(sed: ReceptorSED, truths: Sequence[tuple[float, float, float]]=CALIBRATION_TRUTHS, *, methods: dict | None=None, normalise: Sequence[Normalise]=("both", "neither"),
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
    from ..calibration import calibrate
    from ..profiles import ObservedProfile
    from ..synthesis import Branching, synthesize
    from ..transduction import transduce

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

def hex_block(nx: int, ny: int, nz: int, size: tuple[float, float, float]=(4.0, 3.1, 4.0)) -> tuple[np.ndarray, np.ndarray]:
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


def block_dims(n_points: int, size: tuple[float, float, float]=(4.0, 3.1, 4.0)) -> tuple[int, int, int]:
    """Cells per side (nx, ny, nz) of a block of ``size`` with about ``n_points`` nodes, cubic cells."""
    n = (n_points / float(np.prod(size))) ** (1 / 3)
    return tuple(max(2, round(n * s)) - 1 for s in size)


def write_series(folder: PathLike, n_points: int, n_steps: int) -> list[str]:
    """Write a loading series of binary, zlib-compressed VTUs of a 4 x 3.1 x 4 mm hexahedral
    block of about ``n_points`` nodes (coordinates mm, SED MPa): step k carries
    (k + 1) / n_steps x the manufactured field of :func:`manufactured_sed` (centred on the block).

    meshio writes the first file; the others are that file with its SED array's text replaced by
    the step's, encoded as meshio encodes it (the mesh, 92 % of the bytes, is compressed once
    instead of once per step): the same bytes as ``meshio.write`` of each step, about ten times
    sooner. When meshio's text of the first step is not what ``_zlib_text`` gives (another
    meshio), every step is written by meshio."""
    import meshio

    points, hexes = hex_block(*block_dims(n_points))
    base = manufactured_sed(points * 1e-3 + [0.0, 2.45e-3 - 3.1e-3, 0.0]) / 1e6
    paths = [os.path.join(folder, f"step_{k:03d}.vtu") for k in range(n_steps)]
    values = [(k + 1) / n_steps * base for k in range(n_steps)]
    first, head, tail = None, "", ""
    for k, (path, sed) in enumerate(zip(paths, values)):
        if first is not None:
            with open(path, "w", encoding="ascii") as f:
                f.write(head + _zlib_text(sed) + tail)
            continue
        meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}),
                     binary=True, compression="zlib")
        if k == 0:
            with open(path, encoding="ascii") as f:
                text = f.read()
            first = _zlib_text(sed)
            if text.count(first) == 1:
                head, tail = text.split(first)
            else:
                first = None
    return paths


def _zlib_text(data: np.ndarray) -> str:
    """The text of a binary DataArray as meshio (5.x) writes it with zlib: base64 of the UInt32
    header (block count, block size 32768 bytes, last block's size, compressed sizes), then of
    the zlib blocks."""
    import base64
    import zlib

    raw, size = np.ascontiguousarray(data).tobytes(), 32768
    blocks = [zlib.compress(raw[i:i + size]) for i in range(0, len(raw), size)]
    header = np.array([len(blocks), size, len(raw) - (len(blocks) - 1) * size] + [len(b) for b in blocks], np.uint32)
    return base64.b64encode(header.tobytes()).decode() + base64.b64encode(b"".join(blocks)).decode()


def measure_series(paths: Sequence[str], layout: ReceptorLayout, *, repeat: int = 1) -> list[dict]:
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
    from ..io import iter_sed, read_sed
    from ..sampling import sample_sed, sample_steps

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
