"""Writing the small CSV tables of a run without pandas (afferent._tables.write_table): byte for
byte what pandas' ``to_csv(index=False)`` wrote before (issue 23)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from afferent._tables import write_table
from afferent.spiking import LIF_PRESETS
from afferent.spiking._trains import SpikeTrains
from afferent.stimulus import ramp_and_hold

ODD_FLOATS = [0.0, -0.0, 0.1 + 0.2, 1e-5, 1e-4, 123456789.123, 1e15, 1e16, 1.5e300, 5e-324, 2.2250738585072014e-308,
              -1e-300, np.nan, np.inf, -np.inf, 1 / 3, 2.0 ** 53 + 2, 0.0024400000000000008]


def test_write_table_is_pandas_to_csv_byte_for_byte(tmp_path):
    n = len(ODD_FLOATS)
    columns = {
        "name": np.array(["L0", "a,b", 'say "hi"', "two\nlines", "", "ü", " lead", "trail "] * 3)[:n],
        "x_m": np.array(ODD_FLOATS),
        "count": np.arange(n, dtype=np.int64) - 3,
        "ok": np.arange(n) % 3 == 0,
    }
    with np.errstate(over="ignore"):  # 1.5e300 is inf in float32
        columns["f32"] = np.array(ODD_FLOATS, dtype=np.float32)
    rng = np.random.default_rng(0)
    for name, cols in (("odd", columns),
                       ("random", {"t_s": rng.exponential(1e-2, 500), "v": rng.normal(0, 1e-9, 500)}),
                       ("empty", {"afferent": np.array([], dtype=str), "spike_time_s": np.array([])})):
        ours, ref = tmp_path / f"{name}.csv", tmp_path / f"{name}_pandas.csv"
        write_table(ours, cols)
        pd.DataFrame(cols).to_csv(ref, index=False)
        assert ours.read_bytes() == ref.read_bytes(), name


def test_run_tables_are_what_pandas_wrote(tmp_path):
    trains = SpikeTrains.from_trains(
        [[0.0024400000000000008, 0.01, 0.0207], [], [0.5], [1e-4, 2e-4]], afferent_ids=np.array(["L0", "L1", "L2", "L3"]),
        duration=2.3, dt=0.0, engine="exact", backend="numpy", silent_skipped=np.array([1]), params=LIF_PRESETS["ra"])
    pos = np.array([1e-3 / 3, 2e-3, 3e-3, 4.4e-3])
    write_table(tmp_path / "spikes.csv", trains.table())
    trains.to_dataframe().to_csv(tmp_path / "spikes_pandas.csv", index=False)
    summary = trains.summary_table()
    write_table(tmp_path / "summary.csv", {"afferent": summary.pop("afferent"), "position_m": pos, **summary})
    ref = trains.summary().reset_index()  # how export.write_outputs wrote spike_summary.csv with pandas
    ref.insert(1, "position_m", pos)
    ref.to_csv(tmp_path / "summary_pandas.csv", index=False)
    wave = ramp_and_hold(5e-4, 5e-3, 0.01, dt=1e-3)
    write_table(tmp_path / "waveform.csv", wave.table())
    wave.to_dataframe().to_csv(tmp_path / "waveform_pandas.csv", index=False)
    for name in ("spikes", "summary", "waveform"):
        assert (tmp_path / f"{name}.csv").read_bytes() == (tmp_path / f"{name}_pandas.csv").read_bytes(), name
    assert (tmp_path / "summary.csv").read_text().splitlines()[2] == "L1,0.002,0,0.0,,,,False"


def test_write_table_refuses_columns_of_different_lengths(tmp_path):
    with pytest.raises(ValueError, match=r"the columns of '.*t\.csv' must have equal lengths; got \{'a': 2, 'b': 1\}\."):
        write_table(tmp_path / "t.csv", {"a": np.zeros(2), "b": np.zeros(1)})
