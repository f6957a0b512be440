"""The teaching notebooks: they run top to bottom on the bundled sample, use the public API only,
leak no warning, end with an exercise whose answer is hidden, and are stored with the outputs of
their own code (``notebooks/execute_notebooks.py`` executes and stores them)."""

from __future__ import annotations

import importlib.util
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
SAMPLE = ROOT / "sample_sed" / "block4" / "receptors.csv"
#: The topics; a renamed or lost notebook fails here rather than silently leaving the list.
EXPECTED = ["01_read_fe_export", "02_receptors_and_sampling", "03_transduction_and_synthesis", "04_calibration",
            "05_spikes", "06_speed_vs_accuracy", "07_chapter4", "08_sa1"]
#: A private name of the package: ``afferent._x``, ``afferent.io._csv``, ``from afferent.cli._info import``.
PRIVATE = re.compile(r"\bafferent(\.\w+)*\._\w+|from\s+\.?_\w+\s+import")


#: Run first in the kernel of test_notebook_runs: every figure the notebook displays (the inline backend
#: renders it through ``print_figure``) goes through tests/_figcheck.py, whose findings (a legend over data,
#: overlapping labels, no title, ...) are written to stderr, where the leak check below finds them;
#: a last cell prints how many figures were checked (the test compares it with the figures shown).
FIGCHECK_CELL = """\
import importlib.util as _u, sys as _sys
from matplotlib.backend_bases import FigureCanvasBase as _Canvas
_spec = _u.spec_from_file_location("_figcheck", {figcheck!r})
_figcheck = _u.module_from_spec(_spec)
_spec.loader.exec_module(_figcheck)
_print_figure, _checked = _Canvas.print_figure, []
def _checked_print_figure(self, *args, **kwargs):
    _checked.append(1)
    for problem in _figcheck.figure_problems(self.figure):
        _sys.stderr.write(f"figure check: {{problem}}\\n")
    return _print_figure(self, *args, **kwargs)
_Canvas.print_figure = _checked_print_figure
"""
# the count comes back as the cell's result, one message: a print() is several writes the kernel
# may flush as separate stream outputs under load (CI once saw "figures checked:" alone)
FIGCHECK_COUNT = "len(_checked)"


def _executor():
    spec = importlib.util.spec_from_file_location("execute_notebooks", ROOT / "notebooks" / "execute_notebooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _code_cells(nb):
    return [c for c in nb.cells if c.cell_type == "code"]


def _leaks(nb) -> list[str]:
    """stderr streams (warnings, tracebacks) and errors in a notebook's outputs."""
    out = []
    for i, cell in enumerate(nb.cells):
        for o in cell.get("outputs", []):
            if o.get("output_type") == "error":
                out.append(f"cell {i}: {o.get('ename')}: {o.get('evalue')}")
            elif o.get("output_type") == "stream" and o.get("name") == "stderr":
                out.append(f"cell {i}: stderr: {o.get('text', '')[:300]}")
    return out


def test_the_notebooks_are_there():
    assert [p.stem for p in NOTEBOOKS] == EXPECTED


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_public_api_only(path):
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    for cell in _code_cells(nb):
        assert not PRIVATE.search(cell.source), f"{path.name}: private name in\n{cell.source}"
    text = "\n".join(c.source for c in nb.cells)
    assert "METHOD.md" not in text  # users never get that file; the docs' Method page is cited instead


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_ends_with_exercise_and_hidden_answer(path):
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    *_, exercise, answer = nb.cells
    assert exercise.cell_type == "markdown" and "## Exercise" in exercise.source
    assert answer.cell_type == "code" and answer.source.startswith("# Answer")
    # JupyterLab collapses it; myst-nb (the docs) hides input and output behind a toggle
    assert answer.metadata["jupyter"] == {"source_hidden": True, "outputs_hidden": True}
    assert "hide-cell" in answer.metadata["tags"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_stored_outputs_come_from_the_stored_code(path):
    """The docs render the stored outputs without executing: they must be a clean run of this code."""
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    stored = nb.metadata.get("afferent", {}).get("code_sha256")
    assert stored == _executor().code_digest(nb), (
        f"{path.name} was edited after it was executed; run: python notebooks/execute_notebooks.py {path.relative_to(ROOT)}"
    )
    counts = [c.execution_count for c in _code_cells(nb)]
    assert counts == list(range(1, len(counts) + 1)), f"{path.name}: not one top-to-bottom run: {counts}"
    assert not _leaks(nb)
    # each notebook draws where a reader would look (the docs show these stored figures)
    assert any("image/png" in o.get("data", {}) for c in _code_cells(nb) for o in c.outputs), f"{path.name}: no figure"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    if not SAMPLE.is_file():
        pytest.skip("sample_sed not generated")
    # ipykernel then picks its inline backend, as in JupyterLab and in the stored outputs
    monkeypatch.delenv("MPLBACKEND", raising=False)
    # the kernel imports the package of this checkout, not whichever one is installed
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    nb = nbformat.read(path, as_version=4)
    nb.cells.insert(0, nbformat.v4.new_code_cell(FIGCHECK_CELL.format(figcheck=str(ROOT / "tests" / "_figcheck.py"))))
    nb.cells.append(nbformat.v4.new_code_cell(FIGCHECK_COUNT))
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}})
    client.execute()
    # no error, no warning the notebook does not catch and explain itself, no figure the layout checker flags
    assert not _leaks(nb)
    shown = sum("image/png" in o.get("data", {}) for c in _code_cells(nb) for o in c.outputs)
    # every figure shown was checked (figures the package saves as PNG, e.g. a scene's plots, are checked too)
    (result,) = [o for o in nb.cells[-1].outputs if o["output_type"] == "execute_result"]
    checked = int(result["data"]["text/plain"])
    assert shown and checked >= shown, (checked, shown)
