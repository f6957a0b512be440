"""A VTU file in one parse, decoded by meshio's own decoder: points, cells, data arrays, component names.

meshio 5.3's ``meshio.vtu.read`` joins the points of a VTU with several ``<Piece>`` elements but
keeps only the last piece's cells (``_organize_cells`` leaves its loop over the pieces before
collecting the cells); it splits cell data among the cell blocks without counting it against
``NumberOfCells``; it drops the DataArrays' ``ComponentName`` attributes; and it refuses VTU
file version 2.x. :func:`read_vtu` parses the XML once (``xml.etree``; raw appended data
re-encoded by :func:`_raw_appended`, not meshio's ``_parse_raw_binary``, which can give one array
another's data), decodes each DataArray with meshio's
``VtuReader.read_data`` (base64, zlib, lzma) and its cells with ``vtk_cells_from_data``, and
from that one parse returns:

- points, every piece's in turn;
- cells, each piece's connectivity offset by the points of the pieces before it;
- point and cell data, joined piece by piece in the cells' order, each counted per piece
  against ``NumberOfPoints`` / ``NumberOfCells`` (a value too many or too few is an error
  naming the file, the array, the piece, and both counts);
- the arrays' ``ComponentName0..`` attributes (ccx2paraview writes ``XX YY ZZ XY YZ ZX``).

A binary data array whose header (its byte count; a compressed array's block sizes) agrees with
its piece's count is not decoded here: it comes back as a :class:`~afferent.io._raw.Deferred`,
decoded on first use, so that a reader after the SED alone does not decompress the
displacements and the other arrays beside it (the arrays' text stays in memory with the parsed
file until then). An array whose header disagrees, and every ASCII array, is decoded at once
and meets the checks below as before.

Errors are meshio's (``ReadError``, ``ValueError``, ...), which the caller turns into one
message naming the file, or :class:`VtuCountError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.etree import ElementTree as ET

import numpy as np

from ..exceptions import SEDFormatError
from ._raw import Deferred

__all__ = ["VtuContent", "VtuCountError", "read_vtu", "ALL_PARTS"]

#: The parts of a piece :func:`read_vtu` decodes by default; a series' later steps skip "Cells".
ALL_PARTS = ("Points", "Cells", "PointData", "CellData")


class VtuCountError(SEDFormatError):
    """A VTU that parses but whose pieces' arrays disagree with their counts (or with one another):
    refused as it is, not handed to VTK's reader (which reads such a file without a word)."""


@dataclass(frozen=True)
class VtuContent:
    """What one VTU holds, pieces joined; arrays in the file's own dtype and units.

    Attributes
    ----------
    points : ndarray of shape (n_points, n_components) or None
        None when "Points" was not asked for.
    cells : list of meshio.CellBlock
        In file order, piece after piece (connectivity indices into ``points``).
    point_data : dict of str to ndarray or Deferred
        Shape (n_points, ...) each (meshio's: ``(n,)``, or ``(n, k)`` when the tag gives
        NumberOfComponents); a :class:`~afferent.io._raw.Deferred` is decoded on first use.
    cell_values : dict of str to ndarray or Deferred
        Each cell array over all the file's cells (every type, in the order of ``cells``' blocks),
        pieces in order.
    n_points, n_cells, n_pieces : int
    components : dict of str to tuple of str
        ``{array name: (ComponentName0, ...)}`` for the arrays whose tag names each component.
    """

    points: np.ndarray | None
    cells: list
    point_data: dict
    cell_values: dict
    n_points: int
    n_cells: int
    n_pieces: int
    components: dict = field(default_factory=dict)


def _root(path: str):
    """The parsed VTKFile element (meshio's checks of the header), raw appended data re-encoded as base64."""
    from meshio import ReadError

    try:
        root = ET.parse(path).getroot()
    except ET.ParseError:
        root = _raw_appended(path)
    if root.tag != "VTKFile":
        raise ReadError(f"Expected tag 'VTKFile', found {root.tag}")
    if root.attrib.get("type") != "UnstructuredGrid":
        raise ReadError(f"Expected type UnstructuredGrid, found {root.attrib.get('type')}")
    return root


def _raw_appended(path: str):
    """The VTKFile element of a file with raw (binary) appended data, that data base64-encoded.

    meshio's ``_parse_raw_binary`` does this but finds each array by its offset *after* giving the
    arrays before it their new (base64) offsets: when a new offset equals a later array's raw one
    (NGSolve's ``VTKOutput(floatsize="single")``: 1304 Float32 points, 15,652 bytes, whose base64
    length is the raw offset of ``offsets``), one array gets another's data, or the file fails to
    read. Here every array is found by its raw offset first. Each is one header (UInt32 or UInt64
    byte count; compressed: block count, sizes) and its bytes, as VTK writes them.
    """
    import base64
    import lzma
    import re
    import zlib

    from meshio import ReadError
    from meshio.vtu._vtu import vtu_to_numpy_type

    with open(path, "rb") as f:
        raw = f.read()
    start, stop = re.search(rb'<AppendedData[^>]+(?:">)', raw), raw.find(b"</AppendedData>")
    if start is None or stop < 0 or b"_" not in raw[start.end():stop]:
        raise ReadError()
    root = ET.fromstring(raw[:start.end()].decode() + raw[stop:].decode())
    data = raw[start.end():stop].split(b"_", 1)[1]
    head = vtu_to_numpy_type[root.get("header_type", "UInt32")]
    head = head.newbyteorder("<" if root.get("byte_order", "LittleEndian") == "LittleEndian" else ">")
    by_offset: dict = {}  # raw offset -> the DataArrays there (one, unless a writer shares data)
    for a in root.iter("DataArray"):
        if a.get("format") == "appended":
            if not (a.get("offset") or "").strip().isdigit():
                raise ReadError(f"appended DataArray {a.get('Name')!r}: offset {a.get('offset')!r} is not a byte count")
            by_offset.setdefault(int(a.get("offset")), []).append(a)
    compressor = root.attrib.pop("compressor", None)
    unzip = {"vtkLZMADataCompressor": lzma, "vtkZLibDataCompressor": zlib, None: None}[compressor]
    encoded, i, at = [], 0, 0  # at: where the next array starts in the base64 text
    for offset in sorted(by_offset):
        if offset != i:
            raise ReadError(f"appended data: an array at byte {offset}, the previous one ends at {i}")
        for a in by_offset[offset]:
            a.set("offset", str(at))
        if unzip is None:
            size = int(np.frombuffer(data[i:i + head.itemsize], head)[0])
            block, i = data[i:i + head.itemsize + size], i + head.itemsize + size
        else:
            n_blocks = int(np.frombuffer(data[i:i + head.itemsize], head)[0])
            sizes = np.frombuffer(data[i:i + (3 + n_blocks) * head.itemsize], head)[3:].astype(int)
            i += (3 + n_blocks) * head.itemsize
            body = b"".join(unzip.decompress(data[i + a:i + b])
                            for a, b in zip(np.r_[0, np.cumsum(sizes)[:-1]], np.cumsum(sizes)))
            block, i = np.array([len(body)]).astype(head).tobytes() + body, i + int(sizes.sum())
        encoded.append(base64.b64encode(block).decode())
        at += len(encoded[-1])
    tag = root.find("AppendedData")
    tag.set("encoding", "base64")
    tag.text = "_" + "".join(encoded)
    return root


def _decoder(root):
    """meshio's VtuReader set up for ``root``'s encoding (not run: only its ``read_data`` is used)."""
    from meshio import ReadError
    from meshio.vtu import _vtu

    reader = _vtu.VtuReader.__new__(_vtu.VtuReader)
    reader.compression = root.attrib.get("compressor")
    if reader.compression not in (None, "vtkLZMADataCompressor", "vtkZLibDataCompressor"):
        raise ReadError(f"Unknown compressor '{reader.compression}'.")
    reader.header_type = root.attrib.get("header_type", "UInt32")
    reader.byte_order = root.attrib.get("byte_order")
    if reader.byte_order not in (None, "LittleEndian", "BigEndian"):
        raise ReadError(f"Unknown byte order '{reader.byte_order}'.")
    return reader


def _component_names(attrib: dict) -> tuple[str, ...]:
    """The ``ComponentName0..`` of a DataArray tag when it names every component (else ``()``)."""
    named = {k[13:]: v for k, v in attrib.items() if k.startswith("ComponentName")}
    if not named:
        return ()
    # the names the tag carries, not range(NumberOfComponents): a corrupt count (9999999999) is no loop
    comps = [named[str(i)] for i in range(len(named)) if str(i) in named]
    ok = comps and str(len(comps)) == attrib.get("NumberOfComponents", "").strip()
    return tuple(comps) if ok else ()


class _Piece:
    """One ``<Piece>`` decoded: its counts, points, raw cells and data arrays."""

    def __init__(self, decoder, piece, parts, components: dict, index: int, path: str):
        from meshio import ReadError
        from meshio._common import warn
        from meshio._exceptions import CorruptionError

        self.index = index  # in the file, from 0
        self.n_points = int(piece.attrib["NumberOfPoints"])
        self.n_cells = int(piece.attrib["NumberOfCells"])
        self.points, self.cells, self.point_data, self.cell_data = None, None, {}, {}
        #: no points and no cells (a parallel writer's idle rank): nothing to decode (meshio's decoder
        #: fails on an empty compressed array), left out when the pieces are joined
        self.empty = self.n_points == 0 and self.n_cells == 0
        for child in () if self.empty else piece:
            if child.tag not in ALL_PARTS:
                raise ReadError(f"Unknown tag '{child.tag}'.")
            if child.tag not in parts:
                continue
            arrays = list(child)
            if any(a.tag != "DataArray" for a in arrays):
                raise ReadError()
            for a in arrays:
                if a.attrib.get("NumberOfComponents") == "":  # as Firedrake writes it: meshio drops it too
                    a.attrib.pop("NumberOfComponents")
            if child.tag == "Points":
                if len(arrays) != 1:
                    raise ReadError()
                self.points = decoder.read_data(arrays[0]).reshape(self.n_points, int(arrays[0].attrib["NumberOfComponents"]))
            elif child.tag == "Cells":
                self.cells = {a.attrib["Name"]: decoder.read_data(a) for a in arrays}
                if len(self.cells["offsets"]) != self.n_cells or len(self.cells["types"]) != self.n_cells:
                    raise ReadError()
            else:
                into, n = (self.point_data, self.n_points) if child.tag == "PointData" else (self.cell_data, self.n_cells)
                for a in arrays:
                    names = _component_names(a.attrib)
                    if names:
                        components[a.attrib["Name"]] = names
                    shape = _announced_shape(decoder, a, n)
                    if shape is not None:  # its header agrees with the piece: decoded when first used
                        label = f"SED file {path!r}: {child.tag[:-4].lower()} array {a.attrib['Name']!r}"
                        into[a.attrib["Name"]] = Deferred(shape, lambda a=a: decoder.read_data(a), label)
                        continue
                    try:
                        into[a.attrib["Name"]] = decoder.read_data(a)
                    except CorruptionError as err:
                        if child.tag == "CellData":
                            raise
                        warn(err.args[0] + " Skipping.")  # meshio's own words, on stderr as meshio says them


def _announced_shape(decoder, array, n: int) -> tuple | None:
    """The shape meshio's ``read_data`` will give a binary DataArray, from its header alone, when the
    header announces ``n`` values (times NumberOfComponents); None otherwise (ASCII, another count,
    an unknown type or a damaged header: decoded at once, to meet the checks and messages as they are).

    The header is the first item(s) of the base64 text (inline, or at the array's offset in the
    appended data, which the parse has base64-encoded): uncompressed, the byte count; compressed,
    the number of blocks, the block size and the last block's size (0: a full block).
    """
    import base64

    from meshio.vtu._vtu import num_bytes_to_num_base64_chars, vtu_to_numpy_type

    attrib = array.attrib
    fmt = attrib.get("format", "ascii")
    try:
        dtype = np.dtype(vtu_to_numpy_type[attrib["type"]])
        k = int(attrib["NumberOfComponents"]) if "NumberOfComponents" in attrib else None
        if fmt == "binary":
            text = array.text.lstrip()
        elif fmt == "appended":
            text = decoder.appended_data[int(attrib["offset"]):]
        else:
            return None
        head = np.dtype(vtu_to_numpy_type[decoder.header_type])
        if decoder.byte_order is not None:
            head = head.newbyteorder("<" if decoder.byte_order == "LittleEndian" else ">")
        items = 3 if decoder.compression is not None else 1
        raw = base64.b64decode(text[:num_bytes_to_num_base64_chars(items * head.itemsize)])
        header = np.frombuffer(raw[:items * head.itemsize], head).astype(np.int64)
    except (KeyError, ValueError, TypeError, AttributeError):
        return None
    if len(header) != items or header.min() < 0:
        return None
    if decoder.compression is None:
        n_bytes = int(header[0])
    else:
        blocks, size, last = (int(h) for h in header)
        n_bytes = 0 if blocks == 0 else (blocks - 1) * size + (last or size)
    if k is None:
        return (n,) if n_bytes == n * dtype.itemsize else None
    return (n, k) if k > 0 and n_bytes == n * k * dtype.itemsize else None


def _check_counts(path: str, pieces: list, data: str, n_pieces: int) -> None:
    """Refuse a cell array (or, with several pieces, a point array) with more or fewer values than its piece has."""
    count = "n_cells" if data == "cell_data" else "n_points"
    many = n_pieces > 1
    for piece in pieces:
        n = getattr(piece, count)
        for name, values in getattr(piece, data).items():
            if values.shape[0] != n:  # a Deferred's shape is its piece's: checked by _announced_shape
                kind, attr = ("cell", "NumberOfCells") if data == "cell_data" else ("point", "NumberOfPoints")
                where = f" in piece {piece.index} of {n_pieces}" if many else ""
                raise VtuCountError(f"SED file {path!r}: {kind} array {name!r} must have one value per {kind}{where} "
                                     f"({attr} = {n}); got {values.shape[0]} instead.")


def _joined(path: str, pieces: list, data: str, n_pieces: int) -> dict:
    """Each array of every piece, pieces in order (one piece: no copy; deferred while every piece's is)."""
    first = getattr(pieces[0], data)
    if len(pieces) == 1:
        return dict(first)
    for piece in pieces[1:]:
        have = set(getattr(piece, data))
        if have != set(first):
            kind = "point" if data == "point_data" else "cell"
            raise VtuCountError(f"SED file {path!r}: piece {piece.index} of {n_pieces} has the {kind} arrays "
                                f"{sorted(have)}, piece {pieces[0].index} has {sorted(first)}; every piece must carry "
                                "the same arrays.")
    out = {}
    for name in first:
        parts = [getattr(p, data)[name] for p in pieces]
        if all(isinstance(v, Deferred) for v in parts) and len({v.shape[1:] for v in parts}) == 1:
            shape = (sum(v.shape[0] for v in parts),) + parts[0].shape[1:]
            out[name] = Deferred(shape, lambda parts=parts: np.concatenate([v.decode() for v in parts]), parts[0].label)
        else:
            out[name] = np.concatenate([v.decode() if isinstance(v, Deferred) else v for v in parts])
    return out


def _cells(pieces: list) -> list:
    """meshio cell blocks of every piece; each piece's connectivity offset by the points before it
    (meshio 5.3 keeps the last piece's only). The blocks are runs of one cell type in the file's
    order, so a cell array over all the file's cells is the blocks' data end to end."""
    from meshio._mesh import CellBlock
    from meshio._vtk_common import vtk_cells_from_data
    from meshio.vtu import _vtu

    blocks, offset = [], 0
    for piece in pieces:
        raw = piece.cells
        if not len(raw["types"]):  # points without cells: meshio's split fails on no cells
            offset += piece.n_points
            continue
        if "faces" in raw or np.any(raw["types"] == 42):  # polyhedra: meshio's own path (refused later, by type)
            got, _ = _vtu._organize_cells([offset], [raw], [{}])
        else:
            got, _ = vtk_cells_from_data(raw["connectivity"].ravel(), raw["offsets"].ravel(), raw["types"].ravel(), {})
            if offset:
                got = [CellBlock(b.type, b.data + offset) for b in got]
        blocks.extend(got)
        offset += piece.n_points
    return _runs_joined(blocks) if len(pieces) > 1 else blocks


def _runs_joined(blocks: list) -> list:
    """Adjacent blocks of one cell type and node count (a type running on from one piece into the
    next) as one block: a mesh's blocks do not depend on how it was cut."""
    from meshio._mesh import CellBlock

    runs: list[list[int]] = []
    for k, b in enumerate(blocks):
        last = blocks[runs[-1][0]] if runs else None
        if (last is not None and last.type == b.type and isinstance(b.data, np.ndarray) and b.data.ndim == 2
                and isinstance(last.data, np.ndarray) and last.data.shape[1:] == b.data.shape[1:]):
            runs[-1][1] = k + 1
        else:
            runs.append([k, k + 1])
    if len(runs) == len(blocks):
        return blocks
    return [blocks[a] if b - a == 1 else CellBlock(blocks[a].type, np.concatenate([c.data for c in blocks[a:b]]))
            for a, b in runs]


def read_vtu(path: str, parts=ALL_PARTS) -> VtuContent:
    """Read a VTU file in one parse: see the module docstring. ``parts``: which of :data:`ALL_PARTS` to decode."""
    from meshio import ReadError
    from meshio.vtu import _vtu

    root = _root(path)
    decoder = _decoder(root)
    grid, decoder.appended_data = _vtu.get_grid(root)
    unknown = [c.tag for c in grid if c.tag not in ("Piece", "FieldData")]
    if unknown:
        raise ReadError(f"Unknown grid subtag '{unknown[0]}'.")
    components: dict = {}
    pieces = [_Piece(decoder, p, parts, components, k, path) for k, p in enumerate(c for c in grid if c.tag == "Piece")]
    if not pieces:
        raise ReadError("No Piece found.")
    n_pieces = len(pieces)
    pieces = [p for p in pieces if not p.empty] or pieces[:1]
    many = len(pieces) > 1
    _check_counts(path, pieces, "cell_data", n_pieces)
    _check_counts(path, pieces, "point_data", n_pieces)
    points = None
    if "Points" in parts:
        if any(p.points is None for p in pieces):
            raise ReadError()
        points = np.concatenate([p.points for p in pieces]) if many else pieces[0].points
    point_data, cell_values = _joined(path, pieces, "point_data", n_pieces), _joined(path, pieces, "cell_data", n_pieces)
    blocks = []
    if "Cells" in parts and any(p.cells is not None for p in pieces):
        if any(p.cells is None for p in pieces):
            raise ReadError()
        blocks = _cells(pieces)
    return VtuContent(points, blocks, point_data, cell_values, sum(p.n_points for p in pieces),
                      sum(p.n_cells for p in pieces), n_pieces, components)
