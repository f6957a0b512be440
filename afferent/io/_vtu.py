"""A VTU file in one parse: points, cells, data arrays, component names.

meshio 5.3's ``meshio.vtu.read`` joins the points of a VTU with several ``<Piece>`` elements but
keeps only the last piece's cells (``_organize_cells`` leaves its loop over the pieces before
collecting the cells); it splits cell data among the cell blocks without counting it against
``NumberOfCells``; it drops the DataArrays' ``ComponentName`` attributes; it refuses VTU
file version 2.x; and it inflates every compressed block whole, whatever its header declares
(1 MB of zlib can inflate to 1 GiB), re-encoding raw appended data as base64 at parse time.
:func:`read_vtu` parses the XML once (``xml.etree``; a file with raw appended data: the XML
around the data, which stays raw bytes), decodes each DataArray with :class:`_Decoder` (meshio's
layouts: ASCII, base64 or raw, zlib or LZMA blocks; each block inflated to at most the size its
header declares) and its cells with meshio's ``vtk_cells_from_data``, and from that one parse
returns:

- points, every piece's in turn;
- cells, each piece's connectivity offset by the points of the pieces before it;
- point and cell data, joined piece by piece in the cells' order, each counted per piece
  against ``NumberOfPoints`` / ``NumberOfCells`` (a value too many or too few is an error
  naming the file, the array, the piece, and both counts);
- the arrays' ``ComponentName0..`` attributes (ccx2paraview writes ``XX YY ZZ XY YZ ZX``).

A binary data array is not decoded here: its header (its byte count; a compressed array's block
sizes) gives its shape, and it comes back as a :class:`~afferent.io._raw.Deferred`, decoded on
first use, so that a reader after the SED alone does not decompress the displacements and the
other arrays beside it (the arrays' bytes stay in memory with the parsed file until then). A
header declaring another count than its piece's is refused by the count checks before anything
is inflated. ASCII arrays, and binary ones whose header cannot tell their shape, are decoded at
once, never beyond their piece's counts (the points, ``NumberOfPoints`` x components; the
connectivity, up to the last offset).

Memory: the file's bytes (raw appended) or its parsed text (inline, base64 appended), plus the
arrays decoded, plus one block (VTK: 32 kB) at a time.

Errors are meshio's (``ReadError``, ``ValueError``, ...), which the caller turns into one
message naming the file, or :class:`VtuCountError` (and, for a damaged header,
:class:`~afferent.exceptions.SEDFormatError`) naming the file and the array.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.etree import ElementTree as ET

import numpy as np

from ..exceptions import SEDFormatError
from ._raw import Deferred
from ._vtu_decode import _NOT_SPACE, VtuCountError, _Decoder

__all__ = ["VtuContent", "VtuCountError", "read_vtu", "ALL_PARTS"]

#: The parts of a piece :func:`read_vtu` decodes by default; a series' later steps skip "Cells".
ALL_PARTS = ("Points", "Cells", "PointData", "CellData")


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
    """(the parsed VTKFile element, its appended data): meshio's checks of the header; the appended
    data as :class:`_Decoder` takes it (None, base64 text, or the raw bytes of a raw section)."""
    from meshio import ReadError

    try:
        root, raw = ET.parse(path).getroot(), None
    except ET.ParseError:
        root, raw = _raw_appended(path)
    if root.tag != "VTKFile":
        raise ReadError(f"Expected tag 'VTKFile', found {root.tag}")
    if root.attrib.get("type") != "UnstructuredGrid":
        raise ReadError(f"Expected type UnstructuredGrid, found {root.attrib.get('type')}")
    return root, raw


def _raw_appended(path: str):
    """(the VTKFile element, the raw bytes of the appended data after its ``_``) of a file with raw
    (binary) appended data: the XML around the data parsed alone, the data left as it is (a view of
    the file's bytes, decoded array by array when used, at each array's own byte offset).

    meshio's ``_parse_raw_binary`` instead inflates and base64-encodes every array at parse time
    (a 230 MB file: 1.37 GB at peak; a zlib block declaring 5,832 bytes that inflates to 1 GiB:
    6.5 GB, used or not) and finds each array by its offset *after* giving the arrays before it
    their new (base64) offsets, so that one array can get another's data (NGSolve's
    ``VTKOutput(floatsize="single")``).
    """
    import re

    from meshio import ReadError

    with open(path, "rb") as f:
        raw = f.read()
    start, stop = re.search(rb'<AppendedData[^>]+(?:">)', raw), raw.rfind(b"</AppendedData>")
    under = -1 if start is None else raw.find(b"_", start.end(), stop)
    if start is None or stop < start.end() or under < 0:
        raise ReadError()
    root = ET.fromstring(raw[:start.end()].decode() + raw[stop:].decode())
    return root, memoryview(raw)[under + 1:stop]


def _grid(root, raw):
    """(the UnstructuredGrid element, the appended data: None, base64 text or raw bytes), as meshio's
    ``get_grid`` checks them (the base64 text kept whole, with the index of its first array's char)."""
    from meshio import ReadError

    grid, appended = None, None
    for c in root:
        if c.tag == "UnstructuredGrid":
            if grid is not None:
                raise ReadError("More than one UnstructuredGrid found.")
            grid = c
        elif c.tag != "AppendedData":
            raise ReadError(f"Unknown main tag '{c.tag}'.")
        elif appended is not None:
            raise ReadError("More than one AppendedData section found.")
        elif raw is not None:
            if c.attrib.get("encoding") != "raw":
                raise ReadError("")
            appended = raw
        else:
            if c.attrib.get("encoding") != "base64":
                raise ReadError("")
            text = c.text or ""
            first = _NOT_SPACE.search(text)
            if first is None or text[first.start()] != "_":  # the data begins with a (meaningless) underscore
                raise ReadError()
            appended = (text, first.start() + 1)
    if grid is None:
        raise ReadError("No UnstructuredGrid found.")
    return grid, appended


def _component_names(attrib: dict) -> tuple[str, ...]:
    """The ``ComponentName0..`` of a DataArray tag when it names every component (else ``()``)."""
    named = {k[13:]: v for k, v in attrib.items() if k.startswith("ComponentName")}
    if not named:
        return ()
    # the names the tag carries, not range(NumberOfComponents): a corrupt count (9999999999) is no loop
    comps = [named[str(i)] for i in range(len(named)) if str(i) in named]
    ok = comps and str(len(comps)) == attrib.get("NumberOfComponents", "").strip()
    return tuple(comps) if ok else ()


#: How each part of a piece names its arrays in messages.
_PART = {"Points": "points", "Cells": "cells", "PointData": "point", "CellData": "cell"}


def _label(path: str, part: str, array) -> str:
    """How a message names a DataArray, e.g. ``SED file 'a.vtu': point array 'sed'``."""
    return f"SED file {path!r}: {_PART[part]} array {array.attrib.get('Name', part)!r}"


def _most_bytes(array, n: int) -> int | None:
    """The bytes ``n`` values (times NumberOfComponents) of a DataArray's type take; None for an unknown type."""
    from meshio.vtu._vtu import vtu_to_numpy_type

    try:
        k = int(array.attrib.get("NumberOfComponents", 1))
        return max(n, 0) * max(k, 1) * np.dtype(vtu_to_numpy_type[array.attrib["type"]]).itemsize
    except (KeyError, ValueError, TypeError):
        return None


class _Piece:
    """One ``<Piece>`` decoded: its counts, points, raw cells and data arrays."""

    def __init__(self, decoder, piece, parts, components: dict, index: int, path: str):
        from meshio import ReadError

        self.index = index  # in the file, from 0
        self.n_points = int(piece.attrib["NumberOfPoints"])
        self.n_cells = int(piece.attrib["NumberOfCells"])
        self.points, self.cells, self.point_data, self.cell_data = None, None, {}, {}
        #: no points and no cells (a parallel writer's idle rank): nothing to decode, left out when the
        #: pieces are joined
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
                points = decoder.read_data(arrays[0], _label(path, "Points", arrays[0]), _most_bytes(arrays[0], self.n_points))
                self.points = points.reshape(self.n_points, int(arrays[0].attrib["NumberOfComponents"]))
            elif child.tag == "Cells":
                self.cells = _cell_arrays(decoder, arrays, self.n_cells, path)
            else:
                self._data(decoder, child.tag, arrays, components, path)

    def _data(self, decoder, part: str, arrays: list, components: dict, path: str) -> None:
        """The arrays of a PointData or CellData element: deferred when their headers tell their shapes."""
        from meshio._common import warn
        from meshio._exceptions import CorruptionError

        into, n = (self.point_data, self.n_points) if part == "PointData" else (self.cell_data, self.n_cells)
        for a in arrays:
            names = _component_names(a.attrib)
            if names:
                components[a.attrib["Name"]] = names
            label = _label(path, part, a)
            shape = _announced_shape(decoder, a, label)
            if shape is not None:  # decoded when first used; a count other than n is refused before that
                into[a.attrib["Name"]] = Deferred(shape, lambda a=a, label=label: decoder.read_data(a, label), label)
                continue
            try:
                into[a.attrib["Name"]] = decoder.read_data(a, label, _most_bytes(a, n))
            except CorruptionError as err:
                if part == "CellData":
                    raise
                warn(err.args[0] + " Skipping.")  # meshio's own words, on stderr as meshio says them


def _cell_arrays(decoder, arrays: list, n_cells: int, path: str) -> dict:
    """A piece's cell arrays by name (``types``, ``offsets``, then ``connectivity`` up to the last
    offset; a polyhedral piece's ``faceoffsets`` and ``faces``), none decoded beyond what the counts
    before it allow; other arrays, which the cells do not use, are not decoded."""
    from meshio import ReadError

    by_name = {a.attrib.get("Name"): a for a in arrays}
    if any(name not in by_name for name in ("types", "offsets", "connectivity")):
        raise ReadError()
    out = {}
    for name in ("types", "offsets", "faceoffsets", "connectivity", "faces"):
        if name not in by_name:
            continue
        a = by_name[name]
        if name in ("connectivity", "faces"):
            last = out["offsets" if name == "connectivity" else "faceoffsets"].ravel()
            n = int(max(last.max(initial=0), 0))
        else:
            n = n_cells
        out[name] = decoder.read_data(a, _label(path, "Cells", a), _most_bytes(a, n))
    if len(out["offsets"]) != n_cells or len(out["types"]) != n_cells:
        raise ReadError()
    return out


def _announced_shape(decoder, array, label: str) -> tuple | None:
    """The shape a binary DataArray's values will have, from its header alone: ``(rows,)``, or
    ``(rows, k)`` when the tag gives NumberOfComponents ``k``, ``rows`` the declared bytes over ``k``
    values' size; None when the header cannot tell (ASCII, an unknown type, a damaged header, a byte
    count that is no whole number of rows: decoded at once, to meet the checks and messages as they are).

    ``rows`` need not be the piece's count: the count checks refuse another one before anything is
    decoded (a header declaring a thousand times the piece's values is never inflated).
    """
    from meshio.vtu._vtu import vtu_to_numpy_type

    attrib = array.attrib
    try:
        dtype = np.dtype(vtu_to_numpy_type[attrib["type"]])
        k = int(attrib["NumberOfComponents"]) if "NumberOfComponents" in attrib else None
        source = decoder.source(array)
        if source is None or (k is not None and k <= 0):
            return None
        n_bytes = decoder.declared(decoder.header(source, label))
    except (KeyError, ValueError, TypeError, AttributeError, SEDFormatError):
        return None
    rows, rest = divmod(n_bytes, (k or 1) * dtype.itemsize)
    if rest:
        return None
    return (rows,) if k is None else (rows, k)


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
            got = _one_type(raw) or vtk_cells_from_data(raw["connectivity"].ravel(), raw["offsets"].ravel(),
                                                        raw["types"].ravel(), {})[0]
            if offset:
                got = [CellBlock(b.type, b.data + offset) for b in got]
        blocks.extend(got)
        offset += piece.n_points
    return _runs_joined(blocks) if len(pieces) > 1 else blocks


def _one_type(raw: dict) -> list | None:
    """A piece's cells as one meshio block that is a view of its connectivity, when every cell is of one
    fixed-size type written end to end (offsets ``k, 2k, 3k, ...``; no reordering of its nodes): what
    meshio's ``vtk_cells_from_data`` gives then, without its index array and copy (2M hexahedra: 1.3 s
    and 0.25 GB at peak). None otherwise (meshio's own split)."""
    from meshio._common import num_nodes_per_cell
    from meshio._mesh import CellBlock
    from meshio._vtk_common import vtk_to_meshio_order, vtk_to_meshio_type

    types, offsets, conn = raw["types"].ravel(), raw["offsets"].ravel(), raw["connectivity"].ravel()
    if not len(types) or len(offsets) != len(types) or types.min() != types.max():
        return None
    kind = vtk_to_meshio_type.get(int(types[0]))
    k = num_nodes_per_cell.get(kind)
    if k is None or kind == "polygon" or kind.startswith("VTK_LAGRANGE") or vtk_to_meshio_order(int(types[0])) is not None:
        return None
    n = len(types)
    if len(conn) < n * k or offsets[0] != k or not np.array_equal(np.diff(offsets), np.broadcast_to(np.asarray(k, offsets.dtype), (n - 1,))):
        return None
    return [CellBlock(kind, conn[:n * k].reshape(n, k))]


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

    root, raw = _root(path)
    grid, appended = _grid(root, raw)
    decoder = _Decoder(root, appended, path)
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


def cell_array_names(path: str, chunk: int = 1 << 16) -> tuple[str, ...] | None:
    """The names of the cell-data arrays of a VTU's first piece, from its XML alone: no array decoded.

    The file is read in ``chunk`` bytes through a pull parser up to the end of that piece's
    ``<CellData>`` (or of the piece): with raw or base64 appended data (the usual binary VTU) only
    the small XML header; with inline data, the text of the arrays written before ``<CellData>``.
    None when the XML does not tell (not well-formed up to there, not an UnstructuredGrid): the
    caller then checks after the file is read.
    """
    parser = ET.XMLPullParser(events=("start", "end"))
    names, inside, grid = [], False, False
    with open(path, "rb") as f:
        while True:
            data = f.read(chunk)
            broken = False
            try:
                parser.feed(data) if data else parser.close()
            except ET.ParseError:  # raw appended bytes, or a damaged file: the events before it still count
                broken = True
            for event, el in parser.read_events():
                grid = grid or (event == "start" and el.tag == "UnstructuredGrid")
                if event == "start" and el.tag == "CellData":
                    inside = True
                elif event == "start" and el.tag == "DataArray" and inside and el.get("Name") is not None:
                    names.append(el.get("Name"))
                elif event == "end" and el.tag in ("CellData", "Piece") or event == "start" and el.tag == "AppendedData":
                    return tuple(names) if grid else None
            if broken or not data:
                return None
