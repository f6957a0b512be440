"""Rate-sensitive inputs: :class:`InputCurrent`, :func:`static_input`, :func:`adapting_input` (RA-I and SA-I modes).

The model is given in :mod:`afferent.stimulus` and on the Method page (:ref:`method-spikes`).
"""

from __future__ import annotations

from ..receptors._layout import ReceptorLayout
from ..synthesis import AfferentCurrent, Branching
from ..transduction import ReceptorCurrent



import warnings
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from .._validation import check_option, check_positive, describe_array
from ..exceptions import AfferentWarning


# Modes of adapting_input (documented in afferent.stimulus, where the API reference shows it).
AdaptationMode = Literal["rectified-rate", "static-plus-rate"]
ADAPTATION_MODES: tuple[str, ...] = get_args(AdaptationMode)
#: Input kinds recorded on an :class:`InputCurrent` (the kind each adaptation mode gives: _KIND_OF_MODE).
InputKind = Literal["static", "rate-sensitive", "slowly-adapting"]
INPUT_KINDS: tuple[str, ...] = get_args(InputKind)
_KIND_OF_MODE = {"rectified-rate": "rate-sensitive", "static-plus-rate": "slowly-adapting"}
# Default low-pass time constant of the rate in s (documented in afferent.stimulus).
DEFAULT_TAU = 5e-3
# Mode 'static-plus-rate': how the terms are rectified, and the slow component's default time constant in s
# (tau_2 = 200 ms of fit_model.py in yw5aj/PlosCompBiol; docs/classes.md).
Rectify = Literal["sum", "components"]
RECTIFY_CHOICES: tuple[str, ...] = get_args(Rectify)
DEFAULT_SLOW_TAU = 0.2


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
    kind : {'static', 'rate-sensitive', 'slowly-adapting'}
        ``'static'``: the sigmoid current itself (the study's input). ``'rate-sensitive'``:
        the output of :func:`adapting_input` in mode ``'rectified-rate'`` (RA-I);
        ``'slowly-adapting'``: in mode ``'static-plus-rate'`` (SA-I).
    level : {'receptor', 'afferent'}
        Whether the columns are receptors or afferents.
    source : ReceptorCurrent or AfferentCurrent
        The static current it was derived from (for afferent level after
        :meth:`synthesize`, the synthesised afferent current of the adapted receptor input).
    mode : str or None
        The adaptation mode (``'rectified-rate'``, ``'static-plus-rate'``) or None for static input.
    tau : float or None
        Low-pass time constant of the rate in s.
    gain : float or None
        Gain ``k_on`` on the rising rate in s.
    off_gain : float or None
        Gain ``k_off`` on the falling rate in s.
    notes : tuple of str
        Remarks (coarse sampling, ...).
    static_gain : float or None
        Mode ``'static-plus-rate'``: the dimensionless gain ``k_s`` on the static current.
    """

    values: np.ndarray
    times: np.ndarray
    kind: InputKind
    level: str
    source: object
    mode: AdaptationMode | None = None
    tau: float | None = None
    gain: float | None = None
    off_gain: float | None = None
    notes: tuple = ()
    static_gain: float | None = None

    def __post_init__(self):
        from ..transduction import _check_values_times

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
    def afferent_ids(self) -> np.ndarray | None:
        """Afferent names (afferent level), else None."""
        return getattr(self.source, "afferent_ids", None) if self.level == "afferent" else None

    @property
    def positions(self) -> np.ndarray | None:
        """Afferent positions in m along ``axis`` (afferent level), else None."""
        return getattr(self.source, "positions", None) if self.level == "afferent" else None

    @property
    def axis(self) -> str | None:
        """The coordinate ``positions`` is measured along (afferent level), else None."""
        return getattr(self.source, "axis", None) if self.level == "afferent" else None

    @property
    def layout(self) -> ReceptorLayout | None:
        """Receptor layout (receptor level), else None."""
        return getattr(self.source, "layout", None) if self.level == "receptor" else None

    def synthesize(self, branching: Branching) -> InputCurrent:
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
        from ..synthesis import synthesize
        from ..transduction import ReceptorCurrent

        if self.level != "receptor":
            raise ValueError(f"Only receptor-level input can be synthesised; got level={self.level!r} instead.")
        rc = ReceptorCurrent(self.values, self.times, self.layout, getattr(self.source, "params", None))
        aff = synthesize(rc, branching)
        return InputCurrent(aff.values, aff.times, self.kind, "afferent", aff, self.mode, self.tau, self.gain,
                            self.off_gain, self.notes, self.static_gain)

    def __array__(self, dtype=None, copy=None):
        if copy:
            return np.array(self.values, dtype=dtype, copy=True)
        return np.asarray(self.values, dtype=dtype)

    def __repr__(self) -> str:
        extra = "" if self.kind == "static" else f", {self.mode}, tau={self.tau:g} s, gain={self.gain:g} s"
        extra += "" if self.static_gain is None else f", static_gain={self.static_gain:g}"
        return (
            f"<InputCurrent {self.kind!r} ({self.level} level{extra}): {self.values.shape[0]} steps x "
            f"{self.values.shape[1]}, I in [{self.values.min():.4g}, {self.values.max():.4g}] A>"
        )


def _unwrap_current(current):
    """(values, times, level, source) of a ReceptorCurrent / AfferentCurrent / static InputCurrent."""
    from ..synthesis import AfferentCurrent
    from ..transduction import ReceptorCurrent

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


def static_input(current: ReceptorCurrent | AfferentCurrent) -> InputCurrent:
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


def adapting_input(current: ReceptorCurrent | AfferentCurrent | InputCurrent, *, gain: float, tau: float = DEFAULT_TAU, off_gain: float | None = None,
                   mode: AdaptationMode = "rectified-rate", static_gain: float | None = None, rectify: Rectify | None = None,
                   slow_gain: float | None = None, slow_tau: float | None = None) -> InputCurrent:
    """Rate-sensitive input from a static current: RA-I (onset and offset) or SA-I (static plus rate).

    Mode ``'rectified-rate'`` (RA-I, rapidly adapting; ``kind='rate-sensitive'``)::

        tau dr/dt = -r + dI/dt                           r in A/s, first-order low-pass of the rate
        I_in(t)   = k_on max(r, 0) + k_off max(-r, 0)    k in s, so I_in is in A

    Mode ``'static-plus-rate'`` (SA-I, slowly adapting; ``kind='slowly-adapting'``)::

        I_in(t)   = max(k_s (I - I_rest) + k_d r, 0)     k_s dimensionless, k_d = gain in s
                                                         (rectify='sum', the default)
        I_in(t)   = max(k_s (I - I_rest), 0) + max(k_d r, 0)                 (rectify='components')

    With ``slow_gain`` (``k_2``, s) a second rate component ``k_2 r_2``, ``r_2`` the rate
    low-passed with ``slow_tau`` (``tau_2``, s; default 0.2 s), joins the sum (or, with
    ``rectify='components'``, is rectified on its own as ``max(k_2 r_2, 0)``).

    ``I_rest`` is the current of unloaded skin: the sigmoid at zero SED for a receptor current
    that carries its sigmoid parameters (``alpha / (1 + exp(gamma lambda))``, 0.2 alpha for the
    study's start row, which would otherwise fire SA-I afferents at rest), 0 for a current
    without them (taken as measured from rest); the returned ``notes`` say which.

    A step ``dI`` then gives ``k_s dI + k_d dI / tau`` at once, decaying with ``tau`` to the
    sustained ``k_s dI``: the neuron fires through a hold, faster during the ramp, and a
    falling current lowers the input (to 0 at most, no offset burst). This is the SA-I
    generator function of the Gerling group's model code (yw5aj/PlosCompBiol, the Afferent
    classes page, docs/classes.md) applied to the current: its components ``k_c int
    exp(-(t - s) / tau_c) dI(s)`` are ``k_c tau_c r_c`` (``tau_c`` finite) and ``k_c I`` (``tau_c``
    infinite, the static term), so ``k_d = k_1 tau_1`` and ``k_s = k_3``. That code rectifies
    each component (``rectify='components'``): then the static part keeps driving while the
    current falls, and a release can fire the neuron. The default ``'sum'`` rectifies the sum,
    as the code's earliest form did (one component ``K int [k1 exp(-(t - s) / tau) + 1 - k1]
    dI(s)``, rectified whole, up to its commit 1276cc4): a falling current then silences it.

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
        Static current in A with sample times in s (at least two samples; mode
        ``'static-plus-rate'`` takes one as a constant current, rate 0). Between samples
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
    mode : {'rectified-rate', 'static-plus-rate'}, default='rectified-rate'
        The transform: RA-I or SA-I (above).
    static_gain : float, optional
        Mode ``'static-plus-rate'`` only: ``k_s``, the dimensionless gain on the static
        current, >= 0; default 1 (the sigmoid current itself is the sustained input).
    rectify : {'sum', 'components'}, optional
        Mode ``'static-plus-rate'`` only: rectify the sum of the terms (default ``'sum'``) or
        each term on its own (``'components'``, as the cited model code does).
    slow_gain : float, optional
        Mode ``'static-plus-rate'`` only: ``k_2`` in s, >= 0, the gain of a second, slower rate
        component (the cited model's 200 ms term). Default None: no such component.
    slow_tau : float, optional
        With ``slow_gain``: its time constant ``tau_2`` in s, > 0; default 0.2.

    Returns
    -------
    InputCurrent
        ``kind='rate-sensitive'`` or ``'slowly-adapting'``, values of shape (n_times,
        n_columns) in A at the same times, with ``mode``, ``tau``, ``gain``, ``off_gain`` and
        ``static_gain`` recorded.

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
    static_gain, off_gain = _mode_gains(mode, gain, off_gain, static_gain)
    rectify, slow = _generator_terms(mode, rectify, slow_gain, slow_tau)
    values, times, level, source = _unwrap_current(current)
    values = np.asarray(values, dtype=np.float64)
    if values.shape[0] == 1 and mode == "static-plus-rate":
        # one sample: a current constant for all time (a static export), whose rate is 0
        rest, note = _rest_current(source)
        return InputCurrent(np.maximum(static_gain * (values - rest), 0.0), np.asarray(times, dtype=np.float64),
                            _KIND_OF_MODE[mode], level, source, mode, tau, gain, None,
                            (note, "one sample: the current is constant, so the rate term is 0"), static_gain)
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
    if mode == "static-plus-rate":
        rest, note = _rest_current(source)
        notes.append(note)
        terms = [static_gain * (values - rest), gain * r]
        if slow is not None:
            terms.append(slow[0] * _lowpass_rate(values, times, slow[1]))
            notes.append(f"a second rate component: gain {slow[0]:g} s, tau {slow[1]:g} s")
        if rectify == "components":
            notes.append("each component rectified on its own (rectify='components')")
            out = sum(np.maximum(term, 0.0) for term in terms)
        else:
            out = np.maximum(sum(terms), 0.0)
    else:
        out = gain * np.maximum(r, 0.0) + off_gain * np.maximum(-r, 0.0)
        # Rates that are pure float noise on a constant current (|dI| ~ 1e-16 I) must not drive anything.
        scale = float(np.abs(values).max()) if values.size else 0.0
        out[out <= 1e-12 * scale * max(gain, off_gain) / tau] = 0.0
    return InputCurrent(out, times, _KIND_OF_MODE[mode], level, source, mode, tau, gain, off_gain, tuple(notes),
                        static_gain)


def _rest_current(source) -> tuple:
    """(current of unloaded skin in A, a note saying so) for the static term of mode 'static-plus-rate'."""
    params = getattr(source, "params", None)
    if params is None:
        return 0.0, "static term: the current as given (no sigmoid parameters to find its value at zero SED)"
    from ..transduction import sigmoid

    rest = float(sigmoid(np.zeros(1), params)[0])
    return rest, f"static term measured from the sigmoid's current at zero SED, {rest:.4g} A"


def _generator_terms(mode: str, rectify, slow_gain, slow_tau) -> tuple:
    """(rectify, (slow_gain, slow_tau) or None) of mode 'static-plus-rate', checked; refused in another mode."""
    given = {k: v for k, v in (("rectify", rectify), ("slow_gain", slow_gain), ("slow_tau", slow_tau)) if v is not None}
    if mode != "static-plus-rate":
        if given:
            key, value = next(iter(given.items()))
            raise ValueError(f"{key!r} applies to mode='static-plus-rate', not {mode!r}; got {key}={value!r} instead.")
        return None, None
    rectify = "sum" if rectify is None else check_option("rectify", rectify, RECTIFY_CHOICES)
    if slow_gain is None:
        if slow_tau is not None:
            raise ValueError(f"'slow_tau' needs 'slow_gain' (the gain of the slow component, s); got slow_tau={slow_tau!r} "
                             "and no slow_gain instead.")
        return rectify, None
    slow_gain = check_positive("slow_gain", slow_gain, unit="s", strict=False)
    slow_tau = DEFAULT_SLOW_TAU if slow_tau is None else check_positive("slow_tau", slow_tau, unit="s")
    return rectify, (slow_gain, slow_tau)


def _mode_gains(mode: str, gain: float, off_gain, static_gain) -> tuple:
    """(static_gain, off_gain) of ``mode``, checked: each applies to one mode only."""
    if mode == "static-plus-rate":
        if off_gain is not None:
            raise ValueError(f"'off_gain' applies to mode='rectified-rate', not {mode!r} (a falling current lowers "
                             f"the SA-I input through k_d r); got off_gain={off_gain!r} instead.")
        static_gain = 1.0 if static_gain is None else check_positive("static_gain", static_gain, strict=False)
        return static_gain, None
    if static_gain is not None:
        raise ValueError(f"'static_gain' applies to mode='static-plus-rate', not {mode!r}; "
                         f"got static_gain={static_gain!r} instead.")
    return None, (gain if off_gain is None else check_positive("off_gain", off_gain, unit="s", strict=False))
