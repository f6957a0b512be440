"""Write the Abaqus report files abaqus_frames.rpt, abaqus_parts.rpt (+ abaqus_parts_nodes.csv) and abaqus_wrapped.rpt
of this folder.

Run from anywhere: ``python tests/data/csv/make_abaqus_rpt.py``. No Abaqus is needed: the layouts
imitate real Abaqus/CAE field reports (Report > Field Output) printed in the Abaqus Getting Started
guide and in public reports (see README.md here: which report each file follows); the values are made up.
"""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).parent


def _source(step: str, increment: int, step_time: str, position: str, sort: str) -> str:
    """The block header Abaqus/CAE writes above a report's tables."""
    return (
        "********************************************************************************\n"
        "Field Output Report, written Mon Dec  8 03:10:45 2025\n\n"
        "Source 1\n---------\n\n"
        "   ODB: /home/u/skin.odb\n"
        f"   Step: {step}\n"
        f"   Frame: Increment {increment:6d}: Step Time = {step_time:>9s}\n\n"
        f"Loc 1 : {position} values from source 1\n\n"
        f'Output sorted by column "{sort}".\n\n'
    )


PARTS = {
    "DERMIS-1": [(1, "0.", "0.", "-1.", ["100.E-06", "400.E-06"]),
                 (2, "1.", "0.", "-1.", ["200.E-06", "800.E-06"]),
                 (3, "0.", "1.", "-1.", ["300.E-06", "1.2E-03"]),
                 (4, "1.", "1.", "-1.", ["1.11111E-03", "4.44444E-03"])],
    "EPIDERMIS-1": [(1, "0.", "0.", "0.", ["33.3333E-06", "133.333E-06"]),
                    (2, "500.E-03", "500.E-03", "-0.", ["2.5E-03", "10.E-03"])],
}


def _frames(coord: bool = True) -> str:
    """Two frames of step 'Indent', each with two parts (instances) whose node labels both start at 1; with the
    nodes' COORD columns, or (``coord=False``) SENER alone, the reference positions then given by
    abaqus_parts_nodes.csv."""
    out = []
    for k, (inc, t) in enumerate(((5, "0.5000"), (10, "1.000"))):
        out.append(_source("Indent", inc, t, "Nodal", "Node Label"))
        for part, rows in PARTS.items():
            out.append(f"Field Output reported at nodes for part: {part}\n\n")
            if coord:
                out.append("            Node     COORD.COOR1     COORD.COOR2     COORD.COOR3           SENER\n"
                           "           Label          @Loc 1          @Loc 1          @Loc 1          @Loc 1\n"
                           + "-" * 81 + "\n")
            else:
                out.append("            Node           SENER\n           Label          @Loc 1\n" + "-" * 33 + "\n")
            for label, x, y, z, sed in rows:
                out.append(f"{label:16d}" + (f"{x:>16s}{y:>16s}{z:>16s}" if coord else "") + f"{sed[k]:>16s}\n")
            cols = ([[r[1] for r in rows], [r[2] for r in rows], [r[3] for r in rows]] if coord else []) + [
                [r[4][k] for r in rows]]
            lo = [min(range(len(c)), key=lambda i, c=c: float(c[i])) for c in cols]
            hi = [max(range(len(c)), key=lambda i, c=c: float(c[i])) for c in cols]
            out.append("\n\n  Minimum       " + "".join(f"{c[i]:>16s}" for c, i in zip(cols, lo)) + "\n"
                       "         At Node" + "".join(f"{rows[i][0]:>16d}" for i in lo) + "\n\n"
                       "  Maximum       " + "".join(f"{c[i]:>16s}" for c, i in zip(cols, hi)) + "\n"
                       "         At Node" + "".join(f"{rows[i][0]:>16d}" for i in hi) + "\n\n\n")
    return "".join(out)


def _part_nodes() -> str:
    """The reference positions of both parts' nodes, keyed by (part, label): the table --coordinates reads."""
    return "Part,Node Label,X,Y,Z\n" + "".join(
        f"{part},{label},{float(x):g},{float(y):g},{float(z):g}\n"
        for part, rows in reversed(PARTS.items()) for label, x, y, z, _ in rows)


def _wrapped() -> str:
    """An integration-point report wrapped at a page width: 6 values on a record's first line, 6 on its second."""
    out = [_source("Indent", 10, "1.000", "Integration point", "Element Label"),
           "Field Output reported at integration points for part: SKIN-1\n\n",
           "Element   Int  COORD.COOR1  COORD.COOR2  COORD.COOR3        SENER\n"
           "Label     Pt        @Loc 1       @Loc 1       @Loc 1       @Loc 1\n" + "-" * 65 + "\n",
           "        S.S11        S.S22        S.S33        S.S12        S.S13        S.S23\n"
           "       @Loc 1       @Loc 1       @Loc 1       @Loc 1       @Loc 1       @Loc 1\n" + "-" * 78 + "\n"]
    records = [
        (1, 1, "211.325E-03", "211.325E-03", "-788.675E-03", "1.5E-03", ["-3.E-03", "-1.E-03", "-10.E-03", "500.E-06", "-250.E-06", "125.E-06"]),
        (1, 2, "788.675E-03", "211.325E-03", "-788.675E-03", "2.5E-03", ["-4.E-03", "-2.E-03", "-12.E-03", "0.", "-0.", "62.5E-06"]),
        (2, 1, "1.21132", "211.325E-03", "-788.675E-03", "750.E-06", ["-2.E-03", "-500.E-06", "-8.E-03", "-125.E-06", "250.E-06", "0."]),
        (2, 2, "1.78868", "211.325E-03", "-788.675E-03", "333.333E-06", ["-1.E-03", "-250.E-06", "-4.E-03", "31.25E-06", "0.", "-15.625E-06"]),
    ]
    for el, ip, x, y, z, sed, s in records:
        out.append(f"{el:5d}{ip:6d}{x:>13s}{y:>13s}{z:>13s}{sed:>13s}\n")
        out.append("".join(f"{v:>13s}" for v in s) + "\n")
    out.append("\n\n  Minimum   " + "".join(f"{v:>13s}" for v in ("211.325E-03", "211.325E-03", "-788.675E-03", "333.333E-06")) + "\n"
               + "".join(f"{v:>13s}" for v in ("-4.E-03", "-2.E-03", "-12.E-03", "-125.E-06", "-250.E-06", "-15.625E-06")) + "\n"
               + "      At Element" + "".join(f"{v:>13d}" for v in (1, 1, 1, 2)) + "\n" + "".join(f"{v:>13d}" for v in (1, 1, 1, 2, 1, 2)) + "\n"
               + "          Int Pt" + "".join(f"{v:>13d}" for v in (1, 1, 1, 2)) + "\n" + "".join(f"{v:>13d}" for v in (2, 2, 2, 1, 1, 2)) + "\n"
               + "  Maximum   " + "".join(f"{v:>13s}" for v in ("1.78868", "211.325E-03", "-788.675E-03", "2.5E-03")) + "\n"
               + "".join(f"{v:>13s}" for v in ("-1.E-03", "-250.E-06", "-4.E-03", "500.E-06", "250.E-06", "125.E-06")) + "\n"
               + "      At Element" + "".join(f"{v:>13d}" for v in (2, 1, 1, 1)) + "\n" + "".join(f"{v:>13d}" for v in (2, 2, 2, 1, 2, 1)) + "\n"
               + "          Int Pt" + "".join(f"{v:>13d}" for v in (2, 1, 1, 2)) + "\n" + "".join(f"{v:>13d}" for v in (2, 2, 2, 1, 1, 1)) + "\n")
    return "".join(out)


if __name__ == "__main__":
    (HERE / "abaqus_frames.rpt").write_text(_frames())
    (HERE / "abaqus_parts.rpt").write_text(_frames(coord=False))
    (HERE / "abaqus_parts_nodes.csv").write_text(_part_nodes())
    (HERE / "abaqus_wrapped.rpt").write_text(_wrapped())
