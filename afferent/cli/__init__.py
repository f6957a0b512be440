"""The ``afferent`` command line: one module per subcommand, wired in :mod:`afferent.cli._main`.

Only this package turns exceptions into exit codes: 0 success, 2 bad input (one line
``afferent: error: ...`` on stderr, no traceback), 1 an unexpected failure (a bug).
"""

from __future__ import annotations

from ._main import main

__all__ = ["main"]
