"""The command line, in-process through ``main(argv)`` (plus one smoke test of the entry point)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from afferent.cli import main

from conftest import SAMPLE_DIR, linear_sed


@pytest.fixture
def receptors_csv(tmp_path, rng):
    pos = rng.uniform(0.1, 0.6, (7, 3))
    path = tmp_path / "R.csv"
    pd.DataFrame({"id": [f"r{i}" for i in range(7)], "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2]}).to_csv(path, index=False)
    return path, pos


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_sample_writes_long_form_csv(capsys, tmp_path, box_vtu, receptors_csv):
    rpath, pos = receptors_csv
    out = tmp_path / "sed.csv"
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", rpath, "--length-unit", "mm", "--sed-unit", "MPa", "-o", out)
    assert code == 0, err
    df = pd.read_csv(out)
    assert list(df.columns) == ["receptor", "x_m", "y_m", "z_m", "time_s", "sed_pa"]
    np.testing.assert_allclose(df["sed_pa"], linear_sed(pos) * 1e6, rtol=1e-12)
    np.testing.assert_allclose(df[["x_m", "y_m", "z_m"]], pos * 1e-3, rtol=1e-15)


def test_existing_output_is_not_overwritten(capsys, tmp_path, box_vtu, receptors_csv):
    out = tmp_path / "sed.csv"
    out.write_text("precious\n")
    args = ["sample", box_vtu, "--receptors", receptors_csv[0], "--length-unit", "mm", "--sed-unit", "MPa", "-o", out]
    code, _, err = run(capsys, *args)
    assert code == 2
    assert err == f"afferent: error: Output file {str(out)!r} already exists; pass --overwrite to replace it.\n"
    assert out.read_text() == "precious\n"
    code, _, _ = run(capsys, *args, "--overwrite")
    assert code == 0 and out.read_text().startswith("receptor,")


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--sed-unit", "MPa"], "The length unit of the coordinates in SED file"),
        (["--length-unit", "mm", "--sed-unit", "furlong"], "argument --sed-unit: must be a SED/stress unit, one of"),
        (["--length-unit", "mm", "--sed-unit", "MPa", "--sed-column", "SENER"], "has no array or column 'SENER'"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_no_output(capsys, tmp_path, box_vtu, receptors_csv, extra, message):
    out = tmp_path / "never.csv"
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", receptors_csv[0], *extra, "-o", out)
    assert code == 2
    assert err.startswith("afferent: error: ") and message in err and err.count("\n") == 1
    assert "Traceback" not in err
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_receptor_file_errors(capsys, tmp_path, box_vtu):
    bad = tmp_path / "R.csv"
    bad.write_text("a,b,c\n1,2,3\n")
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", bad, "--length-unit", "mm", "--sed-unit", "MPa", "-o", tmp_path / "o.csv")
    assert code == 2
    assert err == (f"afferent: error: Receptor file {str(bad)!r} must have columns 'x', 'y', 'z'; missing 'x', 'y', 'z'. "
                   "Found columns 'a', 'b', 'c'.\n")


def test_receptor_outside_mesh(capsys, tmp_path, box_vtu):
    r = tmp_path / "R.csv"
    r.write_text("x,y,z\n0.5,0.3,0.9\n9,9,9\n")
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", r, "--length-unit", "mm", "--sed-unit", "MPa", "-o", tmp_path / "o.csv")
    assert code == 2 and f"1 of 2 receptors of receptor file {str(r)!r} lie outside the SED field" in err
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", r, "--length-unit", "mm", "--sed-unit", "MPa",
                       "--on-outside", "nan", "-o", tmp_path / "o.csv")
    assert code == 0
    assert pd.read_csv(tmp_path / "o.csv")["sed_pa"].isna().tolist() == [False, True]


def test_info_describes_the_export(capsys, box_vtu):
    code, out, _ = run(capsys, "info", box_vtu)
    assert code == 0
    assert "points       120" in out
    assert "60 volume cells (hexahedron)" in out
    assert "cell data of the same name also present: --location cell" in out
    assert "SED unit     not stated: declare --sed-unit" in out
    # max SED 1.995e-4 (file units) is plausible as MPa only; a 1.9 span as mm only
    assert "plausible for skin (1..1e5 J/m^3) in: MPa" in out
    assert "plausible for a fingertip block (0.5..50 mm) in: mm" in out


def test_usage_errors_are_one_line(capsys):
    code, _, err = run(capsys, "sample")
    assert code == 2 and err.startswith("afferent: error: afferent sample: the following arguments are required")
    code, _, err = run(capsys, "frobnicate")
    assert code == 2 and "invalid choice: 'frobnicate'" in err


def test_entry_point_smoke(tmp_path):
    """The installed console script exists and exits 2 on bad input without a traceback."""
    exe = os.path.join(os.path.dirname(sys.executable), "afferent")
    proc = subprocess.run([exe, "info", str(tmp_path / "missing.vtu")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr == f"afferent: error: SED file {str(tmp_path / 'missing.vtu')!r} not found.\n"


def test_import_is_light():
    """`import afferent` and reading an export never import brian2 or matplotlib."""
    code = ("import sys, time; t=time.perf_counter(); import afferent; dt=time.perf_counter()-t; "
            "import afferent.io, afferent.sampling; "
            "print(dt, 'brian2' in sys.modules, 'matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert float(out[0]) < 0.5
    assert out[1:] == ["False", "False"]


def test_missing_output_folders_are_created(capsys, tmp_path, box_vtu, receptors_csv):
    """A fresh checkout has no results/ folder: outputs create their parent folders."""
    out = tmp_path / "results" / "deep" / "sed.csv"
    code, _, err = run(capsys, "sample", box_vtu, "--receptors", receptors_csv[0], "--length-unit", "mm",
                       "--sed-unit", "MPa", "-o", out)
    assert code == 0, err
    assert out.is_file()


def test_negative_sed_artefacts_in_info_and_one_warning_line(capsys, tmp_path, receptors_csv):
    import meshio

    from conftest import hex_box

    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    sed[4] = -2e-5 * sed.max()
    path = tmp_path / "ccx_like.vtu"
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"ENER": sed}))
    code, out, _ = run(capsys, "info", path)
    assert code == 0
    assert ("negative SED 1 of 27 values (down to -2e-05 x the largest, summing to 1e-06 x the positives); within "
            "the tolerance 0.25: nodal-extrapolation artefacts, read as 0") in out
    code, _, err = run(capsys, "sample", path, "--receptors", receptors_csv[0], "--length-unit", "mm", "--sed-unit", "MPa",
                       "-o", tmp_path / "s.csv")
    assert code == 0, err
    warning = [line for line in err.splitlines() if "are negative (down to" in line]
    assert len(warning) == 1 and warning[0].startswith("afferent: warning: SED file ") and "Warning" not in warning[0]
    code, _, err = run(capsys, "sample", path, "--receptors", receptors_csv[0], "--length-unit", "mm", "--sed-unit", "MPa",
                       "--negative-tolerance", "1e-6", "-o", tmp_path / "s2.csv")
    assert code == 2 and "beyond the tolerance 1e-06." in err and not (tmp_path / "s2.csv").exists()


def test_errors_reached_from_the_cli_name_the_flags_not_python_keywords(capsys, tmp_path, box_vtu, receptors_csv):
    r = receptors_csv[0]
    cases = [
        (["sample", box_vtu, "--receptors", r, "--sed-unit", "MPa", "-o", tmp_path / "a.csv"],
         "is neither stated in the file nor declared; pass --length-unit (e.g. --length-unit mm)."),
        (["sample", box_vtu, "--receptors", r, "--length-unit", "mm", "--sed-from", "equivalent", "-o", tmp_path / "b.csv"],
         "--sed-from equivalent needs Poisson's ratio: pass --poisson NU (the study's skin model uses 0.48)."),
        (["sample", box_vtu, "--receptors", r, "--length-unit", "mm", "--stress-unit", "MPa", "--sed-from", "exact",
          "-o", tmp_path / "c.csv"], "pass --preset one of 'abaqus'"),
        (["sample", box_vtu, "--receptors", r, "--length-unit", "mm", "--sed-unit", "MPa", "--negative-tolerance", "2",
          "-o", tmp_path / "d.csv"], "--negative-tolerance must be a number in [0, 1)"),
    ]
    for argv, expected in cases:
        code, _, err = run(capsys, *argv)
        assert code == 2 and expected in err, err
        assert not re.search(r"(?<![-\w])(length_unit|sed_from|poisson|preset|negative_tolerance)(=|')", err), err


def test_speak_cli_rewrites_only_the_commands_own_options():
    from afferent.cli._main import speak_cli

    flags = {"on_outside": "--on-outside", "length_unit": "--length-unit", "overwrite": "--overwrite",
             "overwrite=True": "--overwrite", "format": "--format"}
    assert speak_cli("Pass on_outside='nan' or on_outside=\"warn\"; pass length_unit=.", flags) == \
        "Pass --on-outside nan or --on-outside warn; pass --length-unit."
    assert speak_cli("'length_unit' is 'm' but ...; pass overwrite=True to replace it; format='csv'.", flags) == \
        "--length-unit is 'm' but ...; pass --overwrite to replace it; --format csv."
    # not an option of this command, or part of a longer word: unchanged
    assert speak_cli("pass time_unit='s'; my_length_unit=3; x.format='a'", flags) == "pass time_unit='s'; my_length_unit=3; x.format='a'"


@pytest.mark.parametrize("umask, file_mode, dir_mode", [(0o022, 0o644, 0o755), (0o027, 0o640, 0o750)])
def test_outputs_honour_the_umask(capsys, tmp_path, box_vtu, receptors_csv, umask, file_mode, dir_mode):
    """Temporary files renamed into place were 0600 and folders 0700 whatever the umask."""
    old = os.umask(umask)
    try:
        out = tmp_path / "sed.csv"
        code, _, err = run(capsys, "sample", box_vtu, "--receptors", receptors_csv[0], "--length-unit", "mm",
                           "--sed-unit", "MPa", "-o", out)
        assert code == 0, err
        assert out.stat().st_mode & 0o777 == file_mode
        folder = tmp_path / "run"
        code, _, err = run(capsys, "run", box_vtu, "--receptors", receptors_csv[0], "--length-unit", "mm",
                           "--sed-unit", "MPa", "--params", "start", "-o", folder)
        assert code == 0, err
        assert folder.stat().st_mode & 0o777 == dir_mode
        for name in ("currents.nc", "run.json", "receptors.vtu", "sed_map.png"):
            assert (folder / name).stat().st_mode & 0o777 == file_mode, name
    finally:
        os.umask(old)


def test_run_options_mirror_the_library_constants_and_parse_only_the_chosen_command():
    """afferent/cli/_run.py spells the choices out so that parsing does not import pandas or scipy; they must
    stay the library's."""
    from afferent.cli import _run
    from afferent.synthesis import SYNTHESES
    from afferent.sampling import METHODS
    from afferent.transduction import STUDY_PARAMS

    assert _run.SYNTHESES == SYNTHESES and _run.METHODS == METHODS and _run.STUDY_ROWS == tuple(STUDY_PARAMS)
    code = ("import sys; from afferent.cli._main import build_parser; build_parser(['run', 'x.toml']); "
            "print(sorted(m for m in ('pandas', 'scipy', 'afferent.cli._calibrate', 'afferent.sampling') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]"


def test_cli_messages_offer_only_remedies_the_command_accepts_in_its_own_flags():
    """Issue 22: 'calibrate' refused the offered --on-outside nan, 'run' --on-outside drop; warnings and the
    calibration status spelt Python keywords (refine=N, method='rsm2', shear='tensor')."""
    from afferent.cli._main import _choices_of, _flags_of, build_parser, speak_cli
    from afferent.profiles import compare_profiles, observed_on

    def words(command):
        argv = [command, "x"]
        parser = build_parser(argv)
        return _flags_of(parser, argv), _choices_of(parser, argv)

    obs = ([1e-3, 2e-3], [0.0, 1.0])
    with pytest.raises(ValueError) as direct:
        observed_on([0.5e-3, 1.5e-3], obs)
    with pytest.raises(ValueError) as compared:
        compare_profiles(np.array([1.0, 2.0]), obs, positions=np.array([0.5e-3, 1.5e-3]))
    assert str(direct.value).endswith("Pass on_outside='nan' to skip them.")
    assert str(compared.value).endswith("Pass on_outside='drop' to skip them.")
    cal, run = words("calibrate"), words("run")
    assert speak_cli(str(compared.value), *cal).endswith("the observation is not extrapolated. Pass --on-outside drop "
                                                         "to skip them.")
    # run's --on-outside (receptors outside the mesh) takes raise, warn, nan: no 'drop' offered there
    said = speak_cli(str(compared.value), *run)
    assert said.endswith("the observation is not extrapolated.") and "on-outside" not in said and "on_outside" not in said
    # the calibration's status and a reader's warning, printed by calibrate / run, in their flags
    from afferent.calibration.rsm import _converged_message

    status = _converged_message(3, 1e-9, 1e-6, 1.0, 0.05, 0, stall_note=True)
    assert "refine=N" in status and "method='rsm2'" in status
    said = speak_cli(status, *cal)
    assert "--refine N (halve the increments up to N times) or --method rsm2 may go further." in said
    assert "pass --shear tensor." in speak_cli("... Check the preset or pass shear='tensor'.", *run)


@pytest.mark.skipif(not (SAMPLE_DIR / "block4" / "indent_0p88mm_tensors.vtu").is_file(), reason="sample not generated")
@pytest.mark.parametrize("command", ["sample", "run"])
def test_warnings_printed_by_the_cli_name_its_flags_not_python_keywords(capsys, tmp_path, command):
    """Issue 22: a reader's warning said "pass shear='engineering'" on the command line."""
    block = SAMPLE_DIR / "block4"
    out = tmp_path / ("sed.csv" if command == "sample" else "run")
    argv = [command, str(block / "indent_0p88mm_tensors.vtu"), "--receptors", str(block / "receptors.csv"),
            "--length-unit", "mm", "--stress-unit", "MPa", "--sed-from", "exact", "--preset", "vtk", "--shear", "tensor",
            "-o", str(out)]  # the tensor convention confirmed (--shear): warned about, not refused (issue 34)
    if command == "run":
        argv += ["--params", "start", "--no-plots", "--no-cache"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "the file's shear strain looks engineering. Check the preset or pass --shear engineering." in err
    assert "shear='" not in err
