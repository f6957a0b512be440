"""A VTU's data arrays are decoded when used (afferent.io._vtu, RawArray's Deferred values).

``read_sed`` of a real export decodes the SED (and the material ids), not the displacements and
tensors beside it; an array's shape is known from its header before; an array whose values
disagree with that header is an error naming the file and the array when it is used; an unused
corrupt array does not stop a read.
"""

import base64
import pickle
import re
import zlib
from pathlib import Path

import meshio
import numpy as np
import pytest

from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import read_raw, read_sed

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_sed" / "block4" / "indent_0p88mm.vtu"  # scikit-fem mesh, SED, U, cell SED, layer
DEALII = ROOT / "tests" / "data" / "dealii" / "indent_block.vtu"  # deal.II 9.5: displacement, sed, sed_cell, material_id
UNITS = dict(length_unit="mm", sed_unit="MPa")


def test_arrays_are_read_with_their_shapes_and_decoded_on_first_use_to_meshios_values():
    raw = read_raw(str(SAMPLE))
    mesh = meshio.read(SAMPLE)
    n_points, n_cells = len(mesh.points), sum(len(b.data) for b in mesh.cells)
    u = raw.arrays["U"]
    assert not u.decoded and u.shape == (1, n_points, 3) and u.ndim == 3
    assert raw.arrays["layer"].shape == (1, n_cells) and raw.n_times == 1
    assert not any(a.decoded for a in raw.arrays.values())  # shapes and the step count decode nothing
    np.testing.assert_array_equal(u.values[0], mesh.point_data["U"])
    assert u.decoded and u.values is u.values  # decoded once, kept
    assert u.values.dtype == np.float64  # float32 in the file, float64 as every reader gives
    for key, arr in raw.arrays.items():
        want = mesh.point_data[arr.name] if arr.location == "point" else mesh.cell_data[arr.name][0]
        np.testing.assert_array_equal(arr.values[0], want, err_msg=key)
    again = pickle.loads(pickle.dumps(read_raw(str(SAMPLE)).arrays["SED"]))  # pickled as its values
    np.testing.assert_array_equal(again.values[0], mesh.point_data["SED"])


def _corrupt_array(text: str, name: str) -> str:
    """``text`` (a VTU with inline zlib-compressed base64 arrays) with array ``name``'s compressed
    bytes overwritten after its header: the header still announces the right count."""
    m = re.search(rf'(<DataArray[^>]*Name="{name}"[^>]*>\s*)([A-Za-z0-9+/=]+)', text)
    data = m.group(2)
    head = base64.b64decode(data[:8])  # UInt32 or UInt64 header: blocks first
    itemsize = 8 if 'header_type="UInt64"' in text else 4
    blocks = int.from_bytes(head[:itemsize], "little")
    start = -(-(3 + blocks) * itemsize // 3) * 4 + 40  # past the base64 of the header, into the first block
    bad = data[:start] + "A" * 40 + data[start + 40:]
    return text[:m.start(2)] + bad + text[m.end(2):]


@pytest.mark.filterwarnings("ignore:.*coincident copies")
def test_a_corrupt_unused_array_is_not_decoded_and_names_itself_when_used(tmp_path, capsys):
    path = tmp_path / "indent_block.vtu"
    path.write_text(_corrupt_array(DEALII.read_text(), "displacement"))
    with pytest.raises(Exception):  # the bytes really are corrupt: meshio's decoder fails on them
        meshio.read(path)
    np.testing.assert_array_equal(read_sed(str(path), **UNITS).sed, read_sed(str(DEALII), **UNITS).sed)
    disp = read_raw(str(path)).arrays["displacement"]
    assert disp.shape[2] == 3
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(path)!r} could not be read as .vtu (truncated or "
                                                       "corrupt?): error: Error -3 while decompressing data")):
        disp.values
    assert main(["info", str(path)]) == 2  # afferent info shows every array: one line naming the file
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: SED file {str(path)!r} could not be read as .vtu") and err.count("\n") == 1


def _zlib_array(values: np.ndarray, announced: int) -> str:
    """base64 of a one-block zlib DataArray (UInt32 header) whose header announces ``announced`` bytes."""
    body = zlib.compress(values.tobytes())
    header = np.array([1, announced, announced, len(body)], dtype="<u4").tobytes()
    return base64.b64encode(header).decode() + base64.b64encode(body).decode()


def test_values_that_disagree_with_their_header_are_refused_naming_the_array(tmp_path):
    """A header that announces one value per cell over data holding one value fewer: meshio's
    decoder returns the short array without a word (its Mesh then refuses it); afferent refuses it
    when it is used, naming the array."""
    mesh = meshio.read(DEALII)
    n_cells = len(mesh.cells[0].data)
    path = tmp_path / "short.vtu"
    meshio.write(path, meshio.Mesh(mesh.points, mesh.cells, point_data={"sed": mesh.point_data["sed"]},
                                   cell_data={"E": [np.ones(n_cells)]}), compression="zlib")
    text = path.read_text()
    m = re.search(r'(<DataArray[^>]*Name="E"[^>]*>\s*)([A-Za-z0-9+/=]+)', text)
    path.write_text(text[:m.start(2)] + _zlib_array(np.ones(n_cells - 1), 8 * n_cells) + text[m.end(2):])
    assert len(meshio.vtu._vtu.VtuReader(str(path)).cell_data["E"][0]) == n_cells - 1  # the decoder: no word
    arr = read_raw(str(path)).arrays["E"]
    assert arr.shape == (1, n_cells)
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(path)!r}: cell array 'E': zlib block 1 of 1 "
                                                       f"inflates to {8 * (n_cells - 1):,} bytes where its header "
                                                       f"declares {8 * n_cells:,}: the file is corrupt.")):
        arr.values


def test_cell_data_of_the_volume_cells_only_when_the_file_has_surface_cells_too(tmp_path):
    """A VTU with boundary quadrilaterals before and after the hexahedra: each cell array's values
    are the hexahedra's, in their order (the rows of the arrays over all cells, still deferred)."""
    mesh = meshio.read(DEALII)
    hexes = mesh.cells[0].data
    quads = hexes[:5, :4]
    n = len(hexes)
    data = {"E": [np.full(5, -1.0), np.arange(n, dtype=float), np.full(3, -2.0)],
            "T": [np.full((5, 2), -1.0), np.column_stack([np.arange(n), 2 * np.arange(n)]).astype(float), np.zeros((3, 2))]}
    path = tmp_path / "mixed.vtu"
    meshio.write(path, meshio.Mesh(mesh.points, [("quad", quads), ("hexahedron", hexes), ("quad", quads[:3])],
                                   point_data={"sed": mesh.point_data["sed"]}, cell_data=data), compression="zlib")
    raw = read_raw(str(path))
    assert raw.cells.n_cells == n
    e, t = raw.arrays["E"], raw.arrays["T"]
    assert not e.decoded and e.shape == (1, n) and t.shape == (1, n, 2)
    np.testing.assert_array_equal(e.values[0], np.arange(n))
    np.testing.assert_array_equal(t.values[0], data["T"][1])


def test_a_series_later_steps_decode_only_what_is_used():
    """Each later step of a VTU series is read lazily too (its arrays deferred until used, their
    shapes checked against the first step's), and its SED equals a fresh read of its file."""
    from afferent.io._meshio import iter_vtu_series

    files = sorted(str(p) for p in (ROOT / "sample_sed" / "block4" / "series_0p88mm").glob("*.vtu"))
    steps = list(iter_vtu_series(files))
    assert len(steps) == len(files) > 2
    for step, path in zip(steps[1:], files[1:]):
        assert not any(a.decoded for a in step.arrays.values())
        fresh = read_raw(path)
        assert set(step.arrays) == set(fresh.arrays)
        for key, arr in step.arrays.items():
            assert arr.shape == fresh.arrays[key].shape
            np.testing.assert_array_equal(arr.values, fresh.arrays[key].values, err_msg=key)


def test_a_series_with_surface_cells_reads_each_steps_volume_cell_data(tmp_path):
    """Before: a VTU series whose files hold boundary cells besides the volume and a cell array
    failed at its second step ("array 'mat' must have 384 values; got 389"): later steps counted
    their cell data against all the file's cells, the first step against the volume cells."""
    from afferent.io import iter_sed
    from afferent.io._meshio import iter_vtu_series

    mesh = meshio.read(DEALII)
    hexes = mesh.cells[0].data
    files = []
    for k in range(3):
        files.append(str(tmp_path / f"mix_{k}.vtu"))
        meshio.write(files[-1], meshio.Mesh(mesh.points, [("quad", hexes[:5, :4]), ("hexahedron", hexes)],
                                            point_data={"sed": mesh.point_data["sed"] * (k + 1)},
                                            cell_data={"mat": [np.zeros(5), np.arange(len(hexes)) + 10.0 * k]}),
                     compression="zlib")
    steps = list(iter_vtu_series(files))
    for k, step in enumerate(steps):
        np.testing.assert_array_equal(step.arrays["mat"].values[0], np.arange(len(hexes)) + 10.0 * k)
    pvd = tmp_path / "mix.pvd"
    pvd.write_text('<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>'
                   + "".join(f'<DataSet timestep="{k}" file="mix_{k}.vtu"/>' for k in range(3)) + "</Collection></VTKFile>")
    with pytest.warns(Warning):  # deal.II's discontinuous copies merged
        fields = list(iter_sed(str(pvd), **UNITS))
    assert [f.n_times for f in fields] == [1, 1, 1]
    np.testing.assert_allclose(fields[2].sed, 3 * fields[0].sed)


_VTK_MODES = [("none", "UInt32", "binary", True, "little"), ("none", "UInt64", "appended", False, "little"),
              ("zlib", "UInt32", "binary", True, "little"), ("zlib", "UInt64", "binary", True, "little"),
              ("zlib", "UInt32", "appended", True, "little"), ("zlib", "UInt64", "appended", False, "little"),
              ("lzma", "UInt32", "appended", False, "little"), ("lzma", "UInt64", "binary", True, "little"),
              ("zlib", "UInt32", "binary", True, "big"), ("none", "UInt64", "appended", False, "big")]


@pytest.mark.parametrize("compressor, header, mode, encoded, order", _VTK_MODES,
                         ids=["-".join(map(str, m)) for m in _VTK_MODES])
def test_every_binary_layout_vtk_writes_is_deferred_and_reads_vtks_values(tmp_path, compressor, header, mode, encoded,
                                                                          order):
    """The deal.II export rewritten by VTK's own XML writer in each binary layout (compressor, header
    size, inline or appended, base64 or raw, byte order): every data array deferred (its shape from
    the header) and, decoded, equal to VTK's reading of the same file."""
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(DEALII))
    reader.Update()
    writer = vtk.vtkXMLUnstructuredGridWriter()
    path = tmp_path / "block.vtu"
    writer.SetFileName(str(path))
    writer.SetInputData(reader.GetOutput())
    {"none": writer.SetCompressorTypeToNone, "zlib": writer.SetCompressorTypeToZLib,
     "lzma": writer.SetCompressorTypeToLZMA}[compressor]()
    writer.SetHeaderTypeToUInt64() if header == "UInt64" else writer.SetHeaderTypeToUInt32()
    writer.SetDataModeToAppended() if mode == "appended" else writer.SetDataModeToBinary()
    writer.SetEncodeAppendedData(encoded)
    writer.SetByteOrderToBigEndian() if order == "big" else writer.SetByteOrderToLittleEndian()
    assert writer.Write() == 1
    check = vtk.vtkXMLUnstructuredGridReader()
    check.SetFileName(str(path))
    check.Update()
    data = check.GetOutput().GetPointData()
    raw = read_raw(str(path))
    assert raw.reader.startswith("meshio") and not any(a.decoded for a in raw.arrays.values())
    assert sorted(raw.arrays) == sorted(data.GetArrayName(k) for k in range(data.GetNumberOfArrays()))
    for name, arr in raw.arrays.items():
        want = vtk_to_numpy(data.GetArray(name))
        assert arr.shape == (1,) + want.shape
        np.testing.assert_array_equal(arr.values[0], want, err_msg=name)


def _bomb_vtu(path: Path, mode: str, bomb: str, inflates_to: int = 1 << 30, compressor: str = "zlib") -> int:
    """A hexahedral box written as VTK writes a compressed VTU (UInt64 headers, one block per array),
    ``mode`` "binary" (inline base64) or "appended" (raw appended data), with point arrays ``sed``
    and ``U`` in Float64; the array named ``bomb`` holds a block whose header declares its piece's
    8 bytes a point but which inflates to ``inflates_to`` zero bytes (1 GiB: a ~1 MB file).
    Returns the bytes the bomb's header declares."""
    import lzma

    from conftest import hex_box
    from _memory import zeros_deflated

    points, hexes = hex_box(8, 8, 8)
    n = len(points)
    arrays = [("Points", "Points", points.astype("<f8"), 3), ("PointData", "sed", 1e-3 + points[:, 2] * 1e-4, None),
              ("PointData", "U", points[:, 0] * 0.0, None),
              ("Cells", "connectivity", hexes.ravel().astype("<i8"), None),
              ("Cells", "offsets", 8 * np.arange(1, len(hexes) + 1, dtype="<i8"), None),
              ("Cells", "types", np.full(len(hexes), 12, "<u1"), None)]
    pack = zlib.compress if compressor == "zlib" else lzma.compress
    tags = {"Points": [], "Cells": [], "PointData": []}
    appended, offset = [], 0
    for part, name, values, k in arrays:
        raw = np.ascontiguousarray(values).tobytes()
        body = pack(raw)
        if name == bomb:
            body = zeros_deflated(inflates_to) if compressor == "zlib" else lzma.compress(bytes(inflates_to))
        header = np.array([1, len(raw), len(raw), len(body)], "<u8").tobytes()
        dtype = {"f": "Float64", "i": "Int64", "u": "UInt8"}[values.dtype.kind]
        comps = f' NumberOfComponents="{k}"' if k else ""
        if mode == "binary":
            text = base64.b64encode(header).decode() + base64.b64encode(body).decode()
            tags[part].append(f'<DataArray type="{dtype}" Name="{name}"{comps} format="binary">{text}</DataArray>')
        else:
            tags[part].append(f'<DataArray type="{dtype}" Name="{name}"{comps} format="appended" offset="{offset}"/>')
            appended.append(header + body)
            offset += len(header) + len(body)
    compressor_tag = "vtkZLibDataCompressor" if compressor == "zlib" else "vtkLZMADataCompressor"
    xml = (f'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
           f'header_type="UInt64" compressor="{compressor_tag}">\n<UnstructuredGrid>\n'
           f'<Piece NumberOfPoints="{n}" NumberOfCells="{len(hexes)}">\n'
           + "".join(f"<{part}>\n" + "\n".join(tags[part]) + f"\n</{part}>\n" for part in ("PointData", "Points", "Cells"))
           + "</Piece>\n</UnstructuredGrid>\n")
    tail = "</VTKFile>\n"
    if mode == "binary":
        path.write_text(xml + tail)
    else:
        path.write_bytes(xml.encode() + b'<AppendedData encoding="raw">\n_' + b"".join(appended)
                         + b"\n</AppendedData>\n" + tail.encode())
    return 8 * n


@pytest.mark.parametrize("mode", ["binary", "appended"])
def test_a_bomb_block_is_refused_at_the_size_its_header_declares_in_bounded_memory(tmp_path, mode):
    """Issue 33 item 10: a 1 MB VTU whose SED block declares 5,832 bytes and inflates to 1 GiB. Before:
    inflated whole (raw appended: every array inflated and base64-encoded at parse time, 6.5 GB at
    peak; inline: 2.1 GB), then refused for its shape. Now refused after the declared size plus one
    byte, naming the file, the array and the sizes; the child process stays under 400 MB."""
    from _memory import in_child

    path = tmp_path / f"bomb_{mode}.vtu"
    declared = _bomb_vtu(path, mode, bomb="sed")
    assert declared == 5832 and path.stat().st_size < 1.5e6  # 1 MB of zlib (base64: 1.4 MB)
    got = in_child(f"""
        from afferent.io import read_sed
        read_sed({str(path)!r}, length_unit="mm", sed_unit="MPa")
    """)
    assert got["error"] is not None and got["error"][0] == "VtuCountError"  # an SEDFormatError, not re-read by VTK
    assert got["error"][1] == (f"SED file {str(path)!r}: point array 'sed': zlib block 1 of 1 inflates to more than 5,832 "
                               "bytes where its header declares 5,832: the file is corrupt (or a decompression bomb); "
                               "refused without inflating it further.")
    assert got["peak_mb"] < 400, got


def test_an_unused_bomb_in_raw_appended_data_is_never_inflated(tmp_path):
    """Before: raw appended data was inflated and re-encoded whole at parse time, the unused
    ``U`` too (105 s, 6.5 GB for 1 GiB). Now each array is decoded from its raw bytes when used:
    the SED reads, ``U`` is never inflated, the child stays under 400 MB."""
    from _memory import in_child

    path = tmp_path / "bomb_u.vtu"
    _bomb_vtu(path, "appended", bomb="U")
    got = in_child(f"""
        import numpy as np
        from afferent.io import read_raw, read_sed
        field = read_sed({str(path)!r}, length_unit="mm", sed_unit="MPa")
        assert field.sed.shape == (1, 729) and np.all(field.sed > 0)
        raw = read_raw({str(path)!r})
        assert raw.arrays["U"].shape == (1, 729) and not raw.arrays["U"].decoded
    """)
    assert got["error"] is None and got["peak_mb"] < 400, got


def test_an_lzma_block_is_inflated_no_further_than_declared(tmp_path):
    """The LZMA compressor's blocks are bounded the same way (a small bomb: 4 MiB declared as 5,832 bytes)."""
    path = tmp_path / "bomb_lzma.vtu"
    _bomb_vtu(path, "binary", bomb="U", inflates_to=1 << 22, compressor="lzma")
    raw = read_raw(str(path))
    np.testing.assert_allclose(raw.arrays["sed"].values[0][-1], 1e-3 + 1.9e-4)
    with pytest.raises(SEDFormatError, match=re.escape("point array 'U': LZMA block 1 of 1 inflates to more than 5,832 "
                                                       "bytes where its header declares 5,832")):
        raw.arrays["U"].values


@pytest.mark.parametrize("mode", ["binary", "appended"])
def test_a_header_declaring_more_values_than_the_piece_has_is_refused_before_inflating(tmp_path, mode):
    """A points array whose header declares 1 GiB (and inflates to it) where the piece has 729 points:
    refused from the header, naming the array and both sizes, in bounded memory (before: inflated,
    then refused by its reshape)."""
    from _memory import in_child

    path = tmp_path / f"points_{mode}.vtu"
    _bomb_vtu(path, mode, bomb="Points")
    text = path.read_bytes()
    declared = np.array([1, 1 << 30, 1 << 30], "<u8").tobytes()
    honest = np.array([1, 729 * 24, 729 * 24], "<u8").tobytes()
    if mode == "binary":
        declared, honest = base64.b64encode(declared)[:28], base64.b64encode(honest)[:28]  # whole 3-byte groups only
    assert text.count(honest) == 1
    path.write_bytes(text.replace(honest, declared))
    got = in_child(f"""
        from afferent.io import read_raw
        read_raw({str(path)!r})
    """)
    assert got["error"] == ["VtuCountError", f"SED file {str(path)!r}: points array 'Points': its header declares "
                            "1,073,741,824 bytes of values, more than the 17,496 its piece's counts allow: the file is "
                            "corrupt; refused without decoding it."], got
    assert got["peak_mb"] < 400, got
