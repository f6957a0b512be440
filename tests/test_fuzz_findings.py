"""Every input the fuzzer (fuzz/fuzz_readers.py) found to escape the documented errors, replayed.

Each file in tests/data/fuzz/ is one finding, named after the exception and the line that
raised it before the fix (``IndexError-_csv_868.bin``); its first byte picks the reader (see
``TARGETS`` in the harness; the ``paths-*`` targets build an export whose side files the input names
and places, fuzz/fuzz_paths.py). After the fix each must end in a documented error - an
:class:`~afferent.exceptions.AfferentError` whose message names the file - never in a crash.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from afferent.exceptions import AfferentError

ROOT = Path(__file__).resolve().parent.parent
FINDINGS = sorted((ROOT / "tests" / "data" / "fuzz").glob("*.bin"))


def _harness():
    spec = importlib.util.spec_from_file_location("fuzz_readers", ROOT / "fuzz" / "fuzz_readers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("finding", FINDINGS, ids=[f.stem for f in FINDINGS])
def test_fuzz_finding_ends_in_a_documented_error_naming_the_file(finding, tmp_path):
    harness = _harness()
    target, path = harness.prepare(finding.read_bytes(), str(tmp_path))
    with pytest.raises(AfferentError) as info:
        harness._read(target, path)
    assert path in str(info.value), (target, str(info.value))


def test_the_findings_are_there():
    assert len(FINDINGS) >= 6


def test_the_fuzz_supervisor_measures_a_worker_groups_cpu_time_not_its_wall_time():
    """A hang is CPU time spent on one input (fuzz/fuzz_loop.py, WALL_FACTOR): on a loaded machine wall time made
    ANSYS's reader (5 s of CPU to import) a 'hang' of session 9's third run. The group's CPU counts a reader's own
    child processes; a process sleeping counts none."""
    import os
    import subprocess
    import sys
    import time

    spec = importlib.util.spec_from_file_location("fuzz_loop", ROOT / "fuzz" / "fuzz_loop.py")
    loop = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loop)
    busy = "import subprocess, sys, time; c = subprocess.Popen([sys.executable, '-c', 'while True: pass']); time.sleep(60)"
    idle = "import time; time.sleep(60)"
    procs = [subprocess.Popen([sys.executable, "-c", code], start_new_session=True) for code in (busy, idle)]
    try:
        time.sleep(2.5)
        cpu_busy, cpu_idle = (loop._group_cpu_seconds(p.pid) for p in procs)
        assert cpu_busy > 0.3, cpu_busy  # the grandchild's loop, in the worker's group
        assert cpu_idle < 0.3, cpu_idle
    finally:
        for p in procs:
            os.killpg(p.pid, 9)
            p.wait()
