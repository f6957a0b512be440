"""ANSYS MAPDL text listings (PRNSOL S / EPEL / SEND, NLIST, PRETAB) read by the text-table reader.

The listings under tests/data/mapdl/ imitate real MAPDL listings (README there): their values are
ansys-mapdl-reader's of the MAPDL result file it ships (result sets 1-3), so the SED afferent
computes from the listings is checked against the SED it computes from that ``.rst`` read directly.
The small listings written here follow the same real layouts (page banners, LOAD STEP / TIME lines,
MINIMUM / MAXIMUM summaries, values written without a blank between them).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw

DATA = Path(__file__).parent / "data" / "mapdl"
S, EPEL, SEND, NLIST = (str(DATA / f"beam_{k}.lis") for k in ("s", "epel", "send", "nlist"))


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)  # a steel beam in psi and inches: implausible for skin
        return fn(*args, **kw)


def _page(step: int, time: float, header: str, rows: list[str], banner: str = "POST1 NODAL STRESS LISTING") -> str:
    return "\n".join([
        " ", f"  ***** {banner} *****", " ", f"  LOAD STEP=     {step}  SUBSTEP=     1",
        f"   TIME=    {time:.4f}      LOAD CASE=   0", " ",
        "  THE FOLLOWING X,Y,Z VALUES ARE IN GLOBAL COORDINATES", " ", header, *rows, ""])


HEADER_S = "    NODE    SX          SY          SZ          SXY         SYZ         SXZ"
SUMMARY = "\n MINIMUM VALUES\n NODE          1           1           1           1           1           1\n" \
          " VALUE  -0.20287E-07 -91.213     -27.364    -0.13603E-02 -4.8423    -0.72216E-04\n"


def _write(tmp_path, name: str, text: str) -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_prnsol_pages_summaries_and_result_sets():
    raw = read_raw(S)
    assert raw.format == "csv" and raw.preset == "ansys"
    assert list(raw.arrays) == ["NODE", "SX", "SY", "SZ", "SXY", "SYZ", "SXZ"]
    assert raw.arrays["SX"].values.shape == (3, 99)  # 3 PRNSOL listings (SET 1,1..1,3), 3 pages of 37 rows each
    assert raw.arrays["SX"].values[0, 0] == -0.20604e7 and raw.arrays["SXY"].values[0, 0] == 2810.6
    assert np.all(np.diff(raw.arrays["NODE"].values, axis=1) > 0)
    assert raw.times is None  # a modal run prints FREQ=, not TIME=: steps are numbered
    assert any("FREQ=" in n for n in raw.notes) and any("summaries" in n for n in raw.notes)


def test_listing_values_are_the_result_files():
    reader = pytest.importorskip("ansys.mapdl.reader")
    raw = read_raw([S, EPEL])
    assert list(raw.arrays)[7:] == ["EPELX", "EPELY", "EPELZ", "EPELXY", "EPELYZ", "EPELXZ"]
    rst = reader.read_binary(reader.examples.rstfile)
    for k in range(3):
        nnum, stress = rst.nodal_stress(k)
        ok = ~np.isnan(stress).any(axis=1)
        assert np.array_equal(nnum[ok], raw.arrays["NODE"].values[k])
        got = np.stack([raw.arrays[c].values[k] for c in ("SX", "SY", "SZ", "SXY", "SYZ", "SXZ")], axis=1)
        np.testing.assert_allclose(got, stress[ok], rtol=5e-5, atol=1e-6 * np.abs(stress[ok]).max())


def test_sed_from_s_epel_and_nlist_is_the_result_files_sed():
    pytest.importorskip("ansys.mapdl.reader")
    from ansys.mapdl.reader import examples

    listing = _quiet(read_sed, [S, EPEL], coordinates=NLIST, sed_from="exact", length_unit="m", stress_unit="Pa")
    send = _quiet(read_sed, SEND, coordinates=NLIST, length_unit="m", sed_unit="Pa")
    rst = _quiet(read_sed, examples.rstfile, sed_from="exact", length_unit="m", stress_unit="Pa")
    assert listing.sed.shape == send.sed.shape == (3, 99)
    np.testing.assert_array_equal(listing.points, rst.points)  # NLIST's coordinates joined on NODE
    scale = rst.sed[:3].max()
    assert np.abs(listing.sed - rst.sed[:3]).max() / scale < 1e-4  # 5 significant digits printed
    assert np.abs(send.sed - rst.sed[:3]).max() / scale < 1e-4
    assert send.provenance.columns["sed"] == "SEND ELASTIC"  # 'ELASTIC' under 'PRINT SEND'
    assert "preset='ansys'" in " ".join(listing.provenance.notes)  # engineering shear, X Y Z XY YZ XZ


def test_load_steps_are_time_steps_and_nsort_order_is_undone(tmp_path):
    rows1 = ["       2  0.10000E-02  2.0000      0.0000      0.0000      0.0000      0.0000",
             "       1  0.30000E-02  1.0000      0.0000      0.0000      0.0000      0.0000"]
    rows2 = ["       1  0.60000E-02  4.0000      0.0000      0.0000      0.0000      0.0000",
             "       2  0.20000E-02  3.0000      0.0000      0.0000      0.0000      0.0000"]
    text = (" PRINT S    NODAL SOLUTION PER NODE\n" + _page(1, 0.5, HEADER_S, rows1) + SUMMARY
            + " PRINT S    NODAL SOLUTION PER NODE\n" + _page(2, 1.0, HEADER_S, rows2) + SUMMARY)
    raw = read_raw(_write(tmp_path, "steps.lis", text))
    np.testing.assert_array_equal(raw.times, [0.5, 1.0])
    np.testing.assert_array_equal(raw.arrays["SY"].values, [[1.0, 2.0], [4.0, 3.0]])
    assert any("NSORT" in n for n in raw.notes)


def test_values_written_without_a_blank_between_them(tmp_path):
    text = ("PRINT F    REACTION SOLUTIONS PER NODE\n\n *** ANSYS - ENGINEERING ANALYSIS SYSTEM  RELEASE 2021 R2 ***\n"
            " 00000000  VERSION=LINUX x64     15:56:42  JAN 13, 2022 CP=      0.665\n\n"
            "  ***** POST1 TOTAL REACTION SOLUTION LISTING *****\n\n  LOAD STEP=     1  SUBSTEP=     1\n"
            "   TIME=    1.0000      LOAD CASE=   0\n\n    NODE       FX           FY\n"
            "       1  0.25000E+008 0.50000E+007\n       2 -0.12500E+007-0.75000E+007\n\n"
            " TOTAL VALUES\n VALUE   0.23750E+008-0.25000E+007\n")
    raw = read_raw(_write(tmp_path, "f.lis", text))
    np.testing.assert_array_equal(raw.arrays["FY"].values, [[5e6, -7.5e6]])
    np.testing.assert_array_equal(raw.arrays["FX"].values, [[2.5e7, -1.25e6]])


def test_listings_printed_without_their_title_lines(tmp_path):
    # each page starts with its banner (as a PRNSOL listing cut out of a longer output): S, then EPEL
    rows = ["       2  0.10000E-02  2.0000      0.0000      0.0000      0.0000      0.0000",
            "       1  0.30000E-02  1.0000      0.0000      0.0000      0.0000      0.0000"]
    epel = _page(1, 1.0, HEADER_S.replace(" S", " EPEL"), [r.replace("2.0000", "4.0000") for r in rows],
                 "POST1 NODAL ELASTIC STRAIN LISTING")
    raw = read_raw(_write(tmp_path, "both.lis", _page(1, 1.0, HEADER_S, rows) + _page(1, 1.0, HEADER_S, rows[:0])
                          + SUMMARY + epel + SUMMARY))
    assert list(raw.arrays)[6:9] == ["SXZ", "EPELX", "EPELY"]
    np.testing.assert_array_equal(raw.arrays["EPELY"].values, [[1.0, 4.0]])


def test_pretab_element_table(tmp_path):
    text = ("PRINT ELEMENT TABLE ITEMS PER ELEMENT\n\n  ***** POST1 ELEMENT TABLE LISTING *****\n\n"
            "    STAT     CURRENT     CURRENT\n    ELEM     SED         CX\n"
            "       1  0.59135E-01  0.25000\n       2  0.41000E-01  0.75000\n")
    raw = read_raw(_write(tmp_path, "etab.lis", text))
    assert list(raw.arrays) == ["ELEM", "SED", "CX"] and raw.times is None
    np.testing.assert_array_equal(raw.arrays["SED"].values, [[0.059135, 0.041]])
    # ETABLE,SED,SEND,ELASTIC + ETABLE,X,CENT,X ... + PRETAB,SED,X,Y,Z after each of two SETs: SED at the centroids
    table = ("PRINT ELEMENT TABLE ITEMS PER ELEMENT\n\n  ***** POST1 ELEMENT TABLE LISTING *****\n\n"
             "    STAT     CURRENT     CURRENT     CURRENT     CURRENT\n    ELEM     SED         X           Y           Z\n"
             "       1  {0}      0.25000     0.25000     0.50000\n       2  {1}      0.75000     0.25000     0.50000\n"
             "       3  {2}      0.50000     0.75000     0.50000\n       4  {0}      0.50000     0.50000     0.75000\n")
    two = _write(tmp_path, "etab2.lis", table.format("0.10000E-02", "0.20000E-02", "0.30000E-02")
                 + table.format("0.40000E-02", "0.50000E-02", "0.60000E-02"))
    field = read_sed(two, length_unit="mm", sed_unit="MPa")
    np.testing.assert_allclose(field.sed, [[1e3, 2e3, 3e3, 1e3], [4e3, 5e3, 6e3, 4e3]])
    np.testing.assert_allclose(field.points[1], [0.75e-3, 0.25e-3, 0.5e-3])
    assert field.times.tolist() == [0.0, 1.0] and any("no TIME=" in n for n in field.provenance.notes)


def test_a_listing_deep_in_a_solver_out_file(tmp_path):
    log = "".join(f" *** NOTE ***    CP = {k:.3f}   TIME= 12:00:00\n Solution is done!\n" for k in range(25000))
    text = log + " PRINT S    NODAL SOLUTION PER NODE\n" + _page(1, 1.0, HEADER_S, [
        "       1  0.10000E-02  2.0000      0.0000      0.0000      0.0000      0.0000"]) + SUMMARY + log[:200]
    assert len(log) > 1_000_000 and log.startswith(" *** NOTE")  # the log after the summary is not read as rows
    text = text.replace(" *** NOTE ***    CP = 0.001", "     1   0.001   12.00", 2)  # digits first, after it too
    raw = read_raw(_write(tmp_path, "file.out", text))
    assert raw.arrays["SY"].values.tolist() == [[2.0]]


def test_element_nodal_presol_is_refused(tmp_path):
    text = (" PRINT S    ELEMENT SOLUTION PER ELEMENT\n \n ***** POST1 ELEMENT NODAL STRESS LISTING *****\n \n"
            "  ELEMENT=       1        SOLID185\n" + HEADER_S + "\n"
            "       1 -0.20000E+11  0.0000      0.0000      0.0000      0.0000      0.0000\n")
    with pytest.raises(SEDFormatError, match=r"element-nodal listing .*line 1.*Print PRNSOL,S,COMP"):
        read_raw(_write(tmp_path, "presol.lis", text))
    assert main(["info", str(tmp_path / "presol.lis")]) == 2


def test_nodes_listed_twice_and_powergraphics(tmp_path):
    rows = ["       1  0.20287E-07  91.212      27.364    -0.13603E-02  4.8423    -0.72216E-04",
            "       1 -0.20287E-07 -91.213     -27.364     0.13603E-02 -4.8423     0.72216E-04"]
    text = " PRINT S    NODAL SOLUTION PER NODE\n" + _page(1, 1.0, HEADER_S, rows).replace(
        "LISTING *****", "LISTING *****\n  PowerGraphics Is Currently Enabled") + SUMMARY
    with pytest.raises(SEDFormatError, match=r"each NODE once per load step; got NODE 1 more than once in load step 1 "
                                             r"substep 1 \(TIME= 1.0000\) \(rows at lines 12, 13.*PowerGraphics"):
        read_raw(_write(tmp_path, "twice.lis", text))
    once = _write(tmp_path, "power.lis", text.replace(rows[1] + "\n", ""))
    with pytest.warns(AfferentWarning, match="PowerGraphics enabled: PRNSOL then lists the nodes of the model's "
                                             "exterior surfaces only"):
        raw = read_raw(once)
    assert any("PowerGraphics" in n for n in raw.notes)


def test_steps_with_other_nodes_and_files_that_do_not_match(tmp_path):
    one = "       1  0.10000E-02  2.0000      0.0000      0.0000      0.0000      0.0000"
    two = "       2  0.10000E-02  2.0000      0.0000      0.0000      0.0000      0.0000"
    text = (" PRINT S    NODAL SOLUTION PER NODE\n" + _page(1, 1.0, HEADER_S, [one, two])
            + " PRINT S    NODAL SOLUTION PER NODE\n" + _page(2, 2.0, HEADER_S, [one]))
    with pytest.raises(SEDFormatError, match=r"Every load step of ANSYS MAPDL listing .* must list the same NODEs; "
                                             r"got 2 in load step 1 .* and 1 in load step 2"):
        read_raw(_write(tmp_path, "steps.lis", text))
    s_one = _write(tmp_path, "s.lis", " PRINT S    NODAL SOLUTION PER NODE\n" + _page(1, 1.0, HEADER_S, [one]))
    epel = _page(1, 1.0, HEADER_S.replace(" S", " EPEL"), [two], "POST1 NODAL ELASTIC STRAIN LISTING")
    e_two = _write(tmp_path, "e.lis", " PRINT EPEL NODAL SOLUTION PER NODE\n" + epel)
    with pytest.raises(SEDFormatError, match=r"e.lis' must list the same NODEs at the same steps as .*s.lis' to be "
                                             r"joined side by side"):
        read_raw([s_one, e_two])
    e_late = _write(tmp_path, "late.lis", (" PRINT EPEL NODAL SOLUTION PER NODE\n" + epel.replace(two, one))
                    .replace("TIME=    1.0000", "TIME=    2.0000"))
    with pytest.raises(SEDFormatError, match=r"late.lis' must be printed at the times of .*s.lis' to be joined side "
                                             r"by side; got TIME= \[2.0\] against \[1.0\]"):
        read_raw([s_one, e_late])


def test_listings_without_headers_or_in_another_system(tmp_path):
    bare = " PRINT S    NODAL SOLUTION PER NODE\n       1   -0.2060408000E+07   0.2012382625E+07\n"
    with pytest.raises(SEDFormatError, match=r"must name its columns \(a 'NODE ...' header row\) above its first data "
                                             r"row; got line 2 \('1   -0.2060408000E\+07"):
        read_raw(_write(tmp_path, "bare.lis", bare))
    cyl = " LIST ALL SELECTED NODES.   DSYS=      1\n\n   NODE        X           Y           Z\n" \
          "        1    1.0000      90.000      0.0000\n"
    with pytest.raises(SEDFormatError, match=r"global Cartesian system \(DSYS= 0\); got DSYS= 1 at line 1"):
        read_raw(_write(tmp_path, "nlist.lis", cyl))


def test_cli_info_and_sample_on_listings(tmp_path, capsys):
    assert _quiet(main, ["info", S, EPEL]) == 0
    out = capsys.readouterr().out
    assert "EPELXY" in out and "SXY" in out
    assert "or coordinates='NODES' (an id,x,y,z table, an ANSYS NLIST listing" in out  # how to add them
    assert _quiet(main, ["info", SEND, "--coordinates", NLIST]) == 0
    out = capsys.readouterr().out
    assert "points       99" in out and "SED          'SEND ELASTIC' (point data)" in out
    receptors = tmp_path / "receptors.csv"
    receptors.write_text("id,x,y,z\n1,0.5,0.25,2.0\n2,0.5,0.25,3.0\n")
    code = _quiet(main, ["sample", SEND, "--coordinates", NLIST, "--receptors", str(receptors), "--length-unit", "m",
                         "--sed-unit", "Pa", "--receptor-unit", "m", "--method", "nearest", "-o",
                         str(tmp_path / "sed.csv")])
    assert code == 0
    table = (tmp_path / "sed.csv").read_text().splitlines()
    assert table[0].startswith("receptor") and len(table) == 1 + 2 * 3  # 2 receptors x 3 steps


def test_nlist_in_the_same_output_file_gives_the_coordinates(tmp_path):
    nlist = Path(NLIST).read_text()
    lines = nlist.splitlines()
    lines.insert(5, "      999    7.00000000000        8.00000000000        9.00000000000")  # a node without results
    extra = "\n".join(lines) + "\n"
    both = _write(tmp_path, "run.out", extra + Path(SEND).read_text())
    raw = read_raw(both)
    assert list(raw.arrays) == ["NODE", "SEND ELASTIC", "X", "Y", "Z"]
    assert "coordinates from the NLIST listing (line 2) joined on 'NODE': 100 nodes listed, 99 with results" in raw.notes
    field = _quiet(read_sed, both, length_unit="m", sed_unit="Pa")
    joined = _quiet(read_sed, SEND, coordinates=NLIST, length_unit="m", sed_unit="Pa")
    np.testing.assert_array_equal(field.points, joined.points)
    np.testing.assert_array_equal(field.sed, joined.sed)
    short = _write(tmp_path, "short.out", nlist.replace("        1    0.00000000000", "     1000    0.00000000000")
                   + Path(SEND).read_text())
    with pytest.raises(SEDFormatError, match=r"The NLIST listing of .* \(line 2\) must list every node that has results; "
                                             r"got 1 without coordinates \(first: 1\)"):
        read_raw(short)
    elist = ("\n LIST ALL SELECTED ELEMENTS.  (LIST NODES)\n\n    ELEM MAT TYP REL ESY SEC        NODES\n\n"
             "       1   1   1   1   0   1      1     2     4     3     5     6     8     7\n")
    raw = read_raw(_write(tmp_path, "elist.out", extra + elist + Path(SEND).read_text()))  # an ELIST between them
    assert list(raw.arrays) == ["NODE", "SEND ELASTIC", "X", "Y", "Z"]
    assert "skipped 1 MAPDL list of other items ('LIST ALL SELECTED ELEMENTS.' at line 115)" in raw.notes
    with pytest.raises(SEDFormatError, match=r"must hold results \(PRNSOL, PRETAB\) or node coordinates \(NLIST\); got "
                                             r"only 'LIST ALL SELECTED ELEMENTS.' \(line 2\), which lists the model"):
        read_raw(_write(tmp_path, "elist.lis", elist))
    with pytest.raises(SEDFormatError, match=r"An NLIST listing is a coordinates table: pass it as coordinates="):
        read_raw([SEND, NLIST])
    # a second NLIST with other columns (found by fuzzing: was a bare ValueError from unpacking)
    two = _write(tmp_path, "two.out", nlist + " LIST ALL SELECTED NODES.   DSYS=      0\n\n   NODE        X\n"
                 "        1    0.00000000000\n" + Path(SEND).read_text())
    with pytest.raises(SEDFormatError, match=r"The NLIST listings of ANSYS MAPDL file .* must have the same columns; "
                                             r"got 'NODE', 'X', 'Y', 'Z' and 'NODE', 'X' instead"):
        read_raw(two)
