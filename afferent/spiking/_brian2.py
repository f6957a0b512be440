"""brian2, imported and run without taking over the process's warnings.

Importing brian2 (2.7-2.11) calls ``logging.captureWarnings(True)``, adds its console handler to
the ``py.warnings`` logger and replaces ``sys.excepthook`` (``BrianLogger.initialize``). After that,
every warning of the process (afferent's own included) is printed by logging as
``WARNING .../file.py:220: AfferentWarning ... [py.warnings]``: ``-q`` no longer hides them, a
``warnings.catch_warnings(record=True)`` open at the import stops recording (run.json lost
warnings), and the CLI's one-line format is gone. :func:`import_brian2` imports it and puts all
three back as they were; :func:`quiet` silences the deprecation warnings brian2's equation parser
provokes in pyparsing >= 3.3 (``'parseString' deprecated``: 27 blocks a run), which are brian2's
to fix, not the user's to read.

Nothing else in :mod:`afferent` imports brian2.
"""

from __future__ import annotations

import logging
import sys
import warnings
from contextlib import contextmanager

__all__ = ["import_brian2", "quiet"]


def import_brian2():
    """Import brian2 (``ImportError`` when it cannot be) and leave warnings as they were before.

    Restores :func:`warnings.showwarning`, logging's capture state, the ``py.warnings`` logger's
    handlers and ``sys.excepthook`` when this import is the one that changed them (a process that
    imported brian2 itself keeps brian2's set-up).
    """
    if "brian2" in sys.modules:
        return sys.modules["brian2"]
    py_warnings = logging.getLogger("py.warnings")
    saved = (warnings.showwarning, logging._warnings_showwarning, sys.excepthook,  # noqa: SLF001
             list(py_warnings.handlers), py_warnings.propagate)
    try:
        with quiet():
            import brian2
    finally:
        (warnings.showwarning, logging._warnings_showwarning, sys.excepthook,  # noqa: SLF001
         handlers, py_warnings.propagate) = saved
        py_warnings.handlers[:] = handlers
    return brian2


@contextmanager
def quiet():
    """Inside: deprecation warnings raised by brian2's own code paths (pyparsing, sympy, numpy
    calls it makes) are not shown; every other warning is, through the caller's set-up."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"(brian2|pyparsing|sympy)(\.|$)")
        try:
            from pyparsing.warnings import PyparsingDeprecationWarning  # pyparsing >= 3.3
        except ImportError:
            pass
        else:
            warnings.filterwarnings("ignore", category=PyparsingDeprecationWarning)
        yield
