"""Text exports made of records or sections rather than one table: FEBio logfiles, CalculiX ``.dat`` blocks, ANSYS
MAPDL listings (PRNSOL, NLIST, PRETAB) and COMSOL Sectionwise exports -> columns (and, for COMSOL, the mesh).

See :mod:`afferent.io._csv` for the layouts and the FE-export page for each tool.

Size: about 800 lines: the four record formats side by side, each a few functions that find its records and hand
their rows to the same table machinery (``_read_rows``, ``_Columns``, then ``_csv._to_arrays`` for times and units);
their line patterns are in ``_csv_lines``.
"""

from __future__ import annotations

import re
import warnings
from collections import Counter

import numpy as np

from ..exceptions import AfferentWarning, SEDFormatError
from ._columns import canonical
from ._csv_lines import (
    _CCX_LABELS,
    _CCX_TITLE,
    _DIGITS,
    _MAPDL_BANNER,
    _MAPDL_NLIST,
    _MAPDL_OTHER_LIST,
    _MAPDL_STEP,
    _MAPDL_SUMMARY,
    _MAPDL_TIME,
    _MAPDL_TITLE,
    _FEBIO_KEY,
    _COMSOL_DIM0,
    _COMSOL_GRID,
    _COMSOL_VERTICAL,
    _SECTION_TITLE,
    _SECTIONWISE_ELEMENTS,
    _SECTIONWISE_START,
    _SEP_NAMES,
    _SNIFF_LINES,
    _is_comment,
    _join_names,
    _plural,
    _quote,
)
from ._csv_table import _Columns, _read_rows, _sniff

_SECTION_SEP = re.compile(r"[\s,;]+")

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


def _node_blocks_skipped(path: str, records: list[dict], notes: list[str]) -> list[dict]:
    """The element blocks (``*EL PRINT``: their first column is ``elem``); the node blocks
    (``*NODE PRINT``: ``displacements (vx,vy,vz)``, no label column) are left out with a note."""
    is_element = [any(canonical(n) in _CCX_LABELS for n in r["names"]) for r in records]
    nodal = [r for r, element in zip(records, is_element) if not element]
    kept = [r for r, element in zip(records, is_element) if element]
    if not nodal:
        return records
    kinds = _join_names(list(dict.fromkeys(r["what"] for r in nodal)))
    if not kept:
        raise SEDFormatError(
            f"CalculiX file {path!r} must have element blocks (*EL PRINT of ENER, or S and E, at the integration "
            f"points); got only node blocks (*NODE PRINT: {kinds}) instead."
        )
    notes.append(f"skipped {_plural(len(nodal), 'CalculiX node block')} (*NODE PRINT: {kinds}): "
                 "SED and the tensors are read from the element blocks")
    return kept


def _parse_ccx(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Read CalculiX ``.dat`` blocks; return (_Columns with all rows, n_times, times).

    Each block is a title line `` <what> (<names>) for set <SET> and time <t>`` followed by
    rows (:ref:`fe-calculix`). Blocks of the same ``<what>`` at the same time
    (several sets) are concatenated; different ``<what>`` (stresses, strains, internal energy
    density) are put side by side when they have the same rows, their shared columns (``elem``,
    ``integ.pnt.``) kept once; each distinct time is one time step. Node blocks (``*NODE PRINT``,
    e.g. ``displacements (vx,vy,vz)``: no ``elem`` column) are skipped with a note. A block with a single value
    column names it after the block title (``'internal energy density'``, not ``'energy'``).
    """
    records = _node_blocks_skipped(path, _ccx_records(path, lines, notes), notes)
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


# --------------------------------------------------------------------------------------
# ANSYS MAPDL listings (PRNSOL, NLIST, PRETAB)
# --------------------------------------------------------------------------------------

_MAPDL_ID_NAMES = ("NODE", "ELEM")
_POWERGRAPHICS = "powergraphics is currently enabled"


def _mapdl_new(listings: list[dict], i: int, item: str, kind: str) -> dict:
    cur = {"item": item, "kind": kind, "line": i + 1, "names": None, "header_line": None, "steps": {},
           "power": False, "shell": False}
    listings.append(cur)
    return cur


def _mapdl_element_nodal(path: str, line_no: int, what: str):
    raise SEDFormatError(
        f"ANSYS MAPDL listing {path!r} must list one value per node (PRNSOL) or per element (ETABLE + PRETAB); got "
        f"an element-nodal listing ({what}, line {line_no}: PRESOL prints every element's nodes, each node once per "
        "element it belongs to) instead. Print PRNSOL,S,COMP / PRNSOL,EPEL,COMP / PRNSOL,SEND,ELASTIC for nodal "
        "values, or ETABLE,SED,SEND,ELASTIC then PRETAB for one value per element."
    )


def _mapdl_text_line(path: str, s: str, i: int, cur: dict | None, listings: list[dict], state: dict) -> dict | None:
    """Class a line that is not a data row: a title, banner, load step, time, summary or column header."""
    m = _MAPDL_TITLE.match(s)
    if m:
        if m.group("kind") and m.group("kind").upper() == "ELEMENT":
            _mapdl_element_nodal(path, i + 1, s.strip())
        item = "ETABLE" if m.group("etable") else m.group("item").upper()
        state.update(summary=False, step=None, time=None)
        return _mapdl_new(listings, i, item, "PRETAB" if m.group("etable") else "PRNSOL")
    m = _MAPDL_NLIST.match(s)
    if m:
        dsys = m.group("dsys")
        if dsys is not None and int(dsys) != 0:
            raise SEDFormatError(
                f"NLIST listing {path!r} must give the node coordinates in the global Cartesian system (DSYS= 0); got "
                f"DSYS= {dsys} at line {i + 1} instead (another display system: cylindrical or local coordinates). "
                "Issue DSYS,0 before NLIST."
            )
        state.update(summary=False, step=None, time=None)
        return _mapdl_new(listings, i, "NLIST", "NLIST")
    if _MAPDL_OTHER_LIST.match(s):  # ELIST, DLIST...: its rows are left out
        state.update(summary=False, step=None, time=None)
        return _mapdl_new(listings, i, " ".join(s.split()[:4]), "OTHER")
    m = _MAPDL_BANNER.match(s)
    if m:
        what = " ".join(m.group("what").split()).upper()
        if "ELEMENT NODAL" in what:
            _mapdl_element_nodal(path, i + 1, f"'***** {what} *****'")
        same = cur is not None and not state["summary"] and cur.get("banner", what) == what
        state.update(summary=False)
        if not same:  # a listing printed without its title line: its page banner starts it
            cur = _mapdl_new(listings, i, what, "PRNSOL")
        cur["banner"] = what
        return cur
    if cur is None:
        return None
    upper = s.upper()
    if _POWERGRAPHICS in s.lower():
        cur["power"] = True
    elif "TOP/BOTTOM" in upper:
        cur["shell"] = True
    elif upper.startswith("ELEMENT="):
        _mapdl_element_nodal(path, i + 1, s)
    elif (m := _MAPDL_STEP.match(s)) is not None:
        state.update(step=(m.group("ls"), m.group("sub")), time=None, summary=False)
    elif (m := _MAPDL_TIME.match(s)) is not None:
        state.update(time=(m.group("kind").upper(), m.group("t")), summary=False)
    elif _MAPDL_SUMMARY.match(s):
        state.update(summary=True)
    elif not state["summary"] and s.split()[0].upper() in _MAPDL_ID_NAMES:
        names = s.split()
        if cur["names"] is not None and names != cur["names"]:
            raise SEDFormatError(
                f"Every page of an ANSYS MAPDL listing must have the same columns; got {_join_names(names)} at "
                f"line {i + 1} of {path!r} after {_join_names(cur['names'])} (line {cur['header_line']}) instead."
            )
        cur["names"], cur["header_line"] = names, cur["header_line"] or i + 1
    return cur


def _mapdl_listings(path: str, lines: list[str], notes: list[str]) -> list[dict]:
    """The listings of a MAPDL output: title, columns, and the row indices of each (load step, substep, time)."""
    listings: list[dict] = []
    cur = None
    state = {"step": None, "time": None, "summary": False}
    n_text = 0
    target = None  # the row list of the current listing and step (None after any other line)
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        if s[0] in _DIGITS and target is not None and "VERSION=" not in s:  # the fast path: a data row
            target.append(i)
            continue
        if s[0] in _DIGITS and cur is not None and cur["names"] is not None and not state["summary"] \
                and "VERSION=" not in s:  # the first row after a header, step or page line
            target = cur["steps"].setdefault((state["step"], state["time"]), [])
            target.append(i)
            continue
        target = None
        if s[0] in _DIGITS and cur is not None and "VERSION=" not in s and not state["summary"]:
            raise SEDFormatError(
                f"ANSYS MAPDL listing {path!r} must name its columns (a 'NODE ...' header row) above its first data "
                f"row; got line {i + 1} ({_quote(s)}) with no header above it instead. Print the listing with MAPDL's "
                "default headers (/HEADER,DEFA)."
            )
        new = _mapdl_text_line(path, s, i, cur, listings, state)
        if new is cur and not s.upper().startswith(_MAPDL_ID_NAMES):
            n_text += 1
        cur = new
    if n_text:
        notes.append(f"skipped {_plural(n_text, 'line')} of MAPDL page headers, notes and MINIMUM/MAXIMUM summaries")
    return listings


def _mapdl_names(cur: dict) -> list[str]:
    """Column names as MAPDL prints them; a value column not named after the listing's item gets it in front
    (``PRINT SEND`` and a column ``ELASTIC`` -> ``'SEND ELASTIC'``)."""
    names = list(cur["names"])
    item = cur["item"]
    if cur["kind"] == "PRNSOL" and item.isalnum():
        names[1:] = [n if n.upper().startswith(item) else f"{item} {n}" for n in names[1:]]
    return names


def _mapdl_blocks(path: str, listings: list[dict]) -> dict[tuple, dict]:
    """Listings with the same columns joined (pages, several SET + PRNSOL): names -> {step key: row indices}.
    Several listings of one item without LOAD STEP lines (PRETAB after each SET) are numbered steps."""
    blocks: dict[tuple, dict] = {}
    stepless = Counter(tuple(_mapdl_names(c)) for c in listings if (None, None) in c["steps"])
    for cur in listings:
        if not cur["steps"]:
            continue
        names = tuple(_mapdl_names(cur))
        block = blocks.setdefault(names, {"steps": {}, "header_line": cur["header_line"], "listings": []})
        block["listings"].append(cur)
        for key, rows in cur["steps"].items():
            if key == (None, None) and stepless[names] > 1:
                key = (None, ("LISTING", str(sum((None, None) in c["steps"] for c in block["listings"]))))
            block["steps"].setdefault(key, []).extend(rows)
    if not blocks:
        titles = ", ".join(f"{c['item']} (line {c['line']})" for c in listings) or "none"
        raise SEDFormatError(
            f"ANSYS MAPDL listing {path!r} must hold data rows under a 'NODE ...' (or 'ELEM ...') header; got none "
            f"instead (listings found: {titles})."
        )
    keys = list(next(iter(blocks.values()))["steps"])
    for names, block in blocks.items():
        if list(block["steps"]) != keys:
            raise SEDFormatError(
                f"Every listing of ANSYS MAPDL file {path!r} must cover the same load steps to be read side by side; "
                f"got {_mapdl_steps_text(keys)} for {_join_names(next(iter(blocks)))} and "
                f"{_mapdl_steps_text(list(block['steps']))} for {_join_names(names)} instead."
            )
    return blocks


def _mapdl_steps_text(keys: list) -> str:
    def one(key):
        step, time = key
        where = f"load step {step[0]} substep {step[1]}" if step else "no load step"
        if time and time[0] == "LISTING":
            return f"listing {time[1]} (no load step)"
        return where + (f" ({time[0]}= {time[1]})" if time else "")
    return ", ".join(one(k) for k in keys[:4]) + (f", ... ({len(keys)} in all)" if len(keys) > 4 else "")


def _mapdl_sorted(path: str, names: tuple, block: dict, lines: list[str], notes: list[str]):
    """One block's rows read (pandas), each step's rows put in id order; (headers, values, row lines, ids)."""
    keys = list(block["steps"])
    row_idx = [i for k in keys for i in block["steps"][k]]
    rows = _split_abutting([lines[i] for i in row_idx])
    row_lines = np.asarray([i + 1 for i in row_idx])
    headers, values = _read_rows(path, rows, row_lines, "whitespace", list(names), block["header_line"], notes)
    if headers[0] != names[0]:
        raise SEDFormatError(f"Column {names[0]!r} of ANSYS MAPDL listing {path!r} must hold node or element numbers.")
    ids = values[0]
    order, start, first = [], 0, None
    for k in keys:
        n = len(block["steps"][k])
        step_ids = ids[start:start + n]
        o = np.argsort(step_ids, kind="stable")
        sorted_ids = step_ids[o]
        dup = np.flatnonzero(sorted_ids[1:] == sorted_ids[:-1])
        if dup.size:
            _mapdl_repeated(path, names[0], block, k, sorted_ids[dup[0]], row_lines[start:start + n][o])
        if first is None:
            first = sorted_ids
        elif not np.array_equal(sorted_ids, first):
            raise SEDFormatError(
                f"Every load step of ANSYS MAPDL listing {path!r} must list the same {names[0]}s; got {first.size} in "
                f"{_mapdl_steps_text(keys[:1])} and {sorted_ids.size} in {_mapdl_steps_text([k])} (or other numbers) "
                "instead. Select the same nodes (NSEL) for every SET before PRNSOL."
            )
        order.append(start + o)
        start += n
    order = np.concatenate(order)
    if not np.array_equal(order, np.arange(order.size)):
        notes.append(f"put the rows of every step in {names[0]} order (the listing is sorted otherwise, NSORT)")
    return headers, [v[order] for v in values], row_lines[order], first


def _split_abutting(rows: list[str]) -> list[str]:
    """The rows with a blank before every sign that follows a digit or a point: two values MAPDL wrote without a blank
    between them (``-0.70653E+007-0.40380E+007``: 3-digit exponents, or a negative E-format value after another,
    fill the fixed-width fields) become two; ``E-07`` is left alone. numpy over the bytes: 3x faster than a regex."""
    buf = np.frombuffer("\n".join(rows).encode("utf-8"), dtype=np.uint8)
    sign = (buf == 45) | (buf == 43)
    after = ((buf >= 48) & (buf <= 57)) | (buf == 46)
    at = np.flatnonzero(sign[1:] & after[:-1]) + 1
    if not at.size:
        return rows
    return np.insert(buf, at, 32).tobytes().decode("utf-8").split("\n")


def _mapdl_repeated(path, name, block, key, value, row_lines):
    shells = any(c["shell"] for c in block["listings"])
    power = any(c["power"] for c in block["listings"])
    why = ("shell results listed for the top and bottom surfaces" if shells else
           "PowerGraphics listing a node once per surface it lies on" if power else "element-nodal values")
    raise SEDFormatError(
        f"ANSYS MAPDL listing {path!r} must list each {name} once per load step; got {name} {value:g} more than once "
        f"in {_mapdl_steps_text([key])} (rows at lines {', '.join(map(str, row_lines[:2]))}, ...) instead ({why}). "
        "Print PRNSOL with /GRAPHICS,FULL, over solid elements."
    )


def _mapdl_times(path: str, keys: list, notes: list[str]) -> np.ndarray | None:
    """The ``TIME=`` of each step in the listing's time unit, or None (no times, or frequencies)."""
    times = [k[1] for k in keys]
    if all(t is None for t in times):
        return None
    if any(t is None for t in times) or any(t[0] != "TIME" for t in times):
        notes.append("the listing's steps carry no TIME= (FREQ= or none): steps are numbered, not timed")
        return None
    try:
        return np.array([float(t[1]) for t in times])
    except ValueError as err:
        raise SEDFormatError(f"'TIME=' of ANSYS MAPDL listing {path!r} must be a number; got {times!r}.") from err


def _parse_mapdl(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Read ANSYS MAPDL listings (PRNSOL, NLIST, PRETAB); return (_Columns, n_steps, times).

    Pages are joined and their headers, notes and MINIMUM/MAXIMUM/TOTAL summaries skipped; each
    (LOAD STEP, SUBSTEP, TIME) is one step, its rows put in NODE order; listings of different items
    with the same nodes and steps (S, then EPEL) are put side by side, the NODE column kept once.
    Values written without a blank between them (``-0.7E+007-0.4E+007``) are split. PRESOL
    (element-nodal) listings are refused; a PowerGraphics listing (exterior surfaces only) warns.
    """
    if sep not in (None, "whitespace"):
        raise SEDFormatError(f"ANSYS MAPDL listing {path!r} has blank-separated columns; got sep={sep!r} instead.")
    listings = _mapdl_listings(path, lines, notes)
    other = [c for c in listings if c["kind"] == "OTHER"]
    if other:
        notes.append(f"skipped {_plural(len(other), 'MAPDL list')} of other items ("
                     f"{', '.join(repr(c['item']) + ' at line ' + str(c['line']) for c in other[:3])})")
        listings = [c for c in listings if c["kind"] != "OTHER"]
        if not any(c["steps"] for c in listings):
            raise SEDFormatError(
                f"ANSYS MAPDL file {path!r} must hold results (PRNSOL, PRETAB) or node coordinates (NLIST); got only "
                f"{other[0]['item']!r} (line {other[0]['line']}), which lists the model, not results, instead."
            )
    nlists = [c for c in listings if c["kind"] == "NLIST" and c["steps"]]
    if nlists and len(nlists) < sum(bool(c["steps"]) for c in listings):
        listings = [c for c in listings if c not in nlists]  # results with their NLIST: coordinates, below
    else:
        nlists = []
    blocks = _mapdl_blocks(path, listings)
    headers, values, row_lines, ids, header_line = [], [], None, None, None
    for names, block in blocks.items():
        hs, vs, rl, block_ids = _mapdl_sorted(path, names, block, lines, notes)
        if ids is None:
            ids, row_lines, header_line = block_ids, rl, block["header_line"]
        elif not np.array_equal(block_ids, ids):
            raise SEDFormatError(
                f"The listings of ANSYS MAPDL file {path!r} must list the same {names[0]}s to be read side by side; got "
                f"{ids.size} under {_join_names(headers)} and {block_ids.size} under {_join_names(hs)} instead."
            )
        for h, v in zip(hs, vs):
            if h in headers:
                if h == hs[0]:
                    continue  # the NODE column, kept once
                raise SEDFormatError(f"Column {h!r} of ANSYS MAPDL file {path!r} is listed twice with different values.")
            headers.append(h)
            values.append(v)
    keys = list(next(iter(blocks.values()))["steps"])
    if nlists:
        for h, v in zip(*_mapdl_coordinates(path, nlists, ids, len(keys), lines, notes)):
            if h in headers:
                raise SEDFormatError(f"Column {h!r} of ANSYS MAPDL file {path!r} is both a result and an NLIST column.")
            headers.append(h)
            values.append(v)
    if any(c["power"] for c in listings):
        notes.append("PowerGraphics was enabled: MAPDL lists the exterior surfaces' nodes only")
        warnings.warn(
            f"ANSYS MAPDL listing {path!r} was printed with PowerGraphics enabled: PRNSOL then lists the nodes of the "
            "model's exterior surfaces only, so SED inside the skin (at the receptors) would be interpolated from "
            "surface values. Print it again after /GRAPHICS,FULL.", AfferentWarning, stacklevel=2)
    kinds = list(dict.fromkeys(c["item"] for c in listings if c["steps"]))
    notes.append(f"read {_plural(len(kinds), 'ANSYS MAPDL listing')} ({', '.join(kinds)}) at "
                 f"{_plural(len(keys), 'step')}, {_plural(ids.size, 'row')} per step")
    times = _mapdl_times(path, keys, notes)
    return _Columns(headers, values, row_lines, header_line, {}, notes), len(keys), times


def _mapdl_coordinates(path: str, nlists: list[dict], ids: np.ndarray, n_steps: int, lines: list[str],
                       notes: list[str]) -> tuple[list[str], list[np.ndarray]]:
    """The NLIST columns (X, Y, Z, ...) of the nodes that carry results, repeated for every step."""
    blocks = _mapdl_blocks(path, nlists)
    if len(blocks) > 1:
        raise SEDFormatError(f"The NLIST listings of ANSYS MAPDL file {path!r} must have the same columns; got "
                             f"{' and '.join(_join_names(names) for names in blocks)} instead.")
    (names, block), = blocks.items()
    hs, vs, _, node_ids = _mapdl_sorted(path, names, block, lines, notes)
    pos = np.clip(np.searchsorted(node_ids, ids), 0, node_ids.size - 1)
    missing = ids[node_ids[pos] != ids]
    if missing.size:
        raise SEDFormatError(
            f"The NLIST listing of ANSYS MAPDL file {path!r} (line {nlists[0]['line']}) must list every node that "
            f"has results; got {missing.size} without coordinates (first: {', '.join(f'{v:g}' for v in missing[:5])}) "
            "instead. NLIST the same nodes (NSEL) as PRNSOL."
        )
    notes.append(f"coordinates from the NLIST listing (line {nlists[0]['line']}) joined on {names[0]!r}: "
                 f"{node_ids.size} nodes listed, {ids.size} with results")
    return list(hs[1:]), [np.tile(v[pos], n_steps) for v in vs[1:]]


# --------------------------------------------------------------------------------------
# COMSOL Sectionwise exports
# --------------------------------------------------------------------------------------

#: COMSOL's element section names -> the meshio type they hold. COMSOL exports a simplex mesh: triangles in 2D,
#: tetrahedra in 3D (COMSOL Reference Manual, Sectionwise Data Format); a 2D model is refused by its dimension.
_SECTIONWISE_CELLS = {"tetrahedra": ("tetra", 4)}


def _is_sectionwise(text: str, head: str) -> bool:
    """A COMSOL sectionwise export: its ``% Coordinates`` title near the top (``head``), an ``% Elements (`` title
    anywhere (a real export's coordinates run to megabytes before it)."""
    return bool(_SECTIONWISE_START.search(head)) and bool(_SECTIONWISE_ELEMENTS.search(text))


def _sectionwise_sections(path: str, lines: list[str]) -> tuple[list[str], list[tuple[str, str, int, list[int]]]]:
    """The preamble lines above the first section, and each section: (kind, title text, line, row indices).

    ``kind`` is ``'coordinates'``, ``'elements'`` or ``'data'``; rows are the non-blank lines up to the next title.
    """
    sections: list[tuple[str, str, int, list[int]]] = []
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        if s.startswith("%"):
            m = _SECTION_TITLE.match(s)
            if m:
                kind = "coordinates" if m.group("coords") else "elements" if m.group("type") is not None else "data"
                text = m.group("type") if kind == "elements" else m.group("data") if kind == "data" else ""
                sections.append((kind, (text or "").strip(), i + 1, []))
            elif sections:
                raise SEDFormatError(
                    f"COMSOL sectionwise file {path!r} must hold only '% Coordinates', '% Elements (...)' and "
                    f"'% Data (...)' sections after its preamble; got {_quote(s)} at line {i + 1} instead.")
            continue
        if not sections:
            raise SEDFormatError(f"COMSOL sectionwise file {path!r} must start its rows under a '% Coordinates' title; "
                                 f"got the row {_quote(s)} at line {i + 1} first instead.")
        sections[-1][3].append(i)
    return lines[:sections[0][2] - 1] if sections else list(lines), sections  # the preamble keeps its line numbers


def _section_numbers(path: str, lines: list[str], section, n_cols: int | None, what: str) -> np.ndarray:
    """The numbers of one section's rows as an (n_rows, n_cols) float array; every row must hold ``n_cols``
    numbers (``None``: as many as the first row), separated by blanks, commas or semicolons."""
    import io

    _, _, title_line, rows = section
    if not rows:
        raise SEDFormatError(f"The {what} section of COMSOL sectionwise file {path!r} (line {title_line}) must hold "
                             "at least one row; got none instead.")
    text = "\n".join(lines[i] for i in rows).replace(",", " ").replace(";", " ")
    try:  # numpy's C parser (0.12 s for 224k rows of 4); errors found again below, row by row, to name the line
        values = np.loadtxt(io.StringIO(text), dtype=np.float64, ndmin=2, comments=None)
    except ValueError:
        values = None
    n = len(lines[rows[0]].replace(",", " ").replace(";", " ").split()) if n_cols is None else n_cols
    if values is not None and values.shape[1] == n:
        return values
    for i in rows:
        cells = _SECTION_SEP.split(lines[i].strip())
        if len(cells) != n:
            raise SEDFormatError(
                f"Every row of the {what} section of COMSOL sectionwise file {path!r} must hold {_plural(n, 'value')}; "
                f"got {len(cells)} at line {i + 1} ({_quote(lines[i].strip())}) instead.")
        for c in cells:
            try:
                float(c)
            except ValueError:
                raise SEDFormatError(
                    f"Every value of the {what} section of COMSOL sectionwise file {path!r} must be a number; "
                    f"got {_quote(c)} at line {i + 1} instead.") from None
    raise SEDFormatError(f"The {what} section of COMSOL sectionwise file {path!r} (line {title_line}) could not be "
                         "read as numbers.")  # text float() reads and numpy does not ('1_000')


def _sectionwise_cells(path: str, lines: list[str], section, n_points: int):
    """The section ``% Elements (tetrahedra)`` as afferent's cells (0-based point numbers)."""
    from ._cell_blocks import _Block, cells_from_meshio

    kind = section[1].lower()
    if kind not in _SECTIONWISE_CELLS:
        raise SEDFormatError(
            f"COMSOL sectionwise file {path!r} holds elements of type {_quote(section[1])} (line {section[2]}), which "
            f"afferent cannot read; it reads {', '.join(map(repr, _SECTIONWISE_CELLS))}, what COMSOL writes for a 3D "
            "model. Export the 3D solution, or choose Data format: Spreadsheet.")
    ctype, n_nodes = _SECTIONWISE_CELLS[kind]
    conn = _section_numbers(path, lines, section, n_nodes, f"'% Elements ({section[1]})'")
    bad = np.flatnonzero(np.any((conn != np.round(conn)) | (conn < 1) | (conn > n_points), axis=1))
    if bad.size:
        i = section[3][bad[0]]
        raise SEDFormatError(
            f"The element rows of COMSOL sectionwise file {path!r} must hold point numbers from 1 to {n_points} (the "
            f"rows of its '% Coordinates' section); got {_quote(lines[i].strip())} at line {i + 1} instead "
            f"({_plural(bad.size, 'row')} out of range).")
    return cells_from_meshio([_Block(ctype, conn.astype(np.int64) - 1)], path)


def _sectionwise_count(path: str, meta: dict, key: str, found: int, what: str) -> None:
    """The preamble's ``% Nodes:`` / ``% Elements:`` / ``% Expressions:`` count, when stated, must be what was found
    (``% Expressions:`` counts an expression once per time step: 30 for 3 expressions at 10 parameter values in a
    real COMSOL 6.1 spreadsheet export, NEMS-AI/comsol_mesh, tests/data/comsol_fields/stanford_meter_volume.csv)."""
    if key not in meta:
        return
    value, line = meta[key]
    if value.strip() != str(found):
        raise SEDFormatError(
            f"COMSOL sectionwise file {path!r} states '% {key.capitalize()}: {value.strip()}' (line {line}) but holds "
            f"{_plural(found, what)}; the file is cut short or was edited.")


def _parse_sectionwise(path: str, lines: list[str], notes: list[str]):
    """A COMSOL Sectionwise export -> (columns of the ``% Data`` sections, points (n, 3), cells)."""
    from ._csv_table import _comsol_meta

    pre, sections = _sectionwise_sections(path, lines)
    meta = _comsol_meta(pre, 0)
    kinds = [s[0] for s in sections]
    if kinds[:2] != ["coordinates", "elements"] or "coordinates" in kinds[2:] or "elements" in kinds[2:]:
        got = ", ".join(f"'{k}' (line {s[2]})" for k, s in zip(kinds, sections))
        raise SEDFormatError(f"COMSOL sectionwise file {path!r} must hold one '% Coordinates' section, then one "
                             f"'% Elements (...)' section, then '% Data (...)' sections; got {got} instead.")
    dim = meta.get("dimension", ("3", 0))[0].strip()
    points = _section_numbers(path, lines, sections[0], None, "'% Coordinates'")
    if dim != "3" or points.shape[1] != 3:
        raise SEDFormatError(
            f"COMSOL sectionwise file {path!r} must be a 3D export (3 coordinates a point); got '% Dimension: {dim}' "
            f"and {points.shape[1]} coordinate(s) a point instead. afferent samples a 3D skin model.")
    _sectionwise_count(path, meta, "nodes", len(points), "point")
    _sectionwise_count(path, meta, "elements", len(sections[1][3]), "element")
    cells = _sectionwise_cells(path, lines, sections[1], len(points))
    data = sections[2:]
    if not data:
        raise SEDFormatError(f"COMSOL sectionwise file {path!r} must hold at least one '% Data (...)' section after "
                             "its elements; got none instead. Add the SED expression (solid.Ws) to the export.")
    _sectionwise_count(path, meta, "expressions", len(data), "data section")  # one per expression and time
    headers, values = [], []
    for sec in data:
        col = _section_numbers(path, lines, sec, 1, f"'% Data ({sec[1]})' (line {sec[2]})")
        if len(col) != len(points):
            raise SEDFormatError(
                f"The '% Data ({sec[1]})' section of COMSOL sectionwise file {path!r} (line {sec[2]}) must hold one "
                f"value for each of the {len(points)} points; got {len(col)} instead.")
        headers.append(sec[1] or f"Data (line {sec[2]})")
        values.append(col[:, 0])
    notes.append(f"read a COMSOL sectionwise export: {_plural(len(points), 'point')}, "
                 f"{_plural(cells.n_cells, 'element')} ({sections[1][1]}), {_plural(len(data), 'data section')}")
    return _Columns(headers, values, np.asarray(sections[2][3]) + 1, sections[2][2], meta, notes), points, cells


def _refuse_comsol_layout(path: str, head: str) -> None:
    """Refuse COMSOL's Grid and vertical point-evaluation layouts (Results > Export > Data, Data format), naming them."""
    layout = ("Grid" if _COMSOL_GRID.search(head) else
              "the vertical point-evaluation layout ('% Dimension: 0', '% X' over its value)"
              if _COMSOL_DIM0.search(head) and _COMSOL_VERTICAL.search(head) else None)
    if layout:
        raise SEDFormatError(
            f"SED file {path!r} is a COMSOL export in {layout}, which afferent does not read. Export it again with "
            "Data format: Spreadsheet (or Sectionwise) on the mesh nodes (docs/fe-export.md, COMSOL).")


def _same_parts(files, per_file) -> None:
    """Files stacked along time must number the same part instances alike (an Abaqus report's ``Part`` codes)."""
    from ._columns import part_names

    first = part_names(per_file[0].notes)
    for path, fa in zip(files[1:], per_file[1:]):
        other = part_names(fa.notes)
        if other != first:
            said = lambda p: "none" if p is None else ", ".join(map(repr, p[1]))  # noqa: E731
            raise SEDFormatError(f"SED file {path!r} must report the part instances of {files[0]!r} in the same order "
                                 f"({said(first)}); got {said(other)} instead.")


def _same_mesh(files: list[str], per_file: list) -> None:
    """Files stacked along time that carry a mesh (COMSOL sectionwise) must carry the same points and cells."""
    ref = per_file[0]
    for path, fa in zip(files[1:], per_file[1:]):
        same = (fa.points is None) == (ref.points is None)
        if same and ref.points is not None:
            same = (np.array_equal(fa.points, ref.points) and np.array_equal(fa.cells.tetra, ref.cells.tetra))
        if not same:
            raise SEDFormatError(
                f"SED file {path!r} must hold the points and elements of {files[0]!r} to be read as its next time "
                "steps; got a different mesh instead. Export all times into one sectionwise file.")
