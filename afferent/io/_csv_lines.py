"""Text tables, first layer: bytes -> text lines, line classes (comment, rule, data), delimiters, header names.

Used by :mod:`afferent.io._csv` (the reader) and its layout modules; see there for the layouts handled. The
last section reads the structure of Abaqus reports: frames (time steps), output positions, wrapped tables.
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
from ._columns import COORD_ALIASES, ID_ALIASES, canonical, part_note
from ._files import open_regular

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

_FOOTER = re.compile(r"^\s*(?:minimum|maximum|total|at\s+node|at\s+element|int\s+pt)\b", re.IGNORECASE)
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
#: COMSOL per-step column suffix: ``solid.Ws (J/m^3) @ t=0.02``; a parametric sweep writes ``@ d=0.5`` (a real
#: COMSOL 6.1 export: ``u (m) @ lambda=1``), a sweep of several parameters ``@ d=0.5, F=1``.
_SUFFIX = re.compile(r"^(?P<base>.*)@\s*(?P<pairs>[A-Za-z_][\w.]*\s*=[^=@,]+(?:,\s*[A-Za-z_][\w.]*\s*=[^=@,]+)*)$")
#: One ``name=value`` of a suffix, the value optionally with a bracketed unit: ``d=0.5``, ``d=0.5[mm]``.
_PAIR = re.compile(r"^\s*(?P<var>[A-Za-z_][\w.]*)\s*=\s*(?P<val>[^\s\[\]]+)\s*(?:\[(?P<unit>[^\]]*)\])?\s*$")
#: The title of an Abaqus report block of one part instance: ``Field Output reported at nodes for part: DERMIS-1``.
_RPT_PART = re.compile(r"reported at .* for part:\s*(\S.*)$")
#: Abaqus position qualifier in report column titles: ``SENER @Loc 1``.
_LOC = re.compile(r"@\s*Loc\s*\d+", re.IGNORECASE)
#: Abaqus report header lines naming the analysis step and the frame of the table below them:
#: ``   Step: Indent`` and ``   Frame: Increment      5: Step Time =    0.5000`` (docs/fe-export.md, Abaqus).
_RPT_STEP = re.compile(r"^\s*Step:\s*(?P<val>\S.*?)\s*$")
_RPT_FRAME = re.compile(r"^\s*Frame:\s*(?P<val>\S.*?)\s*$")
_RPT_LOC = re.compile(r"^\s*Loc\s+\d+\s*:\s*(?P<what>.*?)\s+values\s+from\s+source", re.IGNORECASE)
_RPT_STEP_TIME = re.compile(r"Step\s+Time\s*=\s*(?P<t>\S+)", re.IGNORECASE)
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
#: COMSOL Results > Export > Data with Data format: Sectionwise (docs/fe-export.md, COMSOL): a ``% Coordinates``
#: section, a ``% Elements (tetrahedra)`` section of 1-based point numbers, ``% Data (expr (unit) @ t=T)`` sections.
_SECTIONWISE_START = re.compile(r"^[ \t]*%[ \t]*Coordinates\b", re.IGNORECASE | re.MULTILINE)
_SECTIONWISE_ELEMENTS = re.compile(r"^[ \t]*%[ \t]*Elements[ \t]*\(", re.IGNORECASE | re.MULTILINE)
_SECTION_TITLE = re.compile(r"^%\s*(?:(?P<coords>Coordinates)\b.*?|Elements\s*\((?P<type>[^()]*)\)|Data\s*\((?P<data>.*)\))\s*$",
                            re.IGNORECASE)
#: COMSOL's other Data formats afferent refuses: ``Grid`` (``% Grid`` then one line of values per axis) and the
#: vertical layout of point evaluations (``% Dimension: 0``, then ``% X`` over its value, ``% Y``, ...).
_COMSOL_GRID = re.compile(r"^[ \t]*%[ \t]*Grid[ \t]*$", re.IGNORECASE | re.MULTILINE)
_COMSOL_DIM0 = re.compile(r"^[ \t]*%[ \t]*Dimension[ \t]*:[ \t]*0[ \t]*$", re.IGNORECASE | re.MULTILINE)
_COMSOL_VERTICAL = re.compile(r"^[ \t]*%[ \t]*X[ \t]*$", re.MULTILINE)
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
_FOOTER_WORDS = "Minimum/Maximum/At Node/At Element/Int Pt/Total"
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


def step_suffix(header: str) -> tuple[str, tuple[tuple[str, float, str | None], ...]]:
    """Split ``'solid.Ws (J/m^3) @ d=0.5, F=1'`` into its base ``'solid.Ws (J/m^3)'`` and its ``(name, value, unit)``
    pairs (``(('d', 0.5, None), ('F', 1.0, None))``); a title without such a suffix (or with a value that is not a
    number) is its own base with no pairs."""
    m = _SUFFIX.match(header)
    if not m:
        return header, ()
    pairs = []
    for part in m.group("pairs").split(","):
        p = _PAIR.match(part)
        try:
            pairs.append((p.group("var"), float(p.group("val")), (p.group("unit") or "").strip() or None))
        except (AttributeError, ValueError):
            return header, ()
    return m.group("base").rstrip(), tuple(pairs)


def sweep_parameter(path: str, swept: dict[str, list[str]], time_names) -> str | None:
    """The one name the ``@ name=value`` column suffixes of SED file ``path`` step over (``swept``: name -> the column
    titles naming it; ``time_names``: the names that mean time), or None without suffixes; refuses a sweep of several
    parameters, or of a parameter and the time, which afferent cannot lay out as one series of steps."""
    if len(swept) <= 1:
        return next(iter(swept), None)
    params, time = [n for n in swept if n not in time_names], [n for n in swept if n in time_names]
    raise SEDFormatError(
        f"SED file {path!r} sweeps {_plural(len(params), 'parameter')} ({_join_names(params)})"
        + (f" and the time ({_join_names(time)})" if time else "")
        + f" in its '@ name=value' column suffixes (e.g. {swept[params[0]][0]!r}); afferent reads the steps of one "
        "parameter or of the time per file. Export one value of the others at a time (COMSOL: Results > Export > Data, "
        "a single parameter value or time in the data set's selection) and read each file on its own."
    )


def parameter_steps(headers: list[str], values: np.ndarray, notes: list[str]) -> None:
    """A parametric sweep's steps (COMSOL ``@ d=0.5`` columns) have no times: None, with a note naming the values."""
    var, _, unit = step_suffix(headers[0])[1][0]
    units = {step_suffix(h)[1][0][2] for h in headers} - {None}
    unit = f" ({', '.join(sorted(units))})" if units else ""
    notes[:] = [n.replace("'@ t='", f"'@ {var}='").replace("time step", "step") for n in notes]
    notes.append(f"steps are values of parameter {var}{unit}, not times: {var} = {', '.join(f'{v:g}' for v in values)}; "
                 f"pass times= (--times) to give the steps times")
    return None


def _add_parts(lines: list[str], row_lines: np.ndarray, headers: list, values: list, notes: list, n_records: int):
    """Add the column ``Part`` (codes 0, 1, ..., the names in a note) to the columns of an Abaqus report whose blocks
    are of two or more part instances (``Field Output reported at nodes for part: DERMIS-1`` above each) and whose
    labels (first column) repeat within a frame across them: each part instance numbers its nodes from 1, so a row
    is its part and its label. ``row_lines``: the rows' 1-based line numbers."""
    found = [(i + 1, m.group(1).strip()) for i, line in enumerate(lines)
             if "for part:" in line and (m := _RPT_PART.search(line))]
    names = list(dict.fromkeys(n for _, n in found))
    at = np.searchsorted(np.asarray([ln for ln, _ in found]), row_lines) - 1  # the last part line above each row
    labels = values[0][: len(row_lines) // n_records] if values else np.empty(0)
    if len(names) > 1 and (at >= 0).all() and len(np.unique(labels)) < labels.size:
        headers.append("Part")
        values.append(np.asarray([names.index(n) for _, n in found], dtype=np.float64)[at])
        notes.append(part_note("Part", names))


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
    if os.path.isdir(path):
        raise SEDFormatError(f"SED file {path!r} must be a file; got a directory instead.")
    with open_regular(path, "SED file") as fh:  # missing: 'not found'; a FIFO (a --coordinates table too) refused
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


# --------------------------------------------------------------------------------------
# Abaqus report headers: frames and wrapped titles
# --------------------------------------------------------------------------------------


def _report_frame(lines: list[str], lo: int, hi: int) -> tuple[str | None, str, int] | None:
    """The analysis step and frame an Abaqus report states in ``lines[lo:hi]`` (a block's header).

    ``(step, frame, line)`` from the last ``Step:`` and ``Frame:`` lines (``line`` 1-based, of the
    ``Frame:`` line), e.g. ``('Indent', 'Increment      5: Step Time =    0.5000', 9)``; None without a
    ``Frame:`` line.
    """
    step, frame = None, None
    for i in range(max(lo, 0), hi):
        text = lines[i]
        if "Frame:" in text and (m := _RPT_FRAME.match(text)):
            frame = (m.group("val"), i + 1)
        elif "Step:" in text and (m := _RPT_STEP.match(text)):
            step = m.group("val")
    return None if frame is None else (step, frame[0], frame[1])


def _wrapped_titles(lines: list[str], lo: int, m: int) -> list[tuple[int, int]] | None:
    """The sub-block titles of a wrapped Abaqus table above its first data row ``m`` (0-based).

    With a page width set, Abaqus writes a wide table's two-line column title in parts, each
    over its own dashed rule, stacked directly above the rows (``Element Int S.Mises ...`` /
    ``Label Pt @Loc 1 ...`` / ``----`` / ``S.S13 S.S23`` / ``@Loc 1 @Loc 1`` / ``----``); the lower line of
    each part holds the ``@Loc N`` qualifiers of its values. Returns the
    (upper, lower) line indices of each part, top first, or None unless there are two or more.
    """
    parts: list[tuple[int, int]] = []
    j = m - 1
    while True:
        while j >= lo and not lines[j].strip():
            j -= 1
        if j - 2 < lo or not _is_rule(lines[j].strip()):
            break
        upper, lower = j - 2, j - 1
        if not all(_is_body(lines[k].strip()) and not _is_data_line(lines[k], "whitespace") for k in (upper, lower)):
            break
        if not _LOC.search(lines[lower]):  # every part names values ('@Loc 1' under each): not 'Source 1' over '---'
            break
        parts.append((upper, lower))
        j = upper - 1
    return parts[::-1] if len(parts) >= 2 else None


#: What the rows of a report at each output position are, and what they need to become points.
_RPT_POSITIONS = {
    "integration point": "one row per element integration point: they are points only with COORD at the integration "
                         "points in the report, or with coordinates= element centroids (rows averaged per element)",
    "centroidal": "one row per element: points only with COORD at the centroids in the report, or with coordinates= "
                  "element centroids",
    "element nodal": "one row per element and node: a node shared by several elements is listed once per element with "
                     "unaveraged values (refused where they differ); export 'Unique nodal' for one value per node",
}


def _report_position_note(lines: list[str], hi: int) -> str | None:
    """A note on the output position an Abaqus report states above line ``hi`` (``Loc 1 : Nodal values
    from source 1``), saying what its rows are when they are not nodes; None without such a line."""
    for i in range(min(hi, len(lines)) - 1, -1, -1):
        if "values" in lines[i] and (m := _RPT_LOC.match(lines[i])):
            what = m.group("what")
            more = _RPT_POSITIONS.get(what.lower())
            return f"the report holds {what} values (line {i + 1})" + (f": {more}" if more else "")
    return None


def _wrapped_names(path: str, lines: list[str], lo: int, m: int) -> tuple[list[str], tuple[int, ...], int, int] | None:
    """(names, values per line of a record, first and last title line) of a wrapped Abaqus table whose first
    record starts at line ``m`` (0-based), or None.

    Each title part names the values of one line of a record (:func:`_wrapped_titles`); the
    first record's lines fix how many values each part has.
    """
    parts = _wrapped_titles(lines, lo, m)
    if parts is None:
        return None
    names: list[str] = []
    wrap: list[int] = []
    for k, (upper, lower) in enumerate(parts):
        i = m + k
        n = _count_fields(lines[i], "whitespace") if i < len(lines) and _is_data_line(lines[i], "whitespace") else 0
        got = _align_two_lines(lines[upper], lines[lower], n) if n else None
        if got is None:
            what = f"{n} values" if n else f"{_quote(lines[i].strip()) if i < len(lines) else 'the end of the file'}"
            raise SEDFormatError(
                f"SED file {path!r} has a table wrapped over {len(parts)} lines per record (column titles at lines "
                f"{', '.join(str(u + 1) for u, _ in parts)}): line {i + 1}, part {k + 1} of its first record, must "
                f"hold one value per column named at lines {upper + 1}-{lower + 1} ({_quote(lines[upper].strip())}); "
                f"got {what} instead."
            )
        names += got
        wrap.append(n)
    return names, tuple(wrap), parts[0][0], parts[-1][1]


def _join_wrapped(path: str, rows: list[str], row_lines: list[int], wrap: tuple[int, ...],
                  titles: tuple[int, int]) -> tuple[list[str], list[int]]:
    """The records of a wrapped table, each record's lines joined into one row (numbered by its first line).

    ``wrap``: values on each line of a record; ``titles``: the first and last line (1-based) of the column titles.
    Every line must hold its part's count of values. When the first record starts with a label (an integer:
    Abaqus prints every value with a decimal point) and its other lines do not, every record must: a line
    lost or added inside a table whose parts have equal counts is caught where it happens.
    """
    per = len(wrap)
    what = (f"SED file {path!r} has a table wrapped over {per} lines per record of {', '.join(map(str, wrap))} values "
            f"(column titles at lines {titles[0]}-{titles[1]})")
    heads = [rows[k].split(None, 1)[0] if rows[k].strip() else "" for k in range(min(per, len(rows)))]
    labelled = len(heads) == per and heads[0].isdigit() and not any(h.isdigit() for h in heads[1:])
    n_rec = -(-len(rows) // per)
    ok = len(rows) == n_rec * per and [len(x.split()) for x in rows] == list(wrap) * n_rec
    if ok and labelled:
        ok = [x.split(None, 1)[0].isdigit() for x in rows] == ([True] + [False] * (per - 1)) * n_rec
    if ok:  # the common case, checked by list comparisons; else the loop below says where it fails
        return [" ".join(rows[r:r + per]) for r in range(0, len(rows), per)], row_lines[::per]
    out, out_lines = [], []
    for r in range(0, len(rows), per):
        for k, want in enumerate(wrap):
            if r + k >= len(rows):
                raise SEDFormatError(f"{what}: the record at line {row_lines[r]} must have {want} values on its line "
                                     f"{k + 1}; got no line (the rows end at line {row_lines[-1]}) instead.")
            fields = rows[r + k].split()
            if len(fields) != want:
                raise SEDFormatError(f"{what}: the record at line {row_lines[r]} must have {want} values on its line "
                                     f"{k + 1}; got {len(fields)} at line {row_lines[r + k]} instead.")
            if labelled and fields[0].isdigit() != (k == 0):
                must = ("start a record with its label (an integer)" if k == 0 else
                        f"continue the record at line {row_lines[r]} (its line {k + 1} of {per})")
                got = "a continuation line" if k == 0 else "the label of a new record: a line of a record is missing"
                raise SEDFormatError(f"{what}: line {row_lines[r + k]} must {must}; got {_quote(fields[0])}, {got} "
                                     "instead.")
        out.append(" ".join(rows[r:r + per]))
        out_lines.append(row_lines[r])
    return out, out_lines


def _check_frame_labels(path, headers, values, row_lines, n_records: int) -> None:
    """Every frame must list the same node / element labels in the same order (they are one point set)."""
    for name, vals in zip(headers, values):
        if canonical(name) not in ID_ALIASES:
            continue
        per = vals.reshape(n_records, -1)
        differ = np.flatnonzero(np.any(per != per[0], axis=1) & ~np.all(np.isnan(per), axis=1))
        if differ.size:
            k = int(differ[0])
            r = int(np.flatnonzero(per[k] != per[0])[0])
            raise SEDFormatError(
                f"Every frame of the Abaqus report {path!r} must list the same {name!r} values in the same order (one "
                f"point set, one time step per frame); got {per[0, r]:g} at line {row_lines[r]} in the first frame and "
                f"{per[k, r]:g} at line {row_lines[k * per.shape[1] + r]} in frame {k + 1} instead."
            )


def _frame_records(path: str, frames: list, n_rows: int, notes: list[str]) -> tuple[int, np.ndarray | None]:
    """(time steps, their times or None) of a table whose report blocks state Abaqus frames.

    ``frames`` holds ``(first row, (step, frame, line) or None)`` per block. Blocks of one frame
    (the parts of a model) are rows of one time step; each new frame starts a time step. Times are
    the frames' ``Step Time``, used only when every frame states one and all are of one analysis
    step (Abaqus restarts Step Time in each step and the report gives no total time); else None
    (steps numbered), with a note saying why.
    """
    groups: list[tuple[int, tuple | None]] = []
    for start, info in frames:
        prev = groups[-1][1] if groups else False
        if prev is not False and (info is None or (prev is not None and info[:2] == prev[:2])):
            continue  # another part of the same frame
        groups.append((start, info))
    if all(info is None for _, info in groups):
        return 1, None
    bare = next((g for g in groups if g[1] is None), None)
    if bare is not None:
        raise SEDFormatError(
            f"Every report block of SED file {path!r} must state its frame ('Frame: ...') once one does; got a block "
            f"without one (its rows from row {bare[0] + 1}) beside the frame at line {groups[-1][1][2]} instead."
        )
    sizes = [b[0] - a[0] for a, b in zip(groups, groups[1:] + [(n_rows, None)])]
    if len(set(sizes)) > 1:
        k = next(k for k, n in enumerate(sizes) if n != sizes[0])
        raise SEDFormatError(
            f"Every frame of the Abaqus report {path!r} must list the same rows (one time step each); got "
            f"{_plural(sizes[0], 'row')} in frame {_quote(groups[0][1][1])} (line {groups[0][1][2]}) and {sizes[k]} in "
            f"frame {_quote(groups[k][1][1])} (line {groups[k][1][2]}) instead."
        )
    said = "; ".join(f"{_quote(f)} (line {ln})" for _, (_, f, ln) in groups[:4]) + ("; ..." if len(groups) > 4 else "")
    steps = list(dict.fromkeys(info[0] for _, info in groups))
    stated = [_RPT_STEP_TIME.search(info[1]) for _, info in groups]
    kind = "frame" if len(groups) == 1 else f"{len(groups)} frames as time steps of {_plural(sizes[0], 'row')}"
    if len(steps) > 1:
        notes.append(f"read the report's {kind}: {said}; they span {len(steps)} analysis steps "
                     f"({_join_names(str(s) for s in steps)}) and Abaqus restarts 'Step Time' in each step (the report "
                     "gives no total time), so the steps are numbered, not timed; pass times= to set them")
        return len(groups), None
    if not all(stated):
        bad = groups[stated.index(None)][1]
        notes.append(f"read the report's {kind}: {said}; frame {_quote(bad[1])} (line {bad[2]}) states no 'Step Time', "
                     "so the steps are numbered, not timed; pass times= to set them")
        return len(groups), None
    try:
        times = np.asarray([float(m.group("t")) for m in stated], dtype=np.float64)
    except ValueError:
        k = next(k for k, m in enumerate(stated) if not _NUMBER.match(m.group("t")))
        raise SEDFormatError(
            f"The frame line {groups[k][1][2]} of SED file {path!r} must give its Step Time as a number; got "
            f"{_quote(stated[k].group('t'))} instead."
        ) from None
    where = f" (step {_quote(steps[0])})" if steps[0] is not None else ""
    notes.append(f"read the report's {kind}{where}: {said}; times are their 'Step Time'")
    return len(groups), times
