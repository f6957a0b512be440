"""The package's shape: short functions, modules of one concern, and a module tree (docs/contributing.md) that matches the code.

Rules (issue 13), checked with :mod:`ast` on every module of ``afferent/``:

- **Functions**: at most :data:`MAX_FUNCTION_LINES` lines, counted from the ``def`` line to the
  function's last line, *docstring excluded* (decorators excluded too). A numpydoc docstring
  states every parameter with its unit; its length says nothing about how much the function
  does, and cutting it would cut documentation, not logic. Nested functions count inside their
  parent and are also checked on their own.
- **Modules**: at most :data:`MAX_MODULE_LINES` lines (the whole file), unless the module's
  docstring holds a line starting with ``Size:`` that says why it is longer.
- **docs/contributing.md**: the "The code's layout" tree names every module file and subpackage of ``afferent/``.

A function or module over the limit that this change may not edit is listed in
:data:`FUNCTION_ALLOWLIST` with the reason; an entry that is no longer needed fails the test,
so the list only shrinks.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "afferent"

MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 600

#: ("path/relative/to/afferent", "qualified.function.name") -> reason it may stay long for now.
FUNCTION_ALLOWLIST: dict[tuple[str, str], str] = {}


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _docstring_lines(node) -> int:
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        return body[0].end_lineno - body[0].lineno + 1
    return 0


def function_lengths(source: str) -> dict[str, int]:
    """Qualified name -> length in lines from ``def`` to the last line, docstring excluded."""
    out: dict[str, int] = {}

    def visit(node, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                out[name] = child.end_lineno - child.lineno + 1 - _docstring_lines(child)
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return out


def _long_functions() -> dict[tuple[str, str], int]:
    long = {}
    for path in _modules():
        rel = path.relative_to(PACKAGE).as_posix()
        for name, n in function_lengths(path.read_text(encoding="utf-8")).items():
            if n > MAX_FUNCTION_LINES:
                long[(rel, name)] = n
    return long


def test_the_length_rule_excludes_the_docstring_and_counts_nested_functions():
    doc = '    """One.\n\n    Two.\n    """\n'
    src = "def f(x):\n" + doc + "    y = x\n\n    def g():\n        return y\n    return g\n"
    assert function_lengths(src) == {"f": 6, "f.g": 2}  # def + 5 code lines; the 4 docstring lines not counted
    src = "class C:\n    @property\n    def p(self):\n        return 1\n"
    assert function_lengths(src) == {"C.p": 2}


def test_no_function_over_the_limit():
    long = {k: n for k, n in _long_functions().items() if k not in FUNCTION_ALLOWLIST}
    assert not long, (f"functions over {MAX_FUNCTION_LINES} lines (docstring excluded); cut them into named steps: "
                      + ", ".join(f"{p}:{f} ({n} lines)" for (p, f), n in sorted(long.items())))


def test_the_allowlist_holds_only_long_functions():
    stale = sorted(set(FUNCTION_ALLOWLIST) - set(_long_functions()))
    assert not stale, f"allowlisted functions that are no longer over the limit (remove them from the list): {stale}"


def _size_reason(path: Path) -> str | None:
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    for line in doc.splitlines():
        if line.startswith("Size:") and len(line.split(":", 1)[1].strip()) > 10:
            return line
    return None


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(PACKAGE).as_posix())
def test_module_size_is_within_the_limit_or_explained(path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    if n > MAX_MODULE_LINES:
        assert _size_reason(path), (f"{path.relative_to(ROOT)} has {n} lines (limit {MAX_MODULE_LINES}): split it by "
                                    "concern, or say why not in a docstring line starting 'Size:'")


def _development_tree() -> str:
    text = (ROOT / "docs" / "contributing.md").read_text(encoding="utf-8")
    m = re.search(r"^## The code's layout\n.*?^```text\n(.*?)^```", text, flags=re.S | re.M)
    assert m, "docs/contributing.md has no \"## The code's layout\" section with a fenced tree"
    return m.group(1)


def test_readme_development_tree_names_every_module():
    tree = _development_tree()
    names = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*\.py|[A-Za-z_][A-Za-z0-9_]*/", tree))
    missing = []
    for path in _modules():
        if path.name in ("__init__.py", "__main__.py"):
            continue
        if path.name not in names:
            missing.append(path.relative_to(PACKAGE).as_posix())
    for pkg in sorted({p.parent for p in _modules()} - {PACKAGE}):
        if pkg.name + "/" not in names:
            missing.append(pkg.relative_to(PACKAGE).as_posix() + "/")
    assert not missing, f"docs/contributing.md's tree does not name: {missing}"


def test_readme_development_tree_names_only_what_exists():
    tree = _development_tree()
    files = {p.name for p in _modules()} | {p.parent.name + "/" for p in _modules()}
    top = {"afferent/", "tests/", "benchmarks/", "notebooks/", "sample_sed/", "docs/", "fuzz/", "data/"}
    named = set(re.findall(r"^\s*([A-Za-z_][A-Za-z0-9_]*(?:\.py|/))", tree, flags=re.M))
    ghost = sorted(named - files - top)
    assert not ghost, f"docs/contributing.md's tree names modules that do not exist: {ghost}"


#: The orchestra: what chains the stages (the Python API's pipeline, scenes, sweeps, the commands, the
#: report). Every other module of afferent/ is a stage or a tool the stages share, and imports none of them.
ORCHESTRA = ("afferent.pipeline", "afferent.scene", "afferent._sweep", "afferent.cli", "afferent.report")


def _module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, root: Path = ROOT) -> set[str]:
    """Every module (and ``module.name``) that ``path`` (a file of the package under ``root``) imports, at its top
    or inside a function, relative imports resolved."""
    name = _module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                head = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(head + ([node.module] if node.module else []))
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def test_imported_modules_resolves_relative_imports(tmp_path):
    pkg = tmp_path / "afferent" / "calibration"
    pkg.mkdir(parents=True)
    (pkg / "entry.py").write_text("from ..pipeline import make_branching\ndef f():\n    from .. import scene\n")
    assert {"afferent.pipeline", "afferent.pipeline.make_branching", "afferent.scene"} <= \
        imported_modules(pkg / "entry.py", tmp_path)


def test_the_stages_never_import_the_orchestra():
    """No stage module imports afferent.pipeline, scene, _sweep, cli or report, not even inside a function
    (fails before: calibration/entry.py imported make_branching from afferent.pipeline)."""
    bad = []
    for path in _modules():
        name = _module_name(path)
        if name in ("afferent", "afferent.__main__") or name.startswith(ORCHESTRA):
            continue
        for imp in sorted(imported_modules(path)):
            if any(imp == o or imp.startswith(o + ".") for o in ORCHESTRA):
                bad.append(f"{path.relative_to(PACKAGE).as_posix()} imports {imp}")
    assert not bad, "stage modules importing the orchestra (move the function to its stage): " + "; ".join(bad)

