"""Text exports made of records rather than one table: FEBio logfiles and CalculiX ``.dat`` blocks -> columns.

See :mod:`afferent.io._csv` for the layouts and the FE-export page for each tool.
"""

from __future__ import annotations

import numpy as np

from ..exceptions import SEDFormatError
from ._columns import canonical
from ._csv_lines import _CCX_LABELS, _CCX_TITLE, _FEBIO_KEY, _SEP_NAMES, _SNIFF_LINES, _is_comment, _join_names, _plural
from ._csv_table import _Columns, _read_rows, _sniff

# --------------------------------------------------------------------------------------
# FEBio logfiles
# --------------------------------------------------------------------------------------


def _febio_records(lines: list[str], notes: list[str]) -> list[dict]:
    """The ``*Step`` records of a FEBio logfile: step, line, time, data (value, line), row indices."""
    records: list[dict] = []
    cur = None
    n_pre = 0
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        m = _FEBIO_KEY.match(s)
        if m and not s.startswith("**"):
            key = m.group("key").strip().lower()
            if key == "step":
                cur = {"step": m.group("val").strip(), "line": i + 1, "time": None, "data": None, "rows": []}
                records.append(cur)
            elif cur is None:
                n_pre += 1
            elif key == "time":
                cur["time"] = (m.group("val").strip(), i + 1)
            elif key == "data":
                cur["data"] = (m.group("val").strip(), i + 1)
            continue
        if cur is None or _is_comment(s) or s.startswith("*"):
            n_pre += cur is None
            continue
        cur["rows"].append(i)
    if n_pre:
        notes.append(f"skipped {_plural(n_pre, 'line')} before the first '*Step' record")
    return records


def _check_febio_records(path: str, records: list[dict]) -> None:
    """Every record names its data, has rows, and logs the same data in as many rows as the first."""
    first = records[0]
    for rec in records:
        if rec["data"] is None:
            raise SEDFormatError(
                f"Record '*Step = {rec['step']}' (line {rec['line']}) of FEBio logfile {path!r} must have "
                f"a '*Data = ...' line naming its columns; got none instead."
            )
        if not rec["rows"]:
            raise SEDFormatError(
                f"Record '*Step = {rec['step']}' (line {rec['line']}) of FEBio logfile {path!r} must have "
                f"data rows; got none instead."
            )
        if rec["data"][0] != first["data"][0]:
            raise SEDFormatError(
                f"Every record of FEBio logfile {path!r} must log the same data as the first "
                f"('*Data = {first['data'][0]}', line {first['data'][1]}); got "
                f"'*Data = {rec['data'][0]}' at line {rec['data'][1]} instead."
            )
        if len(rec["rows"]) != len(first["rows"]):
            raise SEDFormatError(
                f"Every record of FEBio logfile {path!r} must have the same number of rows; got "
                f"{len(first['rows'])} rows in '*Step = {first['step']}' (line {first['line']}) and "
                f"{len(rec['rows'])} in '*Step = {rec['step']}' (line {rec['line']}) instead."
            )


def _febio_times(path: str, records: list[dict]) -> np.ndarray | None:
    """The ``*Time`` of every record in s, or None when no record has one."""
    with_time = [rec for rec in records if rec["time"] is not None]
    if with_time and len(with_time) != len(records):
        rec = next(r for r in records if r["time"] is None)
        raise SEDFormatError(
            f"Every record of FEBio logfile {path!r} must have a '*Time' line if one has; got none in "
            f"'*Step = {rec['step']}' (line {rec['line']}) instead."
        )
    if not with_time:
        return None
    times = np.empty(len(records))
    for k, rec in enumerate(records):
        try:
            times[k] = float(rec["time"][0])
        except ValueError as err:
            raise SEDFormatError(
                f"'*Time' of FEBio logfile {path!r} must be a number; got {rec['time'][0]!r} at line "
                f"{rec['time'][1]} instead."
            ) from err
    return times


def _parse_febio(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Split a FEBio logfile into records; return (_Columns with all rows, record sizes, times)."""
    records = _febio_records(lines, notes)
    _check_febio_records(path, records)
    first = records[0]
    names = ["id"] + [n.strip() for n in first["data"][0].split(";")]
    row_idx = [i for rec in records for i in rec["rows"]]
    if sep is None:
        delim = _sniff(lines, row_idx[:_SNIFF_LINES]) or "whitespace"
        notes.append(f"detected delimiter: {_SEP_NAMES[delim]}")
    else:
        delim = sep
    rows = [lines[i] for i in row_idx]
    row_lines = [i + 1 for i in row_idx]
    headers, values = _read_rows(path, rows, row_lines, delim, names, first["data"][1], notes)
    notes.append(f"read {_plural(len(records), 'FEBio logfile record')} ('*Step') as time steps")
    times = _febio_times(path, records)
    cols = _Columns(headers, values, np.asarray(row_lines), first["data"][1], {}, notes)
    return cols, len(records), times


# --------------------------------------------------------------------------------------
# CalculiX .dat blocks
# --------------------------------------------------------------------------------------


def _ccx_records(path: str, lines: list[str], notes: list[str]) -> list[dict]:
    """The blocks of a CalculiX ``.dat`` file: what, set, time, column names, title line, row indices."""
    records: list[dict] = []
    n_pre = 0
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        m = _CCX_TITLE.match(s)
        if m:
            records.append({
                "what": m.group("what").strip(), "set": m.group("set"), "time": m.group("time"),
                "names": [n.strip() for n in m.group("cols").split(",")], "line": i + 1, "rows": [],
            })
        elif not records or _is_comment(s):
            n_pre += not records
        else:
            records[-1]["rows"].append(i)
    if not records:
        raise SEDFormatError(
            f"CalculiX file {path!r} names CalculiX output but has no complete block title such as "
            "'stresses (elem, integ.pnt.,sxx,syy,szz,sxy,sxz,syz) for set EALL and time  0.1000000E+01'."
        )
    if n_pre:
        notes.append(f"skipped {_plural(n_pre, 'line')} before the first CalculiX block title")
    return records


def _ccx_block(path, lines, sep, notes, what: str, time_keys: list[str], by_key: dict):
    """One kind of block (``what``) at every time, its sets concatenated: (what, headers, values, row lines)."""
    sizes = []
    for t in time_keys:
        recs = by_key.get((t, what))
        if recs is None:
            raise SEDFormatError(
                f"CalculiX file {path!r} must print every block at every time; got no '{what}' "
                f"block for time {t} instead."
            )
        for r in recs:
            if r["names"] != recs[0]["names"]:
                raise SEDFormatError(
                    f"Blocks '{what}' of CalculiX file {path!r} must have the same columns; got "
                    f"{_join_names(r['names'])} at line {r['line']} instead."
                )
        sizes.append(sum(len(r["rows"]) for r in recs))
    if len(set(sizes)) > 1:
        pairs = ", ".join(f"{n} rows at time {t}" for t, n in zip(time_keys, sizes))
        raise SEDFormatError(
            f"Every time step of CalculiX file {path!r} must have the same number of '{what}' rows; "
            f"got {pairs} instead."
        )
    row_idx = [i for t in time_keys for r in by_key[(t, what)] for i in r["rows"]]
    delim = sep or _sniff(lines, row_idx[:_SNIFF_LINES]) or "whitespace"
    rows = [lines[i] for i in row_idx]
    row_lines = [i + 1 for i in row_idx]
    first = by_key[(time_keys[0], what)][0]
    names = list(first["names"])
    value_cols = [k for k, n in enumerate(names) if canonical(n) not in _CCX_LABELS]
    if len(value_cols) == 1:
        # 'internal energy density (elem, integ.pnt.,energy)': the title, not 'energy',
        # says what the value is (density, not the element energy of 'internal energy').
        k = value_cols[0]
        notes.append(f"named the value column {names[k]!r} of the CalculiX block '{what}' after the block")
        names[k] = what
    headers, values = _read_rows(path, rows, row_lines, delim, names, first["line"], notes)
    return what, headers, values, row_lines


def _ccx_side_by_side(path: str, blocks: list, n_times: int) -> tuple[list[str], list[np.ndarray]]:
    """The blocks' columns side by side (same rows required), shared label columns kept once."""
    n0 = len(blocks[0][3])
    headers: list[str] = []
    values: list[np.ndarray] = []
    owner: list[str] = []
    for what, hs, vs, row_lines in blocks:
        if len(row_lines) != n0:
            raise SEDFormatError(
                f"The blocks of CalculiX file {path!r} must have the same rows to be read side by side; got "
                f"{_plural(n0 // n_times, 'row')} of '{blocks[0][0]}' and "
                f"{_plural(len(row_lines) // n_times, 'row')} of '{what}' per time instead. "
                f"Print one kind of output per file."
            )
        for h, v in zip(hs, vs):
            if h in headers:
                k = headers.index(h)
                if np.array_equal(values[k], v, equal_nan=True):
                    continue  # a shared label column (elem, integ.pnt.)
                raise SEDFormatError(
                    f"Column names of CalculiX file {path!r} must be unique; got {h!r} in block "
                    f"'{owner[k]}' and in block '{what}' with different values instead."
                )
            headers.append(h)
            values.append(v)
            owner.append(what)
    return headers, values


def _parse_ccx(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Read CalculiX ``.dat`` blocks; return (_Columns with all rows, n_times, times).

    Each block is a title line `` <what> (<names>) for set <SET> and time <t>`` followed by
    rows (:ref:`fe-calculix`). Blocks of the same ``<what>`` at the same time
    (several sets) are concatenated; different ``<what>`` (stresses, strains, internal energy
    density) are put side by side when they have the same rows, their shared columns (``elem``,
    ``integ.pnt.``) kept once; each distinct time is one time step. A block with a single value
    column names it after the block title (``'internal energy density'``, not ``'energy'``).
    """
    records = _ccx_records(path, lines, notes)
    time_keys = list(dict.fromkeys(r["time"] for r in records))
    whats = list(dict.fromkeys(r["what"] for r in records))
    by_key: dict[tuple[str, str], list[dict]] = {}
    for r in records:
        if not r["rows"]:
            raise SEDFormatError(
                f"Block '{r['what']}' (line {r['line']}) of CalculiX file {path!r} must have data rows; "
                f"got none instead."
            )
        by_key.setdefault((r["time"], r["what"]), []).append(r)
    blocks = [_ccx_block(path, lines, sep, notes, what, time_keys, by_key) for what in whats]
    headers, values = _ccx_side_by_side(path, blocks, len(time_keys))
    try:
        times = np.array([float(t) for t in time_keys])
    except ValueError as err:
        raise SEDFormatError(
            f"Block times of CalculiX file {path!r} must be numbers; got {time_keys!r} instead."
        ) from err
    notes.append(
        f"read {_plural(len(records), 'CalculiX block')} ({_join_names(whats)}) at {_plural(len(time_keys), 'time')}"
    )
    cols = _Columns(headers, values, np.asarray(blocks[0][3]), records[0]["line"], {}, notes)
    return cols, len(time_keys), times
