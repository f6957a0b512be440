"""Resume from the batches' indexes (issue 38): ``tasks/index-<name>.json`` beside each ``tasks/batch-<name>.jsonl``
says which tasks succeeded and the files each read, so a re-run reads the indexes, not every record; a batch whose
index is missing, unreadable or stale is read instead, and the result is the same."""

from __future__ import annotations

import json
import os
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from afferent._sweep import _inputs, _prepare, load_sweep, records, sweep
from afferent.exceptions import OutputExistsError

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "sample_sed" / "scenes"
SWEEP_GAMMA = SCENES / "sweep_gamma.toml"
pytestmark = pytest.mark.skipif(not SWEEP_GAMMA.is_file(), reason="sample_sed/ not present")
_BASE = SWEEP_GAMMA.read_text().split("[sweep]")[0].replace('"../', f'"{SCENES.parent.as_posix()}/')
# 6 tasks, serial, batches of 2: 3 batch files
SIX = """\
"transduction.gamma_per_pa" = [2e-3, 4.6e-3, 1e-2]
"spikes.gain_ms" = [100, 300]
"""


@pytest.fixture(scope="module")
def done_sweep(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("resume")
    src = tmp / "s.toml"
    src.write_text(_BASE + "[sweep]\n" + textwrap.dedent(SIX))
    out = tmp / "out"
    first = sweep(src, out, scheduler="serial", batch_size=2)
    return src, out, first.table


def _copy(done_sweep, tmp_path) -> Path:
    import shutil

    src, out, _ = done_sweep
    shutil.copytree(out, tmp_path / "out", copy_function=shutil.copy2)  # mtimes kept: the indexes stay current
    return tmp_path / "out"


def _scanned(out: Path) -> list:
    """(task, inputs) of every 'ok' record, read from the records (what resume read before the indexes)."""
    return sorted((r["task"], json.dumps(r.get("inputs"), sort_keys=True)) for r in records._iter_records(str(out))
                  if r.get("status") == "ok")


def _done(out: Path) -> list:
    return sorted((t, json.dumps(i, sort_keys=True)) for t, i in records._done_records(str(out)))


def _ids(src, out) -> set:
    spec = load_sweep(src)
    return set(_prepare(str(out), spec, False, _inputs(spec, spec.probe_tasks())).array.tolist())


def _batches(out: Path) -> list[Path]:
    return sorted((out / "tasks").glob("batch-*.jsonl"))


def _index(batch: Path) -> Path:
    return batch.with_name(batch.name.replace("batch-", "index-").replace(".jsonl", ".json"))


def test_every_batch_has_an_index_and_resume_reads_only_the_indexes(done_sweep, tmp_path, monkeypatch):
    src, _, table = done_sweep
    out = _copy(done_sweep, tmp_path)
    batches = _batches(out)
    assert len(batches) == 3 and all(_index(b).is_file() for b in batches)
    index = json.loads(_index(batches[0]).read_text())
    assert index["batch"] == batches[0].name and len(index["tasks"]) == 2 and set(index["ok"]) == set(index["tasks"])
    assert _done(out) == _scanned(out) and len(_done(out)) == 6
    scan = _ids(src, out)

    def no_scan(path):
        raise AssertionError(f"resume read the records of {path}")

    monkeypatch.setattr(records, "_file_records", no_scan)
    assert _ids(src, out) == scan and len(scan) == 6  # from the indexes alone
    monkeypatch.undo()
    again = sweep(src, out, scheduler="serial", batch_size=2)
    assert (again.n_ran, again.n_skipped) == (0, 6)
    pd.testing.assert_frame_equal(again.table, table)


def test_a_missing_corrupt_or_foreign_index_falls_back_to_its_batch(done_sweep, tmp_path, monkeypatch):
    src, _, table = done_sweep
    out = _copy(done_sweep, tmp_path)
    a, b, c = _batches(out)
    _index(a).unlink()
    _index(b).write_text('{"afferent_sweep_index": 1, "batch": "')
    _index(c).write_text(_index(c).read_text().replace(c.name, a.name))  # another batch's index
    assert _done(out) == _scanned(out) and len(_done(out)) == 6
    read = []
    real = records._file_records
    monkeypatch.setattr(records, "_file_records", lambda path: read.append(os.path.basename(path)) or real(path))
    assert len(_ids(src, out)) == 6 and sorted(read) == [a.name, b.name, c.name]
    monkeypatch.undo()
    again = sweep(src, out, scheduler="serial", batch_size=2)
    assert (again.n_ran, again.n_skipped) == (0, 6)
    pd.testing.assert_frame_equal(again.table, table)


def test_a_batch_changed_after_its_index_is_trusted_over_the_index(done_sweep, tmp_path):
    """The index says both tasks of a batch succeeded; the batch, rewritten since (a record marked not ok, same size,
    later mtime; another cut to its first line), says otherwise: its tasks run again, as a scan would decide."""
    src, _, table = done_sweep
    out = _copy(done_sweep, tmp_path)
    a, b, _ = _batches(out)
    lines = a.read_text().splitlines()
    st = a.stat()
    a.write_text(lines[0].replace('"status":"ok"', '"status":"no"', 1) + "\n" + lines[1] + "\n")
    os.utime(a, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert a.stat().st_size == st.st_size
    b.write_text(b.read_text().splitlines()[0] + "\n")
    assert _done(out) == _scanned(out) and len(_done(out)) == 4
    again = sweep(src, out, scheduler="serial", batch_size=2)
    assert (again.n_ran, again.n_skipped) == (2, 4) and again.n_failed == 0
    pd.testing.assert_frame_equal(again.table, table)


def test_a_sweep_folder_without_indexes_still_resumes(done_sweep, tmp_path):
    """A folder written before the indexes: every batch is read, as before."""
    src, _, table = done_sweep
    out = _copy(done_sweep, tmp_path)
    for b in _batches(out):
        _index(b).unlink()
    assert _done(out) == _scanned(out) and len(_done(out)) == 6
    again = sweep(src, out, scheduler="serial", batch_size=2)
    assert (again.n_ran, again.n_skipped) == (0, 6)
    pd.testing.assert_frame_equal(again.table, table)


def test_overwrite_deletes_the_indexes_afferent_wrote_and_refuses_a_forged_one(done_sweep, tmp_path):
    src, _, _ = done_sweep
    out = _copy(done_sweep, tmp_path)
    a = _batches(out)[0]
    forged = json.loads(_index(a).read_text())
    forged["tasks"] = forged["tasks"][:1]
    (out / "tasks" / f"index-{'0' * 16}.json").write_text(json.dumps(forged))
    with pytest.raises(OutputExistsError, match=r"files afferent did not write \('tasks/index-0{16}\.json'\)"):
        sweep(src, out, scheduler="serial", batch_size=2, overwrite=True)
    (out / "tasks" / f"index-{'0' * 16}.json").unlink()
    res = sweep(src, out, scheduler="serial", batch_size=2, overwrite=True)
    assert res.n_ran == 6 and len(list((out / "tasks").glob("index-*.json"))) == 3
    assert _done(out) == _scanned(out) and len(_done(out)) == 6  # written in the new folder, current after its move
    assert all(records._indexed(str(out / "tasks"), b.name) is not None for b in _batches(out))


def test_a_batch_written_again_drops_its_old_index_first(done_sweep, tmp_path, monkeypatch):
    """A re-run writing a batch of the same tasks again, killed before its new index: the old index is gone, not
    beside a batch it no longer describes (whatever the file system's time resolution)."""
    import afferent._sweep as S
    from afferent._output import atomic_file

    src, _, _ = done_sweep
    out = _copy(done_sweep, tmp_path)
    a = _batches(out)[0]
    items = [(r["task"], "failed", 0.0, json.dumps(dict(r, status="failed")), None)
             for r in records._file_records(str(a))]

    def killed(path, **kw):
        if "index-" in os.path.basename(path):
            raise KeyboardInterrupt
        return atomic_file(path, **kw)

    monkeypatch.setattr("afferent._output.atomic_file", killed)
    with pytest.raises(KeyboardInterrupt):
        S._Sink(str(out), 2, False)(items)
    assert not _index(a).exists() and _done(out) == _scanned(out) and len(_done(out)) == 4
