"""Text tables, second layer: where the header, units row and data rows of a table file are, and the rows as columns.

Covers delimited and whitespace tables, COMSOL spreadsheets and Abaqus ``.rpt``-like reports
(see :mod:`afferent.io._csv`).
"""

from __future__ import annotations

import csv
import io
import re
from collections import Counter
from dataclasses import dataclass, field
from itertools import islice

import numpy as np
import pandas as pd

from ..exceptions import SEDFormatError
from ..units import parse_unit
from ._columns import PART_ALIASES, canonical, part_note, split_unit
from ._csv_lines import (
    _COMMENT_STRIP,
    _DECIMAL_COMMA,
    _DIGITS,
    _FLOAT_KW,
    _FOOTER,
    _FOOTER_WORDS,
    _LOC,
    _META,
    _NA_SET,
    _NA_VALUES,
    _NUMBER,
    _NUMBERISH,
    _SEP_NAMES,
    _SIGNS,
    _SNIFF_LINES,
    _SNIFF_ORDER,
    _WS_TOKEN,
    _align_two_lines,
    _delimited_names,
    _is_body,
    _is_comment,
    _count_fields,
    _head_fields,
    _is_data_line,
    _is_data_line_any,
    _MANY_NAMES,
    _quote,
    _is_rule,
    _join_names,
    _plural,
    _check_frame_labels,
    _frame_records,
    _join_wrapped,
    _report_frame, _add_parts,
    _report_position_note,
    _spans,
    _split,
    _whitespace_names,
    _wrapped_names,
)

# --------------------------------------------------------------------------------------
# Table files
# --------------------------------------------------------------------------------------


@dataclass
class _Header:
    names: list[str]
    line: int  # 1-based line number of the (last) header line
    text: str  # stripped text of the header line, to skip repeats of it
    first_data: int  # 0-based index of the first data row
    from_comment: bool = False
    n_lines: int = 1  # 2 for a two-line column title; from the first title line to the last for a wrapped one
    units_line: int | None = None  # 1-based line of a units row below the names
    wrap: tuple[int, ...] | None = None  # values on each line of a record of a wrapped Abaqus table


@dataclass
class _Columns:
    """Parsed, numeric columns of one file (one entry per kept column)."""

    headers: list[str]
    values: list[np.ndarray]
    row_lines: np.ndarray
    header_line: int
    meta: dict[str, tuple[str, int]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    n_records: int = 1  # time steps, rows in step order (Abaqus report frames)
    record_times: np.ndarray | None = None  # their times, in the file's time unit


def _body_lines(lines: list[str], start: int = 0):
    """Indices of lines that are neither blank, comments nor dashed rules."""
    for i in range(start, len(lines)):
        if _is_body(lines[i].strip()):
            yield i


def _sniff(lines: list[str], idx: list[int]) -> str | None:
    """The delimiter under which most of the lines ``idx`` are data rows (None if none is)."""
    best, best_score = None, (0, 0)
    for prio, delim in enumerate(_SNIFF_ORDER):
        hits = sum(_is_data_line(lines[i], delim) for i in idx)
        score = (hits, -prio)
        if hits and score > best_score:
            best, best_score = delim, score
    return best


def _decimal_comma_delimiter(lines: list[str], idx: list[int]) -> str | None:
    """The delimiter (';', tab or whitespace) of rows like ``0,1;0,5`` (decimal commas), else None."""
    for i in idx:
        for delim in (";", "\t", "whitespace"):
            fields = [f for f in _head_fields(lines[i], delim) if f]
            if (len(fields) >= 2 and all(_NUMBER.match(f) or _DECIMAL_COMMA.match(f) for f in fields)
                    and any(_DECIMAL_COMMA.match(f) for f in fields)):
                return delim
    return None


def _decimal_points(lines: list[str], delim: str) -> tuple[list[str], int]:
    """Rewrite the decimal commas of the all-numeric rows split by ``delim``; return (lines, rows changed)."""
    out, changed = [], 0
    for line in lines:
        fields = _split(line, delim)
        cells = [f for f in fields if f]
        if (len(cells) >= 2 and all(_NUMBER.match(f) or _DECIMAL_COMMA.match(f) or f.lower() in _NA_SET for f in cells)
                and any(_DECIMAL_COMMA.match(f) for f in cells)):
            fields = [f.replace(",", ".") if _DECIMAL_COMMA.match(f) else f for f in fields]
            line = (" " if delim == "whitespace" else delim).join(fields)
            changed += 1
        out.append(line)
    return out, changed


def _raise_no_data(path: str, lines: list[str], body: list[int]):
    if len(body) == 1:
        got = f"only a header row (line {body[0] + 1})"
    else:
        got = f"{len(body)} lines of text and no row of numbers"
    raise SEDFormatError(
        f"SED file {path!r} has a header but no data rows: it must hold rows of numbers below its "
        f"header row; got {got} instead."
    )


def _find_header(path: str, lines: list[str], lo: int, m: int, delim: str, ncols: int) -> _Header:
    """Find the header of the block whose first full data row is ``m`` (0-based)."""
    if delim == "whitespace" and (wrapped := _wrapped_header(path, lines, lo, m)) is not None:
        return wrapped
    first_data = m
    j = m - 1
    while j >= lo:
        s = lines[j].strip()
        if not s or _is_comment(s):
            j -= 1
            continue
        if _is_rule(s):
            k = j - 1
            while k >= lo and not lines[k].strip():
                k -= 1
            if k >= lo and _is_body(lines[k].strip()) and not _is_data_line(lines[k], delim):
                return _header_from_lines(path, lines, k, delim, ncols, first_data, lo, rule=True)
            j -= 1
            continue
        if _is_data_line(lines[j], delim):
            first_data = j
            j -= 1
            continue
        if _FOOTER.match(s):
            _raise_summary_only(path, lines, j, first_data)
        return _header_from_lines(path, lines, j, delim, ncols, first_data, lo, rule=False)
    # No text line above the data: COMSOL puts the names on the last '%' line.
    for k in range(first_data - 1, lo - 1, -1):
        s = lines[k].strip()
        if s and _is_comment(s):
            text = _COMMENT_STRIP.sub("", s, count=1)
            names = _names_for(text, delim, ncols, lines, first_data)
            if s.startswith("%") or (names is not None and ncols >= 2):
                if names is None:
                    _raise_header_count(path, k + 1, ncols, text, delim, first_data)
                return _Header(names, k + 1, s, first_data, from_comment=True)
            break
    raise SEDFormatError(
        f"SED file {path!r} must have a header row naming its {ncols} columns above the first data "
        f"row (line {first_data + 1}); got none instead."
    )


def _wrapped_header(path: str, lines: list[str], lo: int, m: int) -> _Header | None:
    """The header of a wrapped Abaqus table whose first record starts at line ``m`` (0-based), or None
    (:func:`~afferent.io._csv_lines._wrapped_names`)."""
    found = _wrapped_names(path, lines, lo, m)
    if found is None:
        return None
    names, wrap, top, last = found
    return _Header(names, last + 1, lines[last].strip(), m, n_lines=last - top + 1, wrap=wrap)


def _starts_with_number(stripped: str) -> bool:
    c = stripped[:1]
    return c in _DIGITS or (c in _SIGNS and stripped[1:2] in _DIGITS)


def _raise_summary_only(path: str, lines: list[str], footer: int, first_data: int):
    """The first row of numbers lies in a summary (a footer such as MAPDL's ``MINIMUM VALUES``): no data above it."""
    raise SEDFormatError(
        f"SED file {path!r} must hold data rows above its summary; got none: the first row of numbers (line "
        f"{first_data + 1}: {_quote(lines[first_data].strip())}) belongs to the summary {_quote(lines[footer].strip())} "
        f"(line {footer + 1}) instead."
    )


def _names_for(text: str, delim: str, ncols: int, lines: list[str], first_data: int) -> list[str] | None:
    if delim == "whitespace":
        spans = _whitespace_names(text, ncols)
        return None if spans is None else [t for _, _, t in spans]
    if '"' not in text and abs(_count_fields(text, delim) - ncols) > 1:
        return None  # without quotes each delimiter parts two names: too many or too few (cheap on a long line)
    names = _delimited_names(text, delim)
    if len(names) == ncols + 1 and names[-1] == "":
        names = names[:-1]  # trailing delimiter on the header row only
    elif len(names) + 1 == ncols and _split(lines[first_data].rsplit(delim, 1)[-1], delim) == [""]:
        names = names + [""]  # trailing delimiter on the data rows only
    return names if len(names) == ncols else None


def _raise_header_count(path, line_no, ncols, text, delim, first_data):
    if delim == "whitespace":
        got = [t for _, _, t in _spans(text, _WS_TOKEN, True, limit=_MANY_NAMES)]
    else:
        got = _delimited_names(text, delim, limit=_MANY_NAMES)
    many = len(got) > _MANY_NAMES
    n, listed = (f"more than {_MANY_NAMES:,}", _join_names(got[:8]) + ", ...") if many else (len(got), _join_names(got))
    raise SEDFormatError(
        f"The header row (line {line_no}) of SED file {path!r} must name each of the {ncols} columns "
        f"of the first data row (line {first_data + 1}); got {n} names ({listed}) instead."
    )


def _header_from_lines(path, lines, k, delim, ncols, first_data, lo, *, rule: bool) -> _Header:
    """Names from line ``k``; with a dashed rule below it (Abaqus), or when line ``k`` only holds
    qualifiers (``Label  @Loc 1``), the line above is joined column by column."""
    text = lines[k].strip()
    units = None if rule else _units_row(lines[k], delim, ncols)
    if units is not None:  # 'x y z sed' over 'mm mm mm MPa'
        j = k - 1
        while j >= lo and not lines[j].strip():
            j -= 1
        if j >= lo and _is_body(lines[j].strip()) and not _is_data_line(lines[j], delim):
            upper = lines[j] if delim == "whitespace" else lines[j].strip()
            names = _names_for(upper, delim, ncols, lines, first_data)
            if names is not None:
                names = [_with_unit(path, n, u, k + 1) for n, u in zip(names, units)]
                return _Header(names, j + 1, lines[j].strip(), first_data, units_line=k + 1)
    single = _whitespace_names(lines[k], ncols) if delim == "whitespace" else None
    partial = single is None or any(not _LOC.sub("", t).strip() for _, _, t in single)
    if (rule or partial) and delim == "whitespace" and ncols >= 2 and k - 1 >= lo:
        upper = lines[k - 1]
        if _is_body(upper.strip()) and not _is_data_line(upper, delim):
            names = _align_two_lines(upper, lines[k], ncols)
            if names is not None:
                return _Header(names, k + 1, text, first_data, n_lines=2)
    names = _names_for(lines[k] if delim == "whitespace" else text, delim, ncols, lines, first_data)
    if names is None:
        _raise_header_count(path, k + 1, ncols, text, delim, first_data)
    return _Header(names, k + 1, text, first_data)


def _units_row(line: str, delim: str, ncols: int) -> list[str | None] | None:
    """The units of a units row (``mm,mm,mm,MPa`` or ``[mm] [mm] [MPa]``), or None if ``line`` is not one.

    Every field must be a unit :func:`afferent.units.parse_unit` knows, or empty / ``-``.
    """
    if _count_fields(line, delim) != ncols:
        return None
    fields = line.split() if delim == "whitespace" else _split(line, delim)
    out: list[str | None] = []
    for f in fields:
        t = f.strip()
        if t[:1] in ("(", "[") and t[-1:] in (")", "]"):
            t = t[1:-1].strip()
        if t in ("", "-"):
            out.append(None)
        elif parse_unit(t) is None:
            return None
        else:
            out.append(t)
    return out if any(out) else None


def _with_unit(path: str, name: str, unit: str | None, line_no: int) -> str:
    if unit is None:
        return name
    base, own = split_unit(name)
    if own is None:
        return f"{name} ({unit})"
    if (parse_unit(own) or own) != (parse_unit(unit) or unit):
        raise SEDFormatError(
            f"Column {base!r} of SED file {path!r} must state one unit; got {own!r} in its name and "
            f"{unit!r} in the units row (line {line_no}) instead."
        )
    return name


def _parse_table(path: str, lines: list[str], sep: str | None, notes: list[str]) -> _Columns:
    body = list(islice(_body_lines(lines), _SNIFF_LINES))
    if not body:
        n_comment = sum(bool(line.strip()) for line in lines)
        got = ("0 bytes" if not lines else "only blank lines" if not n_comment
               else f"only {_plural(n_comment, 'comment line')}")
        raise SEDFormatError(
            f"SED file {path!r} is empty: it must hold a header row and data rows; got {got} instead."
        )
    delim = sep
    comma_delim = _decimal_comma_delimiter(lines, body) if sep in (None, ";", "\t", "whitespace") else None
    if comma_delim is not None and sep in (None, comma_delim):
        lines, changed = _decimal_points(lines, comma_delim)
        notes.append(f"read decimal commas as decimal points in {_plural(changed, 'row')} ({_SEP_NAMES[comma_delim]} "
                     "delimiter)")
        delim = comma_delim
    if delim is None:
        delim = _sniff(lines, body)
        every = None
        if delim is None and len(body) == _SNIFF_LINES:  # a very long preamble: sniff from its first row of numbers
            every = list(_body_lines(lines))
            first = next((k for k, i in enumerate(every) if _is_data_line_any(lines[i])), None)
            if first is not None:
                delim = _sniff(lines, every[first:first + _SNIFF_LINES])
        if delim is None:
            _raise_no_data(path, lines, every if every is not None else list(_body_lines(lines)))
        notes.append(f"detected delimiter: {_SEP_NAMES[delim]}")

    data_idx = list(islice((i for i in _body_lines(lines) if _is_data_line(lines[i], delim)), _SNIFF_LINES))
    if not data_idx:
        _raise_no_data(path, lines, list(_body_lines(lines)))
    counts = Counter(_count_fields(lines[i], delim) for i in data_idx)
    ncols = counts.most_common(1)[0][0]
    m = next(i for i in data_idx if _count_fields(lines[i], delim) == ncols)
    wrapped = _wrapped_header(path, lines, 0, data_idx[0]) if delim == "whitespace" else None
    if wrapped is not None:  # records over several lines: the first line's count finds later blocks
        header, ncols = wrapped, wrapped.wrap[0]
    else:
        header = _find_header(path, lines, 0, m, delim, ncols)
    n_pre = sum(1 for line in lines[: header.line - header.n_lines] if line.strip())
    meta = _comsol_meta(lines[: header.first_data], header.line)
    if header.from_comment:
        notes.append(f"column names taken from the comment line {header.line}")
    if header.units_line:
        notes.append(f"units taken from the units row (line {header.units_line})")
    if n_pre > 0:
        first = header.line - header.n_lines + 1
        notes.append(f"skipped {_plural(n_pre, 'comment or preamble line')} above the header (line {first})")

    if (where := _report_position_note(lines, header.line - header.n_lines)) is not None:
        notes.append(where)
    rows, row_lines, tally, frames = _collect_rows(path, lines, header, delim, ncols)
    if header.wrap:
        rows, row_lines = _join_wrapped(path, rows, row_lines, header.wrap, (header.line - header.n_lines + 1, header.line))
        frames = [(start // len(header.wrap), info) for start, info in frames]
        notes.append(f"joined each record's {len(header.wrap)} lines of a wrapped table "
                     f"({' + '.join(map(str, header.wrap))} values; column titles in {len(header.wrap)} parts)")
    n_records, times = _frame_records(path, frames, len(rows), notes)
    if tally["footer"]:
        notes.append(f"dropped {_plural(tally['footer'], 'footer row')} ({_FOOTER_WORDS})")
    if tally["blocks"] > n_records:
        per = " in each frame" if n_records > 1 else ""
        notes.append(f"joined {tally['blocks'] // n_records} report blocks with identical columns{per}")
    if tally["trailing"]:
        notes.append(f"ignored {_plural(tally['trailing'], 'text line')} after the last footer")
    if tally["repeat"]:
        notes.append(f"skipped {_plural(tally['repeat'], 'repeated header row')}")
    if tally["inside"]:
        notes.append(f"skipped {_plural(tally['inside'], 'comment or rule line')} among the data rows")

    names = [_LOC.sub("", n).strip() for n in header.names]
    names = [re.sub(r"\s+", " ", n) for n in names]
    if names != [re.sub(r"\s+", " ", n.strip()) for n in header.names]:
        notes.append("removed Abaqus position qualifiers ('@Loc N') from column names")
    headers, values = _read_rows(path, rows, row_lines, delim, names, header.line, notes)
    if tally["blocks"] > 1:
        _add_parts(lines, np.asarray(row_lines), headers, values, notes, n_records)
    if n_records > 1:
        _check_frame_labels(path, headers, values, row_lines, n_records)
    return _Columns(headers, values, np.asarray(row_lines), header.line, meta, notes, n_records, times)


def _comsol_meta(pre: list[str], header_line: int) -> dict[str, tuple[str, int]]:
    """``% Key,value`` lines above the header: ``{'length unit': ('mm', line)}``."""
    meta: dict[str, tuple[str, int]] = {}
    for k, line in enumerate(pre):
        s = line.strip()
        if not s.startswith("%") or k + 1 == header_line:
            continue
        m = _META.match(_COMMENT_STRIP.sub("", s, count=1))
        if m:
            meta[m.group("key").strip().lower()] = (m.group("val").strip().strip("\"'"), k + 1)
    return meta


def _collect_rows(path, lines, header: _Header, delim, ncols):
    """Data rows of every block, skipping blanks, comments, footers and repeated headers.

    Also returns, per block, its first row and the Abaqus frame stated above it
    (:func:`~afferent.io._csv_lines._report_frame`). ``ncols``: values on a block's first data line.
    """
    rows: list[str] = []
    row_lines: list[int] = []
    tally = Counter(blocks=1)
    frames = [(0, _report_frame(lines, 0, header.line - header.n_lines))]
    n = len(lines)
    i = header.first_data
    while True:
        while i < n:
            line = lines[i]
            s = line.lstrip()
            c = s[:1]
            if c in _DIGITS or (c in _SIGNS and s[1:2] in _DIGITS):  # fast path: a number
                rows.append(line)
                row_lines.append(i + 1)
                i += 1
                continue
            s = s.rstrip()
            if not s:
                pass
            elif _is_comment(s) or _is_rule(s):
                tally["inside"] += 1
            elif _FOOTER.match(s):
                break
            elif s == header.text:
                tally["repeat"] += 1
            else:
                rows.append(line)
                row_lines.append(i + 1)
            i += 1
        if i >= n:
            break
        # Footer rows, then maybe another block of the same report. Lines of a summary that start with a word
        # (MAPDL's 'MINIMUM VALUES' / 'NODE  1  1' / 'VALUE  -0.2  -91.') are footer rows too.
        j, after, next_m, lo, in_footer = i, [], None, i, False
        while j < n:
            s = lines[j].strip()
            if _FOOTER.match(s) or (lo == j and s and not _starts_with_number(s) and _is_data_line(lines[j], delim)):
                tally["footer"] += 1
                after, lo, in_footer = [], j + 1, True
            elif in_footer and header.wrap and _is_data_line(lines[j], delim):
                lo = j + 1  # a wrapped footer's continuation line
            elif not s and lo == j:
                lo = j + 1
            elif _is_body(s):
                in_footer = False
                if _is_data_line(lines[j], delim) and _count_fields(lines[j], delim) == ncols:
                    next_m = j
                    break
                after.append(j)
            j += 1
        if next_m is None:
            tally["trailing"] += len(after)
            break
        nxt = _find_header(path, lines, lo, next_m, delim, ncols)
        if [_LOC.sub("", a).strip() for a in nxt.names] != [_LOC.sub("", a).strip() for a in header.names]:
            raise SEDFormatError(
                f"SED file {path!r} must hold one table, or report blocks with the same columns; got a "
                f"block with columns {_join_names(nxt.names)} at line {nxt.line} after columns "
                f"{_join_names(header.names)} instead. Export one region or variable set per file."
            )
        tally["blocks"] += 1
        frames.append((len(rows), _report_frame(lines, lo, nxt.line - nxt.n_lines)))
        i = nxt.first_data
    return rows, row_lines, tally, frames


def _field_counts(text: str, rows: list[str], delim: str) -> np.ndarray:
    """Number of fields on each row of ``text`` (the rows joined by newlines).

    pandas pads short rows silently, so rows are counted here: quoted comma/semicolon/tab
    rows with :mod:`csv`, others by counting delimiters (or whitespace runs, as pandas' ``\\s+``
    does: spaces and tabs) in the encoded text with numpy.
    """
    n = len(rows)
    if delim != "whitespace" and '"' in text:
        counts = [len(f) for f in csv.reader(rows, delimiter=delim, skipinitialspace=True)]
        if len(counts) != n:  # a quote left open runs across rows: no row count can be trusted
            return None
        return np.asarray(counts, dtype=np.int64)
    buf = np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
    newlines = np.flatnonzero(buf == 10)
    if delim == "whitespace":
        gap = (buf == 32) | (buf == 9) | (buf == 10)
        starts = np.flatnonzero(gap[:-1] & ~gap[1:]) + 1
        if buf.size and not gap[0]:
            starts = np.concatenate(([0], starts))
        return np.bincount(np.searchsorted(newlines, starts), minlength=n)
    hits = np.flatnonzero(buf == ord(delim))
    return np.bincount(np.searchsorted(newlines, hits), minlength=n) + 1


def _parse_rows(text: str, delim: str, ncols: int):
    """The rows as a DataFrame of ``ncols`` columns (pandas' C parser, numbers as float64)."""
    return pd.read_csv(
        io.StringIO(text),
        sep=r"\s+" if delim == "whitespace" else delim,
        header=None,
        names=list(range(ncols)),
        index_col=False,
        keep_default_na=False,
        na_values=_NA_VALUES,
        skip_blank_lines=False,
        skipinitialspace=delim != "whitespace",
        engine="c",
        **_FLOAT_KW,
    )


def _read_rows(path, rows, row_lines, delim, names, header_line, notes):
    """Parse ``rows`` with pandas; return (headers, float64 columns), dropping text columns."""
    ncols = len(names)
    text = "\n".join(rows)
    counts = _field_counts(text, rows, delim)
    if counts is None:
        raise SEDFormatError(
            f"SED file {path!r} has a quoted field that is never closed (a '\"' without its partner) in the rows "
            f"from line {row_lines[0]} on; quotes must open and close on the same line."
        )
    bad = np.flatnonzero(counts != ncols)
    if bad.size:
        k = int(bad[0])
        raise SEDFormatError(
            f"Line {row_lines[k]} of SED file {path!r} must have {ncols} values, one per column of the "
            f"header (line {header_line}); got {int(counts[k])} instead."
        )
    try:
        frame = _parse_rows(text, delim, ncols)
    except pd.errors.ParserError as err:
        raise SEDFormatError(
            f"SED file {path!r}: the rows from line {row_lines[0]} on could not be parsed as a table: {err}"
        ) from err
    if len(frame) != len(rows):  # e.g. a quoted field spanning lines
        raise SEDFormatError(
            f"SED file {path!r} must have one table row per line; got {len(frame)} rows from "
            f"{len(rows)} lines instead (check for unbalanced quotes)."
        )
    headers: list[str] = []
    values: list[np.ndarray] = []
    for k, name in enumerate(names):
        col = frame[k]
        if pd.api.types.is_bool_dtype(col.dtype):  # 'True'/'False' cells: text, not numbers
            col = col.astype(str)
        if pd.api.types.is_numeric_dtype(col.dtype):
            num = pd.to_numeric(col).to_numpy(dtype=np.float64)
            bad_rows = np.empty(0, dtype=np.int64)
        else:
            num = pd.to_numeric(col, errors="coerce").to_numpy(dtype=np.float64, na_value=np.nan)
            raw = col.to_numpy(dtype=object)
            cand = np.flatnonzero(np.isnan(num))
            bad_rows = np.array(
                [r for r in cand if not _is_missing(raw[r])], dtype=np.int64
            )
        n_valid = len(rows) - int(np.isnan(num).sum())
        if bad_rows.size:
            r = int(bad_rows[0])
            cell = str(raw[r]).strip()
            if n_valid == 0 and canonical(name) in PART_ALIASES:  # part instance names: codes, the names in a note
                codes, uniq = pd.factorize(col.astype(str).str.strip())
                headers.append(name), values.append(codes.astype(np.float64)), notes.append(part_note(name, uniq))
                continue
            if n_valid == 0 and name and not _NUMBERISH.match(cell):
                notes.append(f"dropped column {_quote(name)}: it holds text, not numbers (e.g. {_quote(cell)})")
                continue
            label = name or f"#{k + 1}"
            raise SEDFormatError(
                f"Column {_quote(label)} of SED file {path!r} must hold numbers; got {_quote(cell)} "
                f"at line {row_lines[r]} instead."
            )
        if not name:
            if n_valid == 0:
                notes.append(f"dropped unnamed empty column {k + 1} (trailing delimiter)")
                continue
            if k == 0 and np.array_equal(num, np.arange(num.size)):
                notes.append("dropped unnamed first column 0, 1, 2, ... (a pandas index)")
                continue
            raise SEDFormatError(
                f"The header row (line {header_line}) of SED file {path!r} must name every column; got "
                f"an empty name for column {k + 1} instead."
            )
        headers.append(name)
        values.append(num)
    return headers, values


def _is_missing(cell) -> bool:
    if cell is None or (isinstance(cell, float) and np.isnan(cell)) or cell is pd.NA:
        return True
    return str(cell).strip().lower() in _NA_SET
