"""The sweep's tidy table: one row per scene x parameter set x afferent; what each column means.

Columns, in order: ``scene``, ``task``, the swept keys (as written, values as written), then
``afferent``, ``position_m`` and the results below; NaN where the scene's outputs did not
compute a result (spike columns without ``spikes``, fit columns without ``fit``).
"""

from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager

import numpy as np

#: Result columns and their meaning (SI units).
COLUMNS = {
    "afferent": "afferent id",
    "position_m": "afferent position along the section axis, m",
    "peak_current_a": "largest afferent current over the stimulus, A",
    "profile_current_a": "afferent current at the profile step (largest total afferent current), A",
    "profile_time_s": "time of the profile step, s (NaN for a static export)",
    "n_spikes": "number of spikes",
    "rate_hz": "mean firing rate over the simulated time, Hz",
    "first_spike_latency_s": "time of the first spike from the start of the simulation, s",
    "mean_isi_s": "mean inter-spike interval, s",
    "cv_isi": "coefficient of variation of the inter-spike intervals",
    "fit_r2_study": "profile fit, the study's R^2 (same for every afferent of the task)",
    "fit_r2": "profile fit, R^2",
    "fit_ssd": "profile fit, sum of squared differences (the calibration objective)",
}
_SPIKE_COLUMNS = ("n_spikes", "rate_hz", "first_spike_latency_s", "mean_isi_s", "cv_isi")


def _plain(v):
    """A swept value for a table cell: scalars as they are, arrays as JSON text."""
    return json.dumps(v) if isinstance(v, (list, dict)) else v


def task_rows(task, out: dict) -> list[dict]:
    """The rows of one task from the stages' results (``run.out`` of :mod:`afferent.scene.run`)."""
    aff = out.get("afferent")
    if aff is None:
        return []
    values = np.asarray(aff.values, dtype=float)
    k = out.get("profile_index", -1)
    n = values.shape[1]
    cols = {
        "afferent": [str(a) for a in aff.afferent_ids],
        "position_m": np.asarray(aff.positions, dtype=float),
        "peak_current_a": np.nanmax(values, axis=0) if values.size else np.full(n, np.nan),
        "profile_current_a": values[k],
        "profile_time_s": np.full(n, float(aff.times[k]) if aff.times is not None else math.nan),
    }
    spikes = out.get("spikes")
    if spikes is not None:
        summary = spikes.summary()
        for c in _SPIKE_COLUMNS:
            cols[c] = summary[c].to_numpy(dtype=float)
    else:
        for c in _SPIKE_COLUMNS:
            cols[c] = np.full(n, np.nan)
    fit = out.get("fit")
    for c, attr in (("fit_r2_study", "r2_study"), ("fit_r2", "r2"), ("fit_ssd", "ssd")):
        cols[c] = np.full(n, float(getattr(fit, attr)) if fit is not None else math.nan)
    head = {"scene": task.label, "task": task.id, **{p: _plain(v) for p, v in task.params.items()}}
    return [dict(head, **{c: (v[i] if c == "afferent" else float(v[i])) for c, v in cols.items()}) for i in range(n)]


def columns_of(keys) -> list:
    """The table's columns: scene, task, the swept keys, then :data:`COLUMNS`."""
    return ["scene", "task", *keys, *COLUMNS]


def frame(rows: list, keys) -> "pandas.DataFrame":  # noqa: F821
    """The tidy table from rows as tuples in :func:`columns_of` order (None: not computed, not swept)."""
    import pandas as pd

    df = pd.DataFrame(rows, columns=columns_of(keys))
    for c in COLUMNS:
        if c != "afferent":
            df[c] = pd.to_numeric(df[c], errors="coerce").astype(float)
    df["n_spikes"] = df["n_spikes"].astype("Int64")  # a count, as in spike_summary.csv; <NA> where not computed
    return df


#: The sweep table's formats (``table_format=``, ``--table-format``): CSV by default everywhere (no extra
#: library: it opens in pandas, R and a spreadsheet); Parquet (typed columns, compressed; needs pyarrow) on request.
TABLE_FORMATS = ("csv", "parquet")


def check_table_format(table_format: str) -> str:
    """``table_format`` if it is one of :data:`TABLE_FORMATS` and its library is installed, else an error saying so
    (raised before the sweep runs)."""
    if table_format not in TABLE_FORMATS:
        raise ValueError(f"table_format must be one of {', '.join(map(repr, TABLE_FORMATS))}; got {table_format!r} "
                         "instead.")
    if table_format == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError as err:
            from ..exceptions import MissingExtraError

            raise MissingExtraError("table_format='parquet' needs pyarrow, which is not installed: pip install pyarrow "
                              "(or leave the table as CSV, the default).") from err
    return table_format


def _swept_dtype(types: set):
    """The dtype of a swept key's column from the Python types of its values (NoneType: a row without the key),
    as pandas gives a whole column of them: every chunk of a streamed table gets it."""
    t, missing = types - {type(None)}, type(None) in types
    if t and t <= {int}:
        return float if missing else "int64"
    if t and t <= {int, float}:
        return float
    if t == {bool} and not missing:
        return bool
    return object


class _Writer:
    """Appends chunks of task records to a table file (CSV: text appended; Parquet: one row group a chunk)."""

    def __init__(self, tmp: str, path: str, fmt: str, keys, kinds: dict):
        self.tmp, self.path, self.fmt, self.keys = tmp, path, fmt, list(keys)
        self.dtypes = {k: _swept_dtype(kinds.get(k, set())) for k in self.keys}
        self.rows, self.columns, self._out = 0, [], None

    def __call__(self, rows: list) -> None:
        """Append rows (tuples in :func:`columns_of` order)."""
        df = frame(rows, self.keys)
        for k, dtype in self.dtypes.items():
            df[k] = df[k].astype(dtype)
        if self.fmt == "csv":
            if self._out is None:
                self._out = open(self.tmp, "w", newline="")
            df.to_csv(self._out, index=False, header=not self.columns)
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            if self._out is None:
                schema = pa.Table.from_pandas(df, preserve_index=False).schema
                for i, f in enumerate(schema):  # a column without a value in this chunk: text, as written
                    if pa.types.is_null(f.type):
                        schema = schema.set(i, f.with_type(pa.string()))
                self._out = pq.ParquetWriter(self.tmp, schema)
            self._out.write_table(pa.Table.from_pandas(df, schema=self._out.schema, preserve_index=False))
        self.columns = list(df.columns)
        self.rows += len(df)

    def close(self) -> None:
        if self._out is None:
            self(())  # no task succeeded: the columns alone
        self._out.close()


@contextmanager
def table_writer(folder: str, table_format: str, keys, kinds: dict):
    """Yield a writer of ``table.csv`` or ``table.parquet`` (``table_format``) in ``folder``: called with chunks of
    task records (in task order), it appends their rows; the file is written under a temporary name and renamed
    when the block ends (:func:`afferent._output.atomic_file`), so a table is whole or absent.

    ``kinds``: swept key -> the Python types of its values (every chunk gets the column's dtype of the whole table).
    The table of the other format, left by an earlier run of the sweep, is removed only if the folder's record
    proves afferent wrote it (:mod:`afferent._owned`); both are recorded there as written or removed."""
    import os

    from .._output import atomic_file
    from .._owned import add_to_record, recorded

    fmt = check_table_format(table_format)
    path = os.path.join(folder, f"table.{fmt}")
    other = os.path.join(folder, "table.csv" if fmt == "parquet" else "table.parquet")
    with atomic_file(path, overwrite=True) as tmp:  # derived from the task records: rewritten on every run
        writer = _Writer(tmp, path, fmt, keys, kinds)
        try:
            yield writer
        finally:
            if writer._out is not None or not sys.exc_info()[0]:
                writer.close()
    gone = [os.path.basename(other)] if recorded(folder, os.path.basename(other)) else []
    if gone:
        os.remove(other)
    add_to_record(folder, [os.path.basename(path)], drop=gone, task_records=True)


def read_table(path: str):
    """Read a sweep table back (Parquet or CSV) as a DataFrame, with its types (CSV: ``scene``, ``task`` and
    ``afferent`` text, ``n_spikes`` an Int64 count, the results floats; the swept keys as pandas reads them)."""
    import pandas as pd

    if str(path).endswith(".parquet"):
        return pd.read_parquet(path)
    return pd.read_csv(path, dtype={"scene": str, "task": str, "afferent": str, "n_spikes": "Int64",
                                    **{c: float for c in COLUMNS if c not in ("afferent", "n_spikes")}})
