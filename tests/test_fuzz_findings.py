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
