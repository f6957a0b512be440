"""The VTK family through VTK's own readers (the optional extra ``vtk``).

VTK's readers are the reference implementation of the formats most FE tools write. afferent
reads ``.vtu`` and legacy ``.vtk`` files through meshio first (light, always installed) and
through VTK only where meshio cannot:

- legacy ``.vtk`` (and ``.vtu``) files meshio refuses: Kratos' default ``VtkOutputProcess``
  output (binary, no newline after each binary block) and FreeFEM's ``savevtk`` legacy files
  (:func:`afferent.io._meshio.read_mesh_file` falls back to :func:`read_vtk_file`);
- parallel ``.pvtu`` records (deal.II, FEniCS, OpenFOAM, Kratos under MPI) and ``.vtm``
  multiblock files (Kratos' ``VtuOutputProcess``), which meshio does not read at all.

Without the ``vtk`` package the error names the extra that reads the file
(``pip install 'afferent-skin[vtk]'``). Why VTK is an extra and not a dependency, with the
measured install size and read times, is in the documentation's formats page
(docs/fe-export.md, "The VTK family").

Pieces of a ``.pvtu`` and blocks of a ``.vtm`` are merged into one mesh. Nodes that two
*different* pieces list at the same coordinates (within :data:`MERGE_RTOL` x the median edge
length) *with the same values* in every point array (within :data:`VALUE_RTOL` x the array's
largest magnitude) are partition-boundary copies and are merged into one node; how many is
stated in the notes. Coincident nodes whose values differ (discontinuous output such as
deal.II's per-cell patches) and coincident nodes within one piece are kept as they are: the
sampling stage handles coincident points with different values. This is the only merge done
at read time, and it is kept minimal on purpose. In a series of ``.pvtu``/``.vtm`` files one
merge (:class:`MergePlan`, from the first and last steps' values) serves every step and is
checked at each: a field all zero at t = 0 and discontinuous later is not merged at t = 0 alone.

Every piece and block file (recursively: a ``.vtm`` block may be a ``.pvtu``) passes
:func:`afferent.io._files.resolve_member` before VTK opens any: inside the folder of the export
named unless ``allow_outside_files``, a regular file; a file that lists itself is refused.

A legacy ``.vtk`` is read by VTK in a child process (:mod:`afferent.io._child`): VTK's legacy reader can
die with SIGSEGV on a damaged file, which becomes an SEDFormatError naming the file.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass

import numpy as np

from ..exceptions import SEDFormatError
from ._files import MAX_DEPTH, Scope, resolve_member
from ._raw import files_read
from ._xml import parse_xml

__all__ = ["EXTRA", "read_vtk_file", "vtk_version", "merge_piece_nodes", "series_merge_plan", "MergePlan", "MERGE_RTOL",
           "VALUE_RTOL"]

_OUTPUT_LOCK = threading.Lock()

#: The install command named when VTK is needed and missing.
EXTRA = "pip install 'afferent-skin[vtk]'"
#: Coordinates of two pieces' nodes closer than this x the median cell-edge length are the same place.
MERGE_RTOL = 1e-6
#: Values of two coincident nodes differing by at most this x the array's largest magnitude are equal
#: (VTK files often store float32: 6e-8 relative).
VALUE_RTOL = 1e-6


def _vtk(problem: str):
    """The VTK modules afferent uses, or a SEDFormatError saying ``problem`` and naming the extra."""
    try:
        from vtkmodules import vtkCommonCore, vtkCommonDataModel, vtkIOLegacy, vtkIOXML
        from vtkmodules.util import numpy_support
    except ImportError as err:
        raise SEDFormatError(f"{problem}; VTK's own readers read it: {EXTRA}.") from err
    return vtkCommonCore, vtkCommonDataModel, vtkIOLegacy, vtkIOXML, numpy_support


def vtk_version() -> str | None:
    """The installed VTK version, or None when the ``vtk`` extra is not installed."""
    try:
        from vtkmodules.vtkCommonCore import vtkVersion
    except ImportError:
        return None
    return vtkVersion.GetVTKVersion()


def _run_reader(reader, path: str, core) -> list[str]:
    """Update a VTK reader; return its warnings, and raise SEDFormatError on what it reports as an error.

    VTK prints its errors and carries on: a truncated legacy .vtk comes back with the arrays read
    before the cut and a warning "Error reading binary data!". Messages are captured (not printed)
    and any that says "Error" refuses the file.
    """
    with _OUTPUT_LOCK:  # VTK's output window is process-wide: one reader at a time (Dask's thread scheduler)
        window = core.vtkStringOutputWindow()
        previous = core.vtkOutputWindow.GetInstance()
        verbosity = core.vtkLogger.GetCurrentVerbosityCutoff()  # the stderr level when no log file is open
        core.vtkOutputWindow.SetInstance(window)
        core.vtkLogger.SetStderrVerbosity(core.vtkLogger.VERBOSITY_OFF)
        try:
            reader.SetFileName(path)
            reader.Update()
        finally:
            core.vtkOutputWindow.SetInstance(previous)
            core.vtkLogger.SetStderrVerbosity(core.vtkLogger.ConvertToVerbosity(verbosity))
    said = window.GetOutput()  # str, or bytes when VTK's messages quote bytes of the file that are not UTF-8
    said = said.decode("utf-8", "replace") if isinstance(said, bytes) else said
    messages = [m.strip() for m in said.split("\n\n") if m.strip()]
    # each message: 'ERROR: In file, line N\nvtkClass (0x...): text' -> 'text'
    texts = [m.splitlines()[-1].split("): ", 1)[-1].strip() for m in messages]
    errors = [t for m, t in zip(messages, texts) if m.startswith("ERROR") or "Error" in t]
    if errors or reader.GetErrorCode():
        raise SEDFormatError(f"SED file {path!r} could not be read by VTK {vtk_version()} (truncated or corrupt?): "
                             f"{errors[0] if errors else 'error code ' + str(reader.GetErrorCode())}")
    return [f"VTK warned: {t}" for t in texts]


def _datasets(path: str, mods, warned: list, scope: Scope) -> list:
    """The leaf datasets of a VTK-family file: one for .vtk/.vtu, one per piece of a .pvtu, every block of a .vtm
    (the files they name already resolved in ``scope``: :func:`_member_files`)."""
    core, data, legacy, xml, _ = mods
    ext = os.path.splitext(path)[1].lower()
    if ext == ".pvtu":
        return [ds for piece in _pvtu_pieces(path, scope) for ds in _datasets(piece, mods, warned, scope)]
    reader = {".vtk": legacy.vtkGenericDataObjectReader, ".vtu": xml.vtkXMLUnstructuredGridReader,
              ".vtm": xml.vtkXMLMultiBlockDataReader}.get(ext, xml.vtkXMLGenericDataObjectReader)()
    if ext == ".vtk":
        _read_all_arrays(reader)
    warned.extend(_run_reader(reader, path, core))
    out = reader.GetOutput()
    if out is None:
        raise SEDFormatError(f"SED file {path!r} could not be read by VTK {vtk_version()}: it returned no data.")
    if isinstance(out, data.vtkCompositeDataSet):
        it = out.NewIterator()
        it.SkipEmptyNodesOn()
        it.InitTraversal()
        leaves = []
        while not it.IsDoneWithTraversal():
            leaves.append(it.GetCurrentDataObject())
            it.GoToNextItem()
        if not leaves:
            raise SEDFormatError(f"SED file {path!r} lists no readable blocks (missing block files?).")
        return leaves
    return [out]


#: The legacy reader's switches that keep every array of a kind: off by default, it keeps only the first
#: ``SCALARS`` (``VECTORS``, ``TENSORS``, ...) section of a POINT_DATA or CELL_DATA part (GetFEM's
#: ``export_to_vtk`` writes one section an array: its SED, after ``von_mises``, was lost).
_READ_ALL = ("Scalars", "Vectors", "Tensors", "Normals", "TCoords", "ColorScalars", "Fields")


def _read_all_arrays(reader) -> None:
    """Switch on every ``ReadAll*`` option of a VTK legacy reader (:data:`_READ_ALL`)."""
    for kind in _READ_ALL:
        getattr(reader, f"ReadAll{kind}On")()


def _pvtu_pieces(path: str, scope: Scope | None = None) -> list[str]:
    """The piece files a .pvtu record lists (``<Piece Source=...>``), each resolved in ``scope``
    (:func:`afferent.io._files.resolve_member`; it must exist)."""
    root = parse_xml(path, ".pvtu")
    sources = [p.attrib.get("Source") for p in root.iter("Piece")]
    if not sources or None in sources:
        raise SEDFormatError(f"SED file {path!r} lists no <Piece Source=...> entries; expected a parallel VTU record.")
    pieces = [resolve_member(path, s, what="the piece", scope=scope) for s in sources]
    for p in pieces:
        if p.lower().endswith(".pvtu"):
            raise SEDFormatError(f"SED file {path!r} lists the piece {p!r}, a parallel record itself; the pieces of a "
                                 ".pvtu are .vtu files.")
    return pieces


def _array(arr, numpy_support) -> tuple[np.ndarray, tuple[str, ...]]:
    """A vtkDataArray as float64 (n,) or (n, k), with its component names when it has them all."""
    values = np.asarray(numpy_support.vtk_to_numpy(arr), dtype=float)
    k = arr.GetNumberOfComponents()
    names = tuple(arr.GetComponentName(i) or "" for i in range(k)) if k > 1 else ()
    return values.reshape(-1, k) if k > 1 else values, names if all(names) else ()


def _cell_types(ds):
    """The cell-type array: ``GetCellTypes()`` from VTK 9.6 on, ``GetCellTypesArray()`` before."""
    try:
        types = ds.GetCellTypes()
    except TypeError:  # VTK < 9.6: GetCellTypes fills a vtkCellTypes argument
        types = None
    return types if types is not None and hasattr(types, "GetNumberOfTuples") else ds.GetCellTypesArray()


def _piece(ds, path: str, mods) -> dict:
    """One unstructured dataset as numpy: points, cells grouped by type, point and cell arrays."""
    from meshio._vtk_common import vtk_to_meshio_type

    _, data, _, _, nps = mods
    if not isinstance(ds, data.vtkUnstructuredGrid):
        raise SEDFormatError(
            f"SED file {path!r} holds a {ds.GetClassName().removeprefix('vtk')}, not the UnstructuredGrid (volume mesh) "
            "afferent reads; in ParaView apply 'Clean to Grid' (or 'Merge Blocks') and save as .vtu."
        )
    n = ds.GetNumberOfPoints()
    points = nps.vtk_to_numpy(ds.GetPoints().GetData()).astype(float) if n else np.zeros((0, 3))
    cells = ds.GetCells()
    offsets = nps.vtk_to_numpy(cells.GetOffsetsArray()).astype(np.int64) if ds.GetNumberOfCells() else np.zeros(1, int)
    conn = nps.vtk_to_numpy(cells.GetConnectivityArray()).astype(np.int64) if ds.GetNumberOfCells() else np.zeros(0, int)
    types = nps.vtk_to_numpy(_cell_types(ds)) if ds.GetNumberOfCells() else np.zeros(0, int)
    blocks = []
    for t in np.unique(types):
        idx = np.flatnonzero(types == t)
        sizes = offsets[idx + 1] - offsets[idx]
        name = vtk_to_meshio_type.get(int(t))
        if name is None or name == "polyhedron" or len(np.unique(sizes)) != 1:
            continue  # cell kinds afferent does not sample in (their data is dropped with them)
        blocks.append((name, conn[offsets[idx][:, None] + np.arange(sizes[0])], idx))
    pd, cd = ds.GetPointData(), ds.GetCellData()
    point_data = {pd.GetArrayName(i): _array(pd.GetArray(i), nps) for i in range(pd.GetNumberOfArrays()) if pd.GetArray(i)}
    cell_data = {cd.GetArrayName(i): _array(cd.GetArray(i), nps) for i in range(cd.GetNumberOfArrays()) if cd.GetArray(i)}
    return {"points": points, "blocks": blocks, "point_data": point_data, "cell_data": cell_data}


def _edge_length(points: np.ndarray, blocks) -> float:
    """Median length of the first edge (nodes 0-1) of the cells: the mesh size."""
    edges = [np.linalg.norm(points[conn[:, 1]] - points[conn[:, 0]], axis=1) for _, conn, _ in blocks if conn.shape[1] > 1]
    lengths = np.concatenate(edges) if edges else np.zeros(0)
    lengths = lengths[lengths > 0]
    if lengths.size:
        return float(np.median(lengths))
    span = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    return span or 1.0


def merge_piece_nodes(points: np.ndarray, piece: np.ndarray, values: list[np.ndarray], tol: float):
    """Merge the nodes that different pieces list at one place with the same values.

    Parameters
    ----------
    points : ndarray of shape (n, 3)
        Every piece's nodes, concatenated (file length unit).
    piece : ndarray of shape (n,)
        The piece each node comes from.
    values : list of ndarray of shape (n, ...)
        The point arrays; coincident nodes are merged only where all of them agree within
        :data:`VALUE_RTOL` x the array's largest magnitude.
    tol : float
        Coordinates closer than this are the same place (file length unit).

    Returns
    -------
    keep : ndarray of int
        Indices of the nodes kept, increasing.
    new_index : ndarray of shape (n,)
        For every node, its index among the kept nodes (merged nodes map to their kept twin).
    n_different : int
        Nodes of different pieces at one place whose values differ: kept as separate copies.
    """
    pairs = _cross_pairs(points, piece, tol)
    same = _same_values(pairs, values, points.shape[0])
    keep, new_index = _joined(pairs[same], points.shape[0])
    return keep, new_index, int(np.unique(pairs[~same]).size)


def _cross_pairs(points: np.ndarray, piece: np.ndarray, tol: float) -> np.ndarray:
    """(k, 2) pairs of nodes of different pieces closer than ``tol``."""
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(tol, output_type="ndarray") if len(points) else np.zeros((0, 2), int)
    return pairs[piece[pairs[:, 0]] != piece[pairs[:, 1]]]


def _same_values(pairs: np.ndarray, values: list[np.ndarray], n: int) -> np.ndarray:
    """Which pairs carry equal values in every array (within :data:`VALUE_RTOL` x its largest magnitude)."""
    same = np.ones(len(pairs), bool)
    for v in values:
        v2 = v.reshape(n, -1)
        scale = float(np.nanmax(np.abs(v2))) if v2.size else 0.0
        same &= (np.abs(v2[pairs[:, 0]] - v2[pairs[:, 1]]) <= VALUE_RTOL * scale).all(axis=1)
    return same


def _joined(pairs: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(nodes kept, new index of every node) when each pair of nodes becomes one node."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1 if n else 0, n)
    np.minimum.at(first, label, np.arange(n))
    keep = np.sort(first)
    position = np.empty(n, np.int64)
    position[keep] = np.arange(keep.size)
    return keep, position[first[label]]


@dataclass(frozen=True)
class MergePlan:
    """Which nodes of a .pvtu's (or .vtm's) pieces become one node, decided once for a whole series.

    Decided per file, a field equal across pieces at one step (all zero at t = 0) and not at
    another would merge differently from step to step; a series' steps share one plan, made
    from the values of its first and last steps and checked at every step.
    """

    pairs: np.ndarray  # (k, 2) node pairs merged, indices into the pieces' concatenated nodes
    n_points: int
    tol: float
    n_different: int
    basis: str  # what the values were compared at, for the notes


def _point_values(pieces: list[dict], names: list[str]) -> list[np.ndarray]:
    return [np.concatenate([p["point_data"][n][0] for p in pieces]) for n in names]


def _plan(piece_sets: list[list[dict]], path: str, basis: str) -> MergePlan:
    """The merge plan for pieces (of one file, or of a series' first and last files, on the same nodes)."""
    first = piece_sets[0]
    points = np.concatenate([p["points"] for p in first])
    piece = np.repeat(np.arange(len(first)), [len(p["points"]) for p in first])
    blocks = [b for p in first for b in p["blocks"]]
    offsets = np.cumsum([0] + [len(p["points"]) for p in first])
    tol = MERGE_RTOL * _edge_length(points, [(n, c + offsets[k], i) for k, p in enumerate(first) for n, c, i in p["blocks"]]
                                    if blocks else [])
    pairs = _cross_pairs(points, piece, tol)
    same = np.ones(len(pairs), bool)
    for pieces in piece_sets:
        if len(pieces) != len(first) or not np.array_equal(np.concatenate([p["points"] for p in pieces]), points):
            raise SEDFormatError(f"SED file {path!r}: the steps of the series are not cut into the same pieces on the same "
                                 "nodes (repartitioned?); afferent reads a series of parallel records on one partition.")
        names = [n for n in pieces[0]["point_data"] if all(n in p["point_data"] for p in pieces)]
        same &= _same_values(pairs, _point_values(pieces, names), len(points))
    return MergePlan(pairs[same], len(points), tol, int(np.unique(pairs[~same]).size), basis)


def series_merge_plan(first: str, last: str, first_scope: Scope | None = None, last_scope: Scope | None = None
                      ) -> MergePlan:
    """One :class:`MergePlan` for a series of .pvtu/.vtm files, from its first and last steps' values (the files
    they point to resolved in their scopes)."""
    scopes = {first: first_scope, last: last_scope}
    sets = [_read_pieces(p, scope=scopes[p])[0] for p in dict.fromkeys((first, last))]
    return _plan(sets, first, f"the first and last steps ({os.path.basename(first)!r}, {os.path.basename(last)!r})")


def _common(pieces: list[dict], key: str, notes: list, path: str) -> list[str]:
    """The array names every piece has (others are dropped with a note)."""
    names = [n for n in pieces[0][key] if all(n in p[key] for p in pieces)]
    dropped = sorted({n for p in pieces for n in p[key]} - set(names))
    if dropped:
        notes.append(f"{', '.join(map(repr, dropped))} dropped: not in every piece of {path!r}.")
    return names


def _merged_mesh(pieces: list[dict], path: str, notes: list, plan: MergePlan | None = None):
    """One meshio.Mesh from the pieces (nodes shared by pieces merged by ``plan``, or by their own
    values), and the component names."""
    import meshio

    offsets = np.cumsum([0] + [len(p["points"]) for p in pieces])
    points = np.concatenate([p["points"] for p in pieces])
    pnames = _common(pieces, "point_data", notes, path)
    cnames = _common(pieces, "cell_data", notes, path)
    for key, names in (("point_data", pnames), ("cell_data", cnames)):
        for n in names:
            shapes = {p[key][n][0].shape[1:] for p in pieces}
            if len(shapes) > 1:
                raise SEDFormatError(f"SED file {path!r}: the pieces' {key.replace('_', ' ')} array {n!r} has "
                                     f"different numbers of components ({', '.join(map(str, sorted(shapes)))}).")
    pdata = {n: np.concatenate([p["point_data"][n][0] for p in pieces]) for n in pnames}
    for k, p in enumerate(pieces):  # VTK keeps what the file says: a cell naming a point the piece lacks is refused
        for name, conn, _ in p["blocks"]:
            if conn.size and (conn.min() < 0 or conn.max() >= len(p["points"])):
                raise SEDFormatError(f"SED file {path!r}: a {name} cell of piece {k} names point {int(conn.max())} "
                                     f"(or {int(conn.min())}); the piece has points 0..{len(p['points']) - 1}.")
    blocks = [(name, conn + offsets[k], idx, k) for k, p in enumerate(pieces) for name, conn, idx in p["blocks"]]
    new_index = np.arange(len(points))
    if len(pieces) > 1:
        plan = plan or _plan([pieces], path, "this step")
        if plan.n_points != len(points) or not _same_values(plan.pairs, list(pdata.values()), len(points)).all():
            raise SEDFormatError(
                f"SED file {path!r}: nodes its pieces share carry different values here but equal ones at {plan.basis} "
                "(or the pieces differ): a field continuous between pieces at some steps and not at others; read the "
                "steps one by one.")
        keep, new_index = _joined(plan.pairs, len(points))
        notes.append(
            f"{len(pieces)} pieces merged into one mesh: {len(points) - keep.size} node(s) that pieces share (same place "
            f"within {plan.tol:.3g} file units, same values at {plan.basis}) merged, {keep.size} nodes left"
            + (f"; {plan.n_different} coincident node(s) of different pieces with different values kept as separate "
               "copies (discontinuous output, handled when sampling)." if plan.n_different else ".")
        )
        points, pdata = points[keep], {n: v[keep] for n, v in pdata.items()}
    types = list(dict.fromkeys(b[0] for b in blocks))  # one block per cell type, pieces in order
    cells = [meshio.CellBlock(t, new_index[np.concatenate([b[1] for b in blocks if b[0] == t])]) for t in types]
    cell_data = {n: [np.concatenate([pieces[k]["cell_data"][n][0][idx] for name, _, idx, k in blocks if name == t])
                     for t in types] for n in cnames}
    comps = {n: pieces[0]["point_data"][n][1] for n in pnames}
    comps.update({n: pieces[0]["cell_data"][n][1] for n in cnames})
    return meshio.Mesh(points, cells, point_data=pdata, cell_data=cell_data), {n: c for n, c in comps.items() if c}


def _read_pieces(path: str, meshio_error: Exception | None = None, scope: Scope | None = None
                 ) -> tuple[list[dict], list[str]]:
    """The unstructured pieces (or blocks) of a VTK-family file as numpy, and the notes; every file it names is
    resolved in ``scope`` before VTK opens any (:func:`_member_files`).

    A legacy ``.vtk`` file is read in a child process (:func:`afferent.io._child.call_in_child`): VTK's legacy
    reader can die with SIGSEGV on a damaged file (``tests/data/fuzz``), which becomes an SEDFormatError here.
    """
    scope = scope or Scope.of(path)
    _member_files(path, scope)
    if path.lower().endswith(".vtk") and vtk_version() is not None:
        from ._child import call_in_child

        return call_in_child("afferent.io._vtk", "_read_pieces_here", path, meshio_error, scope, path=path,
                             reading="a legacy VTK file", tool=f"VTK {vtk_version()}",
                             crash_hint="the file is corrupt or truncated (a count or data type in it that does not "
                                        "match the data that follows)")
    return _read_pieces_here(path, meshio_error, scope)


def _read_pieces_here(path: str, meshio_error: Exception | None, scope: Scope) -> tuple[list[dict], list[str]]:
    """:func:`_read_pieces` in this process (the files it names already resolved)."""
    ext = os.path.splitext(path)[1].lower()
    problem = (str(meshio_error).rstrip(".") if meshio_error is not None else
               f"SED file {path!r} is a {'parallel VTU record' if ext == '.pvtu' else 'VTK multiblock file'}, "
               "which meshio does not read")
    mods = _vtk(problem)
    warned: list[str] = []
    try:
        datasets = _datasets(path, mods, warned, scope)
    except SEDFormatError as err:
        if meshio_error is None:
            raise
        detail = str(err).split("(truncated or corrupt?): ", 1)[-1]
        raise SEDFormatError(f"{str(meshio_error).rstrip('.')}; VTK {vtk_version()} could not read it either: {detail}") from err
    notes = [f"read by VTK {vtk_version()}" + (" (meshio could not read it)." if meshio_error is not None else "."),
             *dict.fromkeys(warned)]
    grids = [ds for ds in datasets if isinstance(ds, mods[1].vtkUnstructuredGrid)]
    if grids and len(grids) < len(datasets):  # a .vtm's surface (PolyData) blocks beside its volume
        others = sorted({ds.GetClassName().removeprefix("vtk") for ds in datasets if ds not in grids})
        notes.append(f"{len(datasets) - len(grids)} block(s) that are not unstructured grids ({', '.join(others)}) left out.")
    return [_piece(ds, path, mods) for ds in (grids or datasets)], notes


def read_vtk_file(path: str, *, meshio_error: Exception | None = None, plan: MergePlan | None = None,
                  scope: Scope | None = None):
    """Read a ``.vtk``, ``.vtu``, ``.pvtu`` or ``.vtm`` file through VTK into a RawExport.

    Parameters
    ----------
    path : str
        The file.
    meshio_error : Exception, optional
        Why meshio could not read it (a ``.vtk``/``.vtu`` file), for the notes and errors.
    plan : MergePlan, optional
        Which nodes of the pieces to merge (one plan for every step of a series,
        :func:`series_merge_plan`); by default decided from this file's own values.
    scope : Scope, optional
        Where the pieces and blocks may be (:func:`afferent.io._files.resolve_member`); default inside
        the file's own folder. Each is resolved before VTK opens any.

    Returns
    -------
    RawExport
        One step; ``reader`` names VTK and its version; the notes say why VTK read it and how
        many shared nodes of the pieces were merged.

    Raises
    ------
    SEDFormatError
        VTK is not installed (the message names the extra), or cannot read the file either.
    """
    from ._meshio import raw_from_mesh

    scope = scope or Scope.of(path)
    pieces, notes = _read_pieces(path, meshio_error, scope)
    mesh, components = _merged_mesh(pieces, path, notes, plan)
    fmt = os.path.splitext(path)[1].lower().lstrip(".")
    return raw_from_mesh(mesh, path, fmt, components, notes, reader=f"VTK {vtk_version()}",
                         files=_member_files(path, scope))


def missing_members(index: str, members: list[str], what: str) -> None:
    """Refuse an index file (a ``.vtm``, a ``.pvd``, a JSON ``.series``) that lists files that do not exist,
    naming each (up to 10) and how many there are, before anything is read.

    Raises
    ------
    FileNotFoundError
        ``"SED file '<index>' lists 2 of its 5 <what> files that do not exist: 'a' (entry 1), 'b' (entry 3)."``
    """
    gone = [(k, m) for k, m in enumerate(members) if not os.path.lexists(m)]
    if not gone:
        return
    named = ", ".join(f"{m!r} (entry {k})" for k, m in gone[:10]) + (f" and {len(gone) - 10} more" if len(gone) > 10 else "")
    raise FileNotFoundError(f"SED file {index!r} lists {len(gone)} of its {len(members)} {what} files that do not "
                            f"exist: {named}.")


def _member_files(path: str, scope: Scope | None = None, _within: tuple = ()) -> tuple[str, ...]:
    """Every file VTK opens for ``path``: the file, a .pvtu's pieces, a .vtm's block files (recursively), each
    resolved in ``scope`` (:func:`afferent.io._files.resolve_member`: inside the folder of the file named, a
    regular file); a piece or block file missing is refused, the error naming every missing one before VTK opens
    any (VTK's own error names the first and reads as a corrupt file); a file that lists itself, directly or
    through others, is refused."""
    scope = scope or Scope.of(path)
    within = _within + (os.path.realpath(path),)
    if len(within) > MAX_DEPTH:
        raise SEDFormatError(f"SED file {scope.export!r}: its pieces and blocks nest more than {MAX_DEPTH} deep.")
    ext = os.path.splitext(path)[1].lower()
    if ext == ".pvtu":
        members = _pvtu_pieces(path, scope)
    elif ext == ".vtm":  # VTK's multiblock reader opens each <DataSet file=...>, relative to the .vtm
        entries = [e.get("file") for e in parse_xml(path, ".vtm").iter("DataSet") if e.get("file")]
        members = [resolve_member(path, f, what="the block", scope=scope, must_exist=False) for f in entries]
        missing_members(path, members, "block")
    else:
        members = []
    for m in members:
        if os.path.realpath(m) in within:
            raise SEDFormatError(f"SED file {path!r} lists {m!r}, which lists {path!r} again (directly or through "
                                 "other files): a loop.")
    return files_read([path], *(_member_files(m, scope, within) for m in members if os.path.isfile(m)))
