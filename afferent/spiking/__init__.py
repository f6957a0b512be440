"""Stage 6: afferent current -> spike trains, through a leaky integrate-and-fire neuron.

::

    AfferentCurrent (n_times, n_afferents) A --simulate_lif--> SpikeTrains (spike times in s)

The model (see the Spikes page of the documentation, docs/spikes.md), one neuron per afferent::

    tau_m dV/dt = -(V - v_rest) + r_m I(t);   V >= v_thresh -> spike, V <- v_reset,
                                               V held at v_reset for t_ref

The input current is known only at its samples. Between samples it is held (the sample
stays in force until the next one, like a brian2 ``TimedArray``; ``input_hold='previous'``,
all engines) or, with the exact engine only, interpolated linearly (``input_hold='linear'``).

Three engines:

``'exact'`` (what ``'auto'`` picks)
    Event-driven: it jumps from sample to sample and from spike to spike, with no time step.
    With the input held over a piece ``[t_k, t_k+1)``, V is the closed-form exponential
    ``V(t) - v_rest = D + (V_0 - v_rest - D) exp(-(t - t_0) / tau_m)``, ``D = r_m I_k``, and it
    reaches threshold (``theta = v_thresh - v_rest``) iff ``D > theta`` and the value at the end
    of the piece is ``>= theta``, at ``t_0 + T(V_0)``,
    ``T(V_0) = tau_m ln((D - (V_0 - v_rest)) / (D - theta))``. After a spike V is held at
    ``v_reset`` for exactly ``t_ref`` and integration resumes there, also in the middle of a
    piece. Spike times are exact to floating-point rounding (the log and exp of one
    crossing, ~1e-15 relative). With a linear input V is still in closed form,
    ``D_a + s y - s tau_m + (V_0 - v_rest - D_a + s tau_m) exp(-y / tau_m)`` at ``y`` after
    ``t`` for a drive ``D_a + s y``, but the crossing is not: it is bracketed in closed form
    (V - v_thresh is convex or concave in time, so it has a single upward crossing in a
    bracket that ends at the piece's end or at the maximum of V) and found by Newton's method
    started on the side from which it converges monotonically. The cost is one pass over the
    samples plus at most a log per spike (a steady drive firing again and again from
    ``v_reset`` reuses the last one): numba, a dependency, its kernel compiled once and cached
    on disk (one afferent at a time, the afferents split in blocks over one thread per core,
    with identical results) when the run repays its load (the numpy loop estimated above
    :data:`NUMBA_FROM_S`, decided by the workload alone so that a scene's bytes do not depend on
    what else the process imported: importing numba and loading the cached kernel costs
    0.4-1 s, more than a small scene's whole simulation), else numpy
    (``'exact-numba'`` / ``'exact-numpy'`` force a back end; the two agree to ~1e-13 s, to a
    few ps where the drive is barely above threshold; the result's ``backend`` says which ran). The spikes come back flat, as brian2's
    ``SpikeMonitor`` gives them (``SpikeTrains.t``, ``SpikeTrains.i``), with
    per-afferent views on demand.
``'fast'``
    Exact exponential integration per step of a clock grid ``dt``, vectorised over afferents
    with a loop over time steps: numba when it is installed (``pip install
    'afferent-skin[fast]'``), else numpy. Both back ends evaluate brian2's own update
    expression in brian2's order of floating-point operations, so they reproduce brian2 bit
    for bit. ``'fast-numba'`` and ``'fast-numpy'`` force a back end.
``'brian2'``
    The grid reference: a :class:`brian2.NeuronGroup` with the input as a
    :class:`brian2.TimedArray`, ``method='exact'``, threshold / reset / refractory, run in an
    explicit :class:`brian2.Network`. This is the only place in :mod:`afferent` that imports
    brian2, and it does so inside the engine function, so ``import afferent.spiking`` stays
    fast. Code is generated for brian2's ``numpy`` target *per object*
    (``codeobj_class=NumpyCodeObject`` on the group and the monitor), so nothing is compiled
    and brian2's global ``prefs.codegen.target`` is never touched.

The grid engines give the **same spikes, step for step**, and converge to the exact engine as
``dt`` shrinks, within the bounds below. What the grid costs (ramp-and-hold, 1 ms samples,
RA preset; ``benchmarks/bench_spiking.py``): median rate error 30 % at dt = 1 ms, 2.9 % at
0.1 ms, 0.2 % at 0.01 ms, and spike times that drift by milliseconds over a second, because
every interval is shortened by up to a step. The exact engine has no such error and costs
about as much as the fast engine at dt = 0.1 ms.

Grid semantics (those of brian2, which both grid engines follow)
----------------------------------------------------------------
Step ``i`` covers ``[t_i, t_i + dt)`` with ``t_i = t_start + i dt``. In step ``i``:

1. the input is the current sample active at ``t_i`` (held constant over the step, like a
   ``TimedArray``);
2. unless refractory, V is advanced exactly over ``dt``:
   ``V <- v_rest + (r_m I + E V) + E (-v_rest - r_m I)`` with ``E = exp(-dt / tau_m)``;
3. if ``V >= v_thresh`` (and not refractory) a spike is stamped at ``t_i`` - the *start* of
   the step in which the crossing happened - and V is set to ``v_reset``;
4. a neuron that spiked in step ``k`` is refractory (V held, threshold off) while
   ``i - k < n_ref``, ``n_ref = floor(t_ref / dt + 1e-3)`` (brian2's ``timestep()``).

Accuracy on the grid (derived for a constant current I, ``theta = v_thresh - v_rest``)
--------------------------------------------------------------------------------------
Let ``T(V0) = tau_m ln((r_m I - (V0 - v_rest)) / (r_m I - theta))`` be the exact time to
threshold from ``V0`` (what the exact engine computes) and ``n_eff = max(n_ref, 1)``. Integration from
V0 needs ``m = ceil(T(V0) / dt)`` steps, and the spike is stamped at the start of the last
one, so

* first spike (from rest): ``t_1 = (m_0 - 1) dt``, i.e. ``T(v_rest) - dt <= t_1 < T(v_rest)``;
* every inter-spike interval: ``ISI_grid = (n_eff - 1 + ceil(T(v_reset) / dt)) dt``, i.e.
  ``(n_eff - 1) dt + T_r <= ISI_grid < (n_eff - 1) dt + T_r + dt`` (see
  :func:`grid_isi_bounds`).

Against the continuous ``ISI = t_ref + T(v_reset)`` this gives
``ISI - 2 dt < ISI_grid < ISI + dt``, and ``ISI - dt <= ISI_grid < ISI`` when ``t_ref`` is a
nonzero multiple of ``dt``: the grid then *shortens* intervals by up to one step (the spike
is stamped early, and refractoriness counts from that stamp), it does not lengthen them.
(With ``t_ref < dt`` the neuron integrates again in the very next step and
``ISI_grid - ISI`` lies in ``(-dt, dt)``.) The steady rate
``1 / ISI_grid`` therefore obeys ``1 / (ISI + dt) < rate_grid < 1 / (ISI - 2 dt)``.

Default parameter sets (:data:`LIF_PRESETS`)
--------------------------------------------
``'ra'`` - RA-like. ``tau_m = 4.47 ms`` from the median membrane constant of the nine RA
afferents fitted in TouchSim (Saal et al. 2017, PNAS 114:E5693; ``hsaal/touchsim``,
``touchsim/constants.py``: parameter 9 of ``affparamsRA`` = 17.1-44.9 samples at 5 kHz,
median 22.87, used as ``V += -V / tau + I`` per 0.2 ms sample in ``touchsim/transduction.py``;
a decay by ``1 - 1/22.87`` per sample is ``exp(-0.2 ms / 4.47 ms)``). ``t_ref = 1.2 ms`` is
TouchSim's hard minimum ISI (a spike is allowed once 6 samples at 5 kHz have passed; TouchSim
also has a post-spike current, which this model does not). TouchSim's IF is dimensionless
(threshold 1, reset 0), so the voltages are the conventional -70 / -50 / -70 mV, and
**r_m = 200 kOhm is illustrative**, not physiological: it puts the rheobase ``theta / r_m`` at
100 nA inside the study's own current range. That range, from the study's sigmoid
parameters and receptor counts (see the Spikes page of the documentation, docs/spikes.md): with the start parameters (alpha = 2.46e-8 A) the receptors sit at 0.20-0.38 alpha =
4.9-9.3 nA, and 9-17 receptors per afferent give 44-160 nA per afferent (silent to 1.6x
rheobase, up to ~180 Hz); the longitudinal fit (alpha = 9.29e-7 A, saturated) gives
8.4-15.8 uA per afferent (84-158x rheobase, ~800 Hz, near the 1 / t_ref = 833 Hz ceiling).
The study's currents are not physiological (real receptor currents are pA-nA), so neither is
this resistance.

``'sa1'`` - SA-I skin-neuron model values from the public Gerling-lab model code
(``yw5aj/PlosCompBiol``, ``model_constants.py``, the mouse SA-I model with Merkel-cell groups
[8, 5, 3, 1] per heminode, the model line of Lesniak & Gerling 2009, Math Biosci 220:15, and
Lesniak et al. 2014, eLife 3:e01488): ``LIF_PARAMS = [30 mV threshold, 30 pF, 5 GOhm]`` from
commit 7c55d9b (25 Feb 2016) to the last (27fec46), with the earlier 1.667 GOhm of the
versions before it (10-20 Feb 2016) commented out; ``REFRACTORY_PERIOD = 1 ms``; voltages
measured from rest (V_rest = V_reset = 0). So ``tau_m = R C = 150 ms`` and the rheobase is 6 pA. These
values were read from that code, not checked against the papers' tables. With the study's
currents (>= 10 nA) every afferent would sit at the 1 / t_ref ceiling: this set expects
pA-scale generator currents. The SA-I afferent class (:mod:`afferent.classes`) uses it with
the rheobase drive (the Afferent classes page, docs/classes.md).

Where the parts live: :func:`simulate_lif` and :data:`ENGINES` here; ``_params.py`` the
parameters, presets and brian2's step arithmetic; ``_input.py`` reading the current;
``_grid.py`` the grid engines ('fast', 'brian2'); ``_exact.py`` the exact engine;
``_group.py`` grouping spikes by afferent; ``_trains.py`` :class:`SpikeTrains`; ``_drive.py``
the drive mapping (:func:`rheobase_scale`, :func:`drive_report`) and :func:`spike_afferents`
(input current, drive mapping, LIF: the stages 'input' and 'spiking' of a run). Every public name is
importable from :mod:`afferent.spiking`.
"""

from __future__ import annotations

from ..synthesis import AfferentCurrent
from ..zones import Zones

from .._typing import ArrayLike

from typing import get_args

import numpy as np

from .._validation import check_option
from . import _drive, _params
from ._drive import CEILING_FRACTION, drive_report, rheobase_scale  # noqa: F401 (CEILING_FRACTION: importable here)
from ._drive import INPUTS, DriveMapping, SpikeStage, spike_afferents  # noqa: F401 (DriveMapping: importable here)
from ._exact import _pieces, _run_exact_numba, _run_exact_numpy, _used_peak
from ._grid import _peak_current, _plan, _run_brian2, _run_numba, _run_numpy, _silent
from ._group import _numba_available
from ._params import _MAX_DRIVE_V, Engine, InputHold, LIFParams, _refractory_steps, grid_isi_bounds
from ._trains import SpikeTrains, spread_counts
from ._zones import simulate_zones

__all__ = [
    "LIFParams",
    "LIF_PRESETS",
    "SpikeTrains",
    "simulate_lif",
    "grid_isi_bounds",
    "ENGINES",
    "INPUT_HOLDS",
    "NUMBA_FROM_S",
    "DRIVE_MAPPINGS",
    "rheobase_scale",
    "drive_report",
    "spike_afferents",
    "SpikeStage",
    "INPUTS",
]

#: Documented default parameter sets; see the module docstring for the sources.
#:
#: * ``'ra'``: RA-like, tau_m and t_ref from TouchSim's RA fits; r_m illustrative (rheobase 100 nA
#:   inside the study's current range).
#: * ``'sa1'``: SA-I skin-neuron model values from Gerling-lab model code (30 mV, 30 pF, 5 GOhm, 1 ms).
LIF_PRESETS: dict[str, LIFParams] = _params.LIF_PRESETS
#: How an input current (A) becomes the membrane drive ``r_m I`` (V) of the LIF:
#:
#: * ``'resistance'``: as is, through the preset's ``r_m`` (V = r_m I). The study's currents are
#:   not physiological (its longitudinal fit gives 8-16 uA per afferent), so with a fixed r_m the
#:   drive can be hundreds of rheobases and every afferent sits at 1 / t_ref.
#: * ``'rheobase'``: the current is rescaled so that a reference current (the largest input
#:   current of the run, or a stated one) is ``multiple`` x the rheobase; the pattern across
#:   afferents and time is kept, the absolute level is a declared modelling choice.
DRIVE_MAPPINGS = _drive.DRIVE_MAPPINGS

#: Engines accepted by :func:`simulate_lif`.
ENGINES: tuple[str, ...] = get_args(Engine)
#: How :func:`simulate_lif` reads the current between samples: ``'previous'`` holds each sample
#: until the next (like brian2's ``TimedArray``; all engines), ``'linear'`` interpolates
#: linearly between samples (the exact engine only).
INPUT_HOLDS: tuple[str, ...] = get_args(InputHold)


# --------------------------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------------------------


def _check_drive(extremes: tuple, params: LIFParams) -> None:
    """``extremes``: (smallest, largest) current of each afferent, A."""
    if not extremes[0].size:
        return
    peak = max(float(extremes[1].max()), -float(extremes[0].min()))
    if not peak * params.r_m < _MAX_DRIVE_V:
        worst = peak * params.r_m
        raise ValueError(
            f"r_m * max|current| must be < {_MAX_DRIVE_V:g} V for the update to stay finite; got {worst:g} V instead."
        )


#: The exact engine's ``'exact'`` (``'auto'``) back end is numba only when the numpy loop is
#: estimated to take longer than this (s), whether or not numba is imported already (the two
#: back ends agree to the last bits or two of a spike time, not bit for bit: the choice must
#: not depend on what else the process imported, or one scene would give two sets of bytes): a fresh ``import
#: numba`` plus loading the cached compiled loop costs 0.4-1 s on the development machine,
#: while the numpy loop costs about 10 us per input sample plus 50 ns per sample and afferent
#: (measured: 23,000 samples x 3 afferents 0.22 s; 1,001 x 12,500 ramp-and-hold, 3.7 M spikes,
#: 0.63-0.65 s CPU against 0.17 s on numba plus 0.54 s to import it and load its kernel).
NUMBA_FROM_S = 0.5


def _numba_repays(n_pieces: int, n_afferents: int) -> bool:
    """Whether ``'exact'`` should run on numba: installed, and the workload worth its import."""
    import importlib.util

    # find_spec, not an import: importing is the cost being avoided
    return n_pieces * (1e-5 + 5e-8 * n_afferents) > NUMBA_FROM_S and importlib.util.find_spec("numba") is not None


def _check_isi_resolution(params: LIFParams, peak: np.ndarray, pc) -> None:
    """Every interval is >= t_ref + (time from v_reset to threshold under the ``peak`` drive, A): it
    must stay resolvable in double precision over the window, or spikes would pile up at one time."""
    isi_min = float(np.min(params.steady_isi(peak)))
    resolution = 8 * np.spacing(max(abs(pc.t_start), abs(pc.t_stop)))
    if not isi_min > resolution:
        raise ValueError(
            f"The exact engine cannot resolve the inter-spike interval: t_ref + the time from v_reset to threshold "
            f"at the peak drive is {isi_min:.3g} s, at or below the time resolution {resolution:.3g} s of the "
            f"window [{pc.t_start!r}, {pc.t_stop!r}] s; got t_ref = {params.t_ref!r} s. Give t_ref > 0 or a "
            "smaller current."
        )


def _simulate_exact(current, params: LIFParams, *, dt, engine: str, duration, times, hold: str) -> SpikeTrains:
    """The exact engine behind :func:`simulate_lif` (``engine`` 'exact', 'exact-numba', 'exact-numpy')."""
    if engine == "exact":
        backend = None  # chosen below, from the size of the run
    elif engine == "exact-numba":
        if not _numba_available():
            raise ImportError(
                "engine='exact-numba' needs numba, which is not installed. "
                "Install it with pip install 'afferent-skin[fast]', or use engine='exact'."
            )
        backend = "numba"
    else:
        backend = "numpy"
    pc = _pieces(current, dt, duration, times, params.tau_m, hold)
    n_aff = pc.values.shape[1]
    if backend is None:
        backend = "numba" if _numba_repays(pc.starts.size, n_aff) else "numpy"
    _check_drive(pc.extremes, params)
    peak = _used_peak(pc, hold)
    # The exact engine fires only where the drive exceeds theta: no rounding margin needed.
    silent = params.r_m * peak <= params.theta
    cols = np.flatnonzero(~silent)
    if cols.size:
        _check_isi_resolution(params, peak[cols], pc)
    if cols.size == 0:
        times_s, counts = np.empty(0), np.zeros(0, np.int64)
    elif backend == "numba":
        times_s, counts = _run_exact_numba(pc, cols, params, peak[cols])
    else:
        times_s, counts = _run_exact_numpy(pc, cols, params)
    return SpikeTrains(
        t=times_s,
        counts=spread_counts(counts, cols, n_aff),
        afferent_ids=pc.afferent_ids,
        duration=pc.t_stop - pc.t_start,
        dt=0.0,
        engine="exact",
        backend=backend,
        silent_skipped=np.flatnonzero(silent),
        params=params,
        t_start=pc.t_start,
        notes=tuple(pc.notes),
    )


def _warn_above_ceiling(times_s: np.ndarray, counts: np.ndarray, params: LIFParams, plan) -> None:
    """Warn (and note in ``plan.notes``) when a grid engine put two spikes ``t_ref`` (s) apart or closer.

    The continuous interval is ``t_ref + T(v_reset) > t_ref``, so a continuous LIF fires below the
    1 / t_ref ceiling (Hz). On a grid of step dt the interval can be up to 2 dt shorter
    (:func:`grid_isi_bounds`): driven hard, a grid neuron reaches or passes the ceiling (the
    ``ra`` preset at dt = 0.1 ms: exactly 1/t_ref = 833 Hz); the exact engine never does.
    """
    if params.t_ref <= 0 or times_s.size < 2:
        return
    gaps = np.diff(times_s)  # the spikes of each simulated afferent in turn (``counts`` of them): drop the gaps
    within = np.ones(gaps.size, dtype=bool)  # between one afferent's last spike and the next one's first
    last = np.cumsum(counts)[:-1] - 1
    within[last[(last >= 0) & (last < gaps.size)]] = False
    shortest = float(gaps[within].min()) if within.any() else np.inf
    if shortest <= params.t_ref * (1.0 + 1e-9):
        import warnings

        from ..exceptions import AfferentWarning

        msg = (f"The grid engine at dt = {plan.dt:g} s fired at up to {1.0 / shortest:.4g} Hz, at or above the 1/t_ref "
               f"ceiling of {1.0 / params.t_ref:.4g} Hz that a continuous LIF never reaches (shortest interval "
               f"{shortest:.4g} s <= t_ref = {params.t_ref:g} s, where the continuous interval is t_ref + the time from v_reset "
               "to threshold): the time step shortens intervals by up to 2 dt. "
               "Use engine='exact' or a smaller dt.")
        plan.notes.append(msg)
        warnings.warn(msg, AfferentWarning, stacklevel=3)


def simulate_lif(current: AfferentCurrent | ArrayLike, params: LIFParams, *, dt: float | None = None, engine: Engine = "auto", duration: float | None=None, times: ArrayLike | None=None,
                 input_hold: InputHold = "previous", zones: Zones | ArrayLike | None=None) -> SpikeTrains:
    """Simulate one leaky integrate-and-fire neuron per afferent.

    Parameters
    ----------
    current : AfferentCurrent or ndarray of shape (n_times, n_afferents)
        Afferent current in A. An object with ``values`` (n_times, n_afferents) in A and
        ``times`` (n_times,) in s (an :class:`afferent.synthesis.AfferentCurrent`) is used
        with its own times and, if it has them, its ``afferent_ids``; if its ``times`` is
        ``None`` it is treated like an ndarray. An ndarray is taken as sampled every ``dt``
        from t = 0 unless ``times`` is given. Between samples the current follows
        ``input_hold``; after the last sample the last is held.
    params : LIFParams
        Neuron parameters (see :data:`LIF_PRESETS`).
    dt : float, optional
        Grid engines (``'fast'``, ``'brian2'``): the simulation time step in s, required. Input
        sample times are put on this grid (a sample counts from the first step at or after its
        time). The exact engine has no time step: there ``dt`` is only the sample interval of
        an ndarray current given without ``times`` (sample k at ``k dt``) and is otherwise
        ignored (validated, not used).
    engine : {'auto', 'exact', 'exact-numba', 'exact-numpy', 'fast', 'fast-numba', 'fast-numpy', 'brian2'}
        ``'auto'`` (default) means ``'exact'``: event-driven, exact spike times (numba if
        installed and the run is large enough to repay importing it, see the module
        docstring; else numpy). ``'brian2'`` is the grid reference; ``'fast'`` gives the same
        spikes on the same grid, using numba if installed, else numpy.
    duration : float, optional
        Simulated time in s from the first sample time. Default: up to one sample interval
        after the last sample (``n_times * dt`` for an ndarray; a single sample with known
        times lasts ``dt``). Grid engines round it to whole steps; the exact engine simulates
        ``[t_start, t_start + duration)`` as given and reports no spike at or after its end.
    times : ndarray of shape (n_times,), optional
        Sample times in s of an ndarray ``current``, strictly increasing.
    input_hold : {'previous', 'linear'}, default='previous'
        The current between samples: each sample held until the next (brian2's ``TimedArray``;
        all engines), or linear from each sample to the next (exact engine only; a grid engine
        refuses it).
    zones : afferent.zones.Zones or array_like of int, optional
        The ``zones`` branching model (:ref:`spikes-zones`): the columns of ``current`` are
        spike-initiation zones, ``zones`` gives each column's afferent (a :class:`afferent.zones.Zones`,
        whose ``afferent`` and ``afferent_ids`` are used, or one afferent index per column,
        non-decreasing). Each zone integrates its own current in its own LIF; an afferent
        fires when any of its zones reaches threshold, and all its zones reset and share the
        refractory period. Every engine: the exact one on numba or, with ``'exact-numpy'``,
        plain Python; the fast one on numpy; brian2 with a ``Synapses`` resetting the afferent's
        other zones (the fast engine's spikes, step for step). Default None: one LIF per column
        (the ``sum`` model).

    Returns
    -------
    SpikeTrains
        Spike times per afferent, with the engine used and the afferents skipped as silent
        (with ``zones``: per afferent, silent when all its zones are).

    Raises
    ------
    TypeError
        If ``current`` is not numeric or a parameter has the wrong type.
    ValueError
        If a shape, a time or a parameter value is invalid, ``r_m * |current|`` would
        overflow, a grid engine is given no ``dt``, a ``dt`` not below the duration (a grid of one
        step) or ``input_hold='linear'``, or (exact
        engine) the intervals between spikes would fall below the time resolution of the
        window (``t_ref = 0`` with an enormous drive).
    ImportError
        If ``engine`` is ``'fast-numba'`` or ``'exact-numba'`` and numba is not installed.

    See Also
    --------
    afferent.synthesis.synthesize : produces the AfferentCurrent.
    LIFParams.steady_rate : closed-form rate for a constant current.
    grid_isi_bounds : how far the grid engines can be from the closed form.

    Notes
    -----
    Afferents whose current never drives V past threshold over the window (``r_m max(I) <=
    v_thresh - v_rest``; the grid engines keep a margin of a few rounding errors) are provably
    silent and are not simulated; they are listed in ``SpikeTrains.silent_skipped``. Only
    ``duration`` is simulated.

    Examples
    --------
    >>> import numpy as np
    >>> p = LIF_PRESETS["ra"]
    >>> current = np.array([[0.0, 5e-8, 2e-7]]).repeat(20, axis=0)   # 20 ms sampled every 1 ms
    >>> trains = simulate_lif(current, p, dt=1e-3)
    >>> trains.silent_skipped.tolist()        # the first two are below the 100 nA rheobase
    [0, 1]
    >>> t = trains.spike_times[2]             # exact: T(v_rest) = tau_m ln 2, then t_ref + tau_m ln 2
    >>> np.round(t * 1e3, 6).tolist()
    [3.098368, 7.396736, 11.695104, 15.993472]
    >>> grid = simulate_lif(current, p, dt=1e-4, engine="fast", times=np.arange(20) * 1e-3)
    >>> np.round(grid.spike_times[2] * 1e3, 6).tolist()   # 0.1 ms grid: each interval shortened
    [3.0, 7.2, 11.4, 15.6, 19.8]
    """
    if not isinstance(params, LIFParams):
        raise TypeError(f"'params' must be a LIFParams; got {type(params).__name__} instead.")
    check_option("engine", engine, ENGINES)
    check_option("input_hold", input_hold, INPUT_HOLDS)
    if engine == "auto":
        engine = "exact"
    if zones is not None:
        return simulate_zones(current, params, zones, dt=dt, engine=engine, duration=duration, times=times,
                              hold=input_hold)
    if engine.startswith("exact"):
        return _simulate_exact(current, params, dt=dt, engine=engine, duration=duration, times=times, hold=input_hold)
    if input_hold != "previous":
        raise ValueError(
            f"input_hold={input_hold!r} needs engine='exact': the grid engines hold each sample, as brian2's "
            f"TimedArray does; got engine={engine!r} instead."
        )
    if dt is None:
        raise ValueError(f"'dt' must be given with engine={engine!r}: it is the time step in s; got None instead.")
    plan = _plan(current, dt, duration, times)
    values = plan.values
    n_aff = values.shape[1]

    _check_drive(plan.extremes, params)

    if engine == "fast":
        backend = "numba" if _numba_available() else "numpy"
    elif engine == "fast-numba":
        if not _numba_available():
            raise ImportError(
                "engine='fast-numba' needs numba, which is not installed. "
                "Install it with pip install 'afferent-skin[fast]', or use engine='fast'."
            )
        engine, backend = "fast", "numba"
    elif engine == "fast-numpy":
        engine, backend = "fast", "numpy"
    else:
        backend = "brian2-numpy"

    n_ref = _refractory_steps(params.t_ref, plan.dt)
    if params.t_ref > 0 and abs(n_ref * plan.dt - params.t_ref) > 1e-9 * plan.dt:
        plan.notes.append(
            f"t_ref = {params.t_ref:g} s is not a whole number of steps: refractory lasts "
            f"{n_ref} step(s) = {n_ref * plan.dt:g} s (brian2's rounding)."
        )

    peak = _peak_current(plan) if n_aff else np.zeros(0)
    silent = _silent(peak, params, plan.dt)
    cols = np.flatnonzero(~silent)

    if cols.size == 0:
        steps, counts = np.empty(0, np.int64), np.zeros(0, np.int64)
    elif backend == "numba":
        steps, counts = _run_numba(plan, cols, params, peak[cols])
    elif backend == "numpy":
        steps, counts = _run_numpy(plan, cols, params)
    else:
        steps, counts = _run_brian2(plan, cols, params)

    # Spike times t_start + k dt (for t_start = 0 exactly brian2's t = timestep * dt).
    times_s = steps * plan.dt
    if plan.t_start:
        times_s += plan.t_start
    _warn_above_ceiling(times_s, counts, params, plan)

    return SpikeTrains(
        t=times_s,
        counts=spread_counts(counts, cols, n_aff),
        afferent_ids=plan.afferent_ids,
        duration=plan.n_steps * plan.dt,
        dt=plan.dt,
        engine=engine,
        backend=backend,
        silent_skipped=np.flatnonzero(silent),
        params=params,
        t_start=plan.t_start,
        notes=tuple(plan.notes),
    )
