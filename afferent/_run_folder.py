"""A run's output folder read back (``afferent run``, :func:`afferent.scene.run_scene`): its ``run.json``
its CSV tables and its ``currents.nc`` (or the long tables of ``results_format='csv'``), one way for :func:`afferent.export.load_results`, ``afferent hotspots`` and
``afferent cycles``.

A damaged file (text where a number belongs, bytes that are not UTF-8, a broken or deeply
nested ``run.json``, a table without rows) is one :class:`~afferent.exceptions.SEDFormatError`
naming the file and what was expected, never a parser's own exception (issue 33, item 11).
:func:`check_table` checks a table's columns wherever it came from (a CSV here, or a sweep's
task record).
"""

from __future__ import annotations

import os

from .exceptions import SEDFormatError

__all__ = ["RUN_RECORD", "read_run_record", "read_run_table", "check_table", "run_label"]

#: The record every run writes into its folder.
RUN_RECORD = "run.json"


def read_run_record(folder) -> dict:
    """The ``run.json`` of a run's output folder, as a dict.

    Raises
    ------
    FileNotFoundError
        ``folder`` holds no ``run.json``.
    SEDFormatError
        ``run.json`` is not UTF-8 JSON text, nests too deeply to be read, or is not a JSON object.
    """
    import json

    from .io._files import open_regular

    path = os.path.join(os.fspath(folder), RUN_RECORD)
    if not os.path.lexists(path) or os.path.isdir(path):
        raise FileNotFoundError(f"{os.fspath(folder)!r} is not an afferent output folder: it holds no {RUN_RECORD}.")
    expected = "expected the run record afferent writes"
    try:
        with open_regular(path, "Run record", "r") as f:  # a FIFO is refused, not waited on
            record = json.load(f)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise SEDFormatError(f"Run record {path!r} is not UTF-8 JSON text ({err}); {expected}.") from err
    except RecursionError as err:
        raise SEDFormatError(f"Run record {path!r} nests arrays or objects too deeply to be read; {expected}.") from err
    if not isinstance(record, dict):
        raise SEDFormatError(f"Run record {path!r} holds a JSON {type(record).__name__}, not an object; {expected}.")
    return record


def run_label(folder) -> str:
    """A run's label: its scene's name in ``run.json`` (``scene.scene.name``), else the folder's name."""
    label = os.path.basename(os.path.normpath(os.fspath(folder)))
    if not os.path.isfile(os.path.join(os.fspath(folder), RUN_RECORD)):
        return label
    scene = read_run_record(folder).get("scene")
    name = ((scene.get("scene") if isinstance(scene, dict) else None) or {})
    name = name.get("name") if isinstance(name, dict) else None
    return name if isinstance(name, str) and name else label


def read_run_table(path, *, what: str, finite=(), numbers=(), columns=(), text=(), rows: bool = True, unique=()):
    """A CSV table a run wrote, read back with :func:`check_table`'s checks.

    Parameters
    ----------
    path : str or path-like
        The table (e.g. ``'runs/a/hotspots.csv'``).
    what : str
        What the table is, for the messages: ``"the 'hotspots' output of a run"``.
    finite, numbers, columns, rows, unique
        As :func:`check_table`.
    text : sequence of str
        Columns read as text as written (ids: ``'007'`` stays ``'007'``), which must be there.

    Returns
    -------
    pandas.DataFrame
        The table, the columns of ``finite`` and ``numbers`` as floats.

    Raises
    ------
    FileNotFoundError
        No such file.
    SEDFormatError
        The file is empty, not UTF-8 CSV, or fails :func:`check_table`.
    """
    import csv

    import pandas as pd

    from .io._files import open_regular

    path = os.fspath(path)
    if not os.path.lexists(path) or os.path.isdir(path):
        raise FileNotFoundError(f"Run table {path!r} not found; expected {what}.")
    where = f"Run table {path!r}"
    try:
        with open_regular(path, "Run table") as f:  # a FIFO is refused, not waited on
            df = pd.read_csv(f, encoding="utf-8", dtype={c: str for c in text})
    except SEDFormatError:  # not a regular file (afferent.io._files.open_regular): said as it is
        raise
    except pd.errors.EmptyDataError as err:
        raise SEDFormatError(f"{where} is empty; expected {what}.") from err
    except (pd.errors.ParserError, UnicodeDecodeError, csv.Error, ValueError) as err:  # ValueError: pyarrow's too
        raise SEDFormatError(f"{where} could not be read as UTF-8 CSV ({' '.join(str(err).split())}); "
                             f"expected {what}.") from err
    return check_table(df, where=where, what=what, finite=finite, numbers=numbers, columns=(*columns, *text), rows=rows,
                       unique=unique)


def check_table(df, *, where: str, what: str, finite=(), numbers=(), columns=(), rows: bool = True, unique=()):
    """``df`` with the columns of ``finite`` and ``numbers`` as floats, once checked.

    Parameters
    ----------
    df : pandas.DataFrame
    where : str
        Names the table in the messages: ``"Run table 'a/cycles.csv'"``.
    what : str
        What the table should be, for the messages.
    finite : sequence of str
        Columns that must hold finite numbers in every row.
    numbers : sequence of str
        Columns that must hold finite numbers, or be empty (NaN: not measured).
    columns : sequence of str
        Further columns that must be there (of any content).
    rows : bool, default=True
        The table must have at least one row.
    unique : sequence of str
        Columns whose values together name one row (``('time_s', 'receptor')``): no two rows alike.

    Raises
    ------
    SEDFormatError
        ``<where> lacks the column(s) [...]``, ``<where>: column 'c' must hold (finite) numbers; got 'abc' on
        data row N instead``, ``<where> has no rows``, ``<where> holds the row of (...) twice``; each ending with
        ``expected <what>``.
    """
    import numpy as np
    import pandas as pd

    missing = [c for c in (*finite, *numbers, *columns) if c not in df.columns]
    if missing:
        raise SEDFormatError(f"{where} lacks the column(s) {missing}; expected {what}.")
    if rows and df.empty:
        raise SEDFormatError(f"{where} has no rows; expected {what}.")
    df = df.copy()
    for names, need_finite in ((finite, True), (numbers, False)):
        for c in names:
            values = pd.to_numeric(df[c], errors="coerce").to_numpy(float)
            bad = ~np.isfinite(values) if need_finite else ~np.isfinite(values) & df[c].notna().to_numpy()
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                cell = df[c].iloc[row]
                cell = cell.item() if hasattr(cell, "item") else cell
                kind = "finite numbers" if need_finite else "finite numbers (or nothing)"
                raise SEDFormatError(f"{where}: column {c!r} must hold {kind}; got {cell!r} on data row {row + 1} "
                                     f"instead; expected {what}.")
            df[c] = values
    twice = df.duplicated(list(unique)) if unique else None
    if twice is not None and twice.any():
        row = df[twice].iloc[0]
        raise SEDFormatError(f"{where} holds the row of {', '.join(f'{c} {row[c]!r}' for c in unique)} twice; "
                             f"expected {what}.")
    return df


def read_results_nc(nc: str, run: dict):
    """``currents.nc`` (:func:`afferent.export.results_dataset`) loaded, once it is a regular file without HDF5 external links or
    variables stored in other files (refused: nothing outside it is read); a file that is not readable
    netCDF-4 (or not a file) is an error naming it."""
    import h5py
    import xarray as xr

    from .io._files import check_regular, h5_refuse_external

    if os.path.isdir(nc):
        raise SEDFormatError(f"Results file {nc!r} is not a file; expected the netCDF-4 file of a run's time courses.")
    check_regular(nc, "Results file")
    try:
        h5 = h5py.File(nc, "r")
    except OSError as err:
        raise SEDFormatError(f"Results file {nc!r} could not be read as netCDF-4 ({' '.join(str(err).split())}); "
                             "expected the time courses a run wrote.") from err
    with h5:
        h5_refuse_external(h5, "Results file")
    _check_results_file(nc, run)
    try:
        with xr.open_dataset(nc, engine="h5netcdf", decode_times=False) as f:  # seconds, not dates (afferent._netcdf)
            return f.load()
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise SEDFormatError(f"Results file {nc!r} could not be read as netCDF-4 ({' '.join(str(err).split())}); "
                             "expected the time courses a run wrote.") from err


def _time_column(path: str) -> str:
    """'step' when the long table's header names steps (an export without times), else 'time_s'."""
    from .io._files import open_regular

    with open_regular(path, "Results table") as f:
        names = [n.strip().strip(b'"') for n in f.readline(65536).split(b",")]
    return "step" if b"step" in names and b"time_s" not in names else "time_s"


def dataset_from_csv(folder: str):
    """The Dataset of :func:`afferent.export.results_dataset` from the long CSV tables of ``results_format='csv'``:
    receptors and afferents in the tables' order, the same integer dimensions and ``*_id`` labels."""
    import xarray as xr

    from ._netcdf import dataset_from_variables

    rec, aff = os.path.join(folder, "receptors.csv"), os.path.join(folder, "afferents.csv")
    if not os.path.lexists(rec):
        return xr.Dataset()
    tcol = _time_column(rec)  # 'step' in the tables of an export without times: step numbers as the time axis
    df = read_run_table(rec, what="the long table of results_format='csv'", rows=False, text=("receptor",),
                        finite=(tcol, "x_m", "y_m", "z_m"), numbers=("sed_pa", "current_a"),
                        columns=("longitudinal", "cross"), unique=(tcol, "receptor"))
    variables = _long_variables(df, tcol, "receptor", {"sed_pa": "sed_pa", "current_a": "current_a"},
                                ("x_m", "y_m", "z_m", "longitudinal", "cross"))
    if os.path.lexists(aff):
        da = read_run_table(aff, what="the long table of results_format='csv'", rows=False, text=("afferent",),
                            finite=(tcol, "position_m"), numbers=("current_a",), unique=(tcol, "afferent"))
        more = _long_variables(da, tcol, "afferent", {"current_a": "afferent_current_a"}, ("position_m",),
                               times=variables["time"][1])
        variables.update({k: v for k, v in more.items() if k != "time"})
    return dataset_from_variables(variables, {})


def _long_variables(df, tcol: str, dim: str, values: dict, per_site: tuple, times=None) -> dict:
    """The variables of one long table (rows: time x site): ``time``, the integer ``dim`` and its ``*_id`` labels
    (sites in the order the table first names them), ``per_site`` columns and ``values`` (column -> variable name)
    over (time, dim), NaN where the table has no row; ``times``: the time axis to use (the receptors')."""
    import numpy as np

    from ._netcdf import integer_ids

    ids = df[dim].drop_duplicates().to_numpy(str)
    t = np.unique(df[tcol].to_numpy(float)) if times is None else np.asarray(times, dtype=float)
    row = np.searchsorted(t, df[tcol].to_numpy(float))
    col = {s: k for k, s in enumerate(ids.tolist())}
    cols = np.array([col[s] for s in df[dim].astype(str).tolist()], dtype=np.int64)
    inside = (row < t.size) & (t[np.minimum(row, t.size - 1)] == df[tcol].to_numpy(float))
    first = df.drop_duplicates(dim)
    out = {"time": (("time",), t, {}), dim: ((dim,), integer_ids(ids), {}), f"{dim}_id": ((dim,), ids, {})}
    out.update({c: ((dim,), first[c].to_numpy(), {}) for c in per_site})
    for column, name in values.items():
        grid = np.full((t.size, ids.size), np.nan)
        grid[row[inside], cols[inside]] = df[column].to_numpy(float)[inside]
        out[name] = (("time", dim), grid, {})
    return out


def _check_results_file(nc: str, run: dict) -> None:
    """Refuse a ``currents.nc`` whose sizes are not its run's, before any value is read: each dimension
    against ``run.json`` (receptors sampled, afferents, steps; those it records), each variable's shape
    against its dimensions, and no variable whose values its file does not store
    (:func:`afferent.io._raw.h5_check`: chunks never written)."""
    import h5netcdf
    import h5py

    from .io._raw import h5_check

    said = {"receptor": (run.get("receptors") or {}).get("n_receptors_sampled"),
            "afferent": (run.get("synthesis") or {}).get("n_afferents"),
            "time": (run.get("profile_step") or {}).get("n_steps")}
    try:
        with h5py.File(nc, "r") as f:
            for dset in [f[name] for name in f if isinstance(f[name], h5py.Dataset)]:
                h5_check(dset, f"results file {nc!r}: variable {dset.name.lstrip('/')!r}")
        with h5netcdf.File(nc, "r") as f:
            sizes = {name: int(d.size) for name, d in f.dimensions.items()}
            shapes = {name: (tuple(v.dimensions), tuple(v.shape)) for name, v in f.variables.items()}
    except SEDFormatError:
        raise
    except (OSError, ValueError, KeyError) as err:
        raise SEDFormatError(f"results file {nc!r} could not be read as NetCDF-4 (truncated or corrupt?): "
                             f"{type(err).__name__}: {err}") from err
    for name, size in sizes.items():
        if isinstance(said.get(name), int) and size != said[name]:
            raise SEDFormatError(f"results file {nc!r}: dimension {name!r} has {size:,} entries where run.json "
                                 f"records {said[name]:,}: the file is not this run's, or corrupt; refused before "
                                 "reading it.")
    for name, (dims, shape) in shapes.items():
        if shape != tuple(sizes.get(d, -1) for d in dims):
            raise SEDFormatError(f"results file {nc!r}: variable {name!r} has shape {shape} where its dimensions "
                                 f"{dims} have {tuple(sizes.get(d) for d in dims)}: the file is corrupt; refused "
                                 "before reading it.")
