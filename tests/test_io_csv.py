"""Tests of :func:`afferent.io._csv.read_csv` (text tables -> RawExport).

Reference files live in ``tests/data/csv/`` (see its README: synthetic files following the
layouts documented in docs/fe-export.md, not real tool output). Values are compared exactly:
the reader must hand back the decimal numbers of the file correctly rounded to float64,
so any loss of precision shows (``assert_array_equal`` treats NaN as equal to NaN).
"""

from __future__ import annotations

import gzip
import os
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from afferent.exceptions import SEDFormatError
from afferent.io._csv import read_csv
from afferent.io._raw import RawExport

DATA = Path(__file__).parent / "data" / "csv"
nan = float("nan")


def _path(name: str) -> str:
    return str(DATA / name)


# --------------------------------------------------------------------------------------
# Reference layouts: columns, shapes, units, times and values, exactly as in the files
# --------------------------------------------------------------------------------------

LAYOUTS = {
    "comsol_spreadsheet.csv": dict(
        names=["x", "y", "z", "solid.Ws", "solid.mises"],
        units={"x": None, "y": None, "z": None, "solid.Ws": "J/m^3", "solid.mises": "N/m^2"},
        shape=(1, 4), times=None, length_unit="mm", time_unit=None,
        values={
            "z": [[0.30000000000000004, -0.25, 3.0, -0.3]],
            "solid.Ws": [[12.333333333333334, 0.0033333333333333335, 1.2345678901234567e-05, nan]],
            "solid.mises": [[3141.5926535897934, nan, 2718.281828459045, 1618.0339887498949]],
        },
        notes=["detected delimiter: comma ','", "column names taken from the comment line 9",
               "skipped 8 comment or preamble lines above the header (line 9)"],
    ),
    "comsol_semicolon.csv": dict(
        names=["x", "y", "z", "solid.Ws"],
        units={"x": None, "solid.Ws": "J/m^3"},
        shape=(1, 3), times=None, length_unit="m", time_unit=None,
        values={
            "y": [[0.002, 0.0025, 0.0012345678901234567]],
            "solid.Ws": [[0.1111111111111111, 0.2222222222222222, 0.3333333333333333]],
        },
        notes=["detected delimiter: semicolon ';'"],
    ),
    "comsol_time_suffix.csv": dict(
        names=["x", "y", "z", "solid.Ws", "solid.mises"],
        units={"x": None, "solid.Ws": "J/m^3", "solid.mises": "Pa"},
        shape=(3, 3), times=[0.0, 0.05, 0.1], length_unit="mm", time_unit=None,
        values={
            "x": [[0.1, 0.4, 0.7]] * 3,
            "solid.Ws": [[0.0, 0.0, 0.0],
                         [0.14285714285714285, 0.07692307692307693, 0.058823529411764705],
                         [0.2857142857142857, 0.15384615384615385, 0.11764705882352941]],
            "solid.mises": [[0.0, 0.0, 0.0],
                            [11.11111111111111, 33.333333333333336, 44.44444444444444],
                            [22.22222222222222, 66.66666666666667, 88.88888888888889]],
        },
        notes=["stacked '@ t=' columns into 3 time steps",
               "columns without an '@ t=' suffix ('x', 'y', 'z') are repeated for every step"],
    ),
    "abaqus_sener.rpt": dict(
        names=["Node Label", "SENER"],
        units={"Node Label": None, "SENER": None},
        shape=(1, 5), times=[1.0], length_unit=None, time_unit=None,
        values={
            "Node Label": [[1.0, 2.0, 3.0, 4.0, 5.0]],
            "SENER": [[1.23456789e-03, 3.33333333e-04, 7.14285714e-05, 9.09090909e-04, 1.11111111e-04]],
        },
        notes=["detected delimiter: runs of whitespace",
               "skipped 10 comment or preamble lines above the header (line 17)",
               "the report holds Nodal values (line 11)",
               "read the report's frame (step 'Indent'): 'Increment     20: Step Time =    1.000' (line 9); times are "
               "their 'Step Time'",
               "dropped 10 footer rows (Minimum/Maximum/At Node/At Element/Int Pt/Total)",
               "joined 2 report blocks with identical columns",
               "removed Abaqus position qualifiers ('@Loc N') from column names"],
    ),
    "abaqus_tensors.rpt": dict(
        names=["Element Label", "Int Pt", "S.S11", "S.S22", "S.S33", "S.S12", "S.S13", "S.S23",
               "LE.LE11", "LE.LE22", "LE.LE33", "LE.LE12", "LE.LE13", "LE.LE23"],
        units={"S.S11": None},
        shape=(1, 3), times=[1.0], length_unit=None, time_unit=None,
        values={
            "Element Label": [[1.0, 1.0, 2.0]],
            "Int Pt": [[1.0, 2.0, 1.0]],
            "S.S11": [[-4.56789012e-02, -4.44444444e-02, -3.14159265e-02]],
            "S.S23": [[7.77777778e-05, 7.07070707e-05, 6.18033989e-04]],
            "LE.LE12": [[-9.09090909e-04, -8.26446281e-04, -1.04719755e-03]],
            "LE.LE23": [[-3.63636364e-05, -3.30578512e-05, -4.18879020e-05]],
        },
        notes=["dropped 4 footer rows (Minimum/Maximum/At Node/At Element/Int Pt/Total)"],
    ),
    "abaqus_frames.rpt": dict(
        names=["Node Label", "COORD.COOR1", "COORD.COOR2", "COORD.COOR3", "SENER", "Part"],
        units={"SENER": None, "COORD.COOR1": None},
        shape=(2, 6), times=[0.5, 1.0], length_unit=None, time_unit=None,
        values={
            "Node Label": [[1.0, 2.0, 3.0, 4.0, 1.0, 2.0]] * 2,
            "Part": [[0.0, 0.0, 0.0, 0.0, 1.0, 1.0]] * 2,  # labels repeat across the parts: a row is (part, label)
            "COORD.COOR1": [[0.0, 1.0, 0.0, 1.0, 0.0, 0.5]] * 2,
            "COORD.COOR3": [[-1.0, -1.0, -1.0, -1.0, 0.0, -0.0]] * 2,
            "SENER": [[100e-6, 200e-6, 300e-6, 1.11111e-3, 33.3333e-6, 2.5e-3],
                      [400e-6, 800e-6, 1.2e-3, 4.44444e-3, 133.333e-6, 10e-3]],
        },
        notes=["read the report's 2 frames as time steps of 6 rows (step 'Indent'): 'Increment      5: Step Time =    "
               "0.5000' (line 9); 'Increment     10: Step Time =     1.000' (line 57); times are their 'Step Time'",
               "dropped 16 footer rows (Minimum/Maximum/At Node/At Element/Int Pt/Total)",
               "joined 2 report blocks with identical columns in each frame",
               "removed Abaqus position qualifiers ('@Loc N') from column names"],
    ),
    "abaqus_wrapped.rpt": dict(
        names=["Element Label", "Int Pt", "COORD.COOR1", "COORD.COOR2", "COORD.COOR3", "SENER",
               "S.S11", "S.S22", "S.S33", "S.S12", "S.S13", "S.S23"],
        units={"SENER": None},
        shape=(1, 4), times=[1.0], length_unit=None, time_unit=None,
        values={
            "Element Label": [[1.0, 1.0, 2.0, 2.0]],
            "Int Pt": [[1.0, 2.0, 1.0, 2.0]],
            "COORD.COOR1": [[211.325e-3, 788.675e-3, 1.21132, 1.78868]],
            "SENER": [[1.5e-3, 2.5e-3, 750e-6, 333.333e-6]],
            "S.S11": [[-3e-3, -4e-3, -2e-3, -1e-3]],
            "S.S13": [[-250e-6, -0.0, 250e-6, 0.0]],
            "S.S23": [[125e-6, 62.5e-6, 0.0, -15.625e-6]],
        },
        notes=["joined each record's 2 lines of a wrapped table (6 + 6 values; column titles in 2 parts)",
               "the report holds Integration point values (line 11): one row per element integration point: they are "
               "points only with COORD at the integration points in the report, or with coordinates= element "
               "centroids (rows averaged per element)",
               "dropped 6 footer rows (Minimum/Maximum/At Node/At Element/Int Pt/Total)"],
    ),
    "workbench_tab.txt": dict(
        names=["Node Number", "X Location", "Y Location", "Z Location", "Equivalent Stress",
               "Strain Energy Density"],
        units={"Node Number": None, "X Location": "mm", "Y Location": "mm", "Z Location": "mm",
               "Equivalent Stress": "MPa", "Strain Energy Density": "MPa"},
        shape=(1, 3), times=None, length_unit="mm", time_unit=None,
        values={
            "Node Number": [[1.0, 2.0, 7.0]],
            "Y Location": [[1.2, 1.4142135623730951, 0.0]],
            "Equivalent Stress": [[0.33333333333333331, 0.66666666666666663, 1.0]],
            "Strain Energy Density": [[5.6e-004, 1.2345678901234567e-003, 0.00011111111111111112]],
        },
        notes=["detected delimiter: tab"],
    ),
    "febio_log.txt": dict(
        names=["id", "sed", "sx"],
        units={"id": None, "sed": None, "sx": None},
        shape=(3, 3), times=[0.1, 0.2, 0.30000000000000004], length_unit=None, time_unit=None,
        values={
            "id": [[1.0, 2.0, 3.0]] * 3,
            "sed": [[0.00033333333333333332, 0.00016666666666666666, 0.0],
                    [0.0013333333333333333, 0.00066666666666666664, 1.1111111111111112e-05],
                    [0.003, 0.0015, 4.4444444444444447e-05]],
            "sx": [[-0.014285714285714285, -0.0071428571428571426, 0.0],
                   [-0.02857142857142857, -0.014285714285714285, -0.0033333333333333335],
                   [-0.04285714285714286, -0.02142857142857143, -0.006666666666666667]],
        },
        notes=["read 3 FEBio logfile records ('*Step') as time steps"],
    ),
    "calculix_blocks.dat": dict(
        names=["elem", "integ.pnt.", "sxx", "syy", "szz", "sxy", "sxz", "syz", "internal energy density"],
        units={"sxx": None, "internal energy density": None},
        shape=(2, 3), times=[0.5, 1.0], length_unit=None, time_unit=None,
        values={
            "elem": [[1.0, 1.0, 2.0]] * 2,
            "integ.pnt.": [[1.0, 2.0, 1.0]] * 2,
            "sxx": [[-6.172835e-01, -5.555556e-01, -4.545455e-01], [-1.234567e+00, -1.111111e+00, -9.090909e-01]],
            "syz": [[3.333333e-04, 2.941176e-04, 2.631579e-04], [6.666667e-04, 5.882353e-04, 5.263158e-04]],
            "internal energy density": [[3.086420e-05, 2.777778e-05, 2.272727e-05],
                                        [1.234568e-04, 1.111111e-04, 9.090909e-05]],
        },
        notes=["read 4 CalculiX blocks ('stresses', 'internal energy density') at 2 times",
               "named the value column 'energy' of the CalculiX block 'internal energy density' after the block"],
    ),
    "plain_time.csv": dict(
        names=["x", "y", "z", "sed"],
        units={"x": None, "sed": None},
        shape=(3, 2), times=[0.0, 0.05, 0.1], length_unit=None, time_unit=None,
        values={
            "x": [[0.1, 0.4]] * 3,
            "sed": [[0.0, 0.0], [0.14285714285714285, 0.07692307692307693],
                    [0.2857142857142857, 0.15384615384615385]],
        },
        notes=["grouped rows by the time column 'time' into 3 time steps of 2 rows"],
    ),
    "hash_whitespace.txt": dict(
        names=["x", "y", "z", "sed"],
        units={"x": None, "sed": None},
        shape=(1, 3), times=None, length_unit=None, time_unit=None,
        values={
            "z": [[0.3, 0.6, -0.9]],
            "sed": [[0.1111111111111111, 0.2222222222222222, 3.3333333333333335e-07]],
        },
        notes=["detected delimiter: runs of whitespace",
               "skipped 2 comment or preamble lines above the header (line 3)",
               "skipped 1 comment or rule line among the data rows"],
    ),
    "units_row.csv": dict(
        names=["x", "y", "z", "sed"],
        units={"x": "mm", "y": "mm", "z": "mm", "sed": "kPa"},
        shape=(1, 2), times=None, length_unit="mm", time_unit=None,
        values={"sed": [[0.14285714285714285, 0.07692307692307693]], "z": [[0.3, 0.6]]},
        notes=["units taken from the units row (line 3)",
               "skipped 1 comment or preamble line above the header (line 2)"],
    ),
    "label_column.csv": dict(
        names=["part", "x", "y", "z", "sed"],
        units={"sed": None},
        shape=(1, 3), times=None, length_unit=None, time_unit=None,
        values={"sed": [[0.1111111111111111, 0.2222222222222222, 0.3333333333333333]], "part": [[0.0, 0.0, 1.0]]},
        notes=["column 'part' numbers the rows' part instances: 0 = 'SKIN-1', 1 = 'BONE-1'"],
    ),
    "gzipped.dat": dict(
        names=["x", "y", "z", "sed"],
        units={"sed": None},
        shape=(3, 2), times=[0.0, 0.05, 0.1], length_unit=None, time_unit=None,
        values={"sed": [[0.0, 0.0], [0.14285714285714285, 0.07692307692307693],
                        [0.2857142857142857, 0.15384615384615385]]},
        notes=["decompressed gzip data"],
    ),
}


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_layout_reads_exactly(name):
    exp = LAYOUTS[name]
    raw = read_csv(_path(name))
    assert isinstance(raw, RawExport)
    assert raw.format == "csv"
    assert raw.files == (_path(name),)
    assert raw.points is None and raw.cells is None
    assert list(raw.arrays) == exp["names"]
    for col, arr in raw.arrays.items():
        assert arr.name == col
        assert arr.location == "point"
        assert arr.values.dtype == np.float64
        assert arr.values.shape == exp["shape"], col
    for col, unit in exp["units"].items():
        assert raw.arrays[col].unit == unit, col
    for col, values in exp["values"].items():
        # exact: decimal text -> float64 must be correctly rounded
        np.testing.assert_array_equal(raw.arrays[col].values, np.array(values, dtype=np.float64))
    if exp["times"] is None:
        assert raw.times is None
    else:
        np.testing.assert_array_equal(raw.times, np.array(exp["times"]))
    assert raw.n_times == exp["shape"][0]
    assert raw.length_unit == exp["length_unit"]
    assert raw.time_unit == exp["time_unit"]
    for note in exp["notes"]:
        assert note in raw.notes


def test_step_files_are_stacked_in_the_given_order():
    files = [_path(f"steps/step_00{k}.csv") for k in (0, 1, 2)]
    raw = read_csv(files)
    assert raw.files == tuple(files)
    assert list(raw.arrays) == ["x", "y", "z", "sed"]
    assert raw.times is None
    np.testing.assert_array_equal(
        raw.arrays["sed"].values,
        [[0.0, 0.0], [0.14285714285714285, 0.07692307692307693], [0.2857142857142857, 0.15384615384615385]],
    )
    np.testing.assert_array_equal(raw.arrays["x"].values, [[0.1, 0.4]] * 3)
    assert "all 3 files: detected delimiter: comma ','" in raw.notes
    assert "stacked 3 files along time" in raw.notes
    # reversed order gives reversed steps
    back = read_csv(files[::-1])
    np.testing.assert_array_equal(back.arrays["sed"].values, raw.arrays["sed"].values[::-1])


def test_path_objects_and_single_item_list():
    a = read_csv(DATA / "plain_time.csv")
    b = read_csv([DATA / "plain_time.csv"])
    np.testing.assert_array_equal(a.arrays["sed"].values, b.arrays["sed"].values)


# --------------------------------------------------------------------------------------
# Reference bad files: each raises, message pinned
# --------------------------------------------------------------------------------------

BAD = {
    "bad_empty.csv": "SED file {p!r} is empty: it must hold a header row and data rows; got 0 bytes instead.",
    "bad_only_comments.csv": (
        "SED file {p!r} is empty: it must hold a header row and data rows; got only 3 comment lines instead."
    ),
    "bad_header_only.csv": (
        "SED file {p!r} has a header but no data rows: it must hold rows of numbers below its header row; "
        "got only a header row (line 1) instead."
    ),
    "bad_no_header.csv": (
        "SED file {p!r} must have a header row naming its 4 columns above the first data row (line 1); "
        "got none instead."
    ),
    "bad_column_count.csv": (
        "Line 3 of SED file {p!r} must have 4 values, one per column of the header (line 1); got 3 instead."
    ),
    "bad_column_count_ws.txt": (
        "Line 4 of SED file {p!r} must have 4 values, one per column of the header (line 2); got 5 instead."
    ),
    "bad_cell.csv": "Column 'sed' of SED file {p!r} must hold numbers; got '0.333.3333' at line 4 instead.",
    "bad_duplicate.csv": (
        "Column names of SED file {p!r} must be unique once units are removed; got 'sed (MPa)' and "
        "'sed (Pa)' (both 'sed') instead."
    ),
    "bad_time_groups.csv": (
        "Every time step of SED file {p!r} must have the same number of rows; got 2 rows at time = 0.0, "
        "1 row at time = 0.1 instead."
    ),
    "bad_coord_units.txt": (
        "Coordinate columns of SED file {p!r} must share one length unit; got 'X Location' in 'mm', "
        "'Y Location' in 'm', 'Z Location' in 'mm' instead."
    ),
    "bad_binary.csv": (
        "SED file {p!r} must be a text table (CSV, TXT or report); got binary data instead "
        "(first bytes b'\\x89PNG\\r\\n\\x1a\\n')."
    ),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_file_raises_with_pinned_message(name):
    p = _path(name)
    with pytest.raises(SEDFormatError, match=re.escape(BAD[name].format(p=p))):
        read_csv(p)


def test_missing_file():
    p = _path("no_such_file.csv")
    with pytest.raises(FileNotFoundError, match=re.escape(f"SED file {p!r} not found.")):
        read_csv(p)


def test_step_files_with_different_row_counts():
    a, b = _path("bad_steps/step_000.csv"), _path("bad_steps/step_001.csv")
    msg = f"SED file {b!r} must have 2 rows per time step like {a!r}; got 3 instead."
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv([a, b])


# --------------------------------------------------------------------------------------
# Smaller cases built in tmp_path
# --------------------------------------------------------------------------------------


def _write(tmp_path, text: str, name: str = "t.csv", *, raw: bytes | None = None) -> str:
    p = tmp_path / name
    p.write_bytes(raw if raw is not None else text.encode("utf-8"))
    return str(p)


def test_step_files_with_different_columns(tmp_path):
    a = _write(tmp_path, "x,y,z,sed\n0.1,0.2,0.3,0.5\n", "a.csv")
    b = _write(tmp_path, "x,y,z,SENER\n0.1,0.2,0.3,0.5\n", "b.csv")
    msg = (f"SED file {b!r} must have the same columns as {a!r} ('x', 'y', 'z', 'sed'); "
           f"got no column 'sed' and an extra column 'SENER' instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv([a, b])


def test_step_files_with_times_are_concatenated(tmp_path):
    a = _write(tmp_path, "t,x,sed\n0.5,0.1,0.25\n0.5,0.2,0.5\n", "a.csv")
    b = _write(tmp_path, "t,x,sed\n1.5,0.1,0.75\n1.5,0.2,1.0\n", "b.csv")
    raw = read_csv([a, b])
    np.testing.assert_array_equal(raw.times, [0.5, 1.5])
    np.testing.assert_array_equal(raw.arrays["sed"].values, [[0.25, 0.5], [0.75, 1.0]])


def test_step_files_mixing_times_and_none(tmp_path):
    a = _write(tmp_path, "x,sed @ t=0.5\n0.1,0.25\n", "a.csv")
    b = _write(tmp_path, "x,sed\n0.1,0.75\n", "b.csv")
    msg = f"SED file {b!r} must state its times like {a!r} does; got no time column, '@ t=' suffix or '*Time' instead."
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv([a, b])


def test_time_column_interleaved_rows_keep_file_order(tmp_path):
    p = _write(tmp_path, "x,time (ms),sed\n1,0.2,10\n2,0.1,20\n3,0.2,30\n4,0.1,40\n")
    raw = read_csv(p)
    np.testing.assert_array_equal(raw.times, [0.2, 0.1])  # order of first appearance
    np.testing.assert_array_equal(raw.arrays["x"].values, [[1, 3], [2, 4]])
    np.testing.assert_array_equal(raw.arrays["sed"].values, [[10, 30], [20, 40]])
    assert raw.time_unit == "ms"
    assert "time" not in raw.arrays


def test_time_column_argument(tmp_path):
    p = _write(tmp_path, "frame,x,sed\n1,0.1,0.5\n2,0.1,0.75\n")
    raw = read_csv(p, time_column="frame")
    np.testing.assert_array_equal(raw.times, [1.0, 2.0])
    assert list(raw.arrays) == ["x", "sed"]
    msg = f"SED file {p!r} has no column 'frames'. Found columns 'frame', 'x', 'sed'. Did you mean 'frame'?"
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p, time_column="frames")


def test_two_time_columns_are_ambiguous(tmp_path):
    p = _write(tmp_path, "Step Time,Total Time,sed\n0.5,1.5,0.25\n")
    msg = (f"SED file {p!r} must have at most one time column; got 'Step Time', 'Total Time' instead. "
           f"Pass time_column='Step Time' to pick one.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)
    raw = read_csv(p, time_column="Total Time")
    np.testing.assert_array_equal(raw.times, [1.5])


def test_temperature_named_t_is_not_a_time(tmp_path):
    p = _write(tmp_path, "x,T (K),sed\n0.1,310.15,0.5\n0.2,310.25,0.75\n")
    raw = read_csv(p)
    assert raw.times is None
    assert raw.arrays["T"].unit == "K"
    assert "column 'T (K)' is named like a time but its unit 'K' is not a time unit; read as data" in raw.notes


def test_time_column_nan(tmp_path):
    p = _write(tmp_path, "time,sed\n0.1,0.5\n,0.75\n")
    msg = (f"Time column 'time' of SED file {p!r} must hold a time on every row; got an empty or NaN cell "
           f"at line 3 instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_suffix_columns_with_different_times(tmp_path):
    p = _write(tmp_path, "% x,a @ t=0,a @ t=1,b @ t=0,b @ t=2\n0.5,1,2,3,4\n")
    msg = (f"Every '@ t=' column group of SED file {p!r} must cover the same times; got 'a' at t = [0.0, 1.0] "
           f"and 'b' at t = [0.0, 2.0] instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_time_column_and_suffix_together(tmp_path):
    p = _write(tmp_path, "time,a @ t=0\n0.5,1\n")
    msg = f"SED file {p!r} must give its times either in a time column or in '@ t=' column suffixes"
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_unknown_unit_is_kept_as_written(tmp_path):
    p = _write(tmp_path, "x (furlong),sed (J/m3),e (1)\n0.1,0.5,0.001\n")
    raw = read_csv(p)
    assert raw.arrays["x"].unit == "furlong"
    assert raw.arrays["sed"].unit == "J/m^3"  # canonical spelling from afferent.units.parse_unit
    assert raw.arrays["e"].unit == "1"
    assert raw.length_unit == "furlong"
    assert "unit 'furlong' of column 'x' is not a unit afferent knows; kept as written" in raw.notes


def test_comsol_length_unit_disagrees_with_columns(tmp_path):
    p = _write(tmp_path, "% Length unit,mm\n% x (m),y,sed\n0.1,0.2,0.5\n")
    msg = (f"Coordinate columns of SED file {p!r} must share one length unit; got "
           f"'% Length unit (line 1)' in 'mm', 'x' in 'm' instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_comsol_txt_layout(tmp_path):
    """COMSOL .txt export: ``% Key:  value`` lines, space-aligned columns ([UNVERIFIED] layout)."""
    text = (
        "% Model:              fingertip.mph\n"
        "% Length unit:        mm\n"
        "% x                   y                   solid.Ws (J/m^3) @ t=0    solid.Ws (J/m^3) @ t=0.5\n"
        "0.1                   0.2                 0.3333333333333333        0.6666666666666666\n"
        "0.4                   0.5                 NaN                       1.3333333333333333\n"
    )
    raw = read_csv(_write(tmp_path, text, "a.txt"))
    assert raw.length_unit == "mm"
    assert list(raw.arrays) == ["x", "y", "solid.Ws"]
    np.testing.assert_array_equal(raw.times, [0.0, 0.5])
    np.testing.assert_array_equal(
        raw.arrays["solid.Ws"].values, [[0.3333333333333333, nan], [0.6666666666666666, 1.3333333333333333]]
    )


def test_plain_and_suffixed_column_collide(tmp_path):
    p = _write(tmp_path, "% x,sed (Pa),sed (Pa) @ t=1\n0.1,0.2,0.3\n")
    msg = (f"Column names of SED file {p!r} must be unique once units are removed; got 'sed (Pa)' and "
           f"'sed (Pa) @ t=1' (both 'sed') instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_comment_line_header_in_whitespace_file(tmp_path):
    p = _write(tmp_path, "# x y z sed\n0.1 0.2 0.3 0.5\n0.4 0.5 0.6 0.75\n", "a.txt")
    raw = read_csv(p)
    assert list(raw.arrays) == ["x", "y", "z", "sed"]
    assert "column names taken from the comment line 1" in raw.notes


def test_quoted_headers_and_trailing_delimiter(tmp_path):
    p = _write(tmp_path, '"x","y","sed (MPa)"\n0.1,0.2,0.5,\n0.3,0.4,0.75,\n')
    raw = read_csv(p)
    assert list(raw.arrays) == ["x", "y", "sed"]
    assert raw.arrays["sed"].unit == "MPa"
    assert "dropped unnamed empty column 4 (trailing delimiter)" in raw.notes


def test_units_row_in_brackets_whitespace(tmp_path):
    raw = read_csv(_write(tmp_path, "x y sed\n[mm] [mm] [MPa]\n0.1 0.2 0.3\n", "a.txt"))
    assert {k: a.unit for k, a in raw.arrays.items()} == {"x": "mm", "y": "mm", "sed": "MPa"}


def test_units_row_contradicting_the_name(tmp_path):
    p = _write(tmp_path, "x (mm),y,sed\nm,mm,MPa\n0.1,0.2,0.3\n")
    msg = (f"Column 'x' of SED file {p!r} must state one unit; got 'mm' in its name and 'm' in the units "
           f"row (line 2) instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_pandas_index_column_is_dropped(tmp_path):
    raw = read_csv(_write(tmp_path, ",x,sed\n0,0.1,0.5\n1,0.2,0.6\n"))
    assert list(raw.arrays) == ["x", "sed"]
    assert "dropped unnamed first column 0, 1, 2, ... (a pandas index)" in raw.notes


def test_unnamed_data_column(tmp_path):
    p = _write(tmp_path, "x,,sed\n0.1,7,0.5\n")
    msg = f"The header row (line 1) of SED file {p!r} must name every column; got an empty name for column 2 instead."
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_empty_and_nan_cells_are_kept(tmp_path):
    p = _write(tmp_path, "x;y;sed\n0.1;0.2;\n0.3;0.4;NaN\n0.5;0.6;0.7\n")
    raw = read_csv(p)
    np.testing.assert_array_equal(raw.arrays["sed"].values, [[nan, nan, 0.7]])


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_decimal_commas_are_read_where_the_delimiter_leaves_no_doubt(tmp_path, sep):
    # European exports (Excel, COMSOL with a comma locale): decimal commas with ';', tab or spaces
    p = _write(tmp_path, f"x{sep}y{sep}sed\n0,1{sep}1,5e-3{sep}0,5\n0,2{sep}-2,25{sep}0,75\n# 9,9{sep}1\n0,3{sep}nan{sep}1\n")
    raw = read_csv(p)
    np.testing.assert_array_equal(raw.arrays["x"].values[0], [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(raw.arrays["y"].values[0][:2], [1.5e-3, -2.25])
    np.testing.assert_array_equal(raw.arrays["sed"].values[0], [0.5, 0.75, 1.0])
    assert any("read decimal commas as decimal points in 3 rows" in n for n in raw.notes)


def test_comma_delimited_rows_are_never_read_as_decimal_commas(tmp_path):
    p = _write(tmp_path, "x,y,sed\n0,1,5\n2,3,7\n")
    raw = read_csv(p)
    np.testing.assert_array_equal(raw.arrays["x"].values[0], [0.0, 2.0])
    np.testing.assert_array_equal(raw.arrays["sed"].values[0], [5.0, 7.0])
    assert not any("decimal commas" in n for n in raw.notes)


def test_number_like_text_column_raises_instead_of_being_dropped(tmp_path):
    p = _write(tmp_path, "x sed\n0.1 1.0D-03\n0.2 2.0D-03\n", "a.txt")
    msg = f"Column 'sed' of SED file {p!r} must hold numbers; got '1.0D-03' at line 2 instead."
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_report_blocks_with_different_columns(tmp_path):
    text = (
        "Node  SENER\n1  0.5\n2  0.25\n  Minimum  0.25\n  Maximum  0.5\n\n"
        "Node  SMISES\n3  1.5\n"
    )
    p = _write(tmp_path, text, "a.rpt")
    msg = (f"SED file {p!r} must hold one table, or report blocks with the same columns; got a block with "
           f"columns 'Node', 'SMISES' at line 7 after columns 'Node', 'SENER' instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_summaries_of_label_and_value_rows_are_footers(tmp_path):
    # MAPDL-style summaries (no listing title: read as a table) - 'NODE 1 1' under 'MINIMUM VALUES' was taken for the
    # first row of a second block ("must have a header row ... above the first data row (line 6)")
    text = ("NODE SX SY\n1 0.1 0.2\n2 0.3 0.4\n\n MINIMUM VALUES\n NODE 1 1\n VALUE -0.1 -0.2\n\n"
            " MAXIMUM VALUES\n NODE 2 2\n VALUE 0.3 0.4\nNODE SX SY\n3 0.5 0.6\n")
    raw = read_csv(_write(tmp_path, text, "a.txt"))
    np.testing.assert_array_equal(raw.arrays["SY"].values, [[0.2, 0.4, 0.6]])
    assert "dropped 6 footer rows (Minimum/Maximum/At Node/At Element/Int Pt/Total)" in raw.notes


def test_a_table_whose_first_row_of_numbers_is_a_summary(tmp_path):
    p = _write(tmp_path, "NODE SX SY\n\n MINIMUM VALUES\n NODE 1 1\n VALUE -0.1 -0.2\n", "a.txt")
    msg = (f"SED file {p!r} must hold data rows above its summary; got none: the first row of numbers (line 4: "
           "'NODE 1 1') belongs to the summary 'MINIMUM VALUES' (line 3) instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_repeated_header_rows_are_skipped(tmp_path):
    p = _write(tmp_path, "NODE SX\n1 0.5\nNODE SX\n2 0.25\n", "a.txt")
    raw = read_csv(p)
    np.testing.assert_array_equal(raw.arrays["SX"].values, [[0.5, 0.25]])
    assert "skipped 1 repeated header row" in raw.notes


def test_febio_records_must_agree(tmp_path):
    text = "*Step  = 1\n*Time  = 0.1\n*Data  = sed\n1 0.5\n2 0.25\n*Step  = 2\n*Time  = 0.2\n*Data  = sed\n1 0.75\n"
    p = _write(tmp_path, text, "log.txt")
    msg = (f"Every record of FEBio logfile {p!r} must have the same number of rows; got 2 rows in "
           f"'*Step = 1' (line 1) and 1 in '*Step = 2' (line 6) instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_febio_records_must_log_the_same_data(tmp_path):
    text = "*Step  = 1\n*Time  = 0.1\n*Data  = sed\n1 0.5\n*Step  = 2\n*Time  = 0.2\n*Data  = sx\n1 0.75\n"
    p = _write(tmp_path, text, "log.txt")
    msg = (f"Every record of FEBio logfile {p!r} must log the same data as the first ('*Data = sed', line 3); "
           f"got '*Data = sx' at line 7 instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_calculix_blocks_with_different_rows(tmp_path):
    text = (
        " internal energy density (elem, integ.pnt.,energy) for set EALL and time  0.1000000E+01\n\n"
        "         1   1  1.234568E-04\n         1   2  1.111111E-04\n\n"
        " internal energy (element, energy) for set EALL and time  0.1000000E+01\n\n"
        "         1  2.500000E-03\n"
    )
    p = _write(tmp_path, text, "job.dat")
    msg = (f"The blocks of CalculiX file {p!r} must have the same rows to be read side by side; got 2 rows of "
           f"'internal energy density' and 1 row of 'internal energy' per time instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_febio_comma_delimiter(tmp_path):
    text = "*Step  = 1\n*Time  = 0.25\n*Data  = sed;sx\n1,0.5,-0.1\n2,0.25,-0.2\n"
    raw = read_csv(_write(tmp_path, text, "log.txt"))
    np.testing.assert_array_equal(raw.arrays["sx"].values, [[-0.1, -0.2]])
    np.testing.assert_array_equal(raw.times, [0.25])


def test_utf16_and_latin1(tmp_path):
    text = "x,sed (µm)\n0.1,0.5\n"
    a = read_csv(_write(tmp_path, "", "a.csv", raw=text.encode("utf-16")))
    assert a.arrays["sed"].unit == "um"
    b = read_csv(_write(tmp_path, "", "b.csv", raw=text.encode("latin-1")))
    assert b.arrays["sed"].unit == "um"
    assert "decoded as Latin-1 (the file is not valid UTF-8)" in b.notes


def test_damaged_gzip(tmp_path):
    p = _write(tmp_path, "", "a.csv.gz", raw=gzip.compress(b"x,sed\n0.1,0.5\n")[:-6])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {p!r} must be a complete gzip stream")):
        read_csv(p)


def test_explicit_sep(tmp_path):
    p = _write(tmp_path, "x;y;z\n1;2;3\n")
    raw = read_csv(p, sep=";")
    assert list(raw.arrays) == ["x", "y", "z"]
    assert not any(n.startswith("detected delimiter") for n in raw.notes)
    with pytest.raises(SEDFormatError, match=re.escape("has a header but no data rows")):
        read_csv(p, sep=",")
    q = _write(tmp_path, "x y\n1 2\n", "q.txt")
    assert list(read_csv(q, sep=" ").arrays) == ["x", "y"]


@pytest.mark.parametrize(
    "kwargs, exc, msg",
    [
        (dict(sep="|"), ValueError,
         "Invalid value for the 'sep' parameter. Allowed values are None, ',', ';', '\\t' and 'whitespace', "
         "but got '|' instead."),
        (dict(time_column=3), TypeError, "'time_column' must be a column name (str) or None; got 3 instead."),
    ],
)
def test_bad_arguments(kwargs, exc, msg):
    with pytest.raises(exc, match=re.escape(msg)):
        read_csv(_path("plain_time.csv"), **kwargs)


def test_bad_paths():
    with pytest.raises(ValueError, match=re.escape("'paths' must be a file path or a non-empty list of file paths")):
        read_csv([])
    msg = "'paths' must be a file path or a list of file paths; got int instead."
    with pytest.raises(TypeError, match=re.escape(msg)):
        read_csv(3)


def test_directory_is_not_a_file(tmp_path):
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(tmp_path)!r} must be a file")):
        read_csv(tmp_path)


def test_progress_bar(capsys):
    files = [_path(f"steps/step_00{k}.csv") for k in (0, 1, 2)]
    raw = read_csv(files, progress=True)
    assert raw.n_times == 3


# --------------------------------------------------------------------------------------
# Round trip: random finite tables, random delimiter, optional '#' preamble
# --------------------------------------------------------------------------------------

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@st.composite
def tables(draw):
    n_cols = draw(st.integers(1, 5))
    n_rows = draw(st.integers(1, 8))
    values = draw(st.lists(st.lists(finite, min_size=n_cols, max_size=n_cols), min_size=n_rows, max_size=n_rows))
    delim = draw(st.sampled_from([",", ";", "\t", " "]))
    joiner = draw(st.sampled_from([" ", "  ", " \t "])) if delim == " " else delim
    preamble = draw(st.lists(st.text(alphabet="ab ;,\t%#1.", max_size=12), max_size=3))
    return np.array(values, dtype=np.float64), delim, joiner, preamble


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tables())
def test_round_trip(table):
    values, delim, joiner, preamble = table
    names = [f"c{k}" for k in range(values.shape[1])]
    lines = [f"# {c}" for c in preamble] + [joiner.join(names)]
    lines += [joiner.join(repr(float(v)) for v in row) for row in values]
    with tempfile.TemporaryDirectory() as tmp:
        p = os.path.join(tmp, "t.txt")
        with open(p, "w", encoding="utf-8", newline="") as fh:
            fh.write("\n".join(lines) + "\n")
        raw = read_csv(p)
    assert list(raw.arrays) == names
    got = np.stack([raw.arrays[n].values[0] for n in names], axis=1)
    np.testing.assert_array_equal(got, values)  # exact: repr precision must round-trip
    assert raw.times is None


# --------------------------------------------------------------------------------------
# A real CalculiX .dat: *EL PRINT element tables next to *NODE PRINT node tables, and gzip
# --------------------------------------------------------------------------------------

CCX = Path(__file__).parent / "data" / "calculix"


def test_calculix_dat_node_print_blocks_are_skipped():
    """ccx 2.20 prints *NODE PRINT U as 'displacements (vx,vy,vz)' tables (node, 3 values) between
    the *EL PRINT tables; they are skipped with a note and the element tables read as without them."""
    raw = read_csv(str(CCX / "block_c3d8_print.dat"))
    alone = read_csv(str(CCX / "block_c3d8.dat"))  # the same model printing *EL PRINT only
    assert list(raw.arrays) == list(alone.arrays)
    for name, arr in alone.arrays.items():
        np.testing.assert_array_equal(raw.arrays[name].values, arr.values)
    np.testing.assert_array_equal(raw.times, [1.0, 2.0, 3.0])
    assert ("skipped 3 CalculiX node blocks (*NODE PRINT: 'displacements'): SED and the tensors are read from "
            "the element blocks") in raw.notes


def test_calculix_dat_gz_is_recognised_and_read_like_the_dat():
    from afferent.io import format_of, read_sed

    assert format_of(str(CCX / "block_c3d8_print.dat.gz")) == "csv"
    kw = dict(coordinates=CCX / "block_c3d8.frd", length_unit="mm", sed_unit="MPa")
    gz = read_sed(CCX / "block_c3d8_print.dat.gz", **kw)
    plain = read_sed(CCX / "block_c3d8_print.dat", **kw)
    np.testing.assert_array_equal(gz.sed, plain.sed)
    assert gz.sed.shape == (3, 32) and "decompressed gzip data" in gz.provenance.notes


def test_calculix_dat_ener_is_a_density_equal_to_half_sigma_eps():
    """ENER of the .dat is the internal energy DENSITY at each integration point: 1/2 sigma:eps of the
    S and E printed at the same points (order xx yy zz xy xz yz, tensor shear) to the print precision;
    with engineering shear the sum is off."""
    from afferent.strain_energy import sed_exact

    a = read_csv(str(CCX / "block_c3d8_print.dat")).arrays
    s = np.stack([a[k].values for k in ("sxx", "syy", "szz", "sxy", "syz", "sxz")], -1)
    e = np.stack([a[k].values for k in ("exx", "eyy", "ezz", "exy", "eyz", "exz")], -1)
    ener = a["internal energy density"].values
    assert ener.shape == (3, 256) and ener.min() > 0
    np.testing.assert_allclose(sed_exact(s, e), ener, rtol=2e-6, atol=1e-6 * ener.max())
    halved = e.copy()
    halved[..., 3:] /= 2
    assert np.abs(sed_exact(s, halved) - ener).max() > 0.01 * ener.max()


def test_calculix_dat_with_only_node_blocks_is_refused(tmp_path):
    text = (" displacements (vx,vy,vz) for set NALL and time  0.1000000E+01\n\n"
            "         1  0.000000E+00  0.000000E+00 -1.000000E-02\n         2  0.000000E+00  0.000000E+00  0.000000E+00\n")
    p = _write(tmp_path, text, "job.dat")
    msg = (f"CalculiX file {p!r} must have element blocks (*EL PRINT of ENER, or S and E, at the integration points); "
           "got only node blocks (*NODE PRINT: 'displacements') instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


# --------------------------------------------------------------------------------------
# Long lines and cells: linear time, short messages (issue 26, item 6)
# --------------------------------------------------------------------------------------

_TIMED_READ = """
import json, sys, time
from afferent.io import read_raw
out = {}
for path in sys.argv[1:]:
    t = time.process_time()
    try:
        read_raw(path)
        msg = ""
    except Exception as err:
        msg = f"{type(err).__name__}: {err}"
    out[path] = (time.process_time() - t, msg)
print(json.dumps(out))
"""


def test_long_lines_and_cells_are_read_in_linear_time_with_short_messages(tmp_path):
    """A first data row starting with 20,000 digits took 227 s (regex backtracking), 10 MB lines
    hung the sniffing; each is now refused in well under 2 s of CPU, quoting at most 80 characters."""
    import json
    import subprocess
    import sys

    rows = "0,1,0,2\n0,0,1,3\n1,1,1,4\n"
    n = 10_000_000
    cases = {
        "digits.csv": "x,y,z,sed\n" + "1" * 20_000 + ",0,0,1\n" + rows,
        "digits_semicolon.csv": "x;y;z;sed\n" + "1" * 20_000 + "x;0;0;1\n" + rows.replace(",", ";"),
        "ones.csv": "x,y,z,sed\n" + "1" * n + "\n" + rows,
        "many_names.csv": "a," * (n // 2) + "\n" + rows,
        "many_words.csv": "x,y,z,sed\n" + "a " * (n // 2) + "\n" + rows,
        "many_numbers.csv": "x,y,z,sed\n" + "1," * (n // 2) + "\n" + rows,
    }
    paths = []
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        paths.append(str(tmp_path / name))
    proc = subprocess.run([sys.executable, "-c", _TIMED_READ, *paths], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    for path, (cpu, msg) in json.loads(proc.stdout).items():
        assert msg.startswith("SEDFormatError: ") and repr(path) in msg, msg
        assert cpu < 2.0, (path, cpu)
        assert len(msg) < 400 + len(path), msg
    digits = json.loads(proc.stdout)[paths[0]][1]
    assert re.search(r"must hold numbers; got '1{80}'\.\.\. \(20,000 characters\) at line 2", digits), digits
    names = json.loads(proc.stdout)[paths[3]][1]
    assert "got more than 10,000 names ('a', 'a', 'a', 'a', 'a', 'a', 'a', 'a', ...) instead." in names, names


def test_a_long_preamble_of_text_lines_is_sniffed_in_linear_time(tmp_path):
    """The fuzzer's csv-long target: 10 MB of short text lines (separated by CR) took > 100 s of CPU (every
    line classed under each of the four delimiters, twice); now the first row of numbers is looked for once,
    a line without a digit (or nan / inf) told in one scan. 500,000 lines here: 12 s before, 0.8-1.4 s now.
    Checked by how the CPU time grows from 50,000 to 500,000 lines (10 x for linear work, 100 x for the
    quadratic one), not by a bound in seconds, which a loaded machine crossed."""
    import json
    import subprocess
    import sys

    files = {}
    for n in (50_000, 500_000):
        files["text", n] = tmp_path / f"text{n}.csv"
        files["text", n].write_bytes(b"page\r" * n)
        files["late", n] = tmp_path / f"late{n}.csv"  # the same preamble, then a table: still found, with its delimiter
        files["late", n].write_bytes(b"page\n" * n + b"x;y;z;sed\n0;0;0;1\n1;0;0;2\n0;1;0;3\n0;0;1;4\n")
    warm = tmp_path / "warm.csv"  # read first: the reader's own imports are not timed with the small files
    warm.write_bytes(b"x;y;z;sed\n0;0;0;1\n1;0;0;2\n0;1;0;3\n0;0;1;4\n")
    proc = subprocess.run([sys.executable, "-c", _TIMED_READ, str(warm), *map(str, files.values())],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    cpu, msg = out[str(files["text", 500_000])]
    assert msg == (f"SEDFormatError: SED file {str(files['text', 500_000])!r} has a header but no data rows: it must "
                   "hold rows of numbers below its header row; got 500000 lines of text and no row of numbers instead."), msg
    for kind in ("text", "late"):
        small, large = out[str(files[kind, 50_000])][0], out[str(files[kind, 500_000])][0]
        assert large < 25 * max(small, 0.01), (kind, small, large)
    assert out[str(files["late", 500_000])][1] == ""
    late = files["late", 500_000]
    raw = read_csv(str(late))
    assert "detected delimiter: semicolon ';'" in raw.notes and raw.arrays["sed"].values.shape == (1, 4)


@pytest.mark.parametrize("pattern, text", [
    ("_NUMBER", "1" * 20_000 + "x"), ("_NUMBERISH", "1" * 20_000 + ",x"),
    ("_META", "a" + " " * 20_000 + "b"), ("_FEBIO_KEY", "*a" + " " * 20_000 + "b"),
    ("_FEBIO_KEY", "*Data = a" + " " * 20_000 + "b"), ("_CCX_TITLE", "a" + " " * 20_000 + "b"),
    ("_SUFFIX", "a @ t=" + " " * 20_000 + "x y"),
])
def test_the_line_patterns_fail_in_linear_time(pattern, text):
    import time

    from afferent.io import _csv_lines

    t = time.process_time()
    _csv_lines.__dict__[pattern].match(text)
    assert time.process_time() - t < 0.2  # quadratic backtracking took 1..4 s on these


def test_the_linear_patterns_read_what_the_old_ones_read():
    from afferent.io._columns import split_unit
    from afferent.io._csv_lines import _CCX_TITLE, _FEBIO_KEY, _META, _SUFFIX, step_suffix

    assert split_unit("solid.Ws (J/m^3)") == ("solid.Ws", "J/m^3")
    assert split_unit("a [b] (c)") == ("a [b]", "c") and split_unit("a ((mm)") == ("a", "(mm")
    assert split_unit("(mm)") == ("(mm)", None) and split_unit("sed (J/(m^3))") == ("sed (J/(m^3))", None)
    assert split_unit("\t" + "(" * 20_000)[1] is None
    m = _META.match("Length unit : mm")
    assert (m["key"].strip(), m["val"].strip()) == ("Length unit", "mm")
    assert _META.match("Key\t,v")["val"] == "v" and _META.match("Key\t\tv")["val"] == "v"
    assert _FEBIO_KEY.match("*Data\t= sed;sx")["val"] == "sed;sx"
    m = _CCX_TITLE.match("stresses (elem, integ.pnt.,sxx) for set EALL and time  0.1E+01")
    assert (m["what"].strip(), m["set"], m["time"]) == ("stresses", "EALL", "0.1E+01")
    m = _SUFFIX.match("SENER @Loc 1 @ t=0.02")
    assert (m["base"].rstrip(), m["pairs"]) == ("SENER @Loc 1", "t=0.02")
    assert step_suffix("SENER @Loc 1 @ t=0.02") == ("SENER @Loc 1", (("t", 0.02, None),))
    assert step_suffix("w (m) @ d=0.5[mm], F=1") == ("w (m)", (("d", 0.5, "mm"), ("F", 1.0, None)))
    assert step_suffix("w (m) @ d=x") == ("w (m) @ d=x", ())


# --------------------------------------------------------------------------------------
# COMSOL parametric sweeps: '@ d=0.5' columns are steps of the parameter, not times
# --------------------------------------------------------------------------------------


def test_comsol_parametric_sweep_is_steps_not_times():
    """One column per expression and value of d, grouped by value as a real COMSOL 6.1 export groups them
    (tests/data/csv/README.md): stacked into 3 steps with no times, the values of d in a note."""
    raw = read_csv(_path("comsol_sweep.csv"))
    assert raw.times is None and raw.time_unit is None
    assert list(raw.arrays) == ["x", "y", "z", "solid.Ws", "solid.mises"]
    np.testing.assert_array_equal(raw.arrays["solid.Ws"].values,
                                  [[1.0, 1.5, 0.5], [2.0, 3.0, 1.0], [3.0, 4.5, 1.5]])
    np.testing.assert_array_equal(raw.arrays["solid.mises"].values[:, 0], [10.0, 20.0, 30.0])
    assert "stacked '@ d=' columns into 3 steps" in raw.notes
    assert ("steps are values of parameter d, not times: d = 0.5, 1, 1.5; pass times= (--times) to give the steps "
            "times") in raw.notes


def test_comsol_parametric_sweep_assembled_as_step_numbers():
    """read_sed takes the path of an export without times: steps numbered 0, 1, 2 with the time unit 'step' (which
    spiking refuses to read as seconds without --times), the parameter's values in the record's notes."""
    from afferent.io import read_sed

    field = read_sed(_path("comsol_sweep.csv"))
    assert field.n_times == 3
    np.testing.assert_array_equal(field.times, [0.0, 1.0, 2.0])
    assert field.provenance.units["time"] == "step"
    assert any(n.startswith("steps are values of parameter d, not times") for n in field.provenance.notes)


def test_comsol_parametric_sweep_unit_named(tmp_path):
    p = tmp_path / "sweep.csv"
    p.write_text("% Length unit,mm\n% x,y,z,solid.Ws (J/m^3) @ d=0.5[mm],solid.Ws (J/m^3) @ d=1[mm]\n"
                 "0,0,0,1,2\n1,0,0,3,4\n")
    raw = read_csv(str(p))
    assert any(n.startswith("steps are values of parameter d (mm), not times: d = 0.5, 1;") for n in raw.notes)


@pytest.mark.parametrize("titles, message", [
    ('"solid.Ws (J/m^3) @ d=0.5, F=1","solid.Ws (J/m^3) @ d=1, F=1"',
     r"sweeps 2 parameters \('d', 'F'\) in its '@ name=value' column suffixes \(e.g. 'solid.Ws \(J/m\^3\) @ d=0.5, "
     r"F=1'\); afferent reads the steps of one parameter or of the time per file. Export one value"),
    ("solid.Ws (J/m^3) @ t=0,solid.Ws (J/m^3) @ d=1",
     r"sweeps 1 parameter \('d'\) and the time \('t'\) in its '@ name=value' column suffixes \(e.g. "
     r"'solid.Ws \(J/m\^3\) @ d=1'\)"),
])
def test_comsol_sweep_of_several_parameters_refused(tmp_path, titles, message):
    p = tmp_path / "sweep.csv"
    p.write_text(f"% Length unit,mm\n% x,y,z,{titles}\n0,0,0,1,2\n1,0,0,3,4\n")
    with pytest.raises(SEDFormatError, match=message):
        read_csv(str(p))


def test_comsol_sectionwise_sweep_is_steps_not_times(tmp_path):
    """The Sectionwise layout's '% Data (solid.Ws (J/m^3) @ d=0.5)' sections take the same path as the columns."""
    p = tmp_path / "sweep.txt"
    p.write_text(Path(_path("comsol_sectionwise.txt")).read_text().replace("@ t=", "@ d="))
    raw = read_csv(str(p))
    assert raw.times is None and raw.arrays["solid.Ws"].values.shape == (2, 371)
    assert "steps are values of parameter d, not times: d = 0.5, 1; pass times= (--times) to give the steps times" \
        in raw.notes
