"""Text-table FE exports (CSV, TXT, report-like text, FEBio logfiles, CalculiX .dat) -> RawExport.

This reader only turns bytes into numbers. It keeps the export's own column names and
units; which column is the SED, which are coordinates or tensor components, unit
conversion and physical checks are done by :mod:`afferent.io._assemble`.

Layouts handled (see :ref:`fe-checklist` and each tool's section of the FE-export page):

* delimiters: comma, semicolon, tab or runs of whitespace, sniffed on the first data rows;
* comment lines starting with ``#``, ``%`` (COMSOL), ``**`` (Abaqus) or ``!``, blank lines,
  BOM, CRLF, gzip compression (detected by magic bytes, not by the file name);
* free-text preambles above the header row, a units row below it, and Abaqus
  ``.rpt`` reports (a two-line column title over a dashed rule, wrapped tables,
  ``Minimum``/``Maximum``/``At Node``/``Int Pt``/``Total`` footers, several blocks with the same
  columns: the parts of one frame joined, each ``Frame:`` one time step);
* COMSOL spreadsheets: ``% Key,value`` lines, the last ``%`` line holding the column names,
  ``% Length unit,mm``, units in parentheses, per-step columns ``solid.Ws (J/m^3) @ t=0.02``;
* a time column (rows grouped by time value), several files (one per time step);
* FEBio logfiles (``*Step``/``*Time``/``*Data`` records, one record per time step);
* CalculiX ``.dat`` blocks (``stresses (elem, integ.pnt.,sxx,...) for set X and time t``);
* ANSYS MAPDL listings (``PRINT S    NODAL SOLUTION PER NODE``, ``LIST ALL SELECTED NODES``,
  ``PRINT ELEMENT TABLE ITEMS PER ELEMENT``, or a ``***** POST1 ... LISTING *****`` banner): pages,
  summaries, load steps; several listing files of different items joined side by side on ``NODE``;
* COMSOL Sectionwise exports (``% Coordinates``, ``% Elements (tetrahedra)`` with 1-based point numbers,
  ``% Data (solid.Ws (J/m^3) @ t=0.1)`` sections): the points and cells of the mesh, one array per expression.
  COMSOL's Grid and vertical point-evaluation layouts are refused by name.

Parsing of the rows themselves is done by :func:`pandas.read_csv`; this module only finds
where the header and the data rows are, counts fields, and checks what pandas returns.

The layers: ``_csv_lines.py`` (bytes -> lines, line classes, delimiters, header names),
``_csv_table.py`` (table files: header, units row, data rows -> columns), ``_csv_blocks.py``
(FEBio logfiles, CalculiX ``.dat`` blocks, MAPDL listings, COMSOL sectionwise exports -> columns), and here:
columns -> arrays with a time axis, several files merged, :func:`read_csv`.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .._validation import check_option, suggest
from ..exceptions import SEDFormatError
from ..units import TIME_UNITS, parse_unit
from ._columns import TIME_ALIASES, canonical, split_unit
from ._csv_blocks import (_is_sectionwise, _parse_ccx, _parse_febio, _parse_mapdl, _parse_sectionwise,
                          _refuse_comsol_layout, _same_mesh, _same_parts)
from ._csv_lines import (
    _CCX_START,
    _MAPDL_START,
    _COORD_NAMES,
    _FEBIO_START,
    _SEP_ALIASES,
    SEPARATORS,
    _join_names,
    _load_text,
    _plural,
    step_suffix,
    parameter_steps,
    sweep_parameter,
)
from ._csv_table import _Columns, _parse_table
from ._raw import RawArray, RawExport

__all__ = ["read_csv"]

# --------------------------------------------------------------------------------------
# Columns -> arrays with a time axis
# --------------------------------------------------------------------------------------


@dataclass
class _FileArrays:
    arrays: dict[str, tuple[str | None, np.ndarray, str]]  # name -> (unit, (n_times, n_rows), header)
    times: np.ndarray | None
    time_unit: str | None
    length_unit: str | None
    notes: list[str]
    preset: str | None = None
    join_key: str | None = None  # the id column several files are joined on side by side (MAPDL listings: NODE)
    points: np.ndarray | None = None  # (n_rows, 3) in the file's length unit, with cells (COMSOL sectionwise)
    cells: object = None  # afferent.field.Cells


def _unit_of(raw: str | None, name: str, notes: list[str]) -> str | None:
    """Canonical unit if :func:`afferent.units.parse_unit` knows it, else the raw text."""
    if raw is None or not raw.strip():
        return None
    unit = parse_unit(raw)
    if unit is None:
        notes.append(f"unit {raw.strip()!r} of column {name!r} is not a unit afferent knows; kept as written")
        return raw.strip()
    return unit


def _to_arrays(path: str, cols: _Columns, time_column: str | None, *, n_records: int = 1,
               record_times: np.ndarray | None = None) -> _FileArrays:
    notes = cols.notes
    entries = []  # (header, name, unit, t, values)
    seen: dict[tuple[str, float | None], str] = {}
    swept: dict[str, list[str]] = {}  # '@ name=value' suffix name -> its column titles
    for header, vals in zip(cols.headers, cols.values):
        base, pairs = step_suffix(header)
        for var, _, _ in pairs:
            swept.setdefault(var, []).append(header)
        t = pairs[0][1] if pairs else None
        name, raw_unit = split_unit(base if pairs else header)
        unit = _unit_of(raw_unit, name, notes)
        key = (name, t)
        if key in seen:
            raise SEDFormatError(
                f"Column names of SED file {path!r} must be unique once units are removed; got "
                f"{seen[key]!r} and {header!r} (both {name!r}) instead."
            )
        seen[key] = header
        entries.append((header, name, unit, t, vals))

    param = sweep_parameter(path, swept, {v for v in swept if canonical(v) in TIME_ALIASES})
    suffixed = [e for e in entries if e[3] is not None]
    tcol = _find_time_column(path, entries, time_column, notes, auto=record_times is None and n_records == 1)
    if tcol is not None and suffixed:
        raise SEDFormatError(
            f"SED file {path!r} must give its times either in a time column or in '@ t=' column "
            f"suffixes; got both ({tcol[0]!r} and {suffixed[0][0]!r}) instead."
        )
    if record_times is not None and (tcol is not None or suffixed):
        raise SEDFormatError(
            f"SED file {path!r} must take its times from its record headers; got a time column "
            f"{(tcol or suffixed[0])[0]!r} as well instead."
        )

    arrays: dict[str, tuple[str | None, np.ndarray, str]] = {}
    times = record_times
    time_unit = None
    if suffixed:
        times, arrays = _stack_suffixed(path, entries, notes)
        if canonical(param) not in TIME_ALIASES:
            times = parameter_steps(swept[param], times, notes)
    elif tcol is not None:
        times, time_unit, arrays = _group_by_time(path, cols, entries, tcol, notes)
    else:
        n_rows = len(cols.row_lines) // n_records
        for header, name, unit, _, vals in entries:
            arrays[name] = (unit, vals.reshape(n_records, n_rows), header)
    length_unit = _length_unit(path, arrays, cols.meta)
    return _FileArrays(arrays, times, time_unit, length_unit, notes)


def _find_time_column(path, entries, time_column, notes, *, auto: bool):
    """The entry of the time column: ``time_column`` if given, else one named like a time."""
    plain = [e for e in entries if e[3] is None]
    if time_column is not None:
        want = canonical(time_column)
        for e in plain:
            if time_column in (e[0], e[1]) or canonical(e[1]) == want:
                return e
        raise SEDFormatError(
            f"SED file {path!r} has no column {time_column!r}. Found columns "
            f"{_join_names(e[0] for e in entries)}.{suggest(time_column, [e[1] for e in entries])}"
        )
    if not auto:
        return None
    found = []
    for e in plain:
        if canonical(e[1]) not in TIME_ALIASES:
            continue
        if e[2] is not None and e[2] not in TIME_UNITS:  # 'T (K)' is a temperature
            notes.append(f"column {e[0]!r} is named like a time but its unit {e[2]!r} is not a time unit; "
                         f"read as data")
            continue
        found.append(e)
    if len(found) > 1:
        raise SEDFormatError(
            f"SED file {path!r} must have at most one time column; got {_join_names(e[0] for e in found)} "
            f"instead. Pass time_column={found[0][1]!r} to pick one."
        )
    return found[0] if found else None


def _stack_suffixed(path, entries, notes):
    groups: dict[str, list] = {}
    for e in entries:
        if e[3] is not None:
            groups.setdefault(e[1], []).append(e)
    plain = [e for e in entries if e[3] is None]
    for e in plain:
        if e[1] in groups:
            raise SEDFormatError(
                f"Column names of SED file {path!r} must be unique once units are removed; got "
                f"{e[0]!r} and {groups[e[1]][0][0]!r} (both {e[1]!r}) instead."
            )
    ref_name, ref = next(iter(groups.items()))
    ref_times = [e[3] for e in ref]
    for name, grp in groups.items():
        t = [e[3] for e in grp]
        if t != ref_times:
            raise SEDFormatError(
                f"Every '@ t=' column group of SED file {path!r} must cover the same times; got "
                f"{ref_name!r} at t = {ref_times} and {name!r} at t = {t} instead."
            )
        units = {e[2] for e in grp}
        if len(units) > 1:
            raise SEDFormatError(
                f"The '@ t=' columns of {name!r} in SED file {path!r} must share one unit; got "
                f"{_join_names(e[0] for e in grp)} instead."
            )
    n_t = len(ref_times)
    arrays = {}
    for e in entries:
        if e[3] is None:
            arrays[e[1]] = (e[2], np.repeat(e[4][None, :], n_t, axis=0), e[0])
        elif e[1] not in arrays:
            grp = groups[e[1]]
            arrays[e[1]] = (e[2], np.stack([g[4] for g in grp]), grp[0][0])
    notes.append(f"stacked '@ t=' columns into {_plural(n_t, 'time step')}")
    if plain:
        notes.append(
            f"columns without an '@ t=' suffix ({_join_names(e[1] for e in plain)}) are repeated for every step"
        )
    return np.asarray(ref_times, dtype=np.float64), arrays


def _group_by_time(path, cols: _Columns, entries, tcol, notes):
    header, tname, tunit, _, tvals = tcol
    nan = np.flatnonzero(np.isnan(tvals))
    if nan.size:
        raise SEDFormatError(
            f"Time column {header!r} of SED file {path!r} must hold a time on every row; got an empty "
            f"or NaN cell at line {cols.row_lines[nan[0]]} instead."
        )
    if tvals.size == 0:
        raise SEDFormatError(f"SED file {path!r} has a time column {header!r} but no data rows.")
    codes, uniques = pd.factorize(tvals, sort=False)
    counts = np.bincount(codes)
    if np.any(counts != counts[0]):
        pairs = [f"{_plural(c, 'row')} at {tname} = {t!r}" for t, c in zip(uniques.tolist(), counts.tolist())]
        if len(pairs) > 6:
            pairs = pairs[:6] + [f"... ({len(pairs) - 6} more times)"]
        raise SEDFormatError(
            f"Every time step of SED file {path!r} must have the same number of rows; got "
            f"{', '.join(pairs)} instead."
        )
    n_t, n_rows = len(uniques), int(counts[0])
    order = np.argsort(codes, kind="stable")
    arrays = {}
    for h, name, unit, t, vals in entries:
        if h == header:
            continue
        arrays[name] = (unit, vals[order].reshape(n_t, n_rows), h)
    notes.append(
        f"grouped rows by the time column {header!r} into {_plural(n_t, 'time step')} of {_plural(n_rows, 'row')}"
    )
    return np.asarray(uniques, dtype=np.float64), tunit, arrays


def _length_unit(path, arrays, meta) -> str | None:
    """Length unit from `% Length unit` and coordinate-named columns; they must agree."""
    units = {name: unit for name, (unit, _, _) in arrays.items() if canonical(name) in _COORD_NAMES and unit}
    if "length unit" in meta:
        value, line = meta["length unit"]
        stated = parse_unit(value) or value
        units = {f"% Length unit (line {line})": stated, **units}
    if len(set(units.values())) > 1:
        got = ", ".join(f"{k!r} in {u!r}" for k, u in units.items())
        raise SEDFormatError(f"Coordinate columns of SED file {path!r} must share one length unit; got {got} instead.")
    return next(iter(units.values()), None)


# --------------------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------------------


def _read_one(path: str, sep: str | None, time_column: str | None) -> _FileArrays:
    text, notes = _load_text(path)
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    head = text[:1_000_000]  # record formats announce themselves near the top
    if "*" in head and _FEBIO_START.search(head):
        cols, n_rec, times = _parse_febio(path, lines, sep, notes)
        return _to_arrays(path, cols, time_column, n_records=n_rec, record_times=times)
    if "for set" in head.lower() and _CCX_START.search(head):
        cols, n_rec, times = _parse_ccx(path, lines, sep, notes)
        out = _to_arrays(path, cols, time_column, n_records=n_rec, record_times=times)
        out.preset = "calculix-dat"  # *EL PRINT: sxx syy szz sxy sxz syz, tensor shear (CalculiX printout.f)
        return out
    if "%" in head:
        _refuse_comsol_layout(path, head)
        if _is_sectionwise(text, head):
            cols, points, cells = _parse_sectionwise(path, lines, notes)
            out = _to_arrays(path, cols, time_column)
            out.points, out.cells = points, cells
            return out
    if _is_mapdl(text, head):
        cols, n_rec, times = _parse_mapdl(path, lines, sep, notes)
        out = _to_arrays(path, cols, time_column, n_records=n_rec, record_times=times)
        out.preset = "ansys"  # S: SX SY SZ SXY SYZ SXZ, EPEL: engineering shear (docs/fe-export.md, ANSYS MAPDL)
        out.join_key = cols.headers[0]
        return out
    cols = _parse_table(path, lines, sep, notes)
    return _to_arrays(path, cols, time_column, n_records=cols.n_records, record_times=cols.record_times)


def _is_mapdl(text: str, head: str) -> bool:
    """An ANSYS MAPDL listing: a PRNSOL/PRETAB title, NLIST title or POST1 banner at a line start (searched
    beyond the first MB only when the words occur: a solver's .out file holds its listings after the log)."""
    if _MAPDL_START.search(head):
        return True
    return len(text) > len(head) and ("PRINT" in text or "LIST ALL" in text or "POST1" in text) and bool(
        _MAPDL_START.search(text))


def _normalise_paths(paths) -> list[str]:
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    if not isinstance(paths, Sequence) or isinstance(paths, bytes):
        raise TypeError(f"'paths' must be a file path or a list of file paths; got {type(paths).__name__} instead.")
    out = []
    for p in paths:
        if not isinstance(p, (str, os.PathLike)):
            raise TypeError(f"'paths' must be a file path or a list of file paths; got an item {p!r} instead.")
        out.append(os.fspath(p))
    if not out:
        raise ValueError("'paths' must be a file path or a non-empty list of file paths; got an empty list instead.")
    return out


def read_csv(paths, *, sep: str | None = None, time_column: str | None = None,
             progress: bool = False) -> RawExport:
    """Read text-table FE exports into a :class:`~afferent.io._raw.RawExport`.

    The reader turns bytes into numbers and nothing more: names and units stay as the file
    writes them, no column is chosen as the SED, no unit is converted (that is
    :mod:`afferent.io._assemble`'s job).

    Parameters
    ----------
    paths : str, path-like or list of them
        One file, or a list of files holding one time step each, in time order. Files may
        be gzip-compressed (detected from their first bytes, whatever their name).
    sep : {None, ',', ';', '\\t', 'whitespace'}, optional
        Column delimiter. None (default) sniffs it from the first non-comment lines: the
        delimiter under which most of them are rows of numbers wins (ties: tab, semicolon,
        comma, whitespace). ``' '`` and ``r'\\s+'`` mean ``'whitespace'`` (runs of spaces/tabs).
    time_column : str, optional
        Name of the column holding the time of each row, with or without its unit
        (``'Time'`` or ``'Time (s)'``). By default a column named like a time (``time``, ``t``,
        ``Step Time``, ...; ``afferent.io._columns.TIME_ALIASES``) is used when there is exactly
        one, unless its unit is not a time unit (``T (K)`` is a temperature).
    progress : bool, default False
        Show a tqdm progress bar over the files.

    Returns
    -------
    RawExport
        ``format='csv'``, ``points=None``, ``cells=None`` (a COMSOL Sectionwise export: its points, in the
        file's length unit, and its tetrahedra). Every numeric column becomes a
        ``RawArray(name, values, location='point', unit)``:

        - ``name``: the header without its unit (``'solid.Ws (J/m^3)'`` -> ``'solid.Ws'``);
        - ``values``: float64 array of shape (n_times, n_rows), in the file's units;
        - ``unit``: the unit in parentheses or brackets after the name, or in a units row
          below the header. It is the canonical spelling of :func:`afferent.units.parse_unit`
          when that function knows the unit (``'J/m3'`` -> ``'J/m^3'``); otherwise the text as
          written (``'furlong'``), with a note, so that the assembler can name it. None when
          the file gives no unit.

        Coordinate columns stay among ``arrays``. ``times`` (shape (n_times,), in the file's
        time unit) come from a time column, ``@ t=`` suffixes, FEBio ``*Time`` or CalculiX
        block titles, else None. ``length_unit`` comes from ``% Length unit`` and from the
        units of coordinate-named columns (``X Location (mm)``), which must agree;
        ``time_unit`` from the unit of the time column. ``notes`` say what the reader did
        (delimiter detected, lines skipped, footer rows dropped, gzip decompressed, columns
        dropped, blocks joined).

    Raises
    ------
    FileNotFoundError
        A file does not exist.
    SEDFormatError
        A file is empty or binary; it has no header row or no data rows; a row has the
        wrong number of values (the message gives the line); a cell is not a number (file,
        column, cell text and line); two columns share a name once units are removed; time
        steps or step files differ in rows, columns or units; coordinate units disagree;
        numbers use decimal commas.
    TypeError, ValueError
        ``paths``, ``sep`` or ``time_column`` is of the wrong type or value.

    Notes
    -----
    Layouts recognised (:ref:`fe-checklist`, :ref:`fe-what-is-verified`; several of these
    layouts are marked unverified there):

    - Comment lines start with ``#``, ``%``, ``**`` or ``!``; blank lines are skipped
      everywhere. The header is the last text line above the first row of numbers, with
      the free-text preamble above it skipped. If there is none, the last ``%`` comment line
      is the header (COMSOL). A units row (``mm,mm,mm,MPa``) just below the header gives
      the units.
    - Abaqus ``.rpt``-like reports: a two-line column title over a dashed rule is joined
      column by column (``Node``/``Label`` -> ``'Node Label'``), ``@Loc N`` qualifiers are
      removed, rows starting with ``Minimum``, ``Maximum``, ``At Node``, ``At Element``, ``Int Pt``
      or ``Total`` are footers and are dropped, and later blocks with the same columns are
      appended (with different columns: error). A repeat of the header line is skipped. A
      wrapped table (titles in parts, each over its own rule; each record over several lines)
      is read as joined records, every line's count checked.

    Time steps come from, within one file:

    1. ``@ t=<value>`` suffixes (COMSOL): columns sharing a base name are stacked in the
       order they appear; columns without a suffix (coordinates) are repeated for every step.
    2. A time column: rows are grouped by time value in order of first appearance; every
       group must have the same number of rows; the time column itself is not in ``arrays``.
    3. FEBio logfile records (``*Step``/``*Time``/``*Data``): each record is one step; the
       column names are ``id`` followed by the ``*Data`` names split on ``;``.
    4. Abaqus report frames (``Frame: Increment N: Step Time = T`` above a block): each new
       frame is one step at its ``Step Time``; blocks of one frame (parts) are joined rows. Frames
       of several analysis steps, or without a step time, give ``times=None`` (with a note): the
       report states no total time.
    5. CalculiX ``.dat`` blocks (``stresses (elem, integ.pnt.,sxx,...) for set S and time t``):
       each time is one step; blocks of different kinds with the same rows are put side by
       side, shared label columns kept once; the single value column of a block such as
       ``internal energy density (elem, integ.pnt.,energy)`` is named after the block.
    6. ANSYS MAPDL listings (``PRNSOL``, ``PRETAB``; ``NLIST`` for coordinates): each ``LOAD STEP`` /
       ``SUBSTEP`` is one step, its ``TIME=`` the step time (``FREQ=``: numbered steps); pages joined,
       banners and ``MINIMUM``/``MAXIMUM VALUES`` summaries skipped, rows put in ``NODE`` order,
       values written without a blank between them split; listings of different items in one file
       side by side, an ``NLIST`` in the same file giving X, Y, Z. ``PRESOL`` (element-nodal) and a
       node listed twice in a step are refused; PowerGraphics (surface nodes only) warns.
    7. COMSOL Sectionwise exports: each ``% Data (expr (unit) @ t=T)`` section is one column of one value per
       point (``@ t=`` stacked as in 1); the ``% Coordinates`` rows are ``points``, the ``% Elements (tetrahedra)``
       rows (1-based, checked against the number of points) the ``cells``; ``% Nodes:``, ``% Elements:``, ``% Expressions:``
       and ``% Dimension: 3`` are checked. Other element types and 2D exports are refused.

    With several files, steps are concatenated in the given order; every file must have the
    same columns and the same number of rows per step (sectionwise files: the same points and elements);
    ``times`` is None unless every file states its times. MAPDL listings of different items (``S`` in one
    file, ``EPEL`` in another) are joined side by side instead, on ``NODE``: same nodes, same steps and times.

    Rows are never dropped silently: empty and ``NaN`` cells stay NaN (the assembler reports
    them); a column with no number at all (a label column such as ``SKIN-1``) is dropped with
    a note; a column with some unreadable cells raises, as does a column of number-like text
    pandas cannot read (``1.0D-03``). An unnamed first column 0, 1, 2, ... (a pandas index)
    and an unnamed empty last column (trailing delimiters) are dropped with a note.

    The rows themselves are parsed by :func:`pandas.read_csv`; decimal text is converted to
    the nearest float64, so values written with ``repr`` precision read back exactly.
    """
    files = _normalise_paths(paths)
    if isinstance(sep, str):
        sep = _SEP_ALIASES.get(sep, sep)
    check_option("sep", sep, SEPARATORS)
    if time_column is not None and not isinstance(time_column, str):
        raise TypeError(f"'time_column' must be a column name (str) or None; got {time_column!r} instead.")

    from .._progress import progress_bar

    iterator = progress_bar(files, enabled=progress, desc="Reading SED files", unit="file")
    per_file = [_read_one(p, sep, time_column) for p in iterator]
    if len(per_file) > 1 and all(fa.join_key for fa in per_file) and _distinct_columns(per_file):
        return _merge(files, [_side_by_side(files, per_file)], along="side by side")
    return _merge(files, per_file)


#: The columns of an NLIST listing besides NODE (coordinates and rotation angles).
_NLIST_COLUMNS = ("X", "Y", "Z", "THXY", "THYZ", "THZX")


def _distinct_columns(per_file: list[_FileArrays]) -> bool:
    """Whether the files hold different columns (besides their id column): listings of different items (S in
    one file, EPEL in another) are joined side by side; files of the same columns are time steps."""
    seen: set[str] = set()
    for fa in per_file:
        own = set(fa.arrays) - {fa.join_key}
        if own & seen:
            return False
        seen |= own
    return True


def _side_by_side(files: list[str], per_file: list[_FileArrays]) -> _FileArrays:
    """Several MAPDL listings of one run joined on their id column (rows are in id order in each)."""
    ref, first = per_file[0], files[0]
    key = ref.join_key
    ids = ref.arrays[key][1]
    arrays = dict(ref.arrays)
    for path, fa in zip(files[1:], per_file[1:]):
        other = fa.arrays[fa.join_key][1]
        if fa.join_key != key or other.shape != ids.shape or not np.array_equal(other, ids):
            nlist = {canonical(n) for n in fa.arrays} <= {canonical(n) for n in (key, *_NLIST_COLUMNS)}
            raise SEDFormatError(
                f"ANSYS MAPDL listing {path!r} must list the same {key}s at the same steps as {first!r} to be joined "
                f"side by side; got {other.shape[1]} {fa.join_key}s at {other.shape[0]} step(s) (or other numbers) "
                f"against {ids.shape[1]} at {ids.shape[0]} instead."
                + (" An NLIST listing is a coordinates table: pass it as coordinates= (--coordinates)." if nlist else "")
            )
        same_times = (fa.times is None) == (ref.times is None) and (
            fa.times is None or np.array_equal(fa.times, ref.times))
        if not same_times:
            raise SEDFormatError(
                f"ANSYS MAPDL listing {path!r} must be printed at the times of {first!r} to be joined side by side; "
                f"got TIME= {None if fa.times is None else fa.times.tolist()} against "
                f"{None if ref.times is None else ref.times.tolist()} instead."
            )
        arrays.update((name, entry) for name, entry in fa.arrays.items() if name != fa.join_key)
    notes = [n for fa in per_file for n in fa.notes] + [
        f"joined {len(files)} listings side by side on {key!r}: {', '.join(map(repr, files))}"]
    return _FileArrays(arrays, ref.times, ref.time_unit, ref.length_unit, notes, ref.preset, key)


def _merge(files: list[str], per_file: list[_FileArrays], along: str = "time") -> RawExport:
    """One RawExport from each file's arrays: stacked along time (one step per file), or ``along='side by side'``
    (``per_file`` then holds the one joined set of arrays of all ``files``)."""
    first, ref = files[0], per_file[0]
    ref_names = list(ref.arrays)
    n_rows = next(iter(ref.arrays.values()))[1].shape[1] if ref.arrays else 0
    if not ref.arrays:
        raise SEDFormatError(f"SED file {first!r} must hold at least one numeric column; got none instead.")
    for path, fa in zip(files[1:], per_file[1:]):
        names = list(fa.arrays)
        if names != ref_names:
            missing = [n for n in ref_names if n not in fa.arrays]
            extra = [n for n in names if n not in ref.arrays]
            what = []
            if missing:
                what.append(f"no column {_join_names(missing)}")
            if extra:
                what.append(f"an extra column {_join_names(extra)}")
            if not what:
                what.append(f"the columns in the order {_join_names(names)}")
            raise SEDFormatError(
                f"SED file {path!r} must have the same columns as {first!r} ({_join_names(ref_names)}); "
                f"got {' and '.join(what)} instead."
            )
        rows = next(iter(fa.arrays.values()))[1].shape[1]
        if rows != n_rows:
            raise SEDFormatError(
                f"SED file {path!r} must have {n_rows} rows per time step like {first!r}; got {rows} instead."
            )
        for name in ref_names:
            if fa.arrays[name][0] != ref.arrays[name][0]:
                raise SEDFormatError(
                    f"Column {name!r} of SED file {path!r} must have the unit of {first!r} "
                    f"({ref.arrays[name][0]!r}); got {fa.arrays[name][0]!r} instead."
                )
        if (fa.times is None) != (ref.times is None):
            with_t, without = (path, first) if fa.times is not None else (first, path)
            raise SEDFormatError(
                f"SED file {without!r} must state its times like {with_t!r} does; got no time column, "
                f"'@ t=' suffix or '*Time' instead."
            )
    _same_mesh(files, per_file)
    _same_parts(files, per_file)
    times = None if ref.times is None else np.concatenate([fa.times for fa in per_file])
    length_unit = _agree(files, [fa.length_unit for fa in per_file], "length unit")
    time_unit = _agree(files, [fa.time_unit for fa in per_file], "time unit")

    arrays = {}
    for name in ref_names:
        unit, _, _ = ref.arrays[name]
        values = (ref.arrays[name][1] if len(per_file) == 1
                  else np.concatenate([fa.arrays[name][1] for fa in per_file], axis=0))
        arrays[name] = RawArray(name=name, values=np.ascontiguousarray(values, dtype=np.float64),
                                location="point", unit=unit)
    presets = {fa.preset for fa in per_file}
    return RawExport(
        files=tuple(files), format="csv", points=ref.points, cells=ref.cells, arrays=arrays, times=times,
        length_unit=length_unit, time_unit=time_unit,
        notes=_merge_notes(files, per_file) if along == "time" else tuple(dict.fromkeys(ref.notes)),
        preset=presets.pop() if len(presets) == 1 else None,
    )


def _agree(files, values, what) -> str | None:
    stated = [(f, v) for f, v in zip(files, values) if v is not None]
    if len({v for _, v in stated}) > 1:
        (f1, v1), (f2, v2) = stated[0], next((f, v) for f, v in stated if v != stated[0][1])
        raise SEDFormatError(
            f"SED file {f2!r} must state the {what} of {f1!r} ({v1!r}); got {v2!r} instead."
        )
    return stated[0][1] if stated else None


def _merge_notes(files, per_file) -> tuple[str, ...]:
    if len(files) == 1:
        return tuple(dict.fromkeys(per_file[0].notes))
    counts = Counter(n for fa in per_file for n in dict.fromkeys(fa.notes))
    out = []
    for path, fa in zip(files, per_file):
        for n in dict.fromkeys(fa.notes):
            note = f"all {len(files)} files: {n}" if counts[n] == len(files) else f"{path!r}: {n}"
            if note not in out:
                out.append(note)
    out.append(f"stacked {len(files)} files along time")
    return tuple(out)
