"""Which install reads which real-tool test file, and how fast (issue 36, item 2).

Run from the repository root, with the python of a venv holding every extra::

    python benchmarks/read_test_files.py [--markdown] [--repeat 3]

The files: every mesh file tests/test_every_array.py checks (its ``_files()``: tests/data less the
hand-made folders), the files it leaves out on purpose (its ``_REFUSED``: listed as refused, not as
failures), and the table files real tools wrote that it leaves out: CalculiX's ``.dat`` prints, the MAPDL
listings of tests/data/mapdl (MAPDL's layout, ansys-mapdl-reader's values: imitations, counted apart) and
the MAPDL result file ``file.rst`` that ansys-mapdl-reader ships (when installed). tests/data/csv is
hand-written (its README) and is left out.

For each file, in a fresh child process: the first :func:`afferent.io.read_raw` (the reader's imports
included; ``import afferent.io`` is done before the clock starts) and the median of ``--repeat`` more
reads in the same, now warm, process (ms, wall time). Then, in one child where **only the default
install** can be imported, a read of each file: a :data:`sys.meta_path` finder refuses every top-level
module that neither the standard library nor a distribution of the default install (pyproject.toml's
``dependencies`` and what they require, as installed here) provides: VTK, pyvista, ansys-mapdl-reader,
pyarrow, dask, pynwb, netCDF4 and everything else of the extras. The verdict is "yes", or the extra the
error names (``pip install 'afferent-skin[X]'``), or the error itself (a failure).

The tool and version of each file come from :data:`TOOLS` (each folder's README.md says them; the test
tests/test_readme.py checks that each README still names the version given here).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"

#: folder (or folder/file, which wins) -> (tool and version, a string its README.md holds). Source: the README.md;
#: ansys-mapdl-reader's example file.rst: that package's examples module.
TOOLS = {
    "calculix": ("CalculiX 2.20", "CrunchiX 2.20"),
    "dealii": ("deal.II 9.4.1", "deal.II 9.4.1"),
    "dolfinx": ("DOLFINx 0.5.2", "DOLFINx 0.5.2"),
    "ensight/openfoam_ascii": ("OpenFOAM 1912 (foamToEnsight)", "1912.200626"),
    "ensight/openfoam_binary": ("OpenFOAM 1912 (foamToEnsight)", "1912.200626"),
    "ensight/vtk": ("VTK 9.7.2 (vtkEnSightWriter)", "VTK 9.7.2"),
    "exodus": ("SfePy 2026.3 + VTK 9.7.2 (vtkIOSSWriter)", "VTK 9.7.2's `vtkIOSSWriter`"),
    "exodus/layers_sfepy.e": ("SfePy 2026.3 (meshio 5.3.5, netCDF-4)", "SfePy 2026.3 itself"),
    "febio": ("FEBio 4.11.0", "FEBio 4.11.0"),
    "freefem": ("FreeFEM 4.11", "FreeFEM 4.11"),
    "getfem": ("GetFEM 5.4.2", "GetFEM 5.4.2"),
    "gmsh": ("Gmsh 4.15.2", "Gmsh 4.15.2"),
    "kratos": ("Kratos 10.4.4", "Kratos Multiphysics 10.4.4"),
    "mapdl": ("imitation: MAPDL layout, ansys-mapdl-reader 0.56.0 values", "ansys-mapdl-reader` 0.56.0"),
    "med": ("medcoupling 9.15.0 (code_aster layout)", "medcoupling 9.15.0"),
    "med/kratos_block.med": ("KratosMedApplication 10.4.4", "KratosMedApplication 10.4.4"),
    "mfem": ("MFEM 4.10 (PyMFEM 4.10.0.1)", "PyMFEM 4.10.0.1"),
    "ngsolve": ("NGSolve 6.2.2608", "NGSolve 6.2.2608"),
    "sfepy": ("SfePy 2026.3", "SfePy 2026.3"),
    "vtk": ("VTK 9.7.2", "VTK 9.7.2"),
    "vtkhdf": ("VTK 9.7.2 (vtkHDFWriter)", "VTK 9.7.2"),
    "ansys-mapdl-reader/examples": ("MAPDL (the example ansys-mapdl-reader ships)", ""),
    "vtkhdf/steps.vtkhdf.series": ("VTK 9.7.2 files; the .series by make_vtkhdf.py", "written by the script"),
}


def tool_of(rel: str) -> tuple[str, str]:
    """(tool and version, the README string) of a file named relative to tests/data."""
    parts = rel.split("/")
    for n in range(len(parts), 0, -1):
        key = "/".join(parts[:n])
        if key in TOOLS:
            return TOOLS[key]
    return ("?", "")


def _every_array():
    spec = importlib.util.spec_from_file_location("_every_array", DATA.parent / "test_every_array.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_files() -> list[tuple[str, str, str]]:
    """(path, kind, why) of each file: kind 'mesh', 'table', 'imitation' or 'refused' (why: its reason)."""
    every = _every_array()
    out = [(p, "mesh", "") for p in every._files()]
    out += [(str(DATA / rel), "refused", why) for rel, why in every._REFUSED.items()]
    out += [(str(p), "table", "") for p in sorted((DATA / "calculix").glob("*.dat*"))]
    out += [(str(p), "imitation", "") for p in sorted((DATA / "mapdl").glob("*.lis"))]
    spec = importlib.util.find_spec("ansys.mapdl.reader")
    if spec is not None and spec.origin:
        rst = Path(spec.origin).parent / "examples" / "file.rst"
        if rst.is_file():
            out.append((str(rst), "table", ""))
    return sorted(out, key=lambda row: (_rel(row[0]), row[1]))


def _rel(path: str) -> str:
    p = Path(path).resolve()
    return str(p.relative_to(DATA)) if p.is_relative_to(DATA) else "ansys-mapdl-reader/examples/" + p.name


# -- the child processes ----------------------------------------------------------------------------------------


def default_modules() -> set[str]:
    """Top-level module names of the default install: its distributions' modules, as installed here."""
    import tomllib
    from importlib import metadata

    sys.path.insert(0, str(Path(__file__).parent))
    from install_size import _closure, _name, _requires

    from packaging.requirements import Requirement

    installed = {_name(d.metadata["Name"]): d for d in metadata.distributions()}
    graph = {n: _requires(d, installed) for n, d in installed.items()}
    with open(ROOT / "pyproject.toml", "rb") as fh:
        deps = tomllib.load(fh)["project"]["dependencies"]
    roots = {_name(r.name) for r in map(Requirement, deps) if r.marker is None or r.marker.evaluate({"extra": ""})}
    dists = set().union(*(_closure(r, graph) for r in roots))
    modules = {"afferent"}
    for module, owners in metadata.packages_distributions().items():
        if any(_name(o) in dists for o in owners):
            modules.add(module)
    return modules


class _Blocker:
    """A meta-path finder refusing every top-level module outside ``allowed`` and the standard library."""

    def __init__(self, allowed: set[str]) -> None:
        self.allowed, self.refused = allowed | set(sys.stdlib_module_names), set()

    def find_spec(self, name, path=None, target=None):
        top = name.partition(".")[0]
        if top not in self.allowed and not top.startswith("_sysconfigdata"):  # the interpreter's own build data
            self.refused.add(top)
            raise ImportError(f"{top} is not in the default install (blocked by benchmarks/read_test_files.py)")
        return None


def _child_default(paths: list[str], allowed: list[str]) -> None:
    blocker = _Blocker(set(allowed))
    sys.meta_path.insert(0, blocker)
    import warnings

    warnings.simplefilter("ignore")
    from afferent.io import read_raw

    for path in paths:
        blocker.refused.clear()
        try:
            read_raw(path)
            got = {"ok": True}
        except Exception as err:  # noqa: BLE001 - the verdict is the error
            extra = re.search(r"afferent-skin\[(\w+)\]", str(err))
            got = {"ok": False, "extra": extra.group(1) if extra else None,
                   "error": f"{type(err).__name__}: {str(err)[:160]}", "blocked": sorted(blocker.refused)}
        print(json.dumps({"path": path, **got}), flush=True)


def _child_time(path: str, repeat: int) -> None:
    import warnings

    warnings.simplefilter("ignore")
    from afferent.io import format_of, read_raw

    t = time.perf_counter()
    try:
        read_raw(path)
    except Exception as err:  # noqa: BLE001
        print(json.dumps({"error": f"{type(err).__name__}: {str(err)[:160]}", "format": format_of(path)}))
        return
    first = time.perf_counter() - t
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        read_raw(path)
        times.append(time.perf_counter() - t)
    print(json.dumps({"first": first, "median": statistics.median(times), "format": format_of(path)}))


def _child(args: list[str], stdin: str | None = None) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    done = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=600, input=stdin)
    if done.returncode:
        raise RuntimeError(f"child {args[:2]} failed: {done.stderr[-2000:]}")
    return done.stdout


# -- the table --------------------------------------------------------------------------------------------------


def measure(repeat: int) -> list[dict]:
    files = test_files()
    allowed = sorted(default_modules())
    rows = []
    for path, kind, why in files:
        row = {"path": path, "file": _rel(path), "kind": kind, "why": why, "tool": tool_of(_rel(path))[0]}
        if kind != "refused":
            row.update(json.loads(_child(["--child-time", path, str(repeat)])))
        rows.append(row)
    readable = [r for r in rows if r["kind"] != "refused"]
    job = json.dumps({"paths": [r["path"] for r in readable], "allowed": allowed})
    verdicts = [json.loads(line) for line in _child(["--child-default"], job).splitlines()]
    for row, got in zip(readable, verdicts):
        row["default"] = got
    return rows


def _verdict(row: dict) -> str:
    if row["kind"] == "refused":
        return f"refused on purpose ({row['why']})"
    if "error" in row:
        return f"FAILS with every extra: {row['error']}"
    got = row["default"]
    if got["ok"]:
        return "yes"
    if got["extra"]:
        return f"needs [{got['extra']}]"
    return f"FAILS: {got['error']} (blocked: {', '.join(got['blocked'])})"


def report(rows: list[dict], markdown: bool, command: str) -> str:
    from afferent import __version__

    vtk = importlib.util.find_spec("vtkmodules") is not None
    said = (f"afferent {__version__}, Python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} CPUs"
            f" (load average {os.getloadavg()[0]:.1f} at the end){', VTK installed' if vtk else ', no VTK'}; times: wall ms, first read in a fresh process (reader imports "
            "included) / median of the next reads")
    lines = [f"Measured with `{command}` ({said}):" if markdown else f"$ {command}\n{said}", ""]
    head = ("folder", "file", "tool", "format", "first ms", "median ms", "default install")
    body = []
    for r in rows:
        folder, _, name = r["file"].rpartition("/")
        ms = ("", "") if "first" not in r else (f"{1e3 * r['first']:.1f}", f"{1e3 * r['median']:.1f}")
        body.append((folder, name + (" (imitation)" if r["kind"] == "imitation" else ""), r["tool"],
                     r.get("format", ""), *ms, _verdict(r)))
    if markdown:
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(c.replace("|", "/") for c in b) + " |" for b in body]
    else:
        widths = [max(len(str(x[i])) for x in [head, *body]) for i in range(len(head) - 1)]
        for b in [head, *body]:
            lines.append("  ".join(str(c).ljust(w) for c, w in zip(b, widths)) + "  " + b[-1])
    real = [r for r in rows if r["kind"] in ("mesh", "table")]
    yes = [r for r in real if "default" in r and r["default"]["ok"]]
    lines += ["", f"Real-tool files the default install reads: {len(yes)} of {len(real)} ({100 * len(yes) / len(real):.0f} %); "
              f"refused on purpose (left out): {sum(r['kind'] == 'refused' for r in rows)}; imitations (left out): "
              f"{sum(r['kind'] == 'imitation' for r in rows)}, read by the default install: "
              f"{sum(r['kind'] == 'imitation' and r['default']['ok'] for r in rows)}."]
    extras: dict[str, list[str]] = {}
    for r in real:
        if "default" in r and not r["default"]["ok"]:
            extras.setdefault(r["default"]["extra"] or "none named (a failure)", []).append(r["file"])
    for extra, names in sorted(extras.items()):
        lines.append(f"Needs [{extra}]: {len(names)} file(s): {', '.join(names)}.")
    failures = [r["file"] for r in rows if _verdict(r).startswith("FAILS")]
    lines.append(f"Failures: {', '.join(failures) if failures else 'none'}.")
    if markdown:  # the summary as a list
        at = len(lines) - lines[::-1].index("")
        lines[at:] = ["- " + line for line in lines[at:]]
    return "\n".join(lines)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child-time"]:
        _child_time(argv[1], int(argv[2]))
        return 0
    if argv[:1] == ["--child-default"]:
        job = json.load(sys.stdin)
        _child_default(job["paths"], job["allowed"])
        return 0
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--markdown", action="store_true", help="print the table as Markdown (docs/fe-export.md)")
    parser.add_argument("--repeat", type=int, default=3, help="warm reads after the first, per file (median)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    command = "python benchmarks/read_test_files.py" + (" --markdown" if args.markdown else "") + \
        (f" --repeat {args.repeat}" if args.repeat != 3 else "")
    print(report(measure(args.repeat), args.markdown, command))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
