"""The README and the pages it points to (issue 37, "A README for researchers"): short, with a table of the
flags each FE tool's export needs that `afferent info` reads on the tools' own files, and no citation of a
section or link that does not exist (a README section that moved, a renamed heading).

* the README is under 20 KB and its Quick start is the two commands (``.ci/run`` runs the second);
* every row of the per-tool table that names a file of ``tests/data`` is read with its flags: ``afferent info``
  exits 0 and :func:`afferent.read_sed` with the options those flags parse to gives a finite SED;
* the README's Python example runs, and its comment names the columns ``to_dataframe`` returns;
* every ``README "Section"`` / ``docs/x.md, "Section"`` citation in the code, docs, samples, benchmarks and
  tests names a heading (or a bold paragraph label) of that file, and every relative link of README.md and
  docs/*.md reaches a file, and its anchor a heading there.
"""

from __future__ import annotations

import importlib.util
import re
import shlex
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TEXT = README.read_text(encoding="utf-8")
MAX_BYTES = 20_000


def _section(text: str, heading: str) -> str:
    """The body of the ``## heading...`` section of ``text`` (up to the next ``## ``)."""
    part = re.split(rf"^## {re.escape(heading)}.*$", text, maxsplit=1, flags=re.M)
    assert len(part) == 2, f"no section '## {heading}'"
    return re.split(r"^## ", part[1], maxsplit=1, flags=re.M)[0]


def test_readme_is_short_and_starts_with_the_two_commands():
    assert len(TEXT.encode("utf-8")) < MAX_BYTES, f"README.md is {len(TEXT.encode())} bytes (limit {MAX_BYTES})"
    quick = _section(TEXT, "Quick start")
    assert "```sh\nmake demo\nmake test\n```" in quick
    assert (ROOT / ".ci" / "run").read_text(encoding="utf-8").rstrip().splitlines()[-1] == "make test"


# ------------------------------------------------------------------ the per-tool table
def _tool_rows() -> list[tuple[str, str, str, list[str]]]:
    """(tool, export, flags, [checked-on entries]) of the README's per-tool table."""
    body = _section(TEXT, "Your own export")
    rows = []
    for line in body.splitlines():
        if not line.startswith("| ") or line.startswith("| tool |"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        assert len(cells) == 4, line
        tool, export, flags, checked = cells
        flags = "" if flags == "none" else flags.strip("`")
        files = [] if checked == "-" else [c.strip("`") for c in checked.split("`, `")]
        rows.append((tool, export, flags, files))
    return rows


TOOL_ROWS = _tool_rows()
CHECKS = [(tool, export, flags, entry) for tool, export, flags, files in TOOL_ROWS for entry in files]


def test_the_table_names_every_tool_the_docs_cover():
    tools = " ".join(t for t, *_ in TOOL_ROWS)
    for name in ("Abaqus", "ANSYS MAPDL", "ANSYS Workbench", "COMSOL", "FEBio", "CalculiX", "FEniCS / DOLFINx",
                 "SfePy", "MOOSE", "code_aster", "Kratos", "FreeFEM", "GetFEM", "deal.II", "NGSolve", "MFEM", "LS-DYNA", "Elmer"):
        assert name in tools, name
    assert len(CHECKS) >= 20
    for tool, export, flags, _ in TOOL_ROWS:  # every flag the table names is one the readers take
        assert not flags or flags.startswith("--"), (tool, flags)


@pytest.mark.parametrize("tool, export, flags, entry", CHECKS, ids=[f"{c[0]}:{c[3].split()[0]}" for c in CHECKS])
def test_each_tool_row_reads_its_test_file_with_its_flags(tool, export, flags, entry, capsys, monkeypatch):
    import afferent
    from afferent.cli import main
    from afferent.cli._main import build_parser
    from afferent.cli._options import input_kwargs

    if "extra `vtk`" in export:
        pytest.importorskip("vtk")
    monkeypatch.chdir(ROOT)  # the table's paths are relative to the repository
    first, *rest = shlex.split(entry)
    path = ROOT / first
    assert path.is_file() and first.startswith(("tests/data/", "sample_sed/")), f"the table names {first}"
    argv = ["info", first, *rest, *shlex.split(flags)]
    assert main(argv) == 0, capsys.readouterr().err
    assert "afferent: error" not in capsys.readouterr().err
    args = build_parser(argv).parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # negative nodal SED, coincident copies, ...: the rows' files show them
        field = afferent.read_sed(first, **input_kwargs(args))
    assert field.sed.size > 0 and np.all(np.isfinite(field.sed))


# ------------------------------------------------------------------ each format and the extra it needs
#: One real-tool test file (under tests/data) per format of afferent.io.FORMATS, read in a child process that can
#: import only the default install (benchmarks/read_test_files.py's); "rst": ansys-mapdl-reader's example file.
FORMAT_FILES = {"csv": "calculix/block_c3d8.dat", "vtu": "ngsolve/block.vtu", "vtk": "sfepy/block.vtk",
                "pvtu": "dealii/block_00.pvtu", "vtm": "kratos/vtu/Structure_1.vtm", "vtkhdf": "vtkhdf/block.vtkhdf",
                "ensight": "ensight/openfoam_binary/foam.case", "pvd": "ngsolve/block.pvd", "xdmf": "dolfinx/block.xdmf",
                "frd": "calculix/block_c3d8.frd", "exodus": "exodus/layers_ioss.e", "rst": None,
                "med": "med/block_hexa.rmed", "xplt": "febio/block_hex8.xplt", "msh": "gmsh/block_v41_ascii.msh",
                "pos": "gmsh/block_views.pos"}
#: A format the default install reads only in part: a second file, which needs an extra.
PARTLY = {"vtk": "freefem/block_point.vtk"}
#: Names of a format besides its file-name endings (afferent.io.FORMATS).
ALIASES = {"csv": "CSV", "vtu": "VTU", "pvd": "PVD", "xdmf": "XDMF", "exodus": "Exodus", "ensight": "EnSight",
           "vtkhdf": "VTKHDF", "med": "MED"}


def _names(text: str, fmt: str) -> bool:
    """Whether ``text`` names the format ``fmt``: one of its endings, or its name."""
    from afferent.io import FORMATS

    endings = "|".join(re.escape(e) for e in FORMATS[fmt])
    alias = rf"|\b{ALIASES[fmt]}\b" if fmt in ALIASES else ""
    return re.search(rf"(?<![\w.])(?:{endings})(?!\w|\.\w){alias}", text) is not None


def _bench():
    """benchmarks/read_test_files.py as a module."""
    spec = importlib.util.spec_from_file_location("_read_test_files", ROOT / "benchmarks" / "read_test_files.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def test_the_benchmark_names_the_tools_the_data_readmes_name():
    """Each tool and version benchmarks/read_test_files.py prints is one the folder's README.md states."""
    for key, (tool, said) in _bench().TOOLS.items():
        readme = ROOT / "tests" / "data" / key.split("/")[0] / "README.md"
        if said:
            assert said in readme.read_text(encoding="utf-8"), f"{readme} does not say {said!r} ({tool})"


def test_the_docs_table_of_test_files_lists_every_file_the_benchmark_reads():
    """docs/fe-export.md's "Which install reads which test file" is the benchmark's output: a test file added,
    renamed or removed without regenerating it shows here."""
    doc = (ROOT / "docs" / "fe-export.md").read_text(encoding="utf-8")
    section = doc.split("## Which install reads which test file", 1)[1].split("\n## ", 1)[0]
    listed = {f"{m.group(1)}/{m.group(2).removesuffix(' (imitation)')}"
              for m in re.finditer(r"^\| ([^|]+?) \| ([^|]+?) \|", section, re.M) if m.group(1) not in ("folder", "---")}
    bench = _bench()
    files = {bench._rel(path) for path, _, _ in bench.test_files()}
    shipped = {f for f in listed | files if f.startswith("ansys-mapdl-reader/")}  # there when ansys-mapdl-reader is
    assert listed - shipped == files - shipped and len(files) > 100


def _read_by_default(paths: list[str]) -> list[str | None]:
    """For each file, None if the default install reads it, else the extra its error names."""
    import json

    bench = _bench()
    job = json.dumps({"paths": paths, "allowed": sorted(bench.default_modules())})
    got = [json.loads(line) for line in bench._child(["--child-default"], job).splitlines()]
    assert all(g["ok"] or g["extra"] for g in got), [g for g in got if not g["ok"] and not g["extra"]]
    return [None if g["ok"] else g["extra"] for g in got]


def test_the_readme_names_each_format_with_the_extra_the_default_install_lacks():
    """Measured, not declared: each format's test file is read where only the default install can be imported;
    the README's install lines, its sentence on the default install and its per-tool table must agree."""
    from afferent.io import FORMATS

    ansys = importlib.util.find_spec("ansys.mapdl.reader")
    if ansys is None:
        pytest.skip("the ANSYS .rst example comes with ansys-mapdl-reader (the test extra)")
    rst = str(Path(ansys.origin).parent / "examples" / "file.rst")
    assert set(FORMAT_FILES) == set(FORMATS), "a new format needs a test file here"
    paths = [str(ROOT / "tests" / "data" / f) if f else rst for f in [*FORMAT_FILES.values(), *PARTLY.values()]]
    extras = _read_by_default(paths)
    always = dict(zip(FORMAT_FILES, extras))
    partly = dict(zip(PARTLY, extras[len(FORMAT_FILES):]))
    assert set(always.values()) - {None} and None in always.values()  # both kinds, or the child measured nothing
    install = _section(TEXT, "Quick start").split("### Install", 1)[1]
    lines = {m.group(1): m.group(2) for m in re.finditer(r"^pip install 'afferent-skin\[(\w+)\]'\s+# (.*)$", install, re.M)}
    default = re.search(r"The default install reads every other format \((.*?)\)", " ".join(install.split())).group(1)
    for fmt in FORMATS:
        for extra in {always[fmt], partly.get(fmt)} - {None}:
            assert _names(lines[extra], fmt), f"the README's `[{extra}]` install line does not name {fmt}"
        if always[fmt] is None:
            assert _names(default, fmt), f"the README's sentence on the default install does not name {fmt}"
        else:
            assert not _names(default, fmt), f"the README says the default install reads {fmt}; it needs [{always[fmt]}]"
        rows = [export for _, export, _, _ in TOOL_ROWS if _names(export, fmt)]
        assert rows, f"no row of the README's per-tool table names {fmt}"
        for export in rows if always[fmt] else ():
            assert f"extra `{always[fmt]}`" in export, f"the row '{export}' names {fmt} but not its extra [{always[fmt]}]"


def test_format_names_are_found_where_they_are_and_only_there():
    assert _names("`.vtk` cell data", "vtk") and _names("the legacy .vtk files, and", "vtk")
    assert not _names("`.vtkhdf`", "vtk") and not _names("a `.vtk.series`", "vtk") and not _names("i.e. e.g.", "exodus")
    assert _names("`.rmed`/`.med`", "med") and _names("VTU/`.vtm` output", "vtu") and not _names("VTUS", "vtu")


# ------------------------------------------------------------------ the Python example
@pytest.mark.parametrize("page", ["README.md", "docs/getting-started.md"])
def test_python_example_runs_and_names_the_columns(page, monkeypatch):
    text = (ROOT / page).read_text(encoding="utf-8")
    code = next(b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "to_dataframe()" in b)
    comment = re.search(r"to_dataframe\(\)\s+# (.*)", code).group(1)
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(code, page, "exec"), namespace)
    assert list(namespace["afferents"].to_dataframe().columns) == [c.strip() for c in comment.split(",")]


# ------------------------------------------------------------------ citations of sections, links
_CITE = re.compile(r"(?P<file>\bREADME(?:\.md)?|\b(?:[\w.-]+/)*[\w.-]+\.md)`?,?\s+(?:section\s+)?"
                   r"(?:\"(?P<title>[^\"\n]{2,100})\"|'(?P<title2>[^'\n]{2,100})')")
_LINK = re.compile(r"(?<!!)\[[^\]\n]*\]\((?P<target>[^)\s]+)\)")
_CITING = ["afferent/**/*.py", "docs/*.md", "README.md", "sample_sed/**/*.py", "sample_sed/**/*.md",
           "sample_sed/**/*.toml", "benchmarks/*.py", "tests/*.py", "fuzz/*.py", "pyproject.toml", "Makefile"]


def _plain(text: str) -> str:
    return " ".join(text.replace("`", "").replace("*", "").split()).rstrip(":.")


def _without_code(md: str) -> str:
    return re.sub(r"^(```|~~~).*?^\1", "", md, flags=re.S | re.M)


def headings(md: str) -> list[str]:
    """The headings of a Markdown text (outside fenced code) and its bold paragraph labels, as plain text."""
    body = _without_code(md)
    found = [_plain(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.*?)\s*#*$", body, flags=re.M)]
    return found + [_plain(m.group(1)) for m in re.finditer(r"\*\*([^*\n]+?)\*\*", body)]


def names_heading(title: str, heads: list[str]) -> bool:
    """``title`` is a heading (its section number optional), or the start of one up to its colon, parenthesis or
    'of ...' tail."""
    title = _plain(title)
    heads = heads + [re.sub(r"^\d+\.\s+", "", h) for h in heads]
    return any(h == title or (h.startswith(title) and h[len(title):].startswith((":", " (", " of ")))
               for h in heads)


def slug(heading: str) -> str:
    """The anchor GitHub (and MyST's heading anchors) give a heading."""
    return re.sub(r"[^\w\- ]", "", _plain(heading).lower()).replace(" ", "-")


def _cited_file(name: str, citing: Path) -> Path | None:
    if name.startswith("README"):
        for folder in [citing.parent, *citing.parent.parents]:
            if (folder / "README.md").is_file():
                return folder / "README.md"
            if folder == ROOT:
                break
        return None
    for base in (ROOT, citing.parent, ROOT / "docs"):
        if (base / name).is_file():
            return base / name
    return None


def citation_errors(text: str, citing: Path) -> list[str]:
    """Each ``FILE "Section"`` citation in ``text`` whose file or section does not exist, as a sentence."""
    errors = []
    for m in _CITE.finditer(text):
        target = _cited_file(m.group("file"), citing)
        where = f"{citing.relative_to(ROOT) if citing.is_relative_to(ROOT) else citing}: {m.group(0)!r}"
        if target is None:
            errors.append(f"{where} cites a file that does not exist")
        elif not names_heading(m.group("title") or m.group("title2"), headings(target.read_text(encoding="utf-8"))):
            errors.append(f"{where}: {target.relative_to(ROOT)} has no such section")
    return errors


def link_errors(md: str, page: Path) -> list[str]:
    """Each relative link of the Markdown ``md`` (of ``page``) whose file or anchor does not exist."""
    errors = []
    for m in _LINK.finditer(_without_code(md)):
        target = m.group("target")
        if re.match(r"[a-z]+:", target) or target.startswith("{"):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            errors.append(f"{page.name}: link {target!r}: no file {path}")
        elif anchor and dest.suffix == ".md":
            if anchor not in {slug(h) for h in headings(dest.read_text(encoding="utf-8"))}:
                errors.append(f"{page.name}: link {target!r}: no heading with anchor #{anchor} in {path or page.name}")
    return errors


def _citing_files() -> list[Path]:
    files = {p for pattern in _CITING for p in ROOT.glob(pattern) if p.is_file()}
    return sorted(files - {Path(__file__).resolve()})


def test_every_cited_section_exists():
    files = _citing_files()
    assert len(files) > 100
    errors = [e for p in files for e in citation_errors(p.read_text(encoding="utf-8", errors="replace"), p)]
    assert not errors, "\n".join(errors)


def test_every_relative_link_of_the_readme_and_docs_resolves():
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    errors = [e for p in pages for e in link_errors(p.read_text(encoding="utf-8"), p)]
    assert not errors, "\n".join(errors)
    assert "docs/fe-export.md#" in TEXT  # the README does link into sections (so the anchor check runs)


def test_the_checks_catch_a_section_or_link_that_moved():
    """A README section that no longer exists (the code cited README "Speed on the default install" before it moved
    to docs/performance.md), a misspelt one and a link to a missing anchor or file are each found; the real ones
    pass."""
    code = ROOT / "afferent" / "export.py"
    readme_cite = "README " + '"' + "Speed on the default install" + '"'  # built: this file holds no bad citation
    assert citation_errors(f"pandas is not imported ({readme_cite}): measured", code) == [
        f"afferent/export.py: {readme_cite!r}: README.md has no such section"]
    assert citation_errors('see docs/cli.md, "Outputs and --overwritten"', code)
    assert citation_errors('see docs/nowhere.md, "Outputs"', code)
    assert not citation_errors('see docs/cli.md, "Outputs and --overwrite"; docs/method.md, "Receptor sites"', code)
    assert not citation_errors('(sample_sed/README.md, "Vibration series")', code)
    assert citation_errors('(`sample_sed/README.md`, "Vibration serie")', code)  # quoted as code too
    assert not citation_errors('docs/fe-export.md, "Each cell\'s own shape functions"', code)  # an apostrophe inside
    assert link_errors("[a](docs/cli.md#no-such-heading)", README)
    assert link_errors("[a](docs/missing.md)", README)
    assert not link_errors("[a](docs/cli.md#outputs-and---overwrite) [b](https://example.org/#x)", README)
