"""Compiled readers in a child process: their crash on a damaged file becomes an error, not the end of afferent.

Two readers afferent uses run C or C++ code that can die on a damaged file instead of reporting it:
ansys-mapdl-reader's compiled record reader (:mod:`afferent.io._ansys`) and VTK's legacy ``.vtk``
reader (:mod:`afferent.io._vtk`; a CONNECTIVITY line whose data type runs into the next keyword
ends the process with SIGSEGV in VTK 9.x, found by ``fuzz/fuzz_readers.py``). Nothing in Python can
catch a segmentation fault, so :func:`call_in_child` runs the reading function in a fresh
interpreter (``sys.executable -c``, this package first on its path: it imports neither the calling
script nor anything else of this process) and turns a death by a signal, or any other exit, into
an :class:`~afferent.exceptions.SEDFormatError` naming the file, the reader and the signal.

What crosses: the function's arguments and its result (or the exception it raised, raised again
here) as pickles through the child's standard input and output; whatever the libraries print goes
to its standard error (kept, and its last line quoted when the child fails). Cost: the child's
start-up and imports (numpy, the reader, :mod:`afferent.io`: ~0.3 s for VTK, ~1 s for
ansys-mapdl-reader) and the pickles' copy, paid only on the files these readers read.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys

from ..exceptions import SEDFormatError

__all__ = ["call_in_child"]

_CHILD = """
import importlib, os, pickle, sys
out = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)  # whatever the libraries print goes to stderr, not into the pickle
module, name, args = pickle.load(sys.stdin.buffer)
try:
    result = ("ok", getattr(importlib.import_module(module), name)(*args))
except Exception as err:
    result = ("error", err)
pickle.dump(result, out, protocol=pickle.HIGHEST_PROTOCOL)
out.close()
"""


def call_in_child(module: str, name: str, *args, path: str, reading: str, tool: str, crash_hint: str,
                  show_stderr: bool = False):
    """``module.name(*args)`` in a child Python process; its result, or the exception it raised.

    Parameters
    ----------
    module, name : str
        The function to call (importable by the child: a module of this package).
    *args
        Its arguments (picklable).
    path : str
        The file it reads (for the messages).
    reading : str
        What the file is read as, for the messages ("an ANSYS MAPDL result file").
    tool : str
        The library whose compiled code reads it ("ansys-mapdl-reader").
    crash_hint : str
        The likely cause said when the child dies by a signal.
    show_stderr : bool
        Let the child's standard error through (its progress bars) instead of keeping it for the message.

    Raises
    ------
    SEDFormatError
        The child died by a signal (a crash of ``tool``'s compiled code) or exited with an error code;
        and whatever the function itself raised.
    """
    package_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([package_root, *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.run([sys.executable, "-c", _CHILD], input=pickle.dumps((module, name, args)),
                          stdout=subprocess.PIPE, stderr=None if show_stderr else subprocess.PIPE, env=env)
    if proc.returncode == 0:
        status, value = pickle.loads(proc.stdout)
        if status == "error":
            raise value
        return value
    said = (proc.stderr or b"").decode("utf-8", "replace").strip().splitlines()
    said = f"; it said {said[-1][:200]!r}" if said else ""
    if proc.returncode < 0:
        sig = -proc.returncode
        signame = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else "unknown signal"
        raise SEDFormatError(f"SED file {path!r} could not be read as {reading}: {tool}'s compiled code crashed on it "
                             f"(signal {sig}, {signame}{said}); {crash_hint}.")
    raise SEDFormatError(f"SED file {path!r} could not be read as {reading}: the process reading it with {tool} "
                         f"exited with code {proc.returncode}{said}.")
