"""Peak memory of a piece of code, measured in a child process (for the decompression-bomb tests).

:func:`in_child` runs a snippet in a fresh Python (this tree's ``afferent`` first on its path) and
returns what it raised and its peak resident memory, so that a test can bound the memory a reader
needs for a hostile file without the test process's own history in the figure.

The peak is the child's ``VmHWM`` (``/proc/self/status``: the high-water mark of its own address
space) where there is one, else ``ru_maxrss``: on Linux a child's ``ru_maxrss`` starts at its
parent's resident size when it was started (it survives the ``exec``), so a test process grown
to 300 MB would see every child at 300 MB or more.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_WRAPPER = """
import json, resource, sys, warnings
warnings.simplefilter("ignore")
error = None
try:
{body}
except Exception as err:  # what the reader raised, for the test to pin
    error = [type(err).__name__, str(err)]
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux; includes the parent's size
try:
    with open("/proc/self/status") as status:
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024  # kB
except (OSError, StopIteration):
    pass
print(json.dumps({{"error": error, "peak_mb": peak}}))
"""


def in_child(code: str, timeout: float = 300.0) -> dict:
    """Run ``code`` in a child Python; return ``{"error": [type, message] or None, "peak_mb": float}``.

    Parameters
    ----------
    code : str
        Python statements (dedented here); what they raise is caught and reported, not re-raised.
    timeout : float
        Seconds before the child is killed (a generous bound: the test fails on it).
    """
    body = textwrap.indent(textwrap.dedent(code).strip() or "pass", "    ")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-c", _WRAPPER.format(body=body)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=str(ROOT))
    assert done.returncode == 0, f"child failed (exit {done.returncode}): {done.stderr[-2000:]}"
    return json.loads(done.stdout.strip().splitlines()[-1])


def zeros_deflated(n_bytes: int, chunk: int = 1 << 22) -> bytes:
    """A zlib stream (RFC 1950, checksum right) inflating to ``n_bytes`` zero bytes, ~1/1000 of their size,
    built in ~0.1 s per GiB: one fully flushed deflate run of ``chunk`` zeros, repeated."""
    import zlib

    n, rest = divmod(n_bytes, chunk)
    if n < 2:
        return zlib.compress(bytes(n_bytes), 9)
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    zeros = bytes(chunk)
    first = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    again = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)  # after a full flush: the same bytes each time
    body = first + again * (n - 1) + c.compress(bytes(rest)) + c.flush()
    adler = ((n_bytes % 65521) << 16) | 1  # adler32 of zeros: a = 1, b = n mod 65521
    return b"\x78\xda" + body + adler.to_bytes(4, "big")
