"""Errors that are not bugs, bugs that look like errors (issue 26, item 9, second half).

Exit code 2 and one line of afferent's own words for bad input; a ValueError or TypeError that
numpy, pandas or a built-in raised on a case afferent does not check is a bug: exit code 1,
"internal error (please report)", never the library's raw text passed off as a diagnosis.
"""

from __future__ import annotations

import os
import subprocess
import sys
import types

import numpy as np
import pytest

from afferent.cli import main
from afferent.cli._main import COMMANDS, raised_on_purpose
from afferent.units import length_factor

from conftest import DATA_DIR, SAMPLE_DIR


def _command(run):
    """A subcommand module as COMMANDS takes them (add_args, run), for the dispatch alone."""
    module = types.ModuleType("afferent_test_command", "A command that fails (tests only).")
    module.add_args = lambda parser: None
    module.run = run
    return module


def _raise_from_numpy(args):
    np.zeros(3).reshape(2, 2)


def _raise_from_a_builtin(args):
    float("n/a")


def _raise_from_numpy_types(args):
    np.add(np.array(["a"]), 1)


@pytest.mark.parametrize("run, text", [
    (_raise_from_numpy, "ValueError: cannot reshape array of size 3 into shape (2,2)"),
    (_raise_from_a_builtin, "ValueError: could not convert string to float: 'n/a'"),
    (_raise_from_numpy_types, "UFuncTypeError: ufunc 'add' did not contain a loop with signature matching types"),
])
def test_a_bare_library_error_is_an_internal_error_exit_1(capsys, monkeypatch, run, text):
    """Before: exit 2 and 'afferent: error: cannot reshape array ...', as if the input were to blame."""
    monkeypatch.setitem(COMMANDS, "info", _command(run))
    code = main(["info"])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith(f"afferent: internal error (please report): {text}"), err
    assert err.count("\n") == 1


def test_the_packages_own_sentences_stay_exit_2(capsys, monkeypatch):
    monkeypatch.setitem(COMMANDS, "info", _command(lambda args: length_factor("furlong")))
    assert main(["info"]) == 2
    assert capsys.readouterr().err.startswith("afferent: error: 'length_unit' must be a length unit")


def test_raised_on_purpose_tells_afferents_raise_from_a_library_call():
    with pytest.raises(ValueError) as own:
        length_factor("furlong")
    with pytest.raises(ValueError) as numpys:
        np.zeros(3).reshape(2, 2)
    with pytest.raises(ValueError) as wrapped:  # afferent's sentence around a library error: on purpose
        try:
            float("x")
        except ValueError as err:
            raise ValueError("'x' must be a number") from err
    assert raised_on_purpose(own.value) and not raised_on_purpose(numpys.value)
    assert not raised_on_purpose(wrapped.value)  # raised here, in the tests, not in afferent
    assert raised_on_purpose(FileNotFoundError(2, "No such file", "a.csv"))


# ------------------------------------------------------------- item 10 through the CLI
def test_a_scene_nested_too_deeply_is_exit_2_not_an_internal_error(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 3000 + "]" * 3000 + "\n")
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (f"afferent: error: Scene file {str(path)!r} nests arrays or inline tables too "
                                       "deeply to be read; a scene needs at most a list of lists.\n")


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf"])
def test_a_grid_pitch_must_be_a_finite_number_above_0(tmp_path, capsys, value):
    """Before: 0 became the default 0.44 mm in 'afferent run'; nan a message about 'x_range'."""
    for command in ("sample", "run"):
        code = main([command, str(DATA_DIR / "bad" / "ok.csv"), "--grid", "y=0.5", "--pitch-x-mm", value,
                     "--length-unit", "mm", "--sed-unit", "MPa", "-o", str(tmp_path / "out")])
        assert code == 2
        assert capsys.readouterr().err == (f"afferent: error: afferent {command}: argument --pitch-x-mm: must be a "
                                           f"finite number > 0; got {value!r} instead\n")


@pytest.mark.parametrize("argv, flag, kind", [
    (["sample", "E.vtu", "--length-unit", "mm", "--sed-unit", "MPa", "--receptors", "R.csv", "--receptor-unit", "furlong",
      "-o", "out"], "--receptor-unit", "length"),
    (["info", "E.vtu", "--receptors", "R.csv", "--receptor-unit", "inch"], "--receptor-unit", "length"),
    (["info", "E.vtu", "--sed-unit", "kg"], "--sed-unit", "SED/stress"),
    (["info", "E.vtu", "--stress-unit", "bar"], "--stress-unit", "SED/stress"),
    (["info", "E.vtu", "--time-unit", "h"], "--time-unit", "time"),
    (["run", "E.vtu", "--grid", "tips", "--waveform-unit", "ft", "-o", "out"], "--waveform-unit", "length"),
    (["calibrate", "R.csv", "--observed", "O.csv", "--observed-unit", "yd", "-o", "out"], "--observed-unit", "length"),
])
def test_an_unknown_unit_is_named_by_its_own_flag_before_any_file_is_read(tmp_path, capsys, monkeypatch, argv, flag, kind):
    """Before: ``--receptor-unit furlong`` was refused as ``--length-unit must be a length unit``, after reading the export."""
    monkeypatch.chdir(tmp_path)  # none of the files exists: the unit is refused first
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: afferent {argv[0]}: argument {flag}: must be a {kind} unit, one of "), err
    assert f"got {argv[argv.index(flag) + 1]!r} instead." in err and err.count("\n") == 1


def test_a_reader_that_goes_away_stops_the_command_quietly():
    """``afferent info E.vtu | head -0``: before, 'afferent: internal error (please report): BrokenPipeError', exit 1."""
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has gone before afferent writes a byte
    try:
        proc = subprocess.run([sys.executable, "-m", "afferent", "info", str(SAMPLE_DIR / "block4" / "indent_0p88mm.vtu"),
                               "--length-unit", "mm", "--sed-unit", "MPa"], stdout=write_end, stderr=subprocess.PIPE,
                              text=True, timeout=120)
    finally:
        os.close(write_end)
    assert proc.returncode == 141 and proc.stderr == "", (proc.returncode, proc.stderr)


# ------------------------------------------------------------- issue 33, item 13: -q and the doubled prefix
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_subcommand_takes_the_common_quiet_option(command):
    """Before: 'afferent hotspots ... -q' and 'afferent cycles ... -q' were refused ('unrecognized arguments: -q')."""
    import argparse

    from afferent.cli._main import build_parser

    parser = build_parser([command])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    actions = sub.choices[command]._option_string_actions
    assert actions["-q"] is actions["--quiet"] and actions["-q"].help.startswith("nothing on the terminal but errors")


def test_q_means_no_warnings_on_the_terminal_for_every_command(tmp_path, capsys):
    """Before: ``-q`` hid a run's warnings but ``sample``, ``demo``, ``hotspots`` ... printed theirs (issue 37)."""
    from afferent.cli import main

    export = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_sed", "block4",
                          "indent_0p88mm.vtu")
    receptors = tmp_path / "r.csv"
    receptors.write_text("id,x,y,z\n1,0.68,2.45,0.24\n2,90,2.45,0.24\n")  # the second far outside the block
    base = ["sample", export, "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
            "--on-outside", "warn"]
    assert main(base + ["-o", str(tmp_path / "a.csv")]) == 0
    said = capsys.readouterr().err
    assert "afferent: warning: " in said and "outside" in said
    assert main(base + ["-o", str(tmp_path / "b.csv"), "-q"]) == 0
    assert capsys.readouterr().err == ""
    assert main(base + ["-o", str(tmp_path / "c.csv")]) == 0  # -q of one call does not silence the next
    assert "afferent: warning: " in capsys.readouterr().err


@pytest.mark.parametrize("argv, line", [
    (["hotspots", "r1", "-o", "out", "-q", "--bogus"], "afferent: error: afferent hotspots: unrecognized arguments: --bogus"),
    (["cycles", "r1", "-o", "out", "-q", "--bogus"], "afferent: error: afferent cycles: unrecognized arguments: --bogus"),
    (["--bogus"], "afferent: error: unrecognized arguments: --bogus"),
    (["sample"], "afferent: error: afferent sample: the following arguments are required: EXPORT, -o/--output"),
])
def test_a_usage_error_names_the_program_once(tmp_path, capsys, monkeypatch, argv, line):
    """Before: 'afferent: error: afferent: unrecognized arguments: -q --bogus' (the program named twice,
    and -q refused by hotspots and cycles)."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert capsys.readouterr().err == line + "\n"
