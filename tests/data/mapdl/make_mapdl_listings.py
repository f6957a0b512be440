"""Write MAPDL text listings (PRNSOL S / EPEL / SEND, NLIST) of the MAPDL result file shipped with
ansys-mapdl-reader, in the layout MAPDL prints them, for afferent's tests.

    python tests/data/mapdl/make_mapdl_listings.py        # needs ansys-mapdl-reader (the 'ansys' extra)

The values are the reader's: ``examples.rstfile`` (a SOLID186 beam, modal analysis, MAPDL's own
file), result sets 1-3 (substeps 1-3 of load step 1, ``FREQ=`` as MAPDL prints for a modal
run), nodal stress S and elastic strain EPEL (X Y Z XY YZ XZ, engineering shear) at the 99 corner
nodes that have them, the node coordinates; SEND is 1/2 S:EPEL (engineering shear, so
SXY*EPELXY counts once) at those nodes. The layout (title, page banner every 37 rows, LOAD STEP /
SUBSTEP / FREQ lines, 'NODE  SX ...' header, I8 node numbers, G12.5 values, MINIMUM / MAXIMUM VALUES
summaries; NLIST,,,,COORD with its header every 20 rows and G21.12 coordinates) follows the real
listings named in README.md. The SEND listing's banner and column title ('ELASTIC') are not
verified on a real listing.
"""

from __future__ import annotations

import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SETS = (0, 1, 2)
ROWS_PER_PAGE = 37


def fortran_g(value: float, w: int, d: int) -> str:
    """Fortran ``Gw.d`` as MAPDL writes it: F(w-4).x plus 4 blanks for 0.1 <= |v| < 10**d (and 0), else Ew.d."""
    a = abs(value)
    if a == 0.0:
        return f"{0.0:{w - 4}.{d - 1}f}" + " " * 4
    rounded = float(f"{a:.{d - 1}e}")
    if 0.1 <= rounded < 10 ** d:
        digits = d - (int(np.floor(np.log10(rounded))) + 1)
        text = f"{value:{w - 4}.{digits}f}" if digits > 0 else f"{value:{w - 5}.0f}."
        return text + " " * 4
    mantissa, exponent = f"{a:.{d - 1}e}".split("e")
    m = "0." + mantissa.replace(".", "")
    e = int(exponent) + 1
    text = f"{'-' if value < 0 else ''}{m}E{'-' if e < 0 else '+'}{abs(e):02d}"
    return text.rjust(w)


def _page_header(banner: str, step: int | None, freq: float | None, note: str, names: list[str]) -> list[str]:
    lines = [" ", f"  ***** {banner} *****".ljust(79), " "]
    if step is not None:
        lines += [f"  LOAD STEP=     1  SUBSTEP={step:6d}".ljust(79),
                  f"   FREQ={fortran_g(freq, 10, 5).rstrip():>10s}      LOAD CASE=   0".ljust(79), " "]
    lines += [f"  {note}".ljust(79), " ", "    NODE" + "".join(f"    {n:<8s}" for n in names)]
    return lines


def prnsol(item: str, banner: str, names: list[str], nodes: np.ndarray, steps: list) -> str:
    """One PRNSOL listing per result set (SET then PRNSOL), as /OUTPUT writes them one after another."""
    out = []
    for step, freq, values in steps:
        out += [f" PRINT {item:<4s} NODAL SOLUTION PER NODE"]
        for start in range(0, nodes.size, ROWS_PER_PAGE):
            out += _page_header(banner, step, freq, "THE FOLLOWING X,Y,Z VALUES ARE IN GLOBAL COORDINATES", names)
            for n, row in zip(nodes[start:start + ROWS_PER_PAGE], values[start:start + ROWS_PER_PAGE]):
                out.append(f"{n:8d} " + "".join(fortran_g(v, 12, 5) for v in row).rstrip())
        for what, pick in (("MINIMUM", np.argmin), ("MAXIMUM", np.argmax)):
            at = pick(values, axis=0)
            out += ["", f" {what} VALUES", " NODE   " + "".join(f"{nodes[k]:{8 if j == 0 else 12}d}" for j, k in
                                                                enumerate(at)),
                    " VALUE  " + "".join(fortran_g(values[k, j], 12, 5) for j, k in enumerate(at)).rstrip()]
        out.append("")
    return "\n".join(out) + "\n"


def nlist(nodes: np.ndarray, xyz: np.ndarray) -> str:
    out = ["", " LIST ALL SELECTED NODES.   DSYS=      0", " SORT TABLE ON  NODE  NODE  NODE"]
    for start in range(0, nodes.size, 20):
        out += ["", "   NODE        X                   Y                   Z"]
        out += [f"{n:9d}" + "".join(fortran_g(v, 21, 12) for v in p) for n, p in zip(nodes[start:start + 20],
                                                                                   xyz[start:start + 20])]
    return "\n".join(out) + "\n"


def results():
    """(node numbers, coordinates, [(set, freq, S, EPEL, SEND)]) of the reader's example file."""
    from ansys.mapdl import reader
    from ansys.mapdl.reader import examples

    rst = reader.read_binary(examples.rstfile)
    steps = []
    keep = None
    for k in SETS:
        nnum, s = rst.nodal_stress(k)
        nnum_e, e = rst.nodal_elastic_strain(k)
        assert np.array_equal(nnum, nnum_e)
        e = e[:, :6]  # X Y Z XY YZ XZ (the 7th is EQV)
        ok = ~np.isnan(s).any(axis=1) & ~np.isnan(e).any(axis=1)
        keep = ok if keep is None else keep & ok
        send = 0.5 * (s[:, :3] * e[:, :3]).sum(axis=1) + 0.5 * (s[:, 3:] * e[:, 3:]).sum(axis=1)
        steps.append((k + 1, float(rst.time_values[k]), s, e, send[:, None]))
    index = {int(n): i for i, n in enumerate(rst.mesh.nnum)}
    xyz = rst.mesh.nodes[[index[int(n)] for n in nnum]][:, :3]
    return nnum[keep], xyz[keep], [(st, f, s[keep], e[keep], d[keep]) for st, f, s, e, d in steps]


def main() -> None:
    nodes, xyz, steps = results()
    files = {
        "beam_s.lis": prnsol("S", "POST1 NODAL STRESS LISTING", ["SX", "SY", "SZ", "SXY", "SYZ", "SXZ"], nodes,
                             [(st, f, s) for st, f, s, _, _ in steps]),
        "beam_epel.lis": prnsol("EPEL", "POST1 NODAL ELASTIC STRAIN LISTING",
                                ["EPELX", "EPELY", "EPELZ", "EPELXY", "EPELYZ", "EPELXZ"], nodes,
                                [(st, f, e) for st, f, _, e, _ in steps]),
        "beam_send.lis": prnsol("SEND", "POST1 NODAL STRAIN ENERGY DENSITY LISTING", ["ELASTIC"], nodes,
                                [(st, f, d) for st, f, _, _, d in steps]),
        "beam_nlist.lis": nlist(nodes, xyz),
    }
    for name, text in files.items():
        with open(os.path.join(HERE, name), "w", newline="\n") as fh:
            fh.write(text)
        print(f"wrote {name}: {len(text):,} bytes")


if __name__ == "__main__":
    main()
