"""The grid engines of :func:`afferent.spiking.simulate_lif`: 'fast' (numba or numpy) and 'brian2'.

Both follow brian2's grid semantics, step for step (see :mod:`afferent.spiking`). This is the
only module of :mod:`afferent` that runs brian2, inside :func:`_run_brian2` (imported through
:func:`afferent.spiking._brian2.import_brian2`, which keeps the process's warnings as they were).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .._validation import check_positive, check_step_count
from ._group import _group_numpy, _numba_group
from ._input import _read_input
from ._params import _CLOCK_EPS, _SAMPLE_EPS, LIFParams, _n_steps, _refractory_steps


@dataclass
class _Plan:
    values: np.ndarray  # (n_times, n_afferents) float64, not copied
    idx: np.ndarray  # (n_steps,) int64: input sample active in each step
    n_steps: int
    dt: float
    t_start: float
    ratio: int | None  # input samples are every `ratio` steps from step 0 (brian2 can use them as is)
    afferent_ids: np.ndarray
    notes: list
    extremes: tuple  # (smallest, largest) current of each afferent over all samples, A



def _plan(current, dt, duration, times) -> _Plan:
    arr, t, ids, extremes = _read_input(current, times)
    n_times = arr.shape[0]
    dt = check_positive("dt", dt, unit="s")
    notes: list[str] = []

    if t is None:
        t_start = 0.0
        start_step = np.arange(n_times, dtype=np.int64)
        default_duration = n_times * dt
    else:
        t_start = float(t[0])
        rel = (t - t[0]) / dt
        start_step = np.ceil(rel - _SAMPLE_EPS).astype(np.int64)
        last = float(t[-1] - t[-2]) if n_times >= 2 else dt
        default_duration = float(t[-1] - t[0]) + last

    # a duration of its own (given, or the span of two or more sample times), not one sample's dt by definition
    own = duration is not None or (t is not None and n_times >= 2)
    if duration is None:
        duration = default_duration
    else:
        duration = check_positive("duration", duration, unit="s")
    check_step_count(duration, dt)
    if own and not dt < duration * (1 - _CLOCK_EPS):  # one step: every spike stamped at the start, counts set by dt
        raise ValueError(f"'dt' must be below the simulated duration of {duration:g} s, so that the grid has more than "
                         f"one step; got {dt!r} s instead. Use a smaller dt, or engine='exact' (no time step).")
    n_steps = max(_n_steps(duration, dt), 1)
    if abs(n_steps * dt - duration) > _CLOCK_EPS * dt:
        notes.append(f"duration {duration!r} s is not a whole number of steps; simulated {n_steps} steps.")

    # Sample active in step i: the last one whose start step is <= i (held before/after, like TimedArray).
    idx = np.searchsorted(start_step, np.arange(n_steps, dtype=np.int64), side="right") - 1
    np.clip(idx, 0, n_times - 1, out=idx)
    ratio = None
    if t is None:
        ratio = 1
    elif n_times >= 2 and start_step[1] >= 1 and np.array_equal(start_step, np.arange(n_times) * start_step[1]):
        ratio = int(start_step[1])
    unused = n_times - np.unique(start_step).size
    if unused:
        notes.append(f"{unused} input sample(s) fall within one step of the next and are never used; reduce dt.")

    return _Plan(arr, idx.astype(np.int64), n_steps, dt, t_start, ratio, ids, notes, extremes)


def _peak_current(plan: _Plan) -> np.ndarray:
    """Largest current of each afferent over the input samples the simulation uses, in A."""
    lo, hi = int(plan.idx[0]), int(plan.idx[-1])
    if lo == 0 and hi == plan.values.shape[0] - 1:
        return plan.extremes[1]
    return plan.values[lo : hi + 1].max(axis=0)


def _silent(i_max: np.ndarray, params: LIFParams, dt: float) -> np.ndarray:
    """Mask of afferents provably silent over the window (never reach threshold from rest)."""
    drive = params.r_m * i_max
    # Rounding in the grid update can push V a few ulp beyond its fixed point v_rest + r_m I;
    # the error is contracted by E each step, so it stays below ~ulp / (1 - E).
    scale = abs(params.v_rest) + abs(params.v_thresh) + np.abs(drive)
    margin = 64 * np.finfo(np.float64).eps * scale / -np.expm1(-dt / params.tau_m)
    return drive <= params.theta - margin


# --------------------------------------------------------------------------------------------
# Engines. Each returns (steps of the spikes grouped by column, each
# group in time order; spike count per column), columns indexing `cols`.
# --------------------------------------------------------------------------------------------


def _lif_loop(values, cols, idx, i_start, n_steps, v, ref_until, a, b, row_now, consts, n_ref, out_step, out_col):
    """Time loop of the fast engine (plain Python source, run compiled by numba).

    Advances the state ``v`` / ``ref_until`` from step ``i_start`` and writes spikes into
    ``out_step`` / ``out_col`` from position 0. It stops early, at a step boundary, when fewer
    than ``len(cols)`` free slots remain, so the caller can grow the buffers and resume; the
    hot loop itself never allocates. Returns ``(next_step, n_spikes_written, row_now)``.

    The update is brian2's exact-integration expression, in brian2's order of operations:
    ``v_rest + ((r I + E v) + E ((0 - v_rest) + (-r) I))``.
    """
    v_rest, r, E, v_thresh, v_reset = consts[0], consts[1], consts[2], consts[3], consts[4]
    n = cols.shape[0]
    cap = out_step.shape[0]
    count = 0
    c0 = 0.0 - v_rest
    mr = -r
    for i in range(i_start, n_steps):
        if cap - count < n:
            return i, count, row_now
        row = idx[i]
        if row != row_now:  # input sample changed: r I and E (-v_rest - r I) once per sample
            for j in range(n):
                current = values[row, cols[j]]
                a[j] = r * current
                b[j] = E * (c0 + mr * current)
            row_now = row
        for j in range(n):  # refractory neurons are not integrated (branch-free select)
            vj = v[j]
            vn = v_rest + ((a[j] + E * vj) + b[j])
            v[j] = vj if ref_until[j] > i else vn
        for j in range(n):  # refractory neurons sit at v_reset < v_thresh: no spike
            if v[j] >= v_thresh:
                out_step[count] = i
                out_col[count] = j
                count += 1
                v[j] = v_reset
                ref_until[j] = i + n_ref
    return n_steps, count, row_now


_NUMBA_LOOP = None


def _numba_loop():
    global _NUMBA_LOOP
    if _NUMBA_LOOP is None:
        import numba

        _NUMBA_LOOP = numba.njit(cache=True, nogil=True)(_lif_loop)
    return _NUMBA_LOOP



def _constants(params: LIFParams, dt: float):
    # np.exp, as brian2's numpy target computes it, so E is the same double. For dt >> tau_m it
    # underflows to 0, which is exact enough: V jumps to v_rest + r_m I within the step.
    with np.errstate(under="ignore"):
        E = float(np.exp((-dt) / params.tau_m))
    return E, _refractory_steps(params.t_ref, dt)


def _capacity_guess(peak: np.ndarray, plan: _Plan, params: LIFParams, n_ref: int) -> int:
    """First size of the spike buffers (>= len(peak)); the loop resumes with bigger ones if short.

    The closed-form rate at each simulated afferent's ``peak`` current, capped by one spike per
    refractory period, plus slack.
    """
    per_aff = np.minimum(params.steady_rate(peak) * plan.n_steps * plan.dt, plan.n_steps / max(n_ref, 1))
    return int(min(1.1 * float(per_aff.sum()), 2.0**26)) + 2 * peak.size + 1024


def _run_numba(plan: _Plan, cols: np.ndarray, params: LIFParams, peak: np.ndarray):
    E, n_ref = _constants(params, plan.dt)
    loop = _numba_loop()
    values = plan.values if plan.values.flags.c_contiguous else np.ascontiguousarray(plan.values)
    cols = cols.astype(np.int64)
    n = cols.size
    v = np.full(n, params.v_rest)
    ref_until = np.zeros(n, np.int64)  # first step at which each neuron integrates again
    a, b = np.empty(n), np.empty(n)
    consts = np.array([params.v_rest, params.r_m, E, params.v_thresh, params.v_reset])
    cap = _capacity_guess(peak, plan, params, n_ref)
    steps_parts, cols_parts = [], []
    i, row_now = 0, -1
    while i < plan.n_steps:
        out_step = np.empty(cap, np.int32)
        out_col = np.empty(cap, np.int32)
        i, count, row_now = loop(
            values, cols, plan.idx, i, plan.n_steps, v, ref_until, a, b, row_now, consts, n_ref, out_step, out_col
        )
        steps_parts.append(out_step[:count])
        cols_parts.append(out_col[:count])
        cap *= 2
    steps = steps_parts[0] if len(steps_parts) == 1 else np.concatenate(steps_parts)
    hit = cols_parts[0] if len(cols_parts) == 1 else np.concatenate(cols_parts)
    grouped, counts = np.empty(steps.size, np.int64), np.zeros(n, np.int64)
    _numba_group()(steps, hit, grouped, counts)
    return grouped, counts


def _drive_terms(current, r: float, mr: float, c0: float, E: float, a: np.ndarray, b: np.ndarray) -> None:
    """brian2's exact update for a held sample: ``a = r I``, ``b = E (c0 - r I)`` (V), written into ``a``, ``b``."""
    np.multiply(r, current, out=a)
    np.multiply(mr, current, out=b)
    np.add(c0, b, out=b)
    np.multiply(E, b, out=b)


def _step(v: np.ndarray, E: float, a: np.ndarray, b: np.ndarray, v_rest: float, tmp: np.ndarray) -> None:
    """One time step of every neuron in place: ``v = v_rest + ((a + E v) + b)`` (V), the operations in brian2's order."""
    np.multiply(E, v, out=tmp)
    np.add(a, tmp, out=tmp)
    np.add(tmp, b, out=tmp)
    np.add(v_rest, tmp, out=v)


def _run_numpy(plan: _Plan, cols: np.ndarray, params: LIFParams):
    E, n_ref = _constants(params, plan.dt)
    n = cols.size
    all_cols = n == plan.values.shape[1]
    v_rest, r = params.v_rest, params.r_m
    c0, mr = 0.0 - v_rest, -r
    v = np.full(n, v_rest)
    a = np.empty(n)  # r I
    b = np.empty(n)  # E (-v_rest - r I)
    tmp = np.empty(n)
    spiking = np.empty(n, dtype=bool)
    recent = deque()  # (step, cols) of spikes still refractory
    steps_out, cols_out = [], []
    row_now = -1
    for i in range(plan.n_steps):
        row = plan.idx[i]
        if row != row_now:
            _drive_terms(plan.values[row] if all_cols else plan.values[row, cols], r, mr, c0, E, a, b)
            row_now = row
        _step(v, E, a, b, v_rest, tmp)
        # Refractory neurons are not integrated: their V stays at v_reset (< v_thresh, so they
        # cannot spike either). Overwriting after the update gives the same state.
        while recent and i - recent[0][0] >= n_ref:
            recent.popleft()
        for _, held in recent:
            v[held] = params.v_reset
        np.greater_equal(v, params.v_thresh, out=spiking)
        if spiking.any():
            fired = np.flatnonzero(spiking)
            v[fired] = params.v_reset
            steps_out.append(np.full(fired.size, i, dtype=np.int64))
            cols_out.append(fired)
            if n_ref > 1:
                recent.append((i, fired))
    if steps_out:
        return _group_numpy(np.concatenate(steps_out), np.concatenate(cols_out).astype(np.int64), n)
    return np.empty(0, np.int64), np.zeros(n, np.int64)


_BRIAN2_EQS = """
dv/dt = (v_rest - v + r_m*I_in(t, i))/tau_m : volt (unless refractory)
v_rest : volt (shared, constant)
v_thresh : volt (shared, constant)
v_reset : volt (shared, constant)
r_m : ohm (shared, constant)
tau_m : second (shared, constant)
"""


def _run_brian2(plan: _Plan, cols: np.ndarray, params: LIFParams, links=None):
    """The reference engine: brian2 NeuronGroup + TimedArray + SpikeMonitor in an explicit Network.

    Code objects use brian2's numpy target through ``codeobj_class`` (nothing is compiled and
    the global ``prefs.codegen.target`` is left alone). ``links``: optional (pre, post) arrays of
    positions in ``cols`` (spike-initiation zones of one afferent, :mod:`afferent.spiking._zones`):
    a spike of ``pre`` resets ``post`` and makes it refractory in the same step (a
    ``Synapses`` without delay, applied before the resets).
    """
    from ._brian2 import import_brian2, quiet

    b2 = import_brian2()
    from brian2.codegen.runtime.numpy_rt import NumpyCodeObject

    dt = plan.dt
    last_row = int(plan.idx[-1])
    ta_dt = None
    if plan.ratio is not None:
        ta_dt = plan.ratio * dt
        if ta_dt / dt != float(plan.ratio):  # brian2 needs an exact integer ratio for exact integration
            ta_dt = None
    if ta_dt is not None:
        table = plan.values[: last_row + 1][:, cols]
    else:  # irregular input: resample onto the simulation grid (per-step constant)
        table, ta_dt = plan.values[np.ix_(plan.idx, cols)], dt
    with quiet():  # brian2's equation parser provokes pyparsing's deprecation warnings
        timed = b2.TimedArray(table * b2.amp, dt=ta_dt * b2.second)
        group = b2.NeuronGroup(
            cols.size,
            _BRIAN2_EQS,
            threshold="v >= v_thresh",
            reset="v = v_reset",
            refractory=params.t_ref * b2.second,
            method="exact",
            dt=dt * b2.second,
            namespace={"I_in": timed},
            codeobj_class=NumpyCodeObject,
        )
        group.v_rest = params.v_rest * b2.volt
        group.v_thresh = params.v_thresh * b2.volt
        group.v_reset = params.v_reset * b2.volt
        group.r_m = params.r_m * b2.ohm
        group.tau_m = params.tau_m * b2.second
        group.v = params.v_rest * b2.volt
        monitor = b2.SpikeMonitor(group, codeobj_class=NumpyCodeObject)
        net = b2.Network(group, monitor)
        if links is not None and len(links[0]):
            # on the neurons' clock (brian2's default 0.1 ms clock would put the reset zones' lastspike on
            # its own grid: they left refractory up to 5 steps late at dt < 0.1 ms, issue 32)
            syn = b2.Synapses(group, group, on_pre="v_post = v_reset_post\nlastspike_post = t\nnot_refractory_post = False",
                              dt=dt * b2.second, codeobj_class=NumpyCodeObject)
            syn.connect(i=np.asarray(links[0]), j=np.asarray(links[1]))
            net.add(syn)
        net.run(plan.n_steps * dt * b2.second, namespace={})
    steps = np.rint(np.asarray(monitor.t_) / dt).astype(np.int64)
    return _group_numpy(steps, np.asarray(monitor.i, dtype=np.int64), cols.size)

