"""LIF parameters (:class:`LIFParams`, :data:`~afferent.spiking.LIF_PRESETS`) and brian2's step arithmetic the grid engines share.

The presets' sources are given in the docstring of :mod:`afferent.spiking`.
"""

from __future__ import annotations

from .._typing import ArrayLike

import numbers
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .._validation import check_option, check_positive

#: The spiking engines (:data:`afferent.spiking.ENGINES`, documented there).
Engine = Literal["auto", "exact", "exact-numba", "exact-numpy", "fast", "fast-numba", "fast-numpy", "brian2"]
#: How the input current holds between its samples (:data:`afferent.spiking.INPUT_HOLDS`).
InputHold = Literal["previous", "linear"]

# brian2's timestep() shifts by 1e-3 dt before flooring (brian2/core/functions.py).
_TIMESTEP_SHIFT = 1e-3
# brian2's Clock rounds a duration to a whole step if within 1e-4 dt (Clock.epsilon_dt).
_CLOCK_EPS = 1e-4
# A sample time within this fraction of dt after a grid point counts as on it.
_SAMPLE_EPS = 1e-3
# |r_m * I| above this (in V) would overflow the update to inf/NaN.
_MAX_DRIVE_V = 1e300


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
    afferent.spiking.LIF_PRESETS : documented parameter sets with their sources.
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
        """Return one of the documented parameter sets of :data:`~afferent.spiking.LIF_PRESETS` (``'ra'``, ``'sa1'``)."""
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

    def first_spike_latency(self, current: ArrayLike) -> np.ndarray:
        """Exact time from rest to the first spike for a constant ``current`` (A), in s.

        ``tau_m ln(r_m I / (r_m I - theta))``; ``inf`` at or below the rheobase.
        """
        return self._time_to_threshold(current, self.v_rest)

    def steady_isi(self, current: ArrayLike) -> np.ndarray:
        """Exact inter-spike interval for a constant ``current`` (A), in s.

        ``t_ref + tau_m ln((r_m I - (v_reset - v_rest)) / (r_m I - theta))`` (see the Spikes page of
        the documentation, docs/spikes.md; with ``v_reset = v_rest`` the study's formula). ``inf`` at or below the rheobase.
        """
        return self.t_ref + self._time_to_threshold(current, self.v_reset)

    def steady_rate(self, current: ArrayLike) -> np.ndarray:
        """Exact firing rate ``1 / steady_isi(current)`` in Hz; 0 at or below the rheobase."""
        isi = self.steady_isi(current)
        with np.errstate(divide="ignore"):
            return np.where(np.isfinite(isi), 1.0 / isi, 0.0)


# Documented in afferent.spiking, where the API reference shows it.
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


def grid_isi_bounds(params: LIFParams, current: ArrayLike, *, dt: float) -> tuple[np.ndarray, np.ndarray]:
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
