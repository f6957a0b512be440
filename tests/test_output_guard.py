"""Issue 33, lost files: --overwrite deletes only files afferent can prove it wrote (afferent._owned), every
command hands all its inputs to the one guard (afferent._output.command_inputs), the final step never
deletes a link swapped in, and SIGTERM / SIGHUP leave no temporary output. Real files in temporary trees.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from afferent.cli import main
from conftest import SAMPLE_DIR

EXPORT = SAMPLE_DIR / "block4" / "indent_0p88mm.vtu"
RECEPTORS = SAMPLE_DIR / "block4" / "receptors.csv"
needs_sample = pytest.mark.skipif(not EXPORT.is_file(), reason="bundled sample not generated")
RUN = ["run", str(EXPORT), "--receptors", str(RECEPTORS), "--length-unit", "mm", "--sed-unit", "MPa", "--params",
       "start", "--no-plots", "--no-cache", "-q"]


def _snapshot(root) -> dict:
    """Every file, link and folder below ``root`` -> its bytes (links: their target; folders: None)."""
    out = {}
    for p in sorted(Path(root).rglob("*")):
        rel = p.relative_to(root).as_posix()
        out[rel] = os.readlink(p) if p.is_symlink() else (p.read_bytes() if p.is_file() else None)
    return out


def _study(root: Path) -> Path:
    """A user's study folder: raw data, a thesis chapter, a config."""
    (root / "raw").mkdir(parents=True)
    (root / "thesis").mkdir()
    (root / "raw" / "measurements.csv").write_text("t,f\n0,1\n")
    (root / "thesis" / "chapter1.md").write_text("# Chapter 1\n")
    (root / "config.json").write_text('{"mine": true}\n')
    return root


@needs_sample
def test_overwrite_never_deletes_a_users_folder_holding_an_earlier_run(tmp_path, capsys):
    """Issue 33.1: `run -o study --overwrite`, study/ holding raw/measurements.csv, thesis/chapter1.md, config.json
    and an earlier run study/run1/, exited 0 and deleted the three files (any */run.json was taken for proof, and
    '*.csv', '*.md', '*.json' matched across '/'). Now refused, nothing touched."""
    study = _study(tmp_path / "study")
    assert main([*RUN, "-o", str(study / "run1")]) == 0
    before = _snapshot(study)
    assert main([*RUN, "-o", str(study), "--overwrite"]) == 2
    assert re.fullmatch(r"afferent: error: Output folder '.*/study' was not written by afferent \(it has no "
                        r"\.afferent-output\.json, the record of each file afferent wrote there; .*\n",
                        capsys.readouterr().err)
    assert _snapshot(study) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study"]  # no temporary left


def _record(folder: Path, files: dict) -> dict:
    return {name: {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()} for name, data in files.items()}


HAND_WRITTEN = {
    "patterns *": {"patterns": ["*"], "files": []},
    "format 1, names": {"afferent_output": 1, "patterns": ["*"], "files": ["thesis.tex", "sub/data.txt"]},
    "format 2, sizes wrong": {"afferent_output": 2, "folders": ["sub"], "files": {
        "thesis.tex": {"size": 1, "sha256": "0" * 64}, "sub/data.txt": {"size": 1, "sha256": "0" * 64}}},
    "format 2, a folder unlisted": "unlisted folder",
}


@pytest.mark.parametrize("kind", list(HAND_WRITTEN))
def test_a_hand_written_record_deletes_nothing(tmp_path, kind):
    """Issue 33.2: a hand-written .afferent-output.json with "patterns": ["*"] was trusted: overwrite deleted
    thesis.tex and sub/data.txt. Only each file's size and SHA-256 as afferent recorded them count."""
    from afferent._output import atomic_dir
    from afferent.exceptions import OutputExistsError

    out = tmp_path / "out"
    (out / "sub").mkdir(parents=True)
    (out / "thesis.tex").write_text("\\documentclass{article}\n")
    (out / "sub" / "data.txt").write_text("1 2 3\n")
    record = HAND_WRITTEN[kind]
    if record == "unlisted folder":  # the files proven, the folder holding one not named: still not afferent's
        record = {"afferent_output": 2, "folders": [], "files": _record(out, {
            "thesis.tex": (out / "thesis.tex").read_bytes(), "sub/data.txt": (out / "sub" / "data.txt").read_bytes()})}
    (out / ".afferent-output.json").write_text(json.dumps(record))
    before = _snapshot(tmp_path)
    with pytest.raises(OutputExistsError, match=r"Output folder '.*/out' (has a \.afferent-output\.json that is not "
                                                r"afferent's record of its files|holds files (afferent did not write|"
                                                r"changed since afferent wrote them) \(.*'(thesis.tex|sub)')"):
        with atomic_dir(out, overwrite=True) as tmp:
            (Path(tmp) / "new.csv").write_text("x\n")
    assert _snapshot(tmp_path) == before


def test_afferents_own_folder_is_replaced_and_its_temporaries_with_it(tmp_path):
    """The other side: a folder afferent wrote (subfolders, a temporary a killed writer left) is replaced whole."""
    from afferent._output import atomic_dir

    out = tmp_path / "out"
    with atomic_dir(out) as tmp:
        (Path(tmp) / "a").mkdir()
        (Path(tmp) / "a" / "t.csv").write_text("old\n")
        (Path(tmp) / "run.json").write_text("{}")
    (out / ".run.json.k2j4x_a1.part").write_text("{")  # a writer killed while replacing run.json
    with atomic_dir(out, overwrite=True) as tmp:
        (Path(tmp) / "b.csv").write_text("new\n")
    assert sorted(_snapshot(out)) == [".afferent-output.json", "b.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    (out / ".notes.txt.k2j4x_a1.part").write_text("mine")  # a temporary of a name afferent did not write: not its
    with pytest.raises(Exception, match=r"holds files afferent did not write \('\.notes\.txt\.k2j4x_a1\.part'\)"):
        with atomic_dir(out, overwrite=True):
            pass


def _hotspot_runs(root: Path) -> list[str]:
    from afferent.hotspots import hotspot_table

    for name, values in (("a_one", [1.0, 2.0, 3.0]), ("a_two", [3.0, 2.0, 1.0])):
        d = root / name
        d.mkdir(parents=True)
        hotspot_table(["1", "2", "3"], np.eye(3) * 1e-3, values, site="RA-I").assign(map="RA-I").to_csv(
            d / "hotspots.csv", index=False)
    return sorted(map(str, root.iterdir()))


def _cycle_runs(root: Path) -> list[str]:
    from afferent.cycles import cycle_table

    for name, f in (("b_20", 20.0), ("b_40", 40.0)):
        t = np.arange(3 * 20 + 1) / (20 * f)
        v = np.array([1.0, 3.0, 2.0])[None, :] * (1 - np.cos(2 * np.pi * f * t[:, None])) / 2
        (root / name).mkdir(parents=True)
        cycle_table(t, v, f)[0].to_csv(root / name / "cycles.csv", index=False)
    return sorted(map(str, root.iterdir()))


@pytest.mark.parametrize("command", ["hotspots", "cycles"])
def test_hotspots_and_cycles_refuse_an_output_at_their_runs(tmp_path, capsys, command):
    """Issue 33.3: `hotspots`/`cycles` did not tell the guard their input runs: -o inside a run was accepted, -o a
    run with --overwrite replaced it, -o the folder holding the runs deleted all of them."""
    runs = (_hotspot_runs if command == "hotspots" else _cycle_runs)(tmp_path / "runs")
    extra = ["--trials", "50"] if command == "hotspots" else []
    assert main([command, *runs, "-o", str(tmp_path / "summary"), *extra]) == 0  # runs as such are fine
    capsys.readouterr()
    before = _snapshot(tmp_path)
    for out, relation in ((Path(runs[0]) / "out", "lies inside the input folder"), (runs[0], "is the input"),
                          (tmp_path / "runs", "holds the input")):
        assert main([command, *runs, "-o", str(out), "--overwrite", *extra]) == 2
        assert re.fullmatch(rf"afferent: error: Output folder '{re.escape(str(out))}' {relation} '.*/runs/\w+'.*\n",
                            capsys.readouterr().err)
        assert _snapshot(tmp_path) == before


def test_a_sweep_of_a_folder_refuses_an_output_inside_it(tmp_path, capsys, monkeypatch):
    """Issue 33.3: `sweep FOLDER -o FOLDER/out` was accepted (the guard saw the folder's scene files, not the
    folder) though the README forbids an output inside an input folder."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    text = (SAMPLE_DIR / "scenes" / "sweep_gamma.toml").read_text().split("[sweep]")[0]
    (scenes / "a.toml").write_text(text.replace('"../', f'"{SAMPLE_DIR.as_posix()}/'))  # a plain scene: one task
    before = _snapshot(tmp_path)
    assert main(["sweep", str(scenes), "-o", str(scenes / "out"), "--scheduler", "serial", "-q"]) == 2
    assert re.fullmatch(r"afferent: error: Output folder '.*/scenes/out' lies inside the input folder '.*/scenes'; "
                        r"choose an output outside it.\n", capsys.readouterr().err)
    assert _snapshot(tmp_path) == before


# -------------------------------------------------------- every command: its -o against every input it reads
#: options whose values name no file or folder (a new option must be classified: marked with
#: afferent.cli._options.reads, or listed here)
NOT_PATHS = {"output", "accept", "grid", "times", "sed_column", "stress_columns", "strain_columns", "coord_columns",
             "material_array", "side", "lif_preset", "series_depths_mm", "start", "group", "noise", "scheduler", "elastic"}


def _commands() -> dict:
    from afferent.cli._main import build_parser

    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def _plain(action) -> bool:
    """A flag, a choice, a number or a unit: never a path."""
    name = getattr(action.type, "__name__", "")
    return (isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction, argparse._HelpAction,
                                argparse._VersionAction)) or bool(action.choices)
            or name in ("int", "float", "positive_number") or name.endswith(" unit"))


def test_every_option_of_every_command_is_classified_path_or_not():
    unclassified = [(name, a.dest) for name, p in _commands().items() for a in p._actions
                    if not hasattr(a, "afferent_reads") and not _plain(a) and a.dest not in NOT_PATHS]
    assert unclassified == []


def _value(action, path: str) -> str:
    """The value of ``action`` that names ``path`` (``map:PATH`` for --synthesis)."""
    for v in (path, f"map:{path}"):
        if tuple(action.afferent_reads(v)) == (path,):
            return v
    raise AssertionError(action.dest)


def _argv(parser, target, path: str, other: str) -> list[str]:
    """A command line giving ``target`` the value naming ``path``, every other input ``other``, every other required
    argument a plain value."""
    pos, opts = [], []
    for a in parser._actions:
        wanted = a.required or not a.option_strings or hasattr(a, "afferent_reads")
        if not wanted or a.dest in ("help", "output"):
            continue
        if a is target:
            value = _value(a, path)
        elif hasattr(a, "afferent_reads"):
            value = _value(a, other)
        else:
            value = "mm" if getattr(a.type, "__name__", "").endswith(" unit") else str((a.choices or ["1"])[0])
        (opts.extend([a.option_strings[-1], value]) if a.option_strings else pos.append(value))
    return [*pos, *opts]


def test_every_command_refuses_an_output_that_is_holds_or_lies_inside_any_input(tmp_path, capsys, monkeypatch):
    """Issue 33.3, made structural: afferent.cli gathers every path a command reads (its options marked with
    _options.reads) and checks -o against them before the command starts, whatever the command."""
    box = tmp_path / "box"
    data = box / "input"
    data.mkdir(parents=True)
    (data / "x.csv").write_text("x\n")
    (tmp_path / "other.csv").write_text("y\n")
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    checked = []
    for name, parser in _commands().items():
        if not any(a.dest == "output" for a in parser._actions):
            continue
        for action in (a for a in parser._actions if hasattr(a, "afferent_reads")):
            argv = [name, *_argv(parser, action, str(data), str(tmp_path / "other.csv"))]
            for out, relation in ((data, "is the input"), (data / "out", "lies inside the input folder"),
                                  (box, "holds the input")):
                before = _snapshot(tmp_path)
                assert main([*argv, "-o", str(out), "--overwrite"]) == 2, (argv, out)
                err = capsys.readouterr().err
                assert re.fullmatch(rf"afferent: error: Output (folder|file) '{re.escape(str(out))}' {relation} "
                                    rf"'{re.escape(str(data))}'.*\n", err), (argv, err)
                assert _snapshot(tmp_path) == before
            checked.append((name, action.dest))
    assert {c for c, _ in checked} == {"sample", "run", "calibrate", "demo", "sweep", "hotspots", "cycles"}


# ------------------------------------------------------------------- a link swapped in at the final step
@pytest.mark.parametrize("renameat2", ["renameat2", "without renameat2"])
def test_a_link_swapped_in_during_overwrite_is_put_back_untouched(tmp_path, monkeypatch, renameat2):
    """Issue 33.4: a symlink put in place of the output between the check and the final exchange ended 1 run in 25
    'internal error: Cannot call rmtree on a symbolic link' and left the link under a hidden '.out.*.part' name.
    Now what was swapped out is proven again: the link is put back, the run's results discarded, nothing left."""
    import afferent._output as output
    from afferent._output import atomic_dir
    from afferent.exceptions import OutputExistsError

    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    with atomic_dir(out) as tmp:
        (Path(tmp) / "a.csv").write_text("old\n")
    elsewhere.mkdir()
    (elsewhere / "precious.txt").write_text("mine\n")
    real_check, calls = output.check_place, []

    def check_then_swap(path, *args):  # at the final step the guard accepts the place; then a link is put there
        real_check(path, *args)
        calls.append(path)
        if len(calls) == 2:  # the first: before the work (atomic_dir), the second: at the final step (_replace)
            out.rename(tmp_path / "moved")
            out.symlink_to(elsewhere)

    monkeypatch.setattr(output, "check_place", check_then_swap)
    if renameat2 != "renameat2":
        monkeypatch.setattr(output, "_renameat2", lambda src, dst, flags: False)
    with pytest.raises(OutputExistsError, match=r"Output folder '.*/out' changed while this run was writing it \(it is "
                                                r"now a symbolic link to '.*/elsewhere'\); it is kept as it is"):
        with atomic_dir(out, overwrite=True) as tmp:
            (Path(tmp) / "a.csv").write_text("new\n")
    assert out.is_symlink() and os.readlink(out) == str(elsewhere)
    assert (elsewhere / "precious.txt").read_text() == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "moved", "out"]  # no '.out.*.part'


# ------------------------------------------------------------------- SIGTERM, SIGHUP while writing
def _command(kind: str, root: Path, out: Path) -> list[str]:
    if kind == "run":
        return [*RUN[:-3], "--no-cache", "-o", str(out)]  # with its figures: a longer writing stage
    runs = (_hotspot_runs if kind == "hotspots" else _cycle_runs)(root / "runs")
    return [kind, *runs, "-o", str(out)]


@needs_sample
@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
@pytest.mark.parametrize("kind, sig", [("run", "SIGTERM"), ("run", "SIGHUP"), ("hotspots", "SIGTERM"),
                                       ("cycles", "SIGTERM")])
def test_sigterm_while_writing_leaves_no_temporary_output(tmp_path, kind, sig):
    """Issue 33.5: SIGTERM during run, hotspots, cycles left '.OUT.XXXX.part' folders (mode 0700, partial results)
    that nothing removed. SIGTERM and SIGHUP now end the command as Ctrl-C does: its temporaries removed, one
    line, exit 128 + the signal's number. The signal is sent once the temporary output folder exists."""
    sig = getattr(signal, sig)
    out = tmp_path / "results" / "out"
    out.parent.mkdir()
    env = dict(os.environ, MPLBACKEND="Agg", AFFERENT_FIGURE_PROCESS="0",
               PYTHONPATH=os.pathsep.join([str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, "-m", "afferent", *_command(kind, tmp_path, out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    sent, deadline = False, time.monotonic() + 120
    while proc.poll() is None and time.monotonic() < deadline:
        if any(p.is_dir() for p in out.parent.glob(".out.*.part")):
            proc.send_signal(sig)
            sent = True
            break
        time.sleep(0.001)
    code = proc.wait(timeout=60)
    assert sent, f"the command ended before it wrote: {proc.stderr.read()}"
    assert code == 128 + sig, proc.stderr.read()
    assert proc.stderr.read() == f"afferent: terminated by {signal.Signals(sig).name}\n"
    assert os.listdir(out.parent) == []
