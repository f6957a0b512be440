"""The entries of a ParaView JSON file series (``.vtu.series``, ``.vtk.series``, ``.vtm.series``, ``.vtkhdf.series``),
a ``.pvd`` and a ``.vtm`` (issue 36, item 2): every file an index names is checked against what exists before any
is read, the error naming each missing one and the index; odd entries are refused, each with its entry number."""

from __future__ import annotations

import json
import os
import re
import shutil

import numpy as np
import pytest

from afferent.exceptions import SEDFormatError
from afferent.io import read_raw

DATA = os.path.join(os.path.dirname(__file__), "data")
VTKHDF = os.path.join(DATA, "vtkhdf")


def _series(folder, entries, name="run.vtu.series") -> str:
    path = os.path.join(folder, name)
    with open(path, "w") as fh:
        json.dump({"file-series-version": "1.0", "files": entries}, fh)
    return path


def _steps(tmp_path, n=3) -> list[str]:
    names = []
    for k in range(n):
        shutil.copy(os.path.join(VTKHDF, f"block_external_steps_{k}.vtkhdf"), tmp_path / f"s{k}.vtkhdf")
        names.append(f"s{k}.vtkhdf")
    return names


def test_a_vtkhdf_series_reads_as_the_file_with_its_steps():
    """The step files vtkHDFWriter wrote (UseExternalTimeSteps), listed by a JSON series, read as the index file
    that VTK wrote over them (virtual datasets): the same arrays, times and values."""
    series = read_raw(os.path.join(VTKHDF, "steps.vtkhdf.series"))
    whole = read_raw(os.path.join(VTKHDF, "block_external_steps.vtkhdf"))
    np.testing.assert_allclose(series.times, whole.times)
    assert set(series.arrays) == set(whole.arrays)
    for key, a in whole.arrays.items():
        np.testing.assert_array_equal(series.arrays[key].values, a.values)


def test_every_missing_step_file_is_named_before_any_is_read(tmp_path):
    names = _steps(tmp_path, 1)
    (tmp_path / "s0.vtkhdf").write_bytes(b"not hdf5")  # a present but damaged file: not reached
    path = _series(tmp_path, [{"name": names[0], "time": 0}, {"name": "s1.vtkhdf", "time": 1},
                              {"name": "s2.vtkhdf", "time": 2}], "run.vtkhdf.series")
    with pytest.raises(FileNotFoundError, match=re.escape(
            f"SED file {path!r} lists 2 of its 3 step files that do not exist: {str(tmp_path / 's1.vtkhdf')!r} (entry 1), "
            f"{str(tmp_path / 's2.vtkhdf')!r} (entry 2).")):
        read_raw(path)


def test_a_pvd_with_a_missing_step_names_it(tmp_path):
    names = _steps(tmp_path, 2)
    pvd = tmp_path / "run.pvd"
    pvd.write_text('<VTKFile type="Collection"><Collection>' + "".join(
        f'<DataSet timestep="{k}" file="{n}"/>' for k, n in enumerate(names + ["s9.vtkhdf"])) + "</Collection></VTKFile>")
    with pytest.raises(FileNotFoundError, match=r"lists 1 of its 3 step files that do not exist: '.*s9.vtkhdf' \(entry 2\)"):
        read_raw(str(pvd))


def test_a_vtm_with_a_missing_block_names_every_missing_one(tmp_path):
    """Before: VTK's error on the first missing block, as "could not be read by VTK (truncated or corrupt?)"."""
    pytest.importorskip("vtkmodules")
    shutil.copytree(os.path.join(DATA, "kratos", "vtu", "Structure"), tmp_path / "Structure")
    vtm = tmp_path / "two.vtm"
    vtm.write_text('<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0"><vtkMultiBlockDataSet>'
                   '<Block index="0"><DataSet index="0" file="Structure/Structure_elements_1.vtu"/>'
                   '<DataSet index="1" file="Structure/gone.vtu"/></Block></vtkMultiBlockDataSet></VTKFile>')
    with pytest.raises(FileNotFoundError, match=r"SED file '.*two.vtm' lists 1 of its 2 block files that do not exist: "
                                                r"'.*Structure/gone.vtu' \(entry 1\)\."):
        read_raw(str(vtm))


@pytest.mark.parametrize("entries, message", [
    ([{"name": "s0.vtkhdf", "time": 0}, {"name": "s1.vtkhdf", "time": "late"}],
     "entry 1 ('s1.vtkhdf') must have a finite number as its time; got 'late' instead."),
    ([{"name": "s0.vtkhdf", "time": 0}, {"name": "s1.vtkhdf", "time": True}],
     "entry 1 ('s1.vtkhdf') must have a finite number as its time; got True instead."),
    ([{"name": "s0.vtkhdf", "time": "nan"}], "entry 0 ('s0.vtkhdf') must have a finite number as its time; got 'nan'"),
    ([{"name": "s0.vtkhdf", "time": 0}, {"file": "s1.vtkhdf", "time": 1}],
     "entry 1 must have a file name (\"name\": a string); got None instead."),
    ([{"name": "s0.vtkhdf", "time": 1}, {"name": "s1.vtkhdf", "time": 0.5}],
     "timesteps must be strictly increasing; got 1.0 followed by 0.5 (entries 0 and 1) instead."),
    ([{"name": "s0.vtkhdf", "time": 0}, {"name": "s1.vtkhdf", "time": 1}, {"name": "s2.vtkhdf", "time": 1}],
     "timesteps must be strictly increasing; got 1.0 followed by 1.0 (entries 1 and 2) instead."),
    ([{"name": "s0.vtkhdf", "time": 0}, {"name": "s1.vtkhdf"}], "entry 1 states no time while others do"),
    ([{"name": "../s0.vtkhdf", "time": 0}], "points to the step file (entry 0) '../s0.vtkhdf'"),
    ("s0.vtkhdf", "is not a ParaView file series (JSON with files: [{name, time}]): TypeError"),
])
def test_odd_entries_are_refused_naming_the_entry(tmp_path, entries, message):
    _steps(tmp_path)
    path = os.path.join(tmp_path, "run.vtkhdf.series")
    with open(path, "w") as fh:
        json.dump({"file-series-version": "1.0", "files": entries}, fh)
    with pytest.raises(SEDFormatError, match=re.escape(message)):
        read_raw(path)


def test_an_absolute_name_inside_the_folder_is_read_and_numeric_strings_are_times(tmp_path):
    names = _steps(tmp_path, 2)
    path = _series(tmp_path, [{"name": str(tmp_path / names[0]), "time": "0"}, {"name": names[1], "time": 0.5}],
                   "run.vtkhdf.series")
    raw = read_raw(path)
    np.testing.assert_allclose(raw.times, [0.0, 0.5])


def test_a_multi_step_vtkhdf_is_refused_as_one_step_of_a_series(tmp_path):
    shutil.copy(os.path.join(VTKHDF, "block_steps.vtkhdf"), tmp_path / "a.vtkhdf")
    path = _series(tmp_path, [{"name": "a.vtkhdf", "time": 0}], "run.vtkhdf.series")
    with pytest.raises(SEDFormatError, match=r"a.vtkhdf' holds 3 time steps; as a step of a series it must hold one"):
        read_raw(path)
