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

Only :func:`afferent.cli.main` turns these into exit codes; the library never exits or prints.
"""

from __future__ import annotations

__all__ = [
    "AfferentError",
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

    def __init__(self, code: int, message: str, filename: str | None = None):
        super().__init__(message)
        self.errno, self.filename = code, filename

    def __str__(self) -> str:
        return str(self.args[0])


class CalibrationError(AfferentError, RuntimeError):
    """A calibration cannot proceed (singular design, degenerate objective)."""


class WorkerLostError(AfferentError, RuntimeError):
    """A worker process of a sweep died (killed by a signal, or out of memory); the tasks done are kept."""


class AfferentWarning(UserWarning):
    """A recoverable oddity (negative SED clipped, saturated sigmoid, ...)."""
