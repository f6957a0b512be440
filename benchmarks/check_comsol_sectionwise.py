"""Re-run the checks of afferent's COMSOL Sectionwise reader on real COMSOL exports one points it at.

    python benchmarks/check_comsol_sectionwise.py FILE ...
    python benchmarks/check_comsol_sectionwise.py --mirror /work/.mirror      # the real files named below

For each file (COMSOL Results > Export > Data, Data format: Sectionwise), with afferent's own section finder:

- **layout**: the preamble keys (``% Model:``, ``% Version:``, ``% Dimension:``, ``% Nodes:``, ``% Elements:``,
  ``% Length unit:``), then one ``% Coordinates`` section, one ``% Elements (type)`` section and the ``% Data (...)``
  sections, nothing else;
- **counts**: the rows of each section against ``% Nodes:`` / ``% Elements:`` / ``% Expressions:`` (one data
  section per expression and time), one value a point in every
  ``% Data`` section;
- **numbering**: the element rows hold whole numbers from 1 to the number of points, and use both ends (1-based:
  a 0-based file would hold 0 and never the last);
- **reader**: ``read_raw`` reads a 3D export (points, tetrahedra, times, units) and refuses a 2D one by name.

The real files are not kept in this repository (docs/fe-export.md, COMSOL, names them with their repository and
commit); ``--mirror`` finds them in local snapshots (``<mirror>/<owner>+<name>/repo``, a bare git directory).
Exit status 1 when a check fails, 0 otherwise.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from afferent.exceptions import SEDFormatError  # noqa: E402
from afferent.io import read_raw  # noqa: E402
from afferent.io._csv_blocks import _sectionwise_sections  # noqa: E402
from afferent.io._csv_table import _comsol_meta  # noqa: E402

#: (repository, commit, path): real COMSOL sectionwise exports found in public repositories.
REAL = [
    ("pjuangph/MGN", "08136d322df7b955144c301160d7ef5710016ebc", "data/mesh_comsol_output.txt"),  # COMSOL 5.5, 2D
]


def git_show(mirror: str, repo: str, commit: str, path: str) -> bytes | None:
    git_dir = os.path.join(mirror, repo.replace("/", "+"), "repo")
    out = subprocess.run(["git", "--git-dir", git_dir, "show", f"{commit}:{path}"], capture_output=True)
    return out.stdout if out.returncode == 0 else None


def check(path: str) -> list[str]:
    """The failed checks of one file (empty: all passed); prints what was found."""
    lines = open(path, encoding="utf-8", errors="replace").read().splitlines()
    pre, sections = _sectionwise_sections(path, lines)
    meta = _comsol_meta(pre, 0)
    kinds = [s[0] for s in sections]
    print(f"{path}\n  preamble  {', '.join(f'{k}: {v[0]}' for k, v in meta.items())}")
    print(f"  sections  {', '.join(f'{k} ({t})' if t else k for k, t, _, _ in sections)}")
    failed = []
    if kinds[:2] != ["coordinates", "elements"] or set(kinds[2:]) - {"data"}:
        failed.append(f"section order {kinds}")
    coords = np.array([lines[i].split() for i in sections[0][3]], dtype=float)
    elems = np.array([lines[i].split() for i in sections[1][3]], dtype=float)
    for key, n in (("nodes", len(coords)), ("elements", len(elems)), ("expressions", len(sections) - 2)):
        if key in meta and int(meta[key][0]) != n:
            failed.append(f"% {key}: {meta[key][0]} but {n} rows")
    for _, title, line, rows in sections[2:]:
        if len(rows) != len(coords):
            failed.append(f"% Data ({title}) at line {line}: {len(rows)} values for {len(coords)} points")
    whole = bool(np.all(elems == np.round(elems)))
    low, high = int(elems.min()), int(elems.max())
    print(f"  points    {coords.shape[0]} x {coords.shape[1]} coordinates; elements {elems.shape[0]} x "
          f"{elems.shape[1]} numbers from {low} to {high}{'' if whole else ' (not whole)'}")
    if not whole or low != 1 or high != len(coords):
        failed.append(f"element numbers {low}..{high} for {len(coords)} points: not 1-based")
    try:
        raw = read_raw(path, format="csv")
        print(f"  read      {raw.points.shape[0]} points, {raw.cells.n_cells} cells, times {raw.times}, "
              f"arrays {[(a.name, a.unit) for a in raw.arrays.values()]}, length unit {raw.length_unit}")
        if meta.get("dimension", ("3",))[0] != "3":
            failed.append("a 2D export was read")
    except SEDFormatError as err:
        print(f"  refused   {err}")
        if meta.get("dimension", ("3",))[0] == "3" or "3D export" not in str(err):
            failed.append(f"refused: {err}")
    return failed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*")
    parser.add_argument("--mirror", help="folder of local repository snapshots holding the files of REAL")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="comsol-real-") as tmp:
        files = list(args.files)
        for repo, commit, rel in REAL if args.mirror else []:
            data = git_show(args.mirror, repo, commit, rel)
            if data is None:
                print(f"{repo}@{commit[:8]}:{rel}: not in {args.mirror}; skipped")
                continue
            files.append(os.path.join(tmp, f"{repo.replace('/', '+')}+{os.path.basename(rel)}"))
            with open(files[-1], "wb") as f:
                f.write(data)
        bad = 0
        for path in files:
            failed = check(path)
            print("  " + ("FAILED: " + "; ".join(failed) if failed else "ok"))
            bad += bool(failed)
    return 1 if bad or not files else 0

if __name__ == "__main__":
    sys.exit(main())
