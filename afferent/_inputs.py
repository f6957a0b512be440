"""Checks before the work: every file a command or a scene names, and the material array its found sites need,
checked before any export is read (issue 34, item 7).

One place, two callers that every route goes through:

- the command line (:func:`afferent.cli._main._guarded`) checks every file its options name
  (those marked with ``afferent.cli._options.reads(..., what=...)``) and the options' combinations
  (``afferent.cli._options.add_receptor_options``) before the command starts;
- a scene (``afferent run SCENE.toml``, ``afferent run EXPORT ...``, a sweep, :func:`afferent.run_scene`)
  checks the files its planned stages read and the material arrays of its found sites
  (``afferent.scene.stages._check_before_reading``) as its first step, before hashing or reading;
  ``afferent sample`` and ``afferent info`` call :func:`check_material_array` before they read.

A material array is checked on the export's header where the format lists its arrays without their
data (:func:`afferent.io._vtu.cell_array_names`: a ``.vtu``, and the first ``.vtu`` of a ``.pvd`` or
``.vtu.series``); in the other formats right after the one read of the export, on its first step as
read, before any site is searched or any receptor sampled
(:func:`afferent.receptors._tips.sites_from_raw`).
"""

from __future__ import annotations

import os

from .exceptions import SEDFormatError


def check_files(named) -> None:
    """Refuse a missing file, or one that is not a regular file (a folder, a FIFO), before anything is read.

    Parameters
    ----------
    named : iterable of (what, path, where)
        ``what``: the kind of file, as the readers name it ('Receptor file'); ``path``: the file (None:
        nothing named); ``where``: the option or scene key that named it ('--receptors', '[receptors]
        file'), or None.

    Raises
    ------
    FileNotFoundError
        ``"<what> '<path>' (<where>) not found."``
    SEDFormatError
        ``"<what> '<path>' (<where>) is a folder, not a regular file; ..."`` (or a FIFO, a device, ...).
    """
    from .io._files import check_regular

    for what, path, where in named:
        if path is None:
            continue
        path = os.fspath(path)
        try:
            check_regular(path, what)
        except (FileNotFoundError, SEDFormatError) as err:
            if not where:
                raise
            raise type(err)(str(err).replace(f"{what} {path!r}", f"{what} {path!r} ({where})", 1)) from None


def check_material_array(exports, material_array: str, *, format: str | None = None,
                         allow_outside_files: bool = False, where: str | None = None) -> bool:
    """Refuse an export whose header lists its cell arrays without ``material_array``, before it is read.

    Parameters
    ----------
    exports : str or list of str
        The export file(s); the first (the first step file of a ``.pvd`` / JSON file series) is checked.
    material_array : str
        The cell array of material ids the found sites (``tips``, ``bases``) need.
    format, allow_outside_files
        As for :func:`afferent.read_sed` (which reader; where a collection's step files may be).
    where : str, optional
        The option or key that named the array ('--material-array'), said in the message.

    Returns
    -------
    bool
        True when checked on the header; False when the format cannot list its arrays without
        reading them (checked right after the one read instead, before any work on it).

    Raises
    ------
    SEDFormatError
        ``"Export '<path>' must have a cell array '<name>' of material ids; found cell arrays ... instead."``
        with the nearest name.
    """
    from .io import format_of
    from .io._vtu import cell_array_names
    from .receptors._tips import missing_material_array

    path = os.fspath(exports if isinstance(exports, (str, os.PathLike)) else exports[0])
    if not os.path.isfile(path):
        return False  # the reader says so, in its words
    kind = format_of(path, format)
    if kind == "pvd":
        from .io._files import Scope
        from .io._meshio import pvd_entries

        files, _ = pvd_entries(path, Scope.of(path, allow_outside_files))
        path = files[0] if files else path
        kind = format_of(path) if files and path.lower().endswith(".vtu") else None
    if kind != "vtu" or not os.path.isfile(path):
        return False
    names = cell_array_names(path)
    if not names:  # the header does not tell (or lists none: the reader's own error comes first)
        return False
    if material_array not in names:
        message = missing_material_array(path, material_array, names)
        raise SEDFormatError(message if not where else message.replace(
            f"a cell array {material_array!r}", f"a cell array {material_array!r} ({where})", 1))
    return True
