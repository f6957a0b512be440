"""Indentation waveforms d(t) (m) at times (s): :class:`Waveform`, :func:`ramp_and_hold`, :func:`sinusoid`.

Documented with the rest of :mod:`afferent.stimulus`, which re-exports every public name.
"""

from __future__ import annotations

from .._typing import ArrayLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal, get_args

import numpy as np

from .._validation import check_option, check_positive, check_step_count
from .._validation import plain as _plain


#: Kinds of :class:`Waveform`.
WaveformKind = Literal["ramp-and-hold", "sinusoid", "file", "custom"]
WAVEFORM_KINDS: tuple[str, ...] = get_args(WaveformKind)
#: Policies for negative depths in the generators and :func:`read_waveform`.
OnNegative = Literal["raise", "clip"]
ON_NEGATIVE: tuple[str, ...] = get_args(OnNegative)
# Negative depths within this fraction of the waveform's scale are float rounding, set to 0 m.
_ROUNDING = 1e-12


# --------------------------------------------------------------------------------------------
# Waveforms
# --------------------------------------------------------------------------------------------


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Waveform:
    """Indentation depth over time.

    Parameters
    ----------
    times : array_like of shape (n_times,)
        Sample times in s, finite and strictly increasing.
    depth : array_like of shape (n_times,)
        Indentation depth in m at each time, finite and >= 0 (0 = indenter just touching or
        off the skin). Between samples the depth is taken as linear.
    kind : {'ramp-and-hold', 'sinusoid', 'file', 'custom'}, default='custom'
        What made the waveform.
    parameters : mapping, optional
        The generator's arguments, each key carrying its unit (``'depth_m'``,
        ``'ramp_speed_m_per_s'``, ...). Stored read-only.
    notes : tuple of str, optional
        Remarks recorded by the generator, e.g. how many samples were clipped to 0 m.

    Raises
    ------
    ValueError
        If the shapes differ, a value is not finite, ``times`` is not strictly increasing,
        or a depth is negative (the message names the first one and its time).

    Notes
    -----
    Arrays are read-only; the object compares by identity (``eq=False``).

    Examples
    --------
    >>> w = Waveform([0.0, 0.1, 0.2], [0.0, 5e-4, 5e-4])
    >>> w.duration, w.max_depth
    (0.2, 0.0005)
    >>> float(w.depth_at(0.05))
    0.00025
    """

    times: np.ndarray
    depth: np.ndarray
    kind: WaveformKind = "custom"
    parameters: object = field(default_factory=dict)
    notes: tuple = ()

    def __post_init__(self):
        check_option("kind", self.kind, WAVEFORM_KINDS)
        times = _readonly(_finite_1d("times", self.times, "s"))
        depth = _readonly(_finite_1d("depth", self.depth, "m"))
        if times.size == 0:
            raise ValueError("'times' must hold at least one sample, in s; got an empty array instead.")
        if depth.shape != times.shape:
            raise ValueError(
                f"'depth' must have one value per time (n_times = {times.size}); got shape {depth.shape} instead."
            )
        if times.size > 1 and not np.all(np.diff(times) > 0):
            k = int(np.flatnonzero(np.diff(times) <= 0)[0])
            raise ValueError(
                f"'times' must be strictly increasing; got {float(times[k])!r} s followed by "
                f"{float(times[k + 1])!r} s (samples {k} and {k + 1}) instead."
            )
        if np.any(depth < 0):
            k = int(np.flatnonzero(depth < 0)[0])
            raise ValueError(
                f"'depth' must be >= 0 m (a negative depth means the indenter has left the skin); got "
                f"{float(depth[k])!r} m at sample {k} (t = {float(times[k])!r} s) instead. Clip it to 0 m, "
                "e.g. with on_negative='clip' in sinusoid() or read_waveform()."
            )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    def __reduce__(self):
        """Pickled as its constructor's arguments (the read-only ``parameters`` view does not pickle itself); the
        figures of a run are drawn from a pickled copy in a second process (``afferent._figure_process``)."""
        return (type(self), (self.times, self.depth, self.kind, dict(self.parameters), self.notes))

    @property
    def n_times(self) -> int:
        """Number of samples."""
        return self.times.size

    @property
    def duration(self) -> float:
        """Time from the first to the last sample, in s."""
        return float(self.times[-1] - self.times[0])

    @property
    def max_depth(self) -> float:
        """Largest depth in m."""
        return float(self.depth.max())

    def depth_at(self, t: ArrayLike) -> np.ndarray:
        """Depth in m at time(s) ``t`` in s, linear between samples, held before/after the ends.

        Parameters
        ----------
        t : float or array_like
            Times in s.

        Returns
        -------
        ndarray
            Depth in m, shaped like ``t``.
        """
        return np.interp(np.asarray(t, dtype=np.float64), self.times, self.depth)

    def velocity(self) -> np.ndarray:
        """Indentation velocity in m/s at each sample (second-order finite differences; 0 for one sample)."""
        if self.n_times < 2:
            return np.zeros(1)
        return np.gradient(self.depth, self.times)

    def phases(self, *, rtol: float = 1e-6) -> list[tuple[str, float, float]]:
        """The waveform cut where the depth changes direction: ``(name, t_start, t_end)`` in s.

        Names: ``'loading'`` (depth increasing), ``'unloading'`` (decreasing), ``'hold'``
        (constant above 0), ``'off'`` (constant at 0). A ramp-and-hold gives loading, hold,
        unloading, off; a sinusoid alternates loading and unloading. Consecutive intervals of
        the same kind are merged.

        Parameters
        ----------
        rtol : float, default=1e-6
            Depth changes below ``rtol`` x the largest depth count as constant.
        """
        if self.n_times < 2:
            return [("hold" if self.depth[0] > 0 else "off", float(self.times[0]), float(self.times[0]))]
        step = np.diff(self.depth)
        tol = rtol * max(float(np.abs(self.depth).max()), 1e-300)
        kinds = np.where(step > tol, "loading", np.where(step < -tol, "unloading",
                                                          np.where(self.depth[1:] > tol, "hold", "off")))
        out: list[tuple[str, float, float]] = []
        for k, name in enumerate(kinds):
            t0, t1 = float(self.times[k]), float(self.times[k + 1])
            if out and out[-1][0] == name:
                out[-1] = (name, out[-1][1], t1)
            else:
                out.append((str(name), t0, t1))
        return out

    def table(self) -> dict:
        """Columns ``time_s`` (s) and ``depth_m`` (m), no pandas: what ``waveform.csv`` lists."""
        return {"time_s": self.times, "depth_m": self.depth}

    def to_dataframe(self) -> DataFrame:
        """Table with columns ``time_s`` and ``depth_m``."""
        import pandas as pd

        return pd.DataFrame(self.table())

    def __repr__(self) -> str:
        return (
            f"<Waveform {self.kind!r}: {self.n_times} samples over {self.duration:g} s, "
            f"depth in [{self.depth.min():.4g}, {self.depth.max():.4g}] m>"
        )


def _finite_1d(name: str, a, unit: str) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name!r} must be a numeric array in {unit}; got {type(a).__name__} instead.") from err
    if arr.ndim != 1:
        raise ValueError(f"{name!r} must be an array of shape (n_times,) in {unit}; got shape {arr.shape} instead.")
    bad = ~np.isfinite(arr)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{name!r} must be finite, in {unit}; got {float(arr[k])!r} at sample {k} instead."
        )
    return arr


def _time_grid(total: float, dt: float) -> np.ndarray:
    """Times 0, dt, 2 dt, ... up to ``total`` (s), the last sample exactly at ``total``; at most
    :data:`afferent._validation.MAX_STEPS` steps, checked before the times are allocated."""
    check_step_count(total, dt, what="The waveform's")
    n = int(np.floor(total / dt + 1e-9))
    t = np.arange(n + 1) * dt
    if abs(n * dt - total) <= 1e-6 * dt:
        t[-1] = total
    else:
        t = np.append(t, total)
    return t


def _clip_negative(depth: np.ndarray, times: np.ndarray, scale: float, on_negative: str, what: str, why: str):
    """Apply the negative-depth policy; return (depth, notes)."""
    depth = depth.copy()
    depth[(depth < 0) & (depth >= -_ROUNDING * scale)] = 0.0  # float rounding, not a lift-off
    neg = depth < 0
    if not neg.any():
        return depth, ()
    k = int(np.flatnonzero(neg)[0])
    if on_negative == "raise":
        raise ValueError(
            f"{what} must be >= 0 m (a negative depth means the indenter has left the skin); got "
            f"{float(depth[k])!r} m at t = {float(times[k])!r} s{why} instead. Pass on_negative='clip' to "
            "hold the depth at 0 m there."
        )
    n = int(neg.sum())
    depth[neg] = 0.0
    note = (
        f"depth clipped to 0 m at {n} of {depth.size} samples (indenter off the skin; first at "
        f"t = {float(times[k]):g} s){why}."
    )
    return depth, (note,)


def ramp_and_hold(depth: float, ramp_speed: float, hold: float, *, release: bool = True, dt: float,
                  pre: float = 0.0, post: float = 0.0) -> Waveform:
    """Trapezoidal indentation: ramp in at ``ramp_speed``, hold, ramp out at the same speed.

    The study's ramp-and-hold (:ref:`method-fe-model`, chapter 4) is 0.5 mm at 5 mm/s held for
    2 s: ``ramp_and_hold(0.5e-3, 5e-3, 2.0, dt=1e-4)``. Each ramp takes
    ``depth / ramp_speed`` = 0.1 s.

    Breakpoints (s): rest until ``pre``; ramp up until ``pre + T_r`` (``T_r = depth /
    ramp_speed``); hold until ``pre + T_r + hold``; with ``release`` ramp down until
    ``pre + 2 T_r + hold``; then ``post`` more seconds at the final depth (0 m after a
    release, ``depth`` without one).

    Parameters
    ----------
    depth : float
        Hold depth in m, > 0.
    ramp_speed : float
        Indenter speed on both ramps in m/s, > 0.
    hold : float
        Hold duration in s, >= 0.
    release : bool, default=True
        Ramp back out to 0 m after the hold.
    dt : float
        Sampling interval in s, > 0 and at most the ramp duration ``depth / ramp_speed``.
        Samples are at ``0, dt, 2 dt, ...``, plus one at the very end if the total is not a
        whole number of steps; the breakpoints need not fall on samples (depth is linear in
        between).
    pre, post : float, default=0.0
        Rest before the ramp and extra time after the end, in s, >= 0. Some ``post`` lets a
        rate-sensitive response to the release finish.

    Returns
    -------
    Waveform
        ``kind='ramp-and-hold'``; ``parameters`` holds the arguments and ``ramp_duration_s``.

    Raises
    ------
    TypeError
        If a number is not real.
    ValueError
        If a value is out of range, or ``dt`` exceeds the ramp duration.

    See Also
    --------
    scale_static : SED over this waveform from one static FE solution.

    Examples
    --------
    >>> w = ramp_and_hold(0.5e-3, 5e-3, 2.0, dt=1e-3)
    >>> w.parameters["ramp_duration_s"], w.duration
    (0.1, 2.2)
    >>> round(float(w.depth_at(0.1)) * 1e3, 9), round(float(w.depth_at(2.15)) * 1e3, 9)   # mm
    (0.5, 0.25)
    """
    depth = check_positive("depth", depth, unit="m")
    ramp_speed = check_positive("ramp_speed", ramp_speed, unit="m/s")
    hold = check_positive("hold", hold, unit="s", strict=False)
    dt = check_positive("dt", dt, unit="s")
    pre = check_positive("pre", pre, unit="s", strict=False)
    post = check_positive("post", post, unit="s", strict=False)
    if not isinstance(release, (bool, np.bool_)):
        raise TypeError(f"'release' must be True or False; got {_plain(release)!r} instead.")
    t_ramp = depth / ramp_speed
    if dt > t_ramp * (1 + 1e-12):
        raise ValueError(
            f"'dt' must be <= the ramp duration depth / ramp_speed = {t_ramp:g} s so the ramp is sampled; "
            f"got {dt!r} instead."
        )
    bt = [0.0, pre, pre + t_ramp, pre + t_ramp + hold]
    bd = [0.0, 0.0, depth, depth]
    if release:
        bt.append(bt[-1] + t_ramp)
        bd.append(0.0)
    bt.append(bt[-1] + post)
    bd.append(bd[-1])
    times = _time_grid(bt[-1], dt)
    values = np.interp(times, bt, bd)  # repeated breakpoints (pre = 0, hold = 0) are fine for np.interp
    params = {
        "depth_m": depth, "ramp_speed_m_per_s": ramp_speed, "hold_s": hold, "release": bool(release),
        "dt_s": dt, "pre_s": pre, "post_s": post, "ramp_duration_s": t_ramp,
    }
    return Waveform(times, values, "ramp-and-hold", params)


def sinusoid(frequency: float, amplitude: float, *, offset: float | None = None, duration: float, dt: float,
             on_negative: OnNegative = "raise") -> Waveform:
    """Sinusoidal vibration ``d(t) = offset + amplitude sin(2 pi f t)``, from t = 0.

    The study's vibration (:ref:`method-fe-model`) is 20, 30, 50 and 80 Hz at 0.5 mm amplitude:
    ``sinusoid(20.0, 0.5e-3, duration=0.5, dt=1e-5)``.

    Parameters
    ----------
    frequency : float
        Frequency in Hz, > 0.
    amplitude : float
        Amplitude in m, > 0 (half the peak-to-peak excursion).
    offset : float, optional
        Mean depth in m, >= 0. Default ``amplitude``, so the depth swings between 0 and
        ``2 * amplitude`` and just touches 0 once a cycle. The waveform starts at
        ``d(0) = offset``: a step from rest when the offset is not 0.
    duration : float
        Length in s, > 0.
    dt : float
        Sampling interval in s, < ``1 / (2 frequency)`` (Nyquist). At least 20 samples per
        period are advised; the LIF stage usually wants ``dt <= 1e-4`` s anyway.
    on_negative : {'raise', 'clip'}, default='raise'
        With ``offset < amplitude`` the indenter would leave the skin once a cycle: raise, or
        hold the depth at 0 m there and record it in ``notes``.

    Returns
    -------
    Waveform
        ``kind='sinusoid'``; ``parameters`` holds ``frequency_hz``, ``amplitude_m``,
        ``offset_m``, ``duration_s``, ``dt_s``.

    Raises
    ------
    TypeError
        If a number is not real.
    ValueError
        If a value is out of range, ``dt`` violates Nyquist, or the depth would go negative
        with ``on_negative='raise'``.

    Examples
    --------
    >>> w = sinusoid(20.0, 0.5e-3, duration=0.1, dt=1e-4)
    >>> round(w.max_depth * 1e3, 6), round(float(w.depth.min()) * 1e3, 6)
    (1.0, 0.0)
    """
    frequency = check_positive("frequency", frequency, unit="Hz")
    amplitude = check_positive("amplitude", amplitude, unit="m")
    offset = amplitude if offset is None else check_positive("offset", offset, unit="m", strict=False)
    duration = check_positive("duration", duration, unit="s")
    dt = check_positive("dt", dt, unit="s")
    check_option("on_negative", on_negative, ON_NEGATIVE)
    if not dt < 0.5 / frequency:
        raise ValueError(
            f"'dt' must be < 1 / (2 frequency) = {0.5 / frequency:g} s (Nyquist) for a {frequency:g} Hz sinusoid; "
            f"got {dt!r} instead."
        )
    times = _time_grid(duration, dt)
    depth = offset + amplitude * np.sin(2.0 * np.pi * frequency * times)
    depth, notes = _clip_negative(
        depth, times, max(amplitude, offset), on_negative, "The sinusoid's depth",
        f" (offset {offset:g} m < amplitude {amplitude:g} m)",
    )
    params = {"frequency_hz": frequency, "amplitude_m": amplitude, "offset_m": offset, "duration_s": duration,
              "dt_s": dt}
    return Waveform(times, depth, "sinusoid", params, notes)
