"""Validation helpers used at the public boundary (scikit-learn / MNE style).

Messages follow one template::

    <subject> must be <expectation incl. unit or shape>; got <repr> instead.[ <hint>]
"""

from __future__ import annotations

import difflib
import numbers
from collections.abc import Iterable

import numpy as np

__all__ = [
    "plain",
    "check_option",
    "check_positive",
    "check_finite_array",
    "check_rng",
    "check_step_count",
    "MAX_STEPS",
    "suggest",
    "describe_array",
    "ACCEPTS",
    "check_accept",
    "confirm_with",
    "refuse_unless",
]


def suggest(word: str, choices: Iterable[str], *, cutoff: float = 0.6) -> str:
    """Return ``" Did you mean 'X'?"`` for the closest choice, or ``""``.

    Matching is case-insensitive; the suggestion keeps the spelling of ``choices``.
    """
    choices = list(choices)
    lower = {c.lower(): c for c in choices}
    match = difflib.get_close_matches(str(word).lower(), list(lower), n=1, cutoff=cutoff)
    return f" Did you mean {lower[match[0]]!r}?" if match else ""


def _join(choices: list) -> str:
    reprs = [repr(c) for c in choices]
    if len(reprs) <= 2:
        return " and ".join(reprs)
    return ", ".join(reprs[:-1]) + " and " + reprs[-1]


def check_option(name: str, value, allowed: Iterable):
    """Return ``value`` if it is one of ``allowed``, else raise ``ValueError``.

    >>> check_option("method", "cubic", ("linear", "nearest"))
    Traceback (most recent call last):
    ...
    ValueError: Invalid value for the 'method' parameter. Allowed values are 'linear' and 'nearest', but got 'cubic' instead.
    """
    allowed = list(allowed)
    if value in allowed:
        return value
    hint = suggest(value, [a for a in allowed if isinstance(a, str)]) if isinstance(value, str) else ""
    raise ValueError(
        f"Invalid value for the {name!r} parameter. Allowed values are {_join(allowed)}, "
        f"but got {value!r} instead.{hint}"
    )


def plain(value):
    """A numpy scalar as the Python scalar it holds, so messages read ``-1.0``, not ``np.float64(-1.0)``."""
    return value.item() if isinstance(value, np.generic) else value


def check_positive(name: str, value, *, unit: str = "", strict: bool = True, owner: str = "") -> float:
    """Return ``float(value)`` if it is a finite real > 0 (>= 0 with ``strict=False``).

    ``owner`` names the object the value belongs to, e.g. ``"LIFParams"``.
    """
    value = plain(value)
    subject = f"The {name!r} field of {owner}" if owner else f"{name!r}"
    unit_txt = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{subject} must be a real number in{unit_txt or ' SI units'}; got {value!r} instead.")
    v = float(value)
    ok = np.isfinite(v) and (v > 0 if strict else v >= 0)
    if not ok:
        raise ValueError(f"{subject} must be {'>' if strict else '>='} 0{unit_txt}; got {value!r} instead.")
    return v


#: The most time steps (duration / dt) a waveform is sampled on or a spiking engine simulates: step indices are
#: int32 in the spike buffers, and a waveform's times alone are 8 bytes a step.
MAX_STEPS = 2.0**31 - 1


def check_step_count(duration: float, dt: float, *, what: str = "") -> None:
    """Refuse ``duration / dt`` (both in s) of :data:`MAX_STEPS` steps or more, before anything is allocated.

    ``what`` names the time grid (``"the waveform's"``), for the message.
    """
    if not duration / dt < MAX_STEPS:
        raise ValueError(
            f"{what + ' ' if what else ''}duration / dt must be below {MAX_STEPS:.0f} steps; got {duration / dt:.3g} "
            f"steps (duration {duration!r} s, dt {dt!r} s) instead."
        )


def describe_array(a) -> str:
    """Short description of an array for error messages: shape and dtype, never the data."""
    a = np.asarray(a)
    return f"array of shape {a.shape} and dtype {a.dtype}"


def check_finite_array(name: str, a, *, ndim: int | None = None, shape_doc: str = "", where: str = "") -> np.ndarray:
    """Return ``a`` as a float64 array; raise ``ValueError`` on NaN/inf or a wrong ``ndim``.

    ``where`` is prefixed to the message (e.g. a file name); ``shape_doc`` documents the
    expected shape, e.g. ``"(n_times, n_receptors)"``.
    """
    prefix = f"{where}: " if where else ""
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{prefix}{name!r} must be a numeric array; got {type(a).__name__} instead.") from err
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(
            f"{prefix}{name!r} must be an array of shape {shape_doc or ndim * '(.)'}; got shape {arr.shape} instead."
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        kind = "NaN" if np.isnan(arr[tuple(idx)]) else "infinite"
        raise ValueError(
            f"{prefix}{name!r} must be finite; got {int(bad.sum())} non-finite value(s) "
            f"(first: {kind} at index {tuple(int(i) for i in idx)}) instead."
        )
    return arr


def check_rng(rng) -> np.random.Generator:
    """Normalise ``None | int | numpy.random.Generator`` to a Generator (no global state)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or (isinstance(rng, numbers.Integral) and not isinstance(rng, bool)):
        return np.random.default_rng(rng)
    raise TypeError(f"'rng' must be None, an int seed or a numpy.random.Generator; got {rng!r} instead.")


#: The checks whose unusual case a user may confirm, by name: with ``--accept NAME[,NAME]`` (``afferent run``),
#: ``[scene] accept = ["NAME", ...]`` (a scene file) or the ``accept=`` keyword of the function that runs the
#: check. Each refuses a likely mistake (exit 2) with one sentence naming its likely cause and its name here.
#: One scheme for every such confirmation: a new check adds its name and what it lets through.
ACCEPTS = {
    "placement": "receptors of an RA-I or SA-I run away from the epidermis/dermis interface, or none in the dermis",
    "reference-step": "a waveform's reference step that is not the deepest step of the export's series",
    "d-ref": "d_ref more than 10 x away from the waveform's deepest point",
    "step-times": "an export's step numbers read as seconds (spiking, cycles) where it states no times",
    "waveform-step": "a sine waveform sampled more coarsely than 1/20 of its period",
    "modulus": "an SED (or stress) unit that makes the export's elastic stiffness (2 SED / eps:eps) far from soft "
               "tissue's 1 kPa..10 MPa, where another unit would not",
    "sed-column": "an SED array named like a stress measure (von Mises, Tresca, pressure, a principal stress), equal "
                  "to one of the stress tensor's, or unlike 1/2 sigma:eps of the file's tensors",
    "large-strain": "SED from stress alone (linear elastic, small strain) where the export's strain is large (its 99th "
                    "percentile of sqrt(eps:eps) beyond 0.1) and its stress is not Hooke's law of its strain",
}


def check_accept(accept) -> frozenset:
    """The confirmed checks: ``accept`` (None, a name of :data:`ACCEPTS` or a sequence of them) as a frozenset.

    Raises ``ValueError`` naming the known checks for a name that is none of them.
    """
    if accept is None:
        return frozenset()
    names = [accept] if isinstance(accept, str) else list(accept)
    for name in names:
        if not isinstance(name, str) or name not in ACCEPTS:
            hint = suggest(name, ACCEPTS) if isinstance(name, str) else ""
            raise ValueError(f"'accept' must name checks among {_join(list(ACCEPTS))}; got {name!r} instead.{hint}")
    return frozenset(names)


def confirm_with(name: str) -> str:
    """The end of a refusal: how to confirm the unusual case of check ``name`` (:data:`ACCEPTS`).

    Written with the keyword (``accept='name'``), which ``afferent run`` says as ``--accept name``.
    """
    assert name in ACCEPTS, name
    return f"if it is intended, confirm it with accept='{name}' (a scene file: [scene] accept = [\"{name}\"])."


def refuse_unless(name: str, accept, message: str, *, cls=ValueError, stacklevel: int = 2, note: bool = True) -> None:
    """Refuse a likely mistake of check ``name`` unless ``accept`` confirms it.

    ``message`` (one sentence without its final period: what is wrong, its likely cause and the fix)
    is raised as ``cls`` ending with :func:`confirm_with`; when ``name`` is in ``accept``, it is an
    :class:`~afferent.exceptions.AfferentWarning` saying it was confirmed (run.json keeps it), unless
    ``note`` is False (a scene's own check: its record holds ``[scene] accept``).
    """
    if name not in check_accept(accept):
        raise cls(f"{message}; {confirm_with(name)}")
    if not note:
        return
    import warnings

    from .exceptions import AfferentWarning

    warnings.warn(f"{message} (confirmed: accept='{name}').", AfferentWarning, stacklevel=stacklevel + 1)
