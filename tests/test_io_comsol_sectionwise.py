"""COMSOL Sectionwise data exports (``% Coordinates`` / ``% Elements (tetrahedra)`` / ``% Data (...)``) read with
their mesh by the text-table reader; COMSOL's Grid and vertical point-evaluation layouts refused by name.

tests/data/csv/comsol_sectionwise.txt imitates the layout of real COMSOL sectionwise exports (README there; written
by make_comsol_sectionwise.py beside it from the sample skin block): sampling it must give what sampling the
sample's VTU files gives at the same receptor sites.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from afferent import read_receptors, read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import read_raw

ROOT = Path(__file__).parents[1]
FILE = ROOT / "tests" / "data" / "csv" / "comsol_sectionwise.txt"
BLOCK = ROOT / "sample_sed" / "block4"
TEXT = FILE.read_text()


def _variant(tmp_path: Path, old: str, new: str, count: int = 1, name: str = "variant.txt") -> str:
    """The test file with ``old`` replaced by ``new`` (``count`` times), written to ``tmp_path``."""
    assert old in TEXT
    path = tmp_path / name
    path.write_text(TEXT.replace(old, new, count))
    return str(path)


def _lines(text: str) -> list[str]:
    return text.splitlines(keepends=True)


def test_sectionwise_reads_points_cells_times_and_units():
    raw = read_raw(FILE)
    assert raw.points.shape == (371, 3) and raw.cells.n_cells == 1296 and raw.cells.tetra.shape == (1296, 4)
    assert raw.cells.tetra.min() == 0 and raw.cells.tetra.max() == 370  # 1-based in the file
    np.testing.assert_array_equal(raw.times, [0.5, 1.0])
    assert raw.length_unit == "mm" and list(raw.arrays) == ["solid.Ws"]
    sed = raw.arrays["solid.Ws"]
    assert sed.unit == "J/m^3" and sed.values.shape == (2, 371)
    assert raw.points[0].tolist() == [0.57, 2.2850375939849625, 0.13]  # repr precision read back exactly


def test_sectionwise_samples_like_the_vtu(tmp_path):
    """The sectionwise piece of the sample block gives, at the receptor sites inside it, the SED of the VTUs."""
    table = np.genfromtxt(BLOCK / "receptors.csv", delimiter=",", names=True)
    inside = table[(table["x"] > 0.6) & (table["x"] < 1.2) & (table["z"] > 0.15) & (table["z"] < 0.75)]
    assert len(inside) >= 4
    sites = tmp_path / "sites.csv"
    sites.write_text("id,x,y,z\n" + "".join(f"{int(r['id'])},{r['x']},{r['y']},{r['z']}\n" for r in inside))
    layout = read_receptors(sites, length_unit="mm")
    got = sample_sed(read_sed(FILE), layout)
    vtus = [BLOCK / "indent_0p44mm.vtu", BLOCK / "indent_0p88mm.vtu"]
    want = sample_sed(read_sed(vtus, length_unit="mm", sed_unit="MPa", times=[0.5, 1.0]), layout)
    np.testing.assert_allclose(got.values, want.values, rtol=1e-12, atol=0)
    assert np.ptp(got.values) > 0 and not got.outside.any()


def test_sectionwise_with_commas_and_no_times(tmp_path):
    """Comma-separated rows and an expression without '@ t=' (a stationary study): one step, no times."""
    text = TEXT.split("% Data (solid.Ws (J/m^3) @ t=1)")[0].replace(" @ t=0.5", "")
    text = text.replace("% Expressions:        2", "% Expressions:        1")
    head, body = text.split("% Coordinates\n")
    coords, rest = body.split("% Elements", 1)
    coords = "".join(",".join(line.split()) + "\n" for line in coords.splitlines())
    path = tmp_path / "stationary.txt"
    path.write_text(f"{head}% Coordinates\n{coords}% Elements{rest}")
    raw = read_raw(path)
    assert raw.times is None and raw.arrays["solid.Ws"].values.shape == (1, 371)
    np.testing.assert_array_equal(raw.points, read_raw(FILE).points)


@pytest.mark.parametrize("old, new, match", [
    ("% Data (solid.Ws (J/m^3) @ t=1)\n", "% Data (solid.Ws (J/m^3) @ t=1)\n1.0\n2.0\n",
     r"'% Data \(solid.Ws \(J/m\^3\) @ t=1\)' section .* \(line 2051\) must hold one value for each of the 371 "
     r"points; got 373 instead"),
    ("% Elements (tetrahedra)\n1         ", "% Elements (tetrahedra)\n372       ",
     r"point numbers from 1 to 371 .* got '372 .* at line 383 instead \(1 row out of range\)"),
    ("% Elements (tetrahedra)\n1         ", "% Elements (tetrahedra)\n0         ",
     r"point numbers from 1 to 371 .* at line 383"),
    ("% Elements (tetrahedra)", "% Elements (hexahedra)",
     r"elements of type 'hexahedra' \(line 382\), which afferent cannot read; it reads 'tetrahedra'"),
    ("% Nodes:              371", "% Nodes:              372",
     r"states '% Nodes: 372' \(line 5\) but holds 371 points"),
    ("% Dimension:          3", "% Dimension:          2", r"must be a 3D export .* got '% Dimension: 2'"),
    ("% Expressions:        2", "% Expressions:        3",
     r"states '% Expressions: 3' \(line 7\) but holds 2 data sections; the file is cut short"),
    ("% Data (solid.Ws (J/m^3) @ t=0.5)", "% Results (solid.Ws (J/m^3) @ t=0.5)",
     r"only '% Coordinates', '% Elements \(...\)' and '% Data \(...\)' sections .* got '% Results .* at line 1679"),
])
def test_sectionwise_errors_name_file_line_and_what_arrived(tmp_path, old, new, match):
    with pytest.raises(SEDFormatError, match=match):
        read_raw(_variant(tmp_path, old, new))


def test_sectionwise_cut_short_and_bad_numbers(tmp_path):
    cut = tmp_path / "cut.txt"
    cut.write_text("".join(_lines(TEXT)[:1000]))  # cut inside the elements
    with pytest.raises(SEDFormatError, match=r"states '% Elements: 1296' \(line 6\) but holds 618 elements"):
        read_raw(cut)
    with pytest.raises(SEDFormatError, match=r"must be a number; got '1\.2\.3' at line 11"):
        read_raw(_variant(tmp_path, "0.57                     2.2850375939849625", "1.2.3 2.2850375939849625"))
    with pytest.raises(SEDFormatError, match=r"must hold 4 values; got 3 at line 383"):
        read_raw(_variant(tmp_path, "% Elements (tetrahedra)\n1         ", "% Elements (tetrahedra)\n"))


def test_sectionwise_files_as_time_steps_must_share_the_mesh(tmp_path):
    one = _variant(tmp_path, "% Data (solid.Ws (J/m^3) @ t=1)", "% Data (solid.Ws (J/m^3) @ t=2)", name="a.txt")
    moved = TEXT.replace("0.57                     2.2850375939849625", "0.58                     2.2850375939849625")
    (tmp_path / "b.txt").write_text(moved.replace("@ t=0.5)", "@ t=3)").replace("@ t=1)", "@ t=4)"))
    with pytest.raises(SEDFormatError, match=r"'.*b\.txt' must hold the points and elements of '.*a\.txt'"):
        read_raw([one, str(tmp_path / "b.txt")])
    same = _variant(tmp_path, "@ t=0.5)", "@ t=3)", name="c.txt")
    raw = read_raw([one, same])
    assert raw.points.shape == (371, 3) and raw.arrays["solid.Ws"].values.shape == (4, 371)


GRID = """% Model:              skin.mph
% Version:            COMSOL 6.2.0.290
% Dimension:          3
% Length unit:        mm
% Grid
0 0.5 1
0 0.5 1
0 1
% Data (solid.Ws (J/m^3))
1 2 3
4 5 6
7 8 9
"""
VERTICAL = """% Model:              skin.mph
% Version:            COMSOL 6.2.0.290
% Dimension:          0
% X
0.5
% Y
0.5
% Z
0.2
% solid.Ws (J/m^3)
12.5
"""


@pytest.mark.parametrize("text, layout", [(GRID, "Grid"), (VERTICAL, "the vertical point-evaluation layout")])
def test_grid_and_vertical_layouts_refused_by_name(tmp_path, capsys, text, layout):
    path = tmp_path / "layout.txt"
    path.write_text(text)
    with pytest.raises(SEDFormatError, match=rf"is a COMSOL export in {layout}.*Data format: Spreadsheet"):
        read_raw(path)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: ") and "Traceback" not in err and err.count("\n") == 1


def test_sectionwise_found_when_its_elements_start_after_the_first_megabyte(tmp_path):
    """A real export's coordinates run to megabytes: the '% Elements' title lies beyond the text the reader
    looks at to tell the layouts apart (it then read the file as a table of one 'Coordinates' column)."""
    n_extra = 14_000  # points no element uses, far from the skin: 14k lines of 75 characters
    extra = "".join(f"{100 + k * 1e-3!r:<25}{-50.0!r:<25}{-50.0!r:<25}\n" for k in range(n_extra))
    text = TEXT.replace("% Nodes:              371", f"% Nodes:              {371 + n_extra}")
    text = text.replace("% Elements (tetrahedra)", extra + "% Elements (tetrahedra)")
    parts = text.split("% Data (")
    text = parts[0] + "".join(f"% Data ({p}" + "7.0\n" * n_extra for p in parts[1:])
    path = tmp_path / "big.txt"
    path.write_text(text)
    assert text.index("% Elements (tetrahedra)") > 1_000_000
    raw = read_raw(path)
    assert raw.points.shape == (371 + n_extra, 3) and raw.cells.n_cells == 1296
    np.testing.assert_array_equal(raw.arrays["solid.Ws"].values[:, :371], read_raw(FILE).arrays["solid.Ws"].values)


def test_sectionwise_preamble_errors_give_the_file_line(tmp_path):
    """Blank lines above the preamble count: the wrong count is named at its own line of the file."""
    path = tmp_path / "blank.txt"
    path.write_text("\n\n" + TEXT.replace("% Nodes:              371", "% Nodes:              370"))
    with pytest.raises(SEDFormatError, match=r"states '% Nodes: 370' \(line 7\) but holds 371 points"):
        read_raw(path)
