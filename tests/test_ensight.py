"""EnSight Gold ``.case`` files (issue 36, item 2) through VTK's reader (the ``vtk`` extra), files from OpenFOAM
1912's foamToEnsight (ASCII and C Binary) and VTK 9.7.2's vtkEnSightWriter (tests/data/ensight/make_ensight.py):
values against those the script wrote; every file the case names through the one resolver."""

from __future__ import annotations

import os
import re
import shutil

import numpy as np
import pytest

from afferent.exceptions import SEDFormatError
from afferent.io import read_raw

pytest.importorskip("vtkmodules")
DATA = os.path.join(os.path.dirname(__file__), "data", "ensight")


@pytest.mark.parametrize("kind", ["openfoam_ascii", "openfoam_binary"])
def test_openfoam_cases_give_the_values_written_and_the_symmetric_tensor_in_vtk_order(kind):
    raw = read_raw(os.path.join(DATA, kind, "foam.case"))
    np.testing.assert_allclose(raw.times, [0.0, 1.0])
    assert raw.points.shape == (36, 3) and raw.cells.n_cells == 12  # the patch part's node copies merged
    i = np.arange(12)
    for k, t in enumerate(raw.times):
        f = (i + 1) * (t + 1)
        np.testing.assert_allclose(raw.arrays["SED"].values[k], i + 1 + 10 * t, rtol=1e-5)
        np.testing.assert_allclose(raw.arrays["D"].values[k], np.column_stack([i, 2 * i, 3 * i]) * (t + 1), rtol=1e-5)
        # OpenFOAM xx xy xz yy yz zz = (1 .. 6) f -> VTK's XX YY ZZ XY YZ XZ
        np.testing.assert_allclose(raw.arrays["sigma"].values[k], np.outer(f, [1, 4, 6, 2, 5, 3]), rtol=1e-5)
    assert len(raw.files) == 1 + 1 + 3 * 2  # case, geometry, 3 variables x 2 steps


def test_vtk_written_case_gives_the_values_written():
    raw = read_raw(os.path.join(DATA, "vtk", "block.0.case"))
    np.testing.assert_allclose(raw.times, [0.0, 1.0, 2.0])  # vtkEnSightWriter writes step numbers as the times
    x, y, z = raw.points.T
    for k, t in enumerate((0.0, 0.5, 1.0)):
        np.testing.assert_allclose(raw.arrays["SED_n"].values[k], (1 + x + 2 * y + 3 * z) * (1 + t), rtol=1e-6)
        np.testing.assert_allclose(raw.arrays["stress_n"].values[k], np.outer(x + 1, np.arange(1.0, 7.0)) * (1 + t),
                                   rtol=1e-6)
    assert raw.cells.n_cells == 14


def test_missing_step_files_are_each_named(tmp_path):
    shutil.copytree(os.path.join(DATA, "openfoam_binary"), tmp_path / "c")
    os.remove(tmp_path / "c" / "data" / "00000001" / "SED")
    os.remove(tmp_path / "c" / "data" / "00000000" / "D")
    case = str(tmp_path / "c" / "foam.case")
    with pytest.raises(FileNotFoundError, match=re.escape(f"SED file {case!r} lists 2 of its 7 geometry and variable "
                                                          "files that do not exist: ")):
        read_raw(case)


def test_a_file_outside_the_folder_is_refused_before_vtk_opens_it(tmp_path):
    shutil.copytree(os.path.join(DATA, "openfoam_binary"), tmp_path / "c")
    case = tmp_path / "c" / "foam.case"
    case.write_text(case.read_text().replace("model:          geometry", "model: ../geometry"))
    shutil.copy(tmp_path / "c" / "geometry", tmp_path / "geometry")
    with pytest.raises(SEDFormatError, match=r"points to the geometry or variable file '../geometry'.*outside the folder"):
        read_raw(str(case))
    assert read_raw(str(case), allow_outside_files=True).cells.n_cells == 12


@pytest.mark.parametrize("edit, message", [
    (("type: ensight gold", "type: something"), "is not an EnSight case file: its FORMAT section must say"),
    (("VARIABLE", "FILE\nfile set: 1\nVARIABLE"), "has a FILE section (file sets, or a server-of-servers case)"),
    (("VARIABLE\n", "VARIABLE\nmeasured: 1 m.geo\n"), "'measured' files are not read by afferent"),
    (("number of steps:        2", "number of steps:        3"), "time set 1 has 3 steps but 2 time values"),
])
def test_case_files_afferent_cannot_list_are_refused(tmp_path, edit, message):
    shutil.copytree(os.path.join(DATA, "openfoam_ascii"), tmp_path / "c")
    case = tmp_path / "c" / "foam.case"
    text = case.read_text()
    assert edit[0] in text
    case.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(SEDFormatError, match=re.escape(message)):
        read_raw(str(case))
