"""The sweep's tidy table: one row per scene x parameter set x afferent; what each column means.

Columns, in order: ``scene``, ``task``, the swept keys (as written, values as written), then
``afferent``, ``position_m`` and the results below; NaN where the scene's outputs did not
compute a result (spike columns without ``spikes``, fit columns without ``fit``).
"""

from __future__ import annotations

import json
import math

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


def assemble(records: list[dict], keys) -> "pandas.DataFrame":  # noqa: F821
    """The tidy table from the task records (those with status 'ok'), in task order."""
    import pandas as pd

    rows = [r for rec in records if rec.get("status") == "ok" for r in rec.get("rows", [])]
    columns = ["scene", "task", *keys, *COLUMNS]
    df = pd.DataFrame(rows, columns=columns)
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


def write_table(df, folder: str, table_format: str = "csv") -> str:
    """Write the table atomically as ``table.csv`` or ``table.parquet`` (``table_format``); returns the path.

    The table of the other format, left by an earlier run of the sweep, is removed only if the folder's record
    proves afferent wrote it (:mod:`afferent._owned`); both are recorded there as written or removed."""
    import os

    from .._output import write_csv
    from .._owned import add_to_record, recorded

    fmt = check_table_format(table_format)
    path = os.path.join(folder, f"table.{fmt}")
    other = os.path.join(folder, "table.csv" if fmt == "parquet" else "table.parquet")
    writer = (lambda d, p: d.to_parquet(p, index=False)) if fmt == "parquet" else None
    write_csv(df, path, overwrite=True, writer=writer)  # derived from the task records: rewritten on every run
    gone = [os.path.basename(other)] if recorded(folder, os.path.basename(other)) else []
    if gone:
        os.remove(other)
    add_to_record(folder, [os.path.basename(path)], drop=gone, task_records=True)
    return path


def read_table(path: str):
    """Read a sweep table back (Parquet or CSV) as a DataFrame."""
    import pandas as pd

    return pd.read_parquet(path) if str(path).endswith(".parquet") else pd.read_csv(path)
