"""What the default install weighs: the size on disk of every distribution a venv holds, and what
each of afferent-skin's direct dependencies brings that no other one needs (its "exclusive" size: what
leaving that one requirement out would save; 0 for numpy, which the others need too).

Run it with the python of a fresh venv holding only the package::

    python3.11 -m venv /tmp/v && /tmp/v/bin/pip install afferent-skin   # or: /tmp/v/bin/pip install .
    /tmp/v/bin/python benchmarks/install_size.py

Sizes in MB (10^6 bytes) from each distribution's RECORD (the files pip installed, compiled bytecode
included once written); ``du -sh /tmp/v`` gives the venv's whole size (pip and setuptools included).
Uses only the standard library, so it runs in the venv it measures.
"""

from __future__ import annotations

import re
import sys
from importlib import metadata
from pathlib import Path

ROOT = "afferent-skin"


def _name(text: str) -> str:
    return re.sub(r"[-_.]+", "-", text).lower()


def _size(dist: metadata.Distribution) -> int:
    total = 0
    for f in dist.files or ():
        path = Path(dist.locate_file(f))
        if path.is_file():
            total += path.stat().st_size
    return total


def _requires(dist: metadata.Distribution, installed: dict) -> set[str]:
    """The installed distributions ``dist`` requires unconditionally (extras left out)."""
    out = set()
    for req in dist.requires or ():
        if "extra ==" in req:
            continue
        m = re.match(r"\s*([A-Za-z0-9_.\-]+)", req)
        marker = req.split(";", 1)[1] if ";" in req else None
        if marker and "python_version" in marker:
            from packaging.markers import Marker  # pip's vendored copy is not importable; packaging usually is

            if not Marker(marker).evaluate():
                continue
        if m and _name(m.group(1)) in installed:
            out.add(_name(m.group(1)))
    return out


def _closure(start: str, graph: dict) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        n = todo.pop()
        if n not in seen:
            seen.add(n)
            todo.extend(graph.get(n, ()))
    return seen


def main() -> int:
    installed = {_name(d.metadata["Name"]): d for d in metadata.distributions()}
    if ROOT not in installed:
        print(f"{ROOT} is not installed in {sys.prefix}", file=sys.stderr)
        return 2
    graph = {n: _requires(d, installed) for n, d in installed.items()}
    sizes = {n: _size(d) for n, d in installed.items()}
    everything = _closure(ROOT, graph)
    total = sum(sizes[n] for n in everything)
    print(f"{ROOT} and its dependencies: {len(everything)} distributions, {total / 1e6:.0f} MB "
          f"(the venv's other distributions: {', '.join(sorted(set(installed) - everything)) or 'none'})")
    print(f"{'direct dependency':<16} {'exclusive MB':>12}  distributions only it brings")
    rows = []
    for dep in sorted(graph[ROOT]):
        without = _closure(ROOT, {**graph, ROOT: graph[ROOT] - {dep}})  # the package without this one requirement
        only = everything - without
        rows.append((sum(sizes[n] for n in only), dep, sorted(only)))
    for size, dep, only in sorted(rows, reverse=True):
        print(f"{dep:<16} {size / 1e6:>12.0f}  {', '.join(only)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
