"""ANSYS MAPDL binary results (.rst), read through ansys-mapdl-reader (the `ansys` extra, part of
the test extra so CI runs these). The file is the real MAPDL result the reader ships
(`ansys.mapdl.reader.examples.rstfile`: 40 SOLID186 hexahedra, a modal analysis, 6 result
sets, material EX = 1.69e7, NUXY = 0.31). References: the reader's own arrays and Hooke's law
for that material.
"""

from __future__ import annotations

import re
import sys
import warnings

import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw
from afferent.strain_energy import sed_exact

reader = pytest.importorskip("ansys.mapdl.reader", reason="the 'ansys' extra (ansys-mapdl-reader) is part of [test]")
RST = reader.examples.rstfile


def _read(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)  # the file is in psi and inches: implausible for skin
        return read_sed(RST, length_unit="m", **kw)


def test_result_sets_mesh_and_components():
    raw = read_raw(RST)
    assert raw.format == "rst" and raw.preset == "ansys" and raw.times.size == 6
    assert raw.cells.cell_types == ("hexahedron",) and raw.cells.n_cells == 40
    assert raw.points.shape == (99, 3)  # MAPDL averages S and EPEL at the corner nodes only: 222 mid-side nodes left out
    assert raw.arrays["S"].components == ("SX", "SY", "SZ", "SXY", "SYZ", "SXZ")
    rst = reader.read_binary(RST)
    nnum, stress = rst.nodal_stress(3)
    ok = np.isfinite(stress).all(axis=1)
    got = raw.arrays["S"].values[3]
    np.testing.assert_allclose(np.sort(got, axis=0), np.sort(stress[ok], axis=0), rtol=0, atol=0)


def test_elastic_strain_shear_is_engineering_by_hookes_law_of_the_files_material():
    raw = read_raw(RST)
    mat = reader.read_binary(RST).materials[1]
    young, nu = mat["EX"], mat["NUXY"]
    lam, g = young * nu / ((1 + nu) * (1 - 2 * nu)), young / (2 * (1 + nu))
    s, e = raw.arrays["S"].values, raw.arrays["EPEL"].values  # X Y Z XY YZ XZ
    scale = np.abs(s).max()
    normal = lam * e[..., :3].sum(-1, keepdims=True) + 2 * g * e[..., :3]
    assert np.abs(normal - s[..., :3]).max() < 1e-7 * scale
    assert np.abs(g * e[..., 3:] - s[..., 3:]).max() < 1e-7 * scale  # engineering: tau = G gamma
    shear_scale = np.abs(s[..., 3:]).max()
    assert np.abs(2 * g * e[..., 3:] - s[..., 3:]).max() > 0.9 * shear_scale  # tensor shear would be off by 2
    field = _read(stress_unit="Pa", sed_from="exact")  # the 'ansys' preset is implied by the file
    shear = field.provenance.checks["shear_convention"]
    assert shear["consistent"] and shear["ratio"] == pytest.approx(1.0, abs=1e-8)
    half = e.copy()
    half[..., 3:] /= 2
    np.testing.assert_allclose(field.sed, sed_exact(s, half), rtol=1e-12)
    with pytest.warns(AfferentWarning, match=re.escape("the file's shear strain looks engineering")):
        read_sed(RST, length_unit="m", stress_unit="Pa", sed_from="exact", shear="tensor")


def test_without_the_extra_the_error_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "ansys.mapdl.reader", None)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {RST!r} is an ANSYS .rst result file; reading it needs the optional extra: "
            "pip install 'afferent-skin[ansys]' (ansys-mapdl-reader).")):
        read_raw(RST)


def test_a_damaged_rst_is_named(tmp_path):
    # the reader's compiled code crashes the interpreter on a truncated file: refused before it
    bad = tmp_path / "cut.rst"
    bad.write_bytes(open(RST, "rb").read()[:5000])
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(bad)!r} is truncated: its header says the file uses 907920 bytes; it has 5000 bytes.")):
        read_raw(bad)
    text = tmp_path / "text.rst"
    text.write_text("x,y,z\n" * 40)
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(text)!r} is not an ANSYS MAPDL binary file")):
        read_raw(text)


def test_info_describes_an_rst(capsys):
    assert main(["info", RST]) == 0
    out = capsys.readouterr().out
    assert "format       rst" in out and "40 volume cells (hexahedron)" in out and "time steps   6" in out
    assert "tensors      stress S; strain EPEL (point data)" in out


def test_a_modal_analysis_is_not_read_as_time_steps():
    raw = read_raw(RST)
    np.testing.assert_array_equal(raw.times, np.arange(6.0))
    assert any("the result sets are not steps in time: a modal (frequencies, Hz) analysis" in n for n in raw.notes)


def _damaged(tmp_path, **words) -> str:
    """The reader's shipped file with some 4-byte words replaced (word index -> value)."""
    data = np.fromfile(RST, "<i4")
    for index, value in words.items():
        data[int(index[1:])] = value
    path = tmp_path / "damaged.rst"
    data.tofile(path)
    return str(path)


def test_a_file_that_crashes_the_readers_compiled_code_is_an_error_naming_the_signal(tmp_path):
    """One word of the element data set to 2**31 - 1 made ansys-mapdl-reader segfault, ending this
    process (found by corrupting the shipped file at random); the file is now read in a child process."""
    bad = _damaged(tmp_path, w77476=2**31 - 1)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {bad!r} could not be read as an ANSYS MAPDL result file: ansys-mapdl-reader's compiled code "
            "crashed on it (signal 11, SIGSEGV")):
        read_raw(bad)
    assert main(["info", bad]) == 2  # and the command line says it in one line


@pytest.mark.parametrize("words, what", [
    ({"w115": 10**7}, "ptrDSI (word 10000000) points outside the file"),
    ({"w116": 5}, "ptrTIM (word 5) points at a record of 20180321 words that does not fit in the file"),
    ({"w192": 320}, "ptrNOD (word 192) points at a record of 320 words that does not end with its length"),
])
def test_records_the_header_points_at_are_checked_before_the_reader_sees_the_file(tmp_path, words, what):
    bad = _damaged(tmp_path, **words)
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {bad!r} is corrupt or truncated: its result "
                                                       f"header's {what} (917504 bytes).")):
        read_raw(bad)
