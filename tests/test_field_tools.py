"""Issue 37: the outputs open cleanly in the field's own tools. ``currents.nc`` (NC_CHAR attributes, integer
id dimensions, CF time; ParaView's NetCDF reader finds its steps; compliance-checker), ``currents.xdmf`` (a
time series for ParaView pointing into currents.nc), ``load_results`` round-tripping to NetCDF.

The NWB file: tests/test_nwb.py."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

import afferent
from afferent.cli import main
from conftest import ROOT, write_bump


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One ramp run of the bump block (162 receptors, 9 afferents, 351 steps) with spikes."""
    folder = tmp_path_factory.mktemp("clients")
    vtu, receptors = write_bump(folder, 8)[:2]
    out = folder / "run"
    assert main(["run", str(vtu), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--params", "start", "--waveform", "ramp:0.5,5,0.05", "--d-ref-mm", "0.5", "--no-plots", "--no-cache",
                 "--spikes", "--drive", "rheobase", "-q", "-o", str(out)]) == 0
    return out


def _attributes(f: h5py.File):
    """(where, name, h5py type id) of every attribute of the file, but the HDF5 dimension-scale bookkeeping."""
    hidden = {"DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid", "_Netcdf4Coordinates", "_NCProperties"}
    found = [("/", name, f.attrs.get_id(name).get_type()) for name in f.attrs if name not in hidden]
    for key, obj in f.items():
        found += [(key, name, obj.attrs.get_id(name).get_type()) for name in obj.attrs if name not in hidden]
    return found


def test_currents_nc_holds_no_variable_length_string_and_integer_id_dimensions(run):
    """Before: every attribute NC_STRING (variable-length), the ids string coordinates: ParaView found no steps,
    cfchecks stopped ("vlen types not supported"), ``ds.sel(receptor=1)`` failed."""
    with h5py.File(run / "currents.nc") as f:
        text = [(where, name) for where, name, kind in _attributes(f) if isinstance(kind, h5py.h5t.TypeStringID)]
        vlen = [(where, name) for where, name, kind in _attributes(f)
                if isinstance(kind, h5py.h5t.TypeStringID) and kind.is_variable_str()]
        assert len(text) > 30 and not vlen, vlen
        assert not [k for k, v in f.items() if isinstance(v, h5py.Dataset) and h5py.check_vlen_dtype(v.dtype)]
        assert f["receptor"].dtype.kind == f["afferent"].dtype.kind == "i"
        assert f["receptor_id"].dtype == f["afferent_id"].dtype == np.dtype("S1")  # CF label variables (NC_CHAR)
        assert f["time"].attrs["standard_name"] == b"time" and f["time"].attrs["axis"] == b"T"
        assert f.attrs["history"].startswith(b"written by afferent-skin ") and f.attrs["Conventions"] == b"CF-1.11"
    ds = afferent.load_results(run).dataset
    one = ds.sel(receptor=1)
    assert one.receptor_id.item() == "1" and one.sed_pa.dims == ("time",)
    sed_map = afferent.load_results(run).tables["sed_map"]  # the tables' integer receptor ids select the same site
    row = sed_map[sed_map["receptor"] == 1].iloc[0]
    assert (float(one.x_m), float(one.z_m)) == (row["x_m"], row["z_m"])
    assert list(ds.afferent_id.values) == [f"L{k}" for k in range(9)] and list(ds.afferent.values) == list(range(9))


def test_ids_that_are_not_integers_are_labels_beside_positions():
    """A grid's ids ('L00C00') are not integers: the dimension counts positions, the labels stay beside it."""
    from afferent._netcdf import integer_ids

    assert integer_ids(["3", "10", "7"]).tolist() == [3, 10, 7]
    assert integer_ids(["L00C00", "L00C01"]).tolist() == [0, 1]
    assert integer_ids(["007", "8"]).tolist() == [0, 1]  # '007' is no plain integer: '7' would be another id


def test_load_results_round_trips_to_netcdf(run, tmp_path):
    """Before: load_results returned the Dataset with DataFrames and a dict in attrs; to_netcdf failed on them."""
    import xarray as xr

    res = afferent.load_results(run)
    assert set(res.tables) >= {"spikes", "spike_summary", "sed_map"} and res.run["outputs"]
    assert set(res.dataset.attrs) == {"Conventions", "title", "source", "history", "comment"}
    for engine in ("h5netcdf", "scipy"):  # netCDF-4 and netCDF-3 (scipy)
        path = tmp_path / f"copy_{engine}.nc"
        res.dataset.to_netcdf(path, engine=engine)
        with xr.open_dataset(path, engine=engine, decode_times=False) as back:
            xr.testing.assert_identical(back.load(), res.dataset)
    with h5py.File(tmp_path / "copy_h5netcdf.nc") as f:  # the labels written back as NC_CHAR, as afferent wrote them
        assert f["receptor_id"].dtype == np.dtype("S1")


_PARAVIEW_STEPS = """
import json, sys
import vtk
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as S
reader = getattr(vtk, sys.argv[1])()
reader.SetFileName(sys.argv[2])
reader.UpdateInformation()
info = reader.GetOutputInformation(0)
steps = list(info.Get(S.TIME_STEPS())) if info.Has(S.TIME_STEPS()) else None
out = {"steps": steps}
if steps and sys.argv[1] == "vtkXdmfReader":
    from vtkmodules.util.numpy_support import vtk_to_numpy
    reader.UpdateTimeStep(steps[int(sys.argv[3])])
    grid = reader.GetOutputDataObject(0)
    data = grid.GetPointData()
    out["points"] = vtk_to_numpy(grid.GetPoints().GetData()).tolist()
    out.update({data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)).tolist() for i in range(data.GetNumberOfArrays())})
print(json.dumps(out))
"""


def _vtk(reader: str, path, *args) -> dict:
    """What VTK's ``reader`` (ParaView's readers) finds in ``path``, read in a child process (VTK may crash)."""
    pytest.importorskip("vtk")
    done = subprocess.run([sys.executable, "-c", _PARAVIEW_STEPS, reader, str(path), *map(str, args)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_paraviews_netcdf_reader_finds_the_time_steps(run):
    """ParaView's NetCDF reader is VTK's vtkNetCDFCFReader. Before: no time steps (NC_STRING attributes:
    "NetCDF: Not a valid data type or _FillValue type mismatch")."""
    got = _vtk("vtkNetCDFCFReader", run / "currents.nc")
    assert got["steps"] is not None and len(got["steps"]) == 351
    with h5py.File(run / "currents.nc") as f:
        np.testing.assert_allclose(got["steps"], f["time"][:], rtol=1e-12)


def test_the_xdmf_index_is_a_time_series_of_the_receptors_read_from_currents_nc(run):
    """currents.xdmf holds no numbers of its own: VTK's XDMF reader (ParaView's) finds every step and reads
    each step's values out of currents.nc. Before: no index (ParaView read (time, afferent) as one image)."""
    ds = afferent.load_results(run).dataset
    k = 200
    got = _vtk("vtkXdmfReader", run / "currents.xdmf", k)
    assert len(got["steps"]) == ds.sizes["time"]
    np.testing.assert_allclose(got["steps"], ds.time.values, rtol=1e-15)
    np.testing.assert_allclose(got["points"], np.c_[ds.x_m, ds.y_m, ds.z_m], rtol=1e-15)
    for name in ("sed_pa", "current_a"):
        np.testing.assert_allclose(got[name], ds[name].values[k], rtol=1e-15, err_msg=name)
    np.testing.assert_array_equal(got["cross"], ds.cross.values)
    text = (run / "currents.xdmf").read_text()
    assert text.count("currents.nc:/sed_pa") == ds.sizes["time"] and f"{float(ds.sed_pa.values[k].max())!r}" not in text
    assert (run / "currents.xdmf").stat().st_size < 2000 * ds.sizes["time"]


@pytest.mark.skipif(shutil.which("pvpython") is None, reason="ParaView (pvpython) is not installed here: "
                    "test_paraviews_netcdf_reader_finds_the_time_steps checks its reader through VTK")
def test_paraview_opens_the_index_with_its_time_steps(run, tmp_path):
    script = tmp_path / "pv.py"
    script.write_text(textwrap.dedent(f"""
        from paraview.simple import OpenDataFile
        src = OpenDataFile({str(run / 'currents.xdmf')!r})
        print(len(src.TimestepValues))
    """))
    done = subprocess.run(["pvpython", str(script)], capture_output=True, text=True, timeout=600)
    assert done.stdout.split()[-1] == "351", done.stderr[-2000:]


def test_compliance_checker_finds_no_high_or_medium_issue(run):
    """IOOS compliance-checker, CF 1.11 (the Conventions currents.nc states). Before: 1 high (time without
    standard_name), 1 medium (no history) and an exception on the string coordinate."""
    pytest.importorskip("compliance_checker", reason="compliance-checker is in the test extra (pyproject.toml)")
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    out = run.parent / "cc.json"
    ComplianceChecker.run_checker(str(run / "currents.nc"), ["cf:1.11"], 0, "normal", output_filename=str(out),
                                  output_format="json")
    report = json.loads(out.read_text())["cf:1.11"]
    failed = [(p["name"], p["msgs"]) for key in ("high_priorities", "medium_priorities") for p in report[key]
              if p["msgs"]]
    assert report["high_count"] == report["medium_count"] == 0 and not failed, failed
    assert report["scored_points"] == report["possible_points"] > 200


def test_the_output_checks_script_is_the_one_the_docs_name():
    """cfchecks (UDUNITS-2, network tables) runs from benchmarks/check_outputs.py, not in the suite."""
    assert (ROOT / "benchmarks" / "check_outputs.py").is_file()
    assert "python benchmarks/check_outputs.py" in (ROOT / "docs" / "outputs.md").read_text()
