"""The documentation builds with warnings as errors, and says what it must.

One Sphinx build (``python -m sphinx -W --keep-going -b html docs OUT``, nitpicky: every
cross-reference must resolve) serves every test here. Measured: ~12 s on the 2-core development
machine (cold, including the API stubs), so the test is not marked slow.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    pytest.importorskip("sphinx")
    out = tmp_path_factory.mktemp("html")
    doctrees = tmp_path_factory.mktemp("doctrees")
    # a copy of docs/: the build writes API stubs and notebook copies below its source folder,
    # and parallel test workers must not do that in one tree
    source = tmp_path_factory.mktemp("src") / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("generated", "notebooks", "_build"))
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "-d", str(doctrees),
         str(source), str(out)],
        capture_output=True, text=True, cwd=ROOT, env={"MPLBACKEND": "Agg", **_env(), "AFFERENT_DOCS_ROOT": str(ROOT)},
    )
    assert proc.returncode == 0, f"sphinx-build failed:\n{proc.stderr[-6000:]}"
    return out


def _env():
    import os

    return {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}


def test_build_has_no_warnings(built):
    assert (built / "index.html").is_file()


@pytest.mark.parametrize("page, labels", [
    ("method", ["method-fe-model", "method-sed", "method-transduction", "method-saturation", "method-synthesis",
                "method-comparison", "method-calibration", "method-identifiability", "method-spikes",
                "method-scaling", "method-findings", "method-references"]),
    ("fe-export", ["fe-checklist", "fe-presets", "fe-crosscheck", "fe-negative", "fe-what-is-verified", "fe-abaqus",
                   "fe-ansys", "fe-comsol", "fe-febio", "fe-calculix", "fe-fenics", "fe-lsdyna", "fe-code-aster",
                   "fe-moose", "fe-sfepy", "fe-other"]),
    ("scenes", ["scene-keys"]),
])
def test_stable_labels(built, page, labels):
    """The labels other pages and the package's docstrings point to exist (ids in the HTML)."""
    html = (built / f"{page}.html").read_text(encoding="utf-8")
    missing = [label for label in labels if f'id="{label}"' not in html]
    assert not missing


def test_cli_page_lists_every_subcommand_and_option(built):
    """The CLI page is generated from the parser: every subcommand and every long option appears."""
    from afferent.cli._main import build_parser

    html = (built / "cli.html").read_text(encoding="utf-8")
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, sp in sub.choices.items():
        assert f'id="afferent-{name}"' in html, name
        for action in sp._actions:
            for opt in action.option_strings:
                if opt.startswith("--"):
                    assert opt in html, f"{name} {opt}"


def test_generated_tables_match_the_code(built):
    """Preset, SED-name and scene-key tables come from the code, so every entry is on its page."""
    from afferent.io._columns import SED_ALIASES
    from afferent.scene.schema import _TABLES
    from afferent.strain_energy import PRESETS

    fe = (built / "fe-export.html").read_text(encoding="utf-8")
    for name in [*PRESETS, *SED_ALIASES]:
        assert f'<span class="pre">{name}</span>' in fe, name
    scenes = (built / "scenes.html").read_text(encoding="utf-8")
    for table in _TABLES:
        assert f'<span class="pre">[{table}]</span>' in scenes, table


def test_notebooks_rendered_not_executed(built):
    """Every notebook has a page; a notebook stored without outputs gets none (nothing was executed)."""
    import json

    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        html = (built / "notebooks" / f"{nb.stem}.html").read_text(encoding="utf-8")
        assert 'class="cell docutils container"' in html
        cells = json.loads(nb.read_text(encoding="utf-8"))["cells"]
        if not any(c.get("outputs") for c in cells if c["cell_type"] == "code"):
            assert 'class="output' not in html, nb.name


def test_readme_and_pages_cite_only_what_ships():
    """The method write-up is docs/method.md: no page nor the README points outside the repository
    for it (the study's summary and the format notes are not shipped), and the README links the docs."""
    sources = [ROOT / "README.md", *sorted(DOCS.glob("*.md")), *sorted(DOCS.glob("*.rst"))]
    cited = {p.name: m.group(0) for p in sources
             if (m := re.search(r"\.\./shared|METHOD\.md|FE-FORMATS\.md", p.read_text(encoding="utf-8")))}
    assert not cited
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "make docs" in readme and "(docs/method.md)" in readme


def test_plain_text_docstrings_are_escaped_only_outside_markup():
    """``|x|`` and ``name_`` in prose render as written; literals, roles, math and blocks are untouched."""
    pytest.importorskip("sphinx")
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        from afferent_tables import _escape_plain, _plain_text
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    assert _escape_plain("default the largest |value|.") == r"default the largest \|value\|."
    assert _escape_plain("alpha (A), lambda_ (Pa)") == r"alpha (A), lambda\_ (Pa)"
    assert _escape_plain("``lambda_`` and :math:`|x|` and `link`_") == "``lambda_`` and :math:`|x|` and `link`_"
    assert _escape_plain("**lambda_** : float") == "**lambda_** : float"
    assert _escape_plain("| a | b |") == "| a | b |"  # a table row is not a substitution
    lines = ["Text |x|.", "", ".. math::", "", "    |x| = y_", "", ">>> f(a_)", "", "After b_."]
    _plain_text(None, "function", "f", None, {}, lines)
    assert lines == [r"Text \|x\|.", "", ".. math::", "", "    |x| = y_", "", ">>> f(a_)", "", r"After b\_."]
