"""Sweeps (afferent._sweep, `afferent sweep`): Dask equals serial, export sampled once, resume, failures,
the no-Dask fallback, and errors that name the file, key and line."""

from __future__ import annotations

import json
import re
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from afferent._sweep import load_sweep, read_table, sweep
from afferent.cli import main
from afferent.exceptions import OutputExistsError
from afferent.scene import SceneError, SceneTypeError

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "sample_sed" / "scenes"
SWEEP_GAMMA = SCENES / "sweep_gamma.toml"
needs_sample = pytest.mark.skipif(not SWEEP_GAMMA.is_file(), reason="sample_sed/ not present")
pytestmark = needs_sample

# the sample sweep's scene tables, with absolute paths: tests write their own [sweep]
_BASE = SWEEP_GAMMA.read_text().split("[sweep]")[0].replace('"../', f'"{SCENES.parent.as_posix()}/')


def write_sweep(tmp_path, sweep_table: str, name="s.toml", base=_BASE) -> Path:
    p = tmp_path / name
    p.write_text(base + "[sweep]\n" + textwrap.dedent(sweep_table))
    return p


SMALL = """\
"transduction.gamma_per_pa" = [2e-3, 1e-2]
"spikes.gain_ms" = [100, 300]
"""


def records(out: Path) -> dict:
    """Task id -> record, from the sweep's tasks/*.jsonl (one JSON line per task)."""
    recs = [json.loads(line) for f in sorted((out / "tasks").glob("*.jsonl")) for line in f.read_text().splitlines()]
    return {r["task"]: r for r in recs}


def _line(path: Path, text: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if text in line)


# ------------------------------------------------------------------------ the engines
def test_dask_cluster_table_equals_serial_and_export_is_sampled_once(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    import afferent.io

    src = write_sweep(tmp_path, SMALL)
    reads = []
    real = afferent.io.iter_sed
    monkeypatch.setattr(afferent.io, "iter_sed", lambda *a, **k: (reads.append(a), real(*a, **k))[1])
    serial = sweep(src, tmp_path / "serial", scheduler="serial", use_cache=False)
    assert len(reads) == 1  # 4 parameter sets, one export: read and sampled once
    assert serial.n_tasks == 4 and serial.n_failed == 0 and len(serial.table) == 4 * 3  # 3 afferents in the region
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        shared = sweep(src, tmp_path / "cluster", scheduler=client, use_cache=False, batch_size=1)
        scattered = sweep(src, tmp_path / "scattered", scheduler=client, use_cache=False, shared_disk=False)
    assert len(reads) == 3  # once per sweep, on the cluster (shared disk) or here (scattered)
    for res in (shared, scattered):
        pd.testing.assert_frame_equal(res.table, serial.table)
        pd.testing.assert_frame_equal(read_table(res.table_path), read_table(serial.table_path))
    eng = shared.record["engine"]
    assert eng["kind"] == "dask-distributed" and eng["cache_shared"] is True and eng["batches"] == 4
    assert "read a token file" in eng["cache_why"]
    assert scattered.record["engine"]["sampling"] == "here, then scattered to the workers"
    # the table answers the sweep's question: a steeper sigmoid or a larger gain never fires less here
    n = serial.table.groupby(["transduction.gamma_per_pa", "spikes.gain_ms"]).n_spikes.sum()
    assert n[(2e-3, 100)] < n[(2e-3, 300)] and n[(2e-3, 100)] < n[(1e-2, 100)]
    # a task's own record is the scene as run with its parameters
    rec = records(tmp_path / "serial")[serial.table.task.iloc[-1]]
    assert rec["status"] == "ok" and rec["params"] == {"transduction.gamma_per_pa": 1e-2, "spikes.gain_ms": 300}
    assert rec["scene_tables"]["transduction"]["gamma_per_pa"] == 1e-2 and rec["scene_tables"]["spikes"]["gain_s"] == 0.3


def test_scheduler_address_connects_probes_the_disk_and_closes(tmp_path):
    distributed = pytest.importorskip("distributed")
    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = [2e-3, 1e-2]\n')
    serial = sweep(src, tmp_path / "serial", scheduler="serial")
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        res = sweep(src, tmp_path / "addr", scheduler=cluster.scheduler_address)
        assert res.record["engine"]["scheduler"] == cluster.scheduler_address and res.record["engine"]["cache_shared"]
        assert not any(".probe-" in p.name for p in Path(res.record["engine"]["cache_why"].split("'")[1]).iterdir())
    pd.testing.assert_frame_equal(res.table, serial.table)


def test_local_schedulers_equal_serial_and_rows_match_a_scene_run(tmp_path):
    pytest.importorskip("dask")
    src = write_sweep(tmp_path, SMALL)
    serial = sweep(src, tmp_path / "serial", scheduler="serial")
    for kind, out in (("processes", sweep(src, tmp_path / "default")), ("threads", sweep(src, tmp_path / "threads",
                                                                                             scheduler="threads"))):
        assert out.record["engine"]["kind"] == f"dask-{kind}"
        pd.testing.assert_frame_equal(out.table, serial.table)
    # one parameter set, run as a plain scene by `afferent run`, gives the same spike counts
    scene_file = tmp_path / "one.toml"
    scene_file.write_text(_BASE.replace("gain_s = 0.2", "gain_s = 0.3").replace(
        'params = "start"', 'params = "start"\ngamma_per_pa = 1e-2'))
    assert main(["run", str(scene_file), "-o", str(tmp_path / "one"), "--quiet"]) == 0
    ref = pd.read_csv(tmp_path / "one" / "spike_summary.csv")
    rows = serial.table[(serial.table["transduction.gamma_per_pa"] == 1e-2) & (serial.table["spikes.gain_ms"] == 300)]
    np.testing.assert_array_equal(rows.n_spikes.to_numpy(), ref.n_spikes.to_numpy())
    np.testing.assert_array_equal(rows.afferent.to_numpy(), ref.afferent.astype(str).to_numpy())


def test_without_dask_the_sweep_runs_serially_with_a_note(tmp_path, monkeypatch, capsys):
    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = [2e-3, 1e-2]\n')
    ref = sweep(src, tmp_path / "ref", scheduler="serial")
    monkeypatch.setitem(sys.modules, "dask", None)  # import dask -> ImportError
    capsys.readouterr()
    res = sweep(src, tmp_path / "nodask")
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("afferent: note: Dask is not installed")
    assert "running the 2 tasks serially" in err
    assert res.record["engine"]["kind"] == "serial"
    pd.testing.assert_frame_equal(res.table, ref.table)
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"scheduler='tcp://127.0.0.1:1' needs Dask's distributed scheduler"):
        sweep(src, tmp_path / "cluster", scheduler="tcp://127.0.0.1:1")


def test_the_table_is_csv_by_default_and_parquet_on_request_with_the_same_values(tmp_path, monkeypatch):
    """Before (issue 37): Parquet when pyarrow happened to be importable, else CSV; n_spikes float64."""
    pytest.importorskip("pyarrow")
    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = [2e-3, 1e-2]\n')
    csv = sweep(src, tmp_path / "csv", scheduler="serial")  # pyarrow installed: CSV still, the one default
    assert (tmp_path / "csv" / "table.csv").is_file() and not (tmp_path / "csv" / "table.parquet").exists()
    assert str(csv.table["n_spikes"].dtype) == "Int64"  # a count, as in spike_summary.csv
    pq = sweep(src, tmp_path / "pq", scheduler="serial", table_format="parquet")
    assert (tmp_path / "pq" / "table.parquet").is_file() and not (tmp_path / "pq" / "table.csv").exists()
    back = read_table(tmp_path / "pq" / "table.parquet")
    pd.testing.assert_frame_equal(back, pq.table)  # types kept, the count as Int64 too
    marker = json.loads((tmp_path / "pq" / ".afferent-output.json").read_text())
    assert "table.parquet" in marker["files"]  # afferent's, with its SHA-256: a later overwrite may replace it
    pd.testing.assert_frame_equal(read_table(tmp_path / "csv" / "table.csv"), back, check_dtype=False)
    assert csv.table.shape == back.shape
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow -> ImportError: said before anything runs
    with pytest.raises(ImportError, match=re.escape("table_format='parquet' needs pyarrow, which is not installed: "
                                                    "pip install pyarrow")):
        sweep(src, tmp_path / "none", scheduler="serial", table_format="parquet")
    assert not (tmp_path / "none").exists()
    with pytest.raises(ValueError, match=re.escape("table_format must be one of 'csv', 'parquet'; got 'xlsx'")):
        sweep(src, tmp_path / "none", scheduler="serial", table_format="xlsx")


# --------------------------------------------------------------------- resume, failures
def test_resume_skips_done_tasks_and_another_sweep_is_refused(tmp_path):
    src = write_sweep(tmp_path, SMALL)
    out = tmp_path / "out"
    first = sweep(src, out, scheduler="serial")
    lost = first.table.task.iloc[0]
    files = [f for f in (out / "tasks").glob("*.jsonl") if lost in f.read_text()]
    assert len(files) == 1 and len(files[0].read_text().splitlines()) == 1  # serial: 4 tasks in batches of 1
    files[0].unlink()  # as if the run had been killed before this task
    again = sweep(src, out, scheduler="serial")
    assert (again.n_ran, again.n_skipped) == (1, 3)
    pd.testing.assert_frame_equal(again.table, first.table)
    done = sweep(src, out, scheduler="serial")
    assert (done.n_ran, done.n_skipped) == (0, 4) and done.record["engine"]["kind"] == "none"
    other = write_sweep(tmp_path, '"transduction.gamma_per_pa" = [3e-3]\n', name="other.toml")
    with pytest.raises(OutputExistsError, match=r"holds another sweep \(4 tasks from .*s\.toml'\).*overwrite=True"):
        sweep(other, out, scheduler="serial")
    assert sweep(other, out, scheduler="serial", overwrite=True).n_ran == 1
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    with pytest.raises(OutputExistsError, match="already exists and is not a sweep's"):
        sweep(other, tmp_path / "busy", scheduler="serial")


def test_resume_redoes_tasks_whose_export_side_file_changed(tmp_path):
    """A task's id covers the files its scene names; a rewritten VTU of the .pvd (a file only the
    reader knows of) makes the re-run redo the tasks instead of keeping their old results."""
    import shutil

    shutil.copytree(SCENES.parent / "block4" / "series_0p88mm", tmp_path / "series")
    base = _BASE.replace(f"{SCENES.parent.as_posix()}/block4/series_0p88mm/", f"{(tmp_path / 'series').as_posix()}/")
    src = write_sweep(tmp_path, SMALL, base=base)
    out = tmp_path / "out"
    first = sweep(src, out, scheduler="serial", cache_dir=tmp_path / "cache")
    table = first.table  # read from table.csv on first access (issue 38): before the re-run rewrites it
    assert all(r["inputs"][str(tmp_path / "series" / "indent_003.vtu")] for r in records(out).values())
    shutil.copy(tmp_path / "series" / "indent_001.vtu", tmp_path / "series" / "indent_003.vtu")
    again = sweep(src, out, scheduler="serial", cache_dir=tmp_path / "cache")
    assert (again.n_ran, again.n_skipped) == (4, 0)
    assert not again.table.equals(table)
    import dataclasses

    from afferent.exceptions import AfferentError

    with pytest.raises(AfferentError, match=r"table\.csv' was rewritten after this sweep .*read it before running the "
                                            r"sweep again, or read_table\(path\)"):
        dataclasses.replace(first, _table=None).table  # not read before the re-run: not the re-run's table instead


def test_a_failing_task_is_reported_and_loses_nothing(tmp_path, capsys):
    src = write_sweep(tmp_path, '"spikes.gain_s" = [0.2, -1.0, 0.3]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(src), "-o", str(out), "--scheduler", "serial"]) == 1
    err = capsys.readouterr().err
    assert "afferent: warning: task " in err
    assert "(ramp_0p88, {'spikes.gain_s': -1.0}) failed: ValueError: 'gain' must be >= 0 s; got -1.0 instead." in err
    record = json.loads((out / "sweep.json").read_text())
    assert record["n_failed"] == 1 and record["failures"][0]["params"] == {"spikes.gain_s": -1.0}
    assert record["failures"][0]["stage"] == "input"
    table = read_table(out / record["table"])
    assert sorted(table["spikes.gain_s"].unique()) == [0.2, 0.3] and len(table) == 6
    # a re-run retries only the failed task
    res = sweep(src, out, scheduler="serial")
    assert (res.n_ran, res.n_skipped, res.n_failed) == (1, 2, 1)


# ---------------------------------------------------------------------- sweep files
def test_ranges_modes_dotted_keys_and_scene_lists(tmp_path):
    src = write_sweep(tmp_path, """\
        mode = "zip"
        "spikes.gain_ms" = {start = 100, stop = 300, num = 3}
        transduction.gamma_per_pa = {start = 1e-3, stop = 1e-1, num = 3, spacing = "log"}
        """)
    spec = load_sweep(src)
    assert [t.params for t in spec.tasks] == [
        {"spikes.gain_ms": 100.0, "transduction.gamma_per_pa": 1e-3},
        {"spikes.gain_ms": 200.0, "transduction.gamma_per_pa": pytest.approx(1e-2, rel=1e-12)},
        {"spikes.gain_ms": 300.0, "transduction.gamma_per_pa": pytest.approx(1e-1, rel=1e-12)}]
    assert [t.scene.spikes.gain_s for t in spec.tasks] == [0.1, 0.2, 0.3]  # ms -> s, the base's gain_s replaced
    assert len({t.group for t in spec.tasks}) == 1 and len({t.id for t in spec.tasks}) == 3
    # a sweep over scenes: each listed scene x the parameter sets; a plain scene file is one task
    lst = tmp_path / "list.toml"
    lst.write_text(f'[sweep]\nscenes = ["{SCENES.as_posix()}/profiles.toml", "{SCENES.as_posix()}/spikes_ramp.toml"]\n'
                   '"transduction.gamma_per_pa" = [2e-3, 4.6e-3]\n')
    spec = load_sweep([lst, SCENES / "profiles.toml"])
    assert [(t.label, t.params.get("transduction.gamma_per_pa")) for t in spec.tasks] == [
        ("profiles", 2e-3), ("profiles", 4.6e-3), ("spikes_ramp", 2e-3), ("spikes_ramp", 4.6e-3), ("profiles", None)]
    assert len({t.group for t in spec.tasks}) == 2  # two exports: two samplings


@pytest.mark.parametrize("table, match, cls", [
    ('"transduction.gama_per_pa" = [1e-3]\n',
     r"line {n}: \[sweep\] 'transduction.gama_per_pa': unknown key 'gama_per_pa' in \[transduction\]; known keys "
     r"are .*Did you mean 'gamma_per_pa'\?", SceneError),
    ('"spikes.engine" = ["exact", "bogus"]\n',
     r"line {n}: \[sweep\] 'spikes.engine' = 'bogus': \[spikes\] 'engine' must be one of 'auto', .*; got 'bogus' "
     r"instead\.", SceneError),
    ('spikes.dt_ms = [0.1, "x"]\n',
     r"line {n}: \[sweep\] 'spikes.dt_ms' = 'x': \[spikes\] 'dt_ms' must be a number in ms; got 'x' \(a string\) "
     r"instead\.", SceneTypeError),
    ('mode = "zip"\n"spikes.gain_ms" = [1, 2]\n"spikes.tau_ms" = [1, 2, 3]\n',
     r"line {n}: \[sweep\] mode = 'zip' pairs .*; 'spikes.tau_ms' has 3, 'spikes.gain_ms' has 2\.", SceneError),
    ('mode = "grid"\n', r"line {n}: \[sweep\] 'mode' must be one of 'product', 'zip'; got 'grid' instead\.", SceneError),
    ('"outputs.want" = [["spikes"]]\n', r"line {n}: \[sweep\] 'outputs.want': \[outputs\] cannot be swept", SceneError),
    ('"spikes.gain_ms" = {start = 1, stop = 2}\n',
     r"line {n}: \[sweep\] 'spikes.gain_ms': a range is \{{start = A, stop = B, num = N\}}", SceneError),
    ('"spikes.gain_ms" = []\n', r"line {n}: \[sweep\] 'spikes.gain_ms' must list at least one value", SceneError),
])
def test_errors_name_the_file_the_key_and_its_line(tmp_path, table, match, cls):
    src = write_sweep(tmp_path, table)
    last = table.strip().splitlines()[-1].split("=")[0].strip()
    n = _line(src, last) if "mode = \"zip\"" not in table else _line(src, '"spikes.tau_ms"')
    with pytest.raises(cls, match=f"^Sweep file '{src}', " + match.format(n=n)) as info:
        load_sweep(src)
    assert info.value.line == n


def test_scene_errors_and_cli_errors(tmp_path, capsys):
    # an error of the scene itself is the scene's, at its own line
    with pytest.raises(SceneError, match=r"^Scene file '.*t\.toml', line \d+: unknown key 'tau_mss' in \[spikes\]") as info:
        load_sweep(write_sweep(tmp_path, '"spikes.gain_ms" = [1]\n', name="t.toml",
                               base=_BASE.replace("tau_ms = 5.0", "tau_mss = 5.0")))
    assert info.value.line == _line(tmp_path / "t.toml", "tau_mss")
    only_map = write_sweep(tmp_path, '"sampling.method" = ["linear", "nearest"]\n', name="m.toml",
                           base=_BASE.replace('want = ["spikes", "profiles"]', 'want = ["sed_map"]'))
    with pytest.raises(SceneError, match=r"a sweep tabulates per-afferent results, so \[outputs\] want must include one "
                                         r"of 'currents', 'profiles', 'fit', 'spikes'; got \['sed_map'\] instead\."):
        load_sweep(only_map)
    src = write_sweep(tmp_path, '"transduction.gama_per_pa" = [1e-3]\n', name="e.toml")
    assert main(["sweep", str(src), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: Sweep file '{src}', line {_line(src, 'gama')}: [sweep] ") and err.count("\n") == 1
    assert not (tmp_path / "o").exists()  # checked before anything is written
    assert main(["sweep", str(tmp_path / "missing.toml"), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: Sweep file '") and err.rstrip().endswith("missing.toml' not found.")


def test_sample_sweep_file_is_a_valid_scene_plus_sweep():
    spec = load_sweep(SWEEP_GAMMA)
    assert len(spec.tasks) == 12 and spec.keys == ("transduction.gamma_per_pa", "spikes.gain_ms")
    assert len(spec.groups) == 1
    assert [t.params for t in spec.tasks][:3] == [{"transduction.gamma_per_pa": 2e-3, "spikes.gain_ms": g}
                                                  for g in (100.0, 200.0, 300.0)]
    assert {t.scene.spikes.gain_s for t in spec.tasks} == {0.1, 0.2, 0.3}


def test_readme_sweep_example_runs_on_the_sample(tmp_path, monkeypatch, capsys):
    """The "Sweeps" example of docs/scenes.md (moved there from the README), as written (output folder moved into
    tmp_path)."""
    page = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    section = page.split("\n## Sweeps")[1].split("\n## ")[0]
    cmd = next(line[2:] for line in section.splitlines() if line.startswith("$ afferent sweep "))
    argv = cmd.split()[1:]
    monkeypatch.chdir(ROOT)
    argv[argv.index("-o") + 1] = str(tmp_path / "sweep_gamma")
    assert main(argv) == 0
    assert "tasks: 12 (12 run, 0 done before, 0 failed)" in capsys.readouterr().err
    table = read_table(next((tmp_path / "sweep_gamma").glob("table.*")))
    assert len(table) == 36  # 12 tasks x 3 afferents in the region, as docs/scenes.md says
    n = table.pivot_table(index="transduction.gamma_per_pa", columns="spikes.gain_ms", values="n_spikes", aggfunc="sum")
    # golden: the page's numbers, from this example run with the exact LIF engine (deterministic)
    assert (n.loc[2e-3, 100.0], n.loc[1e-2, 300.0]) == (23, 226)  # (80, 273) on the sample before issue 21
    assert "23 ... 226 spikes per task" in section


# ------------------------------------------------------------- killed sweeps (issue 26, item 8)
_WIDE = ('"transduction.gamma_per_pa" = {start = 1e-3, stop = 1e-2, num = 40}\n'
         '"spikes.gain_ms" = {start = 100, stop = 300, num = 10}\n')


def _is_pool_worker(proc) -> bool:
    """A process of the 'processes' scheduler's pool (not the resource tracker, not a child before its exec)."""
    import psutil

    try:
        line = " ".join(proc.cmdline())
    except psutil.Error:
        return False
    return "--multiprocessing-fork" in line and "resource_tracker" not in line


def _start_sweep_and_wait_for_workers(tmp_path, spec: str = _WIDE, n_workers: int = 2, poll: float = 0.1):
    """A real `afferent sweep` of ``spec`` on the 'processes' engine, once ``n_workers`` workers run (polled every
    ``poll`` s); (process, its descendants, the workers)."""
    import subprocess
    import time

    psutil = pytest.importorskip("psutil")
    src = write_sweep(tmp_path, spec)
    proc = subprocess.Popen([sys.executable, "-m", "afferent", "sweep", str(src), "-o", str(tmp_path / "out"),
                             "--scheduler", "processes", "--no-cache", "-q"], stderr=subprocess.PIPE, text=True,
                            cwd=ROOT)
    parent, t0 = psutil.Process(proc.pid), time.monotonic()
    while time.monotonic() - t0 < 180:
        kids = parent.children(recursive=True)
        # a pool worker once it runs multiprocessing's spawn_main: a child just forked still shows its parent's
        # command line (the resource tracker before its exec was taken for a worker and killed: a flaky failure)
        workers = [k for k in kids if _is_pool_worker(k)]
        if len(workers) >= n_workers or proc.poll() is not None:
            break
        time.sleep(poll)
    assert proc.poll() is None and len(workers) >= n_workers, proc.stderr.read() if proc.poll() is not None else kids
    return proc, kids, workers


def _end_of_sweep(proc, kids, timeout: float) -> tuple[int, list, str]:
    """Wait for the sweep (``timeout`` s), then for its descendants (10 s; any left are killed): (exit code, the
    descendants that were still alive, its stderr)."""
    import psutil

    code = proc.wait(timeout)
    _, alive = psutil.wait_procs(kids, timeout=10)
    for p in alive:
        p.kill()
    return code, alive, proc.stderr.read()


@pytest.mark.slow
@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
def test_a_killed_sweep_leaves_no_process_behind(tmp_path, how):
    """Killing `afferent sweep` left its workers and the resource tracker running for good (~100 MB each)."""
    import signal

    import psutil

    proc, kids, _ = _start_sweep_and_wait_for_workers(tmp_path)
    proc.send_signal(getattr(signal, how))
    code = proc.wait(30)
    _, alive = psutil.wait_procs(kids, timeout=10)
    for p in alive:  # do not leave them to the next test
        p.kill()
    assert not alive, [p.pid for p in alive]
    assert code == (143 if how == "SIGTERM" else -signal.SIGKILL)  # SIGTERM: the handler ends the workers, exits


@pytest.mark.slow
def test_a_killed_worker_is_named_with_its_signal(tmp_path):
    """A worker killed mid-sweep was reported as a script missing `if __name__ == '__main__'`."""
    import signal

    proc, kids, workers = _start_sweep_and_wait_for_workers(tmp_path)
    workers[0].send_signal(signal.SIGKILL)
    code, alive, err = _end_of_sweep(proc, kids, 60)
    assert code == 2 and not alive, err
    assert err.startswith("afferent: error: a sweep worker died (signal 9, SIGKILL) while running tasks"), err
    assert "run the same sweep again to resume" in err and "__main__" not in err


@pytest.mark.slow
def test_a_worker_killed_in_the_first_task_is_named_with_its_own_signal(tmp_path):
    """Issue 33, item 13: the workers were known from what ran when a task started; one killed while the first
    task (the export's sampling) ran was not, and its death was blamed on a calling script without
    `if __name__ == '__main__'` (internal error, exit 1), or on the SIGTERM the pool sends the others."""
    import signal

    proc, kids, workers = _start_sweep_and_wait_for_workers(tmp_path, SMALL, n_workers=1, poll=0.02)
    workers[0].send_signal(signal.SIGSEGV)  # the first worker, at once: before or while it samples the export
    code, alive, err = _end_of_sweep(proc, kids, 120)
    assert code == 2 and not alive, err
    assert err.startswith("afferent: error: a sweep worker died (signal 11, SIGSEGV) while running tasks"), err


# --------------------------------------------------------- the task count (issue 26, item 7)
def test_a_huge_sweep_is_counted_and_refused_before_anything_is_built(tmp_path, capsys):
    """2 x 10^10 parameter sets were built in memory (MemoryError at 3.8 GB, exit 1)."""
    import time

    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = {start = 1e-3, stop = 1e-2, num = 100000}\n'
                                '"spikes.gain_ms" = {start = 100, stop = 300, num = 200000}\n')
    t = time.process_time()
    assert main(["sweep", str(src), "-o", str(tmp_path / "out")]) == 2
    assert time.process_time() - t < 2.0
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: Sweep file {str(src)!r} makes 20,000,000,000 tasks (scene files x "
                          "parameter sets); a sweep runs at most 1,000,000"), err
    assert "--max-tasks 20000000000" in err and not (tmp_path / "out").exists()
    one = write_sweep(tmp_path, '"spikes.gain_ms" = {start = 100, stop = 300, num = 10000000000}\n', name="one.toml")
    with pytest.raises(SceneError, match="makes 10,000,000,000 tasks"):  # a range of 10^10 values: not allocated
        load_sweep(one)


def test_max_tasks_sets_the_limit_and_parameter_sets_are_made_one_at_a_time(tmp_path):
    import types

    from afferent._sweep import spec

    src = write_sweep(tmp_path, SMALL)
    with pytest.raises(SceneError, match=r"makes 4 tasks .*at most 3 .*max_tasks=4 \(afferent sweep --max-tasks 4\)"):
        load_sweep(src, max_tasks=3)
    assert len(load_sweep(src, max_tasks=4).tasks) == 4
    with pytest.raises(ValueError, match="'max_tasks' must be a positive integer; got 0 instead"):
        load_sweep(src, max_tasks=0)
    params = {"a.b": ([1, 2], None), "c.d": (spec._Range(1.0, 4.0, 4, "log"), None)}
    sets = spec._combinations(params, "product")
    assert isinstance(sets, types.GeneratorType) and spec._n_combinations(params, "product") == 8
    assert [s["c.d"] for s in sets][:4] == [float(v) for v in np.geomspace(1.0, 4.0, 4)]


# ------------------------------------------------- the task list is a stream (issue 26, item 7)
def test_a_sweep_of_a_million_tasks_is_specified_and_made_in_bounded_memory(tmp_path, monkeypatch):
    """The task list was built in full (bounded only by max_tasks): 10^6 tasks, ~8 GB of resolved scenes."""
    import time
    import tracemalloc

    from afferent._sweep import records as sw
    from afferent._sweep.records import _Ids, _windows

    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = {start = 1e-3, stop = 1e-2, num = 1000}\n'
                                '"spikes.gain_ms" = {start = 100, stop = 300, num = 1000}\n')
    tracemalloc.start()
    try:
        t = time.process_time()
        spec = load_sweep(src, max_tasks=10**6)
        assert spec.n_tasks == 10**6 and time.process_time() - t < 2.0
        assert sw.WINDOW <= 4096
        monkeypatch.setattr(sw, "WINDOW", 100)
        ids, counts = bytearray(), {"skipped": 0, "groups": 0}
        windows = _windows(spec, _Ids(), ids, counts)

        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        made = 0
        for t in spec.iter_tasks():  # the stream: each task made, then dropped
            made += 1
            if made == 300:
                break
        peak = tracemalloc.get_traced_memory()[1] - base
        assert peak < 2e6, peak  # ~8 KiB a task were held: 10^6 tasks ~ 8 GB; now one task at a time
        assert next(iter(spec.iter_tasks())).index == 0
        first = next(windows)  # a window holds at most WINDOW tasks, whatever the sweep's size
        assert sum(map(len, first.values())) == 100 and len(ids) == 8 * 100
    finally:
        tracemalloc.stop()
    rec = spec.digest
    assert load_sweep(src, max_tasks=10**6).digest == rec  # the identity is the definition, not a list of tasks


def test_resume_after_an_interruption_equals_an_uninterrupted_run(tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) mid-sweep, tasks made in windows of 3, resumed on another engine: same table and records
    as one uninterrupted run; sweep.json holds the specification and counts, not a list of every task."""
    from afferent._sweep import engine
    from afferent._sweep import records as sw

    src = write_sweep(tmp_path, '"transduction.gamma_per_pa" = [2e-3, 1e-2]\n"spikes.gain_ms" = {start = 100, '
                                'stop = 300, num = 4}\n')
    whole = sweep(src, tmp_path / "whole", scheduler="serial")
    assert (whole.n_tasks, whole.n_ran) == (8, 8)
    monkeypatch.setattr(sw, "WINDOW", 3)
    real, calls = engine.run_batch, []

    def interrupted(sampled, tasks):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(sampled, tasks)

    monkeypatch.setattr(engine, "run_batch", interrupted)
    with pytest.raises(KeyboardInterrupt):
        sweep(src, tmp_path / "out", scheduler="serial", batch_size=1)
    monkeypatch.setattr(engine, "run_batch", real)
    assert len(records(tmp_path / "out")) == 3
    again = sweep(src, tmp_path / "out", scheduler="threads", batch_size=2)
    assert (again.n_tasks, again.n_ran, again.n_skipped, again.n_failed) == (8, 5, 3, 0)
    pd.testing.assert_frame_equal(again.table, whole.table)
    assert {k: r["index"] for k, r in records(tmp_path / "out").items()} == {
        k: r["index"] for k, r in records(tmp_path / "whole").items()}
    rec = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert "tasks" not in rec and rec["n_tasks"] == 8 and rec["sweep_digest"] == whole.record["sweep_digest"]
    assert rec["specification"][0]["params"]["spikes.gain_ms"] == {"start": 100, "stop": 300, "num": 4,
                                                                    "spacing": "linear"}
    assert rec["engine"]["windows"] == 2 and rec["n_sampling_groups"] == 1


def test_resume_reruns_a_task_whose_record_is_not_utf8(tmp_path):
    """Issue 33, item 11. Before: the resume stopped with UnicodeDecodeError (an internal error, exit 1) on a task
    record holding bytes that are not UTF-8; now that line is not a record (the task runs again), the others are."""
    src = write_sweep(tmp_path, SMALL)
    out = tmp_path / "out"
    first = sweep(src, out, scheduler="serial")
    damaged = next(f for f in (out / "tasks").glob("*.jsonl") if first.table.task.iloc[0] in f.read_text())
    damaged.write_bytes(damaged.read_bytes().replace(b'"status"', b'"st\xffatus"', 1))
    again = sweep(src, out, scheduler="serial")
    assert (again.n_ran, again.n_skipped) == (1, 3)
    pd.testing.assert_frame_equal(again.table, first.table)
