"""Stimuli over time: indentation waveforms, quasi-static SED scaling and RA-I adaptation.

::

    Waveform d(t) (m) ---------------------------------------------------------------+
    ReceptorSED, one static step at depth d_ref (J/m^3) --scale_static(sed, waveform, d_ref=...)--> ReceptorSED
        (n_times, n_receptors) J/m^3 over the waveform's times
      --transduce--> ReceptorCurrent --synthesize--> AfferentCurrent   (A)
      --static_input(current)----------------------> InputCurrent kind='static'          (A)
      --adapting_input(current, gain=..., tau=...)--> InputCurrent kind='rate-sensitive'  (A)
      --simulate_lif--> SpikeTrains

Three pieces, each usable on its own:

**Waveforms** (:class:`Waveform`, :func:`ramp_and_hold`, :func:`sinusoid`,
:func:`read_waveform`): the indentation depth d(t) in m, at times in s. Depth is the indenter's
travel into the skin, so d >= 0 always. A negative depth would mean the indenter has left the
skin; the skin is not pulled, so the physical depth there is 0. The :class:`Waveform` object
refuses negative depths (``ValueError``). The generators and the reader also raise by default
(``on_negative='raise'``). With ``on_negative='clip'`` they set those samples to 0 m and
record how many in ``Waveform.notes``. Nothing is clipped silently, except float rounding of
at most 1e-12 of the waveform's scale: ``sin`` of a full-depth sinusoid may give -1e-20 m.

**Quasi-static scaling** (:func:`scale_static`, :func:`depth_scaling_error`): one static FE
solution at depth ``d_ref`` gives the SED at every depth as ``SED(t) = SED_static (d(t) /
d_ref)^2``. Where that holds, and where it does not, is spelled out in :func:`scale_static`.

**RA-I adaptation** (:func:`adapting_input`, :ref:`method-spikes`): a static sigmoid of SED fed
to the LIF fires through a hold; RA-I afferents do not. :func:`adapting_input` turns the
static (receptor or afferent) current into a rate-sensitive one. It takes the full-wave
rectified, low-pass-filtered rate of change: ``I_in = k_on [r]_+ + k_off [r]_-`` with
``tau dr/dt = -r + dI/dt``. The returned :class:`InputCurrent` records which input it is
(``kind='static'`` or ``'rate-sensitive'``) and the parameters used. The study's static
input stays the default of the pipeline; :func:`static_input` tags it the same way.
"""

from __future__ import annotations

import numbers
import os
import re
import warnings
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ._validation import check_option, check_positive, describe_array
from ._validation import plain as _plain
from .exceptions import AfferentWarning, SEDFormatError, UnitError

__all__ = [
    "Waveform",
    "ramp_and_hold",
    "sinusoid",
    "read_waveform",
    "scale_static",
    "depth_scaling_error",
    "scaling_record",
    "interpolate_series",
    "ScalingCheck",
    "InputCurrent",
    "adapting_input",
    "static_input",
    "ADAPTATION_MODES",
    "DEFAULT_TAU",
]

#: Kinds of :class:`Waveform`.
WAVEFORM_KINDS = ("ramp-and-hold", "sinusoid", "file", "custom")
#: Policies for negative depths in the generators and :func:`read_waveform`.
ON_NEGATIVE = ("raise", "clip")
#: Modes of :func:`adapting_input`.
ADAPTATION_MODES = ("rectified-rate",)
#: Input kinds recorded on an :class:`InputCurrent`.
INPUT_KINDS = ("static", "rate-sensitive")
#: Default low-pass time constant of the rate in s (corner 1 / (2 pi tau) = 32 Hz; see adapting_input).
DEFAULT_TAU = 5e-3

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
    kind: str = "custom"
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

    def depth_at(self, t):
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

    def to_dataframe(self):
        """Table with columns ``time_s`` and ``depth_m``."""
        import pandas as pd

        return pd.DataFrame({"time_s": self.times, "depth_m": self.depth})

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
    """Times 0, dt, 2 dt, ... up to ``total`` (s), the last sample exactly at ``total``."""
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
             on_negative: str = "raise") -> Waveform:
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


_UNIT_IN_HEADER = re.compile(r"^\s*(?P<name>[^(\[]*?)\s*[(\[]\s*(?P<unit>[^)\]]*?)\s*[)\]]\s*$")


def _split_header(col) -> tuple[str, str | None]:
    """``'time (ms)'`` -> ``('time', 'ms')``; ``'Depth'`` -> ``('depth', None)``."""
    text = str(col).strip()
    m = _UNIT_IN_HEADER.match(text)
    if m:
        return m.group("name").strip().lower(), m.group("unit")
    return text.lower(), None


def read_waveform(path, *, length_unit: str, time_unit: str = "s", on_negative: str = "raise",
                  time_column: str = "time", depth_column: str = "depth") -> Waveform:
    """Read an indentation waveform from a CSV table with columns ``time`` and ``depth``.

    Separators: comma, semicolon, tab or whitespace (detected); ``#`` starts a comment.
    Column names are matched case-insensitively; a unit in the header (``time (ms)``,
    ``depth [mm]``) is allowed and must agree with the declared one. Values are converted to
    s and m, and the conversion is recorded in ``parameters``.

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    length_unit : {'m', 'mm', 'um', 'cm'}
        Unit of the depth column. Required: never guessed.
    time_unit : {'s', 'ms', 'us'}, default='s'
        Unit of the time column.
    on_negative : {'raise', 'clip'}, default='raise'
        A negative depth means the indenter has left the skin: raise, or set it to 0 m and
        record how many samples in ``notes``.
    time_column, depth_column : str, default='time', 'depth'
        Column names (without the unit).

    Returns
    -------
    Waveform
        ``kind='file'``; ``parameters`` holds ``path``, ``length_unit``, ``time_unit`` and the
        factors to SI.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    UnitError
        If a unit is unknown, or the header states a unit other than the declared one.
    SEDFormatError
        If the file is empty or unparsable, a column is missing or not numeric, the times are
        not strictly increasing, or a depth is negative with ``on_negative='raise'``. The
        message names the file and the data row (1-based, header excluded). (A ``ValueError``.)

    Examples
    --------
    >>> w = read_waveform("ramp.csv", length_unit="mm", time_unit="ms")  # doctest: +SKIP
    """

    from .units import length_factor, parse_unit, time_factor

    check_option("on_negative", on_negative, ON_NEGATIVE)
    lf = length_factor(length_unit)
    tf = time_factor(time_unit)
    path = os.fspath(path)
    where = f"Waveform file {path!r}"
    from ._tables import numeric_columns, read_table

    df, _ = read_table(path, what="Waveform file", expected=f"{time_column!r} and {depth_column!r}", as_text=True)
    headers = {}
    for col in df.columns:
        name, unit = _split_header(col)
        headers.setdefault(name, (col, unit))
    wanted = {"time": time_column.strip().lower(), "depth": depth_column.strip().lower()}
    missing = [v for v in wanted.values() if v not in headers]
    if missing:
        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise SEDFormatError(
            f"{where} must have columns {wanted['time']!r} and {wanted['depth']!r}; missing "
            f"{', '.join(map(repr, missing))}. Found columns {found}."
        )
    out = {}
    for role, declared, factor_fn, unit_kw in (
        ("time", time_unit, time_factor, "time_unit"),
        ("depth", length_unit, length_factor, "length_unit"),
    ):
        col, stated = headers[wanted[role]]
        if stated is not None:
            canon = parse_unit(stated)
            if canon is None or factor_fn(canon) != factor_fn(declared):
                raise UnitError(
                    f"{where}: column {str(col)!r} states the unit {stated!r}, but {unit_kw}={declared!r} was "
                    f"declared. Pass {unit_kw}={stated!r} if the header is right."
                )
        out[role] = numeric_columns(df, [col], what="Waveform file", path=path)[:, 0]
    t_raw, d_raw = out["time"], out["depth"]
    if t_raw.size == 0:
        raise SEDFormatError(f"{where} has no data rows; expected at least one (time, depth) sample.")
    step = np.diff(t_raw)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0])
        raise SEDFormatError(
            f"{where}: 'time' must be strictly increasing; got {_plain(t_raw[k])!r} {time_unit} followed by "
            f"{_plain(t_raw[k + 1])!r} {time_unit} (data rows {k + 1} and {k + 2}) instead."
        )
    neg = d_raw < 0
    notes = ()
    if neg.any():
        k = int(np.flatnonzero(neg)[0])
        if on_negative == "raise":
            raise SEDFormatError(
                f"{where}: 'depth' must be >= 0 (a negative depth means the indenter has left the skin); got "
                f"{_plain(d_raw[k])!r} {length_unit} on data row {k + 1} instead. Pass on_negative='clip' to set "
                "negative depths to 0."
            )
        notes = (
            f"depth clipped to 0 m at {int(neg.sum())} of {d_raw.size} samples (indenter off the skin; first on "
            f"data row {k + 1}).",
        )
        d_raw = np.where(neg, 0.0, d_raw)
    params = {"path": path, "length_unit": length_unit, "time_unit": time_unit, "length_factor_to_m": lf,
              "time_factor_to_s": tf}
    return Waveform(t_raw * tf, d_raw * lf, "file", params, notes)


# --------------------------------------------------------------------------------------------
# Quasi-static scaling of one FE solution
# --------------------------------------------------------------------------------------------


def _static_row(sed, time_index):
    values = np.asarray(sed.values, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError(f"'sed.values' must be an array of shape (n_times, n_receptors); got shape {values.shape} instead.")
    n_t = values.shape[0]
    if time_index is None:
        if n_t != 1:
            raise ValueError(
                f"'sed' has {n_t} time steps; pass time_index to say which one is the static solution at depth "
                "d_ref (e.g. time_index=-1 for the last step of a loading series)."
            )
        return values[0]
    if isinstance(time_index, bool) or not isinstance(time_index, numbers.Integral):
        raise TypeError(f"'time_index' must be an int; got {_plain(time_index)!r} instead.")
    if not -n_t <= time_index < n_t:
        raise ValueError(
            f"'time_index' must be in [{-n_t}, {n_t - 1}] for {n_t} time step(s); got {_plain(time_index)!r} instead."
        )
    return values[int(time_index)]


def scale_static(sed, waveform: Waveform, *, d_ref: float, time_index: int | None = None):
    """SED over time from one static FE solution: ``SED(t) = SED_static (d(t) / d_ref)^2``.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptor sites in J/m^3 (= Pa) from a static solution at indentation depth
        ``d_ref``. NaN (receptors outside the field) stays NaN.
    waveform : Waveform
        Indentation depth d(t) in m.
    d_ref : float
        Depth in m of the static solution, > 0.
    time_index : int, optional
        Which step of ``sed`` is the static solution. Required when ``sed`` has more than one
        step, e.g. ``-1`` for the last step of a loading series.

    Returns
    -------
    ReceptorSED
        Values of shape (waveform.n_times, n_receptors) in J/m^3 at ``waveform.times`` (s),
        with the layout, method and outside mask of ``sed``.

    Raises
    ------
    TypeError
        If ``waveform`` is not a :class:`Waveform` or ``time_index`` not an int.
    ValueError
        If ``d_ref`` is not > 0, or ``sed`` has several steps and no ``time_index``.

    Warns
    -----
    AfferentWarning
        If the waveform goes deeper than ``d_ref``: the scaling then extrapolates beyond the FE
        solution, where the small-strain assumption is weakest.

    See Also
    --------
    depth_scaling_error : check the scaling on an FE loading series.

    Notes
    -----
    **Why d^2.** For a linear-elastic body under small strain whose boundary conditions are a
    prescribed displacement over a *fixed* contact region (a rigid flat punch already in full
    contact, no friction-driven slip), the displacement field is linear in the indentation
    depth: u(x; d) = (d / d_ref) u(x; d_ref). Strains and stresses scale with d, so the strain
    energy density ``1/2 sigma:eps`` scales with d^2, at every point and for both the exact
    and the study's "equivalent" SED (both are quadratic forms of the strain).

    **Where it is valid.** Linear elasticity (the study's chapter-5 model), small strain
    (indentation small next to the layer thicknesses, here 0.5 mm against 3.1 mm of skin),
    quasi-static loading (inertia negligible: the 0.1 s ramp is far slower than the block's
    elastic waves), and a contact area that does not change with depth (a flat punch in
    full contact from the start).

    **Where it is not.**

    - Hyperelastic materials or large strain: the response stiffens, SED grows faster than d^2.
    - A contact area that changes with depth: a spherical or rounded indenter (Hertz: force ~
      d^1.5, the contact radius grows as sqrt(d)), and also a flat punch on ridged skin
      before every ridge is touched (the first ~0.06 mm of the bundled sample).
    - Viscoelastic relaxation (chapter 4's Prony-series dermis and subcutis): the SED at a
      given depth depends on the loading history and relaxes during a hold. The static
      solution is then only the long-time (or the instantaneous) limit.
    - Frictional contact: stick/slip zones under the punch change with depth.
    - Any prescribed displacement that is not proportional to d. For example, a punch whose
      face is brought to a plane ``y_crest - d`` over a rough (ridged) surface gets
      ``u = d + (y_crest - y_surface)``, an offset that does not scale; the SED is then a
      full quadratic ``a d^2 + b d + c`` per point, not ``a d^2``. This is the case of the
      bundled series; :func:`depth_scaling_error` measures how far off d^2 it is. In
      ``sample_sed/block4/series_0p88mm`` (119 papilla tips), the last step (0.5 mm)
      predicts the 0.4, 0.3, 0.2 and 0.1 mm steps with relative L2 errors of 3.5 %,
      9.8 %, 24 % and 85 % over the receptors (89 % at 0.1 mm over the 51 tips of the
      ``spikes_ramp`` scene's region; measured with :func:`depth_scaling_error` on the
      series sampled at ``sample_sed/block4/receptors.csv``, depths 0-0.5 mm in 0.1 mm
      steps). The effective exponent is 2.15-2.38: the SED falls faster than d^2, because
      the ridge valleys are pushed by less than d (:ref:`method-scaling`). A
      per-receptor fit of ``a d^2 + b d + c`` to the full-contact steps (d >= 0.1 mm)
      reproduces them to 3e-7, the float32 precision of the export.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> from afferent.sampling import ReceptorSED
    >>> sed = ReceptorSED(np.array([[100.0, 40.0]]), np.array([0.0]),
    ...                   ReceptorLayout(np.zeros((2, 3)) + [[0, 0, 0], [1e-3, 0, 0]]), "linear",
    ...                   np.zeros(2, bool))
    >>> w = Waveform([0.0, 1.0, 2.0], [0.0, 0.25e-3, 0.5e-3])
    >>> scale_static(sed, w, d_ref=0.5e-3).values.tolist()
    [[0.0, 0.0], [25.0, 10.0], [100.0, 40.0]]
    """
    from .sampling import ReceptorSED

    if not isinstance(waveform, Waveform):
        raise TypeError(f"'waveform' must be a Waveform; got {type(waveform).__name__} instead.")
    if not (hasattr(sed, "values") and hasattr(sed, "layout")) or isinstance(sed, np.ndarray):
        raise TypeError(f"'sed' must be a ReceptorSED (SED at receptor sites); got {type(sed).__name__} instead.")
    d_ref = check_positive("d_ref", d_ref, unit="m")
    static = _static_row(sed, time_index)
    if waveform.max_depth > d_ref * (1.0 + 1e-9):
        warnings.warn(
            f"The waveform reaches {waveform.max_depth:g} m, deeper than the static solution's d_ref = {d_ref:g} m: "
            "scale_static extrapolates the d^2 law beyond the FE solution.",
            AfferentWarning,
            stacklevel=2,
        )
    factor = (waveform.depth / d_ref) ** 2
    values = factor[:, None] * static[None, :]
    outside = np.asarray(getattr(sed, "outside", np.zeros(static.size, bool)), dtype=bool).copy()
    return ReceptorSED(values, waveform.times.copy(), sed.layout, getattr(sed, "method", "linear"), outside,
                       getattr(sed, "placement", ""))


#: Relative L2 error of the d^2 scaling, measured on an export's own loading series, above
#: which a run driven by that scaling is warned about.
SCALING_ERROR_WARN = 0.10

#: When the d^2 scaling is exact, in a line for run records (see :func:`scale_static`, Notes).
SCALING_VALIDITY = ("exact for linear elasticity under small strain, quasi-static loading and a contact area that "
                    "does not change with depth (a flat punch in full contact); not for hyperelastic or viscoelastic "
                    "skin, rounded indenters, or ridged skin before every ridge is touched")


def no_reference_step_message(n_steps: int, times) -> str:
    """The error for a waveform on a multi-step export without a reference step (one wording everywhere)."""
    t = np.asarray(times, dtype=float)
    return (
        f"A waveform scales one static FE step by (d / d_ref)^2, but the export has {n_steps} steps "
        f"(t = {t[0]:g} .. {t[-1]:g} s); say which step was solved at d_ref with reference_step=K (-1: the last, "
        "usually the deepest). A loading series can also be used as it is, without a waveform."
    )


def interpolate_series(sed, waveform: Waveform, *, series_depths):
    """SED over time from a loading series: per receptor, linear in depth between the series' steps.

    Where the user has solved several depths, this follows the FE model itself instead of the
    d^2 law (:func:`scale_static`), which fails where the contact changes (89 % off at 0.1 mm on
    the bundled ridged-skin series).

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors for each step of the series, J/m^3.
    waveform : Waveform
        Indentation depth d(t) in m; it must stay within the series' depths.
    series_depths : array_like of shape (n_steps,)
        The depth of each step in m, strictly increasing.

    Returns
    -------
    ReceptorSED
        Values of shape (waveform.n_times, n_receptors) in J/m^3 at ``waveform.times``.

    Raises
    ------
    ValueError
        If the depths do not match the steps, do not increase, or the waveform leaves their range.
    """
    from .sampling import ReceptorSED

    values = np.asarray(sed.values, dtype=np.float64)
    depths = np.asarray(series_depths, dtype=np.float64)
    if depths.shape != (values.shape[0],):
        raise ValueError(f"'series_depths' must give one depth (m) per export step ({values.shape[0]}); got shape "
                         f"{depths.shape} instead.")
    if depths.size < 2 or np.any(np.diff(depths) <= 0):
        raise ValueError(f"'series_depths' must increase strictly, in m; got {depths.tolist()!r} instead.")
    tol = 1e-9 * depths[-1]
    d = waveform.depth
    if d.min() < depths[0] - tol or d.max() > depths[-1] + tol:
        raise ValueError(
            f"The waveform's depth ({d.min():g}..{d.max():g} m) leaves the series' depths ({depths[0]:g}..{depths[-1]:g} m); "
            "the series is interpolated, never extrapolated."
        )
    d = np.clip(d, depths[0], depths[-1])
    k = np.clip(np.searchsorted(depths, d, side="right") - 1, 0, depths.size - 2)
    w = (d - depths[k]) / (depths[k + 1] - depths[k])
    out = values[k] * (1.0 - w)[:, None] + values[k + 1] * w[:, None]
    outside = np.asarray(getattr(sed, "outside", np.zeros(values.shape[1], bool)), dtype=bool).copy()
    return ReceptorSED(out, waveform.times.copy(), sed.layout, getattr(sed, "method", "linear"), outside)


def scaling_record(sed, waveform: Waveform, *, d_ref: float, reference_step: int = 0, series_depths=None) -> dict:
    """What a run driven by :func:`scale_static` assumed, and its error where the export allows measuring it.

    Parameters
    ----------
    sed : ReceptorSED
        The SED sampled from the export (before scaling), J/m^3, one row per export step.
    waveform : Waveform
        The indentation depth d(t) in m that drives the scaling.
    d_ref : float
        Depth in m of the reference step.
    reference_step : int, default=0
        The export step used as the static solution.
    series_depths : array_like of shape (n_steps,), optional
        The indentation depth in m of every step of a loading-series export. With it, the
        scaling from the reference step is compared with the series' own steps
        (:func:`depth_scaling_error`).

    Returns
    -------
    dict
        ``law``, ``valid_if``, ``d_ref_m``, ``reference_step``, ``reference_time_s``,
        ``n_export_steps``, ``max_depth_m``, ``extrapolates`` (deeper than d_ref), and
        ``measured``: None (one static step, or no depths given: not measurable) or the per-step
        ``depths_m``, ``rel_error_l2``, ``exponent`` and ``max_error_in_range`` (the largest error
        at the steps whose depth the waveform visits).

    Warns
    -----
    AfferentWarning
        When the measured error exceeds :data:`SCALING_ERROR_WARN` at a depth the waveform visits.
    """
    n = int(np.asarray(sed.values).shape[0])
    k = int(reference_step) % n
    record = {
        "time_course": ("interpolated in depth between the series' steps, per receptor (interpolate_series); the "
                        "d^2 law below is measured, not used") if series_depths is not None else
                       "d^2 scaling of the reference step (scale_static)",
        "law": "SED(t) = SED_ref (d(t) / d_ref)^2", "valid_if": SCALING_VALIDITY, "d_ref_m": float(d_ref),
        "reference_step": k, "reference_time_s": float(np.asarray(sed.times)[k]), "n_export_steps": n,
        "max_depth_m": float(waveform.max_depth), "extrapolates": bool(waveform.max_depth > d_ref * (1 + 1e-9)),
        "measured": None,
    }
    if series_depths is None:
        record["measured_note"] = ("not measured: one static step" if n == 1 else
                                   "not measured: pass the depths of the series' steps (series_depths) to measure it")
        return record
    depths = np.asarray(series_depths, dtype=float)
    if depths.shape != (n,):
        raise ValueError(f"'series_depths' must give one depth (m) per export step ({n}); got shape {depths.shape} instead.")
    if not np.isclose(depths[k], d_ref, rtol=1e-6):
        raise ValueError(
            f"'series_depths' puts the reference step {k} at {depths[k]:g} m, but d_ref is {d_ref:g} m; they must agree."
        )
    chk = depth_scaling_error(sed, depths, ref_index=k)
    lo, hi = float(np.min(waveform.depth)), float(np.max(waveform.depth))
    visited = (depths > 0) & (depths >= lo - 1e-12) & (depths <= hi + 1e-12) & (np.arange(n) != k)
    err = chk.rel_error_l2
    worst = float(np.nanmax(err[visited])) if visited.any() else None
    record["measured"] = {"depths_m": depths.tolist(), "rel_error_l2": err.tolist(), "exponent": chk.exponent.tolist(),
                          "max_error_in_range": worst}
    if worst is not None and worst > SCALING_ERROR_WARN:
        j = int(np.flatnonzero(visited)[np.nanargmax(err[visited])])
        warnings.warn(
            f"The d^2 scaling of export step {k} (d_ref = {d_ref:g} m) is off by {100 * worst:.3g} % (relative L2) at "
            f"d = {depths[j]:g} m, a depth the waveform visits, measured on the export's own loading series: "
            "the SED there is not (d / d_ref)^2 x the reference (see scale_static, Notes); the time course is "
            "interpolated in depth between the series' steps instead.",
            AfferentWarning, stacklevel=2,
        )
    return record


@dataclass(frozen=True, eq=False)
class ScalingCheck:
    """How well ``SED(d) = SED_ref (d / d_ref)^2`` predicts an FE loading series.

    Parameters
    ----------
    depths : ndarray of shape (n_times,)
        Indentation depth of each step in m.
    ref_index : int
        The step used as the reference (non-negative index).
    rel_error_l2 : ndarray of shape (n_times,)
        ``||pred - fe||_2 / ||fe||_2`` over the receptors, per step (dimensionless); 0 at the
        reference; NaN where ``||fe||`` is 0 and the prediction is not.
    rel_error_max : ndarray of shape (n_times,)
        ``max |pred - fe| / max |fe|`` over the receptors, per step (dimensionless).
    exponent : ndarray of shape (n_times,)
        Effective power ``ln(||fe_k|| / ||fe_ref||) / ln(d_k / d_ref)`` (2 for exact d^2
        scaling); NaN at the reference and at d = 0.
    n_receptors : int
        Receptors compared (those with finite SED at every step).
    """

    depths: np.ndarray
    ref_index: int
    rel_error_l2: np.ndarray
    rel_error_max: np.ndarray
    exponent: np.ndarray
    n_receptors: int

    def to_dataframe(self):
        """One row per step: ``depth_m``, ``rel_error_l2``, ``rel_error_max``, ``exponent``."""
        import pandas as pd

        return pd.DataFrame({"depth_m": self.depths, "rel_error_l2": self.rel_error_l2,
                             "rel_error_max": self.rel_error_max, "exponent": self.exponent})

    def __repr__(self) -> str:
        others = np.arange(self.depths.size) != self.ref_index
        worst = np.nanmax(self.rel_error_l2[others]) if others.any() else 0.0
        return (
            f"<ScalingCheck: {self.depths.size} steps, reference d = {self.depths[self.ref_index]:g} m, "
            f"worst relative L2 error {worst:.3g}>"
        )


def depth_scaling_error(sed, depths, *, ref_index: int = -1) -> ScalingCheck:
    """Check the d^2 scaling of :func:`scale_static` on an FE loading series.

    Each step k is predicted from the reference step as ``SED_ref (d_k / d_ref)^2`` and
    compared with the FE result.

    Parameters
    ----------
    sed : ReceptorSED
        SED at receptor sites in J/m^3 for a loading series (n_times >= 2 steps), e.g. sampled
        from ``sample_sed/block4/series_0p88mm/indent.pvd``.
    depths : array_like of shape (n_times,)
        Indentation depth of each step in m, >= 0 (for a ramp at constant speed:
        ``speed * times``).
    ref_index : int, default=-1
        The step that plays the static solution (the deepest, by default the last).

    Returns
    -------
    ScalingCheck
        Per-step relative errors and effective exponents.

    Raises
    ------
    ValueError
        If shapes disagree, a depth is negative, or the reference depth is 0.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> from afferent.sampling import ReceptorSED
    >>> v = np.array([[0.0, 0.0], [25.0, 10.0], [100.0, 40.0]])
    >>> sed = ReceptorSED(v, np.array([0.0, 0.5, 1.0]), ReceptorLayout(np.zeros((2, 3)) + [[0, 0, 0], [1e-3, 0, 0]]),
    ...                   "linear", np.zeros(2, bool))
    >>> depth_scaling_error(sed, [0.0, 0.25e-3, 0.5e-3]).rel_error_l2.tolist()
    [0.0, 0.0, 0.0]
    """
    values = np.asarray(sed.values, dtype=np.float64)
    if values.ndim != 2 or values.shape[0] < 2:
        raise ValueError(
            f"'sed' must be a loading series of shape (n_times >= 2, n_receptors); got shape {values.shape} instead."
        )
    d = _finite_1d("depths", depths, "m")
    if d.shape != (values.shape[0],):
        raise ValueError(
            f"'depths' must have one entry per step of 'sed' (n_times = {values.shape[0]}); got shape {d.shape} instead."
        )
    if np.any(d < 0):
        raise ValueError(f"'depths' must be >= 0 m; got {float(d[np.flatnonzero(d < 0)[0]])!r} instead.")
    n_t = values.shape[0]
    if isinstance(ref_index, bool) or not isinstance(ref_index, numbers.Integral) or not -n_t <= ref_index < n_t:
        raise ValueError(f"'ref_index' must be an int in [{-n_t}, {n_t - 1}]; got {_plain(ref_index)!r} instead.")
    ref = int(ref_index) % n_t
    if d[ref] <= 0:
        raise ValueError(f"The reference step's depth must be > 0 m; got {float(d[ref])!r} at step {ref} instead.")
    keep = np.all(np.isfinite(values), axis=0)
    fe = values[:, keep]
    pred = (d[:, None] / d[ref]) ** 2 * fe[ref][None, :]
    diff = pred - fe
    num_l2 = np.linalg.norm(diff, axis=1)
    den_l2 = np.linalg.norm(fe, axis=1)
    num_max = np.abs(diff).max(axis=1) if fe.shape[1] else np.zeros(n_t)
    den_max = np.abs(fe).max(axis=1) if fe.shape[1] else np.zeros(n_t)
    with np.errstate(divide="ignore", invalid="ignore"):
        l2 = np.where(den_l2 > 0, num_l2 / den_l2, np.where(num_l2 == 0, 0.0, np.nan))
        mx = np.where(den_max > 0, num_max / den_max, np.where(num_max == 0, 0.0, np.nan))
        expo = np.log(den_l2 / den_l2[ref]) / np.log(d / d[ref])
    expo[ref] = np.nan
    expo[~np.isfinite(expo)] = np.nan
    return ScalingCheck(d.copy(), ref, l2, mx, expo, int(keep.sum()))


# --------------------------------------------------------------------------------------------
# RA-I adaptation: rate-sensitive input
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class InputCurrent:
    """The current that drives the LIF, tagged with how it was derived.

    It quacks like the current it came from: ``values``, ``times``, and for afferent-level
    input ``afferent_ids`` / ``positions`` / ``axis``, for receptor-level input ``layout``.
    So :func:`afferent.spiking.simulate_lif` takes it as is.

    Parameters
    ----------
    values : ndarray of shape (n_times, n_columns)
        Input current in A (n_columns = n_receptors or n_afferents).
    times : ndarray of shape (n_times,)
        Sample times in s.
    kind : {'static', 'rate-sensitive'}
        ``'static'``: the sigmoid current itself (the study's input). ``'rate-sensitive'``:
        the output of :func:`adapting_input`.
    level : {'receptor', 'afferent'}
        Whether the columns are receptors or afferents.
    source : ReceptorCurrent or AfferentCurrent
        The static current it was derived from (for afferent level after
        :meth:`synthesize`, the synthesised afferent current of the adapted receptor input).
    mode : str or None
        The adaptation mode (``'rectified-rate'``) or None for static input.
    tau : float or None
        Low-pass time constant of the rate in s.
    gain : float or None
        Gain ``k_on`` on the rising rate in s.
    off_gain : float or None
        Gain ``k_off`` on the falling rate in s.
    notes : tuple of str
        Remarks (coarse sampling, ...).
    """

    values: np.ndarray
    times: np.ndarray
    kind: str
    level: str
    source: object
    mode: str | None = None
    tau: float | None = None
    gain: float | None = None
    off_gain: float | None = None
    notes: tuple = ()

    def __post_init__(self):
        from .transduction import _check_values_times

        check_option("kind", self.kind, INPUT_KINDS)
        check_option("level", self.level, ("receptor", "afferent"))
        values, times = _check_values_times(self.values, self.times, what="values", unit="A", cols="n_columns")
        if times is None:
            raise ValueError("'times' must be given, in s; got None instead.")
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    @property
    def n_times(self) -> int:
        """Number of time steps."""
        return self.values.shape[0]

    @property
    def afferent_ids(self):
        """Afferent names (afferent level), else None."""
        return getattr(self.source, "afferent_ids", None) if self.level == "afferent" else None

    @property
    def positions(self):
        """Afferent positions in m along ``axis`` (afferent level), else None."""
        return getattr(self.source, "positions", None) if self.level == "afferent" else None

    @property
    def axis(self):
        """The coordinate ``positions`` is measured along (afferent level), else None."""
        return getattr(self.source, "axis", None) if self.level == "afferent" else None

    @property
    def layout(self):
        """Receptor layout (receptor level), else None."""
        return getattr(self.source, "layout", None) if self.level == "receptor" else None

    def synthesize(self, branching) -> InputCurrent:
        """Sum receptor-level input into afferents, keeping the tag and parameters.

        ``I_A = sum_i w_i I_in,i`` with :func:`afferent.synthesis.synthesize`. Adapting at the
        receptor level and then summing (each corpuscle adapts on its own) differs from
        summing and then adapting, because the rectification is nonlinear.

        Parameters
        ----------
        branching : Branching

        Returns
        -------
        InputCurrent
            ``level='afferent'``, same ``kind``, ``mode``, ``tau`` and gains.

        Raises
        ------
        ValueError
            If this input is already at the afferent level.
        """
        from .synthesis import synthesize
        from .transduction import ReceptorCurrent

        if self.level != "receptor":
            raise ValueError(f"Only receptor-level input can be synthesised; got level={self.level!r} instead.")
        rc = ReceptorCurrent(self.values, self.times, self.layout, getattr(self.source, "params", None))
        aff = synthesize(rc, branching)
        return InputCurrent(aff.values, aff.times, self.kind, "afferent", aff, self.mode, self.tau, self.gain,
                            self.off_gain, self.notes)

    def __array__(self, dtype=None, copy=None):
        if copy:
            return np.array(self.values, dtype=dtype, copy=True)
        return np.asarray(self.values, dtype=dtype)

    def __repr__(self) -> str:
        extra = "" if self.kind == "static" else f", {self.mode}, tau={self.tau:g} s, gain={self.gain:g} s"
        return (
            f"<InputCurrent {self.kind!r} ({self.level} level{extra}): {self.values.shape[0]} steps x "
            f"{self.values.shape[1]}, I in [{self.values.min():.4g}, {self.values.max():.4g}] A>"
        )


def _unwrap_current(current):
    """(values, times, level, source) of a ReceptorCurrent / AfferentCurrent / static InputCurrent."""
    from .synthesis import AfferentCurrent
    from .transduction import ReceptorCurrent

    if isinstance(current, InputCurrent):
        if current.kind != "static":
            raise ValueError(
                f"'current' must be a static current; got an InputCurrent of kind {current.kind!r}, which is "
                "already rate-sensitive. Pass the static current it came from (its .source)."
            )
        return current.values, current.times, current.level, current.source
    if isinstance(current, ReceptorCurrent):
        level = "receptor"
    elif isinstance(current, AfferentCurrent):
        level = "afferent"
    else:
        raise TypeError(
            f"'current' must be a ReceptorCurrent or an AfferentCurrent (in A, with times); got "
            f"{describe_array(current) if isinstance(current, np.ndarray) else type(current).__name__} instead."
        )
    if current.times is None:
        raise ValueError(
            f"'current' must carry its sample times in s; got a {type(current).__name__} with times=None instead. "
            "Transduce a ReceptorSED (or pass times= to transduce)."
        )
    return current.values, current.times, level, current


def static_input(current) -> InputCurrent:
    """Tag a static current as the LIF input (``kind='static'``), the study's choice.

    Parameters
    ----------
    current : ReceptorCurrent or AfferentCurrent
        Sigmoid current in A, with times in s.

    Returns
    -------
    InputCurrent
        The same values, ``kind='static'``.

    Raises
    ------
    TypeError
        If ``current`` is not a ReceptorCurrent or AfferentCurrent.
    ValueError
        If it has no times.
    """
    values, times, level, source = _unwrap_current(current)
    return InputCurrent(values, times, "static", level, source)


def _lowpass_rate(values: np.ndarray, times: np.ndarray, tau: float) -> np.ndarray:
    """Mean over each sample interval of ``r``, ``tau dr/dt = -r + dI/dt``, I linear between samples.

    ``r(t_0) = 0`` (the current was constant before its first sample) and the current is
    constant after its last (the last interval, as long as the one before it, has rate 0).
    Returns an array shaped like ``values`` (A/s).
    """
    n_t = values.shape[0]
    dt = np.diff(times)
    slope = np.diff(values, axis=0) / dt[:, None]  # (n_t - 1, n_cols), A/s on [t_i, t_i+1]
    dt_all = np.append(dt, dt[-1])
    slope_all = np.vstack([slope, np.zeros((1, values.shape[1]))])
    a = np.exp(-dt_all / tau)  # decay over each interval
    # r at the start of each interval: r_{i+1} = s_i + (r_i - s_i) a_i, r_0 = 0
    r = np.empty_like(values)
    r[0] = 0.0
    uniform = np.allclose(dt, dt[0], rtol=1e-9, atol=0.0)
    if n_t > 1 and uniform:
        # scipy.signal.lfilter([1 - a0], [1, -a0]) step by step, bit for bit (its recurrence, in its
        # operation order): importing scipy.signal (it imports scipy.stats) takes longer than a whole run
        a0 = a[0]
        b0 = 1.0 - a0
        prev = np.zeros(values.shape[1:])
        for i in range(n_t - 1):
            prev = b0 * slope[i] + a0 * prev
            r[i + 1] = prev
    else:
        for i in range(n_t - 1):
            r[i + 1] = slope[i] + (r[i] - slope[i]) * a[i]
    # exact mean of r over [t_i, t_i + dt_i]: s + (r_i - s) (tau / dt) (1 - a)
    c = (tau / dt_all) * -np.expm1(-dt_all / tau)
    return slope_all + (r - slope_all) * c[:, None]


def adapting_input(current, *, gain: float, tau: float = DEFAULT_TAU, off_gain: float | None = None,
                   mode: str = "rectified-rate") -> InputCurrent:
    """Rate-sensitive (rapidly adapting) input from a static current: fires at onset and offset.

    Mode ``'rectified-rate'``::

        tau dr/dt = -r + dI/dt                           r in A/s, first-order low-pass of the rate
        I_in(t)   = k_on max(r, 0) + k_off max(-r, 0)    k in s, so I_in is in A

    ``I`` is the static (sigmoid) receptor or afferent current. During a hold ``dI/dt = 0``,
    so ``r`` decays to 0 within a few ``tau`` and the neuron falls silent. Both the rising
    (onset) and the falling (offset) edge drive the neuron, because the rate is full-wave
    rectified. Equivalently ``r = HP_tau(I) / tau`` with ``HP_tau`` the first-order high-pass
    ``s tau / (1 + s tau)``. So ``I_in = (k / tau) |HP_tau(I)|``: with ``gain = tau`` the
    input is the rectified high-pass of the static current, and a step ``dI`` gives a peak
    of ``|dI|``.

    Parameters
    ----------
    current : ReceptorCurrent, AfferentCurrent or InputCurrent of kind 'static'
        Static current in A with sample times in s (at least two samples). Between samples
        the current is taken as linear. Receptor level: each receptor adapts on its own;
        sum afterwards with :meth:`InputCurrent.synthesize`. Afferent level: the summed
        current adapts.
    gain : float
        ``k_on``, the gain on the rising rate, in s (A of input per A/s of rate), >= 0.
        No default: the study's currents and the LIF's ``r_m`` are not physiological (see
        :data:`afferent.spiking.LIF_PRESETS`), so no scale is universal. Choose it so that
        ``gain * dI/dt`` at the ramp speed of interest exceeds the LIF's rheobase.
    tau : float, default=5e-3
        Low-pass time constant of the rate in s, > 0 (corner frequency ``1 / (2 pi tau)`` =
        32 Hz for the default).
    off_gain : float, optional
        ``k_off``, the gain on the falling rate (offset response) in s, >= 0. Default:
        ``gain`` (symmetric on and off responses). RA-I off responses are often weaker than
        on responses; a smaller ``off_gain`` models that.
    mode : {'rectified-rate'}, default='rectified-rate'
        The transform (the only one so far).

    Returns
    -------
    InputCurrent
        ``kind='rate-sensitive'``, values of shape (n_times, n_columns) in A at the same
        times, with ``mode``, ``tau``, ``gain`` and ``off_gain`` recorded.

    Raises
    ------
    TypeError
        If ``current`` is not a ReceptorCurrent, AfferentCurrent or static InputCurrent.
    ValueError
        If ``current`` has no times or fewer than two samples, is already rate-sensitive, or a
        parameter is out of range.

    Warns
    -----
    AfferentWarning
        If a sample interval is longer than ``tau``. The input's time course is then only
        resolved to the sample interval; resample the stimulus (e.g. :func:`scale_static` on
        a waveform with ``dt <= tau / 10``).

    See Also
    --------
    static_input : the study's static input, tagged the same way.
    afferent.spiking.simulate_lif : takes the returned object as its current.

    Notes
    -----
    **Numerics.** ``r`` is integrated exactly for a current that is linear between samples,
    with ``r = 0`` at the first sample (the current was constant before it). Each output
    sample is the mean of ``r`` over the interval to the next sample, the interval for which
    :func:`~afferent.spiking.simulate_lif` holds it. So the charge delivered per interval is
    exact wherever ``r`` keeps its sign. After the last sample the current is taken as
    constant.

    **Why this transform.** RA-I (Meissner) afferents signal skin motion, not position.
    They fire during the ramp of a ramp-and-hold, with a rate that grows with indentation
    velocity, fall silent during the hold, and fire again at release (Knibestöl 1973, J
    Physiol 232:427; Johansson & Vallbo 1983, Trends Neurosci 6:27). Their vibrotactile
    thresholds fall with frequency over the flutter range, roughly as for a velocity
    detector, up to a best frequency of about 30-40 Hz (Talbot et al. 1968, J Neurophysiol
    31:301). TouchSim (Saal et al. 2017, PNAS 114:E5693; ``hsaal/touchsim``,
    ``transduction.py``) drives its RA afferents with separately weighted positive and
    negative parts of the low-pass-filtered rate of change of the local stimulus, with no
    static term; that is this transform with ``k_on`` and ``k_off``. TouchSim also has an
    acceleration term and saturation, left out here. The default ``tau = 5 ms`` puts the
    corner of the low-pass on the rate at 32 Hz, near the RA-I best frequency: below it the
    input is velocity-like, above it displacement-like. It also ends the response within
    ~25 ms (5 tau) of the end of a ramp. The transform is applied to the current, not to
    the indentation, so the sigmoid's nonlinearity and the spatial SED pattern carry over.
    It is a phenomenological rate sensitivity in the spirit of those models, not a fit to
    RA-I recordings.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.synthesis import AfferentCurrent
    >>> t = np.arange(0, 0.3, 1e-3)
    >>> I = np.interp(t, [0.0, 0.1, 0.2, 0.3], [0.0, 1e-7, 1e-7, 1e-7])   # ramp then hold, A
    >>> cur = AfferentCurrent(I[:, None], t, [0.0], ["A0"], "longitudinal")
    >>> rate = adapting_input(cur, gain=0.1, tau=5e-3)
    >>> rate.kind, round(float(rate.values[90, 0]) * 1e9, 3)   # during the ramp: 0.1 s * 1e-6 A/s, nA
    ('rate-sensitive', 100.0)
    >>> float(rate.values[250, 0])   # in the hold
    0.0
    """
    check_option("mode", mode, ADAPTATION_MODES)
    gain = check_positive("gain", gain, unit="s", strict=False)
    tau = check_positive("tau", tau, unit="s")
    off_gain = gain if off_gain is None else check_positive("off_gain", off_gain, unit="s", strict=False)
    values, times, level, source = _unwrap_current(current)
    values = np.asarray(values, dtype=np.float64)
    if values.shape[0] < 2:
        raise ValueError(
            f"'current' must have at least 2 time samples to take a rate; got {values.shape[0]} instead. "
            "Give the stimulus a time course first (scale_static with a Waveform)."
        )
    times = np.asarray(times, dtype=np.float64)
    notes = []
    max_dt = float(np.diff(times).max())
    if max_dt > tau:
        msg = (
            f"The current is sampled every up to {max_dt:g} s, coarser than tau = {tau:g} s: the rate-sensitive "
            f"input is only resolved to the sample interval. Resample the stimulus with dt <= {tau / 10:g} s."
        )
        warnings.warn(msg, AfferentWarning, stacklevel=2)
        notes.append(msg)
    r = _lowpass_rate(values, times, tau)
    out = gain * np.maximum(r, 0.0) + off_gain * np.maximum(-r, 0.0)
    # Rates that are pure float noise on a constant current (|dI| ~ 1e-16 I) must not drive anything.
    scale = float(np.abs(values).max()) if values.size else 0.0
    out[out <= 1e-12 * scale * max(gain, off_gain) / tau] = 0.0
    return InputCurrent(out, times, "rate-sensitive", level, source, mode, tau, gain, off_gain, tuple(notes))
