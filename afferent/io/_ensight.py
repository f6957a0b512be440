"""EnSight Gold ``.case`` files (OpenFOAM's foamToEnsight, VTK's vtkEnSightWriter, commercial solvers' neutral
export) through VTK's own reader (the ``vtk`` extra).

A ``.case`` file names a geometry file and one file per variable, each with a time set whose
``filename start number``/``filename increment`` (or ``filename numbers``) replace the ``*`` wildcards of
the name at each step (``data/********/SED``: zero-padded to the number of stars). afferent parses the
case file itself and passes every file it names, at every step, through the one resolver
(:func:`afferent.io._files.resolve_member`: inside the export's folder unless ``allow_outside_files``, a
regular file) before VTK opens any; the error for missing files names each of them. Constructs whose files
afferent does not list this way (``FILE`` sets, measured/match/boundary/rigid-body files, complex
variables, server-of-servers case files) are refused rather than left to VTK.

VTK's ``vtkGenericEnSightReader`` reads ASCII and C Binary files; each ``part`` is one piece, and the nodes
that parts share (OpenFOAM writes each boundary patch as its own part, on copies of its nodes) are merged
where their values agree (:func:`afferent.io._vtk._merged_mesh`, as a ``.pvtu``'s pieces). Arrays keep the
case file's variable names; a ``tensor symm`` arrives in VTK's order XX YY ZZ XY YZ XZ (VTK maps EnSight's
11 22 33 12 13 23). The ``time values`` are the file's times, in the model's unit. A pure-Python reader
for the default install is not written: the ``vtk`` extra is needed (``pip install 'afferent-skin[vtk]'``); why
(the pure-Python ``ensight-reader`` reads C Binary cases only): docs/fe-export.md, "Which install reads which test file".
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from ..exceptions import SEDFormatError
from ._files import Scope, resolve_member
from ._raw import RawExport, check_export_file, files_read, stack_steps

__all__ = ["read_ensight", "case_files"]

#: Case-file keywords whose files afferent does not resolve: refused, not left to VTK.
_UNLISTED = ("measured:", "match:", "boundary:", "rigid_body:", "complex ")


def _time_sets(lines: list[str], path: str) -> dict[int, dict]:
    """``{set number: {"numbers": [...], "values": [...]}}`` of the TIME section."""
    sets: dict[int, dict] = {}
    current, key = None, None
    for line in lines:
        head, _, rest = line.partition(":")
        head = head.strip().lower()
        if head in ("time set", "number of steps", "filename start number", "filename increment",
                    "filename numbers", "time values"):
            key = head
            if head == "time set":
                current = sets.setdefault(int(rest.split()[0]), {"numbers": [], "values": []})
                continue
            if current is None:
                current = sets.setdefault(1, {"numbers": [], "values": []})
            current[head] = rest.split()
        elif key in ("filename numbers", "time values") and current is not None:
            current[key] += line.split()  # a list continued on the next lines
        else:
            raise SEDFormatError(f"SED file {path!r}: the TIME section line {line.strip()!r} is not one afferent reads.")
    for number, s in sets.items():
        try:
            n = int(s["number of steps"][0])
            values = [float(v) for v in s.get("time values", [])]
            if "filename numbers" in s:
                numbers = [int(v) for v in s["filename numbers"]]
            else:
                start, inc = int(s.get("filename start number", ["0"])[0]), int(s.get("filename increment", ["1"])[0])
                numbers = [start + k * inc for k in range(n)]
        except (KeyError, ValueError, IndexError) as err:
            raise SEDFormatError(f"SED file {path!r}: time set {number} is incomplete or not numbers "
                                 f"({type(err).__name__}: {err}).") from err
        if len(values) != n or len(numbers) != n:
            raise SEDFormatError(f"SED file {path!r}: time set {number} has {n} steps but {len(values)} time values and "
                                 f"{len(numbers)} file numbers.")
        s.update(numbers=numbers, values=values)
    return sets


def _sections(path: str) -> dict[str, list[str]]:
    from ._files import open_regular

    with open_regular(path, "SED file", "r") as fh:
        text = fh.read()
    sections: dict[str, list[str]] = {}
    current = None
    for line in text.splitlines():
        stripped = line.split("#", 1)[0].rstrip()
        if not stripped.strip():
            continue
        if stripped.strip().upper() in ("FORMAT", "GEOMETRY", "VARIABLE", "TIME", "FILE", "MATERIAL", "BLOCK_CONTINUATION",
                                        "SCRIPTS", "SERVERS", "MULTIPLE_CASEFILES"):
            current = stripped.strip().upper()
            sections.setdefault(current, [])
        elif current is not None:
            sections[current].append(stripped)
    fmt = " ".join(sections.get("FORMAT", [])).lower()
    if "ensight" not in fmt:
        raise SEDFormatError(f"SED file {path!r} is not an EnSight case file: its FORMAT section must say 'type: ensight "
                             f"gold'; got {fmt or 'none'!r} instead.")
    for name in ("FILE", "SERVERS", "MULTIPLE_CASEFILES"):
        if name in sections:
            raise SEDFormatError(f"SED file {path!r} has a {name} section (file sets, or a server-of-servers case); "
                                 "afferent reads case files with one file per step named by wildcards.")
    return sections


def _named(line: str) -> tuple[int | None, str]:
    """(time set or None, file name) of a GEOMETRY ``model:`` line or a VARIABLE line (description before the name)."""
    words = line.split(":", 1)[1].split()
    words = [w for w in words if w != "change_coords_only"]
    ts = int(words[0]) if len(words) >= 2 and words[0].isdigit() and (line.lower().startswith("model") or len(words) >= 3) else None
    return ts, words[-1]


def case_files(path: str, scope: Scope | None = None) -> tuple[list[str], list[float] | None]:
    """Every file the case file ``path`` names at every step (wildcards replaced), each resolved in ``scope``,
    and the time values (None for a case without a TIME section). Missing files: one error naming each."""
    from ._vtk import missing_members

    scope = scope or Scope.of(path)
    sections = _sections(path)
    sets = _time_sets(sections.get("TIME", []), path)
    named = []
    for line in sections.get("GEOMETRY", []) + sections.get("VARIABLE", []):
        low = line.lower()
        if low.startswith(_UNLISTED):
            raise SEDFormatError(f"SED file {path!r}: {line.split(':')[0]!r} files are not read by afferent; remove "
                                 "the line or export without them.")
        if low.startswith("constant per case"):
            continue
        named.append(_named(line))
    if not named or not sections.get("GEOMETRY"):
        raise SEDFormatError(f"SED file {path!r} names no geometry file (GEOMETRY section, 'model:').")
    files = []
    for ts, name in named:
        stars = re.search(r"\*+", name)
        if stars is None:
            files.append(name)
            continue
        chosen = sets.get(ts) if ts is not None else (next(iter(sets.values())) if len(sets) == 1 else None)
        if chosen is None:
            raise SEDFormatError(f"SED file {path!r}: {name!r} has wildcards but no time set to number them.")
        width = len(stars.group(0))
        files += [name[:stars.start()] + str(n).zfill(width) + name[stars.end():] for n in chosen["numbers"]]
    resolved = [resolve_member(path, f, what="the geometry or variable file", scope=scope, must_exist=False)
                for f in dict.fromkeys(files)]
    missing_members(path, resolved, "geometry and variable")
    geometry_set = named[0][0]
    times = sets.get(geometry_set) if geometry_set is not None else (next(iter(sets.values())) if sets else None)
    if times is None and sets:
        times = next(iter(sets.values()))
    return resolved, None if times is None else times["values"]


def read_ensight(path: str, *, progress: bool = False, scope: Scope | None = None) -> RawExport:
    """Read an EnSight Gold case through VTK: every part (merged into one mesh), every time step, every variable.

    Parameters
    ----------
    path : str
        The ``.case`` file.
    progress : bool
        Unused; accepted for a uniform reader signature.
    scope : Scope, optional
        Where the files it names may be; default inside its own folder.

    Returns
    -------
    RawExport
        Points and arrays in the file's units, times from its TIME section (the model's unit).

    Raises
    ------
    SEDFormatError
        VTK is not installed (the message names the extra), a construct afferent does not list the files of,
        a file outside the export's folder (not allowed), VTK's reader reports an error.
    FileNotFoundError
        Files the case names are missing (each named).
    """
    from ._meshio import raw_from_mesh
    from ._vtk import _OUTPUT_LOCK, _merged_mesh, _piece, _plan, _vtk, vtk_version

    check_export_file(path)
    scope = scope or Scope.of(path)
    files, times = case_files(path, scope)
    mods = _vtk(f"SED file {path!r} is an EnSight Gold case, read through VTK's EnSight reader")
    from vtkmodules.vtkIOEnSight import vtkGenericEnSightReader

    reader = vtkGenericEnSightReader()
    reader.SetCaseFileName(path)
    reader.ReadAllVariablesOn()
    steps = [None] if not times else list(times)
    piece_sets, warned = [], []
    with _OUTPUT_LOCK:
        for t in steps:
            warned += _update(reader, path, mods[0], t)
            piece_sets.append([_piece(ds, path, mods) for ds in _leaves(reader.GetOutput(), mods)])
    plan = _plan([piece_sets[0], piece_sets[-1]], path, "the first and last steps") if len(piece_sets[0]) > 1 else None
    raws = []
    for k, pieces in enumerate(piece_sets):
        notes = [f"EnSight case read by VTK {vtk_version()}: {len(pieces)} part(s), {len(steps)} time step(s).",
                 *dict.fromkeys(warned)]
        mesh, components = _merged_mesh(pieces, path, notes, plan)
        raw = raw_from_mesh(mesh, path, "ensight", components, notes, reader=f"VTK {vtk_version()}",
                            files=files_read([path], files))
        raws.append(raw if times is None else replace(raw, times=np.array([times[k]])))
    return stack_steps(raws) if len(raws) > 1 else raws[0]


def _update(reader, path: str, core, t) -> list[str]:
    """Update ``reader`` at time ``t`` (None: its only step), VTK's messages captured: errors refuse the file."""
    window = core.vtkStringOutputWindow()
    previous = core.vtkOutputWindow.GetInstance()
    core.vtkOutputWindow.SetInstance(window)
    try:
        if t is None:
            reader.Update()
        else:
            reader.UpdateTimeStep(float(t))
    finally:
        core.vtkOutputWindow.SetInstance(previous)
    said = window.GetOutput()
    said = said.decode("utf-8", "replace") if isinstance(said, bytes) else said
    texts = [m.strip().splitlines()[-1].split("): ", 1)[-1] for m in said.split("\n\n") if m.strip()]
    errors = [m for m in said.split("\n\n") if m.strip().startswith("ERROR")]
    if errors or reader.GetErrorCode():
        raise SEDFormatError(f"SED file {path!r} could not be read by VTK's EnSight reader (truncated or corrupt?): "
                             f"{texts[0] if texts else 'error code ' + str(reader.GetErrorCode())}")
    return [f"VTK warned: {t}" for t in texts]


def _leaves(out, mods) -> list:
    """The unstructured grids (the parts with volume or surface cells) of the reader's multiblock output."""
    data = mods[1]
    leaves = []
    it = out.NewIterator()
    it.SkipEmptyNodesOn()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        ds = it.GetCurrentDataObject()
        if isinstance(ds, data.vtkUnstructuredGrid) and ds.GetNumberOfPoints():
            leaves.append(ds)
        it.GoToNextItem()
    return leaves
