"""Text tables, first layer: bytes -> text lines, line classes (comment, rule, data), delimiters, header names.

Used by :mod:`afferent.io._csv` (the reader) and its layout modules; see there for the layouts handled.
"""

from __future__ import annotations

import codecs
import csv
import gzip
import os
import re
import zlib

import numpy as np
import pandas as pd

from ..exceptions import SEDFormatError
from ._columns import COORD_ALIASES

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
#: A line is classed (data row or text, under each delimiter) on its first 64 KiB only, so that
#: sniffing costs a bounded time per line however long the line (a 10 MB line: milliseconds).
_CLASSIFY_CHARS = 65_536
#: Error messages quote at most this many characters of a cell, name or line.
_QUOTE_CHARS = 80
#: Header names listed (and counted exactly) in an error message, at most.
_MANY_NAMES = 10_000

_FOOTER = re.compile(r"^\s*(?:minimum|maximum|total|at\s+node|at\s+element)\b", re.IGNORECASE)
_RULE_CHARS = re.compile(r"^[\s\-=+|]+$")
# The number patterns have no two ways to match the same digits (``\d+(?:\.\d*)?``, never
# ``\d+\.?\d*``): a cell of 20,000 digits followed by a letter fails in linear time, not quadratic.
_NUMBER = re.compile(
    r"^[+-]?(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)$", re.IGNORECASE
)
#: Cells that look like numbers pandas cannot read: Fortran ``D`` exponents, decimal
#: commas, CalculiX numbers that lost their ``E`` (``1.234-100``).
_NUMBERISH = re.compile(r"^[+-]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eEdD]?[+-]\d+|[dD]\d+)?$")
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+(?:[eE][+-]?\d+)?$")
#: Cells read as missing values (NaN), on top of empty cells.
_NA_VALUES = ["", "nan", "NaN", "NAN", "-nan", "-NaN", "+nan", "+NaN", "NA", "N/A", "n/a", "null", "NULL"]
_NA_SET = frozenset(v.lower() for v in _NA_VALUES)
#: COMSOL-style per-step column suffix: ``solid.Ws (J/m^3) @ t=0.02``.
_SUFFIX = re.compile(r"^(?P<base>.*)@\s*(?P<var>[A-Za-z_][\w.]*)\s*=\s*(?P<val>\S+)\s*$")
#: Abaqus position qualifier in report column titles: ``SENER @Loc 1``.
_LOC = re.compile(r"@\s*Loc\s*\d+", re.IGNORECASE)
#: ``% Key,value`` (COMSOL .csv) or ``% Key: value`` (COMSOL .txt) metadata lines.
_META = re.compile(r"^(?P<key>[A-Za-z][^,;:\t=]*)(?:\t\s*)?[,;:\t=](?P<val>.*)$")
#: FEBio logfile record keys: ``*Step  = 3``, ``*Time  = 0.3``, ``*Data  = sed;sx``.
_FEBIO_KEY = re.compile(r"^\s*\*\s*(?P<key>[A-Za-z][A-Za-z ]*)(?:\t\s*)?=\s*(?P<val>.*)$")
_FEBIO_START = re.compile(r"^[ \t]*\*[ \t]*Step[ \t]*=", re.IGNORECASE | re.MULTILINE)
#: CalculiX .dat block title: `` stresses (elem, integ.pnt.,sxx,...) for set EALL and time  0.1E+01``.
_CCX_TITLE = re.compile(
    r"^\s*(?P<what>[A-Za-z][A-Za-z0-9 .'/-]*)(?:\t\s*)?\((?P<cols>[^()]*)\)\s*for\s+set\s+(?P<set>\S+)"
    r"\s+and\s+time\s+(?P<time>\S+)\s*$",
    re.IGNORECASE,
)
_CCX_START = re.compile(
    r"^[ \t]*[A-Za-z][A-Za-z0-9 .'/-]*\([^()\n]*\)[ \t]*for[ \t]+set[ \t]+\S+[ \t]+and[ \t]+time[ \t]+\S+[ \t]*$",
    re.IGNORECASE | re.MULTILINE,
)
_CCX_LABELS = frozenset({"elem", "element", "node", "integpnt"})  # canonical label columns of .dat blocks
#: ``PRINT S    NODAL SOLUTION PER NODE`` (PRNSOL), ``PRINT S    ELEMENT SOLUTION PER ELEMENT`` (PRESOL),
#: ``PRINT F    REACTION SOLUTIONS PER NODE`` (PRRSOL), ``PRINT ELEMENT TABLE ITEMS PER ELEMENT`` (PRETAB).
_MAPDL_TITLE = re.compile(
    r"^\s*PRINT\s+(?:(?P<etable>ELEMENT\s+TABLE\s+ITEMS)|(?P<item>\S+)\s+(?P<kind>NODAL|ELEMENT|REACTION)\s+"
    r"SOLUTIONS?)\s+PER\s+(?:NODE|ELEMENT)\b", re.IGNORECASE)
#: ``LIST ALL SELECTED NODES.   DSYS=      0`` (NLIST).
_MAPDL_NLIST = re.compile(r"^\s*LIST\s+ALL\s+SELECTED\s+NODES\b[^\n]*?(?:DSYS\s*=\s*(?P<dsys>-?\d+))?\s*$",
                          re.IGNORECASE)
#: Other MAPDL lists whose rows are not results (``LIST ALL SELECTED ELEMENTS``, ``LIST CONSTRAINTS ...``): skipped.
_MAPDL_OTHER_LIST = re.compile(r"^\s*LIST\s+[A-Z]", re.IGNORECASE)
#: The page banner ``***** POST1 NODAL STRESS LISTING *****``.
_MAPDL_BANNER = re.compile(r"^\s*\*{5}\s*(?P<what>POST1\b[^*]*?LISTING)\s*\*{5}", re.IGNORECASE)
#: Where a listing starts (to detect one): a title, an NLIST title or a POST1 page banner at a line start.
_MAPDL_START = re.compile(
    r"^[ \t]*(?:PRINT[ \t]+(?:ELEMENT[ \t]+TABLE[ \t]+ITEMS|\S+[ \t]+(?:NODAL|ELEMENT|REACTION)[ \t]+SOLUTIONS?)"
    r"[ \t]+PER[ \t]|LIST[ \t]+ALL[ \t]+SELECTED[ \t]+(?:NODES|ELEMENTS)\b|\*{5}[ \t]*POST1\b[^*\n]*LISTING[ \t]*\*{5})",
    re.IGNORECASE | re.MULTILINE)
_MAPDL_STEP = re.compile(r"^\s*LOAD\s+STEP\s*=\s*(?P<ls>\d+)\s+SUBSTEP\s*=\s*(?P<sub>\d+)", re.IGNORECASE)
_MAPDL_TIME = re.compile(r"^\s*(?P<kind>TIME|FREQ)\s*=\s*(?P<t>\S+)", re.IGNORECASE)
#: Summaries after the rows: ``MINIMUM VALUES``, ``MAXIMUM VALUES``, ``MAXIMUM ABSOLUTE VALUES``, ``TOTAL VALUES``.
_MAPDL_SUMMARY = re.compile(r"^\s*(?:MINIMUM|MAXIMUM|TOTAL)\b[A-Z ]*\bVALUES\s*$", re.IGNORECASE)
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


def _head_fields(line: str, delim: str) -> list[str]:
    """The fields of the first :data:`_CLASSIFY_CHARS` characters of ``line`` (a field cut there is left out,
    unless it is the only one)."""
    if len(line) <= _CLASSIFY_CHARS:
        return _split(line, delim)
    fields = _split(line[:_CLASSIFY_CHARS], delim)
    return fields[:-1] or fields


def _count_fields(line: str, delim: str) -> int:
    """``len(_split(line, delim))``, counted by str methods (a 10 MB line: milliseconds)."""
    return len(line.split()) if delim == "whitespace" else line.count(delim) + 1


def _is_data_line(line: str, delim: str) -> bool:
    """Whether ``line`` is a data row under ``delim`` (:func:`_is_data` of its first fields)."""
    return _is_data(_head_fields(line, delim))


#: What every cell :data:`_NUMBER` matches holds: a digit, or the letters of nan / inf.
_NUMBER_SIGN = re.compile(r"\d|nan|inf", re.IGNORECASE)


def _is_data_line_any(line: str) -> bool:
    """Whether ``line`` is a data row under some delimiter of :data:`_SNIFF_ORDER`; a line of text
    without a digit (or nan / inf) is told in one scan of its first :data:`_CLASSIFY_CHARS` characters."""
    if not _NUMBER_SIGN.search(line, 0, _CLASSIFY_CHARS):
        return False
    return any(_is_data_line(line, d) for d in _SNIFF_ORDER)


def _quote(text) -> str:
    """``repr`` of ``text``, cut to :data:`_QUOTE_CHARS` characters plus '...' and its length when longer."""
    text = str(text)
    if len(text) <= _QUOTE_CHARS:
        return repr(text)
    return f"{text[:_QUOTE_CHARS]!r}... ({len(text):,} characters)"


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
    names = list(names)
    more = len(names) - 8
    names = [_quote(n) for n in names[:8]] + ([f"... ({more} more)"] if more > 0 else [])
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


def _spans(line: str, pattern: re.Pattern, merge_units: bool, limit: int | None = None) -> list[tuple[int, int, str]]:
    """(start, end, text) of the tokens of ``line``; stops once it holds more than ``limit`` tokens."""
    out: list[tuple[int, int, str]] = []
    for m in pattern.finditer(line):
        if limit is not None and len(out) > limit:
            break
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
        spans = _spans(line, pattern, merge, limit=ncols)
        if len(spans) == ncols:
            return spans
    return None


def _delimited_names(text: str, delim: str, limit: int | None = None) -> list[str]:
    """The names of a delimited header line (quotes as CSV has them); the first ``limit + 1`` only with ``limit``."""
    try:
        names = next(csv.reader([text], delimiter=delim, skipinitialspace=True, strict=True), None) or text.split(delim)
    except csv.Error:  # a quote left open: split as written
        names = text.split(delim)
    if limit is not None:
        names = names[:limit + 1]
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
