"""Check afferent's reading of ANSYS MAPDL text listings against real MAPDL listings (not shipped).

    python benchmarks/check_mapdl_listings.py [--mirror DIR] [--speed NODES]

The real listings are files of public repositories (named below with their commits), read from
local git copies under ``--mirror`` (default ``/work/.mirror``, one ``owner+name/repo`` git
directory per repository, as the project's search tool fetches them); a repository that is not
there is skipped. Nothing of them is committed to afferent. What is checked, per file:

* pymapdl-reader ``tests/elements/solid186/prnsol_s.txt`` (MAPDL's PRNSOL,S of the reader's
  shipped ``examples.rstfile``, printed without column headers): its six value columns against the
  reader's ``nodal_stress`` of that file (the order SX SY SZ SXY SYZ SXZ, the units: none, as stored);
  afferent refuses the headerless listing, naming the line.
* pymapdl-reader ``tests/elements/shell181/test_shell181.py``: the PRNSOL and PRESOL listings in
  its docstring (pages, PowerGraphics, MINIMUM/MAXIMUM VALUES): both refused with their reasons (shell
  top/bottom rows, element-nodal rows).
* pymapdl ``tests/test_commands.py`` ``PRNSOL_OUT_LONG`` (MAPDL 2021 R2: the run's banner, 3-digit
  exponents with abutting values ``-0.70653E+007-0.40380E+007``, TOTAL VALUES): read, against the
  numbers split by hand.
* perryjohnson/ansys_utils ``PRNSOL.lis`` (PRNSOL,U,Y, NSORT-ed, 1,005 pages) and ``NLIST.lis``,
  and three more NLIST listings: read, against a plain parse of their rows.
* MahsaScript ``stressANSYS`` / ``strainANSYS`` (PRESOL of LINK180 elements): refused; an ELIST
  (``LIST ALL SELECTED ELEMENTS``) alone: refused (no results), skipped beside listings.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from afferent.exceptions import SEDFormatError  # noqa: E402
from afferent.io._csv import read_csv  # noqa: E402

READER = ("ansys/pymapdl-reader", "0f7498616374328e8489f46fc35e478419546bd1")
CASES = [
    # (repository, commit, path, how to check)
    (*READER, "tests/elements/solid186/prnsol_s.txt", "solid186"),
    (*READER, "tests/elements/shell181/test_shell181.py", "shell181"),
    ("ansys/pymapdl", "5e5a47594ed8320a211117602b6debd8d0a8e424", "tests/test_commands.py", "prrsol"),
    ("perryjohnson/ansys_utils", "15a0654f648f8199815c2f30d05f0cc63e72e8b9", "PRNSOL.lis", "rows"),
    ("perryjohnson/ansys_utils", "15a0654f648f8199815c2f30d05f0cc63e72e8b9", "NLIST.lis", "rows"),
    ("MahsaScript/Matlab_Finite_Element_Methode_Stress_Strain_3D", "257150a6774cfd64e07382ad91468bbf3d398348",
     "NLIST.lis", "rows"),
    ("SanthoshKumarArroju/Finite_Element_Analysis", "27b223dac0eb27534c9d3e5560ce855b1d34e51e", "NLIST.lis", "rows"),
    ("BaoxuanWang/Blade_model_and_results_2026", "4176decad200604ae6f26fbeb6c8deae6c1374d6", "NLIST.lis", "rows"),
    ("SanthoshKumarArroju/Finite_Element_Analysis", "350e0921373456bbcbdee684b4f420c2d97910f4", "ELIST.lis", "elist"),
    ("MahsaScript/Matlab_Finite_Element_Methode_Stress_Strain_3D", "257150a6774cfd64e07382ad91468bbf3d398348",
     "stressANSYS", "presol"),
    ("MahsaScript/Matlab_Finite_Element_Methode_Stress_Strain_3D", "257150a6774cfd64e07382ad91468bbf3d398348",
     "strainANSYS", "presol"),
]


def git_show(mirror: str, repo: str, commit: str, path: str) -> str | None:
    base = os.path.join(mirror, repo.replace("/", "+"), "repo")
    for git_dir in (base, os.path.join(base, ".git")):
        if os.path.isdir(git_dir):
            out = subprocess.run(["git", "--git-dir", git_dir, "show", f"{commit}:{path}"], capture_output=True)
            if out.returncode == 0:
                return out.stdout.decode("latin-1")
    return None


def refused(path: str, words: str) -> str:
    try:
        read_csv(path)
    except SEDFormatError as err:
        assert words in str(err), str(err)
        return f"refused: {str(err)[:110]}..."
    raise AssertionError(f"{path} was read; expected it refused ({words!r})")


def check_solid186(path: str, text: str) -> str:
    from ansys.mapdl import reader
    from ansys.mapdl.reader import examples

    rows = np.array([[float(v) for v in line.split()] for line in text.splitlines() if re.match(r"^\s*\d", line)])
    nnum, stress = reader.read_binary(examples.rstfile).nodal_stress(0)
    ok = ~np.isnan(stress).any(axis=1)
    assert np.array_equal(nnum[ok], rows[:, 0])
    scale = np.abs(stress[ok]).max(axis=0)
    worst = (np.abs(stress[ok] - rows[:, 1:]) / scale).max(axis=0)
    assert (worst < 1e-6).all(), worst
    words = refused(path, "must name its columns")
    return (f"{rows.shape[0]} nodes x 6 columns = reader's nodal_stress SX SY SZ SXY SYZ SXZ (max relative "
            f"difference per column {worst.max():.1e}); afferent {words}")


def check_shell181(tmp: str, text: str) -> str:
    doc = text.split('"""')[1]
    nodal = doc[doc.index(" PRINT S    NODAL"):].split("####")[0]
    element = doc[doc.index(" PRINT S    ELEMENT"):].split("####")[0]
    out = []
    for name, body, words in (("prnsol", nodal, "top and bottom surfaces"), ("presol", element, "element-nodal")):
        p = os.path.join(tmp, f"shell181_{name}.lis")
        with open(p, "w") as fh:
            fh.write(body)
        out.append(f"{name.upper()} {refused(p, words)}")
    return "; ".join(out)


def check_prrsol(tmp: str, text: str) -> str:
    body = re.search(r'PRNSOL_OUT_LONG = """(.*?)"""', text, re.S).group(1)
    p = os.path.join(tmp, "prrsol.lis")
    with open(p, "w") as fh:
        fh.write(body)
    raw = read_csv(p)
    fx, fy = raw.arrays["FX"].values[0], raw.arrays["FY"].values[0]
    assert np.allclose(fx, [0.12875e8, -0.15120e7, -0.70653e7, -0.42978e7], rtol=0, atol=0)
    assert np.allclose(fy, [0.42667e7, 0.22476e7, -0.40380e7, -0.24763e7], rtol=0, atol=0)
    return f"read FX, FY of 4 nodes exactly (abutting values split, banner and TOTAL VALUES skipped); {raw.times=}"


def check_rows(path: str, text: str) -> str:
    t0 = time.perf_counter()
    raw = read_csv(path)
    seconds = time.perf_counter() - t0
    number = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:E[-+]?\d+)?", re.I)  # also splits '-0.73051E-01-0.82345'
    rows = [number.findall(line) for line in text.splitlines() if re.match(r"^\s*\d+\s+[-+.\dE]+(\s|$)", line)
            and "VERSION=" not in line]
    width = max(len(r) for r in rows)
    plain = np.array([[float(v) for v in r] for r in rows if len(r) == width])
    plain = plain[np.argsort(plain[:, 0], kind="stable")]
    names = list(raw.arrays)[:width]
    got = np.stack([raw.arrays[n].values[0] for n in names], axis=1)
    assert np.array_equal(got, plain), "values differ from the plain parse"
    abutting = sum(bool(re.search(r"[\d.][-+]\d", line.split(None, 1)[-1].replace("E-", "").replace("E+", "")))
                   for line in text.splitlines() if re.match(r"^\s*\d+\s", line))
    return (f"{got.shape[0]} rows x {', '.join(names)} = the plain parse ({abutting} rows with abutting values); "
            f"{seconds:.2f} s, {len(text):,} bytes")


def speed(n_nodes: int, repeats: int = 3) -> None:
    """Read time of a PRNSOL,S listing of ``n_nodes`` nodes x 3 load steps (written by the test data's script,
    random values) against the same numbers as a plain whitespace table with a time column."""
    import importlib.util

    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "mapdl",
                        "make_mapdl_listings.py")
    spec = importlib.util.spec_from_file_location("make_mapdl_listings", here)
    make = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make)
    rng = np.random.default_rng(1)
    nodes = np.arange(1, n_nodes + 1)
    steps = [(k, float(k), rng.normal(0, 1e3, (n_nodes, 6))) for k in (1, 2, 3)]
    with tempfile.TemporaryDirectory() as tmp:
        listing = os.path.join(tmp, "s.lis")
        with open(listing, "w") as fh:
            fh.write(make.prnsol("S", "POST1 NODAL STRESS LISTING", ["SX", "SY", "SZ", "SXY", "SYZ", "SXZ"], nodes,
                                 steps).replace("FREQ=", "TIME="))
        table = os.path.join(tmp, "s.txt")
        with open(table, "w") as fh:
            fh.write("time node sx sy sz sxy syz sxz\n")
            for k, t, v in steps:
                fh.write("".join(f"{t} {n} " + " ".join(f"{x:.5g}" for x in row) + "\n" for n, row in zip(nodes, v)))
        for label, path in (("MAPDL listing", listing), ("plain table", table)):
            times = []
            for _ in range(repeats):
                t0 = time.process_time()
                read_csv(path)
                times.append(time.process_time() - t0)
            print(f"{label}: {n_nodes:,} nodes x 3 steps, {os.path.getsize(path) / 1e6:.1f} MB: "
                  f"read_csv median {sorted(times)[len(times) // 2]:.2f} s CPU of {repeats}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mirror", default="/work/.mirror")
    parser.add_argument("--speed", type=int, metavar="NODES", help="also time a listing of NODES nodes x 3 steps")
    args = parser.parse_args()
    if args.speed:
        speed(args.speed)
    with tempfile.TemporaryDirectory() as tmp:
        for repo, commit, path, how in CASES:
            text = git_show(args.mirror, repo, commit, path)
            label = f"{repo}@{commit[:7]}:{path}"
            if text is None:
                print(f"SKIP {label} (no local copy)")
                continue
            local = os.path.join(tmp, re.sub(r"\W", "_", f"{repo}_{path}") + ".lis")
            with open(local, "w", encoding="latin-1") as fh:
                fh.write(text)
            result = {"solid186": lambda: check_solid186(local, text), "shell181": lambda: check_shell181(tmp, text),
                      "prrsol": lambda: check_prrsol(tmp, text), "rows": lambda: check_rows(local, text),
                      "presol": lambda: refused(local, "element-nodal"),
                      "elist": lambda: refused(local, "which lists the model, not results")}[how]()
            print(f"OK   {label}: {result}")


if __name__ == "__main__":
    main()
