"""MED result files (``.med``, ``.rmed``): code_aster, Salome-Meca and other MED writers.

MED is HDF5 (read here with h5py, the layout of med-fichier 3.x/4.x): ``/ENS_MAA/<mesh>``
holds the mesh (``NOE/COO`` node coordinates, ``MAI/<type>/NOD`` the 1-based connectivity of
each element type, stored component by component), ``/CHA/<field>`` the result fields (attributes
``NCO`` number of components, ``NOM``/``UNI`` component names and units in 16-character slots,
``MAI`` the mesh), one subgroup per time step (attributes ``NDT``, ``NOR``, ``PDT`` = time), and
under each step one group per support: ``NOE`` (values at the nodes), ``NOE.<type>`` (at the nodes
of each element: MED_NODE_ELEMENT) or ``MAI.<type>`` (per element, or at its Gauss points, with a
localisation in ``/GAUSS`` giving their weights); values may cover only the entities a profile
(``/PROFILS``) lists. meshio's MED reader (5.3.5) keeps each time step as a separate array, drops the
component names, refuses files whose element fields do not cover every element type (a Salome
mesh with its skin faces) and reads element-node and Gauss-point values element-fastest, mixing
them up between elements (MED stores them point by point within each element); this reader
keeps every step.

code_aster names a field ``<result name padded to 8 with '_'><option>`` (``RESU____ENEL_ELNO``)
unless ``NOM_CHAM_MED`` renames it; when every field carries one result name, the arrays are
named by the option alone (``ENEL_ELNO``) and the result name is noted. How each support becomes
an array (see the FE-export page of the documentation, "code_aster"):

- nodes (``_NOEU``): point data;
- element nodes (``_ELNO``; MED_NODE_ELEMENT, or per cell with MED's ``MED_GAUSS_ELNO``
  localisation): point data, the **mean of the element-node copies at each node**, each element once
  (afferent's one element-node rule, :func:`afferent.io._coincident.element_node_mean`, and the
  rule by which code_aster builds ``_NOEU`` from ``_ELNO``); nodes no element carries are NaN;
- Gauss points (``_ELGA``): cell data, the mean over each element's Gauss points weighted by the
  localisation's weights (the element average for elements of constant Jacobian);
- one value per element (``_ELEM``): cell data. ``ENEL_ELEM`` is the element's elastic energy, not
  a density, and is refused as SED.

Only volume elements (tetrahedra, pyramids, wedges, hexahedra, linear or quadratic) become cells;
faces and edges are ignored. Tensors keep their component names (``SIXX SIYY SIZZ SIXY SIXZ
SIYZ``, ``EPXX ... EPYZ`` with tensor shear), so their order is read from the names and the
``code_aster`` preset is implied. MED files state no units unless the writer filled them in (code_aster
does not): the user declares them.

HDF5 external links, external raw storage and virtual datasets in a MED file are followed only to
files inside the folder of the export named (unless ``allow_outside_files``), regular files, each
resolved before HDF5 opens it (:mod:`afferent.io._files`) and listed in the files read.
"""

from __future__ import annotations

import re

import numpy as np

from ..exceptions import SEDFormatError
from ._coincident import element_node_mean
from ._files import Scope, h5_open, h5_read
from ._raw import RawArray, RawExport, check_export_file, drop_valueless_nodes, files_read

__all__ = ["read_med", "MED_VOLUME_TYPES"]

#: MED volume element type -> meshio cell type (corner nodes first in both orders).
MED_VOLUME_TYPES = {
    "TE4": "tetra", "T10": "tetra10", "PY5": "pyramid", "P13": "pyramid13", "PE6": "wedge", "P15": "wedge15",
    "P18": "wedge18", "HE8": "hexahedron", "H20": "hexahedron20", "H27": "hexahedron27",
}
_NO_PROFILE = "MED_NO_PROFILE_INTERNAL"
_GAUSS_ELNO = "MED_GAUSS_ELNO"  # MED's reserved localisation: values per element node stored per cell
_ASTER_OPTION = re.compile(r"^[A-Z][A-Z0-9]{3}(_[A-Z]{4})?$")  # DEPL, SIEF_ELGA, ENEL_NOEU, ...


def _text(value) -> str:
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("latin-1")
    return str(value)


def _slots(value, n: int) -> tuple[str, ...]:
    """``n`` names packed in 16-character slots (MED's component names and units)."""
    text = _text(value)
    return tuple(text[16 * k:16 * (k + 1)].strip() for k in range(n))


class _File:
    """The open HDF5 file, with errors that name the file and the object read."""

    def __init__(self, path: str, scope: Scope | None = None):
        self.path, self.scope = path, scope or Scope.of(path)
        self.opened: list[str] = []  # the files besides path that HDF5 opened (links, external storage)
        with open(path, "rb") as fh:
            magic = fh.read(8)
        if magic != b"\x89HDF\r\n\x1a\n":
            raise SEDFormatError(f"SED file {path!r} is not a MED file: it must be HDF5 (signature b'\\x89HDF'); got "
                                 f"{magic[:4]!r} instead.")
        try:  # the targets of its HDF5 external links resolved before anything is looked up in it
            self.h5 = h5_open(path, self.scope, self.opened)
        except SEDFormatError:
            raise
        except Exception as err:  # a damaged superblock: OSError from h5py
            raise SEDFormatError(f"SED file {path!r} could not be read as MED (HDF5; truncated or corrupt?): "
                                 f"{type(err).__name__}: {err}") from err
        try:
            is_med = "ENS_MAA" in self.h5
            groups = ", ".join(sorted(self.h5)) or "none"
        except (KeyError, RuntimeError, OSError, ValueError) as err:  # damaged root group
            self.h5.close()
            raise SEDFormatError(f"SED file {path!r} could not be read as MED (HDF5; truncated or corrupt?): "
                                 f"{type(err).__name__}: {err}") from err
        if not is_med:
            self.h5.close()
            raise SEDFormatError(f"SED file {path!r} is HDF5 but not a MED file: it has no mesh group '/ENS_MAA' "
                                 f"(top-level groups: {groups}).")

    def get(self, node, key: str, what: str):
        try:
            return node[key]
        except Exception as err:
            raise SEDFormatError(f"SED file {self.path!r}: {what} ('{node.name}/{key}') could not be read (truncated or "
                                 f"not a MED layout?): {type(err).__name__}: {err}") from err

    def values(self, node, key: str, what: str, size: int | None = None) -> np.ndarray:
        """A dataset's values, checked before reading (:func:`~afferent.io._raw.h5_check`: no more than
        ``size`` values when given, no values its file does not store)."""
        from ._raw import h5_check

        try:
            self.get(node, key, what)
            label = f"SED file {self.path!r}: {what} ('{node.name}/{key}')"
            return np.asarray(h5_read(node, key, self.scope, self.opened,  # external storage resolved before it is read
                                      check=lambda d: h5_check(d, label, size)))
        except SEDFormatError:
            raise
        except Exception as err:
            raise SEDFormatError(f"SED file {self.path!r}: {what} ('{node.name}/{key}') could not be read (truncated?): "
                                 f"{type(err).__name__}: {err}") from err

    def attr(self, node, key: str, what: str):
        if key not in node.attrs:
            raise SEDFormatError(f"SED file {self.path!r}: {what} ('{node.name}') must have the MED attribute {key!r}; "
                                 "got none (not a MED layout?).")
        return node.attrs[key]


def _mesh(f: _File, name: str | None):
    """(mesh name, the group holding NOE and MAI, spatial dimension, length unit or None)."""
    meshes = list(f.h5["ENS_MAA"])
    if name is None or name not in meshes:
        if len(meshes) != 1:
            raise SEDFormatError(f"SED file {f.path!r} must hold one mesh, or fields naming theirs; got meshes "
                                 f"{', '.join(map(repr, meshes)) or 'none'} instead.")
        name = meshes[0]
    group = f.h5["ENS_MAA"][name]
    dim = int(f.attr(group, "ESP", "the mesh"))
    units = {u for u in _slots(group.attrs.get("UNI", b""), dim) if u}
    node = group
    if "NOE" not in group:
        steps = sorted(group)
        if not steps:
            raise SEDFormatError(f"SED file {f.path!r}: mesh {name!r} holds no nodes.")
        node = group[steps[0]]  # the mesh at its first (usually only) step
    return name, node, dim, (units.pop() if len(units) == 1 else None)


def _mesh_arrays(f: _File, node, dim: int):
    """Coordinates (n, 3) and the element blocks {MED type: (n_elements, nodes per element) 0-based}."""
    coo = f.get(node, "NOE", "the mesh's nodes")
    n = int(f.attr(f.get(coo, "COO", "the node coordinates"), "NBR", "the node coordinates"))
    flat = f.values(coo, "COO", "the node coordinates", n * dim).astype(float)
    if flat.size != n * dim:
        raise SEDFormatError(f"SED file {f.path!r}: the node coordinates must hold {n} x {dim} values; got {flat.size}.")
    xyz = flat.reshape(n, dim, order="F")
    if dim < 3:
        xyz = np.column_stack([xyz, np.zeros((n, 3 - dim))])
    blocks = {}
    for mtype, group in (node["MAI"].items() if "MAI" in node else ()):
        count = int(f.attr(f.get(group, "NOD", f"the {mtype} connectivity"), "NBR", f"the {mtype} connectivity"))
        conn = f.values(group, "NOD", f"the {mtype} connectivity").astype(np.int64)
        if count == 0 or conn.size % count:
            continue
        conn = conn.reshape(count, -1, order="F") - 1
        if conn.min() < 0 or conn.max() >= n:
            raise SEDFormatError(f"SED file {f.path!r}: {mtype} elements refer to node {int(conn.max()) + 1}, but the "
                                 f"mesh has {n} nodes.")
        blocks[mtype] = conn
    return xyz, blocks


def _profile(f: _File, name: str) -> np.ndarray | None:
    """0-based entity indices of a profile, None for 'every entity'."""
    if not name or name == _NO_PROFILE:
        return None
    group = f.get(f.h5, "PROFILS", "the profiles")
    return f.values(f.get(group, name, f"profile {name!r}"), "PFL", f"profile {name!r}").astype(np.int64) - 1


def _support(f: _File, step, key: str, n_entities: int, ncomp: int):
    """Values of one support of one step: (n_entities, points per entity, ncomp), NaN off the profile;
    and the name of its Gauss localisation ('' when none)."""
    group = step[key]
    pfl = _text(group.attrs.get("PFL", _NO_PROFILE)).strip()
    data = f.get(group, pfl, f"the values of {key!r}")
    count, per = int(f.attr(data, "NBR", key)), int(data.attrs.get("NGA", 1))
    flat = f.values(data, "CO", f"the values of {key!r}", count * per * ncomp).astype(float)
    if flat.size != count * per * ncomp:
        raise SEDFormatError(f"SED file {f.path!r}: '{data.name}' must hold {count} x {per} x {ncomp} values; got "
                             f"{flat.size} instead.")
    # component by component; within one, entity by entity and, within one, point by point
    vals = flat.reshape(ncomp, count, per).transpose(1, 2, 0)
    index = _profile(f, pfl)
    if index is None and count != n_entities:
        raise SEDFormatError(f"SED file {f.path!r}: '{data.name}' must have one entry per entity ({n_entities}); "
                             f"got {count} instead.")
    if index is not None:
        full = np.full((n_entities, per, ncomp), np.nan)
        full[index] = vals
        vals = full
    return vals, _text(data.attrs.get("GAU", group.attrs.get("GAU", b""))).strip()


def _weights(f: _File, loc: str, per: int) -> tuple[np.ndarray, bool]:
    """The Gauss weights of a localisation, or equal weights when the file has none: (weights, stated)."""
    if loc and "GAUSS" in f.h5 and loc in f.h5["GAUSS"]:
        w = f.values(f.h5["GAUSS"][loc], "VAL", f"localisation {loc!r}").astype(float).ravel()
        if w.size == per and w.sum() > 0:
            return w, True
    return np.full(per, 1.0), False


def _step_values(f: _File, step, kind: str, ncomp: int, mesh: dict, notes: set) -> np.ndarray:
    """One step of one field, (n_values, ncomp): at the nodes, or per volume cell."""
    n_nodes, blocks, volume = mesh["n_nodes"], mesh["blocks"], mesh["volume"]
    if kind == "node":
        return _support(f, step, "NOE", n_nodes, ncomp)[0][:, 0, :]
    if kind == "elno":  # the element-node rule: the mean of the element-node copies at each node
        nodes, copies = [np.zeros(0, np.int64)], [np.zeros((0, ncomp))]
        for key in step:
            mtype = key.partition(".")[2]
            if not _is_elno(step, key) or mtype not in blocks:
                continue
            conn = blocks[mtype]
            vals, _ = _support(f, step, key, conn.shape[0], ncomp)
            if vals.shape[1] != conn.shape[1]:
                raise SEDFormatError(f"SED file {f.path!r}: '{step.name}/{key}' must have one value per element node "
                                     f"({conn.shape[1]}); got {vals.shape[1]} instead.")
            nodes.append(conn.ravel())
            copies.append(vals.reshape(-1, ncomp))
        return element_node_mean(np.concatenate(nodes), np.concatenate(copies), n_nodes)
    parts = []  # per volume cell: ELEM values, or the weighted mean of the Gauss-point values
    for mtype, n_cells in volume:
        key = f"MAI.{mtype}"
        if key not in step:
            parts.append(np.full((n_cells, ncomp), np.nan))
            continue
        vals, loc = _support(f, step, key, n_cells, ncomp)
        w, stated = _weights(f, loc, vals.shape[1])
        if vals.shape[1] > 1:
            notes.add(f"{mtype}: the mean of its {vals.shape[1]} Gauss points weighted by "
                      + ("the localisation's weights" if stated else "equal weights (no localisation weights in the file)"))
        parts.append(np.einsum("cpk,p->ck", vals, w / w.sum()))
    return np.concatenate(parts) if parts else np.zeros((0, ncomp))


def _is_elno(step, key: str) -> bool:
    """Values at the element nodes: MED_NODE_ELEMENT (``NOE.<type>``), or per cell with MED's
    reserved localisation ``MED_GAUSS_ELNO`` (``MAI.<type>``)."""
    if key.startswith("NOE."):
        return True
    if not key.startswith("MAI."):
        return False
    group = step[key]
    pfl = _text(group.attrs.get("PFL", _NO_PROFILE)).strip()
    loc = group.attrs.get("GAU", group[pfl].attrs.get("GAU", b"") if pfl in group else b"")
    return _text(loc).strip() == _GAUSS_ELNO


def _kind(f: _File, step, name: str) -> str:
    """'node', 'elno' or 'cell' from the supports of a field's step."""
    keys = list(step)
    if "NOE" in keys:
        return "node"
    if any(_is_elno(step, k) for k in keys):
        return "elno"
    if any(k.startswith("MAI.") for k in keys):
        return "cell"
    raise SEDFormatError(f"SED file {f.path!r}: field {name!r} has values on {', '.join(map(repr, keys)) or 'nothing'}; "
                         "expected nodes ('NOE'), element nodes ('NOE.<type>') or elements ('MAI.<type>').")


def _steps(f: _File, group) -> list[tuple[tuple[int, int], float, object]]:
    """The time steps of a field: ((NDT, NOR), time, group), in step order."""
    out = []
    for key, step in group.items():
        ndt, nor = int(step.attrs.get("NDT", -1)), int(step.attrs.get("NOR", -1))
        out.append(((ndt, nor), float(step.attrs.get("PDT", 0.0)), step))
    return sorted(out, key=lambda s: s[0])


def _fields(f: _File, mesh_name: str):
    """Every field of the mesh: {name: (kind, components, units, time unit, steps)}."""
    if "CHA" not in f.h5:
        return {}
    out = {}
    for name, group in f.h5["CHA"].items():
        if _text(group.attrs.get("MAI", mesh_name.encode())).strip() != mesh_name:
            continue
        ncomp = int(f.attr(group, "NCO", f"field {name!r}"))
        comps = _slots(group.attrs.get("NOM", b""), ncomp)
        units = {u for u in _slots(group.attrs.get("UNI", b""), ncomp) if u}
        steps = _steps(f, group)
        if not steps:
            continue
        out[name] = (_kind(f, steps[0][2], name), comps, units.pop() if len(units) == 1 else None,
                     _text(group.attrs.get("UNT", b"")).strip() or None, steps)
    return out


def _common_steps(path: str, fields: dict, notes: list) -> list[tuple[int, int]]:
    """The steps every field has (an array holds every step of the export)."""
    sets = {name: [s[0] for s in spec[4]] for name, spec in fields.items()}
    common = sorted(set.intersection(*(set(v) for v in sets.values())))
    if not common:
        listing = "; ".join(f"{n!r}: {len(v)} step(s)" for n, v in sets.items())
        raise SEDFormatError(f"SED file {path!r}: the fields must share at least one time step (NDT, NOR); got none "
                             f"in common ({listing}).")
    for name, keys in sets.items():
        if len(keys) > len(common):
            notes.append(f"field {name!r}: {len(keys) - len(common)} of its {len(keys)} step(s) left out (not every "
                         "field has them; an array holds the steps all fields share)")
    return common


def _array_names(fields: dict, notes: list) -> dict[str, str]:
    """Field name -> array name: code_aster's result prefix dropped when every field carries the same one."""
    names = list(fields)
    prefixes = {n[:8] for n in names if len(n) > 8 and _ASTER_OPTION.match(n[8:])}
    if len(prefixes) == 1 and all(len(n) > 8 and _ASTER_OPTION.match(n[8:]) for n in names):
        prefix = prefixes.pop()
        renamed = {n: n[8:] for n in names}
        if len(set(renamed.values())) == len(renamed):
            notes.append(f"code_aster result {prefix.rstrip('_')!r} (the first 8 characters of every field name) left "
                         "out of the array names")
            return renamed
    return {n: n for n in names}


def _volume_cells(blocks: dict, path: str):
    """Volume cells for sampling (tetrahedra), and [(MED type, n_elements)] in cell order."""
    from ._exodus import _Block
    from ._cell_blocks import cells_from_meshio

    volume = [(t, conn) for t, conn in blocks.items() if t in MED_VOLUME_TYPES]
    cells = cells_from_meshio([_Block(MED_VOLUME_TYPES[t], conn) for t, conn in volume], path) if volume else None
    return cells, [(t, conn.shape[0]) for t, conn in volume]


def _describe(name: str, spec, kept: int, where: str) -> str:
    kind, comps, _, _, steps = spec
    times = [s[1] for s in steps]
    support = {"node": "nodes", "elno": "element nodes (ELNO), averaged at each node",
               "cell": "elements (ELEM or Gauss points), one value per volume cell"}[kind]
    span = f"t = {times[0]:g}" + (f" .. {times[-1]:g}" if len(times) > 1 else "")
    return (f"field {name!r} -> {where}: on {support}; components {' '.join(comps) or '(unnamed)'}; "
            f"{len(steps)} step(s), {span}" + (f" ({kept} kept)" if kept != len(steps) else ""))


def read_med(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """Read a MED file: the mesh, every field, every time step they share.

    Parameters
    ----------
    path : str
        ``.med`` or ``.rmed`` file (code_aster ``IMPR_RESU(FORMAT='MED')``, Salome-Meca).
    progress : bool
        Unused (the file is read in one pass); accepted for a uniform reader signature.
    scope : Scope, optional
        Where the files its HDF5 external links and external storage lead to may be
        (:mod:`afferent.io._files`); default inside the file's own folder.

    Returns
    -------
    RawExport
        Points (the model's length unit), volume cells, one array per field (nodal and ELNO
        fields point data, ELGA and ELEM fields cell data), the times of the steps (the
        ``INST`` of code_aster, s unless the file states a unit), preset ``'code_aster'``.

    Raises
    ------
    SEDFormatError
        Not HDF5, not a MED layout, a field whose sizes do not match the mesh, a damaged or
        truncated file, fields with no time step in common.
    """
    check_export_file(path)
    f = _File(path, scope)
    try:
        return _read(f)
    except SEDFormatError:
        raise
    except (KeyError, RuntimeError, OSError, ValueError, TypeError, AttributeError) as err:
        # damaged HDF5 metadata surfaces from h5py as any of these (a broken link reads as None)
        raise SEDFormatError(f"SED file {path!r} could not be read as MED (truncated or corrupt?): "
                             f"{type(err).__name__}: {err}") from err
    finally:
        f.h5.close()


def _read(f: _File) -> RawExport:
    path = f.path
    names = [_text(g.attrs.get("MAI", b"")).strip() for g in f.h5["CHA"].values()] if "CHA" in f.h5 else []
    mesh_name, node, dim, length_unit = _mesh(f, names[0] if names else None)
    xyz, blocks = _mesh_arrays(f, node, dim)
    cells, volume = _volume_cells(blocks, path)
    mesh = {"n_nodes": xyz.shape[0], "blocks": blocks, "volume": volume}
    fields = _fields(f, mesh_name)
    notes = [f"MED mesh {mesh_name!r}: {xyz.shape[0]} nodes, element types "
             + ", ".join(f"{t} x {c.shape[0]}" + ("" if t in MED_VOLUME_TYPES else " (not a volume: ignored)")
                         for t, c in blocks.items())]
    if not fields:
        notes.append("The file holds a mesh and no field: no results to read.")
        return RawExport(files=files_read([path], f.opened), format="med", points=xyz, cells=cells, length_unit=length_unit,
                         notes=tuple(notes), preset="code_aster")
    common = _common_steps(path, fields, notes)
    renamed = _array_names(fields, notes)
    arrays, times, time_units = {}, None, set()
    for name, spec in fields.items():
        kind, comps, unit, tunit, steps = spec
        rules: set = set()
        by_key = {key: (t, step) for key, t, step in steps}
        values = np.stack([_step_values(f, by_key[k][1], kind, len(comps), mesh, rules) for k in common])
        if times is None:
            times = np.array([by_key[k][0] for k in common])
        location = "point" if kind in ("node", "elno") else "cell"
        arrays[renamed[name]] = RawArray(renamed[name], values[..., 0] if len(comps) == 1 else values, location, unit,
                                         comps if len(comps) > 1 else ())
        time_units.add(tunit)
        notes.append(_describe(name, spec, len(common), f"{location} array {renamed[name]!r}")
                     + (f"; per cell: {'; '.join(sorted(rules))}" if rules else ""))
    if cells is None:
        notes.append("No volume elements in the file: the points are treated as scattered samples.")
    time_units.discard(None)
    raw = RawExport(files=files_read([path], f.opened), format="med", points=xyz, arrays=arrays, times=times, cells=cells,
                    length_unit=length_unit, time_unit=time_units.pop() if len(time_units) == 1 else None,
                    notes=tuple(notes), preset="code_aster")
    return drop_valueless_nodes(raw)
