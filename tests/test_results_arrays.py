"""Dense results as arrays: ``currents.nc`` (NetCDF-4) for the time courses, ``afferent.load_results``,
``--results-format csv`` for anyone who asks, and the spike trains as NWB (issue 22)."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pandas as pd
import pytest

import afferent
from afferent.cli import main
from conftest import PITCH_X, write_bump

@pytest.fixture
def bump(tmp_path):
    """A 4 x 3.1 x 4 mm hex block with a Gaussian SED bump (MPa) and a papilla grid (mm)."""
    return write_bump(tmp_path, 8)[:2]


def _run(tmp_path, bump, name, *extra):
    vtu, receptors = bump
    out = tmp_path / name
    argv = ["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
            "--params", "start", "--waveform", "ramp:0.5,5,0.05", "--d-ref-mm", "0.5", "--no-plots", "--no-cache",
            "-q", "-o", str(out), *extra]
    assert main(argv) == 0
    return out


def test_time_courses_are_one_netcdf_file_with_named_dimensions_units_and_coordinates(tmp_path, bump):
    out = _run(tmp_path, bump, "nc")
    assert not (out / "receptors.csv").exists() and not (out / "afferents.csv").exists()
    assert "currents.nc" in json.loads((out / ".afferent-output.json").read_text())["files"]
    assert "currents.nc" in json.loads((out / "run.json").read_text())["outputs"]
    res = afferent.load_results(out)
    ds = res.dataset
    n_t = ds.sizes["time"]
    assert dict(ds.sizes) == {"time": n_t, "receptor": 9 * 18, "afferent": 9} and n_t > 100
    assert ds.sed_pa.dims == ds.current_a.dims == ("time", "receptor")
    assert ds.afferent_current_a.dims == ("time", "afferent")
    assert {"x_m", "y_m", "z_m", "longitudinal", "cross", "position_m", "receptor_id", "afferent_id"} <= set(ds.coords)
    units = {k: ds[k].attrs["units"] for k in ("time", "x_m", "sed_pa", "current_a", "afferent_current_a", "position_m")}
    assert units == {"time": "seconds since 1970-01-01 00:00:00", "x_m": "m", "sed_pa": "J m-3", "current_a": "A",
                     "afferent_current_a": "A", "position_m": "m"}
    assert ds.time.dtype == np.float64 and ds.time.values[1] == pytest.approx(1e-3)  # seconds, never dates
    assert all("long_name" in ds[k].attrs for k in ds.variables) and ds.attrs["Conventions"] == "CF-1.11"
    np.testing.assert_allclose(ds.x_m.max(), 3.74e-3 + PITCH_X / 2 * 1e-3 - 0.22e-3, rtol=1e-12)
    # synthesis sums each longitudinal section: the afferent current is the sum of its receptors'
    by_section = ds.current_a.groupby("longitudinal").sum().values
    np.testing.assert_allclose(by_section, ds.afferent_current_a.values, rtol=1e-12)
    # the tables beside it, as pandas; the record
    assert set(res.tables) == {"profiles", "sed_map", "waveform"} and res.folder == str(out)
    assert res.run["outputs"] == sorted(res.run["outputs"]) and "currents.xdmf" in res.run["outputs"]
    # a plain netCDF-4 / HDF5 file (no filter), what ncread, R ncdf4, ParaView read; CF auxiliary coordinates
    with h5py.File(out / "currents.nc") as f:
        assert f["current_a"].compression is None and f["current_a"].dtype == np.float64
        assert f["current_a"].attrs["coordinates"].split() == [b"receptor_id", b"x_m", b"y_m", b"z_m", b"longitudinal",
                                                                b"cross"]


def test_results_format_csv_writes_the_long_tables_with_the_same_numbers(tmp_path, bump):
    nc, csv = _run(tmp_path, bump, "nc"), _run(tmp_path, bump, "csv", "--results-format", "csv")
    assert not (csv / "currents.nc").exists()
    rec = pd.read_csv(csv / "receptors.csv")
    assert list(rec.columns) == ["receptor", "x_m", "y_m", "z_m", "longitudinal", "cross", "time_s", "sed_pa", "current_a"]
    a, b = afferent.load_results(nc).dataset, afferent.load_results(csv).dataset
    for v in ("sed_pa", "current_a", "afferent_current_a", "x_m", "z_m", "position_m"):
        np.testing.assert_allclose(a[v].values, b[v].values, rtol=1e-15, err_msg=v)
    for v in ("time", "receptor", "afferent", "receptor_id", "afferent_id", "longitudinal", "cross"):
        np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)


def test_scene_key_and_bad_format_and_load_results_on_a_non_output(tmp_path, bump, capsys):
    from afferent.scene import SceneError, parse_scene

    with pytest.raises(SceneError, match=r"\[outputs\] 'format'"):
        parse_scene('[export]\nfile = "a.vtu"\n[outputs]\nwant = ["currents"]\nformat = "hdf"\n')
    with pytest.raises(FileNotFoundError, match="is not an afferent output folder: it holds no run.json"):
        afferent.load_results(tmp_path)
    vtu, receptors = bump
    assert main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "--nwb", "-o", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err == "afferent: error: --nwb writes the spike trains: it needs --spikes.\n"


def test_spike_trains_as_nwb_read_back_with_positions_and_parameters(tmp_path, bump):
    pynwb = pytest.importorskip("pynwb")
    out = _run(tmp_path, bump, "nwb", "--spikes", "--nwb", "--drive", "rheobase")
    spikes = pd.read_csv(out / "spikes.csv", dtype={"afferent": str})
    summary = pd.read_csv(out / "spike_summary.csv", dtype={"afferent": str})
    record = json.loads((out / "run.json").read_text())
    with pynwb.NWBHDF5IO(str(out / "spikes.nwb"), "r") as io:
        units = io.read().units.to_dataframe()
    assert list(units["afferent"]) == list(summary["afferent"])
    np.testing.assert_allclose(units["position_m"], summary["position_m"], rtol=1e-15)
    assert len(spikes) > 0 and sum(len(t) for t in units["spike_times"]) == len(spikes)
    for aid, times in zip(units["afferent"], units["spike_times"]):
        np.testing.assert_allclose(times, spikes.loc[spikes.afferent == aid].iloc[:, 1].to_numpy(), rtol=1e-15)
    lif = record["spikes"]["lif"]
    assert (units["tau_m_s"] == lif["tau_m"]).all() and (units["v_thresh_v"] == lif["v_thresh"]).all()
    assert all(np.allclose(iv, [[0.0, record["spikes"]["duration_s"]]]) for iv in units["obs_intervals"])


# ------------------------------------------------------------- issue 33, item 11: damaged output folders
def _damaged(folder, how: str):
    """Damage a copy of a run's output folder as ``how`` says; return the file named in the error."""
    if how == "run.json broken":
        (folder / "run.json").write_text('{"outputs": [')
        return folder / "run.json"
    if how == "run.json too deep":
        (folder / "run.json").write_text("[" * 100_000 + "]" * 100_000)
        return folder / "run.json"
    if how == "run.json a list":
        (folder / "run.json").write_text("[1, 2]")
        return folder / "run.json"
    if how in ("currents.nc garbage", "currents.nc a folder"):
        (folder / "currents.nc").unlink()
        if how.endswith("garbage"):
            (folder / "currents.nc").write_bytes(b"CDF\x01" + b"\x00" * 100)
        else:
            (folder / "currents.nc").mkdir()
        return folder / "currents.nc"
    if how == "table ragged":
        (folder / "waveform.csv").write_text("time_s,depth_m\n0,0\n1,2,3,4\n")
        return folder / "waveform.csv"
    (folder / "waveform.csv").write_bytes(b"time_s,depth_m\n0,\xe9\n")  # "table not UTF-8"
    return folder / "waveform.csv"


@pytest.mark.parametrize("how, message", [
    ("run.json broken", "Run record {path!r} is not UTF-8 JSON text (Expecting value: line 1 column 14 (char 13)); "
                        "expected the run record afferent writes."),
    ("run.json too deep", "Run record {path!r} nests arrays or objects too deeply to be read; expected the run record "
                          "afferent writes."),
    ("run.json a list", "Run record {path!r} holds a JSON list, not an object; expected the run record afferent writes."),
    ("currents.nc garbage", "Results file {path!r} could not be read as netCDF-4 ("),
    ("currents.nc a folder", "Results file {path!r} is not a file; expected the netCDF-4 file of a run's time courses."),
    ("table ragged", "Run table {path!r} could not be read as UTF-8 CSV (Error tokenizing data. C error: Expected 2 "
                     "fields in line 3, saw 4); expected a table afferent wrote."),
    ("table not UTF-8", "Run table {path!r} could not be read as UTF-8 CSV ("),
])
def test_load_results_names_the_damaged_file(tmp_path, bump, how, message):
    """Before: JSONDecodeError, RecursionError, AttributeError later, OSError, an empty Dataset (currents.nc a
    folder: no error at all), ParserError, UnicodeDecodeError: the parsers' own exceptions."""
    import shutil

    from afferent.exceptions import SEDFormatError

    out = _run(tmp_path, bump, "nc")
    folder = tmp_path / "damaged"
    shutil.copytree(out, folder)
    path = str(_damaged(folder, how))
    with pytest.raises(SEDFormatError) as err:
        afferent.load_results(folder)
    assert str(err.value).startswith(message.format(path=path)), str(err.value)


def test_a_results_file_larger_than_its_run_is_refused_before_it_is_read(tmp_path, bump):
    """Issue 33 item 10: a currents.nc whose time axis holds 2e8 values (1.6 GB of gzip-compressed zeros in a
    1.6 MB file) beside a run.json of 351 steps. Before: load_results read it whole (xarray loads the time
    index at open); now each dimension is checked against run.json, and each variable against its
    dimensions and what its file stores, before anything is read: the child stays under 400 MB."""
    import zlib

    import h5netcdf
    from _memory import in_child

    out = _run(tmp_path, bump, "nc")
    n_steps = json.loads((out / "run.json").read_text())["profile_step"]["n_steps"]
    (out / "currents.nc").unlink()
    n, rows = 200_000_000, 1 << 20
    with h5netcdf.File(out / "currents.nc", "w") as f:
        f.dimensions = {"time": n}
        f.create_variable("time", ("time",), "f8", chunks=(rows,), compression="gzip")
    with h5py.File(out / "currents.nc", "r+") as f:
        packed = zlib.compress(bytes(8 * rows), 9)
        for start in range(0, n, rows):
            f["time"].id.write_direct_chunk((start,), packed)
    assert (out / "currents.nc").stat().st_size < 3e6
    got = in_child(f"""
        import afferent
        afferent.load_results({str(out)!r})
    """)
    assert got["error"] == ["SEDFormatError", f"results file {str(out / 'currents.nc')!r}: dimension 'time' has "
                            f"200,000,000 entries where run.json records {n_steps:,}: the file is not this run's, or "
                            "corrupt; refused before reading it."], got
    assert got["peak_mb"] < 400, got
    with h5py.File(out / "currents.nc", "r+") as f:  # chunks never written: refused whatever run.json says
        del f["time"]
        f.create_dataset("unwritten", shape=(n,), dtype="f8", chunks=(rows,))
    with pytest.raises(afferent.exceptions.SEDFormatError, match="variable 'unwritten': the dataset holds 200,000,000 "
                                                                 "values .* of which the file stores 0 bytes"):
        afferent.load_results(out)
