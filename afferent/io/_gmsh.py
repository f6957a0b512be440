"""Gmsh's own result files: MSH 2.2 and 4.1, ASCII and binary, with their post-processing views.

Read by afferent's own parser (sections ``$MeshFormat``, ``$Entities``, ``$Nodes``, ``$Elements``,
``$NodeData``, ``$ElementData``, ``$ElementNodeData``; every other section is skipped). meshio reads
the mesh of a ``.msh`` but drops ``$ElementNodeData``, which solvers built on Gmsh write.

How each view becomes an array, named by the view's first string tag (its name):

- ``$NodeData``: point data; ``$ElementData``: cell data over the volume elements (values of surface
  and line elements are left out); ``$ElementNodeData`` (each element's own value at each of its
  nodes): point data on **each volume element's own copies of its nodes**, i.e. the mesh is written
  out as discontinuous output, and the copies are merged as for any discontinuous export
  (:mod:`afferent.io._coincident`: the element-node rule, the mean of the copies at each node, how far the copies
  disagree is reported). Node data then sits on every copy of its node.
- Several blocks of one name are one series: the integer tag (the step index) orders them, the
  first real tag is the step's time. Blocks of one name and step (the partitions of a partitioned
  run) are joined. Views with one step on a file of several are the same at every step.
- Materials: the physical tag of each volume element (MSH 2.2: its first tag; MSH 4.1: its
  entity's first physical tag in ``$Entities``), else its elementary entity, as the cell array
  ``material`` when there are at least two.
- A file holding the mesh again before each view (what ``gmsh.view.write(..., append=True)``
  writes) is read once; a second, different mesh is refused.

Bounded memory: every count a header declares is checked against the bytes left in the file before
anything of that size is allocated; anything malformed is a SEDFormatError naming the file and the
section. Gmsh states no units (the user declares them).
"""

from __future__ import annotations

import numpy as np

from ._cell_blocks import _Block, cells_from_meshio, volume_type_blocks
from ._files import open_regular
from ._gmsh_sections import _err, gmsh_types, parse_msh
from ._raw import RawArray, RawExport, check_export_file, material_array

__all__ = ["read_msh", "read_gmsh"]


def _lookup(tags: np.ndarray, path: str, section: str, what: str):
    """A function mapping tags to their index in ``tags`` (unique), refusing unknown tags; with ``known=False`` it
    returns -1 for them instead."""
    order = np.argsort(tags, kind="stable")
    ordered = tags[order]
    if ordered.size > 1 and np.any(ordered[1:] == ordered[:-1]):
        dup = int(ordered[1:][ordered[1:] == ordered[:-1]][0])
        raise _err(path, section, f"{what} tag {dup} appears twice.")

    def find(query: np.ndarray, known: bool = True, where: str = section) -> np.ndarray:
        at = np.minimum(np.searchsorted(ordered, query), max(ordered.size - 1, 0))
        ok = ordered[at] == query if ordered.size else np.zeros(query.shape, bool)
        if known and not ok.all():
            raise _err(path, where, f"{what} tag {int(query[~ok].ravel()[0])} is not in the file's ${section}.")
        return np.where(ok, order[at] if ordered.size else -1, -1)

    return find


def _volume(parsed: dict, path: str, find_node):
    """The volume element blocks, one per cell type: [(meshio type, connectivity (VTK order, node indices),
    element tags, materials, gmsh->VTK order)], and the tags of every element."""
    types = gmsh_types()
    from meshio._mesh import topological_dimension

    groups: dict = {}
    for etype, tags, conn, entity, phys in parsed["elements"]:
        name, _, order = types[etype]
        if topological_dimension.get(name) != 3:
            continue
        if phys is None:  # MSH 4.1: the entity's physical tag
            mat = np.full(tags.size, parsed["entities"].get(int(entity[0]), int(entity[0])) if tags.size else 0)
        else:
            mat = np.where(phys != 0, phys, entity)
        nodes = find_node(conn, where="Elements")
        groups.setdefault(name, []).append((nodes if order is None else nodes[:, order], tags, mat, order))
    blocks = [(name, np.concatenate([g[0] for g in gs]), np.concatenate([g[1] for g in gs]),
               np.concatenate([g[2] for g in gs]), gs[0][3]) for name, gs in groups.items()]
    every = np.concatenate([b[1] for b in parsed["elements"]]) if parsed["elements"] else np.zeros(0, np.int64)
    return blocks, every


def _series(views: list, path: str) -> dict:
    """(kind, name) -> [(step, time, runs)] in step order, the blocks of one step (partitions) joined."""
    out: dict = {}
    for v in views:
        steps = out.setdefault((v["kind"], v["name"]), {})
        s = steps.setdefault(v["step"], {"time": v["time"], "runs": [], "ncomp": v["ncomp"]})
        if s["time"] != v["time"] or s["ncomp"] != v["ncomp"]:
            raise _err(path, v["kind"], f"view {v['name']!r} step {v['step']}: two blocks with different times or "
                                        "component counts.")
        s["runs"] += v["runs"]
    return {key: [(k, s["time"], s["runs"], s["ncomp"]) for k, s in sorted(steps.items())] for key, steps in out.items()}


def _values(kind: str, runs: list, ncomp: int, ctx: dict, label: str) -> np.ndarray:
    """One step of one view over the points (node data), the volume cells, or the element-node copies."""
    path = ctx["path"]
    size = {"NodeData": ctx["n_nodes"], "ElementData": ctx["n_cells"], "ElementNodeData": ctx["n_copies"]}[kind]
    out = np.full((size, ncomp), np.nan)
    seen = np.zeros(size, bool)
    for ids, vals in runs:
        if kind == "NodeData":
            pos = ctx["find_node"](ids, where=kind)[:, None]
        else:
            ctx["find_element"](ids, where=kind)  # every tag an element of the file
            rows = ctx["find_cell"](ids, known=False)
            keep = rows >= 0  # values of surface and line elements: left out
            rows, vals = rows[keep], vals[keep]
            if kind == "ElementData":
                pos = rows[:, None]
            else:
                nn = ctx["cell_nodes"][rows]
                if np.any(nn != vals.shape[1]):
                    raise _err(path, kind, f"{label}: element {int(ids[keep][nn != vals.shape[1]][0])} has "
                                           f"{int(nn[nn != vals.shape[1]][0])} nodes; {vals.shape[1]} values given.")
                vals = vals.copy()
                for b, order in enumerate(ctx["orders"]):  # gmsh's node order to VTK's (quadratic cells)
                    swap = ctx["cell_block"][rows] == b
                    if order is not None and swap.any():
                        vals[swap] = vals[swap][:, order]
                pos = ctx["cell_start"][rows][:, None] + np.arange(vals.shape[1])
        flat = pos.ravel()
        if np.any(seen[flat]) or np.unique(flat).size != flat.size:
            raise _err(path, kind, f"{label}: an entity is given twice.")
        seen[flat] = True
        out[flat] = vals.reshape(-1, ncomp)
    return out


def _times(series: dict, path: str, notes: list):
    """The steps' times (None when the file states none, or they do not increase) and the number of steps."""
    multi = {key: [t for _, t, _, _ in steps] for key, steps in series.items() if len(steps) > 1}
    lists = list(multi.values()) or [[steps[0][1]] for steps in series.values()]
    if any(len(t) != len(lists[0]) or t != lists[0] for t in lists[1:]):
        if multi:
            said = "; ".join(f"{name!r} ({kind}) at times {t}" for (kind, name), t in multi.items())
            raise _err(path, next(iter(multi))[0], f"the views have different steps: {said}; afferent reads views "
                                                  "over one series of steps (write each series to a file of its own).")
        notes.append("The views (one step each) state different times; read as one step with no time.")
        return None, 1
    times = lists[0] if lists else []
    if not times or any(t is None for t in times):
        return None, max(len(times), 1)
    if any(b <= a for a, b in zip(times, times[1:])):
        notes.append(f"The steps' times {times} do not increase: steps numbered 0, 1, ... instead.")
        return None, len(times)
    return np.asarray(times, dtype=float), len(times)


def _arrays(series: dict, ctx: dict, copies, n_steps: int, notes: list) -> dict:
    """Every view as a RawArray of shape (n_steps, n[, ncomp]), named by the view's name."""
    arrays: dict = {}
    for (kind, name), steps in series.items():
        label = f"view {name!r}"
        per = np.stack([_values(kind, runs, ncomp, ctx, f"{label} step {k}") for k, _, runs, ncomp in steps])
        if kind == "NodeData" and copies is not None:
            per = per[:, copies]
        if per.shape[2] == 1:
            per = per[:, :, 0]
        if len(steps) == 1 and n_steps > 1:
            per = np.broadcast_to(per, (n_steps,) + per.shape[1:])
            notes.append(f"{label} ({kind}) has one step: the same at each of the {n_steps} steps.")
        location = "cell" if kind == "ElementData" else "point"
        key = name if name not in arrays else f"{name}@{'cell' if location == 'cell' else kind}"
        arrays[key] = RawArray(name, per, location)
    return arrays


def read_msh(path: str, *, progress: bool = False, data: bytes | None = None) -> RawExport:
    """A Gmsh ``.msh`` file (MSH 2.2 or 4.1, ASCII or binary) with its views, as a RawExport (model units).

    Points in the file's (undeclared) length unit; one array per view (see the module docstring);
    times from the views' real tags. Raises SEDFormatError naming the file and the section for
    anything malformed, truncated, or a count larger than the file.
    """
    if data is None:
        check_export_file(path)
        with open_regular(path, "SED file") as fh:
            data = fh.read()
    parsed = parse_msh(path, data)
    node_tags, xyz = parsed["nodes"]
    find_node = _lookup(node_tags, path, "Nodes", "node")
    blocks, every = _volume(parsed, path, find_node)
    cell_tags = np.concatenate([b[2] for b in blocks]) if blocks else np.zeros(0, np.int64)
    counts = [b[1].shape[0] for b in blocks]
    cell_nodes = np.repeat([b[1].shape[1] for b in blocks], counts).astype(np.int64)
    ctx = {"path": path, "find_node": find_node, "find_element": _lookup(every, path, "Elements", "element"),
           "find_cell": _lookup(cell_tags, path, "Elements", "element"), "cell_nodes": cell_nodes,
           "cell_start": np.concatenate([[0], np.cumsum(cell_nodes)[:-1]]).astype(np.int64),
           "cell_block": np.repeat(np.arange(len(blocks)), counts), "orders": [b[4] for b in blocks],
           "n_nodes": xyz.shape[0], "n_cells": cell_tags.size, "n_copies": int(cell_nodes.sum())}
    series = _series(parsed["views"], path)
    dropped = [k for k in series if k[0] == "ElementNodeData"] if not blocks else []
    for key in dropped:  # element-node values need volume elements to sit on
        del series[key]
    notes = [f"Gmsh MSH {parsed['version']:g} {'binary' if parsed['binary'] else 'ASCII'}; views: "
             + (", ".join(f"{name!r} ({kind}, {len(s)} step(s))" for (kind, name), s in series.items()) or "none")]
    notes += [f"View {name!r} (ElementNodeData) left out: the file has no volume elements." for _, name in dropped]
    copies = None
    conns = [b[1] for b in blocks]
    if any(kind == "ElementNodeData" for kind, _ in series):
        copies = np.concatenate([c.ravel() for c in conns])
        starts = np.cumsum([0] + [c.size for c in conns])
        conns = [np.arange(a, a + c.size).reshape(c.shape) for a, c in zip(starts, conns)]
        notes.append(f"Element-node data: each volume element has its own copies of its nodes ({copies.size} points for "
                     f"{xyz.shape[0]} nodes), merged as discontinuous output.")
    points = np.ascontiguousarray(xyz if copies is None else xyz[copies], dtype=float)
    points.setflags(write=False)
    cells = cells_from_meshio(volume_type_blocks([_Block(b[0], c) for b, c in zip(blocks, conns)], path), path)
    times, n_steps = _times(series, path, notes)
    arrays = _arrays(series, ctx, copies, n_steps, notes)
    if cells is not None:
        material = material_array(np.concatenate([b[3] for b in blocks]), n_steps)
        if material is not None and "material" not in arrays:
            arrays["material"] = material
    else:
        notes.append("No volume elements in the file: the points are treated as scattered samples.")
    return RawExport(files=(path,), format="msh", points=points, arrays=arrays, times=times, cells=cells,
                     notes=tuple(notes))


def read_gmsh(path: str, *, progress: bool = False) -> RawExport:
    """A Gmsh result file, ``.msh`` or ``.pos``, by its content: MSH sections (``$MeshFormat``, whatever the
    name) by :func:`read_msh`; parsed views (``View "name" {...};``, or anything else named ``.pos``) and
    the legacy ``$PostFormat`` (refused) by :mod:`afferent.io._gmsh_pos`."""
    from ._gmsh_pos import parse_pos, pos_export

    check_export_file(path)
    with open_regular(path, "SED file") as fh:
        data = fh.read()
    head = data.lstrip()[:12]
    legacy = head.startswith(b"$PostFormat")
    if not legacy and (head.startswith(b"$") or not (head.startswith(b"View") or path.lower().endswith(".pos"))):
        return read_msh(path, progress=progress, data=data)
    points, blocks, arrays, times, notes = pos_export(path, parse_pos(path, data))
    points.setflags(write=False)
    cells = cells_from_meshio(volume_type_blocks([_Block(t, c) for t, c in blocks], path), path) if blocks else None
    if cells is None:
        notes.append("No volume elements in the views: the points are treated as scattered samples.")
    return RawExport(files=(path,), format="pos", points=points, arrays=arrays, times=times, cells=cells,
                     notes=tuple(notes))
