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
:func:`apply_waveform` is the stage a run calls: d^2 scaling of one step, or interpolation in
depth between the steps of a loading series (:func:`interpolate_series`), and the record of
either (:func:`scaling_record`).

**RA-I adaptation** (:func:`adapting_input`, :ref:`method-spikes`): a static sigmoid of SED fed
to the LIF fires through a hold; RA-I afferents do not. :func:`adapting_input` turns the
static (receptor or afferent) current into a rate-sensitive one. It takes the full-wave
rectified, low-pass-filtered rate of change: ``I_in = k_on [r]_+ + k_off [r]_-`` with
``tau dr/dt = -r + dI/dt``. The returned :class:`InputCurrent` records which input it is
(``kind='static'`` or ``'rate-sensitive'``) and the parameters used. The study's static
input stays the default of the pipeline; :func:`static_input` tags it the same way.

Where the parts live: ``_waveforms.py`` (:class:`Waveform` and the generators),
``_waveform_file.py`` (:func:`read_waveform`), ``_scaling.py`` (depth scaling and series
interpolation, their checks and run records), ``_adaptation.py`` (:class:`InputCurrent`, the
rate-sensitive input). Every public name is importable from :mod:`afferent.stimulus`.
"""

from __future__ import annotations

from . import _adaptation
from ._adaptation import INPUT_KINDS, InputCurrent, _lowpass_rate, adapting_input, static_input  # noqa: F401
from ._scaling import (  # noqa: F401 (SCALING_* and no_reference_step_message: importable here, as before)
    SCALING_ERROR_WARN,
    SCALING_VALIDITY,
    ScalingCheck,
    apply_waveform,
    depth_scaling_error,
    interpolate_series,
    no_reference_step_message,
    scale_static,
    scaling_record,
)
from ._waveform_file import read_waveform
from ._waveforms import ON_NEGATIVE, WAVEFORM_KINDS, Waveform, ramp_and_hold, sinusoid  # noqa: F401

__all__ = [
    "Waveform",
    "ramp_and_hold",
    "sinusoid",
    "read_waveform",
    "scale_static",
    "apply_waveform",
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

#: Modes of :func:`adapting_input`.
ADAPTATION_MODES = _adaptation.ADAPTATION_MODES
#: Default low-pass time constant of the rate in s (corner 1 / (2 pi tau) = 32 Hz; see adapting_input).
DEFAULT_TAU = _adaptation.DEFAULT_TAU
