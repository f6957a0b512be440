"""ANSYS MAPDL binary result files (``.rst``), through ``ansys-mapdl-reader`` (optional extra).

``pip install 'afferent-skin[ansys]'`` installs the reader (it brings pyvista and VTK, several
hundred MB, which is why it is not a core dependency). Read per result set: the nodal
displacement, the nodal stress (``S``: SX SY SZ SXY SYZ SXZ) and the nodal elastic strain
(``EPEL``: X Y Z XY YZ XZ, **engineering** shear, verified on the reader's shipped MAPDL file:
stress = C : EPEL holds with G gamma, not 2G eps), each averaged at the nodes by MAPDL's
post-processing as the reader returns it. MAPDL has no units: the user declares them. The
implied preset is 'ansys'.

The reader's compiled code can crash the interpreter on a damaged file (SIGSEGV, 'double free
or corruption', ``std::bad_alloc``): the headers and the records they point at are checked
first, then the file is read in a child Python process, whose death by a signal is reported as
an error naming the file and the signal.

Result sets are steps in time when their time values increase; a modal or harmonic analysis
(whose "time" values are frequencies, possibly repeated) is read with steps numbered by set,
as the note says.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..exceptions import SEDFormatError
from ._raw import RawArray, RawExport, drop_valueless_nodes

__all__ = ["read_rst"]

#: MAPDL analysis types (result header 'kan') whose result sets are not steps in time.
_NOT_TIME = {1: "buckling (load factors)", 2: "modal (frequencies, Hz)", 3: "harmonic (frequencies, Hz)",
             8: "substructure", 9: "spectrum"}
#: VTK cell type -> meshio cell type for the volume elements pyvista's grid carries.
_VTK_VOLUME = {10: "tetra", 12: "hexahedron", 13: "wedge", 14: "pyramid", 24: "tetra10", 25: "hexahedron20"}


def _check_header(path: str) -> None:
    """Refuse what the reader's compiled code would crash on: a file that is not an MAPDL binary
    file, or one shorter than its headers say (truncated).

    MAPDL binary files start with the 100-word standard header (record length 100, then items;
    item 2 is the file format, 12 for results). A result file's result header follows (its
    length at word 103, its items from word 105); its item 10, ``ptrend``, is the file's length
    in 4-byte words. (This check, and the reading of the headers, follow ansys-mapdl-reader's
    ``rst.py``; verified on the MAPDL files that project ships.)
    """
    size = os.path.getsize(path)
    words = np.fromfile(path, "<i4", count=min(size // 4, 105 + 80))
    if words.size and words[0] != 100 and words[:1].byteswap()[0] == 100:
        words = words.byteswap()
    if words.size < 105 or words[0] != 100:
        raise SEDFormatError(f"SED file {path!r} is not an ANSYS MAPDL binary file: it must start with the 100-word "
                             f"standard header record ({size} bytes found).")
    if words[2] != 12:
        return  # another MAPDL binary file: the reader names its kind
    n = int(words[103])
    if not 0 < n <= 80 or words.size < 105 + n:
        raise SEDFormatError(f"SED file {path!r} is truncated or corrupt: it has no MAPDL result header.")
    used = 4 * int(words[105 + 9])  # ptrend, in 4-byte words
    if size < used:
        raise SEDFormatError(f"SED file {path!r} is truncated: its header says the file uses {used} bytes; it has "
                             f"{size} bytes.")
    _check_records(path, words, size)


#: Result header items (from word 105) that point at a record: ptrDSI, ptrTIM, ptrLSP, ptrELM, ptrNOD, ptrGEO.
_POINTERS = {10: "ptrDSI", 11: "ptrTIM", 12: "ptrLSP", 13: "ptrELM", 14: "ptrNOD", 15: "ptrGEO"}


def _check_records(path: str, words: np.ndarray, size: int) -> None:
    """Each record the result header points at lies inside the file, as a Fortran record does: its
    length ``n`` (4-byte words), a flag word, ``n`` words, then ``n`` again (verified on the
    reader's shipped file). The 32-bit pointers address files up to 8 GiB; larger ones are left
    to the reader."""
    n_words = size // 4
    if n_words >= 2**31:
        return
    data = np.memmap(path, dtype="<i4", mode="r", shape=(n_words,))
    if data[0] != 100:  # a big-endian file (its header was byte-swapped to be read)
        data = np.memmap(path, dtype=">i4", mode="r", shape=(n_words,))
    for item, name in _POINTERS.items():
        ptr = int(words[105 + item])
        if ptr == 0:
            continue
        n = int(data[ptr]) if 0 < ptr < n_words else None
        if n is None or not 0 <= n <= n_words - ptr - 3 or int(data[ptr + 2 + n]) != n:
            what = ("points outside the file" if n is None else f"points at a record of {n} words that "
                    + ("does not fit in the file" if not 0 <= n <= n_words - ptr - 3 else "does not end with its length"))
            raise SEDFormatError(f"SED file {path!r} is corrupt or truncated: its result header's {name} (word {ptr}) "
                                 f"{what} ({size} bytes).")


def read_rst(path: str, *, progress: bool = False) -> RawExport:
    """Read an ANSYS MAPDL ``.rst`` result file.

    The file's headers and the records its pointers name are checked first; then
    ansys-mapdl-reader reads it in a child Python process, so that a crash of its compiled
    code on a corrupt file (SIGSEGV, 'double free or corruption', ``std::bad_alloc``) ends the
    child, and is reported as an error naming the file and the signal, instead of ending
    this process.

    Parameters
    ----------
    path : str
        The ``.rst`` file.
    progress : bool
        Show a progress bar over the result sets.

    Returns
    -------
    RawExport
        Points (model length unit), volume cells, per result set the arrays ``U``
        (displacement), ``S`` (stress, components SX..SXZ) and ``EPEL`` (elastic strain,
        EPELX..EPELXZ, engineering shear) as point data; ``preset='ansys'``.

    Raises
    ------
    SEDFormatError
        The optional reader is not installed, or the file is not a readable MAPDL result file
        (damaged headers or records, or the reader failed or crashed on it).
    """
    from ._cell_blocks import cells_from_meshio

    if not os.path.isfile(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    _check_header(path)
    if not _reader_installed():
        raise SEDFormatError(
            f"SED file {path!r} is an ANSYS .rst result file; reading it needs the optional extra: "
            "pip install 'afferent-skin[ansys]' (ansys-mapdl-reader)."
        )
    got = _read_in_child(path, progress)
    points, blocks, stacks, times, kan = got["points"], got["blocks"], got["stacks"], got["times"], got["kan"]

    class _Block:
        def __init__(self, ctype, data):
            self.type, self.data = ctype, np.asarray(data, dtype=np.int64)

    cells = cells_from_meshio([_Block(t, c) for t, c in blocks], path) if blocks else None
    notes = [f"ANSYS MAPDL result file (ansys-mapdl-reader): {len(times)} result set(s); nodal S and EPEL as MAPDL "
             "averages them at the nodes; EPEL shear is engineering (preset 'ansys')."]
    if kan in _NOT_TIME or (times.size > 1 and np.any(np.diff(times) <= 0)):
        what = _NOT_TIME.get(kan, "values that do not increase")
        notes.append(f"the result sets are not steps in time: a {what} analysis (set values "
                     f"{', '.join(f'{t:g}' for t in times[:6])}{', ...' if times.size > 6 else ''}); steps are numbered "
                     "by result set 0, 1, ...")
        times = np.arange(times.size, dtype=float)
    components = {"U": ("UX", "UY", "UZ"), "S": ("SX", "SY", "SZ", "SXY", "SYZ", "SXZ"),
                  "EPEL": ("EPELX", "EPELY", "EPELZ", "EPELXY", "EPELYZ", "EPELXZ")}
    arrays = {k: RawArray(k, np.stack(v), "point", None, components[k]) for k, v in stacks.items()}
    raw = RawExport(files=(path,), format="rst", points=points, arrays=arrays, times=times, cells=cells,
                    notes=tuple(notes), preset="ansys")
    return drop_valueless_nodes(raw)


def _reader_installed() -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec("ansys.mapdl.reader") is not None
    except (ImportError, ValueError):  # a parent package missing, or the module set to None (tests)
        return False


def _read_arrays(path: str, progress: bool) -> dict:
    """What ansys-mapdl-reader reads of ``path`` (runs in the child process of :func:`_read_in_child`)."""
    from ansys.mapdl.reader import read_binary

    from .._progress import progress_bar

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rst = read_binary(path)
            grid = rst.grid
            node_numbers = np.asarray(grid.point_data["ansys_node_num"], dtype=np.int64)
            points = np.asarray(grid.points, dtype=float)
            blocks = []
            for vtk_type, conn in grid.cells_dict.items():
                ctype = _VTK_VOLUME.get(int(vtk_type))
                if ctype is not None:
                    k = {"tetra": 4, "hexahedron": 8, "wedge": 6, "pyramid": 5}.get(ctype, conn.shape[1])
                    base = {"tetra10": "tetra", "hexahedron20": "hexahedron"}.get(ctype, ctype)
                    blocks.append((base, np.asarray(conn)[:, :{"tetra": 4, "hexahedron": 8}.get(base, k)]))
            order = np.argsort(node_numbers)
            stacks = {"U": [], "S": [], "EPEL": []}
            for k in progress_bar(range(rst.nsets), enabled=progress, desc="reading rst", unit="set"):
                for key, getter, ncomp in (("U", rst.nodal_displacement, 3), ("S", rst.nodal_stress, 6),
                                           ("EPEL", rst.nodal_elastic_strain, 6)):
                    nnum, values = getter(k)
                    values = np.asarray(values, dtype=float)[:, :ncomp]
                    full = np.full((points.shape[0], ncomp), np.nan)
                    pos = np.searchsorted(node_numbers[order], np.asarray(nnum))
                    full[order[pos]] = values
                    stacks[key].append(full)
            times = np.asarray(rst.time_values, dtype=float)
            kan = int(getattr(rst, "_resultheader", {}).get("kan", 0))
    except Exception as err:
        raise SEDFormatError(
            f"SED file {path!r} could not be read as an ANSYS MAPDL result file (ansys-mapdl-reader): "
            f"{type(err).__name__}: {err}"
        ) from err
    return {"points": points, "blocks": blocks, "stacks": stacks, "times": times, "kan": kan}


def _read_in_child(path: str, progress: bool) -> dict:
    """:func:`_read_arrays` in a child Python process (:func:`afferent.io._child.call_in_child`): a crash of
    ansys-mapdl-reader's compiled code on a damaged file becomes an :class:`SEDFormatError`. Cost: the
    child's start-up (importing numpy and ansys-mapdl-reader), about a second."""
    from ._child import call_in_child

    return call_in_child("afferent.io._ansys", "_read_arrays", os.path.abspath(path), progress, path=path,
                         reading="an ANSYS MAPDL result file", tool="ansys-mapdl-reader", show_stderr=progress,
                         crash_hint="the file is corrupt or truncated, or not a result file this reader knows")
