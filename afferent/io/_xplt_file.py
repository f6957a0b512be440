"""FEBio plot files (``.xplt``), the file layer: chunks, header, dictionary, mesh and states.

FEBio's layout (``FEBioPlot/FEBioPlotFile.h`` and ``PltArchive.cpp`` in FEBio's source; see
docs/fe-export.md, "FEBio"): the tag ``BEF\\0`` (0x00464542, little-endian), then chunks, each
``(id: uint32, size: uint32, payload)``, a branch's payload being its child chunks: the root
(header and dictionary), the mesh, then one state per output time, zlib-compressed when the
header's compression flag is set. Every overrun names the file and the chunk (truncated or
corrupt files). :mod:`afferent.io._xplt` turns what is read here into a RawExport.
"""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import dataclass

import numpy as np

from ..exceptions import SEDFormatError
from ._raw import check_export_file

__all__ = ["XPLT_ELEMENTS"]

_TAG = 0x00464542  # 'BEF\0'
_ROOT, _HEADER, _VERSION, _COMPRESSION, _SOFTWARE, _UNITS = 0x01000000, 0x01010000, 0x01010001, 0x01010004, 0x01010006, 0x01010007
_DICTIONARY, _DIC_ITEM, _DIC_TYPE, _DIC_FMT, _DIC_NAME = 0x01020000, 0x01020001, 0x01020002, 0x01020003, 0x01020004
_DIC_ARRAYSIZE, _DIC_ARRAYNAME = 0x01020005, 0x01020006
_DIC_CLASSES = {0x01021000: "global", 0x01023000: "nodal", 0x01024000: "domain", 0x01025000: "surface",
                0x01026000: "edge"}
_MESH, _NODE_SECTION, _NODE_HEADER, _NODE_SIZE, _NODE_COORDS = 0x01040000, 0x01041000, 0x01041100, 0x01041101, 0x01041200
_DOMAIN_SECTION, _DOMAIN, _DOMAIN_HDR, _DOM_ELEM_TYPE, _DOM_PART_ID, _DOM_ELEMS, _DOM_NAME = \
    0x01042000, 0x01042100, 0x01042101, 0x01042102, 0x01042103, 0x01032104, 0x01032105
_DOM_ELEM_LIST, _ELEMENT = 0x01042200, 0x01042201
_PARTS_SECTION, _PART, _PART_ID, _PART_NAME = 0x01045000, 0x01045100, 0x01045101, 0x01045102
_STATE, _STATE_HEADER, _STATE_TIME, _STATE_DATA = 0x02000000, 0x02010000, 0x02010002, 0x02020000
_STATE_VARIABLE, _STATE_VAR_ID, _STATE_VAR_DATA = 0x02020001, 0x02020002, 0x02020003
_NODE_DATA, _ELEMENT_DATA = 0x02020300, 0x02020400
_STATE_DATA_CLASSES = {0x02020100: "global", _NODE_DATA: "nodal", _ELEMENT_DATA: "domain", 0x02020500: "surface",
                       0x02020600: "edge"}
_VERSIONS = (0x0030, 0x0035)  # oldest and newest plot file version read
_STR_SIZE = 64  # FEBio's fixed name length (PlotFile.h STR_SIZE)

#: FEBio plot element type (FEBioPlotFile::Elem_Type) -> (name, node count, meshio volume type or None).
XPLT_ELEMENTS = {
    0: ("HEX8", 8, "hexahedron"), 1: ("PENTA6", 6, "wedge"), 2: ("TET4", 4, "tetra"), 3: ("QUAD4", 4, None),
    4: ("TRI3", 3, None), 5: ("LINE2", 2, None), 6: ("HEX20", 20, "hexahedron20"), 7: ("TET10", 10, "tetra10"),
    8: ("TET15", 15, "tetra"), 9: ("HEX27", 27, "hexahedron"), 10: ("TRI6", 6, None), 11: ("QUAD8", 8, None),
    12: ("QUAD9", 9, None), 13: ("PENTA15", 15, "wedge15"), 14: ("TET20", 20, "tetra"), 15: ("TRI10", 10, None),
    16: ("PYRA5", 5, "pyramid"), 17: ("TET5", 5, "tetra"), 18: ("PYRA13", 13, "pyramid13"), 19: ("LINE3", 3, None),
}
_BY_CORNERS = {"TET15", "HEX27", "TET20", "TET5"}  # the volume types read by their corner nodes only

_TYPES = ("FLOAT", "VEC3F", "MAT3FS", "MAT3FD", "TENS4FS", "MAT3F", "ARRAY", "ARRAY_VEC3F")
_FORMATS = ("NODE", "ITEM", "MULT", "REGION")
_COMPONENTS = {
    "FLOAT": (), "VEC3F": ("x", "y", "z"), "MAT3FS": ("xx", "yy", "zz", "xy", "yz", "xz"),
    "MAT3FD": ("xx", "yy", "zz"), "MAT3F": ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"),
    "TENS4FS": tuple(f"c{k}" for k in range(21)),
}


@dataclass(frozen=True)
class _Variable:
    """One dictionary entry: name, data type, storage format, class and number of values per item."""

    name: str
    vtype: str
    fmt: str
    kind: str
    components: tuple[str, ...]

    size = property(lambda self: max(len(self.components), 1))


@dataclass(frozen=True)
class _Domain:
    """One mesh domain: its number (1-based, the state data's chunk id), element type, part and elements."""

    number: int
    etype: str
    ctype: str | None
    part: int
    name: str
    conn: np.ndarray  # (n_elements, n_nodes), 0-based node indices

    @property
    def nodes(self) -> np.ndarray:
        """The domain's nodes in FEBio's order (first appearance in the connectivity: FEMeshPartition::Init)."""
        flat = self.conn.ravel()
        _, first = np.unique(flat, return_index=True)
        return flat[np.sort(first)]


@dataclass(frozen=True)
class _Model:
    """What the root and mesh chunks say: header, dictionary, nodes, domains, parts."""

    version: int
    compression: int
    software: str
    units: str
    variables: dict  # class -> list of _Variable, in dictionary order
    points: np.ndarray
    domains: tuple
    parts: dict


def _err(path: str, what: str) -> SEDFormatError:
    return SEDFormatError(f"SED file {path!r}: {what}")


def _children(buf, path: str, what: str) -> list:
    """The chunks ``(id, payload)`` of a branch's payload; an overrun names ``what`` (truncated or corrupt)."""
    out, off, n = [], 0, len(buf)
    while off < n:
        if off + 8 > n:
            raise _err(path, f"{what} ends inside a chunk header ({n - off} byte(s) left, 8 expected): truncated or "
                             "corrupt .xplt file.")
        cid, size = struct.unpack_from("<II", buf, off)
        if size > n - off - 8:
            raise _err(path, f"chunk {cid:#010x} of {what} declares {size} bytes but only {n - off - 8} remain: "
                             "truncated or corrupt .xplt file.")
        out.append((cid, buf[off + 8:off + 8 + size]))
        off += 8 + size
    return out


def _one(chunks, cid: int, path: str, what: str):
    """The payload of the chunk ``cid`` among ``chunks``; a SEDFormatError naming ``what`` if there is none."""
    found = dict(chunks)
    if cid not in found:
        ids = ", ".join(f"{k:#010x}" for k, _ in chunks) or "none"
        raise _err(path, f"{what} must hold chunk {cid:#010x}; got none (ids {ids}).")
    return found[cid]


def _int(payload, path: str, what: str) -> int:
    if len(payload) != 4:
        raise _err(path, f"{what} must be a 4-byte integer; got {len(payload)} bytes.")
    return struct.unpack("<i", payload)[0]


def _text(payload) -> str:
    """A name: FEBio writes either a length-prefixed string or a fixed 64-byte NUL-padded one."""
    raw = bytes(payload)
    if len(raw) >= 4 and struct.unpack_from("<i", raw)[0] == len(raw) - 4:
        raw = raw[4:]
    return raw.split(b"\x00", 1)[0].decode("latin-1").strip()


def _header(chunks, path: str) -> tuple[int, int, str, str]:
    """(version, compression, software, units) of the header chunk; refuses versions not read."""
    found = dict(chunks)
    version = _int(_one(chunks, _VERSION, path, "the header"), path, "the plot file version")
    if not _VERSIONS[0] <= version <= _VERSIONS[1]:
        what = "FEBio 2.x's layout" if version < _VERSIONS[0] else "newer than the versions this reader knows"
        raise _err(path, f"plot file version {version:#06x} is not read ({what}); "
                         f"versions 3.0 to 3.5 ({_VERSIONS[0]:#06x}-{_VERSIONS[1]:#06x}, FEBio 3.x and 4.x) are. Open "
                         "the file in FEBio Studio and export VTK, or rerun the model with FEBio 3 or 4.")
    compression = _int(found[_COMPRESSION], path, "the compression flag") if _COMPRESSION in found else 0
    software = _text(found[_SOFTWARE]) if _SOFTWARE in found else ""
    units = _text(found[_UNITS]) if _UNITS in found else ""
    return version, compression, software, units


def _dictionary(chunks, path: str) -> dict:
    """Class -> [_Variable] of the dictionary chunk."""
    out: dict = {}
    for cid, payload in chunks:
        kind = _DIC_CLASSES.get(cid)
        if kind is None:
            continue
        for item_id, item in _children(payload, path, f"the {kind} dictionary"):
            if item_id != _DIC_ITEM:
                continue
            fields = _children(item, path, f"a {kind} dictionary item")
            name = _text(_one(fields, _DIC_NAME, path, f"a {kind} dictionary item"))
            vtype = _int(_one(fields, _DIC_TYPE, path, f"dictionary item {name!r}"), path, f"the type of {name!r}")
            fmt = _int(_one(fields, _DIC_FMT, path, f"dictionary item {name!r}"), path, f"the format of {name!r}")
            if not (0 <= vtype < len(_TYPES) and 0 <= fmt < len(_FORMATS)):
                raise _err(path, f"plot variable {name!r} has data type {vtype} and storage format {fmt}; expected a "
                                 f"type 0-{len(_TYPES) - 1} ({', '.join(_TYPES)}) and a format 0-3 ({', '.join(_FORMATS)}).")
            names = tuple(_text(p) for k, p in fields if k == _DIC_ARRAYNAME)
            size = dict(fields).get(_DIC_ARRAYSIZE)
            n_array = _int(size, path, f"the array size of {name!r}") if size is not None else 0
            comps = _COMPONENTS.get(_TYPES[vtype])
            if comps is None:  # ARRAY (n values) or ARRAY_VEC3F (n vectors)
                labels = names if len(names) == n_array else tuple(str(k) for k in range(n_array))
                comps = labels if _TYPES[vtype] == "ARRAY" else tuple(f"{a}_{x}" for a in labels for x in "xyz")
            out.setdefault(kind, []).append(_Variable(name, _TYPES[vtype], _FORMATS[fmt], kind, comps))
    return out


def _nodes(chunks, path: str) -> np.ndarray:
    """Reference coordinates (n_nodes, 3) of the node section (each node: int id, float x, y, z)."""
    header = _children(_one(chunks, _NODE_HEADER, path, "the node section"), path, "the node header")
    n = _int(_one(header, _NODE_SIZE, path, "the node header"), path, "the node count")
    coords = _one(chunks, _NODE_COORDS, path, "the node section")
    if n < 0 or len(coords) != 16 * n:
        raise _err(path, f"the node coordinates must be {n} x (id, x, y, z), {16 * max(n, 0)} bytes; got "
                         f"{len(coords)} bytes instead.")
    table = np.frombuffer(coords, dtype="<f4").reshape(n, 4)
    return table[:, 1:].astype(np.float64)


def _domain(number: int, chunks, path: str, n_nodes: int) -> _Domain:
    """One domain chunk: header (type, part, count, name) and element list (id, nodes)."""
    what = f"domain {number}"
    hdr = _children(_one(chunks, _DOMAIN_HDR, path, what), path, f"the header of {what}")
    code = _int(_one(hdr, _DOM_ELEM_TYPE, path, f"the header of {what}"), path, f"the element type of {what}")
    if code not in XPLT_ELEMENTS:
        raise _err(path, f"{what} has element type {code}; expected one of FEBio's plot element types 0-"
                         f"{max(XPLT_ELEMENTS)}.")
    etype, per, ctype = XPLT_ELEMENTS[code]
    part = _int(_one(hdr, _DOM_PART_ID, path, f"the header of {what}"), path, f"the part id of {what}")
    count = _int(_one(hdr, _DOM_ELEMS, path, f"the header of {what}"), path, f"the element count of {what}")
    name = _text(dict(hdr)[_DOM_NAME]) if _DOM_NAME in dict(hdr) else ""
    rows = [p for k, p in _children(_one(chunks, _DOM_ELEM_LIST, path, what), path, f"the elements of {what}")
            if k == _ELEMENT]
    if len(rows) != count or any(len(r) != 4 * (per + 1) for r in rows):
        raise _err(path, f"{what} ({etype}) must list {count} elements of {per + 1} integers (id and {per} nodes); "
                         f"got {len(rows)} element record(s) of {sorted({len(r) // 4 for r in rows})} integers.")
    table = np.frombuffer(b"".join(rows), dtype="<i4").reshape(count, per + 1) if rows else np.zeros((0, per + 1), int)
    conn = table[:, 1:].astype(np.int64)
    if conn.size and (conn.min() < 0 or conn.max() >= n_nodes):
        raise _err(path, f"{what} refers to node index {int(conn.max() if conn.max() >= n_nodes else conn.min())}, "
                         f"but the file has {n_nodes} nodes (0-based indices expected).")
    return _Domain(number, etype, ctype, part, name, conn)


def _parts(chunks, path: str) -> dict:
    out = {}
    for cid, payload in chunks:
        if cid == _PART:
            fields = dict(_children(payload, path, "a part"))
            if _PART_ID in fields:
                out[_int(fields[_PART_ID], path, "a part id")] = _text(fields.get(_PART_NAME, b""))
    return out


class _File:
    """The open .xplt file read chunk by chunk (states one at a time, zlib-inflated when compressed)."""

    def __init__(self, path: str):
        check_export_file(path)
        self.path = path
        self.fh = open(path, "rb")
        self.pending = b""
        tag = self.fh.read(4)
        if len(tag) < 4 or struct.unpack("<I", tag)[0] != _TAG:
            self.fh.close()
            raise SEDFormatError(f"SED file {path!r} is not an FEBio plot file: it must start with the tag "
                                 f"b'BEF\\x00' (0x00464542); got {tag!r} instead.")

    def close(self):
        self.fh.close()

    def read(self, n: int) -> bytes:
        data, self.pending = self.pending[:n], self.pending[n:]
        if len(data) < n:
            data += self.fh.read(n - len(data))
        return data

    def chunk(self, what: str, skip: bool = False):
        """(id, payload) of the next plain top-level chunk (payload None with ``skip``: not read), or None at the end."""
        head = self.read(8)
        if not head:
            return None
        if len(head) < 8:
            raise _err(self.path, f"the file ends inside the header of {what} ({len(head)} of 8 bytes): truncated .xplt.")
        cid, size = struct.unpack("<II", head)
        if skip:
            left = os.fstat(self.fh.fileno()).st_size - self.fh.tell()
            self.fh.seek(min(size, left), os.SEEK_CUR)
            payload = None
        else:
            payload = memoryview(self.read(size))
            left = len(payload)
        if left < size:
            raise _err(self.path, f"{what} (chunk {cid:#010x}) declares {size} bytes but the file ends after "
                                  f"{left}: truncated .xplt (was FEBio still writing it?).")
        return cid, payload

    def inflated(self, what: str):
        """(id, payload) of the next zlib-compressed top-level chunk, or None at the end of the file."""
        first = self.read(1 << 20)
        if not first:
            return None
        z, parts, data = zlib.decompressobj(), [], first
        try:
            while True:
                parts.append(z.decompress(data))
                if z.eof:
                    break
                data = self.fh.read(1 << 20)
                if not data:
                    raise _err(self.path, f"{what} is a zlib stream that ends early: truncated .xplt.")
        except zlib.error as err:
            raise _err(self.path, f"{what} is not a valid zlib stream (the header says the states are "
                                  f"compressed): {err}; corrupt .xplt.") from err
        self.pending = z.unused_data
        buf = b"".join(parts)
        chunks = _children(memoryview(buf), self.path, what)
        if len(chunks) != 1:
            raise _err(self.path, f"{what} must inflate to one chunk; got {len(chunks)}.")
        return chunks[0]


def _model(f: _File) -> _Model:
    """Root (header, dictionary) and mesh of an open file."""
    path = f.path
    root = f.chunk("the root chunk")
    if root is None or root[0] != _ROOT:
        raise _err(path, f"the first chunk must be the root (0x01000000); got {'none' if root is None else hex(root[0])}.")
    rc = _children(root[1], path, "the root chunk")
    version, compression, software, units = _header(_children(_one(rc, _HEADER, path, "the root"), path, "the header"),
                                                    path)
    variables = _dictionary(_children(_one(rc, _DICTIONARY, path, "the root"), path, "the dictionary"), path)
    mesh = f.chunk("the mesh chunk")
    if mesh is None or mesh[0] != _MESH:
        raise _err(path, "the chunk after the root must be the mesh (0x01040000); got "
                         f"{'the end of the file' if mesh is None else hex(mesh[0])}.")
    mc = _children(mesh[1], path, "the mesh")
    points = _nodes(_children(_one(mc, _NODE_SECTION, path, "the mesh"), path, "the node section"), path)
    domains = [
        _domain(k + 1, _children(p, path, f"domain {k + 1}"), path, points.shape[0])
        for k, (cid, p) in enumerate(c for c in _children(_one(mc, _DOMAIN_SECTION, path, "the mesh"), path,
                                                            "the domain section") if c[0] == _DOMAIN)
    ]
    parts = _parts(_children(dict(mc)[_PARTS_SECTION], path, "the parts"), path) if _PARTS_SECTION in dict(mc) else {}
    return _Model(version, compression, software, units, variables, points, tuple(domains), parts)


def _states(f: _File, model: _Model):
    """Yield (time, {class: {variable index: {block id: float32 array}}}) per state, in file order."""
    k = 0
    while True:
        what = f"state {k}"
        chunk = f.inflated(what) if model.compression else f.chunk(what)
        if chunk is None:
            return
        cid, payload = chunk
        if cid == _MESH:
            raise _err(f.path, f"a second mesh follows state {k - 1}: the mesh changes during the run (adaptive "
                               "remeshing), which is not read; export VTK from FEBio Studio instead.")
        if cid != _STATE:
            raise _err(f.path, f"{what} must be a state chunk (0x02000000); got {cid:#010x}.")
        sc = _children(payload, f.path, what)
        head = _children(_one(sc, _STATE_HEADER, f.path, what), f.path, f"the header of {what}")
        time_bytes = _one(head, _STATE_TIME, f.path, f"the header of {what}")
        if len(time_bytes) != 4:
            raise _err(f.path, f"the time of {what} must be a 4-byte float; got {len(time_bytes)} bytes.")
        time = float(struct.unpack("<f", time_bytes)[0])
        data = {}
        for dcid, block in _children(_one(sc, _STATE_DATA, f.path, what), f.path, f"the data of {what}"):
            kind = _STATE_DATA_CLASSES.get(dcid)
            if kind is None:
                continue
            per_var = {}
            for vcid, var in _children(block, f.path, f"the {kind} data of {what}"):
                if vcid != _STATE_VARIABLE:
                    continue
                fields = _children(var, f.path, f"a {kind} variable of {what}")
                vid = _int(_one(fields, _STATE_VAR_ID, f.path, f"a {kind} variable of {what}"), f.path, "a variable id")
                blocks = _children(_one(fields, _STATE_VAR_DATA, f.path, f"{kind} variable {vid} of {what}"), f.path,
                                   f"{kind} variable {vid} of {what}")
                per_var[vid - 1] = {bid: np.frombuffer(b, dtype="<f4") for bid, b in blocks}
            data[kind] = per_var
        yield time, data
        k += 1
