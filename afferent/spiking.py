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
    samples plus a log per spike: numba when it is installed (the afferents split in blocks
    over one thread per core, with identical results), else numpy (``'exact-numba'`` /
    ``'exact-numpy'`` force a back end; the two agree to ~1e-13 s).
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

``'sa1'`` - SA-I skin-neuron model values from the public Gerling-lab model code (Python
constants file of the mouse SA-I model with Merkel-cell groups [8, 5, 3, 1] per heminode, the
model line of Lesniak & Gerling 2009, Math Biosci 220:15, and Lesniak et al. 2014, eLife
3:e01488): ``LIF_PARAMS = [30 mV threshold, 30 pF, 5 GOhm]`` (marked "Original Version"; a
sibling version of the file has 1.667 GOhm), ``REFRACTORY_PERIOD = 1 ms``; voltages measured
from rest (V_rest = V_reset = 0). So ``tau_m = R C = 150 ms`` and the rheobase is 6 pA. These
values were read from that code, not checked against the papers' tables. With the study's
currents (>= 10 nA) every afferent would sit at the 1 / t_ref ceiling: this set expects
pA-scale generator currents.
"""

from __future__ import annotations

import numbers
import os
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ._validation import check_option, check_positive, describe_array

__all__ = [
    "LIFParams",
    "LIF_PRESETS",
    "SpikeTrains",
    "simulate_lif",
    "grid_isi_bounds",
    "ENGINES",
    "INPUT_HOLDS",
    "DRIVE_MAPPINGS",
    "rheobase_scale",
    "drive_report",
]

#: How an input current (A) becomes the membrane drive ``r_m I`` (V) of the LIF:
#:
#: * ``'resistance'``: as is, through the preset's ``r_m`` (V = r_m I). The study's currents are
#:   not physiological (its longitudinal fit gives 8-16 uA per afferent), so with a fixed r_m the
#:   drive can be hundreds of rheobases and every afferent sits at 1 / t_ref.
#: * ``'rheobase'``: the current is rescaled so that a reference current (the largest input
#:   current of the run, or a stated one) is ``multiple`` x the rheobase; the pattern across
#:   afferents and time is kept, the absolute level is a declared modelling choice.
DRIVE_MAPPINGS = ("resistance", "rheobase")
#: Fraction of the 1 / t_ref ceiling at which a rate counts as saturated by the LIF.
CEILING_FRACTION = 0.9

def rheobase_scale(values, lif: "LIFParams", *, multiple: float, reference: float | None = None) -> tuple[float, float]:
    """Factor that maps a reference current to ``multiple`` x the LIF's rheobase.

    Parameters
    ----------
    values : array_like
        The input currents in A (to find the reference when none is given).
    lif : LIFParams
        Its rheobase ``(v_thresh - v_rest) / r_m`` in A is the target unit.
    multiple : float
        How many rheobases the reference current becomes, > 0 (2: the strongest afferent fires
        at about 1 / (t_ref + tau_m ln 2)).
    reference : float, optional
        The reference current in A; default the largest |value|.

    Returns
    -------
    (scale, reference) : tuple of float
        Multiply the currents by ``scale`` (dimensionless); ``reference`` in A.
    """
    multiple = check_positive("multiple", multiple, unit="rheobases")
    ref = float(np.max(np.abs(np.asarray(values, dtype=float)))) if reference is None else float(reference)
    if not ref > 0:
        return 1.0, ref
    return multiple * lif.rheobase / ref, ref


def drive_report(input_values, lif: "LIFParams", spikes: "SpikeTrains") -> dict:
    """What the LIF made of its drive, per afferent, and whether the rates carry information.

    Parameters
    ----------
    input_values : array_like of shape (n_times, n_afferents)
        The current fed to the LIF, in A (after any mapping).
    lif : LIFParams
    spikes : SpikeTrains

    Returns
    -------
    dict
        Per afferent (lists): ``peak_current_a``, ``drive_over_rheobase`` (r_m I_peak over
        v_thresh - v_rest), ``predicted_rate_hz`` (the closed-form rate of a constant I_peak),
        ``rate_hz`` (simulated mean), ``peak_instantaneous_hz``; and ``ceiling_hz`` (1 / t_ref),
        ``all_at_ceiling`` (every afferent's peak instantaneous rate >= 90 % of it),
        ``all_silent``, ``warning`` (a sentence, or None).
    """
    v = np.asarray(input_values, dtype=float)
    peak = np.max(v, axis=0) if v.size else np.zeros(spikes.n_afferents)
    ratio = peak / lif.rheobase
    ceiling = 1.0 / lif.t_ref if lif.t_ref > 0 else float("inf")
    inst = spikes.peak_rate()
    all_ceiling = bool(spikes.n_afferents and np.all(inst >= CEILING_FRACTION * ceiling))
    all_silent = bool(spikes.n_afferents and np.all(spikes.n_spikes == 0))
    warning = None
    if all_ceiling:
        warning = (f"All {spikes.n_afferents} afferents fire at >= {CEILING_FRACTION:.0%} of 1/t_ref ({ceiling:.4g} Hz): "
                   f"their drive is {ratio.min():.3g}-{ratio.max():.3g} x the rheobase, so the rates carry no information "
                   "about the SED pattern. Map the current to the membrane with drive 'rheobase' (the largest current -> "
                   "k x the rheobase) or choose r_m for these currents.")
    elif all_silent:
        warning = (f"All {spikes.n_afferents} afferents are silent: their drive peaks at {ratio.max():.3g} x the rheobase "
                   "(< 1 never fires). Map the current with drive 'rheobase' or choose r_m for these currents.")
    return {
        "peak_current_a": peak.tolist(), "drive_over_rheobase": ratio.tolist(),
        "predicted_rate_hz": lif.steady_rate(peak).tolist(), "rate_hz": spikes.rates().tolist(),
        "peak_instantaneous_hz": inst.tolist(), "ceiling_hz": ceiling, "all_at_ceiling": all_ceiling,
        "all_silent": all_silent, "warning": warning,
    }


#: Engines accepted by :func:`simulate_lif`.
ENGINES = ("auto", "exact", "exact-numba", "exact-numpy", "fast", "fast-numba", "fast-numpy", "brian2")
#: How :func:`simulate_lif` reads the current between samples: ``'previous'`` holds each sample
#: until the next (like brian2's ``TimedArray``; all engines), ``'linear'`` interpolates
#: linearly between samples (the exact engine only).
INPUT_HOLDS = ("previous", "linear")

# brian2's timestep() shifts by 1e-3 dt before flooring (brian2/core/functions.py).
_TIMESTEP_SHIFT = 1e-3
# brian2's Clock rounds a duration to a whole step if within 1e-4 dt (Clock.epsilon_dt).
_CLOCK_EPS = 1e-4
# A sample time within this fraction of dt after a grid point counts as on it.
_SAMPLE_EPS = 1e-3
# |r_m * I| above this (in V) would overflow the update to inf/NaN.
_MAX_DRIVE_V = 1e300
# Step indices are int32 in the spike buffers; the step -> sample map alone is 8 bytes a step.
_MAX_STEPS = 2.0**31 - 1


def _check_voltage(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"The {name!r} field of LIFParams must be a real number in V; got {value!r} instead.")
    if not np.isfinite(float(value)):
        raise ValueError(f"The {name!r} field of LIFParams must be a finite real number in V; got {value!r} instead.")
    return float(value)


@dataclass(frozen=True)
class LIFParams:
    """Parameters of the leaky integrate-and-fire neuron, in SI units.

    ``tau_m dV/dt = -(V - v_rest) + r_m I``; a spike when ``V >= v_thresh``, then
    ``V = v_reset`` held for ``t_ref``.

    Parameters
    ----------
    tau_m : float
        Membrane time constant in s (``r_m`` times the membrane capacitance), > 0.
    r_m : float
        Membrane (input) resistance in Ohm, > 0.
    v_rest : float
        Resting potential in V (the neuron starts here).
    v_thresh : float
        Firing threshold in V, > ``v_rest``.
    v_reset : float
        Potential after a spike in V, < ``v_thresh``.
    t_ref : float
        Absolute refractory period in s, >= 0. On a grid it is rounded down to
        ``floor(t_ref / dt + 1e-3)`` steps, as brian2 does.

    See Also
    --------
    LIF_PRESETS : documented parameter sets with their sources.
    simulate_lif : run the neuron on an afferent current.

    Examples
    --------
    >>> p = LIFParams(tau_m=0.01, r_m=1e7, v_rest=-0.07, v_thresh=-0.05, v_reset=-0.07, t_ref=0.002)
    >>> round(p.rheobase * 1e9, 6)   # nA
    2.0
    >>> round(float(p.steady_rate(4e-9)), 3)   # Hz, closed form
    111.964
    """

    tau_m: float
    r_m: float
    v_rest: float
    v_thresh: float
    v_reset: float
    t_ref: float

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "tau_m", check_positive("tau_m", self.tau_m, unit="s", owner="LIFParams"))
        set_(self, "r_m", check_positive("r_m", self.r_m, unit="Ohm", owner="LIFParams"))
        for name in ("v_rest", "v_thresh", "v_reset"):
            set_(self, name, _check_voltage(name, getattr(self, name)))
        set_(self, "t_ref", check_positive("t_ref", self.t_ref, unit="s", strict=False, owner="LIFParams"))
        if not self.v_thresh > self.v_rest:
            raise ValueError(
                f"The 'v_thresh' field of LIFParams must be > v_rest = {self.v_rest!r} V; "
                f"got {self.v_thresh!r} instead."
            )
        if not self.v_reset < self.v_thresh:
            raise ValueError(
                f"The 'v_reset' field of LIFParams must be < v_thresh = {self.v_thresh!r} V; "
                f"got {self.v_reset!r} instead."
            )

    @classmethod
    def from_preset(cls, name: str) -> LIFParams:
        """Return one of the documented parameter sets of :data:`LIF_PRESETS` (``'ra'``, ``'sa1'``)."""
        check_option("name", name, tuple(LIF_PRESETS))
        return LIF_PRESETS[name]

    @property
    def theta(self) -> float:
        """Threshold distance ``v_thresh - v_rest`` in V."""
        return self.v_thresh - self.v_rest

    @property
    def rheobase(self) -> float:
        """Smallest constant current that ever fires, ``(v_thresh - v_rest) / r_m``, in A.

        A current at or below it never reaches threshold (the spike time is infinite).
        """
        return self.theta / self.r_m

    def _time_to_threshold(self, current, v0: float) -> np.ndarray:
        drive = self.r_m * np.asarray(current, dtype=np.float64)
        out = np.full(drive.shape, np.inf)
        ok = drive > self.theta
        # ln((D - (v0 - v_rest)) / (D - theta)) as log1p, exact also for D >> theta
        out[ok] = self.tau_m * np.log1p((self.theta - (v0 - self.v_rest)) / (drive[ok] - self.theta))
        return out

    def first_spike_latency(self, current) -> np.ndarray:
        """Exact time from rest to the first spike for a constant ``current`` (A), in s.

        ``tau_m ln(r_m I / (r_m I - theta))``; ``inf`` at or below the rheobase.
        """
        return self._time_to_threshold(current, self.v_rest)

    def steady_isi(self, current) -> np.ndarray:
        """Exact inter-spike interval for a constant ``current`` (A), in s.

        ``t_ref + tau_m ln((r_m I - (v_reset - v_rest)) / (r_m I - theta))`` (see the Spikes page of
        the documentation, docs/spikes.md; with ``v_reset = v_rest`` the study's formula). ``inf`` at or below the rheobase.
        """
        return self.t_ref + self._time_to_threshold(current, self.v_reset)

    def steady_rate(self, current) -> np.ndarray:
        """Exact firing rate ``1 / steady_isi(current)`` in Hz; 0 at or below the rheobase."""
        isi = self.steady_isi(current)
        with np.errstate(divide="ignore"):
            return np.where(np.isfinite(isi), 1.0 / isi, 0.0)


#: Documented default parameter sets; see the module docstring for the sources.
#:
#: * ``'ra'``: RA-like, tau_m and t_ref from TouchSim's RA fits; r_m illustrative (rheobase 100 nA
#:   inside the study's current range).
#: * ``'sa1'``: SA-I skin-neuron model values from Gerling-lab model code (30 mV, 30 pF, 5 GOhm, 1 ms).
LIF_PRESETS: dict[str, LIFParams] = {
    "ra": LIFParams(tau_m=4.47e-3, r_m=2.0e5, v_rest=-0.070, v_thresh=-0.050, v_reset=-0.070, t_ref=1.2e-3),
    "sa1": LIFParams(tau_m=5e9 * 30e-12, r_m=5e9, v_rest=0.0, v_thresh=0.030, v_reset=0.0, t_ref=1e-3),
}


def _refractory_steps(t_ref: float, dt: float) -> int:
    """brian2's ``timestep(t_ref, dt)``: ``floor((t_ref + 1e-3 dt) / dt)``."""
    return int(np.array((t_ref + _TIMESTEP_SHIFT * dt) / dt, dtype=np.int64))


def _n_steps(duration: float, dt: float) -> int:
    """brian2's ``Clock._calc_timestep``: round to a whole step if within 1e-4 dt, else round up."""
    n = int(np.round(duration / dt))
    if n * dt == duration or abs(n * dt - duration) / dt <= _CLOCK_EPS:
        return n
    return int(np.ceil(duration / dt))


def grid_isi_bounds(params: LIFParams, current, *, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds on the inter-spike interval the grid engines produce for a constant current.

    ``ISI_grid = (n_eff - 1 + ceil(T_r / dt)) dt`` with ``n_eff = max(n_ref, 1)``,
    ``n_ref = floor(t_ref / dt + 1e-3)`` and ``T_r = tau_m ln((r_m I - (v_reset - v_rest)) /
    (r_m I - theta))``, so ``lo <= ISI_grid < hi`` with ``lo = (n_eff - 1) dt + T_r`` and
    ``hi = lo + dt`` (both widened by 1e-6 dt for floating-point rounding of V). The looser,
    parameter-free form is ``ISI - 2 dt < ISI_grid < ISI + dt`` (module docstring).

    Parameters
    ----------
    params : LIFParams
    current : float or array_like
        Constant current(s) in A.
    dt : float
        Time step in s.

    Returns
    -------
    lo, hi : ndarray
        Bounds in s, shaped like ``current``; ``inf`` at or below the rheobase.
    """
    dt = check_positive("dt", dt, unit="s")
    n_eff = max(_refractory_steps(params.t_ref, dt), 1)
    t_r = params._time_to_threshold(current, params.v_reset)
    lo = (n_eff - 1) * dt + t_r - 1e-6 * dt
    return lo, lo + dt + 2e-6 * dt


# --------------------------------------------------------------------------------------------
# Result object
# --------------------------------------------------------------------------------------------


def _readonly(a: np.ndarray) -> np.ndarray:
    if not a.flags.c_contiguous:
        a = np.ascontiguousarray(a)
    if a.flags.writeable:
        a = a.view()
        a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class SpikeTrains:
    """Spike times of a population of afferents, from :func:`simulate_lif`.

    Parameters
    ----------
    spike_times : tuple of ndarray
        One sorted array of spike times in s per afferent (``n_afferents`` arrays). Exact
        engine: the threshold crossing times, in ``[t_start, t_start + duration)``. Grid
        engines: ``t_start + k dt`` for whole steps ``k``, a spike stamped at the start of the
        step in which V crossed threshold.
    afferent_ids : ndarray of shape (n_afferents,)
        Identifier of each afferent (the current's ``afferent_ids`` if it has them, else
        ``0 .. n_afferents - 1``).
    duration : float
        Simulated time in s (a whole number of steps on a grid; as asked with the exact engine).
    dt : float
        Time step in s; ``0.0`` for the exact engine, which has no grid.
    engine : str
        ``'exact'``, ``'fast'`` or ``'brian2'``.
    backend : str
        What ran: ``'numba'`` or ``'numpy'`` for the exact and fast engines, ``'brian2-numpy'``
        for brian2.
    silent_skipped : ndarray of int
        Positions (0-based columns of the current) of afferents that were not simulated
        because they are provably silent: ``r_m max(I) <= v_thresh - v_rest`` over the
        simulated window (see the Spikes page of the documentation, docs/spikes.md). The grid
        engines keep a margin of a few rounding errors so the skip never disagrees with a
        simulation; the exact engine, which fires only where the drive exceeds
        ``v_thresh - v_rest``, needs none.
    params : LIFParams
        The neuron parameters used.
    t_start : float, default=0.0
        Time of the first step in s (the current's first sample time).
    notes : tuple of str
        Remarks recorded by the simulation (refractory rounding, unused input samples, ...).

    Notes
    -----
    Arrays are read-only; the object compares by identity (``eq=False``).
    """

    spike_times: tuple
    afferent_ids: np.ndarray
    duration: float
    dt: float
    engine: str
    backend: str
    silent_skipped: np.ndarray
    params: LIFParams
    t_start: float = 0.0
    notes: tuple = field(default_factory=tuple)

    def __post_init__(self):
        trains = tuple(_readonly(np.asarray(t, dtype=np.float64)) for t in self.spike_times)
        object.__setattr__(self, "spike_times", trains)
        object.__setattr__(self, "afferent_ids", _readonly(np.asarray(self.afferent_ids)))
        object.__setattr__(self, "silent_skipped", _readonly(np.asarray(self.silent_skipped, dtype=np.int64)))
        if self.afferent_ids.shape != (len(trains),):
            raise ValueError(
                f"'afferent_ids' must be an array of shape (n_afferents,) = ({len(trains)},); "
                f"got shape {self.afferent_ids.shape} instead."
            )

    @property
    def n_afferents(self) -> int:
        """Number of afferents (simulated or skipped)."""
        return len(self.spike_times)

    @property
    def n_spikes(self) -> np.ndarray:
        """Spike count per afferent, ndarray of shape (n_afferents,)."""
        return np.array([t.size for t in self.spike_times], dtype=np.int64)

    @property
    def simulated(self) -> np.ndarray:
        """Boolean mask of shape (n_afferents,): True where the afferent was simulated."""
        mask = np.ones(self.n_afferents, dtype=bool)
        mask[self.silent_skipped] = False
        return mask

    def rates(self) -> np.ndarray:
        """Mean firing rate over the simulated window, in Hz: ``n_spikes / duration``."""
        return self.n_spikes / self.duration

    def rates_between(self, t0: float, t1: float) -> np.ndarray:
        """Mean rate of each afferent over [t0, t1) in s, in Hz (NaN for an empty interval)."""
        if not t1 > t0:
            return np.full(self.n_afferents, np.nan)
        return np.array([np.count_nonzero((t >= t0) & (t < t1)) for t in self.spike_times], dtype=float) / (t1 - t0)

    def peak_rate(self) -> np.ndarray:
        """Peak instantaneous rate of each afferent, 1 / (shortest inter-spike interval), in Hz;
        0 below two spikes. Bursts at a ramp's onset show here, not in the window mean."""
        return np.array([1.0 / np.diff(t).min() if t.size >= 2 else 0.0 for t in self.spike_times])

    def first_spike_latency(self) -> np.ndarray:
        """Time from ``t_start`` to each afferent's first spike in s; NaN if it never fired."""
        return np.array([t[0] - self.t_start if t.size else np.nan for t in self.spike_times])

    def isi(self) -> tuple:
        """Inter-spike intervals in s: one array of length ``n_spikes - 1`` per afferent."""
        return tuple(np.diff(t) for t in self.spike_times)

    def psth(self, bin_width: float) -> tuple[np.ndarray, np.ndarray]:
        """Population peri-stimulus time histogram.

        Parameters
        ----------
        bin_width : float
            Bin width in s; the last bin is cut at the end of the window.

        Returns
        -------
        rate_hz : ndarray of shape (n_bins,)
            Mean rate per afferent in each bin, in Hz (spikes / (n_afferents * bin width)).
        edges : ndarray of shape (n_bins + 1,)
            Bin edges in s, from ``t_start`` to ``t_start + duration``.
        """
        bin_width = check_positive("bin_width", bin_width, unit="s")
        n_bins = max(int(np.ceil(self.duration / bin_width - 1e-9)), 1)
        edges = self.t_start + np.minimum(np.arange(n_bins + 1) * bin_width, self.duration)
        allspikes = np.concatenate(self.spike_times) if self.n_afferents else np.empty(0)
        counts, _ = np.histogram(allspikes, bins=edges)
        denom = max(self.n_afferents, 1) * np.diff(edges)
        return counts / denom, edges

    def to_dataframe(self):
        """Tidy table of every spike: columns ``afferent`` and ``spike_time_s``, sorted by afferent."""
        import pandas as pd

        counts = self.n_spikes
        return pd.DataFrame(
            {
                "afferent": np.repeat(self.afferent_ids, counts),
                "spike_time_s": np.concatenate(self.spike_times) if self.n_afferents else np.empty(0),
            }
        )

    def summary(self):
        """One row per afferent, as a DataFrame indexed by ``afferent``.

        Columns: ``n_spikes``; ``rate_hz``; ``first_spike_latency_s`` (NaN if it never fired);
        ``mean_isi_s`` (NaN below 2 spikes); ``cv_isi``, the standard deviation over the mean
        of the ISIs (NaN below 3 spikes); ``simulated`` (False for afferents skipped as
        provably silent).
        """
        import pandas as pd

        isis = self.isi()
        mean_isi = np.array([d.mean() if d.size >= 1 else np.nan for d in isis])
        cv_isi = np.array([d.std() / d.mean() if d.size >= 2 else np.nan for d in isis])
        df = pd.DataFrame(
            {
                "n_spikes": self.n_spikes,
                "rate_hz": self.rates(),
                "first_spike_latency_s": self.first_spike_latency(),
                "mean_isi_s": mean_isi,
                "cv_isi": cv_isi,
                "simulated": self.simulated,
            },
            index=pd.Index(self.afferent_ids, name="afferent"),
        )
        return df

    def __repr__(self) -> str:
        return (
            f"<SpikeTrains: {self.n_afferents} afferents ({self.silent_skipped.size} skipped as silent), "
            f"{int(self.n_spikes.sum())} spikes in {self.duration:g} s, engine {self.engine!r} ({self.backend}), "
            + (f"dt={self.dt:g} s>" if self.dt else "no grid>")
        )


# --------------------------------------------------------------------------------------------
# Input preparation
# --------------------------------------------------------------------------------------------


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


def _as_current(current, times):
    """Split ``current`` into (values, times or None, afferent_ids or None).

    An object with ``values`` and ``times`` (an AfferentCurrent) brings its own times; when
    those are ``None`` (unknown) it is treated like an ndarray, and ``times`` may be passed.
    """
    if isinstance(current, np.ndarray) or not (hasattr(current, "values") and hasattr(current, "times")):
        return current, times, None
    own = current.times
    if times is not None and own is not None:
        raise ValueError(
            "Pass 'times' only with an ndarray current; the "
            f"{type(current).__name__} carries its own times. Got times={describe_array(times)} instead."
        )
    return current.values, (own if own is not None else times), getattr(current, "afferent_ids", None)


def _read_input(current, times):
    """Validated (values (n_times, n_afferents) float64, times (n_times,) or None, afferent ids)."""
    values, times, ids = _as_current(current, times)
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"'current' must be a numeric array in A; got {type(values).__name__} instead.") from err
    if arr.ndim != 2:
        hint = " For one afferent pass current[:, None]." if arr.ndim == 1 else ""
        raise ValueError(
            f"'current' must be an array of shape (n_times, n_afferents) in A; got shape {arr.shape} instead.{hint}"
        )
    if arr.shape[0] == 0:
        raise ValueError(f"'current' must have at least one time step; got shape {arr.shape} instead.")
    # max/min propagate NaN and inf: a cheap, temporary-free test before locating any culprit
    if arr.size and not (np.isfinite(arr.max()) and np.isfinite(arr.min())):
        bad = ~np.isfinite(arr)
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        kind = "NaN" if np.isnan(arr[first]) else "infinite"
        raise ValueError(
            f"'current' must be finite; got {int(bad.sum())} non-finite value(s) (first: {kind} at index {first}) "
            "instead."
        )
    n_times = arr.shape[0]
    t = None
    if times is not None:
        t = np.asarray(times, dtype=np.float64)
        if t.shape != (n_times,):
            raise ValueError(
                f"'times' must be an array of shape (n_times,) = ({n_times},) in s to match 'current'; "
                f"got shape {t.shape} instead."
            )
        if not np.all(np.isfinite(t)):
            raise ValueError("'times' must be finite; got non-finite values instead.")
        steps_back = np.flatnonzero(np.diff(t) <= 0)
        if steps_back.size:
            k = int(steps_back[0]) + 1
            raise ValueError(
                f"'times' must be strictly increasing in s; got times[{k}] = {float(t[k])!r} <= times[{k - 1}] = "
                f"{float(t[k - 1])!r} instead."
            )
    if ids is None:
        ids = np.arange(arr.shape[1])
    else:
        ids = np.asarray(ids)
        if ids.shape != (arr.shape[1],):
            raise ValueError(
                f"'afferent_ids' of the current must have shape (n_afferents,) = ({arr.shape[1]},); "
                f"got shape {ids.shape} instead."
            )
    return arr, t, ids


def _plan(current, dt, duration, times) -> _Plan:
    arr, t, ids = _read_input(current, times)
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

    if duration is None:
        duration = default_duration
    else:
        duration = check_positive("duration", duration, unit="s")
    if not duration / dt < _MAX_STEPS:
        raise ValueError(
            f"duration / dt must be below {_MAX_STEPS:.0f} steps; got {duration / dt:.3g} steps "
            f"(duration {duration!r} s, dt {dt!r} s) instead."
        )
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

    return _Plan(arr, idx.astype(np.int64), n_steps, dt, t_start, ratio, ids, notes)


def _peak_current(plan: _Plan) -> np.ndarray:
    """Largest current of each afferent over the input samples the simulation uses, in A."""
    lo, hi = int(plan.idx[0]), int(plan.idx[-1])
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


def _group_by_col(steps, cols, out, counts):
    """Counting sort of spikes by column, keeping time order (plain Python, run by numba).

    Fills ``out`` (steps grouped by column) and ``counts`` (zeroed, one per column); both are
    allocated by the caller so that Python's memory tools see them.
    """
    n = counts.shape[0]
    for k in range(cols.shape[0]):
        counts[cols[k]] += 1
    start = np.empty(n, np.int64)
    acc = 0
    for j in range(n):
        start[j] = acc
        acc += counts[j]
    for k in range(cols.shape[0]):
        c = cols[k]
        out[start[c]] = steps[k]
        start[c] += 1


_NUMBA_LOOP = None
_NUMBA_GROUP = None


def _numba_available() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def _numba_loop():
    global _NUMBA_LOOP
    if _NUMBA_LOOP is None:
        import numba

        _NUMBA_LOOP = numba.njit(cache=True, nogil=True)(_lif_loop)
    return _NUMBA_LOOP


def _numba_group():
    global _NUMBA_GROUP
    if _NUMBA_GROUP is None:
        import numba

        _NUMBA_GROUP = numba.njit(cache=True, nogil=True)(_group_by_col)
    return _NUMBA_GROUP


def _group_numpy(steps: np.ndarray, cols: np.ndarray, n: int):
    """Spikes grouped by column in time order: (steps sorted by column, count per column)."""
    # numpy's stable sort is a radix sort for 16-bit keys: O(n), several times faster than on int64
    order = np.argsort(cols.astype(np.uint16) if n <= 2**16 else cols, kind="stable")
    return steps[order], np.bincount(cols, minlength=n).astype(np.int64)


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
            current = plan.values[row] if all_cols else plan.values[row, cols]
            np.multiply(r, current, out=a)
            np.multiply(mr, current, out=b)
            np.add(c0, b, out=b)
            np.multiply(E, b, out=b)
            row_now = row
        np.multiply(E, v, out=tmp)
        np.add(a, tmp, out=tmp)
        np.add(tmp, b, out=tmp)
        np.add(v_rest, tmp, out=v)
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


def _run_brian2(plan: _Plan, cols: np.ndarray, params: LIFParams):
    """The reference engine: brian2 NeuronGroup + TimedArray + SpikeMonitor in an explicit Network.

    Code objects use brian2's numpy target through ``codeobj_class`` (nothing is compiled and
    the global ``prefs.codegen.target`` is left alone).
    """
    import brian2 as b2
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
    net.run(plan.n_steps * dt * b2.second, namespace={})
    steps = np.rint(np.asarray(monitor.t_) / dt).astype(np.int64)
    return _group_numpy(steps, np.asarray(monitor.i, dtype=np.int64), cols.size)


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


def _pieces(current, dt, duration, times, tau_m: float, hold: str) -> _Pieces:
    """Input pieces of the exact engine: the current's own sample times, no grid."""
    arr, t, ids = _read_input(current, times)
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
    return _Pieces(arr, starts, ends, decay, growth, nxt, inv_h, t_start, t_stop, ids, notes)


def _exact_loop(values, cols, starts, ends, decay, growth, nxt, inv_h, k0, j0, u, ref_end, eg, consts, out_t, out_c):
    """Event loop of the exact engine (plain Python source, run compiled by numba).

    Walks the pieces from piece ``k0``, afferent ``j0``; writes spike times and columns into
    ``out_t`` / ``out_c`` from position 0. When the buffers are full it returns
    ``(k, j, count)`` before the spike that did not fit, with ``u`` / ``ref_end`` / ``eg``
    holding a state the loop resumes from bit for bit; ``k == len(starts)`` when done.
    ``eg`` carries ``exp(-(t_end - ref_end) / tau)`` for the end ``t_end`` of the last piece
    seen, so that resuming after a refractory period needs no exp (held input: it is the
    decay to the piece's end times ``(D - u) / (D - theta)`` times ``exp(t_ref / tau)``, then
    times each skipped piece's decay; an exp replaces it if it under- or overflowed).

    In a piece, an afferent not refractory starts at the piece start (decay ``decay[k]``
    shared by all) or, if its refractory period ends inside the piece, at that time with
    ``u = u_reset``. With a constant drive ``D`` it reaches threshold within the piece iff
    ``D > theta`` and ``D + (u - D) e^(-h / tau) >= theta``, at
    ``t + tau log1p((theta - u) / (D - theta))``. With a linear drive the crossing is
    bracketed in closed form (V - v_thresh is convex or concave in t) and found by Newton's
    method from the side where it converges monotonically.
    """
    r, theta, u_reset, tau, t_ref, t_stop, eri = consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], consts[6]
    n = cols.shape[0]
    n_pieces = starts.shape[0]
    cap = out_t.shape[0]
    count = 0
    for k in range(k0, n_pieces):
        t0 = starts[k]
        t1 = ends[k]
        row = values[k]
        row1 = values[nxt[k]]
        ih = inv_h[k]
        for j in range(j0 if k == k0 else 0, n):
            tr = ref_end[j]
            if tr >= t1:  # refractory through the whole piece
                eg[j] *= decay[k]
                continue
            c = cols[j]
            d0 = r * row[c]
            uj = u[j]  # u_reset if the neuron spiked: set with ref_end
            if ih == 0.0 and tr <= t0:  # fast path: held input, no crossing in the piece
                u_end = d0 + (uj - d0) * decay[k]
                if d0 <= theta or u_end < theta:
                    u[j] = u_end
                    continue
            s = r * (row1[c] - row[c]) * ih  # drive slope, V/s (0 when held)
            if tr > t0:
                t = tr
                # decay from tr to t1; saved as is when the loop stopped at this afferent
                e = eg[j] if (k == k0 and j == j0) else decay[k] * eg[j]
                if not (0.0 < e <= 1.0):  # under- or overflowed on the way: direct
                    e = np.exp(-(t1 - t) / tau)
            else:
                t = t0
                e = decay[k]
            while True:
                h = t1 - t
                da = d0 + s * (t - t0)  # drive at t
                x = -1.0  # time from t to the crossing; < 0: none in the piece
                if s == 0.0:
                    u_end = da + (uj - da) * e
                    if da > theta and u_end >= theta:
                        x = min(tau * np.log1p((theta - uj) / (da - theta)), h)
                else:
                    db = da + s * h
                    # u(t + y) = uj + (da - uj) w + s (y - tau w), w = 1 - e^(-y / tau): every term
                    # is of the size of the change it describes (no s tau - s tau cancellation)
                    cc = uj - da + s * tau  # its sign is that of d2u/dy2
                    wh = growth[k] if t == t0 else -np.expm1(-h / tau)
                    u_end = uj + (da - uj) * wh + s * (h - tau * wh)
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
                if x < 0.0:
                    uj = u_end
                    break
                ts = t + x
                if ts >= t_stop:  # a crossing at or after the end of the window is not reported
                    uj = u_end
                    break
                uj_cross = uj
                if count == cap:  # full: resume at this afferent, from the state as stored
                    if ref_end[j] > t0:  # e is the decay from ref_end to t1
                        eg[j] = e
                    return k, j, count
                out_t[count] = ts
                out_c[count] = j
                count += 1
                tr = ts + t_ref
                ref_end[j] = tr
                u[j] = u_reset
                uj = u_reset
                # exp(-(t1 - tr) / tau) without an exp: held input, e = exp(-(t1 - t) / tau) and
                # exp(x / tau) = (da - uj) / (da - theta); > 1 while refractory past t1 (then
                # multiplied by each skipped piece's decay)
                if s == 0.0:
                    e = e * (1.0 + (theta - uj_cross) / (da - theta)) * eri
                else:
                    e = np.exp(-(t1 - tr) / tau)
                if tr >= t1:
                    eg[j] = e
                    break
                t = tr
                if not (0.0 < e <= 1.0):
                    e = np.exp(-(t1 - t) / tau)
            u[j] = uj
    return n_pieces, 0, count


_NUMBA_EXACT = None


def _numba_exact():
    global _NUMBA_EXACT
    if _NUMBA_EXACT is None:
        import numba

        _NUMBA_EXACT = numba.njit(cache=True, nogil=True, error_model="numpy")(_exact_loop)
    return _NUMBA_EXACT


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
    """One block of afferents through the compiled loop (runs without the GIL)."""
    loop = _numba_exact()
    n = cols.size
    u = np.zeros(n)
    ref_end = np.full(n, -np.inf)
    eg = np.ones(n)  # exp(-(end of the last piece seen - ref_end) / tau_m)
    consts = _exact_consts(params, pc.t_stop)
    cap = _exact_capacity(peak, pc, params)
    t_parts, c_parts = [], []
    k, j = 0, 0
    while k < pc.starts.size:
        out_t = np.empty(cap)
        out_c = np.empty(cap, np.int32)
        k, j, count = loop(
            values, cols, pc.starts, pc.ends, pc.decay, pc.growth, pc.nxt, pc.inv_h, k, j, u, ref_end, eg, consts,
            out_t, out_c,
        )
        t_parts.append(out_t[:count])
        c_parts.append(out_c[:count])
        cap *= 2
    times = t_parts[0] if len(t_parts) == 1 else np.concatenate(t_parts)
    hit = c_parts[0] if len(c_parts) == 1 else np.concatenate(c_parts)
    grouped, counts = np.empty(times.size), np.zeros(n, np.int64)
    _numba_group()(times, hit, grouped, counts)
    return grouped, counts


def _run_exact_numba(pc: _Pieces, cols: np.ndarray, params: LIFParams, peak: np.ndarray):
    """The compiled exact engine, the afferents split into contiguous blocks run on threads (the
    afferents are independent, so the spikes do not depend on the split, bit for bit)."""
    values = pc.values if pc.values.flags.c_contiguous else np.ascontiguousarray(pc.values)
    cols = cols.astype(np.int64)
    _numba_exact()  # compile or load once, before any thread
    _numba_group()
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
    """Vectorised form of the Newton iteration of :func:`_exact_loop` (same start, clamp and stop)."""
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
    """The exact engine vectorised over afferents with numpy: same events as :func:`_exact_loop`."""
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
    """Vectorised crossing search of :func:`_exact_loop` for held (s = 0) and linear drives.

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


# --------------------------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------------------------


def _check_drive(values: np.ndarray, params: LIFParams) -> None:
    if not values.size:
        return
    peak = max(float(values.max()), -float(values.min()))  # no |values| temporary
    if not peak * params.r_m < _MAX_DRIVE_V:
        worst = peak * params.r_m
        raise ValueError(
            f"r_m * max|current| must be < {_MAX_DRIVE_V:g} V for the update to stay finite; got {worst:g} V instead."
        )


def _simulate_exact(current, params: LIFParams, *, dt, engine: str, duration, times, hold: str) -> SpikeTrains:
    """The exact engine behind :func:`simulate_lif` (``engine`` 'exact', 'exact-numba', 'exact-numpy')."""
    if engine == "exact":
        backend = "numba" if _numba_available() else "numpy"
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
    values = pc.values
    n_aff = values.shape[1]
    _check_drive(values, params)
    n_pieces = pc.starts.size
    if hold == "linear" and n_pieces:  # the drive reaches the next sample's value at the piece's end
        peak = values[: int(pc.nxt[-1]) + 1].max(axis=0) if n_aff else np.zeros(0)
    else:
        peak = values[:n_pieces].max(axis=0) if n_aff else np.zeros(0)
    # The exact engine fires only where the drive exceeds theta: no rounding margin needed.
    silent = params.r_m * peak <= params.theta
    cols = np.flatnonzero(~silent)
    if cols.size:
        # Every interval is >= t_ref + (time from v_reset to threshold under the peak drive): it
        # must stay resolvable in double precision, or spikes would pile up at one time.
        isi_min = float(np.min(params.steady_isi(peak[cols])))
        resolution = 8 * np.spacing(max(abs(pc.t_start), abs(pc.t_stop)))
        if not isi_min > resolution:
            raise ValueError(
                f"The exact engine cannot resolve the inter-spike interval: t_ref + the time from v_reset to threshold "
                f"at the peak drive is {isi_min:.3g} s, at or below the time resolution {resolution:.3g} s of the "
                f"window [{pc.t_start!r}, {pc.t_stop!r}] s; got t_ref = {params.t_ref!r} s. Give t_ref > 0 or a "
                "smaller current."
            )
    if cols.size == 0:
        times_s, counts = np.empty(0), np.zeros(0, np.int64)
    elif backend == "numba":
        times_s, counts = _run_exact_numba(pc, cols, params, peak[cols])
    else:
        times_s, counts = _run_exact_numpy(pc, cols, params)
    ends = np.cumsum(counts).tolist()
    trains = [np.empty(0)] * n_aff
    for c, lo, hi in zip(cols.tolist(), [0, *ends[:-1]], ends):
        trains[c] = times_s[lo:hi]
    return SpikeTrains(
        spike_times=tuple(trains),
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


def simulate_lif(current, params: LIFParams, *, dt: float | None = None, engine: str = "auto", duration=None, times=None,
                 input_hold: str = "previous"):
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
        installed, else numpy). ``'brian2'`` is the grid reference; ``'fast'`` gives the same
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

    Returns
    -------
    SpikeTrains
        Spike times per afferent, with the engine used and the afferents skipped as silent.

    Raises
    ------
    TypeError
        If ``current`` is not numeric or a parameter has the wrong type.
    ValueError
        If a shape, a time or a parameter value is invalid, ``r_m * |current|`` would
        overflow, a grid engine is given no ``dt`` or ``input_hold='linear'``, or (exact
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

    _check_drive(values, params)

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
    ends = np.cumsum(counts).tolist()
    trains = [np.empty(0)] * n_aff
    for c, lo, hi in zip(cols.tolist(), [0, *ends[:-1]], ends):
        trains[c] = times_s[lo:hi]

    return SpikeTrains(
        spike_times=tuple(trains),
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
