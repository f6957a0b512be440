"""Spike-initiation zones in the LIF engines: one membrane per zone, one spike train per afferent.

Each zone ``z`` of afferent ``A`` integrates its own current ``I_z`` (A) with the LIF of the
model (:mod:`afferent.spiking`). The afferent fires when any of its zones reaches threshold;
then every zone of that afferent is set to ``v_reset`` and held there for ``t_ref`` (one
refractory period for the afferent). With one zone per afferent this is the ``sum`` model.

Three engines:

* exact (:func:`_zones_afferent`): event-driven like :mod:`afferent.spiking._exact`, the same
  closed forms per zone (held input: ``T = tau ln((D - u) / (D - theta))``; linear input: the
  same bracketed Newton search, :func:`afferent.spiking._exact._linear_crossing`); in each
  piece every zone's crossing time is found from the common start and the earliest one is the
  afferent's spike. Compiled by numba (a dependency) when it is installed, else run as plain
  Python (backend ``'python'``, slow: for small runs and tests).
* fast (:func:`_run_fast_zones`): brian2's grid semantics (the update of ``_grid._lif_loop``),
  numpy, vectorised over zones; an afferent spikes at the first step in which one of its zones
  is at or above threshold.
* brian2 (:func:`_run_brian2_zones`): a neuron per zone and a delay-free ``Synapses`` from every
  zone to the other zones of its afferent (``v_post = v_reset``, refractory from ``t``), applied
  in the step of the spike before the resets; zones crossing in one step make one spike. It
  gives the fast engine's spikes step for step (``tests/test_zones.py``).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ._exact import _exact_capacity, _exact_consts, _linear_crossing, _Pieces, compile_block, run_in_buffers
from ._grid import _drive_terms, _step
from ._group import _group_numpy, _numba_available
from ._params import LIFParams


def zone_groups(zones, n_columns: int, afferent_ids) -> tuple[np.ndarray, int, np.ndarray]:
    """(afferent index of each column, number of afferents, afferent ids) from ``zones``.

    ``zones`` is an :class:`afferent.zones.Zones` (its ``afferent`` and ``afferent_ids``) or an
    array of one afferent index (int >= 0) per column of the current; columns of one afferent
    must be contiguous and in afferent order. ``afferent_ids``: the ids to use for a plain array.
    """
    if hasattr(zones, "afferent") and hasattr(zones, "afferent_ids"):
        aff, ids = np.asarray(zones.afferent), np.asarray(zones.afferent_ids)
    else:
        aff, ids = np.asarray(zones), None
    if aff.dtype.kind not in "iu" or aff.shape != (n_columns,):
        raise ValueError(f"'zones' must give one afferent index (int) per column of the current ({n_columns}); "
                         f"got {aff.dtype} of shape {aff.shape} instead.")
    if aff.size and (aff.min() < 0 or np.any(np.diff(aff) < 0)):
        raise ValueError("'zones' must be non-decreasing afferent indices >= 0 (the zones of an afferent contiguous); "
                         f"got {aff[:8].tolist()}{' ...' if aff.size > 8 else ''} instead.")
    n_aff = int(aff.max()) + 1 if aff.size else 0
    if ids is None:
        ids = np.arange(n_aff)
    elif ids.shape[0] < n_aff:
        raise ValueError(f"'zones' names {ids.shape[0]} afferents but indexes {n_aff}.")
    else:
        n_aff = ids.shape[0]
    return aff.astype(np.int64), n_aff, ids


def _zones_afferent(v, z0, z1, starts, ends, decay, growth, nxt, inv_h, consts, u, uend, d, s, out_t, count):
    """Spikes of one afferent whose zones are columns ``z0:z1`` of ``v`` (A, one row per sample).

    Plain Python, compiled by numba (:func:`_numba_zones`). ``u``, ``uend``, ``d``, ``s``: work
    arrays of >= ``z1 - z0`` entries (V above rest, V at the piece's end, drive V, drive slope
    V/s). Writes spike times into ``out_t`` from ``count``; returns the position after the last,
    or -1 when ``out_t`` is full.
    """
    r, theta, u_reset, tau, t_ref, t_stop = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5]
    m = z1 - z0
    cap = out_t.shape[0]
    for j in range(m):
        u[j] = 0.0
    tr = -np.inf
    for k in range(starts.shape[0]):
        t0, t1, ih = starts[k], ends[k], inv_h[k]
        if tr >= t1:  # refractory through the whole piece
            continue
        for j in range(m):
            d[j] = r * v[k, z0 + j]
            s[j] = r * (v[nxt[k], z0 + j] - v[k, z0 + j]) * ih
        t = tr if tr > t0 else t0
        while True:
            h = t1 - t
            e = decay[k] if t == t0 else np.exp(-h / tau)
            best = np.inf
            for j in range(m):
                da = d[j] + s[j] * (t - t0)
                if s[j] == 0.0:
                    ue = da + (u[j] - da) * e
                    x = -1.0
                    if da > theta and ue >= theta:
                        x = min(tau * np.log1p((theta - u[j]) / (da - theta)), h)
                else:
                    wh = growth[k] if t == t0 else -np.expm1(-h / tau)
                    x, ue = _linear_crossing(u[j], da, s[j], h, wh, t, theta, tau)
                uend[j] = ue
                if x >= 0.0 and x < best:
                    best = x
            ts = t + best
            if best == np.inf or ts >= t_stop:  # no zone crosses in the piece (or in the window)
                for j in range(m):
                    u[j] = uend[j]
                break
            if count == cap:
                return -1
            out_t[count] = ts
            count += 1
            tr = ts + t_ref
            for j in range(m):
                u[j] = u_reset
            if tr >= t1:
                break
            t = tr
    return count


def _zones_block(values, zptr, starts, ends, decay, growth, nxt, inv_h, a0, consts, out_t, counts):
    """Afferents ``a0:`` (zones ``zptr[a]:zptr[a+1]`` of ``values``) through :func:`_zones_afferent`.

    Returns (afferents done, spikes written): fewer than all when ``out_t`` filled up.
    """
    n = zptr.shape[0] - 1
    width = 1
    for a in range(n):
        width = max(width, zptr[a + 1] - zptr[a])
    u, uend, d, s = np.empty(width), np.empty(width), np.empty(width), np.empty(width)
    count = 0
    for a in range(a0, n):
        end = _zones_afferent(values, zptr[a], zptr[a + 1], starts, ends, decay, growth, nxt, inv_h, consts, u, uend,
                              d, s, out_t, count)
        if end < 0:
            return a, count
        counts[a] = end - count
        count = end
    return n, count


_NUMBA_ZONES = None


def _numba_zones():
    """The compiled :func:`_zones_block` (numba, cached on disk)."""
    global _NUMBA_ZONES
    if _NUMBA_ZONES is None:
        _NUMBA_ZONES = compile_block(_zones_block, (_linear_crossing, _zones_afferent))
    return _NUMBA_ZONES


def run_exact_zones(pc: _Pieces, aff: np.ndarray, keep: np.ndarray, peak: np.ndarray, params: LIFParams,
                    backend: str):
    """The exact zones engine on the afferents ``keep`` (indices, increasing) whose zones are the
    columns ``aff == a``; ``peak``: the largest zone current of each kept afferent, A (sizes the
    spike buffer). Returns (spike times grouped by afferent, count per kept afferent)."""
    cols = np.flatnonzero(np.isin(aff, keep))
    # column-major: each zone's samples contiguous, as the per-afferent loop walks them (an afferent's
    # few zones are a few streams through memory, not one stride of all zones per sample)
    values = np.asfortranarray(pc.values[:, cols])
    zptr = np.append(np.searchsorted(aff[cols], keep, side="left"), cols.size).astype(np.int64)
    block = _numba_zones() if backend == "numba" else _zones_block
    consts = _exact_consts(params, pc.t_stop)
    counts = np.zeros(keep.size, np.int64)
    # first buffer: each afferent at the closed-form rate of its strongest zone (grows if short)
    return run_in_buffers(block, values, zptr, pc, consts, counts, _exact_capacity(peak, pc, params)), counts


def exact_backend(engine: str) -> str:
    """'numba' or 'python' for the exact zones engine (``engine`` 'exact', 'exact-numba' or 'exact-numpy')."""
    if engine == "exact-numpy":
        return "python"
    if _numba_available():
        return "numba"
    if engine == "exact-numba":
        raise ImportError("engine='exact-numba' needs numba, which is not installed. "
                          "Install it with pip install 'afferent-skin[fast]', or use engine='exact'.")
    return "python"


def _run_fast_zones(plan, aff: np.ndarray, keep: np.ndarray, params: LIFParams, E: float, n_ref: int):
    """The grid zones engine (numpy), brian2's update per zone; returns (spike steps grouped by
    afferent, count per kept afferent)."""
    cols = np.flatnonzero(np.isin(aff, keep))
    owner = np.searchsorted(keep, aff[cols])  # kept afferent of each simulated zone
    n = cols.size
    v_rest, r = params.v_rest, params.r_m
    c0, mr = 0.0 - v_rest, -r
    v = np.full(n, v_rest)
    a, b, tmp = np.empty(n), np.empty(n), np.empty(n)
    refractory = np.zeros(keep.size, dtype=bool)
    recent = deque()  # (step, afferents) still refractory
    steps_out, aff_out = [], []
    row_now = -1
    for i in range(plan.n_steps):
        row = plan.idx[i]
        if row != row_now:
            _drive_terms(plan.values[row, cols], r, mr, c0, E, a, b)
            row_now = row
        _step(v, E, a, b, v_rest, tmp)
        while recent and i - recent[0][0] >= n_ref:
            refractory[recent.popleft()[1]] = False
        held = refractory[owner]
        v[held] = params.v_reset
        spiking = v >= params.v_thresh
        if spiking.any():
            fired = np.unique(owner[spiking])
            v[np.isin(owner, fired)] = params.v_reset
            steps_out.append(np.full(fired.size, i, dtype=np.int64))
            aff_out.append(fired)
            if n_ref > 1:
                refractory[fired] = True
                recent.append((i, fired))
    if steps_out:
        return _group_numpy(np.concatenate(steps_out), np.concatenate(aff_out).astype(np.int64), keep.size)
    return np.empty(0, np.int64), np.zeros(keep.size, np.int64)


def _afferent_peak(zone_peak: np.ndarray, aff: np.ndarray, n_aff: int) -> np.ndarray:
    """Largest zone current of each afferent (A; -inf for an afferent without zones)."""
    out = np.full(n_aff, -np.inf)
    np.maximum.at(out, aff, zone_peak)
    return out


def simulate_zones(current, params: LIFParams, zones, *, dt, engine: str, duration, times, hold: str):
    """:func:`afferent.spiking.simulate_lif` with ``zones``: the current's columns are zones.

    ``engine``: 'exact', 'exact-numba', 'exact-numpy' (plain Python here), 'fast', 'fast-numba',
    'fast-numpy' (numpy here) or 'brian2'. Returns SpikeTrains per afferent.
    """
    from . import _check_drive, _check_isi_resolution, _used_peak, _warn_above_ceiling
    from ._exact import _pieces
    from ._grid import _constants, _peak_current, _plan, _silent
    from ._trains import SpikeTrains, spread_counts

    if engine.startswith("exact"):
        backend = exact_backend(engine)
        src = _pieces(current, dt, duration, times, params.tau_m, hold)
        peak = _used_peak(src, hold)
    else:
        if hold != "previous":
            raise ValueError(f"input_hold={hold!r} needs engine='exact': the grid engines hold each sample; "
                             f"got engine={engine!r} instead.")
        if dt is None:
            raise ValueError(f"'dt' must be given with engine={engine!r}: it is the time step in s; got None instead.")
        backend, src = ("brian2-numpy" if engine == "brian2" else "numpy"), _plan(current, dt, duration, times)
        peak = _peak_current(src) if src.values.shape[1] else np.zeros(0)
    aff, n_aff, ids = zone_groups(zones, src.values.shape[1], None)
    _check_drive(src.extremes, params)
    aff_peak = _afferent_peak(peak, aff, n_aff)
    notes = list(src.notes) + [f"spike-initiation zones: {aff.size} zones of {n_aff} afferents, each its own LIF; "
                               "the first zone at threshold fires the afferent and resets all its zones"]
    if engine.startswith("exact"):
        keep = np.flatnonzero(params.r_m * aff_peak > params.theta)
        if keep.size:
            _check_isi_resolution(params, aff_peak[keep], src)
            t, counts = run_exact_zones(src, aff, keep, aff_peak[keep], params, backend)
        else:
            t, counts = np.empty(0), np.zeros(0, np.int64)
        dur, step, eng = src.t_stop - src.t_start, 0.0, "exact"
    else:
        keep = np.flatnonzero(~_silent(np.where(np.isfinite(aff_peak), aff_peak, 0.0), params, src.dt))
        E, n_ref = _constants(params, src.dt)
        if not keep.size:
            steps, counts = np.empty(0, np.int64), np.zeros(0, np.int64)
        elif engine == "brian2":
            steps, counts = _run_brian2_zones(src, aff, keep, params)
        else:
            steps, counts = _run_fast_zones(src, aff, keep, params, E, n_ref)
        t = steps * src.dt + src.t_start if src.t_start else steps * src.dt
        _warn_above_ceiling(t, counts, params, src)
        dur, step, eng = src.n_steps * src.dt, src.dt, ("brian2" if engine == "brian2" else "fast")
    silent = np.setdiff1d(np.arange(n_aff), keep)
    return SpikeTrains(t=t, counts=spread_counts(counts, keep, n_aff), afferent_ids=ids, duration=dur, dt=step,
                       engine=eng, backend=backend, silent_skipped=silent, params=params, t_start=src.t_start,
                       notes=tuple(notes))


def _run_brian2_zones(plan, aff: np.ndarray, keep: np.ndarray, params: LIFParams):
    """The brian2 zones engine: one neuron per zone, a delay-free ``Synapses`` from every zone to the
    other zones of its afferent that resets them and starts their refractory period. Returns (spike
    steps grouped by afferent, count per kept afferent); zones crossing in one step are one spike."""
    from ._grid import _run_brian2

    cols = np.flatnonzero(np.isin(aff, keep))
    owner = np.searchsorted(keep, aff[cols])
    pre, post = np.nonzero((owner[:, None] == owner[None, :]) & ~np.eye(cols.size, dtype=bool))
    steps, counts = _run_brian2(plan, cols, params, links=(pre, post))
    zone_of = np.repeat(np.arange(cols.size), counts)
    pairs = np.unique(np.stack([owner[zone_of], steps]), axis=1) if steps.size else np.zeros((2, 0), np.int64)
    return _group_numpy(pairs[1].astype(np.int64), pairs[0].astype(np.int64), keep.size)
