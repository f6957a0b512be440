"""Exceptions and warnings raised by :mod:`afferent`.

Every domain error subclasses both :class:`AfferentError` and the built-in type a
caller would expect (scikit-learn's ``NotFittedError(ValueError, AttributeError)``
pattern), so ``except ValueError`` keeps working::

    AfferentError(Exception)
    ├── SEDFormatError(AfferentError, ValueError)       unreadable or unsupported input file
    ├── UnitError(AfferentError, ValueError)            a unit missing, unknown or inconsistent
    ├── FieldCoverageError(AfferentError, ValueError)   receptors outside the FE field
    ├── OutputExistsError(AfferentError, FileExistsError)  refusing to overwrite results
    ├── OutputWriteError(AfferentError, OSError)         the disk refuses (full, read-only, ...)
    ├── CalibrationError(AfferentError, RuntimeError)   a calibration that cannot proceed
    └── WorkerLostError(AfferentError, RuntimeError)    a sweep's worker process died (killed)

Only :func:`afferent.cli.main` turns these into exit codes (``raised_on_purpose`` tells bad
input, exit code 2, from a bug, 1); the library never exits or prints.
"""

from __future__ import annotations



import dis
import os

__all__ = [
    "AfferentError",
    "MissingExtraError",
    "SEDFormatError",
    "UnitError",
    "FieldCoverageError",
    "OutputExistsError",
    "OutputWriteError",
    "CalibrationError",
    "WorkerLostError",
    "AfferentWarning",
]


class AfferentError(Exception):
    """Base class of every error raised on purpose by :mod:`afferent`."""


class SEDFormatError(AfferentError, ValueError):
    """An input file could not be read: an FE export, or a receptor, observed-profile, waveform or
    SED table (unknown format, missing columns, bad values). The message names the file."""


class UnitError(AfferentError, ValueError):
    """A physical unit is missing, unknown, or contradicts what the file states."""


class FieldCoverageError(AfferentError, ValueError):
    """Receptor sites lie outside the FE field and ``on_outside='raise'``."""


class OutputExistsError(AfferentError, FileExistsError):
    """An output file or folder exists and overwriting was not asked for."""


class OutputWriteError(AfferentError, OSError):
    """An output could not be written for a reason of the environment: a full or read-only disk, a
    quota, permissions. The message names the output and the reason; ``errno`` is the system's code."""

    def __init__(self, code: int, message: str, filename: str | None = None) -> None:
        super().__init__(message)
        self.errno, self.filename = code, filename

    def __str__(self) -> str:
        return str(self.args[0])

    def __reduce__(self):  # pickled as its constructor's arguments (a run's figure process sends it back)
        return (type(self), (self.errno, str(self.args[0]), self.filename))


class MissingExtraError(AfferentError, ImportError):
    """An option asks for an optional library that is not installed; the message names the install command."""


class CalibrationError(AfferentError, RuntimeError):
    """A calibration cannot proceed (singular design, degenerate objective)."""


class WorkerLostError(AfferentError, RuntimeError):
    """A worker process of a sweep died (killed by a signal, or out of memory); the tasks done are kept."""


class AfferentWarning(UserWarning):
    """A recoverable oddity (negative SED clipped, saturated sigmoid, ...)."""


_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep


def raised_on_purpose(err: BaseException) -> bool:
    """Whether ``err`` is one of afferent's own errors: bad input, exit code 2 (:func:`afferent.cli.main`).

    An :class:`AfferentError`, a missing or unreadable file (``FileNotFoundError``,
    ``PermissionError``, ...), or a ``ValueError`` / ``TypeError`` that a ``raise`` statement in
    afferent's own code raised (the argument checks of ``afferent._validation`` and the modules'
    own sentences). The same types raised from inside numpy, pandas, scipy or a built-in call
    (``float('x')``, ``a.reshape(...)``) carry the library's words, not afferent's: a case
    afferent does not check, so a bug (exit code 1). An error raised again from another process
    (a run's figure process, ``afferent._figure_process``) carries the judgement made where it
    was raised.
    """
    judged = getattr(err, "_afferent_on_purpose", None)
    if judged is not None:
        return bool(judged)
    if isinstance(err, AfferentError) or not isinstance(err, (ValueError, TypeError)):
        return True
    tb = err.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:  # the innermost frame: where the exception was raised
        tb = tb.tb_next
    code = tb.tb_frame.f_code
    if not os.path.abspath(code.co_filename).startswith(_PACKAGE):
        return False
    return dis.opname[code.co_code[tb.tb_lasti]] == "RAISE_VARARGS"
