"""Sphinx configuration of the afferent documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (``make docs``).
The notebooks in ``notebooks/`` are rendered, never executed here: the test suite executes
them (``tests/test_notebooks.py``).
"""

from __future__ import annotations

import shutil
import sys
import os
from pathlib import Path

DOCS = Path(__file__).resolve().parent
# The test suite builds a copy of docs/ in a temporary folder (parallel workers must not write
# generated stubs into the same tree) and names the repository here.
ROOT = Path(os.environ.get("AFFERENT_DOCS_ROOT", DOCS.parent))
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(ROOT))

import afferent  # noqa: E402

project = "afferent"
author = "afferent developers"
copyright = "afferent developers"
release = afferent.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_nb",  # also loads myst_parser for the Markdown pages
    "sphinxarg.ext",
    "afferent_tables",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

# --- notebooks: shown as stored, never executed by the docs build ---------------------------
nb_execution_mode = "off"
# The teaching notebooks live in ../notebooks (the test suite runs them there); Sphinx only
# reads files below docs/, so they are copied into docs/notebooks/ (git-ignored) at build time.
_NB_SRC = ROOT / "notebooks"
_NB_DST = DOCS / "notebooks"
_NB_DST.mkdir(exist_ok=True)
for _nb in sorted(_NB_SRC.glob("*.ipynb")):
    _target = _NB_DST / _nb.name
    if not _target.exists() or _target.read_bytes() != _nb.read_bytes():
        shutil.copyfile(_nb, _target)
for _stale in _NB_DST.glob("*.ipynb"):
    if not (_NB_SRC / _stale.name).exists():
        _stale.unlink()

# --- MyST -------------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# --- API reference: autosummary + numpydoc ---------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autosummary_ignore_module_all = False  # a module's __all__ is its public API
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"          # numpydoc's Parameters sections carry the types and units
numpydoc_show_class_members = False  # autosummary lists members; avoids duplicate stubs
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
add_module_names = False

# Every cross-reference must resolve (warnings are errors in the test build).
nitpicky = True
# The build is offline (no intersphinx inventories), so references to other projects' objects
# cannot resolve; they are rendered as code.
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|scipy|sklearn|brian2|pandas|meshio|matplotlib|tomllib|pydoe|json|xarray|pynwb|h5netcdf)(\..*)?"),
]
# Docstrings that point at private modules or at constants outside their module's __all__,
# which the API reference does not document (to be made public or reworded in the package).
nitpick_ignore = [
    ("py:mod", "afferent.cli._main"),
    ("py:mod", "afferent.io._assemble"),
    ("py:class", "afferent.io._raw.RawExport"),
    ("py:func", "afferent.io._assemble.tensor_sed_crosscheck"),
    ("py:data", "MAX_RASTER_LABELS"),
    ("py:data", "SCALING_ERROR_WARN"),
    ("py:data", "DEFAULT_TOL"),
    ("py:data", "IDENTIFIABLE_COND"),
    ("py:data", "STAGES"),
    ("py:data", "afferent.scene.OUTPUTS"),
    ("py:func", "afferent.stimulus.no_reference_step_message"),
    ("py:func", "afferent.cli._run.scene_from_args"),
]

# --- HTML -------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"afferent {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path: list[str] = []
