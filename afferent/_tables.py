"""Reading the small CSV tables users write by hand (receptor sites, observed profiles,
branching maps, waveforms, sampled SED): one way, with one set of messages."""

from __future__ import annotations

import os

from .exceptions import SEDFormatError

__all__ = ["read_table"]


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
    import pandas as pd

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{what} {path!r} not found.")
    kwargs = dict(dtype=str, keep_default_na=False) if as_text else {}
    try:
        df = pd.read_csv(path, sep=None, engine="python", comment="#", skipinitialspace=True, **kwargs)
    except pd.errors.EmptyDataError as err:
        raise SEDFormatError(f"{what} {path!r} is empty; expected columns {expected}.") from err
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as err:
        raise SEDFormatError(f"{what} {path!r} could not be parsed as CSV: {err}") from err
    return df, {str(c).strip().lower(): c for c in df.columns}
