"""CalculiX result files (``.frd``, ASCII or binary, optionally gzip-compressed).

CalculiX (ccx) writes its field output to ``job.frd``: a node block (``2C``), an element
block (``3C``), then one result block (``100C``) per output variable and output time, each
with its component names (``-5`` lines). Results in the ``.frd`` are always at the nodes:
ccx extrapolates integration-point values (stress, strain, the internal energy density
``ENER``) to the nodes of each element and averages them. ``*NODE FILE``/``*EL FILE`` write
ASCII (fixed-width fields, numbers that may touch: ``-1.2E-03-4.5E-01``); ``*NODE OUTPUT`` /
``*ELEMENT OUTPUT`` write the same blocks with binary records (int32 ids, float32 or float64
values; only the block headers stay text).

Component order and shear convention are CalculiX's own and are taken from the file: stress
``SXX SYY SZZ SXY SYZ SZX``, strain ``EXX ... EZX`` with tensor shear (CalculiX's
``calctotstrain.f`` halves the engineering shear before output), so the reader sets
``preset='calculix-frd'``. CalculiX has no units: the user declares them (an mm/N/s model has
stress and ENER in MPa).

Only volume elements become cells (hexahedra, wedges, tetrahedra, linear or quadratic: their
corner nodes come first in CalculiX's node order, as in VTK's); shells and beams are expanded
by ccx into volume elements before output.
"""

from __future__ import annotations

import gzip
import os
import re
import zlib

import numpy as np

from ..exceptions import SEDFormatError
from ._raw import RawArray, RawExport, drop_valueless_nodes, material_array

__all__ = ["read_frd", "frd_mesh"]

#: CalculiX .frd element type -> (meshio cell type, number of nodes).
FRD_ELEMENTS = {
    1: ("hexahedron", 8), 2: ("wedge", 6), 3: ("tetra", 4), 4: ("hexahedron20", 20), 5: ("wedge15", 15),
    6: ("tetra10", 10), 7: ("triangle", 3), 8: ("triangle6", 6), 9: ("quad", 4), 10: ("quad8", 8),
    11: ("line", 2), 12: ("line3", 3),
}
#: The .frd numbers the mid-edge nodes of its 20-node bricks and 15-node wedges (types 4 and 5)
#: vertical edges first, then the top face's edges (seen in ccx 2.20's own .frd: the element
#: block lists an input C3D15's nodes 1-9, 13-15, 10-12), while the input deck, VTK and meshio
#: put the top face's before the vertical ones: the columns of VTK's order in the .frd's.
FRD_TO_VTK = {"hexahedron20": np.r_[0:12, 16:20, 12:16], "wedge15": np.r_[0:9, 12:15, 9:12]}
_HEADER = re.compile(rb"^\s*(\d+)([A-Z])")


class _Blocks:
    """A cursor over the file's bytes: text lines for headers, raw bytes for binary payloads."""

    def __init__(self, data: bytes, path: str):
        self.data, self.pos, self.path, self.line_no = data, 0, path, 0

    def line(self) -> bytes | None:
        if self.pos >= len(self.data):
            return None
        end = self.data.find(b"\n", self.pos)
        end = len(self.data) if end < 0 else end
        out = self.data[self.pos:end].rstrip(b"\r")
        self.pos = end + 1
        self.line_no += 1
        return out

    def take(self, n: int, what: str) -> bytes:
        if self.pos + n > len(self.data):
            raise SEDFormatError(
                f"SED file {self.path!r} ends inside the binary {what} (after line {self.line_no}): it needs {n} bytes, "
                f"{len(self.data) - self.pos} remain (truncated?)."
            )
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def error(self, message: str) -> SEDFormatError:
        return SEDFormatError(f"SED file {self.path!r}, line {self.line_no}: {message}")


def _int(cur: _Blocks, token: bytes, what: str) -> int:
    try:
        return int(token)
    except ValueError:
        raise cur.error(f"{what} must be a whole number; got {token.decode('latin-1')!r} instead.") from None


def _records(cur: _Blocks, what: str) -> list[bytes]:
    """ASCII records of a block: the lines up to its ' -3' terminator (found with one search)."""
    data, start = cur.data, cur.pos
    end = start if data.startswith(b" -3", start) else data.find(b"\n -3", start) + 1
    if end <= 0:
        raise cur.error(f"the {what} block has no end (' -3'): the file is truncated.")
    lines = [line.rstrip(b"\r") for line in data[start:end].split(b"\n")[:-1]] if end > start else []
    cur.line_no += len(lines)
    cur.pos = start
    cur.pos = end
    cur.line()  # the ' -3' line itself
    return lines


def _fixed(lines: list[bytes], start: int, width: int, count: int, cur: _Blocks, what: str) -> np.ndarray:
    """Fixed-width numbers: ``count`` fields of ``width`` bytes from column ``start`` of each line."""
    span = width * count
    try:
        if lines and len({len(line) for line in lines}) == 1 and len(lines[0]) >= start + span:
            grid = np.frombuffer(b"".join(lines), dtype="S1").reshape(len(lines), len(lines[0]))
            fields = np.ascontiguousarray(grid[:, start:start + span]).view(f"S{width}")
        else:  # lines of different lengths (short last record line): pad each
            raw = b"".join(line[start:start + span].ljust(span) for line in lines)
            fields = np.frombuffer(raw, dtype=f"S{width}").reshape(len(lines), count)
        return fields.astype(np.float64)
    except ValueError as err:
        raise cur.error(f"the {what} block holds a field that is not a number ({err}).") from None


def _nodes(cur: _Blocks, header: bytes) -> tuple[np.ndarray, np.ndarray]:
    tokens = header.split()
    n = _int(cur, tokens[1], "the node count") if len(tokens) > 1 else 0
    fmt = int(tokens[-1]) if len(tokens) > 2 and tokens[-1].isdigit() else 1
    if fmt >= 2:
        size = 8 if fmt == 3 else 4
        rec = np.dtype([("id", "<i4"), ("xyz", f"<f{size}", 3)])
        arr = np.frombuffer(cur.take(n * rec.itemsize, "node block"), dtype=rec)
        return arr["id"].astype(np.int64), arr["xyz"].astype(np.float64)
    lines = _records(cur, "node")
    w = 5 if fmt == 0 else 10
    bad = [k for k, line in enumerate(lines) if not line.startswith(b" -1")]
    if bad:
        raise cur.error(f"the node block must hold ' -1' records; got {lines[bad[0]][:20].decode('latin-1')!r}.")
    ids = _fixed(lines, 3, w, 1, cur, "node")[:, 0].astype(np.int64)
    return ids, _fixed(lines, 3 + w, 12, 3, cur, "node")


def _elements(cur: _Blocks, header: bytes) -> list[tuple[int, int, list[int], int]]:
    """(element id, frd type, node ids, material number) per element."""
    tokens = header.split()
    n = _int(cur, tokens[1], "the element count") if len(tokens) > 1 else 0
    fmt = int(tokens[-1]) if len(tokens) > 2 and tokens[-1].isdigit() else 1
    out = []
    if fmt >= 2:
        for _ in range(n):
            eid, etype, _group, mat = np.frombuffer(cur.take(16, "element block"), dtype="<i4")
            if int(etype) not in FRD_ELEMENTS:
                raise cur.error(f"element {int(eid)} has type {int(etype)}, which is not a CalculiX element type.")
            k = FRD_ELEMENTS[int(etype)][1]
            out.append((int(eid), int(etype), np.frombuffer(cur.take(4 * k, "element block"), dtype="<i4").tolist(),
                        int(mat)))
        return out
    w = 5 if fmt == 0 else 10
    current = None
    for line in _records(cur, "element"):
        if line.startswith(b" -1"):
            eid = _int(cur, line[3:3 + w], "an element id")
            etype = _int(cur, line[3 + w:8 + w], "an element type")
            if etype not in FRD_ELEMENTS:
                raise cur.error(f"element {eid} has type {etype}, which is not a CalculiX element type.")
            mat = line[13 + w:18 + w].strip()  # after the group number: the material, 1-based in *MATERIAL order
            current = (eid, etype, [], _int(cur, mat, "a material number") if mat else 0)
            out.append(current)
        elif line.startswith(b" -2") and current is not None:
            body = line[3:]
            current[2].extend(_int(cur, body[i:i + w], "a node id") for i in range(0, len(body.rstrip()), w))
        else:
            raise cur.error(f"the element block must hold ' -1' and ' -2' records; got {line[:20].decode('latin-1')!r}.")
    for eid, etype, nodes, _mat in out:
        if len(nodes) != FRD_ELEMENTS[etype][1]:
            raise SEDFormatError(
                f"SED file {cur.path!r}: element {eid} (type {etype}, {FRD_ELEMENTS[etype][0]}) must list "
                f"{FRD_ELEMENTS[etype][1]} nodes; got {len(nodes)} instead."
            )
    return out


def _result(cur: _Blocks, header: bytes):
    """One ``100C`` block: (time, name, component names, node ids, values (n, n_stored))."""
    tokens = header.split()
    if len(tokens) < 4:
        raise cur.error("a result header ('100C') must give the time and the number of values.")
    try:
        time = float(tokens[2])
    except ValueError:
        raise cur.error(f"a result header ('100C') must give a time; got {tokens[2].decode('latin-1')!r}.") from None
    n = _int(cur, tokens[3], "the number of result values")
    fmt = int(tokens[-1]) if tokens[-1].isdigit() else 1
    line = cur.line()
    if line is None or not line.startswith(b" -4"):
        raise cur.error("a result header ('100C') must be followed by its ' -4' line (name and components).")
    t4 = line.split()
    if len(t4) < 3:
        raise cur.error(f"the ' -4' line must give a name and a component count; got {line.decode('latin-1')!r}.")
    name = t4[1].decode("latin-1")
    ncomp = _int(cur, t4[2], "the component count")
    stored = []
    for _ in range(ncomp):
        c = cur.line()
        if c is None or not c.startswith(b" -5"):
            raise cur.error(f"result {name!r} must list {ncomp} components on ' -5' lines.")
        t5 = c.split()
        if len(t5) < 2:
            raise cur.error(f"a ' -5' line of result {name!r} must name its component; got {c.decode('latin-1')!r}.")
        computed = len(t5) > 6 and t5[6][:1] == b"1"  # e.g. 'ALL' (a magnitude ccx does not store)
        if not computed:
            stored.append(t5[1].decode("latin-1"))
    k = len(stored)
    if k == 0:
        raise cur.error(f"result {name!r} stores no component (every ' -5' line is a computed one).")
    if fmt >= 2:
        size = 8 if fmt == 3 else 4
        rec = np.dtype([("id", "<i4"), ("v", f"<f{size}", (k,))])
        arr = np.frombuffer(cur.take(n * rec.itemsize, f"result block {name!r}"), dtype=rec)
        return time, name, tuple(stored), arr["id"].astype(np.int64), arr["v"].astype(np.float64).reshape(n, k)
    lines = _records(cur, f"result {name!r}")
    w = 5 if fmt == 0 else 10
    per = (k + 5) // 6  # ccx writes 6 values per line, continuing on ' -2' lines
    if len(lines) % per:
        raise cur.error(f"result {name!r} must have {per} line(s) per node; got {len(lines)} lines.")
    first = lines[0::per]
    if any(not line.startswith(b" -1") for line in first):
        raise cur.error(f"result {name!r} must hold ' -1' records.")
    ids = _fixed(first, 3, w, 1, cur, f"result {name!r}")[:, 0].astype(np.int64)
    parts = [_fixed(lines[j::per], 3 + w, 12, min(6, k - 6 * j), cur, f"result {name!r}") for j in range(per)]
    return time, name, tuple(stored), ids, np.concatenate(parts, axis=1)


def _parse(path: str):
    """(node ids, coordinates, elements, result blocks, version, binary?) of a .frd file."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as err:
            raise SEDFormatError(f"SED file {path!r} is a damaged gzip file: {err}") from err
    if not data.strip():
        raise SEDFormatError(f"SED file {path!r} is empty.")
    cur = _Blocks(data, path)
    first = cur.line()
    if first is None or not re.match(rb"^\s*1C", first):
        raise SEDFormatError(
            f"SED file {path!r} is not a CalculiX .frd file: it must start with the '    1C' header line; got "
            f"{(first or b'')[:40].decode('latin-1')!r} instead."
        )
    version = None
    node_ids = coords = None
    elements: list = []
    results: list = []
    while True:
        line = cur.line()
        if line is None:
            break
        if line.strip() == b"9999":
            break
        m = _HEADER.match(line)
        if not m:
            if line.strip() and not line.startswith((b" -1", b" -2", b" -3", b" -4", b" -5")):
                raise cur.error(f"expected a block header ('2C', '3C', '1P', '100C', '9999'); got "
                                f"{line[:40].decode('latin-1')!r} (a damaged file?).")
            continue  # blank, or a record of a block afferent does not read
        key = m.group(1) + m.group(2)
        if key == b"1U" and line[6:13] == b"VERSION":
            version = line[13:].strip().decode("latin-1")
        elif key == b"2C":
            node_ids, coords = _nodes(cur, line)
        elif key == b"3C":
            elements = _elements(cur, line)
        elif key == b"100C":
            results.append(_result(cur, line))
    if node_ids is None or node_ids.size == 0:
        raise SEDFormatError(f"SED file {path!r} has no node block ('2C'): no coordinates to place the results at.")
    return node_ids, coords, elements, results, version, b"\x00" in data[:65536]


def frd_mesh(path: str):
    """(node ids, node coordinates (n, 3), elements [(id, frd type, node ids, material number)]) of a ``.frd``."""
    node_ids, coords, elements, _, _, _ = _parse(path)
    return node_ids, coords, elements


def _cells(path: str, index: dict, elements):
    """(volume cells for sampling or None, the material number of each cell in cell order) of the element block."""
    from ._cell_blocks import cells_from_meshio

    blocks: dict[str, list] = {}
    materials: dict[str, list] = {}  # per cell type, in the order the cells are made
    for eid, etype, nodes, mat in elements:
        try:
            blocks.setdefault(FRD_ELEMENTS[etype][0], []).append([index[n] for n in nodes])
            materials.setdefault(FRD_ELEMENTS[etype][0], []).append(mat)
        except KeyError as err:
            raise SEDFormatError(f"SED file {path!r}: element {eid} refers to node {err.args[0]}, "
                                 "which the node block does not list.") from None

    class _Block:  # what cells_from_meshio reads: .type and .data
        def __init__(self, ctype, conn):
            self.type, self.data = ctype, np.asarray(conn, dtype=np.int64)

    cells = cells_from_meshio([_Block(t, np.asarray(c)[:, FRD_TO_VTK[t]] if t in FRD_TO_VTK else c)
                               for t, c in blocks.items()], path) if blocks else None
    return cells, [m for t in blocks for m in materials[t]]


def _material_array(numbers: list[int], n_times: int) -> RawArray | None:
    """The elements' material numbers (in cell order) as the cell array ``material``, when there are several.

    ccx numbers the materials from 1 in the order of the input deck's ``*MATERIAL`` cards. With
    several, the interface between two of them can be found (``--grid tips --material-array
    material``); one material (or none, 0) gives no array.
    """
    if len(numbers) == 0 or min(numbers) < 1:
        return None
    return material_array(numbers, n_times)


def read_frd(path: str, *, progress: bool = False) -> RawExport:
    """Read a CalculiX ``.frd`` result file (ASCII or binary, or ``.frd.gz``).

    Parameters
    ----------
    path : str
        The ``.frd`` (or ``.frd.gz``) file.
    progress : bool
        Unused (reading is a single pass); accepted for a uniform reader signature.

    Returns
    -------
    RawExport
        Points (the node coordinates, in the model's length unit), volume cells, one array
        per result variable (``DISP``, ``STRESS``, ``TOSTRAIN``, ``ENER``, ...; point data,
        shape (n_times, n_nodes[, n_components]) with CalculiX's component names), the time
        of each output step, and ``preset='calculix-frd'``.

    Raises
    ------
    SEDFormatError
        Not a ``.frd`` file, a block that is truncated or malformed (the message gives the
        line), results at nodes that are not in the node block, or a time step that lacks a
        variable the first step has.
    """
    node_ids, coords, elements, results, version, binary = _parse(path)
    index = {int(i): k for k, i in enumerate(node_ids)}
    if len(index) != node_ids.size:
        raise SEDFormatError(f"SED file {path!r}: the node block lists a node id twice.")

    cells, numbers = _cells(path, index, elements)

    # results: group the blocks by output time, in file order
    order = np.argsort(node_ids, kind="stable")
    sorted_ids = node_ids[order]
    times: list[float] = []
    per_step: list[dict] = []
    for time, name, comps, ids, values in results:
        if not times or time != times[-1] or name in per_step[-1]:
            times.append(time)
            per_step.append({})
        rows = np.searchsorted(sorted_ids, ids)
        rows = np.where((rows < sorted_ids.size) & (sorted_ids[np.minimum(rows, sorted_ids.size - 1)] == ids),
                        order[np.minimum(rows, sorted_ids.size - 1)], -1)
        if (rows < 0).any():
            raise SEDFormatError(f"SED file {path!r}: result {name!r} at t = {time:g} has values for node "
                                 f"{int(ids[rows < 0][0])}, which the node block does not list.")
        full = np.full((node_ids.size, values.shape[1]), np.nan)
        full[rows] = values
        per_step[-1][name] = (comps, full)
    if not per_step:
        raise SEDFormatError(f"SED file {path!r} holds a mesh but no result blocks ('100C'): request output with "
                             "*NODE FILE / *EL FILE (e.g. S, E, ENER).")
    names = list(per_step[0])
    arrays = {}
    for name in names:
        steps = []
        for k, step in enumerate(per_step):
            if name not in step:
                raise SEDFormatError(f"SED file {path!r}: output step {k} (t = {times[k]:g}) lacks the result "
                                     f"{name!r} that step 0 has; every step must carry the same variables.")
            if step[name][1].shape != per_step[0][name][1].shape:
                raise SEDFormatError(
                    f"SED file {path!r}: result {name!r} has {step[name][1].shape[1]} component(s) in output step "
                    f"{k} (t = {times[k]:g}) but {per_step[0][name][1].shape[1]} in step 0; every step must carry "
                    "the same components.")
            steps.append(step[name][1])
        comps = per_step[0][name][0]
        stacked = np.stack(steps)
        values = stacked[..., 0] if stacked.shape[2] == 1 else stacked
        arrays[name] = RawArray(name, values, "point", None, comps if stacked.shape[2] > 1 else ())
    material = _material_array(numbers, len(times))
    if material is not None:
        arrays["material"] = material
    kind = "binary" if binary else "ASCII"
    notes = [f"CalculiX .frd ({kind})"
             + (f", written by CalculiX {version}" if version else "")
             + f": {len(times)} output step(s), results {', '.join(names)}; nodal values (ccx extrapolates "
             "integration-point values to the nodes and averages them)."]
    if material is not None:
        notes.append(f"cell array 'material': the material number of each element (1-based, in the order of the input "
                     f"deck's *MATERIAL cards; {np.unique(material.values[0]).size} materials)")
    points = coords
    return drop_valueless_nodes(RawExport(
        files=(path,), format="frd", points=points, arrays=arrays, times=np.asarray(times, dtype=float),
        cells=cells, notes=tuple(notes), preset="calculix-frd",
    ))
