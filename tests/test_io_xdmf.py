"""XDMF written by DOLFINx 0.5.2 itself (tests/data/dolfinx/make_dolfinx.py): one grid per
function and time step, which meshio's XDMF reader refuses. References: the HDF5 datasets read
with h5py here, and DOLFINx's own SED (DG0 interpolation of 1/2 sigma:eps) against the SED
afferent computes from the written stress and strain tensors.
"""

from __future__ import annotations

import os
import re
import shutil

import h5py
import numpy as np
import pytest

from afferent import read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import read_raw
from afferent.receptors import ReceptorLayout

from conftest import DATA_DIR

DX = DATA_DIR / "dolfinx"
MU = 0.1 / (2 * 1.45)  # MPa: E = 0.1 MPa, nu = 0.45


def test_every_function_and_time_of_a_dolfinx_file():
    raw = read_raw(DX / "block.xdmf")
    np.testing.assert_array_equal(raw.times, [1.0, 2.0, 3.0])
    assert raw.cells.cell_types == ("hexahedron",) and raw.cells.n_cells == 32 and raw.points.shape == (75, 3)
    assert {k: (a.location, a.values.shape) for k, a in raw.arrays.items()} == {
        "u": ("point", (3, 75, 3)), "stress": ("cell", (3, 32, 9)), "strain": ("cell", (3, 32, 9)),
        "sed": ("cell", (3, 32)), "sed_nodal": ("point", (3, 75)),
    }
    with h5py.File(DX / "block.h5") as h5:
        for k in (1, 2, 3):
            np.testing.assert_array_equal(raw.arrays["stress"].values[k - 1], h5[f"Function/stress/{k}"][()])
            np.testing.assert_array_equal(raw.arrays["sed"].values[k - 1], h5[f"Function/sed/{k}"][()][:, 0])
        np.testing.assert_array_equal(raw.points, h5["Mesh/mesh/geometry"][()])
    # the patch goes down by d = 1/3, 2/3, 3/3 of 0.1 mm
    np.testing.assert_allclose(raw.arrays["u"].values[:, :, 2].min(axis=1), [-0.1 / 3, -0.2 / 3, -0.1], rtol=1e-12)


@pytest.mark.parametrize("preset", ["abaqus", "comsol", "sfepy"])
def test_sed_from_dolfinx_tensors_equals_dolfinx_own_sed(preset):
    """3x3 tensors hold tensor components whatever a preset says about 6-vectors."""
    own = read_sed(DX / "block.xdmf", length_unit="mm", sed_unit="MPa")
    assert own.location == "cell" and own.provenance.columns["sed"] == "sed"
    exact = read_sed(DX / "block.xdmf", length_unit="mm", stress_unit="MPa", sed_from="exact", preset=preset)
    np.testing.assert_allclose(exact.sed, own.sed, rtol=1e-12)
    shear = exact.provenance.checks["shear_convention"]
    assert shear["consistent"] and shear["k_shear"] == pytest.approx(2 * MU * 1e6, rel=1e-10)
    assert exact.provenance.checks["tensor_sed_vs_export_sed"]["relative_difference"] < 1e-12


def test_nodal_function_samples_exactly_at_the_nodes():
    field = read_sed(DX / "block.xdmf", length_unit="mm", sed_unit="MPa", sed_column="sed_nodal")
    assert field.location == "point"
    raw = read_raw(DX / "block.xdmf")
    layout = ReceptorLayout(raw.points[::7] * 1e-3)
    np.testing.assert_allclose(sample_sed(field, layout).values, field.sed[:, ::7], rtol=1e-12, atol=1e-12)
    # and the projected nodal SED stays close to the cell SED where the field is smooth: same order of magnitude
    assert 0.3 < field.sed.max() / read_sed(DX / "block.xdmf", length_unit="mm", sed_unit="MPa").sed.max() < 3


def test_a_single_function_file():
    raw = read_raw(DX / "sed_only.xdmf")
    np.testing.assert_array_equal(raw.times, [3.0])
    assert list(raw.arrays) == ["sed"] and raw.arrays["sed"].location == "cell"


def test_missing_heavy_data_and_damaged_files_are_named(tmp_path):
    shutil.copy(DX / "block.xdmf", tmp_path / "block.xdmf")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(tmp_path / 'block.xdmf')!r}: the heavy-data file {str(tmp_path / 'block.h5')!r} of the geometry "
            "of grid 'mesh' is missing (keep the .h5 beside the .xdmf).")):
        read_raw(tmp_path / "block.xdmf")
    with h5py.File(DX / "block.h5") as src, h5py.File(tmp_path / "block.h5", "w") as dst:
        for name in ("Mesh", "Function/u", "Function/stress"):
            src.copy(src[name], dst, name)
    with pytest.raises(SEDFormatError, match=re.escape("dataset '/Function/strain/1' of attribute 'strain' at t = 1 is not in")):
        read_raw(tmp_path / "block.xdmf")
    text = (DX / "block.xdmf").read_text()
    (tmp_path / "cut.xdmf").write_text(text[: len(text) // 2])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(tmp_path / 'cut.xdmf')!r} is not a valid XDMF (XML) file")):
        read_raw(tmp_path / "cut.xdmf")


def test_info_lists_the_functions_and_steps(capsys):
    assert main(["info", str(DX / "block.xdmf")]) == 0
    out = capsys.readouterr().out
    assert "time steps   3, t = 1 .. 3" in out and "32 volume cells (hexahedron)" in out
    assert "XDMF with 15 grids in temporal collections: 3 time step(s), functions u, stress, strain, sed, sed_nodal" in out


def test_a_meshio_time_series_with_mixed_cells(tmp_path, monkeypatch):
    """meshio's TimeSeriesWriter: a 'Mixed' topology (hexahedron + tetrahedron) and xi:include in the
    2003 XInclude namespace; decoded with meshio's own cell tables."""
    import meshio

    monkeypatch.chdir(tmp_path)  # meshio writes the .h5 beside the working folder
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)] + [[0.5, 0.5, 2]], float)
    cells = [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]])), ("tetra", np.array([[4, 5, 6, 8]]))]
    with meshio.xdmf.TimeSeriesWriter("mixed.xdmf") as w:
        w.write_points_cells(pts, cells)
        for t in (0.0, 1.0):
            w.write_data(t, point_data={"SED": np.full(9, 1e-4 * (t + 1))})
    raw = read_raw("mixed.xdmf")
    assert raw.cells.cell_types == ("hexahedron", "tetra") and raw.cells.n_cells == 2
    np.testing.assert_array_equal(raw.times, [0.0, 1.0])
    np.testing.assert_allclose(raw.arrays["SED"].values[:, 0], [1e-4, 2e-4])


def test_a_series_steps_read_whole_are_h5py_s_values_bit_for_bit(tmp_path, monkeypatch):
    """The later datasets of a series (hard links in a group already followed) are read by one H5Dread into
    a new array when they are contiguous and allocated, integers or reals (afferent.io._xdmf._read_whole);
    every other storage goes through h5py's own read. Each step is h5py's `f[name][()]` as float64, bit for
    bit, whichever way it was read; an external link's target is listed. An unallocated dataset
    whose fill time is 'never' is the reason for the guard: HDF5 leaves the buffer untouched."""
    import meshio
    from h5py import h5d, h5s, h5t

    from afferent.io import _raw_steps, _xdmf

    monkeypatch.chdir(tmp_path)  # meshio writes the .h5 into the working folder
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    sed = 1e-4 * (1.0 + pts @ [1.0, 2.0, 3.0])
    kinds = ["float64", ">f8", "<f4", ">i4", "chunked gzip", "compact", "fill never", "external link"]
    with meshio.xdmf.TimeSeriesWriter("s.xdmf") as w:
        w.write_points_cells(pts, [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]]))])
        for k in range(len(kinds)):
            w.write_data(float(k), point_data={"SED": sed * (k + 1)})
    names = [f"/data{k + 2}" for k in range(len(kinds))]  # meshio's names: the mesh's /data0 and /data1, then a step each
    assert re.findall(r"s\.h5:(/data\d+)", (tmp_path / "s.xdmf").read_text()) == names + ["/data0", "/data1"]
    with h5py.File("s.h5", "r+") as f, h5py.File("target.h5", "w") as target:
        for kind, name in zip(kinds, names):
            values = f[name][()]
            del f[name]
            if kind in ("float64", ">f8", "<f4"):
                f[name] = values.astype(kind)
            elif kind == ">i4":
                f[name] = (values * 1e7).astype(">i4")
            elif kind == "chunked gzip":
                f.create_dataset(name, data=values, chunks=(4,), compression="gzip")
            elif kind == "external link":
                target["sed"] = values
                f[name] = h5py.ExternalLink("target.h5", "/sed")
            else:  # compact storage, or none allocated with HDF5's fill time 'never'
                dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
                dcpl.set_layout(h5d.COMPACT) if kind == "compact" else dcpl.set_fill_time(h5d.FILL_TIME_NEVER)
                dset = h5d.create(f.id, name.encode(), h5t.NATIVE_DOUBLE, h5s.create_simple(values.shape), dcpl=dcpl)
                if kind == "compact":
                    dset.write(h5s.ALL, h5s.ALL, values)
    whole = []
    original = _xdmf._read_whole
    monkeypatch.setattr(_xdmf, "_read_whole", lambda h5, name, *check: whole.append((name, r := original(h5, name, *check))) or r)
    steps = list(_raw_steps("s.xdmf", None, False)[1])
    read_whole = {name for name, r in whole if r is not None}
    assert read_whole == {"/data1", *names[:4]}  # the cells (after the points followed the group) and 4 steps
    assert {name for name, r in whole if r is None} == set(names[4:7])  # chunked, compact, fill never
    with h5py.File("s.h5", "r") as f:
        for step, name in zip(steps, names):
            values = step.arrays["SED"].values[0]
            assert values.dtype == np.float64
            np.testing.assert_array_equal(values, np.asarray(f[name][()]).astype(float), err_msg=name)
        np.testing.assert_array_equal(steps[6].arrays["SED"].values[0], 0.0)  # h5py's zero-filled buffer
        buffer = np.full(len(pts), 7.0)
        h5d.open(f.id, names[6].encode()).read(h5s.ALL, h5s.ALL, buffer)
        np.testing.assert_array_equal(buffer, 7.0)  # untouched by HDF5: an uninitialised buffer would be garbage
    # the link's target is opened (its own links resolved: afferent.io._files.h5_open) with s.h5, so listed from the start
    assert [os.path.basename(p) for p in steps[-1].files] == ["s.xdmf", "s.h5", "target.h5"]
    assert [os.path.basename(p) for p in steps[0].files] == ["s.xdmf", "s.h5", "target.h5"]


def test_a_series_xml_is_parsed_once_and_its_meshes_and_links_listed_once(monkeypatch):
    """_raw_steps parsed the XDMF three times (collections? how many steps? then the steps), the mesh
    grids were listed again for every leaf grid, twice (N^2 for N steps), and each step's dataset had
    its link checked: once each now, the links once per HDF5 group (DOLFINx: /Mesh/mesh, and one group
    per function holding its steps)."""
    from afferent.io import _raw_steps, _xdmf

    parses, listings, groups = [], [], []
    parse, uniform, hard_links = _xdmf._parse, _xdmf._uniform_grids, _xdmf._Heavy._hard_links
    monkeypatch.setattr(_xdmf, "_parse", lambda path: parses.append(path) or parse(path))
    monkeypatch.setattr(_xdmf, "_uniform_grids", lambda domain: listings.append(1) or uniform(domain))
    monkeypatch.setattr(_xdmf._Heavy, "_hard_links", staticmethod(lambda h5, g: groups.append(g) or hard_links(h5, g)))
    n_steps, steps = _raw_steps(str(DX / "block.xdmf"), None, False)
    steps = list(steps)
    assert n_steps == len(steps) == 3 and len(steps[0].arrays) == 5
    assert len(parses) == 1 and len(listings) == 1
    assert sorted(groups) == ["/Function/" + f for f in sorted(("sed", "sed_nodal", "strain", "stress", "u"))] + [
        "/Mesh/mesh"]
    with h5py.File(DX / "block.h5", "r") as f:  # every step's arrays as h5py reads them
        for k, step in enumerate(steps, start=1):
            for name, a in step.arrays.items():
                np.testing.assert_array_equal(a.values[0].ravel(), f[f"/Function/{name}/{k}"][()].ravel())


def test_datasets_stored_in_other_files_list_those_files(tmp_path, monkeypatch):
    """A step whose dataset keeps its values in an external raw file (HDF5 external storage) or in
    another HDF5 file (a virtual dataset) lists that file among the files read (what the cache and
    run.json hash): before, neither was listed, so rewriting it went unnoticed."""
    import meshio

    from afferent.io import _raw_steps

    monkeypatch.chdir(tmp_path)
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    sed = 1e-4 * (1.0 + pts @ [1.0, 2.0, 3.0])
    with meshio.xdmf.TimeSeriesWriter("s.xdmf") as w:
        w.write_points_cells(pts, [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]]))])
        for k in range(4):
            w.write_data(float(k), point_data={"SED": sed * (k + 1)})
    with h5py.File("s.h5", "r+") as f, h5py.File("source.h5", "w") as source:
        values = f["/data4"][()]
        del f["/data4"]  # step 2: values in an external raw file
        f.create_dataset("/data4", shape=values.shape, dtype="<f8", external=[("raw.bin", 0, values.nbytes)])
        f["/data4"][...] = values
        values = f["/data5"][()]
        del f["/data5"]  # step 3: a virtual dataset over another HDF5 file
        source["sed"] = values
        layout = h5py.VirtualLayout(shape=values.shape, dtype="f8")
        layout[:] = h5py.VirtualSource("source.h5", "sed", shape=values.shape)
        f.create_virtual_dataset("/data5", layout)
    steps = list(_raw_steps("s.xdmf", None, False)[1])
    names = [[os.path.basename(p) for p in step.files] for step in steps]
    assert names[1] == ["s.xdmf", "s.h5"]
    assert "raw.bin" in names[2] and "source.h5" in names[3]
    for k, step in enumerate(steps):
        np.testing.assert_array_equal(step.arrays["SED"].values[0], sed * (k + 1))


# ------------------------------------------------------------- issue 33, item 11: malformed heavy data
def _binary_series(folder, sed_item: str) -> str:
    """A temporal collection of one grid whose data are raw binary files (meshio's Binary XDMF, wrapped in a
    collection so that afferent's own reader reads it), the SED DataItem's attributes replaced by ``sed_item``."""
    import meshio

    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    mesh = meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))], point_data={"sed": np.arange(1.0, 5.0)})
    meshio.xdmf.write(os.path.join(folder, "b.xdmf"), mesh, data_format="Binary")
    grid = re.search(r'<Grid Name="Grid">(.*)</Grid>', open(os.path.join(folder, "b.xdmf")).read()).group(1)
    grid = grid.replace('DataType="Float" Dimensions="4" Format="Binary"', sed_item)
    path = os.path.join(folder, "series.xdmf")
    with open(path, "w") as f:
        f.write('<Xdmf Version="3.0"><Domain><Grid Name="T" GridType="Collection" CollectionType="Temporal">'
                f'<Grid Name="mesh" GridType="Uniform"><Time Value="0.5"/>{grid}</Grid></Grid></Domain></Xdmf>')
    return path


@pytest.mark.parametrize("item, message", [
    ('DataType="Float" Dimensions="4" Format="Binary"', None),
    ('DataType="Float" Dimensions="4" Seek="-5" Format="Binary"',
     "the Seek of attribute 'sed' at t = 0.5 must be a byte offset, a whole number >= 0; got '-5' instead."),
    ('DataType="Float" Dimensions="4" Seek="abc" Format="Binary"',
     "the Seek of attribute 'sed' at t = 0.5 must be a byte offset, a whole number >= 0; got 'abc' instead."),
    ('DataType="Float" Dimensions="100000000000" Format="Binary"',  # refused by the mesh's row count, before the file
     "attribute 'sed' at t = 0.5 must have one row per point (4); got 100000000000."),
    ('DataType="Float" Dimensions="4 25000000000" Format="Binary"',
     "attribute 'sed' at t = 0.5 must hold 100000000000 values of 8 byte(s) (its Dimensions) from byte 0 of "
     "'{folder}/b2.bin'; the file holds 32 byte(s) from there."),
    ('DataType="Float" Dimensions="4" Seek="24" Format="Binary"',
     "attribute 'sed' at t = 0.5 must hold 4 values of 8 byte(s) (its Dimensions) from byte 24 of "
     "'{folder}/b2.bin'; the file holds 8 byte(s) from there."),
    ('DataType="Float" Dimensions="²" Format="Binary"',
     "the Dimensions of attribute 'sed' at t = 0.5 must be whole numbers separated by spaces; got '²' instead."),
])
def test_a_binary_data_item_is_checked_against_its_file_before_it_is_read(tmp_path, item, message):
    """Before: OSError 'Invalid argument' (Seek -5), ValueError from int() (Seek abc), MemoryError allocating
    745 GiB (Dimensions 1e11 over a 32-byte file), ValueError from int('²'): each an internal error, exit 1."""
    path = _binary_series(str(tmp_path), item)
    if message is None:
        np.testing.assert_array_equal(read_raw(path).arrays["sed"].values.ravel(), [1, 2, 3, 4])
        return
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {path!r}: " + message.format(folder=tmp_path))):
        read_raw(path)


@pytest.mark.parametrize("target, meaning", [  # the resolver (afferent.io._files) checks each link's target first
    (("notes.txt", "/x"), "SED file 's.h5': the target 'notes.txt' of its HDF5 external link 'data3' could not be "
                          "opened as HDF5 (truncated or corrupt?)"),
    (("s.h5", "/nothing"), "SED file 's.xdmf': dataset '/data3' of attribute 'SED' at t = 1 is not in 's.h5' (or an "
                           "external link on its path points to a missing file"),
    (("s.h5", "/data3"), "SED file 's.xdmf': dataset '/data3' of attribute 'SED' at t = 1 is not in 's.h5' (or an "
                         "external link on its path points to a missing file"),
])
def test_an_external_link_that_cannot_be_followed_is_named(tmp_path, monkeypatch, target, meaning):
    """Links inside the export's folder to a text file, to a missing object, to itself: before, OSError or KeyError
    from h5py, an internal error (exit 1)."""
    import meshio

    monkeypatch.chdir(tmp_path)
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    with meshio.xdmf.TimeSeriesWriter("s.xdmf") as w:
        w.write_points_cells(pts, [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]]))])
        for k in range(2):
            w.write_data(float(k), point_data={"SED": 1e-4 * (k + 1) * (1.0 + pts[:, 0])})
    (tmp_path / "notes.txt").write_text("not HDF5\n" * 100)
    with h5py.File("s.h5", "r+") as f:
        del f["/data3"]
        f["/data3"] = h5py.ExternalLink(*target)
    with pytest.raises(SEDFormatError, match=re.escape(meaning)):
        read_raw("s.xdmf")


def _zeros_gzip(h5, name: str, shape: tuple, chunk_rows: int = 1 << 20) -> None:
    """A chunked gzip dataset of float64 zeros (``shape``), every chunk written as the same precompressed
    bytes (no 8-GB buffer, no compression time): ~1 kB stored per 1 MiB of values."""
    import zlib

    rows = min(chunk_rows, shape[0])
    dset = h5.create_dataset(name, shape=shape, dtype="f8", chunks=(rows,) + shape[1:], compression="gzip")
    packed = zlib.compress(bytes(8 * rows * int(np.prod(shape[1:]))), 9)
    for start in range(0, shape[0], rows):
        dset.id.write_direct_chunk((start,) + (0,) * (len(shape) - 1), packed)


def _dolfinx_copy(tmp_path, replace: dict, dims: dict | None = None) -> str:
    """The DOLFINx block (tests/data/dolfinx) copied to ``tmp_path``, datasets replaced by ``replace``
    ({name: function(h5 file, name)}) and DataItem Dimensions rewritten by ``dims`` ({dataset: text})."""
    shutil.copy(DX / "block.h5", tmp_path / "block.h5")
    text = (DX / "block.xdmf").read_text()
    for name, dim in (dims or {}).items():
        text, n = re.subn(rf'Dimensions="[^"]*"(?=[^>]*>block\.h5:{re.escape(name)}<)', f'Dimensions="{dim}"', text)
        assert n == 1, name
    (tmp_path / "block.xdmf").write_text(text)
    with h5py.File(tmp_path / "block.h5", "r+") as h5:
        for name, make in replace.items():
            del h5[name]
            make(h5, name)
    return str(tmp_path / "block.xdmf")


def _read_in_child(path: str) -> dict:
    from _memory import in_child

    return in_child(f"""
        from afferent.io import read_raw
        read_raw({path!r})
    """)


def test_a_dataset_larger_than_its_dimensions_is_refused_before_it_is_read(tmp_path):
    """Issue 33 item 10: a 2 MB .h5 whose gzip dataset inflates to 2 GiB under XDMF Dimensions "75 1". Before:
    read whole (2.1 GB), then refused for its size; now refused from its shape, nothing read."""
    path = _dolfinx_copy(tmp_path, {"/Function/sed_nodal/2": lambda h5, n: _zeros_gzip(h5, n, (1 << 28, 1))})
    assert os.path.getsize(tmp_path / "block.h5") < 3e6
    got = _read_in_child(path)
    assert got["error"] == ["SEDFormatError", f"SED file {path!r}: attribute 'sed_nodal' at t = 2 must hold 75 x 1 "
                            "values (its Dimensions); got 268435456 instead."], got
    assert got["peak_mb"] < 400, got


def test_values_for_more_rows_than_the_mesh_has_are_refused_before_they_are_read(tmp_path):
    """An attribute declaring 1e9 rows (Dimensions and dataset agree; its chunks never written: HDF5 would
    hand back 8 GB of fill value) on a mesh of 75 points: refused from the Dimensions, nothing read."""
    def unwritten(h5, name):
        h5.create_dataset(name, shape=(10**9, 1), dtype="f8", chunks=(1 << 20, 1))

    path = _dolfinx_copy(tmp_path, {"/Function/sed_nodal/2": unwritten}, {"/Function/sed_nodal/2": "1000000000 1"})
    got = _read_in_child(path)
    assert got["error"] == ["SEDFormatError", f"SED file {path!r}: attribute 'sed_nodal' at t = 2 must have one row "
                            "per point (75); got 1000000000."], got
    assert got["peak_mb"] < 400, got


def test_a_geometry_whose_file_stores_none_of_its_values_is_refused(tmp_path):
    """The mesh's own geometry declaring 1e8 points (2.4 GB; Dimensions and dataset agree) whose chunks were
    never written: no count to check it against, but its file stores nothing of it; refused before reading."""
    def unwritten(h5, name):
        h5.create_dataset(name, shape=(10**8, 3), dtype="f8", chunks=(1 << 18, 3))

    path = _dolfinx_copy(tmp_path, {"/Mesh/mesh/geometry": unwritten}, {"/Mesh/mesh/geometry": "100000000 3"})
    got = _read_in_child(path)
    assert got["error"] == ["SEDFormatError", f"SED file {path!r}: the geometry of grid 'mesh' ({str(tmp_path / 'block.h5')!r}, "
                            "dataset '/Mesh/mesh/geometry'): the dataset holds 300,000,000 values (shape (100000000, 3), "
                            "2,400,000,000 bytes) of which the file stores 0 bytes: chunks never written (no data, "
                            "HDF5's fill value) or a compression beyond gzip's (1,100:1 at most); refused before reading "
                            "it."], got
    assert got["peak_mb"] < 400, got


def test_all_zero_values_compressed_by_gzip_pass_the_stored_bytes_check(tmp_path):
    """The check of what a file stores does not refuse legitimate data: 128 MiB of zeros under gzip (~1,000:1)
    pass, as would their read; the same values unwritten do not."""
    from afferent.io._raw import h5_check

    with h5py.File(tmp_path / "z.h5", "w") as h5:
        _zeros_gzip(h5, "zeros", (1 << 24,))
        h5.create_dataset("unwritten", shape=(1 << 24,), dtype="f8", chunks=(1 << 20,))
        ratio = h5["zeros"].nbytes / h5["zeros"].id.get_storage_size()
        assert 900 < ratio < 1100
        h5_check(h5["zeros"], "zeros")
        with pytest.raises(SEDFormatError, match=re.escape("unwritten: the dataset holds 16,777,216 values (shape (16777216,), "
                                                           "134,217,728 bytes) of which the file stores 0 bytes")):
            h5_check(h5["unwritten"], "unwritten")
        with pytest.raises(SEDFormatError, match=re.escape("zeros: the dataset holds 16,777,216 values (shape (16777216,)) where "
                                                           "1,000 are expected")):
            h5_check(h5["zeros"], "zeros", 1000)
