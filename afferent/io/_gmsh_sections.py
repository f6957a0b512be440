"""The sections of a Gmsh ``.msh`` file (MSH 2.2 and 4.1, ASCII and binary), parsed for :mod:`afferent.io._gmsh`.

:func:`_parse` walks the file's sections in order: ``$MeshFormat``, ``$Entities`` (4.1: each volume
entity's physical tag), ``$Nodes``, ``$Elements``, and the data blocks ``$NodeData``,
``$ElementData``, ``$ElementNodeData`` (records by tag, in runs of one element type or node count);
any other section is skipped to its ``$End``. Every count a header declares is checked against the
numbers (ASCII) or bytes (binary) left before anything of that size is allocated; each failure is a
SEDFormatError naming the file and the section.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..exceptions import SEDFormatError
__all__ = ["parse_msh", "gmsh_types"]

_SPACE = re.compile(rb"\s*")
_DATA = {"NodeData": "point", "ElementData": "cell", "ElementNodeData": "element nodes"}


def _err(path: str, section: str, msg: str) -> SEDFormatError:
    return SEDFormatError(f"SED file {path!r}: ${section}: {msg}")


def gmsh_types():
    """(meshio type name, node count, gmsh -> VTK node order or None) of each Gmsh element type number."""
    from meshio._common import num_nodes_per_cell
    from meshio.gmsh.common import _gmsh_to_meshio_order, _gmsh_to_meshio_type

    out = {}
    for number, name in _gmsh_to_meshio_type.items():
        n = num_nodes_per_cell.get(name)
        if n is not None:
            order = _gmsh_to_meshio_order(name, np.arange(n)[None])[0]
            out[number] = (name, n, None if np.array_equal(order, np.arange(n)) else order)
    return out


class _Cursor:
    """A position in the file's bytes: lines, ASCII numbers, binary values; each read checked against what is left."""

    def __init__(self, data: bytes, path: str):
        self.data, self.pos, self.path, self.section = data, 0, path, "MeshFormat"
        self.binary, self.order, self.size_t = False, "<", "<u8"

    def fail(self, msg: str) -> SEDFormatError:
        return _err(self.path, self.section, msg)

    def line(self) -> str:
        """The next line, stripped (blank lines skipped)."""
        while True:
            if self.pos >= len(self.data):
                raise self.fail("the file ends inside this section (truncated?).")
            end = self.data.find(b"\n", self.pos)
            end = len(self.data) if end < 0 else end
            text, self.pos = self.data[self.pos:end].strip(), end + 1
            if text:
                return text.decode("latin-1")

    def int_line(self, what: str) -> int:
        text = self.line()
        try:
            return int(text)
        except ValueError:
            raise self.fail(f"expected {what} (an integer); got {text[:40]!r} instead.") from None

    def left(self) -> int:
        return len(self.data) - self.pos

    def need(self, n_bytes: int, what: str) -> None:
        if n_bytes > self.left():
            raise self.fail(f"{what} take {n_bytes:,} bytes where {self.left():,} are left in the file: truncated or "
                            "corrupt; refused before reading it.")

    def ascii_body(self) -> np.ndarray:
        """The numbers up to ``$End<section>``, as float64 (the cursor then after that line)."""
        end = self.data.find(b"$End" + self.section.encode(), self.pos)
        if end < 0:
            raise self.fail(f"no $End{self.section} (truncated?).")
        body, self.pos = self.data[self.pos:end], end
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                values = np.fromstring(body, sep=" ")  # noqa: NPY201 - text mode (sep) is the fast path, not deprecated
        except (ValueError, DeprecationWarning):
            bad = next((t for t in body.split() if not _is_number(t)), b"?")
            raise self.fail(f"expected numbers; got {bad[:40].decode('latin-1')!r} instead.") from None
        return values

    def take(self, dtype, count: int, what: str) -> np.ndarray:
        """``count`` binary values of ``dtype`` (a view of the file's bytes)."""
        dtype = np.dtype(dtype)
        if count < 0:
            raise self.fail(f"{what}: a negative count ({count}).")
        self.need(count * dtype.itemsize, f"{what} ({count:,} values)")
        out = np.frombuffer(self.data, dtype, count, self.pos)
        self.pos += count * dtype.itemsize
        return out

    def end(self) -> None:
        """Expect ``$End<section>`` next."""
        text = self.line()
        if text != f"$End{self.section}":
            raise self.fail(f"expected $End{self.section}; got {text[:40]!r} instead (a count that does not match "
                            "the data: corrupt).")


def _is_number(token: bytes) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


class _Numbers:
    """The numbers of a 4.1 section read in order, from ASCII tokens or binary values alike."""

    def __init__(self, cur: _Cursor):
        self.cur = cur
        self.tokens = None if cur.binary else cur.ascii_body()
        self.at = 0

    def _ascii(self, count: int, what: str) -> np.ndarray:
        if count < 0 or self.at + count > self.tokens.size:
            raise self.cur.fail(f"{what}: {count:,} numbers announced where {self.tokens.size - self.at:,} are left "
                                "in the section: truncated or corrupt.")
        out, self.at = self.tokens[self.at:self.at + count], self.at + count
        return out

    def ints(self, count: int, what: str, size_t: bool = False) -> np.ndarray:
        if self.tokens is None:
            return self.cur.take(self.cur.size_t if size_t else self.cur.order + "i4", count, what).astype(np.int64)
        v = self._ascii(count, what)
        if not np.all(v == np.round(v)):
            raise self.cur.fail(f"{what}: expected integers.")
        return v.astype(np.int64)

    def doubles(self, count: int, what: str) -> np.ndarray:
        if self.tokens is None:
            return self.cur.take(self.cur.order + "f8", count, what)
        return self._ascii(count, what)

    def done(self) -> None:
        if self.tokens is not None and self.at != self.tokens.size:
            raise self.cur.fail(f"{self.tokens.size - self.at} number(s) beyond what the section's counts announce.")
        self.cur.end()


def _mesh_format(cur: _Cursor) -> float:
    parts = cur.line().split()
    try:
        version, binary, size = float(parts[0]), int(parts[1]), int(parts[2])
    except (ValueError, IndexError):
        raise cur.fail(f"expected 'version file-type data-size'; got {' '.join(parts)[:40]!r} instead.") from None
    if version not in (2.2, 4.1) and not 2.0 <= version < 2.3:
        raise cur.fail(f"MSH version {version:g}: afferent reads MSH 2.2 and 4.1 (in Gmsh: Mesh.MshFileVersion = 4.1 or "
                       "2.2, or File > Export > 'Version 4 ASCII').")
    if size not in (4, 8):
        raise cur.fail(f"data-size {size}: expected 8 (or 4).")
    cur.binary, cur.size_t = bool(binary), f"<u{size}"
    if cur.binary:
        one = cur.data[cur.pos:cur.pos + 4]
        cur.order = "<" if one == b"\x01\x00\x00\x00" else ">" if one == b"\x00\x00\x00\x01" else None
        if cur.order is None:
            raise cur.fail("the binary file's first integer is not 1 in either byte order: corrupt.")
        cur.size_t = f"{cur.order}u{size}"
        cur.pos += 4
    cur.end()
    return version


def _entities(cur: _Cursor) -> dict:
    """MSH 4.1 ``$Entities``: each volume entity's first physical tag (those that have one)."""
    num = _Numbers(cur)
    counts = num.ints(4, "the entity counts", size_t=True)
    out = {}
    for dim, n in enumerate(counts):
        for _ in range(int(n)):
            tag = int(num.ints(1, "an entity tag")[0])
            num.doubles(3 if dim == 0 else 6, "an entity's bounding box")
            phys = num.ints(int(num.ints(1, "a physical tag count", size_t=True)[0]), "physical tags")
            if dim > 0:
                num.ints(int(num.ints(1, "a bounding entity count", size_t=True)[0]), "bounding entities")
            if dim == 3 and phys.size:
                out[tag] = int(phys[0])
    num.done()
    return out


def _nodes41(cur: _Cursor):
    num = _Numbers(cur)
    n_blocks, n_nodes = (int(v) for v in num.ints(4, "the $Nodes header", size_t=True)[:2])
    tags, xyz = [], []
    for _ in range(n_blocks):
        dim, _, parametric = (int(v) for v in num.ints(3, "a node block's header"))
        k = int(num.ints(1, "a node block's size", size_t=True)[0])
        tags.append(num.ints(k, "node tags", size_t=True))
        width = 3 + (dim if parametric else 0)
        xyz.append(num.doubles(k * width, "node coordinates").reshape(k, width)[:, :3])
    num.done()
    return _joined(cur, tags, xyz, n_nodes, "nodes")


def _nodes22(cur: _Cursor):
    n = cur.int_line("the number of nodes")
    if cur.binary:
        rec = cur.take(np.dtype([("id", cur.order + "i4"), ("xyz", cur.order + "f8", 3)]), n, "the nodes")
        cur.end()
        return rec["id"].astype(np.int64), rec["xyz"].astype(float)
    body = cur.ascii_body()
    if body.size != 4 * n:
        raise cur.fail(f"{n:,} nodes announced (4 numbers each); the section holds {body.size:,} numbers.")
    cur.end()
    rows = body.reshape(n, 4)
    return rows[:, 0].astype(np.int64), rows[:, 1:]


def _joined(cur, tags, values, n: int, what: str):
    tags = np.concatenate(tags) if tags else np.zeros(0, np.int64)
    if tags.size != n:
        raise cur.fail(f"{n:,} {what} announced; the blocks hold {tags.size:,}.")
    return tags, (np.concatenate(values) if values else np.zeros((0, 3)))


def _elements41(cur: _Cursor, types: dict) -> list:
    num = _Numbers(cur)
    n_blocks, n_elements = (int(v) for v in num.ints(4, "the $Elements header", size_t=True)[:2])
    blocks, total = [], 0
    for _ in range(n_blocks):
        dim, entity, etype = (int(v) for v in num.ints(3, "an element block's header"))
        k = int(num.ints(1, "an element block's size", size_t=True)[0])
        if etype not in types:
            raise cur.fail(f"element type {etype} is not a Gmsh element type afferent knows.")
        nn = types[etype][1]
        rows = num.ints(k * (1 + nn), f"{k} elements of type {etype}", size_t=True).reshape(k, 1 + nn)
        blocks.append((etype, rows[:, 0], rows[:, 1:], np.full(k, entity), None))
        total += k
    num.done()
    if total != n_elements:
        raise cur.fail(f"{n_elements:,} elements announced; the blocks hold {total:,}.")
    return blocks


def _run(columns, values, k_max: int) -> int:
    """How many records in a row have ``values`` in ``columns`` (strided views, ``k_max`` long)."""
    same = np.ones(k_max, bool)
    for col, v in zip(columns, values):
        same &= col[:k_max] == v
    return k_max if same.all() else int(np.argmin(same))


def _elements22(cur: _Cursor, types: dict) -> list:
    """MSH 2.2 ``$Elements``: records ``id type ntags tags... nodes...`` (binary: under headers ``type n ntags``),
    read in runs of one type and tag count."""
    n = cur.int_line("the number of elements")
    blocks, done = [], 0
    words = None if cur.binary else cur.ascii_body()
    at = 0
    while done < n:
        if cur.binary:
            etype, follow, ntags = (int(v) for v in cur.take(cur.order + "i4", 3, "an element header"))
        else:
            if at + 3 > words.size:
                raise cur.fail(f"{n:,} elements announced; the section ends after {done:,}.")
            etype, ntags, follow = int(words[at + 1]), int(words[at + 2]), n - done
        if etype not in types or ntags < 0:
            raise cur.fail(f"element type {etype} (with {ntags} tags) is not a Gmsh element type afferent knows.")
        width = 1 + ntags + types[etype][1]
        if cur.binary and follow == 1:  # gmsh writes a header before every element: runs of header + element
            cur.pos -= 12
            k_max = min(n - done, cur.left() // (4 * (width + 3)))
            cols = [np.ndarray((k_max,), cur.order + "i4", cur.data, cur.pos + 4 * c, (4 * (width + 3),)) for c in (0, 1, 2)]
            k = max(_run(cols, (etype, 1, ntags), k_max), 1)
            rows = cur.take(cur.order + "i4", k * (width + 3), f"{k} elements").reshape(k, width + 3)[:, 3:]
        elif cur.binary:
            k = follow
            if k < 0 or done + k > n:
                raise cur.fail(f"a header announces {k} elements beyond the {n:,} of the section.")
            rows = cur.take(cur.order + "i4", k * width, f"{k} elements").reshape(k, width)
        else:
            k_max = min(follow, (words.size - at) // (width + 2))
            cols = [words[at + c::width + 2] for c in (1, 2)]
            k = max(_run(cols, (etype, ntags), k_max), 1) if k_max else 0
            if k == 0:
                raise cur.fail(f"{n:,} elements announced; the section ends after {done:,}.")
            rows = words[at:at + k * (width + 2)].reshape(k, width + 2)
            rows = np.delete(rows, (1, 2), axis=1).astype(np.int64)
            at += k * (width + 2)
        tags = rows[:, 1:1 + ntags]
        phys = tags[:, 0] if ntags else np.zeros(len(rows), np.int64)
        entity = tags[:, 1] if ntags > 1 else phys
        blocks.append((etype, rows[:, 0].astype(np.int64), rows[:, 1 + ntags:].astype(np.int64), entity, phys))
        done += k
    if words is not None and at != words.size:
        raise cur.fail(f"{words.size - at} number(s) beyond the {n:,} elements announced.")
    cur.end()
    return blocks


def _data(cur: _Cursor, kind: str) -> dict:
    """One ``$NodeData`` / ``$ElementData`` / ``$ElementNodeData`` block: its tags and its records."""
    strings = [cur.line().strip('"') for _ in range(cur.int_line("the number of string tags"))]
    reals = []
    for _ in range(cur.int_line("the number of real tags")):
        text = cur.line()
        try:
            reals.append(float(text))
        except ValueError:
            raise cur.fail(f"expected a real tag (the time); got {text[:40]!r} instead.") from None
    ints = [cur.int_line("an integer tag") for _ in range(cur.int_line("the number of integer tags"))]
    if len(ints) < 3 or ints[1] < 1 or ints[2] < 0:
        raise cur.fail(f"integer tags {ints}: expected the step, the number of components (>= 1) and of entities.")
    step, ncomp, n = ints[:3]
    what = f"view {strings[0] if strings else ''!r} step {step}"
    if kind != "ElementNodeData":
        if cur.binary:
            rec = cur.take(np.dtype([("id", cur.order + "i4"), ("v", cur.order + "f8", ncomp)]), n, what)
            ids, values = rec["id"].astype(np.int64), rec["v"].reshape(n, ncomp).astype(float)
        else:
            body = cur.ascii_body()
            if body.size != n * (1 + ncomp):
                raise cur.fail(f"{what}: {n:,} entities of {ncomp} component(s) announced ({n * (1 + ncomp):,} numbers); "
                               f"the section holds {body.size:,}.")
            rows = body.reshape(n, 1 + ncomp)
            ids, values = rows[:, 0].astype(np.int64), rows[:, 1:]
        runs = [(ids, values[:, None, :])]
    else:
        runs = _element_nodes(cur, n, ncomp, what)
    cur.end()
    return {"kind": kind, "name": strings[0] if strings else "", "time": reals[0] if reals else None, "step": step,
            "ncomp": ncomp, "runs": runs}


def _element_nodes(cur: _Cursor, n: int, ncomp: int, what: str) -> list:
    """The records ``id nn values(nn x ncomp)`` of an ``$ElementNodeData`` block, in runs of one ``nn``."""
    runs, done, at = [], 0, 0
    words = None if cur.binary else cur.ascii_body()
    while done < n:
        if cur.binary:
            cur.need(8, f"{what}: element {done + 1}")
            nn = int(np.frombuffer(cur.data, cur.order + "i4", 1, cur.pos + 4)[0])
            width = 8 + 8 * nn * ncomp
            k_max = min(n - done, cur.left() // max(width, 1))
            col = np.ndarray((k_max,), cur.order + "i4", cur.data, cur.pos + 4, (width,)) if nn >= 0 else None
        else:
            nn = int(words[at + 1]) if at + 2 <= words.size else 0
            width = 2 + nn * ncomp
            k_max = min(n - done, (words.size - at) // max(width, 1))
            col = words[at + 1::width] if nn >= 0 else None
        if nn < 0 or nn > 1000:
            raise cur.fail(f"{what}: element {done + 1} announces {nn} nodes.")
        k = _run([col], (nn,), k_max) if k_max else 0
        if k == 0:
            raise cur.fail(f"{what}: {n:,} elements announced; the section ends after {done:,} (truncated or corrupt).")
        if cur.binary:
            rec = cur.take(np.dtype([("id", cur.order + "i4"), ("nn", cur.order + "i4"),
                                     ("v", cur.order + "f8", nn * ncomp)]), k, what)
            runs.append((rec["id"].astype(np.int64), rec["v"].reshape(k, nn, ncomp).astype(float)))
        else:
            rows = words[at:at + k * width].reshape(k, width)
            runs.append((rows[:, 0].astype(np.int64), rows[:, 2:].reshape(k, nn, ncomp)))
            at += k * width
        done += k
    if words is not None and at != words.size:
        raise cur.fail(f"{what}: {words.size - at} number(s) beyond the {n:,} elements announced.")
    return runs


def parse_msh(path: str, data: bytes) -> dict:
    """Every section of the file: the mesh (once) and the data blocks in file order."""
    cur = _Cursor(data, path)
    types = gmsh_types()
    out = {"version": None, "nodes": None, "elements": None, "entities": {}, "views": []}
    while True:
        cur.pos = _SPACE.match(data, cur.pos).end()
        if cur.pos >= len(data):
            break
        if data[cur.pos:cur.pos + 1] != b"$":
            raise _err(path, cur.section, f"unexpected bytes after $End{cur.section} (at byte {cur.pos:,}): corrupt.")
        name = (cur.line()[1:].split() or [""])[0]
        cur.section = name
        if out["version"] is None and name != "MeshFormat":
            raise _err(path, name, "the file does not start with $MeshFormat: not a Gmsh .msh file.")
        if name == "MeshFormat":
            version = _mesh_format(cur)
            if out["version"] not in (None, version):
                raise cur.fail(f"a second $MeshFormat of version {version:g} after {out['version']:g}.")
            out["version"], out["binary"] = version, cur.binary
        elif name == "Entities" and out["version"] == 4.1:
            out["entities"] = _entities(cur)
        elif name == "Nodes":
            _once(cur, out, "nodes", _nodes41(cur) if out["version"] == 4.1 else _nodes22(cur))
        elif name == "Elements":
            _once(cur, out, "elements", _elements41(cur, types) if out["version"] == 4.1 else _elements22(cur, types))
        elif name in _DATA:
            out["views"].append(_data(cur, name))
        else:  # $PhysicalNames, $InterpolationScheme, $Periodic, ...: not needed
            end = data.find(b"$End" + name.encode(), cur.pos)
            if end < 0:
                raise cur.fail(f"no $End{name} (truncated?).")
            cur.pos = end
            cur.end()
    if out["version"] is None:
        raise _err(path, "MeshFormat", "no $MeshFormat section: not a Gmsh .msh file.")
    for key, section in (("nodes", "Nodes"), ("elements", "Elements")):
        if out[key] is None:
            raise _err(path, section, f"the file holds no ${section} section (a view saved without its mesh, Gmsh's "
                                      "PostProcessing.SaveMesh = 0?): save the views with their mesh.")
    return out


def _once(cur: _Cursor, out: dict, key: str, value) -> None:
    """Keep the mesh section the first time; a repeat (the mesh written again before each view) must equal it."""
    if out[key] is None:
        out[key] = value
        return
    first = out[key]
    flat = (lambda v: [np.asarray(x) for b in v for x in b[:3]]) if key == "elements" else (lambda v: list(v))
    a, b = flat(first), flat(value)
    if len(a) != len(b) or not all(x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, b)):
        raise cur.fail("a second, different mesh in the file: afferent reads one mesh per .msh file (write each "
                       "model's views to a file of their own).")
