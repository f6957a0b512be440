"""Reading a waveform from a table file: :func:`read_waveform` (depth and time columns with their units).
"""

from __future__ import annotations

from .._typing import PathLike

import os
import re

import numpy as np

from .._validation import check_option
from .._validation import plain as _plain
from ..exceptions import SEDFormatError, UnitError
from ._waveforms import ON_NEGATIVE, OnNegative, Waveform

_UNIT_IN_HEADER = re.compile(r"^\s*(?P<name>[^(\[]*?)\s*[(\[]\s*(?P<unit>[^)\]]*?)\s*[)\]]\s*$")


def _split_header(col) -> tuple[str, str | None]:
    """``'time (ms)'`` -> ``('time', 'ms')``; ``'Depth'`` -> ``('depth', None)``."""
    text = str(col).strip()
    m = _UNIT_IN_HEADER.match(text)
    if m:
        return m.group("name").strip().lower(), m.group("unit")
    return text.lower(), None


def read_waveform(path: PathLike, *, length_unit: str, time_unit: str = "s", on_negative: OnNegative = "raise",
                  time_column: str = "time", depth_column: str = "depth") -> Waveform:
    """Read an indentation waveform from a CSV table with columns ``time`` and ``depth``.

    Separators: comma, semicolon, tab or whitespace (detected); ``#`` starts a comment.
    Column names are matched case-insensitively; a unit in the header (``time (ms)``,
    ``depth [mm]``) is allowed and must agree with the declared one. Values are converted to
    s and m, and the conversion is recorded in ``parameters``.

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    length_unit : {'m', 'mm', 'um', 'cm'}
        Unit of the depth column. Required: never guessed.
    time_unit : {'s', 'ms', 'us'}, default='s'
        Unit of the time column.
    on_negative : {'raise', 'clip'}, default='raise'
        A negative depth means the indenter has left the skin: raise, or set it to 0 m and
        record how many samples in ``notes``.
    time_column, depth_column : str, default='time', 'depth'
        Column names (without the unit).

    Returns
    -------
    Waveform
        ``kind='file'``; ``parameters`` holds ``path``, ``length_unit``, ``time_unit`` and the
        factors to SI.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    UnitError
        If a unit is unknown, or the header states a unit other than the declared one.
    SEDFormatError
        If the file is empty or unparsable, a column is missing or not numeric, the times are
        not strictly increasing, or a depth is negative with ``on_negative='raise'``. The
        message names the file and the data row (1-based, header excluded). (A ``ValueError``.)

    Examples
    --------
    >>> w = read_waveform("ramp.csv", length_unit="mm", time_unit="ms")  # doctest: +SKIP
    """

    from ..units import length_factor, parse_unit, time_factor

    check_option("on_negative", on_negative, ON_NEGATIVE)
    lf = length_factor(length_unit)
    tf = time_factor(time_unit)
    path = os.fspath(path)
    where = f"Waveform file {path!r}"
    from .._tables import numeric_columns, read_table

    df, _ = read_table(path, what="Waveform file", expected=f"{time_column!r} and {depth_column!r}", as_text=True)
    headers = {}
    for col in df.columns:
        name, unit = _split_header(col)
        headers.setdefault(name, (col, unit))
    wanted = {"time": time_column.strip().lower(), "depth": depth_column.strip().lower()}
    missing = [v for v in wanted.values() if v not in headers]
    if missing:
        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise SEDFormatError(
            f"{where} must have columns {wanted['time']!r} and {wanted['depth']!r}; missing "
            f"{', '.join(map(repr, missing))}. Found columns {found}."
        )
    out = {}
    for role, declared, factor_fn, unit_kw in (
        ("time", time_unit, time_factor, "time_unit"),
        ("depth", length_unit, length_factor, "length_unit"),
    ):
        col, stated = headers[wanted[role]]
        if stated is not None:
            canon = parse_unit(stated)
            if canon is None or factor_fn(canon) != factor_fn(declared):
                raise UnitError(
                    f"{where}: column {str(col)!r} states the unit {stated!r}, but {unit_kw}={declared!r} was "
                    f"declared. Pass {unit_kw}={stated!r} if the header is right."
                )
        out[role] = numeric_columns(df, [col], what="Waveform file", path=path)[:, 0]
    t_raw, d_raw = out["time"], out["depth"]
    if t_raw.size == 0:
        raise SEDFormatError(f"{where} has no data rows; expected at least one (time, depth) sample.")
    step = np.diff(t_raw)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0])
        raise SEDFormatError(
            f"{where}: 'time' must be strictly increasing; got {_plain(t_raw[k])!r} {time_unit} followed by "
            f"{_plain(t_raw[k + 1])!r} {time_unit} (data rows {k + 1} and {k + 2}) instead."
        )
    neg = d_raw < 0
    notes = ()
    if neg.any():
        k = int(np.flatnonzero(neg)[0])
        if on_negative == "raise":
            raise SEDFormatError(
                f"{where}: 'depth' must be >= 0 (a negative depth means the indenter has left the skin); got "
                f"{_plain(d_raw[k])!r} {length_unit} on data row {k + 1} instead. Pass on_negative='clip' to set "
                "negative depths to 0."
            )
        notes = (
            f"depth clipped to 0 m at {int(neg.sum())} of {d_raw.size} samples (indenter off the skin; first on "
            f"data row {k + 1}).",
        )
        d_raw = np.where(neg, 0.0, d_raw)
    params = {"path": path, "length_unit": length_unit, "time_unit": time_unit, "length_factor_to_m": lf,
              "time_factor_to_s": tf}
    return Waveform(t_raw * tf, d_raw * lf, "file", params, notes)
