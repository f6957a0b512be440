"""FEBio plot files (``.xplt``): the binary result file FEBio writes by default.

The layout is FEBio's own (``FEBioPlot/FEBioPlotFile.h`` and ``PltArchive.cpp`` in FEBio's source;
see docs/fe-export.md, "FEBio"; read by :mod:`afferent.io._xplt_file`): the tag ``BEF\\0``, then
chunks, each ``(id: uint32, size: uint32, payload)``, a branch's payload being its child chunks:

- the root (0x01000000): the header (plot file version, compression flag, the software that wrote
  it, FEBio 4's unit system) and the dictionary: each plot variable's name, data type (FLOAT,
  VEC3F, MAT3FS, MAT3FD, TENS4FS, MAT3F, ARRAY, ARRAY_VEC3F), storage format (NODE, ITEM, MULT,
  REGION) and class (nodal, domain, surface, edge, global);
- the mesh (0x01040000): the nodes (id and reference x, y, z as float32), the domains (element
  type, part id, element ids and 0-based connectivity), surfaces, node sets, parts;
- one state (0x02000000) per output time: the time (float32) and, per variable, one float32 block
  per domain (chunk id = domain number), nodal variables one block over all nodes. A file written
  with ``compression`` holds each state as a zlib stream (root and mesh stay plain).

How each variable becomes an array (named as FEBio names it: ``strain energy density``,
``stress``, ``Lagrange strain``, ``displacement``):

- nodal variables: point data;
- domain variables stored per element (ITEM; ``strain energy density``, ``stress``, ``Lagrange
  strain``: FEBio's average over the element's Gauss points): cell data over the volume domains,
  NaN in a volume domain that does not carry the variable; per domain (REGION): cell data, the
  domain's value in each of its elements;
- per element node (MULT): point data, each node the mean of the copies of the elements around it,
  each element once (afferent's one element-node rule, :func:`afferent.io._coincident.element_node_mean`,
  as FEBio's own VTK export averages them); per domain node (NODE): point data, the mean over the
  domains sharing a node (each domain's copy once).

Only volume domains become cells: hexahedra (8, 20 nodes), wedges (6, 15), tetrahedra (4, 10),
pyramids (5, 13), in VTK's node order (FEBio's VTK export writes them unchanged); TET5, TET15,
TET20 and HEX27 domains by their corner nodes (a note says so). Shell, beam, discrete and 2-D
domains, surface, edge and global variables are ignored, each named in the notes. Symmetric
tensors (MAT3FS) keep FEBio's component order xx yy zz xy yz xz (``FECore/FEDataStream.h``) as
component names; FEBio's ``Lagrange strain`` has tensor shear, so the ``febio`` preset is implied.

Versions: plot files 3.0 to 3.5 (0x0030-0x0035, written by FEBio 3.x and 4.x) are read; FEBio
2.x's layout (versions below 0x0030) and versions newer than 0x0035 are refused, naming the
version. A file whose mesh changes between states (adaptive remeshing writes a second mesh) is
refused. FEBio has no units: the user declares them (an mm-N-s model gives stress and SED in MPa);
the unit system FEBio 4 may record in the header is only quoted in the notes.
"""

from __future__ import annotations

import numpy as np

from ._coincident import element_node_mean
from ._raw import RawArray, RawExport, material_array, stack_steps
from ._xplt_file import _BY_CORNERS, _Model, _Variable, _File, _err, _model, _states

__all__ = ["read_xplt", "iter_xplt", "xplt_step_count"]


def _volume(model: _Model, path: str):
    """(volume cells or None, volume domains in cell order, notes on the domains read and ignored)."""
    from ._exodus import _Block
    from ._meshio import cells_from_meshio
    from meshio._common import num_nodes_per_cell

    volume = [d for d in model.domains if d.ctype is not None and d.conn.shape[0]]
    blocks = [_Block(d.ctype, d.conn[:, :num_nodes_per_cell[d.ctype]]) for d in volume]
    cells = cells_from_meshio(blocks, path) if blocks else None
    notes = []
    read = ", ".join(f"{d.number} ({d.etype}, {d.conn.shape[0]} elements{', part ' + repr(model.parts.get(d.part, d.part)) if model.parts else ''})"
                     for d in volume)
    numbers = {d.number for d in volume}
    ignored = [f"{d.number} ({d.etype}, {d.conn.shape[0]} elements)" for d in model.domains if d.number not in numbers]
    notes.append(f"volume domain(s) {read or 'none'}" + (f"; ignored domain(s) {', '.join(ignored)} (shells, beams, "
                                                        "springs, 2-D or empty)" if ignored else "") + ".")
    corners = sorted({d.etype for d in volume if d.etype in _BY_CORNERS})
    if corners:
        notes.append(f"{', '.join(corners)} elements read by their corner nodes (point data linear between corners).")
    return cells, volume, notes


def _domain_cells(var: _Variable, blocks: dict, volume: list, path: str, time: float):
    """One ITEM or REGION domain variable as (n_cells, size) over the volume domains (NaN where not carried)."""
    parts, present = [], False
    for d in volume:
        n_el = d.conn.shape[0]
        v = blocks.get(d.number)
        if v is None:
            parts.append(np.full((n_el, var.size), np.nan))
            continue
        expected = var.size * (n_el if var.fmt == "ITEM" else 1)
        if v.size != expected:
            raise _err(path, f"plot variable {var.name!r} ({var.vtype}, {var.fmt}) must have {expected} values in "
                             f"domain {d.number} ({n_el} elements) at t = {time:g}; got {v.size} instead.")
        v = v.reshape(-1, var.size)
        parts.append(v if var.fmt == "ITEM" else np.repeat(v, n_el, axis=0))
        present = True
    return np.concatenate(parts).astype(np.float64) if present else None


def _domain_points(var: _Variable, blocks: dict, volume: list, n_nodes: int, path: str, time: float):
    """One MULT or NODE domain variable as (n_nodes, size): the mean of the copies at each node (NaN: no copy), by
    the element-node rule (:func:`afferent.io._coincident.element_node_mean`)."""
    at, copies = [np.zeros(0, np.int64)], [np.zeros((0, var.size))]
    for d in volume:
        v = blocks.get(d.number)
        if v is None:
            continue
        nodes = d.conn.ravel() if var.fmt == "MULT" else d.nodes
        if v.size != var.size * nodes.size:
            raise _err(path, f"plot variable {var.name!r} ({var.vtype}, {var.fmt}) must have {var.size * nodes.size} "
                             f"values in domain {d.number} at t = {time:g} ({nodes.size} "
                             f"{'element nodes' if var.fmt == 'MULT' else 'nodes'}); got {v.size} instead.")
        at.append(nodes)
        copies.append(v.reshape(-1, var.size).astype(np.float64))
    if len(at) == 1:
        return None
    return element_node_mean(np.concatenate(at), np.concatenate(copies), n_nodes)


def _partial_note(var: _Variable, blocks: dict, volume: list) -> str | None:
    """The note for a domain variable written for some volume domains only (FEBio's ``elem_set=`` on a ``<var>``)."""
    def named(ds):
        return ", ".join(f"{d.number} ({d.name or d.etype}, {d.conn.shape[0]} elements)" for d in ds)

    has = [d for d in volume if d.number in blocks]
    lacks = [d for d in volume if d.number not in blocks]
    if not has or not lacks:
        return None
    return (f"plot variable {var.name!r} is written for domain(s) {named(has)} only: NaN on domain(s) {named(lacks)}. "
            f"To read it there, request it for every domain: in the .feb, <var type=\"{var.name}\"/> without elem_set= "
            "or a domain list; in FEBio Studio, the plot variable without a domain selection.")


def _arrays(model: _Model, volume: list, data: dict, path: str, time: float, elsewhere: list, partial: list) -> dict:
    """The nodal and domain variables of one state as one-step RawArrays; the names of domain variables only
    ignored domains carry are appended to ``elsewhere``, the notes on those some volume domains lack to ``partial``."""
    arrays: dict = {}
    n = model.points.shape[0]

    def add(var: _Variable, values, location: str):
        if values is None:
            return
        values = values[None] if var.size > 1 else values.reshape(1, -1)
        key = var.name if var.name not in arrays else f"{var.name}@{location}"
        arrays[key] = RawArray(var.name, np.asarray(values, dtype=np.float64), location, None, var.components)

    for k, var in enumerate(model.variables.get("nodal", [])):
        v = data.get("nodal", {}).get(k, {}).get(0)
        if v is None or var.fmt != "NODE":
            continue
        if v.size != n * var.size:
            raise _err(path, f"nodal plot variable {var.name!r} ({var.vtype}) must have {n * var.size} values ({n} "
                             f"nodes) at t = {time:g}; got {v.size} instead.")
        add(var, v.reshape(n, var.size).astype(np.float64), "point")
    for k, var in enumerate(model.variables.get("domain", [])):
        blocks = data.get("domain", {}).get(k, {})
        if var.fmt in ("ITEM", "REGION"):
            add(var, _domain_cells(var, blocks, volume, path, time), "cell")
        else:
            add(var, _domain_points(var, blocks, volume, n, path, time), "point")
        if blocks and var.name not in arrays:
            elsewhere.append(var.name)
        elif note := _partial_note(var, blocks, volume):
            partial.append(note)
    material = material_array(np.repeat([d.part for d in volume], [d.conn.shape[0] for d in volume])) if volume else None
    if material is not None and "material" not in arrays:
        arrays["material"] = material
    return arrays


def _notes(model: _Model, volume_notes: list) -> tuple[str, ...]:
    """What the reader read, ignored and implied, for the provenance."""
    v = model.version
    by = f", written by {model.software}" if model.software else ""
    notes = [f"FEBio plot file version {v >> 4}.{v & 0xF} ({v:#06x}){by}"
             + (", states zlib-compressed" if model.compression else "") + "; " + volume_notes[0]]
    notes += volume_notes[1:]
    ignored = [f"{var.name!r} ({kind})" for kind in ("surface", "edge", "global") for var in model.variables.get(kind, [])]
    if ignored:
        notes.append(f"plot variables not on the volume mesh ignored: {', '.join(ignored)}.")
    domain = {var.name: var for var in model.variables.get("domain", [])}
    if "strain energy density" in domain:
        notes.append(f"'strain energy density' is FEBio's per element ({domain['strain energy density'].fmt}): the "
                     "average over each element's Gauss points, cell data.")
    elif "stress" in domain and "Lagrange strain" in domain:
        notes.append("no 'strain energy density' plot variable: SED from 'stress' and 'Lagrange strain' "
                     "(sed_from='exact'; FEBio's order xx yy zz xy yz xz and tensor shear, preset 'febio').")
    if model.units:
        notes.append(f"the model declares FEBio units {model.units!r}: declare them as length_unit and "
                     "sed_unit/stress_unit (FEBio writes numbers without units).")
    return tuple(notes)


def _open(path: str):
    """(open file, model, cells, volume domains, notes)."""
    f = _File(path)
    try:
        model = _model(f)
        cells, volume, volume_notes = _volume(model, path)
    except BaseException:
        f.close()
        raise
    return f, model, cells, volume, _notes(model, volume_notes)


def iter_xplt(path: str, *, progress: bool = False):
    """Yield an FEBio plot file one state at a time, as one-step RawExports sharing points and cells.

    Parameters
    ----------
    path : str
        The ``.xplt`` file.
    progress : bool
        Unused (states are read as they come); accepted for a uniform reader signature.

    Yields
    ------
    RawExport
        Points (reference node coordinates, the model's length unit), volume cells, one array per
        nodal or domain plot variable (FEBio's names and component order), the state's time, and
        ``preset='febio'``.

    Raises
    ------
    SEDFormatError
        Not an FEBio plot file, a version not read, a truncated or corrupt chunk, a variable whose
        size does not match its domain, a mesh that changes between states.
    """
    f, model, cells, volume, notes = _open(path)
    try:
        for time, data in _states(f, model):
            elsewhere: list = []
            partial: list = []
            arrays = _arrays(model, volume, data, path, time, elsewhere, partial)
            more = (f"plot variable(s) {', '.join(map(repr, elsewhere))} only on ignored domains: not read.",)
            yield RawExport(files=(path,), format="xplt", points=model.points, arrays=arrays, times=np.array([time]),
                            cells=cells, notes=notes + (more if elsewhere else ()) + tuple(partial), preset="febio")
    finally:
        f.close()


def xplt_step_count(path: str) -> int:
    """The number of states (output times) of an FEBio plot file, without decoding their data."""
    f, model, *_ = _open(path)
    try:
        k = 0
        while (f.inflated(f"state {k}") if model.compression else f.chunk(f"state {k}", skip=True)) is not None:
            k += 1
        return k
    finally:
        f.close()


def read_xplt(path: str, *, progress: bool = False) -> RawExport:
    """Read an FEBio plot file (``.xplt``): mesh, every state, nodal and domain plot variables.

    Returns a RawExport as :func:`iter_xplt` yields, every state stacked along the time axis (a
    file holding no state: the mesh and no arrays); raises SEDFormatError as :func:`iter_xplt`.
    ``progress`` is unused, accepted for a uniform reader signature.
    """
    steps = list(iter_xplt(path))
    for k, step in enumerate(steps):
        if set(step.arrays) != set(steps[0].arrays):
            raise _err(path, f"state {k} (t = {step.times[0]:g}) carries the variables {sorted(step.arrays)}, state 0 "
                             f"{sorted(steps[0].arrays)}; every state must carry the same ones.")
    if steps:
        return stack_steps(steps)
    f, model, cells, _, notes = _open(path)
    f.close()
    return RawExport(files=(path,), format="xplt", points=model.points, cells=cells, preset="febio",
                     notes=notes + ("The file holds a mesh and no state: no results to read.",))
