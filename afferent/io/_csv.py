"""Text-table FE exports (CSV, TXT, report-like text, FEBio logfiles, CalculiX .dat) -> RawExport.

This reader only turns bytes into numbers. It keeps the export's own column names and
units; which column is the SED, which are coordinates or tensor components, unit
conversion and physical checks are done by :mod:`afferent.io._assemble`.

Layouts handled (see :ref:`fe-checklist` and each tool's section of the FE-export page):

* delimiters: comma, semicolon, tab or runs of whitespace, sniffed on the first data rows;
* comment lines starting with ``#``, ``%`` (COMSOL), ``**`` (Abaqus) or ``!``, blank lines,
  BOM, CRLF, gzip compression (detected by magic bytes, not by the file name);
* free-text preambles above the header row, a units row below it, and Abaqus
  ``.rpt``-like reports (a two-line column title over a dashed rule,
  ``Minimum``/``Maximum``/``At Node``/``Total`` footers, several blocks with the same columns);
* COMSOL spreadsheets: ``% Key,value`` lines, the last ``%`` line holding the column names,
  ``% Length unit,mm``, units in parentheses, per-step columns ``solid.Ws (J/m^3) @ t=0.02``;
* a time column (rows grouped by time value), several files (one per time step);
* FEBio logfiles (``*Step``/``*Time``/``*Data`` records, one record per time step);
* CalculiX ``.dat`` blocks (``stresses (elem, integ.pnt.,sxx,...) for set X and time t``).

Parsing of the rows themselves is done by :func:`pandas.read_csv`; this module only finds
where the header and the data rows are, counts fields, and checks what pandas returns.
"""

from __future__ import annotations

import codecs
import csv
import gzip
import io
import os
import re
import zlib
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import islice

import numpy as np
import pandas as pd

from .._validation import check_option, suggest
from ..exceptions import SEDFormatError
from ..units import TIME_UNITS, parse_unit
from ._columns import COORD_ALIASES, TIME_ALIASES, canonical, split_unit
from ._raw import RawArray, RawExport

__all__ = ["read_csv"]

# --------------------------------------------------------------------------------------
# Line classification
# --------------------------------------------------------------------------------------

#: Line prefixes that mark a comment (COMSOL ``%``, Abaqus ``**``, Fortran-style ``!``).
COMMENT_PREFIXES: tuple[str, ...] = ("#", "%", "**", "!")

#: Delimiter choices for ``sep`` (``None`` means sniff).
SEPARATORS: tuple[str | None, ...] = (None, ",", ";", "\t", "whitespace")
_SEP_ALIASES = {" ": "whitespace", r"\s+": "whitespace", "tab": "\t", "\\t": "\t"}
_SEP_NAMES = {",": "comma ','", ";": "semicolon ';'", "\t": "tab", "whitespace": "runs of whitespace"}
_SNIFF_ORDER = ("\t", ";", ",", "whitespace")  # tie-break order when several delimiters fit
_SNIFF_LINES = 200

_FOOTER = re.compile(r"^\s*(?:minimum|maximum|total|at\s+node|at\s+element)\b", re.IGNORECASE)
_RULE_CHARS = re.compile(r"^[\s\-=+|]+$")
_NUMBER = re.compile(
    r"^[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)$", re.IGNORECASE
)
#: Cells that look like numbers pandas cannot read: Fortran ``D`` exponents, decimal
#: commas, CalculiX numbers that lost their ``E`` (``1.234-100``).
_NUMBERISH = re.compile(r"^[+-]?(?:\d+[.,]?\d*|[.,]\d+)(?:[eEdD]?[+-]\d+|[dD]\d+)?$")
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+(?:[eE][+-]?\d+)?$")
#: Cells read as missing values (NaN), on top of empty cells.
_NA_VALUES = ["", "nan", "NaN", "NAN", "-nan", "-NaN", "+nan", "+NaN", "NA", "N/A", "n/a", "null", "NULL"]
_NA_SET = frozenset(v.lower() for v in _NA_VALUES)
#: COMSOL-style per-step column suffix: ``solid.Ws (J/m^3) @ t=0.02``.
_SUFFIX = re.compile(r"^(?P<base>.*?)\s*@\s*(?P<var>[A-Za-z_][\w.]*)\s*=\s*(?P<val>\S+)\s*$")
#: Abaqus position qualifier in report column titles: ``SENER @Loc 1``.
_LOC = re.compile(r"@\s*Loc\s*\d+", re.IGNORECASE)
#: ``% Key,value`` (COMSOL .csv) or ``% Key: value`` (COMSOL .txt) metadata lines.
_META = re.compile(r"^(?P<key>[A-Za-z][^,;:\t=]*?)\s*[,;:\t=]\s*(?P<val>.*?)\s*$")
#: FEBio logfile record keys: ``*Step  = 3``, ``*Time  = 0.3``, ``*Data  = sed;sx``.
_FEBIO_KEY = re.compile(r"^\s*\*\s*(?P<key>[A-Za-z][A-Za-z ]*?)\s*=\s*(?P<val>.*?)\s*$")
_FEBIO_START = re.compile(r"^[ \t]*\*[ \t]*Step[ \t]*=", re.IGNORECASE | re.MULTILINE)
#: CalculiX .dat block title: `` stresses (elem, integ.pnt.,sxx,...) for set EALL and time  0.1E+01``.
_CCX_TITLE = re.compile(
    r"^\s*(?P<what>[A-Za-z][A-Za-z0-9 .'/-]*?)\s*\((?P<cols>[^()]*)\)\s*for\s+set\s+(?P<set>\S+)"
    r"\s+and\s+time\s+(?P<time>\S+)\s*$",
    re.IGNORECASE,
)
_CCX_START = re.compile(
    r"^[ \t]*[A-Za-z][A-Za-z0-9 .'/-]*\([^()\n]*\)[ \t]*for[ \t]+set[ \t]+\S+[ \t]+and[ \t]+time[ \t]+\S+[ \t]*$",
    re.IGNORECASE | re.MULTILINE,
)
_CCX_LABELS = frozenset({"elem", "element", "node", "integpnt"})  # canonical label columns of .dat blocks
_COMMENT_STRIP = re.compile(r"^\s*(?:\*\*|[#%!])\s?")
_UNIT_ONLY = re.compile(r"^[\(\[][^\)\]]*[\)\]]$")
_WIDE_TOKEN = re.compile(r"\S+(?: \S+)*")  # tokens separated by two or more spaces or a tab
_WS_TOKEN = re.compile(r"\S+")

_DIGITS = frozenset("0123456789")  # a line starting with a digit (or -1, +1, .5) is a data row
_SIGNS = frozenset("+-.")
_COORD_NAMES = frozenset().union(*COORD_ALIASES.values())
_FOOTER_WORDS = "Minimum/Maximum/At Node/At Element/Total"
# pandas < 3 needs round_trip to read floats exactly; pandas 3 reads them exactly by default
# and deprecates the argument.
_FLOAT_KW = {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}


def _is_comment(stripped: str) -> bool:
    return stripped.startswith(COMMENT_PREFIXES)


def _is_rule(stripped: str) -> bool:
    """A dashed rule such as ``-------`` or ``=====`` (at least three dashes or equals signs)."""
    return bool(_RULE_CHARS.match(stripped)) and stripped.count("-") + stripped.count("=") >= 3


def _is_body(stripped: str) -> bool:
    return bool(stripped) and not _is_comment(stripped) and not _is_rule(stripped)


def _split(line: str, delim: str) -> list[str]:
    """Quick split used to classify lines (never to read values; pandas does that)."""
    if delim == "whitespace":
        return line.split()
    return [f.strip().strip("\"'").strip() for f in line.split(delim)]


def _is_data(fields: list[str]) -> bool:
    """A data row: more than half of its non-empty fields are numbers.

    Number-like cells pandas cannot read (``1.0D-03``) count as numbers here, so that such
    rows reach the numeric check and raise there, naming the cell.
    """
    n_num = n_full = 0
    for f in fields:
        if f:
            n_full += 1
            n_num += bool(_NUMBER.match(f) or _NUMBERISH.match(f))
    return n_num > 0 and 2 * n_num > n_full


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _join_names(names) -> str:
    names = [repr(n) for n in names]
    if len(names) > 8:
        names = names[:8] + [f"... ({len(names) - 8} more)"]
    return ", ".join(names)


# --------------------------------------------------------------------------------------
# Bytes -> text
# --------------------------------------------------------------------------------------


def _load_text(path: str) -> tuple[str, list[str]]:
    """Read ``path``, decompress gzip, decode; raise on a missing or binary file."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"SED file {path!r} not found.")
    if os.path.isdir(path):
        raise SEDFormatError(f"SED file {path!r} must be a file; got a directory instead.")
    with open(path, "rb") as fh:
        data = fh.read()
    notes: list[str] = []
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as err:
            raise SEDFormatError(
                f"SED file {path!r} must be a complete gzip stream; got a damaged one instead ({err})."
            ) from err
        notes.append("decompressed gzip data")
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        try:
            return data.decode("utf-16"), notes + ["decoded UTF-16 text"]
        except UnicodeDecodeError as err:
            raise SEDFormatError(
                f"SED file {path!r} must be a text table; got undecodable UTF-16 bytes instead ({err})."
            ) from err
    head = data[:4096]
    if b"\x00" in head or (data and _binary_fraction(head) > 0.05):
        raise SEDFormatError(
            f"SED file {path!r} must be a text table (CSV, TXT or report); got binary data instead "
            f"(first bytes {data[:8]!r})."
        )
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
        notes.append("decoded as Latin-1 (the file is not valid UTF-8)")
    return text, notes


def _binary_fraction(head: bytes) -> float:
    """Fraction of control bytes other than tab, newline, carriage return and form feed."""
    bad = sum(1 for b in head if b < 32 and b not in (9, 10, 12, 13))
    return bad / max(len(head), 1)


# --------------------------------------------------------------------------------------
# Header names
# --------------------------------------------------------------------------------------


def _spans(line: str, pattern: re.Pattern, merge_units: bool) -> list[tuple[int, int, str]]:
    out: list[tuple[int, int, str]] = []
    for m in pattern.finditer(line):
        tok = m.group(0)
        if merge_units and out and _UNIT_ONLY.match(tok):
            s, _, prev = out[-1]
            out[-1] = (s, m.end(), f"{prev} {tok}")
        else:
            out.append((m.start(), m.end(), tok))
    return out


def _whitespace_names(line: str, ncols: int) -> list[tuple[int, int, str]] | None:
    """Split a whitespace header into ``ncols`` names, or None.

    Tried in order: single spaces (a lone ``(unit)`` joins the name before it), then
    two or more spaces / tabs (names that contain single spaces, ``X Location (mm)``).
    """
    for pattern, merge in ((_WS_TOKEN, True), (_WIDE_TOKEN, False)):
        spans = _spans(line, pattern, merge)
        if len(spans) == ncols:
            return spans
    return None


def _delimited_names(text: str, delim: str) -> list[str]:
    try:
        row = pd.read_csv(
            io.StringIO(text), sep=delim, header=None, dtype=object, na_filter=False,
            skipinitialspace=True, engine="c",
        )
        names = ["" if v is None else str(v) for v in row.iloc[0].tolist()]
    except (pd.errors.ParserError, pd.errors.EmptyDataError, IndexError):
        names = text.split(delim)
    return [n.strip().strip("\"'").strip() for n in names]


def _align_two_lines(upper: str, lower: str, ncols: int) -> list[str] | None:
    """Join a two-line column title (``Node``/``Label``, ``SENER``/``@Loc 1``) by position."""
    base = _whitespace_names(upper, ncols)
    if base is None:
        return None
    parts = [[tok] for _, _, tok in base]
    for s2, e2, tok in _spans(lower, _WIDE_TOKEN, False):
        overlaps = [max(0, min(e1, e2) - max(s1, s2)) for s1, e1, _ in base]
        if max(overlaps) > 0:
            k = int(np.argmax(overlaps))
        else:
            centre = (s2 + e2) / 2
            k = int(np.argmin([abs((s1 + e1) / 2 - centre) for s1, e1, _ in base]))
        parts[k].append(tok)
    return [" ".join(p) for p in parts]


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
    n_lines: int = 1  # 2 for a two-line column title
    units_line: int | None = None  # 1-based line of a units row below the names


@dataclass
class _Columns:
    """Parsed, numeric columns of one file (one entry per kept column)."""

    headers: list[str]
    values: list[np.ndarray]
    row_lines: np.ndarray
    header_line: int
    meta: dict[str, tuple[str, int]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _body_lines(lines: list[str], start: int = 0):
    """Indices of lines that are neither blank, comments nor dashed rules."""
    for i in range(start, len(lines)):
        if _is_body(lines[i].strip()):
            yield i


def _sniff(lines: list[str], idx: list[int]) -> str | None:
    """The delimiter under which most of the lines ``idx`` are data rows (None if none is)."""
    best, best_score = None, (0, 0)
    for prio, delim in enumerate(_SNIFF_ORDER):
        hits = sum(_is_data(_split(lines[i], delim)) for i in idx)
        score = (hits, -prio)
        if hits and score > best_score:
            best, best_score = delim, score
    return best


def _decimal_comma_delimiter(lines: list[str], idx: list[int]) -> str | None:
    """The delimiter (';', tab or whitespace) of rows like ``0,1;0,5`` (decimal commas), else None."""
    for i in idx:
        for delim in (";", "\t", "whitespace"):
            fields = [f for f in _split(lines[i], delim) if f]
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
            if k >= lo and _is_body(lines[k].strip()) and not _is_data(_split(lines[k], delim)):
                return _header_from_lines(path, lines, k, delim, ncols, first_data, lo, rule=True)
            j -= 1
            continue
        if _is_data(_split(lines[j], delim)):
            first_data = j
            j -= 1
            continue
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


def _names_for(text: str, delim: str, ncols: int, lines: list[str], first_data: int) -> list[str] | None:
    if delim == "whitespace":
        spans = _whitespace_names(text, ncols)
        return None if spans is None else [t for _, _, t in spans]
    names = _delimited_names(text, delim)
    if len(names) == ncols + 1 and names[-1] == "":
        names = names[:-1]  # trailing delimiter on the header row only
    elif len(names) + 1 == ncols and _split(lines[first_data], delim)[-1] == "":
        names = names + [""]  # trailing delimiter on the data rows only
    return names if len(names) == ncols else None


def _raise_header_count(path, line_no, ncols, text, delim, first_data):
    got = [t for _, _, t in _spans(text, _WS_TOKEN, True)] if delim == "whitespace" else _delimited_names(text, delim)
    raise SEDFormatError(
        f"The header row (line {line_no}) of SED file {path!r} must name each of the {ncols} columns "
        f"of the first data row (line {first_data + 1}); got {len(got)} names ({_join_names(got)}) instead."
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
        if j >= lo and _is_body(lines[j].strip()) and not _is_data(_split(lines[j], delim)):
            upper = lines[j] if delim == "whitespace" else lines[j].strip()
            names = _names_for(upper, delim, ncols, lines, first_data)
            if names is not None:
                names = [_with_unit(path, n, u, k + 1) for n, u in zip(names, units)]
                return _Header(names, j + 1, lines[j].strip(), first_data, units_line=k + 1)
    single = _whitespace_names(lines[k], ncols) if delim == "whitespace" else None
    partial = single is None or any(not _LOC.sub("", t).strip() for _, _, t in single)
    if (rule or partial) and delim == "whitespace" and ncols >= 2 and k - 1 >= lo:
        upper = lines[k - 1]
        if _is_body(upper.strip()) and not _is_data(_split(upper, delim)):
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
    fields = line.split() if delim == "whitespace" else _split(line, delim)
    if len(fields) != ncols:
        return None
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
        if delim is None and len(body) == _SNIFF_LINES:  # a very long preamble
            delim = _sniff(lines, list(_body_lines(lines)))
        if delim is None:
            _raise_no_data(path, lines, list(_body_lines(lines)))
        notes.append(f"detected delimiter: {_SEP_NAMES[delim]}")

    data_idx = list(islice((i for i in _body_lines(lines) if _is_data(_split(lines[i], delim))), _SNIFF_LINES))
    if not data_idx:
        _raise_no_data(path, lines, list(_body_lines(lines)))
    counts = Counter(len(_split(lines[i], delim)) for i in data_idx)
    ncols = counts.most_common(1)[0][0]
    m = next(i for i in data_idx if len(_split(lines[i], delim)) == ncols)

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

    rows, row_lines, tally = _collect_rows(path, lines, header, delim, ncols)
    if tally["footer"]:
        notes.append(f"dropped {_plural(tally['footer'], 'footer row')} ({_FOOTER_WORDS})")
    if tally["blocks"] > 1:
        notes.append(f"joined {tally['blocks']} report blocks with identical columns")
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
    return _Columns(headers, values, np.asarray(row_lines), header.line, meta, notes)


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
    """Data rows of every block, skipping blanks, comments, footers and repeated headers."""
    rows: list[str] = []
    row_lines: list[int] = []
    tally = Counter(blocks=1)
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
        # Footer rows, then maybe another block of the same report.
        j, after, next_m, lo = i, [], None, i
        while j < n:
            s = lines[j].strip()
            if _FOOTER.match(s):
                tally["footer"] += 1
                after, lo = [], j + 1
            elif _is_body(s):
                fields = _split(lines[j], delim)
                if _is_data(fields) and len(fields) == ncols:
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
        i = nxt.first_data
    return rows, row_lines, tally


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
            if n_valid == 0 and name and not _NUMBERISH.match(cell):
                notes.append(f"dropped column {name!r}: it holds text, not numbers (e.g. {cell!r})")
                continue
            label = name or f"#{k + 1}"
            raise SEDFormatError(
                f"Column {label!r} of SED file {path!r} must hold numbers; got {cell!r} "
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


# --------------------------------------------------------------------------------------
# FEBio logfiles
# --------------------------------------------------------------------------------------


def _parse_febio(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Split a FEBio logfile into records; return (_Columns with all rows, record sizes, times)."""
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
                cur = {"step": m.group("val"), "line": i + 1, "time": None, "data": None, "rows": []}
                records.append(cur)
            elif cur is None:
                n_pre += 1
            elif key == "time":
                cur["time"] = (m.group("val"), i + 1)
            elif key == "data":
                cur["data"] = (m.group("val"), i + 1)
            continue
        if cur is None or _is_comment(s) or s.startswith("*"):
            n_pre += cur is None
            continue
        cur["rows"].append(i)
    if n_pre:
        notes.append(f"skipped {_plural(n_pre, 'line')} before the first '*Step' record")

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

    times = None
    with_time = [rec for rec in records if rec["time"] is not None]
    if with_time and len(with_time) != len(records):
        rec = next(r for r in records if r["time"] is None)
        raise SEDFormatError(
            f"Every record of FEBio logfile {path!r} must have a '*Time' line if one has; got none in "
            f"'*Step = {rec['step']}' (line {rec['line']}) instead."
        )
    if with_time:
        times = np.empty(len(records))
        for k, rec in enumerate(records):
            try:
                times[k] = float(rec["time"][0])
            except ValueError as err:
                raise SEDFormatError(
                    f"'*Time' of FEBio logfile {path!r} must be a number; got {rec['time'][0]!r} at line "
                    f"{rec['time'][1]} instead."
                ) from err
    cols = _Columns(headers, values, np.asarray(row_lines), first["data"][1], {}, notes)
    return cols, len(records), times


# --------------------------------------------------------------------------------------
# CalculiX .dat blocks
# --------------------------------------------------------------------------------------


def _parse_ccx(path: str, lines: list[str], sep: str | None, notes: list[str]):
    """Read CalculiX ``.dat`` blocks; return (_Columns with all rows, n_times, times).

    Each block is a title line `` <what> (<names>) for set <SET> and time <t>`` followed by
    rows (:ref:`fe-calculix`). Blocks of the same ``<what>`` at the same time
    (several sets) are concatenated; different ``<what>`` (stresses, strains, internal energy
    density) are put side by side when they have the same rows, their shared columns (``elem``,
    ``integ.pnt.``) kept once; each distinct time is one time step. A block with a single value
    column names it after the block title (``'internal energy density'``, not ``'energy'``).
    """
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

    blocks = []
    for what in whats:
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
        blocks.append((what, headers, values, row_lines))

    n0 = len(blocks[0][3])
    headers: list[str] = []
    values: list[np.ndarray] = []
    owner: list[str] = []
    for what, hs, vs, row_lines in blocks:
        if len(row_lines) != n0:
            raise SEDFormatError(
                f"The blocks of CalculiX file {path!r} must have the same rows to be read side by side; got "
                f"{_plural(n0 // len(time_keys), 'row')} of '{blocks[0][0]}' and "
                f"{_plural(len(row_lines) // len(time_keys), 'row')} of '{what}' per time instead. "
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


def _unit_of(raw: str | None, name: str, notes: list[str]) -> str | None:
    """Canonical unit if :func:`afferent.units.parse_unit` knows it, else the raw text."""
    if raw is None or not raw.strip():
        return None
    unit = parse_unit(raw)
    if unit is None:
        notes.append(f"unit {raw.strip()!r} of column {name!r} is not a unit afferent knows; kept as written")
        return raw.strip()
    return unit


def _time_suffix(header: str) -> tuple[str, float | None]:
    m = _SUFFIX.match(header)
    if m and canonical(m.group("var")) in TIME_ALIASES:
        try:
            return m.group("base"), float(m.group("val"))
        except ValueError:
            pass
    return header, None


def _to_arrays(path: str, cols: _Columns, time_column: str | None, *, n_records: int = 1,
               record_times: np.ndarray | None = None) -> _FileArrays:
    notes = cols.notes
    entries = []  # (header, name, unit, t, values)
    seen: dict[tuple[str, float | None], str] = {}
    for header, vals in zip(cols.headers, cols.values):
        base, t = _time_suffix(header)
        name, raw_unit = split_unit(base)
        unit = _unit_of(raw_unit, name, notes)
        key = (name, t)
        if key in seen:
            raise SEDFormatError(
                f"Column names of SED file {path!r} must be unique once units are removed; got "
                f"{seen[key]!r} and {header!r} (both {name!r}) instead."
            )
        seen[key] = header
        entries.append((header, name, unit, t, vals))

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
    cols = _parse_table(path, lines, sep, notes)
    return _to_arrays(path, cols, time_column)


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
        ``format='csv'``, ``points=None``, ``cells=None``. Every numeric column becomes a
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
      removed, rows starting with ``Minimum``, ``Maximum``, ``At Node``, ``At Element`` or
      ``Total`` are footers and are dropped, and later blocks with the same columns are
      appended (with different columns: error). A repeat of the header line is skipped.

    Time steps come from, within one file:

    1. ``@ t=<value>`` suffixes (COMSOL): columns sharing a base name are stacked in the
       order they appear; columns without a suffix (coordinates) are repeated for every step.
    2. A time column: rows are grouped by time value in order of first appearance; every
       group must have the same number of rows; the time column itself is not in ``arrays``.
    3. FEBio logfile records (``*Step``/``*Time``/``*Data``): each record is one step; the
       column names are ``id`` followed by the ``*Data`` names split on ``;``.
    4. CalculiX ``.dat`` blocks (``stresses (elem, integ.pnt.,sxx,...) for set S and time t``):
       each time is one step; blocks of different kinds with the same rows are put side by
       side, shared label columns kept once; the single value column of a block such as
       ``internal energy density (elem, integ.pnt.,energy)`` is named after the block.

    With several files, steps are concatenated in the given order; every file must have the
    same columns and the same number of rows per step; ``times`` is None unless every file
    states its times.

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

    iterator = files
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(files, desc="Reading SED files", unit="file")
    per_file = [_read_one(p, sep, time_column) for p in iterator]
    return _merge(files, per_file)


def _merge(files: list[str], per_file: list[_FileArrays]) -> RawExport:
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
        files=tuple(files), format="csv", points=None, arrays=arrays, times=times,
        length_unit=length_unit, time_unit=time_unit, notes=_merge_notes(files, per_file),
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
