"""Reading the small CSV tables users write by hand (receptor sites, observed profiles,
branching maps, waveforms, sampled SED): one way, with one set of messages."""

from __future__ import annotations

import os

from .exceptions import SEDFormatError

__all__ = ["read_table", "numeric_columns"]


def read_table(path, *, what: str, expected: str, as_text: bool = False):
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

    Returns
    -------
    df : pandas.DataFrame
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
    import csv
    import re

    import pandas as pd

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{what} {path!r} not found.")
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
    import pandas as pd

    columns = list(columns)
    data = df[columns].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        cell = df.iloc[row][columns[col]]
        cell = cell.item() if hasattr(cell, "item") else cell
        cell = cell.strip() if isinstance(cell, str) else cell
        raise SEDFormatError(
            f"{what} {os.fspath(path)!r}: column {str(columns[col])!r} must hold finite numbers; "
            f"got {cell!r} on data row {row + 1} instead."
        )
    return data
