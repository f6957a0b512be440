"""Exodus II result files (``.e``, ``.exo``, ``.g``): MOOSE, Cubit, Sierra, SEACAS tools.

An Exodus file is a netCDF file: netCDF-3 ("classic" or 64-bit offset, read with
:class:`scipy.io.netcdf_file`) or netCDF-4 (an HDF5 file, read with h5py). It holds the node
coordinates (``coordx/coordy/coordz`` or ``coord``), element blocks (``connect1..N``, 1-based,
with an ``elem_type`` attribute), the output times (``time_whole``), nodal variables
(``name_nod_var``; ``vals_nod_var1..N`` or one ``vals_nod_var``) and element variables
(``name_elem_var``; ``vals_elem_var{i}eb{j}`` per block, present where the truth table
``elem_var_tab`` says so). Every time step is read (meshio's Exodus reader keeps only the
first). Nodal variables are point data (a variable with a trailing component axis, as meshio
writes a vector, keeps its components); element variables are cell data over the volume blocks
(hexahedra, tetrahedra, wedges, pyramids, linear or quadratic), NaN in a volume block that
does not carry the variable. Surface, shell, bar and truss blocks are ignored. Several volume
blocks with different ids give the cell array ``material`` (each cell's block id, ``eb_prop1``),
the materials the interface site finders and ``side=`` use.

MOOSE writes tensor components as separate scalar variables (``stress_xx``, ``stress_xy``, ...
from RankTwoAux); afferent matches them by name. Their shear is tensor shear (stress =
C : elastic_strain with tensor shear, checked during development on MOOSE's test files with
benchmarks/check_exodus_files.py; docs/fe-export.md). Exodus has no units: the user declares them.

In a netCDF-4 file, HDF5 external links, external raw storage and virtual datasets are followed
only to files inside the folder of the export named (unless ``allow_outside_files``), regular
files, each resolved before HDF5 opens it (:mod:`afferent.io._files`) and listed in the files read.
"""

from __future__ import annotations


import numpy as np

from ..exceptions import SEDFormatError
from ._files import Scope, h5_open, h5_read
from ._raw import RawArray, RawExport, check_export_file, files_read, material_array

__all__ = ["read_exodus", "EXODUS_ELEMENTS"]

#: Exodus element type (upper case, leading letters and node count) -> meshio volume cell type.
EXODUS_ELEMENTS = {
    "HEX": "hexahedron", "HEX8": "hexahedron", "HEX20": "hexahedron20", "HEX27": "hexahedron27",
    "TETRA": "tetra", "TETRA4": "tetra", "TET4": "tetra", "TETRA10": "tetra10", "TET10": "tetra10",
    "TETRA14": "tetra14", "WEDGE": "wedge", "WEDGE6": "wedge", "WEDGE15": "wedge15", "WEDGE18": "wedge18",
    "PYRAMID": "pyramid", "PYRAMID5": "pyramid", "PYRAMID13": "pyramid13", "PYRAMID14": "pyramid14",
}


#: Exodus II node order -> VTK/meshio's, for the types where they differ (the columns of VTK's order
#: in Exodus's): Exodus numbers the vertical edges' mid-nodes before the top face's (HEX20, HEX27,
#: WEDGE15, WEDGE18: HEX20 checked on VTK 9.7.2's IOSS writer, tests/data/exodus/hex20_ioss.e, and on MOOSE's
#: HEX20 patch test with benchmarks/check_exodus_files.py)
#: and a HEX27's centre node before its face nodes (-z, +z, -x, +x, -y, +y; VTK: -x, +x, -y, +y,
#: -z, +z, centre), per the Exodus II manual's table of higher-order nodes (as libMesh's Exodus
#: reader maps them; no HEX27 file in the tests).
EXODUS_TO_VTK = {
    "hexahedron20": np.r_[0:12, 16:20, 12:16],
    "hexahedron27": np.r_[0:12, 16:20, 12:16, 23, 24, 25, 26, 21, 22, 20],
    "wedge15": np.r_[0:9, 12:15, 9:12],
    "wedge18": np.r_[0:9, 12:15, 9:12, 15:18],
}

#: Volume element families (the leading letters of elem_type) -> meshio type by node count.
_FAMILIES = {
    "HEX": {8: "hexahedron", 20: "hexahedron20", 27: "hexahedron27"},
    "TET": {4: "tetra", 10: "tetra10", 14: "tetra14"},
    "WEDGE": {6: "wedge", 15: "wedge15", 18: "wedge18"},
    "PYRA": {5: "pyramid", 13: "pyramid13", 14: "pyramid14"},
}


def _volume_type(etype: str, n_nodes: int) -> str | None:
    """meshio volume type of an Exodus element type spelled otherwise (``HEXAHEDRON``, ``TETRA``,
    ``tet10``...): by its family and its number of nodes; None for surfaces, shells and bars."""
    for prefix, by_nodes in _FAMILIES.items():
        if etype.startswith(prefix):
            return by_nodes.get(n_nodes)
    return None


class _NetCDF:
    """The few things read from either netCDF flavour: variables by name, their attributes, dimensions."""

    def __init__(self, path: str, scope: Scope | None = None):
        self.path, self.scope = path, scope or Scope.of(path)
        self.opened: list[str] = []  # the files besides path that HDF5 opened (links, external storage)
        with open(path, "rb") as fh:
            magic = fh.read(8)
        try:
            if magic[:3] == b"CDF":
                from scipy.io import netcdf_file

                self._nc = netcdf_file(path, "r", mmap=False)
                self.kind = "netCDF-3 (64-bit offset)" if magic[3:4] == b"\x02" else "netCDF-3 (classic)"
                self.names = set(self._nc.variables)
            elif magic[:4] == b"\x89HDF":
                import h5py

                self._h5 = h5_open(path, self.scope, self.opened)  # its external links resolved before anything is looked up
                self.kind = "netCDF-4 (HDF5)"
                self.names = {k for k, v in self._h5.items() if isinstance(v, h5py.Dataset)}
            else:
                raise SEDFormatError(
                    f"SED file {path!r} is not an Exodus II file: it must be netCDF ('CDF' or HDF5 signature); got "
                    f"{magic[:4]!r} instead."
                )
        except SEDFormatError:
            raise
        except Exception as err:  # a damaged header: ValueError, TypeError, OSError from the netCDF readers
            raise SEDFormatError(
                f"SED file {path!r} could not be read as Exodus II (netCDF; truncated or corrupt?): "
                f"{type(err).__name__}: {err}"
            ) from err

    def __contains__(self, name: str) -> bool:
        return name in self.names

    def get(self, name: str, size: int | None = None) -> np.ndarray:
        """A variable's values; netCDF-4: checked before reading (:func:`~afferent.io._raw.h5_check`: no more
        than ``size`` values when given, no values its file does not store). netCDF-3 stores every value."""
        from ._raw import h5_check

        try:
            if hasattr(self, "_nc"):
                return np.array(self._nc.variables[name].data)
            label = f"SED file {self.path!r}: Exodus variable {name!r}"
            return np.array(h5_read(self._h5, name, self.scope, self.opened,  # external storage resolved before it is read
                                    check=lambda d: h5_check(d, label, size)))
        except SEDFormatError:
            raise
        except Exception as err:
            raise SEDFormatError(
                f"SED file {self.path!r}: Exodus variable {name!r} could not be read (truncated file?): "
                f"{type(err).__name__}: {err}"
            ) from err

    def attr(self, name: str, key: str):
        if hasattr(self, "_nc"):
            value = getattr(self._nc.variables[name], key, None)
        else:
            value = self._h5[name].attrs.get(key)
        if isinstance(value, (bytes, np.bytes_)):
            return value.decode("latin-1").strip("\x00 ")
        if isinstance(value, np.ndarray) and value.dtype.kind in "SU":
            return b"".join(value.ravel()).decode("latin-1").strip("\x00 ") if value.dtype.kind == "S" else str(value)
        return value

    def strings(self, name: str) -> list[str]:
        """A 2-D char array (one name per row) as Python strings."""
        if name not in self:
            return []
        raw = self.get(name)
        if raw.dtype.kind == "S":
            raw = raw.reshape(raw.shape[0], -1) if raw.ndim > 1 else raw.reshape(1, -1)
            # a name ends at its first NUL: MOOSE files carry leftover bytes after it
            return [b"".join(row).split(b"\x00", 1)[0].decode("latin-1").strip() for row in raw]
        return [str(v).strip() for v in raw]

    def close(self):
        if hasattr(self, "_nc"):
            self._nc.close()
        else:
            self._h5.close()


def _per_step(values, n_t: int, n: int, path: str, what: str, per: str, components: bool = False) -> np.ndarray:
    """Values as (n_times, n), or with ``components`` (n_times, n, k) for a variable stored with a
    trailing component axis (meshio writes a nodal vector as one (time, node, k) variable); a
    SEDFormatError naming ``what`` when the sizes disagree."""
    v = np.asarray(values, dtype=float)
    if components and v.ndim == 3 and v.shape[:2] == (n_t, n) and v.shape[2] > 1:
        return v
    if v.size != n_t * n:
        raise SEDFormatError(f"SED file {path!r}: {what} must have one value per {per} ({n}) at each of the {n_t} "
                             f"time step(s); got {v.size} values (shape {v.shape}) instead.")
    return v.reshape(n_t, n)


class _Block:  # what cells_from_meshio reads: .type and .data
    def __init__(self, ctype, conn):
        self.type, self.data = ctype, conn


def _coordinates(nc, path: str) -> np.ndarray:
    """Node coordinates (n_nodes, 3) in the model's length unit; 2-D models padded with z = 0."""
    if "coord" in nc:
        coords = nc.get("coord").T
    elif "coordx" in nc:
        axes = [np.asarray(nc.get(f"coord{a}")).ravel() for a in "xyz" if f"coord{a}" in nc]
        if len({a.size for a in axes}) > 1:
            raise SEDFormatError(f"SED file {path!r}: the coordinate arrays coordx/coordy/coordz have different "
                                 f"lengths ({', '.join(str(a.size) for a in axes)}); expected one value per node.")
        coords = np.column_stack(axes)
    else:
        raise SEDFormatError(f"SED file {path!r} has no node coordinates ('coordx'/'coordy'/'coordz' or 'coord'): "
                             "is it an Exodus II file?")
    coords = np.asarray(coords, dtype=float)
    if coords.shape[1] < 3:
        coords = np.column_stack([coords, np.zeros((coords.shape[0], 3 - coords.shape[1]))])
    return coords


def _volume_blocks(nc, path: str, n_nodes: int):
    """The element blocks: (volume cells or None, [(block number, n_elements)] of volume blocks, skipped blocks)."""
    from ._cell_blocks import cells_from_meshio

    n_blocks = sum(1 for k in nc.names if k.startswith("connect") and k[7:].isdigit())
    blocks, volume, skipped = [], [], []
    for j in range(1, n_blocks + 1):
        conn = nc.get(f"connect{j}").astype(np.int64) - 1
        etype = str(nc.attr(f"connect{j}", "elem_type") or "").upper()
        ctype = EXODUS_ELEMENTS.get(etype) or _volume_type(etype, conn.shape[1] if conn.ndim == 2 else 0)
        if ctype is None:
            skipped.append(f"block {j} ({etype or 'no elem_type'}, {conn.shape[0]} elements)")
            continue
        if conn.size and (conn.min() < 0 or conn.max() >= n_nodes):
            raise SEDFormatError(f"SED file {path!r}: element block {j} refers to node {int(conn.max()) + 1}, but "
                                 f"the file has {n_nodes} nodes.")
        blocks.append(_Block(ctype, conn[:, EXODUS_TO_VTK[ctype]] if ctype in EXODUS_TO_VTK else conn))
        volume.append((j, conn.shape[0]))
    return (cells_from_meshio(blocks, path) if blocks else None), volume, skipped


def _nodal_arrays(nc, path: str, n_t: int, n_nodes: int) -> dict[str, RawArray]:
    """Every nodal variable as point data (n_t, n_nodes)."""
    arrays: dict[str, RawArray] = {}
    for i, name in enumerate(nc.strings("name_nod_var"), start=1):
        if f"vals_nod_var{i}" in nc:
            v = nc.get(f"vals_nod_var{i}", max(n_t, 1) * n_nodes * 9)  # a trailing component axis: up to a 3 x 3 tensor
        elif "vals_nod_var" in nc:
            combined = nc.get("vals_nod_var", max(n_t, 1) * len(nc.strings("name_nod_var")) * n_nodes)  # (time, variable, node)
            if combined.ndim != 3 or combined.shape[1] < i:
                raise SEDFormatError(f"SED file {path!r}: 'vals_nod_var' must be (time, variable, node) with a "
                                     f"slot for nodal variable {i} ({name!r}); got shape {combined.shape} instead.")
            v = combined[:, i - 1, :]
        else:
            raise SEDFormatError(f"SED file {path!r} names the nodal variable {name!r} but holds no values for it.")
        arrays[name] = RawArray(name, _per_step(v, n_t, n_nodes, path, f"nodal variable {name!r}", "node", True), "point")
    return arrays


def _element_arrays(nc, path: str, n_t: int, volume: list, arrays: dict[str, RawArray]) -> None:
    """Add every element variable as cell data over the volume blocks (NaN in blocks that do not carry it)."""
    table = nc.get("elem_var_tab") if "elem_var_tab" in nc else None
    n_cells = sum(n for _, n in volume)
    for i, name in enumerate(nc.strings("name_elem_var"), start=1):
        parts, present = [], False
        for k, (j, n) in enumerate(volume):
            key = f"vals_elem_var{i}eb{j}"
            in_table = table is None or (table.ndim == 2 and j - 1 < table.shape[0] and i - 1 < table.shape[1]
                                         and bool(table[j - 1, i - 1]))
            carried = key in nc and in_table
            if carried:
                v = _per_step(nc.get(key, max(n_t, 1) * n), n_t, n, path, f"element variable {name!r} of block {j}", "element")
                present = True
            else:
                v = np.full((n_t, n), np.nan)
            parts.append(v)
        if present:
            key = name if name not in arrays else f"{name}@cell"
            arrays[key] = RawArray(name, np.concatenate(parts, axis=1).reshape(n_t, n_cells), "cell")


def _material_array(nc, volume: list, n_t: int) -> tuple[RawArray | None, str | None]:
    """The element block id of each volume cell (cell order) as the cell array ``material``, with a note.

    Only for a file of several volume blocks with different ids (``eb_prop1``; the block's
    position, 1-based, when the file has none), so that the interface between two materials
    can be found (``--grid tips --material-array material --upper ID --lower ID``) and sampled
    on one side (``side=ID``), as for a CalculiX ``.frd`` or an FEBio ``.xplt``. The ids stay
    numbers (what those options take); the note names each block when the file does
    (``eb_names``).
    """
    if len(volume) < 2:
        return None, None
    ids = nc.get("eb_prop1").astype(np.int64).ravel() if "eb_prop1" in nc else np.zeros(0, dtype=np.int64)
    names = nc.strings("eb_names")
    block_ids = [int(ids[j - 1]) if j - 1 < ids.size else j for j, _ in volume]
    if len(set(block_ids)) < 2:
        return None, None
    values = np.concatenate([np.full(n, float(b)) for b, (_, n) in zip(block_ids, volume)])
    material = material_array(values, n_t)
    labels = [f"{b} {names[j - 1]!r}" if j - 1 < len(names) and names[j - 1] else str(b)
              for b, (j, _) in zip(block_ids, volume)]
    note = (f"cell array 'material': the element block id of each cell ({len(set(block_ids))} blocks: "
            f"{', '.join(labels)})")
    return material, note


def read_exodus(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """Read an Exodus II file: mesh, every time step, nodal and element variables.

    Parameters
    ----------
    path : str
        ``.e``, ``.exo``, ``.ex2`` or ``.g`` file.
    progress : bool
        Unused (the file is read in one pass); accepted for a uniform reader signature.
    scope : Scope, optional
        Where the files the HDF5 external links and external storage of a netCDF-4 file lead to
        may be (:mod:`afferent.io._files`); default inside the file's own folder.

    Returns
    -------
    RawExport
        Points (model length unit), volume cells, one array per variable (nodal -> point data,
        element -> cell data over the volume blocks), times (``time_whole``).

    Raises
    ------
    SEDFormatError
        Not a netCDF file, no coordinates, a variable whose size does not match the mesh, a
        damaged or truncated file.
    """
    check_export_file(path)
    nc = _NetCDF(path, scope)
    try:
        coords = _coordinates(nc, path)
        cells, volume, skipped = _volume_blocks(nc, path, coords.shape[0])
        times = nc.get("time_whole").astype(float).ravel() if "time_whole" in nc else np.zeros(0)
        n_t = times.size  # 0: a mesh (Cubit .g) with no results
        arrays = _nodal_arrays(nc, path, n_t, coords.shape[0])
        if cells is not None:
            _element_arrays(nc, path, n_t, volume, arrays)
        material, material_note = _material_array(nc, volume, n_t)
        notes = [f"Exodus II, {nc.kind}: {n_t} time step(s), {len(volume)} volume block(s)"
                 + (f"; ignored {', '.join(skipped)}" if skipped else "") + "."]
        if material is not None and "material" not in arrays:
            arrays["material"] = material
            notes.append(material_note)
    finally:
        nc.close()
    if cells is None:
        notes.append("No volume elements in the file: the points are treated as scattered samples.")
    if n_t == 0:
        notes.append("The file holds a mesh and no time step: no results to read.")
    if n_t > 1 and np.any(np.diff(times) <= 0):
        k = int(np.flatnonzero(np.diff(times) <= 0)[0])
        raise SEDFormatError(f"SED file {path!r}: time_whole must increase; got {times[k]!r} then {times[k + 1]!r} "
                             f"(steps {k} and {k + 1}).")
    return RawExport(files=files_read([path], nc.opened), format="exodus", points=coords, arrays=arrays, times=times if n_t else None, cells=cells,
                     notes=tuple(notes))
