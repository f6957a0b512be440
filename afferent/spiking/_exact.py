"""The exact engine of :func:`afferent.spiking.simulate_lif`: event-driven, from sample to sample and spike to spike.

The closed forms it evaluates are given in the docstring of :mod:`afferent.spiking`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .._validation import check_positive
from ._group import _group_numpy
from ._input import _read_input
from ._params import LIFParams


# --------------------------------------------------------------------------------------------
# Exact engine: event-driven, from sample to sample and from spike to spike, no time step.
# State per afferent: u = V - v_rest (V relative to rest) and the time at which integration
# resumes after the last spike (-inf before any). Each input piece [t_k, t_k+1) has the drive
# D(t) = r_m I(t) (V): constant ('previous') or linear in t ('linear').
# --------------------------------------------------------------------------------------------


@dataclass
class _Pieces:
    values: np.ndarray  # (n_times, n_afferents) float64, not copied
    starts: np.ndarray  # (n_pieces,) s: piece k starts at sample k's time
    ends: np.ndarray  # (n_pieces,) s: next sample's time, the last one cut at t_stop
    decay: np.ndarray  # (n_pieces,) exp(-(end - start) / tau_m)
    growth: np.ndarray  # (n_pieces,) 1 - decay, as -expm1 (accurate for short pieces)
    nxt: np.ndarray  # (n_pieces,) int64: row of the sample at the piece's end (itself if held)
    inv_h: np.ndarray  # (n_pieces,) 1/s: 1 / (next sample time - start) for 'linear', else 0
    t_start: float
    t_stop: float
    afferent_ids: np.ndarray
    notes: list
    extremes: tuple  # (smallest, largest) current of each afferent over all samples, A


def _pieces(current, dt, duration, times, tau_m: float, hold: str) -> _Pieces:
    """Input pieces of the exact engine: the current's own sample times, no grid."""
    arr, t, ids, extremes = _read_input(current, times)
    n_times = arr.shape[0]
    if dt is not None:
        dt = check_positive("dt", dt, unit="s")
    if t is None:
        if dt is None:
            raise ValueError(
                "'dt' must be given with engine='exact' for an ndarray current without 'times': it is the "
                "sample interval in s (sample k at k dt); got None instead. Or pass 'times'."
            )
        t = np.arange(n_times) * dt
    t_start = float(t[0])
    if duration is None:
        if n_times >= 2:
            duration = float(t[-1] - t[0]) + float(t[-1] - t[-2])
        elif dt is not None:
            duration = dt
        else:
            raise ValueError(
                "'duration' must be given with engine='exact' for a current of a single sample (or 'dt', its "
                "sample interval); got None instead."
            )
    else:
        duration = check_positive("duration", duration, unit="s")
    t_stop = t_start + duration
    if not t_stop > t_start:
        raise ValueError(
            f"'duration' must be large enough to change t_start = {t_start!r} s in double precision; "
            f"got {duration!r} s instead."
        )
    n_pieces = int(np.searchsorted(t, t_stop, side="left"))  # samples before t_stop start a piece
    starts = t[:n_pieces]
    ends = np.append(t[1:n_pieces], t_stop)
    with np.errstate(under="ignore"):
        decay = np.exp(-(ends - starts) / tau_m)
    growth = -np.expm1(-(ends - starts) / tau_m)
    nxt = np.minimum(np.arange(n_pieces) + 1, n_times - 1).astype(np.int64)
    inv_h = np.zeros(n_pieces)
    notes: list[str] = []
    if hold == "linear":
        k = np.flatnonzero(nxt > np.arange(n_pieces))
        inv_h[k] = 1.0 / (t[nxt[k]] - t[k])
        notes.append("input interpolated linearly between samples (last sample held)")
    else:
        nxt = np.arange(n_pieces, dtype=np.int64)
    return _Pieces(arr, starts, ends, decay, growth, nxt, inv_h, t_start, t_stop, ids, notes, extremes)


def _used_peak(pc: _Pieces, hold: str) -> np.ndarray:
    """Largest current (A) of each afferent over the samples the pieces use, from ``pc.extremes``
    (over every sample) and a look at the unused last samples only: no second pass over the input
    (12,500 afferents x 1,001 samples, the last one unused: 0.011 s less on one core)."""
    values = pc.values
    if hold == "linear" and pc.starts.size:  # the drive reaches the next sample's value at the piece's end
        used = int(pc.nxt[-1]) + 1
    else:
        used = pc.starts.size
    largest = pc.extremes[1]
    if used >= values.shape[0] or not values.shape[1]:
        return largest
    # where an unused sample reaches the largest value, the used ones may not: those columns again
    redo = np.flatnonzero(values[used:].max(axis=0) >= largest)
    if redo.size > values.shape[1] // 8:
        return values[:used].max(axis=0)
    out = largest.copy()
    if redo.size:
        out[redo] = values[:used, redo].max(axis=0)
    return out


def _linear_crossing(uj, da, s, h, wh, t, theta, tau):
    """Crossing under a linear drive ``da + s y`` (V, V/s) from ``uj`` over ``h`` s, ``wh = 1 - exp(-h / tau)``.

    The crossing is bracketed in closed form (u - theta is convex or concave in y) and found by
    Newton's method from the side where it converges monotonically; ``t`` (s) sets its stopping
    tolerance. Returns (time to the crossing in s, < 0 for none; u at the piece's end in V).
    Plain Python, compiled into :func:`_exact_afferent` by numba (see :func:`_numba_exact`).
    """
    db = da + s * h
    # u(t + y) = uj + (da - uj) w + s (y - tau w), w = 1 - e^(-y / tau): every term
    # is of the size of the change it describes (no s tau - s tau cancellation)
    cc = uj - da + s * tau  # its sign is that of d2u/dy2
    u_end = uj + (da - uj) * wh + s * (h - tau * wh)
    x = -1.0
    if da > theta or db > theta:
        b = -1.0  # right end of a bracket [0, b] with g(0) < 0 <= g(b)
        if u_end >= theta:
            b = h
        elif cc < 0.0 and s < 0.0:  # concave: the maximum may cross and come back
            ystar = tau * np.log(cc / (s * tau))
            if 0.0 < ystar < h and da + s * ystar >= theta:  # g(y*) = da + s y* - theta
                b = ystar
        if b >= 0.0:
            # g concave: Newton from 0 stays left of the root; convex: from b, right
            y = 0.0 if cc < 0.0 else b
            for _ in range(100):
                w = -np.expm1(-y / tau)
                g = (uj - theta) + (da - uj) * w + s * (y - tau * w)
                dg = (da - uj) * (1.0 - w) / tau + s * w
                if dg == 0.0:
                    break
                y_new = min(max(y - g / dg, 0.0), b)
                if abs(y_new - y) <= 4e-16 * (abs(t) + y_new):
                    y = y_new
                    break
                y = y_new
            x = y
    return x, u_end


def _exact_afferent(v, starts, ends, decay, growth, nxt, inv_h, consts, out_t, count):
    """Spikes of one afferent, its current ``v`` (A) one value per sample, over every piece
    (plain Python, run compiled by numba: see :func:`_numba_exact`).

    Writes its spike times into ``out_t`` from position ``count`` and returns the position after
    the last one, or -1 when ``out_t`` is full (the caller grows it and runs the afferent again).

    State: ``u`` (V above rest), ``tr``, the end of the refractory period (-inf before any spike),
    and ``eg = exp(-(end of the last piece seen - tr) / tau)``, so that resuming after a
    refractory period needs no exp (held input: it is the decay to the piece's end times
    ``(D - u) / (D - theta)`` times ``exp(t_ref / tau)``, then times each skipped piece's decay;
    an exp replaces it if it under- or overflowed).

    In a piece, an afferent not refractory starts at the piece start (decay ``decay[k]``) or, if
    its refractory period ends inside the piece, at that time with ``u = u_reset``. With a
    constant drive ``D`` it reaches threshold within the piece iff ``D > theta`` and
    ``D + (u - D) e^(-h / tau) >= theta``, at ``t + tau log1p((theta - u) / (D - theta))``; the
    last such logarithm is kept with the ``(D, u)`` it was computed for, so a steady drive firing
    from ``u_reset`` again and again takes one logarithm, not one per spike (the same value, bit
    for bit). With a linear drive the crossing is bracketed in closed form (V - v_thresh is
    convex or concave in t) and found by Newton's method from the side where it converges
    monotonically (:func:`_linear_crossing`).
    """
    r, theta, u_reset, tau, t_ref, t_stop, eri = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], consts[6]
    cap = out_t.shape[0]
    u, tr, eg = 0.0, -np.inf, 1.0
    m_da, m_u, m_q, m_x = np.nan, np.nan, 0.0, 0.0  # last held crossing: drive, start u, ratio, log
    for k in range(starts.shape[0]):
        t0 = starts[k]
        t1 = ends[k]
        if tr >= t1:  # refractory through the whole piece
            eg *= decay[k]
            continue
        d0 = r * v[k]
        ih = inv_h[k]
        uj = u  # u_reset if the neuron spiked
        if ih == 0.0 and tr <= t0:  # fast path: held input, no crossing in the piece
            u_end = d0 + (uj - d0) * decay[k]
            if d0 <= theta or u_end < theta:
                u = u_end
                continue
        s = r * (v[nxt[k]] - v[k]) * ih  # drive slope, V/s (0 when held)
        if tr > t0:
            t = tr
            e = decay[k] * eg  # decay from tr to t1
            if not (0.0 < e <= 1.0):  # under- or overflowed on the way: direct
                e = np.exp(-(t1 - t) / tau)
        else:
            t = t0
            e = decay[k]
        while True:
            h = t1 - t
            da = d0 + s * (t - t0)  # drive at t
            # x: time from t to the crossing (< 0: none in the piece); u_end: u at the piece's end
            if s == 0.0:
                u_end = da + (uj - da) * e
                x = -1.0
                if da > theta and u_end >= theta:
                    if da != m_da or uj != m_u:
                        m_q = (theta - uj) / (da - theta)
                        m_x = tau * np.log1p(m_q)
                        m_da, m_u = da, uj
                    x = min(m_x, h)
            else:
                wh = growth[k] if t == t0 else -np.expm1(-h / tau)
                x, u_end = _linear_crossing(uj, da, s, h, wh, t, theta, tau)
            if x < 0.0:
                uj = u_end
                break
            ts = t + x
            if ts >= t_stop:  # a crossing at or after the end of the window is not reported
                uj = u_end
                break
            if count == cap:
                return -1
            out_t[count] = ts
            count += 1
            tr = ts + t_ref
            uj = u_reset
            # exp(-(t1 - tr) / tau) without an exp: held input, e = exp(-(t1 - t) / tau) and
            # exp(x / tau) = 1 + m_q; > 1 while refractory past t1 (then multiplied by each
            # skipped piece's decay)
            if s == 0.0:
                e = e * (1.0 + m_q) * eri
            else:
                e = np.exp(-(t1 - tr) / tau)
            if tr >= t1:
                eg = e
                break
            t = tr
            if not (0.0 < e <= 1.0):
                e = np.exp(-(t1 - t) / tau)
        u = uj
    return count


#: Afferents whose samples :func:`_exact_block` copies together into one contiguous buffer, each
#: column walked down its samples (the input is stored sample by sample: the tile's 16 columns
#: share their cache lines, which the copy brings in once; the event loop then reads contiguous
#: memory). 12,500 afferents x 1,001 samples, one core: kernel 0.20 s walking the input
#: directly, 0.165 s copying row by row, 0.135 s column by column (CPU).
_TILE = 16


def _exact_block(values, cols, starts, ends, decay, growth, nxt, inv_h, j0, consts, out_t, counts):
    """Afferents ``cols[j0:]`` one after the other through :func:`_exact_afferent` (plain Python,
    run compiled by numba): their spikes land in ``out_t`` grouped by afferent, in time order,
    ``counts[j]`` of them for ``cols[j]``. Returns (afferents done, spikes written): fewer than
    ``cols.size`` when ``out_t`` filled up (the caller grows it and resumes there)."""
    n, n_rows = cols.shape[0], values.shape[0]
    buf = np.empty((_TILE, n_rows))
    count = 0
    for lo in range(j0, n, _TILE):
        m = min(_TILE, n - lo)
        for i in range(m):  # the tile's columns, each walked down its samples (2.7x faster than row by row)
            c = cols[lo + i]
            b = buf[i]
            for k in range(n_rows):
                b[k] = values[k, c]
        for i in range(m):
            end = _exact_afferent(buf[i], starts, ends, decay, growth, nxt, inv_h, consts, out_t, count)
            if end < 0:
                return lo + i, count
            counts[lo + i] = end - count
            count = end
    return n, count


_NUMBA_EXACT = None


def _numba_exact():
    """The compiled :func:`_exact_block`, compiled once and cached on disk by numba (``cache=True``:
    a later process loads it instead of compiling)."""
    global _NUMBA_EXACT
    if _NUMBA_EXACT is None:
        _NUMBA_EXACT = compile_block(_exact_block, (_linear_crossing, _exact_afferent))
    return _NUMBA_EXACT


def compile_block(block, steps):
    """``block`` compiled by numba (nogil, numpy's error model, cached on disk), with the plain-Python
    functions ``steps`` it calls (the per-afferent loop, the crossing search) compiled into it."""
    import numba

    from numba.extending import register_jitable

    for step in steps:
        register_jitable(nogil=True, error_model="numpy")(step)
    return numba.njit(cache=True, nogil=True, error_model="numpy")(block)


def _exact_consts(params: LIFParams, t_stop: float) -> np.ndarray:
    with np.errstate(over="ignore"):
        eri = float(np.exp(params.t_ref / params.tau_m))  # inf if huge: the loop then uses exp directly
    return np.array([params.r_m, params.theta, params.v_reset - params.v_rest, params.tau_m, params.t_ref, t_stop, eri])


def _exact_capacity(peak: np.ndarray, pc: _Pieces, params: LIFParams) -> int:
    """First size of the spike buffers: the closed-form rate at each afferent's peak, capped by
    1 / t_ref, plus slack (the loop resumes with bigger buffers if short)."""
    duration = pc.t_stop - pc.t_start
    per_aff = params.steady_rate(peak) * duration
    if params.t_ref > 0:
        per_aff = np.minimum(per_aff, duration / params.t_ref)
    return int(min(1.1 * float(per_aff.sum()), 2.0**26)) + 2 * peak.size + 1024


def _exact_threads(n: int) -> int:
    """Threads for the numba exact engine: one per available core, each with >= 2,000 afferents."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, n // 2000, 8))


def _run_exact_numba_block(pc: _Pieces, values, cols: np.ndarray, params: LIFParams, peak: np.ndarray):
    """One block of afferents through the compiled loop (runs without the GIL): (spike times
    grouped by afferent, count per afferent)."""
    counts = np.zeros(cols.size, np.int64)
    return run_in_buffers(_numba_exact(), values, cols, pc, _exact_consts(params, pc.t_stop), counts,
                          _exact_capacity(peak, pc, params)), counts


def run_in_buffers(block, values, index, pc: _Pieces, consts, counts: np.ndarray, cap: int) -> np.ndarray:
    """Spike times (s, grouped by afferent) of a compiled or plain block loop over ``counts.size`` afferents,
    ``block(values, index, pieces..., first, consts, out_t, counts) -> (next afferent, n written)``: it stops
    when ``out_t`` (``cap`` spikes) is full and resumes from the next afferent with a buffer twice as big."""
    parts, j = [], 0
    while j < counts.size:
        out_t = np.empty(cap)
        j, count = block(values, index, pc.starts, pc.ends, pc.decay, pc.growth, pc.nxt, pc.inv_h, j, consts, out_t,
                         counts)
        parts.append(out_t[:count])
        cap *= 2
    return parts[0] if len(parts) == 1 else (np.concatenate(parts) if parts else np.empty(0))


def _run_exact_numba(pc: _Pieces, cols: np.ndarray, params: LIFParams, peak: np.ndarray):
    """The compiled exact engine, the afferents split into contiguous blocks run on threads (the
    afferents are independent, so the spikes do not depend on the split, bit for bit)."""
    values = pc.values if pc.values.flags.c_contiguous else np.ascontiguousarray(pc.values)
    cols = cols.astype(np.int64)
    _numba_exact()  # compile or load once, before any thread
    n_threads = _exact_threads(cols.size)
    if n_threads == 1:
        return _run_exact_numba_block(pc, values, cols, params, peak)
    from concurrent.futures import ThreadPoolExecutor

    edges = np.linspace(0, cols.size, n_threads + 1).astype(int)
    with ThreadPoolExecutor(n_threads) as pool:
        parts = list(pool.map(lambda lo_hi: _run_exact_numba_block(pc, values, cols[lo_hi[0]:lo_hi[1]], params,
                                                                    peak[lo_hi[0]:lo_hi[1]]),
                              zip(edges[:-1], edges[1:])))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _newton_crossing(y, b, da, s, cc, uj, theta, tau, t):
    """Vectorised form of the Newton iteration of :func:`_exact_afferent` (same start, clamp and stop)."""
    active = np.ones(y.size, dtype=bool)
    for _ in range(100):
        if not active.any():
            break
        a = np.flatnonzero(active)
        ya = y[a]
        w = -np.expm1(-ya / tau)
        g = (uj[a] - theta) + (da[a] - uj[a]) * w + s[a] * (ya - tau * w)
        dg = (da[a] - uj[a]) * (1.0 - w) / tau + s[a] * w
        zero = dg == 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            y_new = np.minimum(np.maximum(ya - g / dg, 0.0), b[a])
        y_new[zero] = ya[zero]
        done = zero | (np.abs(y_new - ya) <= 4e-16 * (np.abs(t[a]) + y_new))
        y[a] = y_new
        active[a[done]] = False
    return y


def _run_exact_numpy(pc: _Pieces, cols: np.ndarray, params: LIFParams):
    """The exact engine vectorised over afferents with numpy: same events as :func:`_exact_afferent`."""
    n = cols.size
    all_cols = n == pc.values.shape[1]
    r, theta, tau, t_ref, t_stop = params.r_m, params.theta, params.tau_m, params.t_ref, pc.t_stop
    u_reset = params.v_reset - params.v_rest
    u = np.zeros(n)
    ref_end = np.full(n, -np.inf)
    times_out, cols_out = [], []
    for k in range(pc.starts.size):
        t0, t1, ih = pc.starts[k], pc.ends[k], pc.inv_h[k]
        live = np.flatnonzero(ref_end < t1)  # not refractory through the whole piece
        if live.size == 0:
            continue
        row = pc.values[k] if all_cols else pc.values[k, cols]
        d0 = r * row[live]
        if ih:
            row1 = pc.values[pc.nxt[k]] if all_cols else pc.values[pc.nxt[k], cols]
            s = r * (row1[live] - row[live]) * ih
        else:
            s = np.zeros(live.size)
        uj = u[live]
        tr = ref_end[live]
        late = tr > t0
        t = np.where(late, tr, t0)
        e = np.full(live.size, pc.decay[k])
        if late.any():
            e[late] = np.exp(-(t1 - t[late]) / tau)
        idx = live
        while idx.size:
            h = t1 - t
            if not ih:  # held input everywhere: the closed form only
                u_end = d0 + (uj - d0) * e
                x = np.full(idx.size, -1.0)
                hit = np.flatnonzero((d0 > theta) & (u_end >= theta))
                if hit.size:
                    x[hit] = np.minimum(tau * np.log1p((theta - uj[hit]) / (d0[hit] - theta)), h[hit])
                else:
                    u[idx] = u_end
                    break
            else:
                x, u_end = _crossings_any_input(t, t0, h, d0, s, uj, e, pc.growth[k], theta, tau)
            ts = t + x
            fire = (x >= 0) & (ts < t_stop)
            u[idx[~fire]] = u_end[~fire]
            if not fire.any():
                break
            f = np.flatnonzero(fire)
            fired = idx[f]
            times_out.append(ts[f])
            cols_out.append(fired)
            trf = ts[f] + t_ref
            ref_end[fired] = trf
            u[fired] = u_reset
            again = trf < t1
            f, idx = f[again], fired[again]
            t = trf[again]
            uj = np.full(idx.size, u_reset)
            d0, s = d0[f], s[f]
            e = np.exp(-(t1 - t) / tau)
    if times_out:
        return _group_numpy(np.concatenate(times_out), np.concatenate(cols_out), n)
    return np.empty(0), np.zeros(n, np.int64)


def _crossings_any_input(t, t0, h, d0, s, uj, e, growth, theta, tau):
    """Vectorised crossing search of :func:`_exact_afferent` for held (s = 0) and linear drives.

    Returns (time from t to the crossing, < 0 for none; u at the piece's end t + h).
    """
    da = d0 + s * (t - t0)
    held = s == 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        cc = uj - da + s * tau
        u_end = da + (uj - da) * e
        if not held.all():
            nh = ~held
            wh = np.where(t[nh] == t0, growth, -np.expm1(-h[nh] / tau))
            u_end[nh] = uj[nh] + (da[nh] - uj[nh]) * wh + s[nh] * (h[nh] - tau * wh)
        x = np.full(t.size, -1.0)
        # held input: closed form
        hit = held & (da > theta) & (u_end >= theta)
        x[hit] = np.minimum(tau * np.log1p((theta - uj[hit]) / (da[hit] - theta)), h[hit])
        # linear input: closed-form bracket, then Newton
        db = da + s * h
        lin = ~held & ((da > theta) | (db > theta))
        b = np.full(t.size, -1.0)
        b[lin & (u_end >= theta)] = h[lin & (u_end >= theta)]
        conc = lin & (b < 0) & (cc < 0) & (s < 0)
        if conc.any():
            ystar = np.full(t.size, -1.0)
            ystar[conc] = tau * np.log(cc[conc] / (s[conc] * tau))
            ok = conc & (ystar > 0) & (ystar < h) & (da + s * ystar >= theta)
            b[ok] = ystar[ok]
        nl = np.flatnonzero(b >= 0)
        if nl.size:
            y0 = np.where(cc[nl] < 0, 0.0, b[nl])
            x[nl] = _newton_crossing(y0, b[nl], da[nl], s[nl], cc[nl], uj[nl], theta, tau, t[nl])
    return x, u_end

