"""Abaqus/CAE field reports (``.rpt``) as Abaqus really writes them: frames as time steps, wrapped
tables, COORD columns, integration-point and element-nodal positions (:mod:`afferent.io._csv_table`).

The layouts follow real reports (tests/data/csv/README.md names them); the values are made up.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_sed
from afferent.io._csv import read_csv

TITLE = ("            Node     COORD.COOR1     COORD.COOR2     COORD.COOR3           SENER\n"
         "           Label          @Loc 1          @Loc 1          @Loc 1          @Loc 1\n" + "-" * 81 + "\n")


def _frame(step: str, frame: str, rows: list[str], *, position: str = "Nodal", title: str = TITLE) -> str:
    return ("Field Output Report, written Mon Dec  8 03:10:45 2025\n\nSource 1\n---------\n\n"
            f"   ODB: /home/u/skin.odb\n   Step: {step}\n   Frame: {frame}\n\n"
            f"Loc 1 : {position} values from source 1\n\n"
            'Output sorted by column "Node Label".\n\n'
            "Field Output reported at nodes for part: SKIN-1\n\n" + title + "\n".join(rows) + "\n\n\n"
            "  Minimum           0.           0.           0.       1.0000E-03\n"
            "         At Node           1            1            1            1\n\n")


ROWS = ["               1      0.0000E+00      0.0000E+00      0.0000E+00      1.0000E-03",
        "               2      1.0000E+00      0.0000E+00      0.0000E+00      2.0000E-03",
        "               3      0.0000E+00      1.0000E+00      0.0000E+00      3.0000E-03"]


def _write(tmp_path, text: str, name: str = "r.rpt") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_frames_of_one_step_are_time_steps_at_their_step_time(tmp_path):
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS)
               + _frame("Indent", "Increment     10: Step Time =     1.000", [r.replace("E-03", "E-02") for r in ROWS]))
    field = read_sed(p, sed_unit="MPa", length_unit="mm")
    assert field.n_points == 3
    np.testing.assert_array_equal(field.times, [0.5, 1.0])
    np.testing.assert_allclose(field.sed, [[1e3, 2e3, 3e3], [1e4, 2e4, 3e4]])  # MPa -> J/m^3
    np.testing.assert_allclose(field.points[1], [1e-3, 0.0, 0.0])


def test_frames_of_several_analysis_steps_are_numbered_not_timed(tmp_path):
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =     1.000", ROWS)
               + _frame("Hold", "Increment      2: Step Time =     1.000", ROWS))
    raw = read_csv(p)
    assert raw.times is None and raw.n_times == 2
    assert ("read the report's 2 frames as time steps of 3 rows: 'Increment      5: Step Time =     1.000' (line 8); "
            "'Increment      2: Step Time =     1.000' (line 34); they span 2 analysis steps ('Indent', 'Hold') and "
            "Abaqus restarts 'Step Time' in each step (the report gives no total time), so the steps are numbered, "
            "not timed; pass times= to set them") in raw.notes
    field = read_sed(p, sed_unit="MPa", length_unit="mm")
    np.testing.assert_array_equal(field.times, [0.0, 1.0])


def test_frames_without_a_step_time_are_numbered(tmp_path):
    p = _write(tmp_path, _frame("Freq", "Mode      1: Value =  1.0E+03 Freq =  5.0329  (cycles/time)", ROWS)
               + _frame("Freq", "Mode      2: Value =  4.0E+03 Freq =  10.066  (cycles/time)", ROWS))
    raw = read_csv(p)
    assert raw.times is None and raw.n_times == 2
    assert any("frame 'Mode      1: Value =  1.0E+03 Freq =  5.0329  (cycles/time)' (line 8) states no 'Step Time', "
               "so the steps are numbered" in n for n in raw.notes)


def test_frames_must_list_the_same_rows(tmp_path):
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS)
               + _frame("Indent", "Increment     10: Step Time =     1.000", ROWS[:2]))
    msg = (f"Every frame of the Abaqus report {p!r} must list the same rows (one time step each); got 3 rows in frame "
           "'Increment      5: Step Time =    0.5000' (line 8) and 2 in frame 'Increment     10: Step Time =     1.000' "
           "(line 34) instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_frames_must_list_the_same_nodes(tmp_path):
    other = [ROWS[0], ROWS[1].replace("               2", "               7"), ROWS[2]]
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS)
               + _frame("Indent", "Increment     10: Step Time =     1.000", other))
    msg = (f"Every frame of the Abaqus report {p!r} must list the same 'Node Label' values in the same order (one point "
           "set, one time step per frame); got 2 at line 20 in the first frame and 7 at line 46 in frame 2 instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_a_block_without_a_frame_after_frames_is_refused(tmp_path):
    text = (_frame("Indent", "Increment      5: Step Time =    0.5000", ROWS).split("Field Output reported")[0]
            .replace("   Frame: Increment      5: Step Time =    0.5000\n", "")
            + "Field Output reported" + _frame("Indent", "Increment 5: Step Time = 0.5", ROWS).split(
                "Field Output reported")[1]
            + _frame("Indent", "Increment     10: Step Time =     1.000", ROWS))
    p = _write(tmp_path, text)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"Every report block of SED file {p!r} must state its frame ('Frame: ...') once one does; got a block "
            "without one (its rows from row 1) beside the frame at line 33 instead.")):
        read_csv(p)


def test_one_frame_per_file_gives_each_file_its_step_time(tmp_path):
    a = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS), "f5.rpt")
    b = _write(tmp_path, _frame("Indent", "Increment     10: Step Time =     1.000", ROWS), "f10.rpt")
    raw = read_csv([a, b])
    np.testing.assert_array_equal(raw.times, [0.5, 1.0])


def test_coord_coordinates_warn_that_they_are_deformed_positions_under_nlgeom(tmp_path):
    """Abaqus' COORD is the current position in a geometrically nonlinear step: read, with a warning
    in the run record (receptor sites of the undeformed model would fall beside the points)."""
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS))
    with pytest.warns(AfferentWarning, match=re.escape(
            f"SED file {p!r}: the coordinates are Abaqus' COORD output ('COORD.COOR1', 'COORD.COOR2', 'COORD.COOR3'): "
            "the nodes' current (deformed) positions when the step ran with NLGEOM")):
        field = read_sed(p, sed_unit="MPa", length_unit="mm")
    assert any("Abaqus' COORD output" in n for n in field.provenance.notes)


def test_coord_of_a_first_frame_at_time_0_stands_for_every_frame(tmp_path):
    """Frames whose COORD moves (NLGEOM) were refused; with the step's first frame (increment 0, time 0:
    the undeformed model) in the report, its COORD gives the points of every frame, no warning."""
    moved = [r[:32] + f"{float(r[32:48]) - 0.05:16.4E}" + r[48:64] + r[64:].replace("E-03", "E-02") for r in ROWS]
    p = _write(tmp_path, _frame("Indent", "Increment      0: Step Time =    0.0000", ROWS)
               + _frame("Indent", "Increment      5: Step Time =    0.5000", moved))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        field = read_sed(p, sed_unit="MPa", length_unit="mm")
    np.testing.assert_allclose(field.points[2], [0.0, 1e-3, 0.0])  # frame 0's, not the moved 0.95 mm
    np.testing.assert_allclose(field.sed[1], [1e4, 2e4, 3e4])
    assert any("COORD of the first frame (time 0: the undeformed model)" in n for n in field.provenance.notes)
    later = _write(tmp_path, _frame("Indent", "Increment      2: Step Time =    0.2000", ROWS)
                   + _frame("Indent", "Increment      5: Step Time =    0.5000", moved), "later.rpt")
    with pytest.raises(SEDFormatError, match="the coordinates of time step 1 differ from those of step 0"):
        read_sed(later, sed_unit="MPa", length_unit="mm")


@pytest.mark.filterwarnings("ignore:.*Abaqus' COORD output")
def test_coord_with_dashes_is_a_coordinate(tmp_path):
    p = _write(tmp_path, _frame("Indent", "Increment      5: Step Time =    0.5000", ROWS,
                                title=TITLE.replace("COORD.COOR", "COORD-COOR")))
    field = read_sed(p, sed_unit="MPa", length_unit="mm")
    np.testing.assert_allclose(field.points[2], [0.0, 1e-3, 0.0])


WRAPPED = ("Element   Int  COORD.COOR1  COORD.COOR2\n"
           "Label     Pt        @Loc 1       @Loc 1\n" + "-" * 39 + "\n"
           "  COORD.COOR3        SENER\n"
           "       @Loc 1       @Loc 1\n" + "-" * 26 + "\n"
           "        S.S11        S.S22\n"
           "       @Loc 1       @Loc 1\n" + "-" * 26 + "\n")


def test_a_table_wrapped_over_three_lines_reads_as_joined_records(tmp_path):
    rows = ["    1     1      0.25      0.25", "       -0.5   1.5E-03", "   -2.E-03      -0.", "",
            "    1     2      0.75      0.25", "       -0.5   2.5E-03", "   -3.E-03   1.E-03"]
    text = _frame("Indent", "Increment 1: Step Time = 1.", rows, position="Integration point", title=WRAPPED)
    raw = read_csv(_write(tmp_path, text))
    assert list(raw.arrays) == ["Element Label", "Int Pt", "COORD.COOR1", "COORD.COOR2", "COORD.COOR3", "SENER",
                                "S.S11", "S.S22"]
    np.testing.assert_array_equal(raw.arrays["SENER"].values, [[1.5e-3, 2.5e-3]])
    np.testing.assert_array_equal(raw.arrays["S.S22"].values, [[-0.0, 1e-3]])
    assert "joined each record's 3 lines of a wrapped table (4 + 2 + 2 values; column titles in 3 parts)" in raw.notes


def test_a_short_wrapped_record_is_refused(tmp_path):
    rows = ["    1     1      0.25      0.25", "       -0.5   1.5E-03", "   -2.E-03      -0.",
            "    1     2      0.75      0.25", "       -0.5", "   -3.E-03   1.E-03"]
    p = _write(tmp_path, _frame("Indent", "Increment 1: Step Time = 1.", rows, title=WRAPPED))
    msg = (f"SED file {p!r} has a table wrapped over 3 lines per record of 4, 2, 2 values (column titles at lines 16-23): "
           "the record at line 28 must have 2 values on its line 2; got 1 at line 29 instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_a_lost_line_of_a_wrapped_record_is_found_where_it_is_lost(tmp_path):
    """Parts of equal counts (6 + 6): the line counts alone would pair the wrong lines until the last record."""
    from pathlib import Path

    lines = (Path(__file__).parent / "data" / "csv" / "abaqus_wrapped.rpt").read_text().split("\n")
    del lines[25]  # the second line of the second record (line 26)
    p = _write(tmp_path, "\n".join(lines))
    msg = (f"SED file {p!r} has a table wrapped over 2 lines per record of 6, 6 values (column titles at lines 17-21): "
           "line 26 must continue the record at line 25 (its line 2 of 2); got '2', the label of a new record: a line "
           "of a record is missing instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_a_wrapped_title_must_name_the_first_record(tmp_path):
    rows = ["    1     1      0.25", "       -0.5   1.5E-03", "   -2.E-03      -0."]
    p = _write(tmp_path, _frame("Indent", "Increment 1: Step Time = 1.", rows, title=WRAPPED))
    msg = (f"SED file {p!r} has a table wrapped over 3 lines per record (column titles at lines 16, 19, 22): line 25, "
           "part 1 of its first record, must hold one value per column named at lines 16-17 ('Element   Int  "
           "COORD.COOR1  COORD.COOR2'); got 3 values instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv(p)


def test_a_titled_rule_above_a_plain_title_is_not_a_wrapped_table(tmp_path):
    text = ("Field Output Report\nSource 1\n---------\n"
            "            Node           SENER\n           Label          @Loc 1\n" + "-" * 33 + "\n"
            "               1     1.0E-03\n               2     2.0E-03\n")
    raw = read_csv(_write(tmp_path, text))
    assert list(raw.arrays) == ["Node Label", "SENER"]
    np.testing.assert_array_equal(raw.arrays["SENER"].values, [[1e-3, 2e-3]])


def test_the_lug_report_reads_as_joined_records():
    """The wrapped integration-point report of the Abaqus Getting Started guide's lug example (its layout, made-up
    values): 7 + 2 values per record, wrapped footers with 'Int Pt' rows."""
    from pathlib import Path

    raw = read_csv(str(Path(__file__).parent / "data" / "csv" / "abaqus_wrapped.rpt"))
    assert raw.n_times == 1 and raw.arrays["S.S23"].values.shape == (1, 4)
    assert not any("after the last footer" in n for n in raw.notes)


ELEMENT_NODAL = ("    Element            Node     COORD.COOR1     COORD.COOR2     COORD.COOR3           SENER\n"
                 "      Label           Label          @Loc 1          @Loc 1          @Loc 1          @Loc 1\n"
                 + "-" * 97 + "\n")


def _element_nodal(shared_sed: str) -> str:
    rows = ["          1               1              0.              0.              0.        1.0E-03",
            "          1               2              1.              0.              0.        2.0E-03",
            "          1               3              0.              1.              0.        3.0E-03",
            "          2               2              1.              0.              0.   " + shared_sed,
            "          2               3              0.              1.              0.        3.0E-03",
            "          2               4              1.              1.              0.        4.0E-03"]
    return _frame("Indent", "Increment 1: Step Time = 1.", rows, position="Element nodal", title=ELEMENT_NODAL)


def test_element_nodal_copies_with_different_values_are_refused(tmp_path):
    p = _write(tmp_path, _element_nodal("     2.5E-03"))
    assert any("the report holds Element nodal values (line 10): one row per element and node" in n
               for n in read_csv(p).notes)
    with pytest.raises(SEDFormatError, match=re.escape(
            "lists the point (1, 0, 0) more than once with different SED (rows 1 and 3: 2000 and 2500 J/m^3); "
            "2 point(s) repeat. These look like unaveraged element-nodal values")):
        read_sed(p, sed_unit="MPa", length_unit="mm")


def test_element_nodal_copies_that_agree_are_merged(tmp_path):
    field = read_sed(_write(tmp_path, _element_nodal("     2.0E-03")), sed_unit="MPa", length_unit="mm")
    assert field.n_points == 4
    np.testing.assert_allclose(np.sort(field.sed[0]), [1e3, 2e3, 3e3, 4e3])


def test_integration_point_report_without_coordinates_is_refused_naming_them(tmp_path):
    title = ("Element   Int        SENER\nLabel     Pt        @Loc 1\n" + "-" * 26 + "\n")
    p = _write(tmp_path, _frame("Indent", "Increment 1: Step Time = 1.", ["    1     1  1.5E-03", "    1     2  2.5E-03"],
                                position="Integration point", title=title))
    with pytest.raises(SEDFormatError, match=re.escape(
            "must have one x coordinate column (e.g. 'x', 'X', 'COORD1', 'X Location'); found no. Found columns "
            "'Element Label', 'Int Pt', 'SENER'.")):
        read_sed(p, sed_unit="MPa", length_unit="mm")


def test_integration_points_with_coord_are_points_of_their_own():
    """COORD at the integration points places each row: four points, not two element means."""
    from pathlib import Path

    field = read_sed(str(Path(__file__).parent / "data" / "csv" / "abaqus_wrapped.rpt"), sed_unit="MPa",
                     length_unit="mm")
    assert field.n_points == 4
    np.testing.assert_allclose(field.points[:, 0], [211.325e-6, 788.675e-6, 1.21132e-3, 1.78868e-3])
    np.testing.assert_allclose(field.sed[0], [1.5e3, 2.5e3, 750.0, 333.333])


# --------------------------------------------------------------------------------------
# Reports of several part instances: a node is (part, label); --coordinates joins on both
# --------------------------------------------------------------------------------------

PARTS_RPT = str(Path(__file__).parent / "data" / "csv" / "abaqus_parts.rpt")
PARTS_NODES = str(Path(__file__).parent / "data" / "csv" / "abaqus_parts_nodes.csv")


def test_report_keeps_each_rows_part_instance():
    """Two frames of two parts whose labels both start at 1 (no COORD): each row keeps its part as column 'Part'
    (codes in order of appearance, the names in a note)."""
    raw = read_csv(PARTS_RPT)
    np.testing.assert_array_equal(raw.arrays["Part"].values, [[0, 0, 0, 0, 1, 1]] * 2)
    np.testing.assert_array_equal(raw.arrays["Node Label"].values[0], [1, 2, 3, 4, 1, 2])
    assert "column 'Part' numbers the rows' part instances: 0 = 'DERMIS-1', 1 = 'EPIDERMIS-1'" in raw.notes


def test_coordinates_join_on_part_and_label():
    """The coordinates table lists the parts in another order: each row gets the position of its (part, label)."""
    from afferent.io._find_arrays import join_coordinates

    joined = join_coordinates(read_csv(PARTS_RPT), PARTS_NODES)
    np.testing.assert_array_equal(joined.points, [[0, 0, -1], [1, 0, -1], [0, 1, -1], [1, 1, -1],
                                                   [0, 0, 0], [0.5, 0.5, 0]])
    np.testing.assert_array_equal(joined.times, [0.5, 1.0])
    assert any("keyed by part instance (column 'Part') and label" in n for n in joined.notes)


def test_sampled_through_read_sed_with_parts():
    field = read_sed(PARTS_RPT, coordinates=PARTS_NODES, length_unit="mm", sed_unit="MPa")
    assert field.n_times == 2 and field.points.shape == (6, 3)
    np.testing.assert_allclose(field.points[5], [0.5e-3, 0.5e-3, 0.0])


def test_coordinates_without_parts_refused(tmp_path):
    from afferent.io._find_arrays import join_coordinates

    nodes = tmp_path / "nodes.csv"
    nodes.write_text("Node Label,X,Y,Z\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,1,1,0\n")
    with pytest.raises(SEDFormatError, match=r"its node labels \('Node Label'\) repeat across its part instances "
                       r"\('DERMIS-1', 'EPIDERMIS-1': each numbers its nodes from 1\), so coordinates file .*nodes.csv' "
                       r"must name the part of each row: give it a 'Part' \(or 'Instance'\) column"):
        join_coordinates(read_csv(PARTS_RPT), str(nodes))


def test_coordinates_missing_a_part_named(tmp_path):
    from afferent.io._find_arrays import join_coordinates

    nodes = tmp_path / "nodes.csv"
    nodes.write_text("".join(Path(PARTS_NODES).read_text().splitlines(keepends=True)[:3]).replace("Part,", "Instance,"))
    with pytest.raises(SEDFormatError, match=r"lacks 4 id\(s\) of SED file .*\(first: label 1 of part DERMIS-1, "
                       r"label 2 of part DERMIS-1"):
        join_coordinates(read_csv(PARTS_RPT), str(nodes))


def test_coordinates_with_parts_for_a_report_of_one_part(tmp_path):
    """A table naming parts given to a report of one part: its labels alone when they are unique, else refused."""
    from afferent.io._find_arrays import join_coordinates

    rpt = tmp_path / "one.rpt"
    title = "            Node           SENER\n           Label          @Loc 1\n" + "-" * 33 + "\n"
    rpt.write_text(_frame("Indent", "Increment      1: Step Time =    1.000",
                          ["               1        1.E-03", "               2        2.E-03"], title=title))
    nodes = tmp_path / "nodes.csv"
    nodes.write_text("Part,Node Label,X,Y,Z\nSKIN-1,2,1,0,0\nSKIN-1,1,0,0,0\n")
    np.testing.assert_array_equal(join_coordinates(read_csv(str(rpt)), str(nodes)).points, [[0, 0, 0], [1, 0, 0]])
    nodes.write_text("Part,Node Label,X,Y,Z\nSKIN-1,1,1,0,0\nBONE-1,1,0,0,0\nSKIN-1,2,0,0,0\n")
    with pytest.raises(SEDFormatError, match=r"names the part instances 'SKIN-1', 'BONE-1', whose labels repeat, but "
                       r"SED file .* names none"):
        join_coordinates(read_csv(str(rpt)), str(nodes))


def test_coord_of_a_first_frame_at_time_0_with_two_parts(tmp_path):
    """The time-0 COORD rule with two part instances whose labels both run 1..3: frame 0's positions for every frame,
    the rows' parts kept."""
    def frame(inc: str, rows: list[str], deeper: list[str]) -> str:
        bone = [r[:48] + f"{float(r[48:64]) - 1:16.4E}" + r[64:] for r in deeper]
        return (_frame("Indent", inc, rows) + "Field Output reported at nodes for part: BONE-1\n\n" + TITLE
                + "\n".join(bone) + "\n\n\n  Minimum           0.           0.           0.       1.0000E-03\n\n")

    moved = [r[:32] + f"{float(r[32:48]) - 0.05:16.4E}" + r[48:] for r in ROWS]
    p = _write(tmp_path, frame("Increment      0: Step Time =    0.0000", ROWS, ROWS)
               + frame("Increment      5: Step Time =    0.5000", moved, moved))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        field = read_sed(p, sed_unit="MPa", length_unit="mm")
    np.testing.assert_allclose(field.points[[2, 5]], [[0.0, 1e-3, 0.0], [0.0, 1e-3, -1e-3]])
    assert any("0 = 'SKIN-1', 1 = 'BONE-1'" in n for n in field.provenance.notes)


def test_integration_points_of_two_parts_averaged_per_part_and_element(tmp_path):
    """Element 1 of SKIN-1 and element 1 of BONE-1 are two elements: their integration points are averaged apart
    (grouping by label alone would mix them into one wrong mean)."""
    title = ("Element   Int        SENER\nLabel     Pt        @Loc 1\n" + "-" * 26 + "\n")
    skin = _frame("Indent", "Increment 1: Step Time = 1.", ["    1     1  1.0E-03", "    1     2  3.0E-03"],
                  position="Integration point", title=title)
    bone = ("Field Output reported at integration points for part: BONE-1\n\n" + title
            + "    1     1  5.0E-03\n    1     2  7.0E-03\n\n\n  Minimum        5.0E-03\n\n")
    p = _write(tmp_path, skin + bone)
    cells = tmp_path / "centroids.csv"
    cells.write_text("Instance,Element Label,X,Y,Z\nBONE-1,1,0,0,-1\nSKIN-1,1,0,0,0\n")
    field = read_sed(p, coordinates=str(cells), sed_unit="MPa", length_unit="mm")
    np.testing.assert_allclose(field.points, [[0, 0, 0], [0, 0, -1e-3]])
    np.testing.assert_allclose(field.sed[0], [2e3, 6e3])


def test_one_frame_per_file_of_several_parts_joins_with_coordinates_or_is_refused_when_parts_are_reordered(tmp_path):
    """Reports of several part instances, one frame per file: the same parts in the same order join with a
    coordinates table on (part, label); before, the joined notes ('all 2 files: column ...') hid the part names and
    the join refused the files as 'a report of one part'. Parts in another order in a later file number the rows
    otherwise (its codes would name other parts): refused, naming the orders."""
    data = Path(__file__).parent / "data" / "csv"
    lines = (data / "abaqus_parts.rpt").read_text().split("\n")
    start = [k for k, line in enumerate(lines) if line.startswith("*****")][1]  # the second frame's report
    first, second = "\n".join(lines[:start]) + "\n", "\n".join(lines[start:])
    a, b = tmp_path / "f5.rpt", tmp_path / "f10.rpt"
    a.write_text(first)
    b.write_text(second)
    nodes = str(data / "abaqus_parts_nodes.csv")
    both = read_sed([str(a), str(b)], coordinates=nodes, length_unit="mm", sed_unit="MPa")
    whole = read_sed(str(data / "abaqus_parts.rpt"), coordinates=nodes, length_unit="mm", sed_unit="MPa")
    np.testing.assert_array_equal(both.sed, whole.sed)
    np.testing.assert_array_equal(both.points, whole.points)
    i, j = second.index("Field Output reported at nodes for part: DERMIS-1"), second.index(
        "Field Output reported at nodes for part: EPIDERMIS-1")
    b.write_text(second[:i] + second[j:].rstrip("\n") + "\n\n\n" + second[i:j])  # EPIDERMIS-1 first
    msg = (f"SED file {str(b)!r} must report the part instances of {str(a)!r} in the same order ('DERMIS-1', "
           "'EPIDERMIS-1'); got 'EPIDERMIS-1', 'DERMIS-1' instead.")
    with pytest.raises(SEDFormatError, match=re.escape(msg)):
        read_csv([str(a), str(b)])
