"""Gmsh's parsed post-processing views (``.pos``), read by afferent's own parser.

The format is a list of views, each ``View "name" { ... };`` holding ``TIME{t0,t1,...};`` and one
statement per element, ``XY(x1,y1,z1,...,xn,yn,zn){values};``: X the kind of value (``S`` scalar,
``V`` vector: 3 components, ``T`` tensor: 9, row-major), Y the element (``P`` point, ``L`` line,
``T`` triangle, ``Q`` quadrangle, ``S`` tetrahedron, ``H`` hexahedron, ``I`` prism, ``Y`` pyramid),
the coordinates node by node, the values node by node (components fastest) for the first step,
then the next step's. It is what ``gmsh.view.write(tag, "x.pos")`` and Gmsh's "Save as parsed
view" (``PostProcessing.Format = 2``) write, list-based views and views on a mesh alike.

How a file becomes an export:

- **Each element has its own copies of its nodes** (the format repeats the coordinates per
  element): the points are the volume elements' copies, in file order, and the cells use their own
  copies, as discontinuous output; the copies are then merged into nodes by the one element-node
  rule (:mod:`afferent.io._coincident`: the mean of the copies at each node, each element's copy
  once). Each view is the point array named by the view, and ``<name>@cell`` (cell data: the mean
  of each element's node values, the element's average for linear elements).
- Views over the same elements (equal coordinates, shape by shape) share the mesh; a view over
  other volume elements is refused. Points, lines, triangles and quadrangles are left out (noted);
  a file with no volume element but points (``SP``, ``VP``, ``TP``) is read as scattered points.
- Steps: the number of values of each element over its nodes and components; one count per
  view. ``TIME`` gives the times (Gmsh writes none for views on a mesh: the steps are numbered);
  views of one step are the same at every step of the others; different step counts are refused.
- Refused with a clear error: Gmsh's legacy post-processing formats (``$PostFormat`` 1.x, ASCII
  or binary: ``PostProcessing.Format`` 0 and 1), second-order list elements (``SS2``, ...) and
  ``INTERPOLATION_SCHEME`` (high-order views), expressions in place of numbers, mixed kinds
  (scalar and vector) in one view, a count that does not match (naming the view, the element
  type and the element). A ``.pos`` holding an MSH file (``$MeshFormat``) is read as ``.msh``.

Bounded memory: the format declares no count; every array is sized by the numbers present in the
file, each element's counts checked before its numbers are parsed. Gmsh states no units.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..exceptions import SEDFormatError
from ._gmsh_sections import _is_number

__all__ = ["parse_pos", "pos_export"]

#: Element letter -> (meshio type, nodes, dimension).
SHAPES = {"P": ("vertex", 1, 0), "L": ("line", 2, 1), "T": ("triangle", 3, 2), "Q": ("quad", 4, 2),
          "S": ("tetra", 4, 3), "H": ("hexahedron", 8, 3), "I": ("wedge", 6, 3), "Y": ("pyramid", 5, 3)}
KINDS = {"S": 1, "V": 3, "T": 9}
_VOLUME = "SHIY"

_SKIP = re.compile(rb'(?:\s+|//[^\n]*|/\*.*?\*/)*', re.S)
_VIEW = re.compile(rb'View\s*(?:\(\s*\d+\s*\)\s*)?"([^"]*)"\s*\{')
_ENTRY = re.compile(rb'([SVT])([PLTQSHIY])(\d*)\s*\(([^(){};]*)\)\s*\{([^{};]*)\}\s*;')
_TIME = re.compile(rb'TIME\s*\{([^{};]*)\}\s*;')
_TEXT = re.compile(rb'T[23]\s*\([^(){};]*\)\s*\{\s*(?:"[^"]*"\s*,?\s*)*\}\s*;')
_CLOSE = re.compile(rb'\}\s*;?')


def _err(path: str, msg: str) -> SEDFormatError:
    return SEDFormatError(f"SED file {path!r}: {msg}")


def _numbers(path: str, where: str, text: bytes) -> np.ndarray:
    """Comma-separated numbers as float64, refusing anything else (an expression, a variable)."""
    text = text.strip()
    if not text:
        return np.zeros(0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            out = np.fromstring(text, sep=",")  # noqa: NPY201 - text mode (sep) is the fast path, not deprecated
    except (ValueError, DeprecationWarning):
        out = None
    if out is None or out.size != text.count(b",") + 1:
        bad = next((t.strip() for t in text.split(b",") if not _is_number(t)), b"?")
        raise _err(path, f"{where}: expected numbers; got {bad[:40].decode('latin-1')!r} instead (afferent reads "
                         "the numbers Gmsh writes, not expressions).")
    return out


def _at(data: bytes, pos: int) -> str:
    return f"at byte {pos:,} ({data[pos:pos + 40].decode('latin-1')!r})"


def parse_pos(path: str, data: bytes) -> list[dict]:
    """Every view of a parsed ``.pos`` file: [{'name', 'times', 'kind', 'steps', 'shapes': {letter: (xyz
    (k, nn, 3), values (k, steps, nn, ncomp))}, 'left_out': {type: count}}] in file order."""
    if data.lstrip().startswith(b"$PostFormat"):
        raise _err(path, "Gmsh's legacy post-processing format ($PostFormat, PostProcessing.Format 0 or 1) is not "
                         "read: save the view as a parsed view (PostProcessing.Format = 2, or gmsh.view.write(tag, "
                         "'x.pos')) or as a mesh file (.msh).")
    views, pos = [], _SKIP.match(data, 0).end()
    while pos < len(data):
        m = _VIEW.match(data, pos)
        if m is None:
            raise _err(path, f"expected a view (View \"name\" {{ ... }};) {_at(data, pos)}: not a Gmsh parsed .pos "
                             "file.")
        view, end = _view(path, data, m.group(1).decode("latin-1"), _SKIP.match(data, m.end()).end())
        views.append(view)
        pos = _SKIP.match(data, end).end()
    if not views:
        raise _err(path, "no view in the file (View \"name\" { ... };).")
    return views


def _view(path: str, data: bytes, name: str, pos: int) -> dict:
    """One view's statements, from after its ``{`` to its closing ``};``."""
    label = f"view {name!r}"
    entries: dict = {}  # letter pair -> [(coordinates text, values text)]
    times, left_out = None, {}
    while True:
        if pos >= len(data):
            raise _err(path, f"{label}: the file ends inside the view (truncated?).")
        m = _ENTRY.match(data, pos)
        if m is not None:
            kind, shape, order = (g.decode() for g in m.group(1, 2, 3))
            if order:
                raise _err(path, f"{label}: {kind}{shape}{order} elements (order {order}) are not read: afferent reads "
                                 "first-order list elements (Gmsh writes a high-order view's elements by their corners).")
            entries.setdefault(kind + shape, []).append((m.group(4), m.group(5), m.start()))
        elif (m := _TIME.match(data, pos)) is not None:
            times = _numbers(path, f"{label}: TIME", m.group(1))
        elif (m := _TEXT.match(data, pos)) is not None:
            left_out["text (T2, T3)"] = left_out.get("text (T2, T3)", 0) + 1
        elif (m := _CLOSE.match(data, pos)) is not None:
            break
        elif data.startswith(b"INTERPOLATION_SCHEME", pos):
            raise _err(path, f"{label}: INTERPOLATION_SCHEME (a high-order view) is not read: save the view on its mesh "
                             "as a .msh file, or adapt it to first-order elements (Gmsh's AdaptiveView).")
        else:
            raise _err(path, f"{label}: unexpected {_at(data, pos)}: afferent reads Gmsh's parsed list format "
                             "(TIME{...}; XY(coordinates){values}; with X in S, V, T and Y in P, L, T, Q, S, H, I, Y).")
        pos = _SKIP.match(data, m.end()).end()
    kinds = sorted({key[0] for key in entries})
    if len(kinds) > 1:
        raise _err(path, f"{label} mixes {', '.join(kinds)} values ({', '.join(sorted(entries))}): afferent reads one "
                         "kind (scalar S, vector V or tensor T) per view.")
    shapes, steps = {}, None
    for key, rows in entries.items():
        xyz, values, steps = _elements(path, label, key, rows, steps)
        if SHAPES[key[1]][2] == 3 or key[1] == "P":
            shapes[key[1]] = (xyz, values)
        if SHAPES[key[1]][2] != 3:
            left_out[key] = len(rows)
    if steps is None:
        raise _err(path, f"{label} holds no element.")
    if times is not None and times.size != steps:
        raise _err(path, f"{label}: TIME lists {times.size} time(s); its elements hold {steps} step(s).")
    return {"name": name, "times": times, "kind": kinds[0], "steps": steps, "shapes": shapes,
            "left_out": left_out}, m.end()


def _elements(path: str, label: str, key: str, rows: list, steps):
    """The elements of one type of a view: coordinates (k, nn, 3), values (k, steps, nn, ncomp), steps."""
    nn, ncomp = SHAPES[key[1]][1], KINDS[key[0]]
    n_values = rows[0][1].count(b",") + 1
    per_step = nn * ncomp
    for k, (xyz, vals, _) in enumerate(rows):
        n_xyz, n_vals = xyz.count(b",") + 1, vals.count(b",") + 1
        where = f"{label}, {key} element {k + 1}"
        if n_xyz != 3 * nn:
            raise _err(path, f"{where}: {n_xyz} coordinates; a {SHAPES[key[1]][0]} ({key[1]}) has {nn} nodes "
                             f"({3 * nn} coordinates).")
        if n_vals % per_step or not vals.strip():
            raise _err(path, f"{where}: {n_vals} values, not a multiple of {nn} nodes x {ncomp} component(s) "
                             f"({per_step} a step).")
        if n_vals != n_values:
            raise _err(path, f"{where}: {n_vals // per_step} step(s); its first {key} element has "
                             f"{n_values // per_step}.")
        if steps is not None and n_vals // per_step != steps:
            raise _err(path, f"{where}: {n_vals // per_step} step(s); the view's other elements have {steps}.")
        steps = n_vals // per_step
    k = len(rows)
    xyz = _numbers(path, f"{label}, {key} coordinates", b",".join(r[0] for r in rows)).reshape(k, nn, 3)
    values = _numbers(path, f"{label}, {key} values", b",".join(r[1] for r in rows)).reshape(k, steps, nn, ncomp)
    return xyz, values, steps


def pos_export(path: str, views: list[dict]):
    """(points (n, 3), [(meshio type, connectivity)], {name: RawArray}, times or None, notes) of parsed views."""
    from ._raw import RawArray

    volume = [v for v in views if any(s in v["shapes"] for s in _VOLUME)]
    shapes = [s for s in _VOLUME if volume and s in volume[0]["shapes"]] or (["P"] if views[0]["shapes"].get("P")
                                                                             else [])
    if not shapes:
        raise _err(path, "no view holds volume elements (S, H, I, Y) or points (P): nothing to sample.")
    use = [v for v in views if any(s in v["shapes"] for s in shapes)]
    first = use[0]
    notes = ["Gmsh parsed views: " + ", ".join(f"{v['name']!r} ({ {'S': 'scalar', 'V': 'vector', 'T': 'tensor'}[v['kind']]}, "
                                                 f"{v['steps']} step(s))" for v in use)]
    for v in views:
        if v not in use:
            notes.append(f"View {v['name']!r} left out: it holds no {'volume elements' if shapes != ['P'] else 'points'}.")
        if v["left_out"]:
            notes.append(f"View {v['name']!r}: " + ", ".join(f"{n} {t}" for t, n in v["left_out"].items())
                         + " element(s) left out (not volume elements).")
    for v in use[1:]:
        same = [s for s in shapes if s in v["shapes"] and np.array_equal(v["shapes"][s][0], first["shapes"][s][0])]
        if len(same) != len(shapes) or any(s in v["shapes"] for s in _VOLUME if s not in shapes):
            raise _err(path, f"view {v['name']!r} is on other elements than view {first['name']!r} ("
                             + ", ".join(f"{s}: {len(v['shapes'].get(s, ((),))[0])} vs {len(first['shapes'].get(s, ((),))[0])}"
                                         for s in _VOLUME + "P" if s in v["shapes"] or s in first["shapes"])
                             + "): afferent reads views over one mesh; write each mesh's views to a file of their own.")
    steps = {v["steps"] for v in use if v["steps"] > 1}
    if len(steps) > 1:
        raise _err(path, "the views have different numbers of steps: " + ", ".join(
            f"{v['name']!r} {v['steps']}" for v in use) + "; write each series to a file of its own.")
    n_steps = steps.pop() if steps else 1
    points = np.concatenate([first["shapes"][s][0].reshape(-1, 3) for s in shapes])
    blocks, start = [], 0
    for s in shapes:
        k, nn = first["shapes"][s][0].shape[:2]
        if s != "P":
            blocks.append((SHAPES[s][0], np.arange(start, start + k * nn).reshape(k, nn)))
        start += k * nn
    arrays = {}
    for v in use:
        per_point = np.concatenate([v["shapes"][s][1].transpose(1, 0, 2, 3).reshape(v["steps"], -1, KINDS[v["kind"]])
                                    for s in shapes], axis=1)
        per_cell = [v["shapes"][s][1].mean(axis=2).transpose(1, 0, 2) for s in shapes if s != "P"]
        if v["steps"] == 1 and n_steps > 1:
            notes.append(f"View {v['name']!r} has one step: the same at each of the {n_steps} steps.")
        for key, vals, where in ((v["name"], per_point, "point"),
                                 (f"{v['name']}@cell", np.concatenate(per_cell, axis=1) if per_cell else None, "cell")):
            if vals is None:
                continue
            if key in arrays:
                raise _err(path, f"two views named {v['name']!r}: afferent names arrays by their view.")
            vals = vals[..., 0] if vals.shape[2] == 1 else vals
            arrays[key] = RawArray(key, np.broadcast_to(vals, (n_steps,) + vals.shape[1:]), where)
    times = _times([v for v in use if v["steps"] == n_steps], n_steps, notes)
    if blocks:
        notes.append(f"Each element has its own copies of its nodes ({points.shape[0]} points): merged as "
                     "discontinuous output; '<view>@cell' is each element's mean of its node values.")
    return points, blocks, arrays, times, notes


def _times(views: list[dict], n_steps: int, notes: list):
    """The views' TIME list (None when none is given or they disagree, noted; or when the times do not increase)."""
    lists = [v["times"] for v in views if v["times"] is not None]
    if not lists:
        if n_steps > 1:
            notes.append("No TIME list in the views (Gmsh writes none for views on a mesh): steps numbered 0, 1, ...")
        return None
    if any(not np.array_equal(t, lists[0]) for t in lists[1:]):
        notes.append("The views' TIME lists differ: steps numbered 0, 1, ... instead.")
        return None
    if np.any(np.diff(lists[0]) <= 0):
        notes.append(f"The steps' times {lists[0].tolist()} do not increase: steps numbered 0, 1, ... instead.")
        return None
    return lists[0].astype(float)
