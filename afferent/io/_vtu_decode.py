"""The binary DataArrays of a VTU, decoded in bounded memory (for :mod:`afferent.io._vtu`).

meshio's ``VtuReader.read_data`` inflates each compressed block whole, whatever size its header
declares: 1 MB of zlib inflates to 1 GiB. :class:`_Decoder` reads the same layouts (ASCII; binary
inline or appended, base64 or raw; zlib or LZMA blocks; UInt32 or UInt64 headers; either byte
order) from an array's own bytes alone, and inflates no block beyond its declared size.
"""

from __future__ import annotations

import base64
import lzma
import re
import zlib

import numpy as np

from ..exceptions import SEDFormatError

__all__ = ["VtuCountError", "_Decoder"]


class VtuCountError(SEDFormatError):
    """A VTU that parses but whose pieces' arrays disagree with their counts (or with one another, or a
    compressed block with the size its header declares, or a binary array's header cut short): refused as it
    is, not handed to VTK's reader (which reads such a file without a word, inflates the block, or loops on a
    corrupt header: fuzz/fuzz_loop.py, session 9)."""


_NOT_SPACE = re.compile(r"\S")


def _chars(n_bytes: int) -> int:
    """The base64 characters that encode ``n_bytes`` bytes (padding included)."""
    return -(-n_bytes // 3) * 4


class _Source:
    """The bytes of one binary DataArray: base64 text from a character index (inline, or base64
    appended data), or raw bytes from a byte offset (raw appended data); only what is asked for is
    decoded."""

    def __init__(self, data, start: int, encoded: bool):
        self.data, self.start, self.encoded = data, start, encoded

    @property
    def size(self) -> int:
        """The bytes there are from the array's start to the end of its data (an upper bound)."""
        n = max(len(self.data) - self.start, 0)
        return n * 3 // 4 if self.encoded else n

    def head(self, n: int) -> bytes:
        """The first ``n`` bytes (the header; fewer when the data ends before)."""
        if self.encoded:
            return base64.b64decode(self.data[self.start:self.start + _chars(n)])[:n]
        return bytes(self.data[self.start:self.start + n])

    def body(self, head: int, n: int):
        """The ``n`` bytes after a header of ``head`` bytes (raw data: a view, not a copy). VTK encodes
        the header and the body apart (the header's base64 padded); some writers as one stream."""
        if not self.encoded:
            return self.data[self.start + head:self.start + head + n]
        at = self.start + _chars(head)
        if head % 3 and self.data[at - 1:at] != "=":  # one stream: the body starts inside the header's last chars
            return base64.b64decode(self.data[self.start:self.start + _chars(head + n)])[head:head + n]
        return base64.b64decode(self.data[at:at + _chars(n)])[:n]


class _Decoder:
    """The DataArrays of one VTU decoded as meshio's ``VtuReader.read_data`` does (ASCII; binary
    inline or appended, base64 or raw; zlib or LZMA blocks), except that a binary array is read from
    its own bytes alone and never inflated beyond what its header declares:

    - each compressed block is inflated to at most its declared size (plus one byte, to tell):
      a block that inflates to more (a decompression bomb: 1 MB of zlib can inflate to 1 GiB) or
      to less is refused, naming the file, the array and both sizes, after at most that many bytes;
    - a caller that knows how many bytes the array may hold (its piece's counts) passes ``limit``:
      a header declaring more is refused before anything is inflated.

    The refusals are :class:`VtuCountError` (not handed to VTK's reader, which would inflate it).
    """

    def __init__(self, root, appended, path: str):
        from meshio import ReadError
        from meshio.vtu._vtu import vtu_to_numpy_type

        self.path, self.appended = path, appended
        self.compression = root.attrib.get("compressor")
        if self.compression not in (None, "vtkLZMADataCompressor", "vtkZLibDataCompressor"):
            raise ReadError(f"Unknown compressor '{self.compression}'.")
        self.byte_order = root.attrib.get("byte_order")
        if self.byte_order not in (None, "LittleEndian", "BigEndian"):
            raise ReadError(f"Unknown byte order '{self.byte_order}'.")
        self.head = self.ordered(vtu_to_numpy_type[root.attrib.get("header_type", "UInt32")])

    def ordered(self, dtype) -> np.dtype:
        """``dtype`` in the file's byte order."""
        return dtype if self.byte_order is None else dtype.newbyteorder("<" if self.byte_order == "LittleEndian" else ">")

    def source(self, array) -> _Source | None:
        """Where a binary DataArray's bytes are; None for an ASCII one."""
        from meshio import ReadError

        fmt = array.attrib.get("format", "ascii")
        if fmt == "binary":
            text = array.text or ""
            first = _NOT_SPACE.search(text)
            start = len(text) if first is None else first.start()
            end = len(text)
            while end > start and text[end - 1].isspace():
                end -= 1
            if any(text.find(c, start, end) >= 0 for c in " \n\r\t"):  # a writer that wraps its lines
                text, start = "".join(text.split()), 0
            return _Source(text, start, True)
        if fmt == "appended":
            offset = int(array.attrib["offset"])
            if self.appended is None or offset < 0:
                raise ReadError(f"appended DataArray {array.attrib.get('Name')!r}: no appended data at offset {offset}")
            if isinstance(self.appended, tuple):  # base64: (the text, the index of its first array's first char)
                return _Source(self.appended[0], self.appended[1] + offset, True)
            return _Source(self.appended, offset, False)
        if fmt != "ascii":
            raise ReadError(f"Unknown data format '{fmt}'.")
        return None

    def header(self, source: _Source, label: str) -> np.ndarray:
        """The array's header, int64: ``[bytes]``, or compressed ``[blocks, block size, last block's size,
        each block's compressed size...]``."""
        item = self.head.itemsize
        n = item
        if self.compression is not None:
            first = source.head(item)
            blocks = int(np.frombuffer(first, self.head)[0]) if len(first) == item else -1
            if not 0 <= blocks <= source.size // item:
                raise VtuCountError(f"{label}: its header is cut short or corrupt (a truncated file?).")
            n = (3 + blocks) * item
        raw = source.head(n)
        header = np.frombuffer(raw[:len(raw) // item * item], self.head).astype(np.int64)
        if len(raw) < n or header.min(initial=0) < 0:
            raise VtuCountError(f"{label}: its header is cut short or corrupt (a truncated file?).")
        return header

    def declared(self, header: np.ndarray) -> int:
        """The bytes the array's values take once decoded, as its header declares them."""
        if self.compression is None:
            return int(header[0])
        blocks, size, last = (int(h) for h in header[:3])
        return 0 if blocks == 0 else (blocks - 1) * size + (last or size)

    def read_data(self, array, label: str, limit: int | None = None) -> np.ndarray:
        """The values of a DataArray element, shaped as meshio's ``read_data`` gives them; ``limit``:
        the most bytes they may take (None: what the header declares)."""
        from meshio import ReadError
        from meshio._exceptions import CorruptionError
        from meshio.vtu._vtu import vtu_to_numpy_type

        try:
            dtype = vtu_to_numpy_type[array.attrib["type"]]
        except KeyError:
            raise ReadError(f"Illegal data type '{array.attrib.get('type')}'.") from None
        source = self.source(array)
        if source is None:
            text = array.text or ""
            data = np.empty((0,), dtype) if not text.strip() else np.fromstring(text, dtype=dtype, sep=" ")
        else:
            data = self._binary(source, self.ordered(dtype), label, limit)
        if "NumberOfComponents" in array.attrib:
            nc = int(array.attrib["NumberOfComponents"])
            try:
                data = data.reshape(-1, nc)
            except ValueError:
                raise CorruptionError(f"VTU file corrupt. The size of the data array '{array.attrib.get('Name')}' is "
                                      f"{data.size} which doesn't fit the number of components {nc}.") from None
        return data

    def _binary(self, source: _Source, dtype, label: str, limit: int | None) -> np.ndarray:
        """A binary array's values from its header and bytes, each block inflated to at most its declared size."""
        header = self.header(source, label)
        n_bytes = self.declared(header)
        if limit is not None and n_bytes > limit:
            raise VtuCountError(f"{label}: its header declares {n_bytes:,} bytes of values, more than the {limit:,} "
                                "its piece's counts allow: the file is corrupt; refused without decoding it.")
        if self.compression is None:
            values = np.frombuffer(source.body(self.head.itemsize, n_bytes), dtype)
            return values if source.encoded else values.copy()  # a copy: not a view keeping the whole file alive
        blocks, size, last = (int(h) for h in header[:3])
        sizes = header[3:]
        body = source.body(len(header) * self.head.itemsize, int(sizes.sum()))
        out = np.empty(n_bytes, np.uint8)
        into = memoryview(out)  # a block copied in through the buffer: 0.04 instead of 0.33 s for 3,818 blocks
        at = done = 0
        for k, packed in enumerate(int(p) for p in sizes):
            want = last if k == blocks - 1 and last else size
            unzip = zlib.decompressobj() if self.compression == "vtkZLibDataCompressor" else lzma.LZMADecompressor()
            got = unzip.decompress(body[at:at + packed], want + 1)
            if len(got) != want or not unzip.eof:
                kind = "zlib" if self.compression == "vtkZLibDataCompressor" else "LZMA"
                more = len(got) > want
                raise VtuCountError(f"{label}: {kind} block {k + 1} of {blocks} inflates to "
                                    f"{f'more than {want:,}' if more else f'{len(got):,}'} bytes where its header "
                                    f"declares {want:,}: the file is corrupt"
                                    + (" (or a decompression bomb); refused without inflating it further." if more else "."))
            into[done:done + want] = got
            at, done = at + packed, done + want
        return out.view(dtype)
