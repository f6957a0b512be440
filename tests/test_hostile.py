"""The hostile-input corpus (tests/data/bad, written by make_bad.py): every bad file gives exit
code 2, one line ``afferent: error: ...`` naming the file and what is wrong, and leaves no
output; the shapes real exports take (gzip, decimal commas, BOM + CRLF, a long preamble) read.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pandas as pd
import pytest

from afferent.cli import main

from conftest import DATA_DIR

BAD = DATA_DIR / "bad"
ROOT = Path(__file__).resolve().parents[1]
CASES = [
    ("empty.vtu", "SED file {f!r} is empty."),
    ("header_only.csv", "SED file {f!r} has a header but no data rows"),
    ("truncated.vtu", "SED file {f!r} could not be read as .vtu (truncated or corrupt?)"),
    ("corrupt.vtu", "SED file {f!r}: points array 'Points': its header is cut short or corrupt (a truncated file?)"),
    ("binary.csv", "SED file {f!r} must be a text table (CSV, TXT or report); got binary data instead"),
    ("nan_sed.csv", "SED file {f!r}: SED column 'SED' must be finite; got 1 non-finite value(s) (first: NaN at row 3)"),
    ("inf_sed.csv", "SED file {f!r}: SED column 'SED' must be finite; got 1 non-finite value(s) (first: infinite at row 3)"),
    ("negative_sed.csv", "SED file {f!r}: SED must be >= 0 J/m^3 up to the nodal-extrapolation artefacts of FE tools; got 8"),
    ("duplicated_points.csv", "SED file {f!r} lists the point (0, 0, 0) more than once with different SED"),
    ("no_coordinates.csv", "SED file {f!r} must have one x coordinate column"),
    ("nonmonotonic_times.csv", "SED file {f!r}: time steps must be strictly increasing; got 0.2 followed by 0.1"),
    ("duplicated_times.csv", "Every time step of SED file {f!r} must have the same number of rows"),
    ("unknown_unit.csv", "SED file {f!r} states the unit 'furlong-poundals' for SED column 'SED', which afferent does not know"),
    ("element_energy.csv", "SED file {f!r}: column 'ELSE' holds an energy, not an energy density"),
    ("length_mismatch.vtu", "SED file {f!r}: point array 'SED' must have one value per point (NumberOfPoints = 8); got 7 "
                            "instead."),
    ("different_meshes.pvd", "SED file 'step_b.vtu' is not on the same mesh as 'step_a.vtu'"),
    ("corrupt_heavy.xdmf", "SED file {f!r}: the heavy-data file 'corrupt_heavy.h5' could not be opened (truncated or corrupt?)"),
    ("negative_connectivity.vtu", "SED file {f!r}: 'cells' refer to point -2; point indices must be >= 0 (a corrupt "
                                  "connectivity array?)."),
    ("cell_array_long.vtu", "SED file {f!r}: cell array 'E' must have one value per cell (NumberOfCells = 1); got 2 instead."),
    ("complex_heavy.xdmf", "SED file {f!r}: dataset '/sed' of attribute 'SED' at t = 0 in 'complex_heavy.h5' holds complex "
                           "values (complex128); afferent reads real numbers (write the real part)."),
    ("nan_timestep.pvd", "SED file {f!r}: DataSet 1 timestep must be a finite number; got 'nan' instead."),
    ("truncated.xplt", "SED file {f!r}: state 2 (chunk 0x02000000) declares 13388 bytes but the file ends after 13288: "
                       "truncated .xplt (was FEBio still writing it?)."),
]


def _cli(capsys, *argv):
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


@pytest.fixture
def corpus(tmp_path, monkeypatch):
    """A copy of the corpus to run in (messages name files relative to it; outputs land beside)."""
    folder = tmp_path / "bad"
    shutil.copytree(BAD, folder)
    monkeypatch.chdir(folder)
    return folder


def _nothing_left(folder, before):
    return sorted(p.name for p in folder.iterdir()) == before


@pytest.mark.parametrize("name, message", CASES, ids=[c[0] for c in CASES])
def test_a_bad_export_is_one_line_exit_2_and_leaves_nothing(capsys, corpus, name, message):
    before = sorted(p.name for p in corpus.iterdir())
    code, err = _cli(capsys, "sample", name, "--receptors", "receptors_ok.csv", "--length-unit", "mm", "--sed-unit", "MPa",
                     "-o", "out.csv")
    assert code == 2 and err.count("\n") == 1 and err.startswith("afferent: error: "), err
    assert message.format(f=name) in err, err
    assert _nothing_left(corpus, before)


def test_bad_receptor_files_and_scenes(capsys, corpus):
    before = sorted(p.name for p in corpus.iterdir())
    code, err = _cli(capsys, "sample", "ok.csv", "--receptors", "receptors_text.csv", "--length-unit", "mm", "--sed-unit",
                     "MPa", "-o", "out.csv")
    assert (code, err) == (2, "afferent: error: Receptor file 'receptors_text.csv': column 'y' must hold finite numbers; "
                              "got 'n/a' on data row 2 instead.\n")
    code, err = _cli(capsys, "sample", "ok.csv", "--receptors", "receptors_outside.csv", "--length-unit", "mm", "--sed-unit",
                     "MPa", "-o", "out.csv")
    assert code == 2 and "1 of 2 receptors of receptor file 'receptors_outside.csv' lie outside the SED field" in err
    code, err = _cli(capsys, "run", "scene_wrong_types.toml", "-o", "out")
    assert code == 2 and err.endswith("scene_wrong_types.toml', line 8: [sampling] 'method' must be a string, one of "
                                      "'linear', 'nearest'; got 3 (an integer) instead.\n"), err
    assert _nothing_left(corpus, before)


@pytest.mark.parametrize("name", ["good_gzip.csv.gz", "good_decimal_comma.csv", "good_bom_crlf.csv", "good_long_preamble.csv"])
def test_the_shapes_real_exports_take_read_like_the_plain_table(capsys, corpus, name):
    code, err = _cli(capsys, "sample", "ok.csv", "--receptors", "receptors_ok.csv", "--length-unit", "mm", "--sed-unit", "MPa",
                     "-o", "plain.csv")
    assert code == 0, err
    code, err = _cli(capsys, "sample", name, "--receptors", "receptors_ok.csv", "--length-unit", "mm", "--sed-unit", "MPa",
                     "-o", "shaped.csv")
    assert code == 0, err
    pd.testing.assert_frame_equal(pd.read_csv("shaped.csv"), pd.read_csv("plain.csv"))


def test_an_all_zero_sed_field_warns(capsys, corpus):
    code, err = _cli(capsys, "sample", "all_zero.csv", "--receptors", "receptors_ok.csv", "--length-unit", "mm",
                     "--sed-unit", "MPa", "-o", "out.csv")
    assert code == 0, err
    assert ("afferent: warning: SED file 'all_zero.csv' (MPa declared): every SED value is 0 J/m^3 (8 values): the wrong "
            "column, or the undeformed state exported? The currents and spikes computed from it are zero.") in err, err


def test_a_corrupt_component_count_is_skipped_in_seconds_with_one_warning_line(corpus):
    """Before: NumberOfComponents="9999999999" made afferent loop 1e10 times over component names
    (a hang), and meshio's own two-line 'Warning: VTU file corrupt' went to stderr as it was."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "afferent", "sample", "huge_component_count.vtu", "--receptors",
                           "receptors_ok.csv", "--length-unit", "mm", "--sed-unit", "MPa", "-o", "out.csv"],
                          capture_output=True, text=True, timeout=120, cwd=corpus,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.startswith("afferent: warning: SED file 'huge_component_count.vtu': meshio: Warning: VTU file "
                                  "corrupt. The size of the data array 'E' is 48 which doesn't fit the number of "
                                  "components 9999999999. Skipping.\nwrote out.csv: "), proc.stderr
    assert proc.stderr.count("\n") == 2
