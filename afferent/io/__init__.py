"""Stage 1: read the SED field of an FE export (CSV or mesh files) into an :class:`SEDField`.

::

    FE export --read_sed--> SEDField   (points m, SED J/m^3, times s, provenance)

One private module per kind of file returns a :class:`~afferent.io._raw.RawExport` in the
file's own names and units; :mod:`afferent.io._assemble` interprets it (SED column or
stress/strain tensors, units, validation) the same way for every format. The registry is the
explicit dict :data:`FORMATS`.

**A reader lists every file it opened** in ``RawExport.files``: the export file(s) first, then
each side file (VTU files of a ``.pvd``, HDF5 and ``.bin`` files of an XDMF, targets of HDF5
external links, ...) in the order first opened, recorded where it is really opened
(``_raw.files_read``, ``_raw.h5_files``), never found by parsing the export for names (only
``data_files`` lists them so, from an index file, to size a read before it starts). The
list becomes :attr:`~afferent.field.Provenance.files`; the sampled-SED cache
(:mod:`afferent.cache`) re-checks each listed file's hash before serving an entry and
``run.json`` records each with its SHA-256. A new reader must do the same (details in
``afferent.io._raw``); a file it opens but does not list is a file whose rewrite goes
unnoticed.

Size: just over 600 lines: the registry of readers and the entry points that share one list of
declarations (read_sed, iter_sed, sed_from_raw); each reader lives in its own module.
"""

from __future__ import annotations

from .._typing import Accept, PathLike
from typing import Any

import os
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from .._validation import check_option
from ..exceptions import AfferentWarning, SEDFormatError
from ..field import Provenance, SEDField
from ._assemble import NEGATIVE_SED_RTOL, ReadOptions, assemble
from ._describe import describe_raw
from ._files import Scope, check_regular, outside_note
from ._raw import RawExport

__all__ = ["read_sed", "iter_sed", "series_provenance", "read_raw", "describe_raw", "format_of", "FORMATS"]

#: Known formats: name -> file-name endings. '.gz' CSV files are read by the CSV reader, as are ANSYS MAPDL text
#: listings (``.lis``, a solver's ``.out``). A ParaView
#: JSON file series (``.vtu.series``, Kratos' ``.vtm.series``) is read like a ``.pvd``. ``.pvtu`` and
#: ``.vtm`` (and ``.vtk``/``.vtu`` files meshio refuses) need the ``vtk`` extra (see docs/fe-export.md).
FORMATS: dict[str, tuple[str, ...]] = {
    "csv": (".csv", ".txt", ".tsv", ".dat", ".rpt", ".log", ".lis", ".out", ".csv.gz", ".txt.gz", ".tsv.gz", ".dat.gz",
            ".rpt.gz", ".log.gz", ".lis.gz", ".out.gz"),
    "vtu": (".vtu",),
    "vtk": (".vtk",),
    "pvtu": (".pvtu",),
    "vtm": (".vtm",),
    "vtkhdf": (".vtkhdf",),
    "ensight": (".case",),
    "pvd": (".pvd", ".vtu.series", ".vtk.series", ".pvtu.series", ".vtm.series", ".vtkhdf.series"),
    "xdmf": (".xdmf", ".xmf"),
    "frd": (".frd", ".frd.gz"),
    "exodus": (".e", ".exo", ".ex2", ".g"),
    "rst": (".rst", ".rth"),
    "med": (".med", ".rmed"),
    "xplt": (".xplt",),
    "msh": (".msh",),
    "pos": (".pos",),
}


def format_of(path: str, fmt: str | None = None) -> str:
    """The reader (a key of :data:`FORMATS`) that reads ``path``: ``fmt`` if given (checked), else the one
    its file-name ending selects.

    Parameters
    ----------
    path : str
        An FE export file.
    fmt : str, optional
        A format name from :data:`FORMATS`, overriding the ending.

    Returns
    -------
    str

    Raises
    ------
    ValueError
        ``fmt`` is not a known format.
    SEDFormatError
        No known ending matches ``path``.
    """
    if fmt is not None:
        return check_option("format", fmt, tuple(FORMATS))
    lower = path.lower()
    for name, endings in FORMATS.items():
        if lower.endswith(endings):
            return name
    for endings, what in _UNREAD.items():
        if lower.endswith(endings):
            raise SEDFormatError(f"SED file {path!r} is {what}, which afferent does not read; {_UNREAD_WAY_OUT}")
    known = ", ".join(repr(e) for ends in FORMATS.values() for e in ends)
    raise SEDFormatError(
        f"Could not deduce the SED file format from {path!r}. Known extensions are {known}; "
        f"pass format='csv' (or one of {', '.join(map(repr, FORMATS))}) explicitly."
    )


_format_of = format_of

#: Native files of the tools of docs/fe-export.md's "NGSolve and MFEM" that afferent does not read,
#: and the export it reads instead.
_UNREAD = {(".mfem_root",): "an MFEM VisItDataCollection", (".gf", ".gf.gz"): "an MFEM/GLVis grid function",
           (".vol", ".vol.gz"): "a Netgen/NGSolve mesh"}
_UNREAD_WAY_OUT = ("write VTU: MFEM's ParaViewDataCollection (a .pvd), NGSolve's VTKOutput (docs/fe-export.md, "
                   "'NGSolve and MFEM').")


def _paths(path_or_paths) -> list[str]:
    if isinstance(path_or_paths, (str, os.PathLike)):
        paths = [os.fspath(path_or_paths)]
    elif isinstance(path_or_paths, Sequence):
        paths = [os.fspath(p) for p in path_or_paths]
    else:
        raise TypeError(f"'path_or_paths' must be a path or a list of paths; got {type(path_or_paths).__name__} instead.")
    if not paths:
        raise ValueError("'path_or_paths' must name at least one file; got an empty list instead.")
    for p in paths:
        if not os.path.exists(p):
            raise FileNotFoundError(f"SED file {p!r} not found.")
        if os.path.isdir(p):
            raise SEDFormatError(f"SED file {p!r} is a directory; pass the export file(s) inside it.")
        check_regular(p)  # a FIFO or a device: refused before anything opens it (it would block, or never end)
    return paths


def data_files(path_or_paths, *, format: str | None = None) -> tuple[str, ...]:
    """The files a read of the export will open, listed from its index files alone (no data read), each once.

    A ``.pvd`` or JSON file series: itself and its entries (:func:`afferent.io._meshio.pvd_entries`);
    a ``.pvtu``: its pieces; a ``.vtm``: its blocks (an entry of either kind with its own files);
    an XDMF file: its HDF5 and binary heavy-data files (:func:`afferent.io._xdmf.heavy_files`; not
    the targets of HDF5 external links); any other export: its files. For sizing a read before it
    starts (``afferent._figure_process``): the record of what was read is the files each reader
    lists as it opens them (:attr:`RawExport.files`), not this.

    Raises
    ------
    FileNotFoundError, SEDFormatError
        A file named is missing, or an index file cannot be parsed (as its reader says).
    """
    from . import _meshio
    from ._raw import files_read
    from ._vtk import _member_files
    from ._xdmf import heavy_files

    def members(path: str) -> tuple[str, ...]:  # a .pvtu's pieces, a .vtm's blocks, else the file
        return _member_files(path) if os.path.isfile(path) else (path,)

    out = []
    for p in _paths(path_or_paths):
        kind = _format_of(p, format)
        if kind == "pvd":
            out += [p, *(f for entry in _meshio.pvd_entries(p)[0] for f in members(entry))]
        elif kind in ("pvtu", "vtm"):
            out += members(p)
        elif kind == "xdmf":
            out += [p, *heavy_files(p)]
        else:
            out.append(p)
    return files_read(out)


def read_raw(path_or_paths: PathLike | Sequence[PathLike], *, format: str | None = None, progress: bool = False, allow_outside_files: bool = False,
             **csv_kwargs: Any) -> RawExport:
    """Read an export into its raw, uninterpreted form (the file's names and units).

    Used by ``afferent info``; most users want :func:`read_sed`. Several paths are one time
    step each, in the order given. ``allow_outside_files``: see :func:`read_sed`.
    """
    paths = _paths(path_or_paths)
    raw = _read_raw(paths, format, progress, allow_outside_files, csv_kwargs)
    if not allow_outside_files:
        return raw
    from dataclasses import replace

    return replace(raw, notes=raw.notes + outside_note(raw.files, paths, Scope.of))


def _read_raw(paths: list[str], format: str | None, progress: bool, allow: bool, csv_kwargs: dict) -> RawExport:
    """:func:`read_raw` of checked paths; every file an export points to is resolved in the scope of the
    export named (:class:`afferent.io._files.Scope`)."""
    from . import _meshio

    scope = Scope.of(paths[0], allow)
    formats = {_format_of(p, format) for p in paths}
    if len(formats) > 1:
        raise SEDFormatError(f"A series must be of one format; got {', '.join(sorted(formats))} for {paths!r}.")
    fmt = formats.pop()
    if fmt == "csv":
        from ._csv import read_csv

        return read_csv(paths if len(paths) > 1 else paths[0], progress=progress, **csv_kwargs)
    if len(paths) > 1:
        if fmt in ("pvd", "xdmf", "frd", "exodus", "rst", "med", "xplt", "msh", "pos", "vtkhdf", "ensight"):
            raise SEDFormatError(f"Pass one .{fmt} file, not a list: it lists its own time steps ({paths!r}).")
        return _meshio.read_vtu_series(paths, progress=progress, allow=allow)
    if fmt == "pvd":
        return _meshio.read_pvd(paths[0], progress=progress, scope=scope)
    if fmt == "xdmf":
        return _meshio.read_xdmf(paths[0], progress=progress, scope=scope)
    if fmt == "rst":
        from ._ansys import read_rst

        return read_rst(paths[0], progress=progress)
    if fmt == "ensight":
        from ._ensight import read_ensight

        return read_ensight(paths[0], progress=progress, scope=scope)
    if fmt == "vtkhdf":
        from ._vtkhdf import read_vtkhdf

        return read_vtkhdf(paths[0], progress=progress, scope=scope)
    if fmt == "exodus":
        from ._exodus import read_exodus

        return read_exodus(paths[0], progress=progress, scope=scope)
    if fmt == "frd":
        from ._frd import read_frd

        return read_frd(paths[0], progress=progress)
    if fmt == "med":
        from ._med import read_med

        return read_med(paths[0], progress=progress, scope=scope)
    if fmt == "xplt":
        from ._xplt import read_xplt

        return read_xplt(paths[0], progress=progress)
    if fmt in ("msh", "pos"):
        from ._gmsh import read_gmsh

        return read_gmsh(paths[0], progress=progress)
    return _meshio.read_mesh_file(paths[0], scope=scope, fmt=fmt)


def read_sed(
    path_or_paths: PathLike | Sequence[PathLike],
    *,
    length_unit: str | None = None,
    sed_unit: str | None = None,
    stress_unit: str | None = None,
    sed_from: str = "field",
    poisson: float | None = None,
    preset: str | None = None,
    shear: str | None = None,
    location: str | None = None,
    sed_column: str | Sequence[str] | None = None,
    stress_columns: str | Sequence[str] | None = None,
    strain_columns: str | Sequence[str] | None = None,
    coord_columns: Sequence[str] | None = None,
    times: Sequence[float] | None = None,
    time_unit: str | None = None,
    coordinates: str | os.PathLike | None = None,
    on_nan: str = "raise",
    negative_tolerance: float = NEGATIVE_SED_RTOL,
    allow_outside_files: bool = False,
    accept: Accept=None,
    elastic: Sequence[float] | None = None, modulus_unit: str | None = None,
    materials: str | os.PathLike | None = None, material_array: str | None = None,
    format: str | None = None,
    progress: bool = False,
) -> SEDField:
    """Read the strain-energy density of an FE export, in SI units.

    Parameters
    ----------
    path_or_paths : str, path-like or list of them
        One export (``.vtu``, ``.vtk``, ``.pvtu``, ``.vtm``, ``.pvd``, a JSON ``.vtu.series``/``.vtm.series``,
        ``.xdmf``, ``.csv``/``.txt``/``.rpt``, optionally ``.gz``, ANSYS MAPDL listings ``.lis``/``.out``, ``.frd``,
        Exodus, ``.rst``, MED ``.med``/``.rmed``, FEBio ``.xplt``, Gmsh ``.msh``/``.pos``), or several files of one format, one per time step,
        in time order (MAPDL listings of different items, ``S`` in one and ``EPEL`` in another: side by side).
        ``.pvtu`` and ``.vtm`` files, and ``.vtk``/``.vtu`` files meshio refuses, are read through VTK
        (``pip install 'afferent-skin[vtk]'``); a ``.pvtu``'s pieces are joined into one mesh, the nodes
        they share with the same values merged.
    length_unit : {'m', 'mm', 'um', 'cm'}, optional
        Unit of the coordinates. Required unless the file states it (COMSOL ``% Length unit``,
        ``X Location (mm)``); if both are given they must agree. Never guessed.
    sed_unit : {'Pa', 'kPa', 'MPa', 'J/m^3', 'mJ/mm^3', ...}, optional
        Unit of the SED array (``sed_from='field'``). Required unless the column header states it.
        An mm/N/s model exports SED in MPa (= mJ/mm^3).
    stress_unit : str, optional
        Unit of the stress components when SED is computed from tensors (strain is dimensionless).
    sed_from : {'field', 'exact', 'equivalent', 'stress'}, default='field'
        ``'field'`` reads an SED array; ``'exact'`` computes 1/2 sigma:eps from stress and strain;
        ``'equivalent'`` computes the study's 1/2 sigma_e eps_e (needs ``poisson``); ``'stress'`` the linear-elastic
        SED of the stress alone (docs/fe-export.md, "SED from stress alone").
    poisson : float, optional
        Poisson's ratio for ``sed_from='equivalent'`` (the study's skin: 0.48).
    preset : str, optional
        The FE tool whose component order and shear convention the tensors follow, one of
        :data:`afferent.strain_energy.PRESETS` (``'abaqus'``, ``'ansys'``, ``'comsol'``, ``'febio'``,
        ``'calculix-frd'``, ``'calculix-dat'``, ``'sfepy'``, ...). Needed with ``sed_from='exact'|'equivalent'``
        unless ``shear`` is given.
    shear : {'tensor', 'engineering'}, optional
        Overrides the preset's shear-strain convention.
    location : {'point', 'cell'}, optional
        Take SED (or tensors) from point data or cell data when a file has both; default point
        data (the choice is recorded in the provenance).
    sed_column, stress_columns, strain_columns, coord_columns : optional
        Explicit names for anything not recognised. ``sed_column`` may list one column per time
        step, and confirms that an array named like an energy (Kratos' ``STRAIN_ENERGY``) is a
        density where the file has no tensors to decide it from the values; ``stress_columns``/``strain_columns`` take a tensor array name or 6 column names in
        the order xx yy zz xy yz xz.
    times : sequence of float, optional
        Step times, overriding what the file states (unit ``time_unit``, default s). A series
        whose files state no time is numbered 0, 1, ... with the time unit ``'step'`` in the
        provenance (not seconds).
    time_unit : {'s', 'ms', 'us'}, optional
        Unit of the times stated in the file or passed as ``times``.
    coordinates : str or path-like, optional
        A CSV node (or element-centroid) table ``id, x, y, z`` to join on the export's node or
        element label column, for tables that carry no coordinates (Abaqus reports, FEBio
        logfiles, CalculiX .dat, ANSYS PRNSOL listings); an ANSYS ``NLIST`` listing or the run's
        CalculiX ``.frd`` serve too. Its length unit is ``length_unit`` or the one it states.
    on_nan : {'raise', 'drop'}, default='raise'
        NaN in a point table is an error; ``'drop'`` leaves those rows out (COMSOL writes NaN
        where an expression is not evaluated) and records how many in the provenance.
    negative_tolerance : float, default=0.25
        Negative SED is accepted as the artefact FE tools write where they extrapolate
        integration-point SED to the nodes when the most negative value is at most this
        fraction of the field's largest SED and the negatives sum to at most this fraction of
        the positive values (real CalculiX nodal ENER: down to -0.02 x the largest for linear
        hexahedra, -0.16 x for quadratic tetrahedra, near a punch edge). Accepted negatives are
        set to 0, counted in ``provenance.negative_sed`` and reported with an
        :class:`~afferent.exceptions.AfferentWarning`; anything more negative is refused (a
        wrong column, sign or shear convention).
    allow_outside_files : bool, default=False
        The files an export points to (a ``.pvd``'s or ``.series``' steps, a ``.pvtu``'s pieces, a ``.vtm``'s
        blocks, an XDMF file's heavy data, HDF5 external links, external storage and virtual datasets)
        are read only from inside the export's own folder, by default: a name that leads outside it
        (absolute, ``..``, a symbolic link) is refused, naming the file. True reads them wherever they are
        (each is then named in the provenance notes). Either way only regular files are read: a FIFO,
        a device or a folder is refused before it is opened (``afferent.io._files``).
    accept : str or sequence of str, optional
        Checks whose unusual case is confirmed (their names: ``afferent._validation.ACCEPTS``): ``'modulus'``
        lets through an SED (or stress) unit under which the export's elastic stiffness 2 SED /
        eps:eps lies outside soft tissue's 1 kPa..10 MPa while another unit would put it inside (a
        material that really is that stiff or soft); ``'sed-column'`` lets through an SED array named
        like a stress measure, equal to one of the stress tensor's, or unlike 1/2 sigma:eps of the
        file's tensors. Each is otherwise refused (docs/fe-export.md, "Units from physics").
    elastic, modulus_unit, materials, material_array : optional
        ``sed_from='stress'``: ``elastic=(E, nu)`` for a homogeneous model, or a CSV table ``materials`` (columns
        ``material``: the integer id in the export's material array ``material_array``, default the one found by
        its name; ``E``; ``nu``). E in ``modulus_unit`` or the unit the table's header states (``E (MPa)``).
    format : {'csv', 'vtu', 'vtk', 'pvtu', 'vtm', 'pvd', 'xdmf', 'frd', 'exodus', 'rst', 'med', 'xplt', 'msh', 'pos'}, optional
        Overrides the format deduced from the file name.
    progress : bool, default=False
        Show a progress bar while reading a series.

    Returns
    -------
    SEDField
        Points in m, SED of shape (n_times, n_values) in J/m^3, times in s, cells when the
        export has a volume mesh, and the provenance (files, columns, units, formula).

    Raises
    ------
    FileNotFoundError
        A file does not exist.
    SEDFormatError
        Unknown format, unreadable or corrupt file, missing columns, NaN/inf or negative SED,
        SED more negative than ``negative_tolerance`` allows, non-increasing times, a series
        whose steps do not match, a file the export points to outside its folder (unless
        ``allow_outside_files``), a file that is not a regular file.
    UnitError
        A unit neither stated nor declared, unknown, or contradicting the file; a unit under which the
        export's stiffness is far from soft tissue's where another unit is not (unless ``accept='modulus'``).

    See Also
    --------
    afferent.sample_sed : SED at receptor sites (stage 2).

    Examples
    --------
    >>> field = read_sed("sample_sed/block4/indent_0p88mm.vtu", length_unit="mm", sed_unit="MPa")  # doctest: +SKIP
    >>> field.sed.max()  # J/m^3  # doctest: +SKIP
    """
    opts = _read_options(
        length_unit=length_unit, sed_unit=sed_unit, stress_unit=stress_unit, time_unit=time_unit,
        sed_from=sed_from, poisson=poisson, preset=preset, shear=shear, location=location,
        sed_column=sed_column if sed_column is None or isinstance(sed_column, str) else tuple(sed_column),
        stress_columns=stress_columns if stress_columns is None or isinstance(stress_columns, str) else tuple(stress_columns),
        strain_columns=strain_columns if strain_columns is None or isinstance(strain_columns, str) else tuple(strain_columns),
        coord_columns=None if coord_columns is None else tuple(coord_columns),
        times=None if times is None else tuple(float(t) for t in times),
        coordinates=None if coordinates is None else os.fspath(coordinates), on_nan=on_nan,
        negative_tolerance=negative_tolerance, allow_outside_files=allow_outside_files, accept=accept,
        elastic=elastic, modulus_unit=modulus_unit, materials=materials, material_array=material_array,
    )
    raw = read_raw(path_or_paths, format=format, progress=progress, allow_outside_files=opts.allow_outside_files)
    return assemble(raw, opts)


def _read_options(*, sed_column, stress_columns, strain_columns, coord_columns, times, coordinates, accept=None,
                  elastic=None, materials=None, **kw) -> ReadOptions:
    """The user's declarations as a :class:`ReadOptions` (sequences as tuples, ``accept`` checked)."""
    from .._validation import check_accept

    def seq(v):
        return v if v is None or isinstance(v, str) else tuple(v)

    return ReadOptions(
        sed_column=seq(sed_column), stress_columns=seq(stress_columns), strain_columns=seq(strain_columns),
        coord_columns=None if coord_columns is None else tuple(coord_columns),
        times=None if times is None else tuple(float(t) for t in times),
        coordinates=None if coordinates is None else os.fspath(coordinates), accept=check_accept(accept),
        elastic=elastic if elastic is None or isinstance(elastic, str) else tuple(elastic),
        materials=None if materials is None else os.fspath(materials), **kw,
    )


def _declared(declarations: dict, caller: str) -> ReadOptions:
    """The :class:`ReadOptions` of :func:`read_sed`'s keyword ``declarations`` (its defaults for the rest): one
    list of declarations, so that the entry points cannot drift apart."""
    import inspect

    defaults = {name: p.default for name, p in inspect.signature(read_sed).parameters.items()
                if p.kind is p.KEYWORD_ONLY and name not in ("format", "progress")}
    unknown = sorted(set(declarations) - set(defaults))
    if unknown:
        raise TypeError(f"{caller}() got an unexpected keyword argument {unknown[0]!r}.")
    return _read_options(**{**defaults, **declarations})


def sed_from_raw(raw: RawExport, **declarations) -> SEDField:
    """:func:`read_sed` of an export already read by :func:`read_raw` (with the same ``format`` and
    ``allow_outside_files``): the declarations of :func:`read_sed`, no file read again (``afferent info``
    describes the raw export, then samples its field)."""
    return assemble(raw, _declared(declarations, "sed_from_raw"))


def _raw_steps(path_or_paths, fmt: str | None, progress: bool, allow: bool = False):
    """(number of steps, iterator of one-step RawExports) for the formats read step by step, else None
    (``allow``: files outside the export's folder allowed, :func:`read_sed`'s ``allow_outside_files``)."""
    paths = _paths(path_or_paths)
    steps = _step_reader(paths, fmt, progress, Scope.of(paths[0], allow))
    if steps is None or not allow:
        return steps
    from dataclasses import replace

    n, raws = steps
    return n, (replace(r, notes=r.notes + outside_note(r.files, paths, Scope.of)) for r in raws)


def _step_reader(paths: list[str], fmt: str | None, progress: bool, scope: Scope):
    """:func:`_raw_steps` of checked paths."""
    from . import _meshio

    formats = {_format_of(p, fmt) for p in paths}
    kind = formats.pop() if len(formats) == 1 else None
    if kind in ("vtu", "vtk", "pvtu", "vtm") and len(paths) > 1:
        return len(paths), _meshio.iter_vtu_series(paths, progress=progress, allow=scope.allow_outside)
    if kind == "pvd" and len(paths) == 1:
        files, _ = _meshio.pvd_entries(paths[0], scope)
        return len(files), _meshio.iter_pvd(paths[0], progress=progress, scope=scope)
    if kind == "xdmf" and len(paths) == 1 and os.path.getsize(paths[0]) > 0:
        from ._xdmf import series_steps

        steps = series_steps(paths[0], progress=progress, scope=scope)
        if steps is not None:
            return steps
    if kind == "xplt" and len(paths) == 1:
        from ._xplt import iter_xplt, xplt_step_count

        return xplt_step_count(paths[0]), iter_xplt(paths[0], progress=progress)
    return None


def iter_sed(path_or_paths: PathLike | Sequence[PathLike], *, format: str | None = None, progress: bool = False, on_first_raw: Callable[[RawExport], None] | None=None, **declarations: Any) -> Iterator[SEDField]:
    """Read the SED of an export one time step at a time, in SI units (memory: one step).

    Takes the same arguments as :func:`read_sed` and yields :class:`SEDField` objects in time
    order whose steps, concatenated, are what :func:`read_sed` returns for a series of
    steps. A series of VTU files, a ParaView ``.pvd``, an XDMF time series (FEniCS/DOLFINx,
    meshio) and an FEBio ``.xplt`` are read one step at a time: the mesh once, then each step's
    arrays, and every field shares the first step's cells. Other formats (CSV tables, ``.frd``, Exodus, ``.rst``,
    MED) are read whole and yielded as one field.

    Each step is interpreted and checked on its own (units, the SED or tensor arrays, NaN,
    negative nodal SED against ``negative_tolerance`` relative to that step's largest value,
    plausibility); a warning that repeats from step to step (same text up to its numbers) is
    shown once. Step times must increase from one field to the next.

    Used by :func:`afferent.sampling.sample_steps` to sample long series of large meshes;
    ``benchmarks/bench_large_series.py`` measures time and peak memory against
    :func:`read_sed`.

    ``on_first_raw``: a callable given the first :class:`~afferent.io._raw.RawExport` the readers
    return (the first step, or the whole export for formats read at once), in the file's own names
    and units, before it is interpreted; the receptor sites found on the export's materials
    (``afferent.receptors._tips.sites_from_raw``) take it from there, so that the export is read once.

    Yields
    ------
    SEDField
        One time step (or the whole export for formats read at once).

    Raises
    ------
    Same as :func:`read_sed`; a step's error names its file (or its time).
    """
    import re
    import warnings
    from dataclasses import replace

    opts = _declared(declarations, "iter_sed")
    steps = None if opts.coordinates is not None else _raw_steps(path_or_paths, format, progress, opts.allow_outside_files)
    if steps is None:
        if on_first_raw is None:
            yield read_sed(path_or_paths, format=format, progress=progress, **declarations)
            return
        raw = read_raw(path_or_paths, format=format, progress=progress, allow_outside_files=opts.allow_outside_files)
        on_first_raw(raw)  # read_sed's two steps, the raw export shown between them
        yield assemble(raw, opts)
        return
    n_steps, raws = steps
    if opts.times is not None and len(opts.times) != n_steps:
        raise ValueError(f"'times' must have one entry per time step ({n_steps}); got {len(opts.times)} instead.")
    seen: set[str] = set()
    memo: dict = {}  # what assemble learns from the series' mesh at one step, for the next (the mesh is read once)
    previous = None
    negatives: list = []
    zero = []  # the all-zero warning of each step that gave it: shown only if every step did (a loading series
    # starts from the undeformed state)
    for k, raw in enumerate(raws):
        if k == 0 and on_first_raw is not None:
            on_first_raw(raw)
        numbered = raw.times is None and opts.times is None  # numbered 0, 1, ... as read_sed does
        if numbered:
            raw = replace(raw, times=np.array([float(k)]), notes=raw.notes + (
                "The export states no step times; steps are numbered 0, 1, ... (step numbers, not seconds; pass times= "
                "to set them).",))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            field = assemble(raw, opts if opts.times is None else replace(opts, times=opts.times[k:k + 1]), memo)
        if numbered:
            units = dict(field.provenance.units, time="step", time_source="none in the file: steps numbered 0, 1, ...")
            field = replace(field, provenance=replace(field.provenance, units=units))
        if field.provenance.negative_sed:
            negatives.append((k, field.provenance.negative_sed))
        for w in caught:
            key = re.sub(r"[-+]?\d[\d.eE+-]*", "#", str(w.message))
            if field.provenance.negative_sed and _NEGATIVE_WARNING in str(w.message):
                continue  # one warning for the whole series, with its totals, after the last step
            if _ALL_ZERO_WARNING in str(w.message):
                zero.append(w)
                continue
            if key not in seen:
                seen.add(key)
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        t = float(field.times[0])
        if previous is not None and not t > previous:
            raise SEDFormatError(f"SED file {raw.files[0]!r}: time steps must be strictly increasing; got {previous!r} "
                                 f"followed by {t!r} s (steps {k - 1} and {k}) instead.")
        previous = t
        yield field
    if negatives:
        warnings.warn(_series_negative_message(path_or_paths, negatives, n_steps), AfferentWarning, stacklevel=2)
    if zero and len(zero) == n_steps:
        warnings.warn_explicit(zero[0].message, zero[0].category, zero[0].filename, zero[0].lineno)


#: the words of the reader's negative-SED warning (afferent.io._assemble._negatives)
_NEGATIVE_WARNING = "SED value(s) are negative"
#: the words of the all-zero warning (afferent._plausibility.sed_warning)
_ALL_ZERO_WARNING = "every SED value is 0 J/m^3"


def _series_negative_message(path_or_paths, negatives: list, n_steps: int) -> str:
    """The negative-SED warning of a whole series: in how many steps, how many values in total, the worst."""
    paths = [path_or_paths] if isinstance(path_or_paths, (str, os.PathLike)) else list(path_or_paths)
    name = f"{os.fspath(paths[0])!r}" + (f" and {len(paths) - 1} more file(s)" if len(paths) > 1 else "")
    steps = [k for k, _ in negatives]
    listed = ", ".join(map(str, steps[:6])) + (", ..." if len(steps) > 6 else "")
    count, n_values = sum(n["count"] for _, n in negatives), sum(n["n_values"] for _, n in negatives)
    worst, share = min(n["min_relative"] for _, n in negatives), max(n["negative_share"] for _, n in negatives)
    return (f"SED series {name}: negative SED values in {len(steps)} of {n_steps} step(s) (step(s) {listed}; counted "
            f"from 0): {count} of {n_values} values in total, down to {worst:.2g} x the largest SED of their step, "
            f"summing to at most {share:.2g} x the positive values; tolerance {negatives[0][1]['tolerance']:g}. As FE "
            "tools write where they extrapolate integration-point values to the nodes near steep gradients; set to "
            "0. SED near those nodes is unreliable (a finer mesh or integration-point output tells how much).")


def series_provenance(provenances: Sequence[Provenance]) -> Provenance:
    """One :class:`~afferent.field.Provenance` for the steps :func:`iter_sed` yielded.

    Files in order without repeats, the first step's columns, units and factors (every step is
    read with the same declarations), notes without repeats, each check from the first step that
    judged loaded data (``series_step``) with the steps that were not checkable
    (``steps_not_checkable``) or failed it (``steps_failed``), and the negative nodal SED summed over the steps: ``count`` and ``n_values``
    added, ``min_pa`` and ``min_relative`` the most negative, ``negative_share`` the largest,
    ``steps_with_negatives`` and ``first_step`` (index into the series).
    """
    from dataclasses import replace

    provs = list(provenances)
    if not provs:
        raise ValueError("'provenances' must hold at least one Provenance; got none.")
    files = tuple(dict.fromkeys(f for p in provs for f in p.files))
    notes = tuple(dict.fromkeys(n for p in provs for n in p.notes))
    neg = [(k, p.negative_sed) for k, p in enumerate(provs) if p.negative_sed]
    negative = None
    if neg:
        negative = dict(neg[0][1])
        negative.update(
            count=sum(n["count"] for _, n in neg), n_values=sum(n["n_values"] for _, n in neg),
            min_pa=min(n["min_pa"] for _, n in neg), min_relative=min(n["min_relative"] for _, n in neg),
            negative_share=max(n["negative_share"] for _, n in neg), steps_with_negatives=len(neg),
            first_step=neg[0][0],
        )
    return replace(provs[0], files=files, notes=notes, negative_sed=negative, checks=_series_checks(provs))


def _series_checks(provs) -> dict:
    """Each cross-check of a streamed series (each step checked alone) as one record.

    The check of the first step that judged loaded data (``max_strain`` > 0: not the zero state),
    else of the first step that has it; plus ``series_step`` (its index), ``steps_not_checkable``
    (the steps whose strains exceed the small-strain bound: see docs/fe-export.md, "The
    cross-checks") and ``steps_failed`` (the steps whose verdict - ``consistent``, ``agree`` or
    ``density`` - is false), each a list of step indices, when there are any.
    """
    out: dict = {}
    for name in dict.fromkeys(k for p in provs for k in p.checks):
        per = [(k, p.checks[name]) for k, p in enumerate(provs) if name in p.checks]
        judged = [(k, c) for k, c in per if c.get("checkable", True) and c.get("max_strain", 1.0) > 0]
        k, chosen = (judged or per)[0]
        record = dict(chosen, series_step=k)
        skipped = [k for k, c in per if not c.get("checkable", True)]
        failed = [k for k, c in per if c.get("checkable", True)
                  and False in (c.get("consistent"), c.get("agree"), c.get("density"))]
        record.update({"steps_not_checkable": skipped} if skipped else {}, **({"steps_failed": failed} if failed else {}))
        out[name] = record
    return out
