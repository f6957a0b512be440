"""Files an export points to are read only inside its folder, and only when they are regular files (issue 33,
items 6-8): afferent.io._files.resolve_member, through which every reader opens a file the user did not name.

Each test builds the hostile export in tmp_path: an XDMF Binary data item on /proc/self/environ or ../secret.bin,
HDF5 heavy data with external storage, an external link or a virtual dataset pointing outside, MED and Exodus
(netCDF-4) files the same way, series members (.pvd, .series, .pvtu, .vtm) named by absolute or ../ paths or
through a symbolic link, a run's currents.nc stored externally; and, for the hangs, a FIFO, /dev/zero and a sparse
file, read by the CLI in a child process under a generous time bound.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from afferent.exceptions import SEDFormatError
from afferent.io import read_raw, read_sed

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
UNITS = dict(length_unit="mm", sed_unit="MPa")
OUTSIDE = "outside the folder of the export"
ALLOW = "pass allow_outside_files=True"
FLAG = "--allow-outside-files"
ENVIRON = "/proc/self/environ"
needs_proc = pytest.mark.skipif(not os.path.isfile(ENVIRON), reason="no /proc/self/environ")
RUN = "--length-unit mm --sed-unit MPa --params start --no-plots -o out".split()
needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")


def _cli(*args, cwd, timeout=60):
    """``afferent ARGS`` in a child process: (exit code, stderr); a hang fails the test after ``timeout`` s."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    try:
        proc = subprocess.run([sys.executable, "-m", "afferent", *map(str, args)], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"afferent {' '.join(map(str, args))} still running after {timeout} s (hangs)")
    return proc.returncode, proc.stderr


def _sed_only(tmp_path: Path, item: str | None = None) -> Path:
    """DOLFINx's one-function XDMF and its .h5 copied into tmp_path/exp; ``item`` replaces the SED DataItem."""
    exp = tmp_path / "exp"
    exp.mkdir(parents=True, exist_ok=True)
    shutil.copy(DATA / "dolfinx" / "sed_only.h5", exp)
    text = (DATA / "dolfinx" / "sed_only.xdmf").read_text()
    if item is not None:
        text = re.sub(r'<DataItem Dimensions="32 1" Format="HDF">sed_only\.h5:/Function/sed/3</DataItem>', item, text)
    (exp / "sed_only.xdmf").write_text(text)
    return exp / "sed_only.xdmf"


def _binary(name: str) -> str:
    return f'<DataItem Dimensions="32 1" DataType="UInt" Precision="1" Format="Binary">{name}</DataItem>'


def _receptors(tmp_path: Path) -> Path:
    p = tmp_path / "r.csv"
    p.write_text("x,y,z\n1,1,0.5\n")
    return p


# ------------------------------------------------------------------ item 6: XDMF Binary data items
@needs_proc
def test_an_xdmf_binary_item_on_proc_environ_is_refused_and_nothing_written(tmp_path):
    """Before: `afferent sample` wrote the process environment, byte for byte, as SED into the CSV, exit 0."""
    xdmf = _sed_only(tmp_path, _binary(ENVIRON))
    code, err = _cli("sample", xdmf, "--receptors", _receptors(tmp_path), *"--length-unit mm --sed-unit MPa -o s.csv".split(),
                     cwd=tmp_path)
    assert code == 2 and err.count("\n") == 1, err
    assert f"points to the binary data file of attribute 'sed' at t = 3 '{ENVIRON}'" in err and OUTSIDE in err
    assert f"pass {FLAG}." in err
    assert not (tmp_path / "s.csv").exists()


@pytest.mark.filterwarnings("ignore:.*far above what skin")
def test_an_xdmf_binary_item_up_the_tree_is_refused_unless_allowed(tmp_path):
    secret = np.arange(1, 33, dtype=np.uint8)
    secret.tofile(tmp_path / "secret.bin")
    xdmf = _sed_only(tmp_path, _binary("../secret.bin"))
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(xdmf)!r} points to the binary data file of "
                                                       f"attribute 'sed' at t = 3 '../secret.bin', {OUTSIDE} "
                                                       f"{str(xdmf)!r}; afferent reads only the files inside")):
        read_sed(xdmf, **UNITS)
    field = read_sed(xdmf, **UNITS, allow_outside_files=True)  # on purpose: read, recorded, noted
    np.testing.assert_allclose(field.sed[0], secret * 1e6)
    assert str(xdmf.parent / "../secret.bin") in field.provenance.files
    assert any("read outside the export's folder" in n and "secret.bin" in n for n in field.provenance.notes)


def test_an_xdmf_binary_item_is_found_beside_the_xdmf_not_in_the_working_folder(tmp_path, monkeypatch):
    """A relative name is relative to the XDMF file's folder; a file of that name in the working folder is not read."""
    xdmf = _sed_only(tmp_path, _binary("values.bin"))
    np.full(32, 7, np.uint8).tofile(xdmf.parent / "values.bin")
    monkeypatch.chdir(tmp_path)
    np.full(32, 9, np.uint8).tofile(tmp_path / "values.bin")
    assert np.allclose(read_sed(xdmf, **UNITS).sed, 7e6)
    (xdmf.parent / "values.bin").unlink()  # the working folder's file is never taken instead
    with pytest.raises(SEDFormatError, match="the binary data file 'values.bin' of attribute 'sed' at t = 3 is missing"):
        read_sed(xdmf, **UNITS)


# ------------------------------------------------------------------ item 7: HDF5 pointing anywhere
def _rewrite(h5file: Path, name: str, make) -> None:
    """Replace dataset ``name`` of an HDF5 file by what ``make(file, name, values)`` creates there."""
    with h5py.File(h5file, "a") as f:
        values, attrs = f[name][()], dict(f[name].attrs)
        del f[name]
        make(f, name, values)
        if isinstance(f.get(name, getlink=True), h5py.HardLink):
            f[name].attrs.update(attrs)


def _external_storage(target: str):
    def make(f, name, values):
        f.create_dataset(name, shape=values.shape, dtype=values.dtype, external=[(target, 0, values.nbytes)])
    return make


def _external_link(target: str, where: Path):
    def make(f, name, values):
        with h5py.File(where, "w") as other:
            other["x"] = values
        f[name] = h5py.ExternalLink(target, "/x")
    return make


def _virtual(target: str, where: Path):
    def make(f, name, values):
        with h5py.File(where, "w") as other:
            other["x"] = values
        layout = h5py.VirtualLayout(shape=values.shape, dtype=values.dtype)
        layout[...] = h5py.VirtualSource(target, "x", shape=values.shape)
        f.create_virtual_dataset(name, layout)
    return make


def _sed_values() -> np.ndarray:
    with h5py.File(DATA / "dolfinx" / "sed_only.h5", "r") as f:
        return f["/Function/sed/3"][()]


@pytest.mark.parametrize("kind", ["storage", "link", "virtual"])
def test_hdf5_heavy_data_outside_the_folder_is_refused_unless_allowed(tmp_path, kind):
    xdmf = _sed_only(tmp_path)
    values = _sed_values()
    outside = tmp_path / ("raw.bin" if kind == "storage" else "other.h5")
    if kind == "storage":
        (values * 3).tofile(outside)
        make, what = _external_storage("../raw.bin"), "the external storage of HDF5 dataset '/Function/sed/3'"
    elif kind == "link":
        make, what = _external_link("../other.h5", outside), "the target of the HDF5 external link 'Function/sed/3'"
    else:
        make, what = _virtual("../other.h5", outside), "the source of HDF5 virtual dataset '/Function/sed/3'"
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", make)
    with pytest.raises(SEDFormatError, match=re.escape(f"points to {what} '../")) as info:
        read_sed(xdmf, **UNITS)
    assert OUTSIDE in str(info.value) and ALLOW in str(info.value)
    field = read_sed(xdmf, **UNITS, allow_outside_files=True)
    np.testing.assert_allclose(field.sed[0], (values * (3 if kind == "storage" else 1)).ravel() * 1e6)
    assert os.path.realpath(outside) in {os.path.realpath(p) for p in field.provenance.files}


@needs_proc
@pytest.mark.parametrize("target", [ENVIRON, "/etc/passwd"])
def test_hdf5_external_storage_on_system_files_is_refused(tmp_path, target):
    xdmf = _sed_only(tmp_path)
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", _external_storage(target))
    with pytest.raises(SEDFormatError, match=re.escape(f"points to the external storage of HDF5 dataset '/Function/sed/3' "
                                                       f"{target!r}")):
        read_sed(xdmf, **UNITS)


def test_hdf5_external_storage_is_read_beside_its_file_not_in_the_working_folder(tmp_path, monkeypatch):
    """HDF5 takes a relative external-storage name from the working folder; afferent from the HDF5 file's folder."""
    xdmf = _sed_only(tmp_path)
    values = _sed_values()
    (values * 2).tofile(xdmf.parent / "raw.bin")
    (values * 5).tofile(tmp_path / "raw.bin")
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", _external_storage("raw.bin"))
    monkeypatch.chdir(tmp_path)
    field = read_sed(xdmf, **UNITS)
    np.testing.assert_allclose(field.sed[0], values.ravel() * 2e6)
    assert str(xdmf.parent / "raw.bin") in field.provenance.files


@pytest.mark.parametrize("name", ["../sed_only.h5", "ABS"])
def test_an_xdmf_heavy_data_file_outside_the_folder_is_refused(tmp_path, name):
    shutil.copy(DATA / "dolfinx" / "sed_only.h5", tmp_path)
    name = str(tmp_path / "sed_only.h5") if name == "ABS" else name
    xdmf = _sed_only(tmp_path, f'<DataItem Dimensions="32 1" Format="HDF">{name}:/Function/sed/3</DataItem>')
    with pytest.raises(SEDFormatError, match=re.escape(f"points to the heavy-data file of attribute 'sed' at t = 3 {name!r}, "
                                                       f"{OUTSIDE}")):
        read_sed(xdmf, **UNITS)
    assert read_sed(xdmf, **UNITS, allow_outside_files=True).sed.shape == (1, 32)


def _med_copy(tmp_path: Path, folder: str = "exp") -> tuple[Path, str]:
    """A copy of a real MED file in tmp_path/<folder>, and the path of its node coordinates."""
    exp = tmp_path / folder
    exp.mkdir()
    med = exp / "block.med"
    shutil.copy(DATA / "med" / "block_tetra.med", med)
    found = []
    with h5py.File(med, "r") as f:
        f.visit(lambda n: found.append(n) if n.endswith("NOE/COO") else None)
    return med, "/" + found[0]


@needs_proc
def test_med_external_storage_on_proc_environ_is_refused(tmp_path):
    med, coo = _med_copy(tmp_path)
    _rewrite(med, coo, _external_storage(ENVIRON))
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(med)!r} points to the external storage of HDF5 "
                                                       f"dataset {coo!r} {ENVIRON!r}") + f".*, {OUTSIDE}"):
        read_raw(med)


def test_med_external_storage_and_links_inside_the_folder_are_read(tmp_path):
    med, coo = _med_copy(tmp_path)
    before = read_raw(med).points
    _rewrite(med, coo, lambda f, name, values: (values.tofile(med.parent / "coo.bin"),
                                                _external_storage("coo.bin")(f, name, values)))
    raw = read_raw(med)
    np.testing.assert_array_equal(raw.points, before)
    assert raw.files == (str(med), str(med.parent / "coo.bin"))  # listed (the fuzzer found it left out)
    med, coo = _med_copy(tmp_path, "linked")
    with h5py.File(med, "r") as f:
        attrs = dict(f[coo].attrs)
    _rewrite(med, coo, _external_link("coo.h5", med.parent / "coo.h5"))
    with h5py.File(med.parent / "coo.h5", "a") as f:
        f["x"].attrs.update(attrs)  # MED's NBR
    raw = read_raw(med)
    np.testing.assert_array_equal(raw.points, before)
    assert raw.files == (str(med), str(med.parent / "coo.h5"))
    med, coo = _med_copy(tmp_path, "outside")
    _rewrite(med, coo, _external_link("../coo.h5", tmp_path / "coo.h5"))
    with pytest.raises(SEDFormatError, match=re.escape(f"points to the target of the HDF5 external link {coo[1:]!r} "
                                                       f"'../coo.h5', {OUTSIDE}")):
        read_raw(med)


def test_a_link_to_an_object_its_target_lacks_and_a_patterned_virtual_source_are_clean_errors(tmp_path):
    """Found by the fuzzer (fuzz/fuzz_paths.py): a KeyError from h5py, a RuntimeError from HDF5's name parser."""
    xdmf = _sed_only(tmp_path)
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", lambda f, name, values: f.__setitem__(
        name, h5py.ExternalLink("sed_only.h5", "/nowhere")))
    with pytest.raises(SEDFormatError, match=re.escape("dataset '/Function/sed/3' of attribute 'sed' at t = 3 is not in")):
        read_sed(xdmf, **UNITS)
    xdmf = _sed_only(tmp_path / "p")
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", _virtual("x%%.h5", xdmf.parent / "x%.h5"))
    with pytest.raises(SEDFormatError, match=re.escape("names its source file 'x%%.h5' with '%'")):
        read_sed(xdmf, **UNITS)


def test_exodus_netcdf4_external_storage_outside_the_folder_is_refused(tmp_path):
    exp = tmp_path / "exp"
    exp.mkdir()
    e = exp / "layers.e"
    shutil.copy(DATA / "exodus" / "layers_sfepy.e", e)
    before = read_raw(e).points
    with h5py.File(e, "r") as f:
        name = next(n for n in ("coordx", "coord") if n in f)
    _rewrite(e, name, lambda f, n, values: (values.tofile(tmp_path / "x.bin"), _external_storage("../x.bin")(f, n, values)))
    with pytest.raises(SEDFormatError, match=re.escape(f"points to the external storage of HDF5 dataset '/{name}' "
                                                       f"'../x.bin', {OUTSIDE}")):
        read_raw(e)
    np.testing.assert_array_equal(read_raw(e, allow_outside_files=True).points, before)


@needs_proc
def test_load_results_refuses_a_currents_nc_stored_in_proc_environ(tmp_path):
    """Before: load_results returned the variable's values read from /proc/self/environ."""
    from afferent import load_results

    (tmp_path / "run.json").write_text("{}")
    with h5py.File(tmp_path / "currents.nc", "w") as f:
        f.create_dataset("sed_pa", shape=(16,), dtype="u1", external=[(ENVIRON, 0, 16)])
    with pytest.raises(SEDFormatError, match=re.escape(f"Results file {str(tmp_path / 'currents.nc')!r}: dataset 'sed_pa' "
                                                       "is stored in other files")):
        load_results(tmp_path)


def _vtu_members(tmp_path: Path) -> tuple[Path, Path]:
    """tmp_path/exp (the export's folder) and tmp_path/out holding a valid step file."""
    exp, out = tmp_path / "exp", tmp_path / "out"
    exp.mkdir()
    out.mkdir()
    shutil.copy(ROOT / "fuzz" / "seeds" / "step.vtu", out / "step.vtu")
    return exp, out


@pytest.mark.parametrize("how", ["absolute", "up", "symlink"])
@pytest.mark.parametrize("index", [".pvd", ".vtu.series"])
def test_series_members_outside_the_folder_are_refused(tmp_path, how, index):
    exp, out = _vtu_members(tmp_path)
    name = {"absolute": str(out / "step.vtu"), "up": "../out/step.vtu", "symlink": "link.vtu"}[how]
    if how == "symlink":
        (exp / "link.vtu").symlink_to(out / "step.vtu")
    p = exp / f"s{index}"
    p.write_text(json.dumps({"files": [{"name": name, "time": 0.0}]}) if index.endswith(".series") else
                 f'<VTKFile type="Collection"><Collection><DataSet timestep="0" file="{name}"/></Collection></VTKFile>')
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} points to the step file (entry 0) {name!r}")):
        read_raw(p)
    assert read_raw(p, allow_outside_files=True).points.shape == (8, 3)


@pytest.mark.parametrize("how", ["absolute", "up"])
def test_pvtu_pieces_and_vtm_blocks_outside_the_folder_are_refused(tmp_path, how):
    pytest.importorskip("vtkmodules")
    exp, out = _vtu_members(tmp_path)
    name = str(out / "step.vtu") if how == "absolute" else "../out/step.vtu"
    pvtu = exp / "r.pvtu"
    pvtu.write_text('<VTKFile type="PUnstructuredGrid"><PUnstructuredGrid GhostLevel="0"><PPoints>'
                    '<PDataArray type="Float64" NumberOfComponents="3"/></PPoints>'
                    f'<Piece Source="{name}"/></PUnstructuredGrid></VTKFile>')
    vtm = exp / "b.vtm"
    vtm.write_text(f'<VTKFile type="vtkMultiBlockDataSet" version="1.0"><vtkMultiBlockDataSet><DataSet index="0" file="{name}"/>'
                   '</vtkMultiBlockDataSet></VTKFile>')
    for p, what in ((pvtu, "the piece"), (vtm, "the block")):
        with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} points to {what} {name!r}")):
            read_raw(p)
        assert read_raw(p, allow_outside_files=True).points.shape == (8, 3)


def test_the_cli_flag_allows_it_on_purpose(tmp_path):
    exp, out = _vtu_members(tmp_path)
    p = exp / "s.pvd"
    p.write_text('<VTKFile type="Collection"><Collection><DataSet timestep="0" file="../out/step.vtu"/></Collection></VTKFile>')
    code, err = _cli("info", p, cwd=tmp_path)
    assert code == 2 and OUTSIDE in err and f"pass {FLAG}." in err
    code, err = _cli("info", p, FLAG, cwd=tmp_path)
    assert code == 0, err


def test_the_real_exports_that_point_to_their_own_folder_still_read():
    """deal.II .pvtu records, Kratos' .vtm series in a subfolder, DOLFINx heavy data, a .pvd of them."""
    pytest.importorskip("vtkmodules")
    assert read_raw(DATA / "kratos" / "vtu" / "Structure.vtm.series").n_times == 2
    assert read_raw(DATA / "dealii" / "block.pvd").n_times >= 2
    assert read_raw(DATA / "dolfinx" / "block.xdmf").n_times >= 2


# ------------------------------------------------------------------ item 8: hangs
@needs_fifo
@pytest.mark.parametrize("command", ["run", "info"])
def test_a_fifo_export_is_refused_at_once(tmp_path, command):
    """Before: `run` blocked for ever hashing the FIFO; `info` said 'not found'."""
    os.mkfifo(tmp_path / "pipe.vtu")
    extra = ["--receptors", _receptors(tmp_path), *RUN] if command == "run" else []
    code, err = _cli(command, "pipe.vtu", *extra, cwd=tmp_path)
    assert code == 2 and "pipe.vtu' is a FIFO (named pipe), not a regular file" in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_device_export_is_refused_at_once(tmp_path):
    (tmp_path / "zero.vtu").symlink_to("/dev/zero")
    code, err = _cli("run", "zero.vtu", "--receptors", _receptors(tmp_path), *RUN, cwd=tmp_path)
    assert code == 2 and "zero.vtu' is a character device, not a regular file" in err, err


def _hostile_storage(tmp_path: Path, kind: str) -> tuple[Path, str]:
    """The XDMF export with its SED stored on a FIFO, /dev/zero or a 50 GB sparse file, or linked to a FIFO."""
    xdmf = _sed_only(tmp_path)
    if kind == "fifo storage":
        os.mkfifo(xdmf.parent / "pipe.bin")
        make, said = _external_storage("pipe.bin"), "is a FIFO (named pipe), not a regular file"
    elif kind == "fifo link":
        os.mkfifo(xdmf.parent / "pipe.h5")
        make, said = (lambda f, name, values: f.__setitem__(name, h5py.ExternalLink("pipe.h5", "/x"))), "is a FIFO"
    elif kind == "dev/zero":
        make, said = _external_storage("/dev/zero"), OUTSIDE
    else:
        with open(tmp_path / "sparse.bin", "wb") as fh:
            fh.truncate(50 * 2**30)
        make, said = _external_storage(str(tmp_path / "sparse.bin")), OUTSIDE
    _rewrite(xdmf.parent / "sed_only.h5", "/Function/sed/3", make)
    return xdmf, said


@needs_fifo
@pytest.mark.parametrize("kind", ["fifo storage", "fifo link", "dev/zero", "sparse"])
def test_hdf5_storage_that_never_ends_is_refused_at_once(tmp_path, kind):
    """Before: `run` never ended (the file hash read /dev/zero or 50 GB, or blocked opening the FIFO)."""
    xdmf, said = _hostile_storage(tmp_path, kind)
    code, err = _cli("run", xdmf, "--receptors", _receptors(tmp_path), *RUN, cwd=tmp_path)
    assert code == 2 and said in err and err.count("\n") == 1, err


@needs_fifo
def test_a_vtm_block_that_is_a_fifo_is_refused(tmp_path):
    pytest.importorskip("vtkmodules")
    os.mkfifo(tmp_path / "block.vtu")
    (tmp_path / "b.vtm").write_text('<VTKFile type="vtkMultiBlockDataSet" version="1.0"><vtkMultiBlockDataSet>'
                                    '<DataSet index="0" file="block.vtu"/></vtkMultiBlockDataSet></VTKFile>')
    code, err = _cli("info", "b.vtm", cwd=tmp_path)
    assert code == 2 and "names the block" in err and "is a FIFO (named pipe)" in err, err


@needs_fifo
def test_load_results_refuses_a_fifo_table(tmp_path):
    (tmp_path / "run.json").write_text("{}")
    os.mkfifo(tmp_path / "spikes.csv")
    code = (f"import afferent\ntry:\n    afferent.load_results({str(tmp_path)!r})\nexcept Exception as e:\n"
            "    print(type(e).__name__, e)")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    try:
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60).stdout
    except subprocess.TimeoutExpired:
        pytest.fail("load_results blocked on a FIFO")
    assert f"SEDFormatError Run table {str(tmp_path / 'spikes.csv')!r} is a FIFO (named pipe)" in out, out


@needs_fifo
@pytest.mark.skipif(not (ROOT / "sample_sed" / "scenes" / "sweep_gamma.toml").is_file(), reason="sample_sed/ not present")
def test_a_sweep_resume_refuses_a_fifo_record(tmp_path):
    """Before: resuming the sweep blocked for ever opening the FIFO tasks/batch-*.jsonl."""
    from afferent._sweep import sweep

    source = ROOT / "sample_sed" / "scenes" / "sweep_gamma.toml"
    base = source.read_text().split("[sweep]")[0].replace('"../', f'"{source.parent.parent.as_posix()}/')
    src = tmp_path / "s.toml"
    src.write_text(base + '[sweep]\n"transduction.gamma_per_pa" = [2e-3]\n')
    sweep(src, tmp_path / "out", scheduler="serial")
    os.mkfifo(tmp_path / "out" / "tasks" / "batch-zzz.jsonl")
    code, err = _cli("sweep", src, "-o", "out", cwd=tmp_path)
    assert code == 2 and "batch-zzz.jsonl' is a FIFO (named pipe), not a regular file" in err, err


def test_a_run_allowed_outside_does_not_serve_one_that_is_not_from_the_cache(tmp_path):
    """A scene's [export] allow_outside_files = true reads the file and caches the sampled SED; the same scene
    without it must be refused, not served from that cache entry (the permission is part of the key)."""
    import textwrap

    from afferent.scene import load_scene, run_scene

    xdmf = _sed_only(tmp_path, '<DataItem Dimensions="32 1" Format="HDF">../sed_only.h5:/Function/sed/3</DataItem>')
    shutil.copy(DATA / "dolfinx" / "sed_only.h5", tmp_path)
    _receptors(tmp_path)

    def scene(allow: bool) -> Path:
        p = tmp_path / f"scene-{allow}.toml"
        p.write_text(textwrap.dedent(f"""
            [export]
            file = {str(xdmf)!r}
            length_unit = "mm"
            sed_unit = "MPa"
            allow_outside_files = {str(allow).lower()}
            [receptors]
            file = {str(tmp_path / 'r.csv')!r}
            [outputs]
            want = ["sed_map"]
            dir = {str(tmp_path / f'out-{allow}')!r}
            """))
        return p

    allowed = run_scene(load_scene(scene(True)), overwrite=True, cache_dir=tmp_path / "cache")
    assert str(xdmf.parent / "../sed_only.h5") in allowed.record["field"]["files"]
    with pytest.raises(SEDFormatError, match=re.escape(f"'../sed_only.h5', {OUTSIDE}")):
        run_scene(load_scene(scene(False)), overwrite=True, cache_dir=tmp_path / "cache")
    again = run_scene(load_scene(scene(True)), overwrite=True, cache_dir=tmp_path / "cache")
    assert again.cache_hit is True


def test_a_parallel_record_under_another_name_is_refused_not_left_to_vtk(tmp_path):
    """--format pvtu on 'x.xml': VTK's generic reader would open the pieces itself, unchecked."""
    exp, out = _vtu_members(tmp_path)
    p = exp / "r.xml"
    p.write_text('<VTKFile type="PUnstructuredGrid" version="1.0"><PUnstructuredGrid GhostLevel="0"><PPoints>'
                 '<PDataArray type="Float64" NumberOfComponents="3"/></PPoints>'
                 '<Piece Source="../out/step.vtu"/></PUnstructuredGrid></VTKFile>')
    for fmt in ("pvtu", "vtm"):
        with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r}: a {fmt} file is read by its name")):
            read_raw(p, format=fmt)


@needs_fifo
def test_a_coordinates_table_that_is_a_fifo_is_refused(tmp_path):
    """The export's own table is checked by read_sed; a --coordinates table is opened by the text reader."""
    table = tmp_path / "t.csv"
    table.write_text("node,sed\n1,1.0\n")
    os.mkfifo(tmp_path / "nodes.csv")
    code = (f"import afferent\ntry:\n    afferent.read_sed({str(table)!r}, coordinates={str(tmp_path / 'nodes.csv')!r}, "
            "length_unit='mm', sed_unit='MPa')\nexcept Exception as e:\n    print(type(e).__name__, e)")
    try:
        out = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True,
                             text=True, timeout=60).stdout
    except subprocess.TimeoutExpired:
        pytest.fail("read_sed blocked on a FIFO coordinates table")
    assert "nodes.csv' is a FIFO (named pipe), not a regular file" in out, out
