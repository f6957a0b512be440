"""Reading the small CSV tables users write by hand (receptor sites, observed profiles,
branching maps, waveforms, sampled SED): one way, with one set of messages; and writing the
small tables a run writes (:func:`write_table`: spikes, spike summary, waveform, profiles, fit),
byte for byte as pandas' ``to_csv`` wrote them, without importing pandas."""

from __future__ import annotations

import os

from .exceptions import SEDFormatError

__all__ = ["read_table", "numeric_columns", "TextTable", "write_table"]


class TextTable:
    """A small CSV read as text cells without pandas (whose import costs more than reading a
    few hundred rows): ``columns`` (names as written), ``len()`` rows, ``table[name]`` a list of
    the column's cells as written (leading spaces dropped)."""

    def __init__(self, columns: list, rows: list):
        self.columns = columns
        self._rows = rows

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, name) -> list:
        k = self.columns.index(name)
        return [row[k] for row in self._rows]


def _plain_table(path: str):
    """The file as a :class:`TextTable` when it is plainly a table (UTF-8, one of ``,;\\t`` in the
    header and as many cells on every row, no quotes, distinct non-empty names, data rows), else
    None: :func:`read_table` then reads it with pandas, which handles (and words) the rest."""
    try:
        with open(path, encoding="utf-8-sig") as f:  # a byte-order mark is dropped, as pandas does
            text = f.read()
    except (UnicodeDecodeError, OSError):
        return None
    if '"' in text or "'" in text or "\r" in text:
        return None
    lines = [line.split("#", 1)[0] for line in text.split("\n")]
    lines = [line for line in lines if line.strip()]
    if len(lines) < 2 or any(not line[:1].strip() for line in lines):  # blank or indented: pandas decides
        return None
    seps = [s for s in ",;\t" if s in lines[0]]
    if len(seps) != 1:
        return None
    rows = [[cell.lstrip(" ") for cell in line.split(seps[0])] for line in lines]
    names = rows[0]
    if any(len(r) != len(names) for r in rows) or any(not n.strip() for n in names):
        return None
    if len({n.strip().lower() for n in names}) != len(names):
        return None
    return TextTable(names, rows[1:])


def read_table(path, *, what: str, expected: str, as_text: bool = False, frame: bool = True):
    """Read a small CSV (comma, semicolon, tab or whitespace; ``#`` comments) into a DataFrame.

    Parameters
    ----------
    path : str or path-like
    what : str
        How messages name the file, e.g. ``'Receptor file'``.
    expected : str
        The columns expected, for the message about an empty file, e.g. ``'x, y, z'``.
    as_text : bool, default=False
        Keep every cell as text (so that a later error can quote a cell as written).
    frame : bool, default=True
        With ``as_text``, False allows a :class:`TextTable` instead of a DataFrame when the file
        is plainly a table (read without importing pandas); :func:`numeric_columns` takes both.

    Returns
    -------
    df : pandas.DataFrame (or TextTable: see ``frame``)
    columns : dict
        Lower-cased, stripped column name -> column name as written.

    Raises
    ------
    FileNotFoundError
        ``"<what> '<path>' not found."``
    SEDFormatError
        ``"<what> '<path>' is empty; expected columns <expected>."`` or
        ``"<what> '<path>' could not be parsed as CSV: <reason>"``.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{what} {path!r} not found.")
    table = None if frame or not as_text else _plain_table(path)
    if table is not None:
        return table, {str(c).strip().lower(): c for c in table.columns}
    import csv
    import re

    import pandas as pd

    kwargs = dict(dtype=str, keep_default_na=False) if as_text else {}
    try:
        df = pd.read_csv(path, sep=None, engine="python", comment="#", skipinitialspace=True, **kwargs)
    except pd.errors.EmptyDataError as err:
        raise SEDFormatError(f"{what} {path!r} is empty; expected columns {expected}.") from err
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, csv.Error) as err:
        raise SEDFormatError(f"{what} {path!r} could not be parsed as CSV: {err}") from err
    names = [str(c).strip().lower() for c in df.columns]
    repeated = sorted({n for n in names if names.count(n) > 1})
    mangled = [str(c) for c in df.columns if re.fullmatch(r".+\.\d+", str(c)) and str(c).rsplit(".", 1)[0] in df.columns]
    if repeated or mangled:
        twice = repeated[0] if repeated else mangled[0].rsplit(".", 1)[0]
        raise SEDFormatError(f"{what} {path!r} has two columns named {twice!r} (names are compared without case); "
                             "each column needs its own name.")
    return df, {str(c).strip().lower(): c for c in df.columns}


def numeric_columns(df, columns, *, what: str, path):
    """The given columns as a float array of shape (n_rows, n_columns); every cell must be a finite number.

    Raises
    ------
    SEDFormatError
        ``"<what> '<path>': column 'c' must hold finite numbers; got '<cell as written>' on data row N instead."``
    """
    import numpy as np

    columns = list(columns)
    if isinstance(df, TextTable):
        data = np.array([[_number(cell) for cell in df[c]] for c in columns], dtype=float).T.reshape(len(df), -1)
    else:
        import pandas as pd

        data = df[columns].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        cell = df[columns[col]][row] if isinstance(df, TextTable) else df.iloc[row][columns[col]]
        cell = cell.item() if hasattr(cell, "item") else cell
        cell = cell.strip() if isinstance(cell, str) else cell
        raise SEDFormatError(
            f"{what} {os.fspath(path)!r}: column {str(columns[col])!r} must hold finite numbers; "
            f"got {cell!r} on data row {row + 1} instead."
        )
    return data


def _number(cell: str) -> float:
    """A cell as a float as pandas.to_numeric reads it, NaN when it is not a plain number."""
    try:
        return float(cell) if "_" not in cell else float("nan")
    except ValueError:
        return float("nan")


def _cells(values) -> list:
    """A column's cells as pandas' ``to_csv`` writes them (``na_rep=''``, no ``float_format``): floats
    with numpy's shortest round-trip repr (``values.astype(str)``, as pandas does), NaN as ''."""
    import numpy as np

    values = np.asarray(values)
    if values.dtype.kind == "f":
        cells = values.astype(str).astype(object)
        cells[np.isnan(values)] = ""
        return cells.tolist()
    return [str(v) for v in values.tolist()]


def write_table(path, columns: dict) -> None:
    """Write ``columns`` (name -> 1-D array of equal length: float, int, bool or str) as a CSV file,
    byte for byte what ``pandas.DataFrame(columns).to_csv(path, index=False)`` writes (tested):
    a header row, ``,`` between cells, ``\\n`` after each row, quotes only where a cell needs them,
    NaN as an empty cell. pandas is not imported (its import costs more than a run of a few
    afferents: docs/performance.md, "What a spikes-only scene imports").

    Raises
    ------
    ValueError
        If the columns differ in length.
    """
    import csv

    cells = {name: _cells(values) for name, values in columns.items()}
    lengths = {name: len(c) for name, c in cells.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"the columns of {os.fspath(path)!r} must have equal lengths; got {lengths}.")
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, lineterminator="\n", quoting=csv.QUOTE_MINIMAL)
        writer.writerow(list(cells))
        writer.writerows(zip(*cells.values()))
