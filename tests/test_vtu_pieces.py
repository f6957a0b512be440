"""VTU files with several ``<Piece>`` elements, as VTK writes them (tests/data/vtk/make_pieces.py).

meshio 5.3.5 joins the pieces' points but keeps only the last piece's cells: afferent read such
a file with half its cells and no word (point data only) or refused it with "expected one Piece
in a series step" (with cell data). afferent.io._vtu reads every piece in one parse.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from afferent import read_sed
from afferent.exceptions import SEDFormatError
from afferent.io import read_raw
from afferent.io._meshio import read_vtu_series
from afferent.receptors import ReceptorLayout
from afferent.sampling import sample_sed

from conftest import DATA_DIR

PIECES = DATA_DIR / "vtk" / "pieces2.vtu"  # appended raw binary (zlib); SED, S, cell_id
PIECES_ASCII = DATA_DIR / "vtk" / "pieces2_ascii.vtu"  # ASCII; SED, S (no cell data)
PIECES_EMPTY = DATA_DIR / "vtk" / "pieces3_empty.vtu"  # 1 x 1 x 2 cells in three pieces, the middle one empty
#: file, pieces, points, cells, nodes once the pieces' shared points are merged
FILES = [(PIECES, 2, 80, 24, 60), (PIECES_ASCII, 2, 80, 24, 60), (PIECES_EMPTY, 3, 16, 2, 12)]
IDS = ["appended", "ascii", "empty-piece"]


def _vtk_read(path):
    vtk = pytest.importorskip("vtk", reason="the 'vtk' extra reads the file for comparison")
    from vtk.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(path))
    reader.Update()
    grid = reader.GetOutput()
    conn = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 8)
    pd, cd = grid.GetPointData(), grid.GetCellData()
    arrays = {pd.GetArrayName(k): vtk_to_numpy(pd.GetArray(k)) for k in range(pd.GetNumberOfArrays())}
    arrays.update({cd.GetArrayName(k): vtk_to_numpy(cd.GetArray(k)) for k in range(cd.GetNumberOfArrays())})
    return vtk_to_numpy(grid.GetPoints().GetData()), conn, arrays


@pytest.mark.parametrize("path, n_pieces, n_points, n_cells, _", FILES, ids=IDS)
def test_every_piece_is_read_as_vtk_reads_it(path, n_pieces, n_points, n_cells, _):
    from afferent.io._vtu import read_vtu

    points, conn, arrays = _vtk_read(path)
    assert conn.shape == (n_cells, 8) and points.shape == (n_points, 3)
    content = read_vtu(str(path))
    assert content.n_pieces == n_pieces
    np.testing.assert_array_equal(content.points, points)
    np.testing.assert_array_equal(np.concatenate([b.data for b in content.cells]), conn)
    raw = read_raw(str(path))
    assert raw.cells.n_cells == n_cells and raw.reader.startswith("meshio")  # not VTK's reader after meshio's failure
    assert raw.cells.cell_types == ("hexahedron",)  # one block, however the mesh was cut into pieces
    np.testing.assert_array_equal(raw.points, points)
    for name, values in arrays.items():
        np.testing.assert_array_equal(raw.arrays[name].values[0], values)
    assert set(raw.arrays) == set(arrays)
    assert raw.arrays["S"].components == ("XX", "YY", "ZZ", "XY", "YZ", "ZX")


@pytest.mark.parametrize("path, _, __, n_cells, n_nodes", FILES, ids=IDS)
def test_sed_sampled_in_every_piece_is_the_written_field(path, _, __, n_cells, n_nodes):
    field = read_sed(path, length_unit="mm", sed_unit="Pa")
    assert field.cells.n_cells == n_cells and field.n_points == n_nodes  # the points on the pieces' shared face merged
    xyz = np.array([[0.5, 0.5, 0.5], [0.3, 0.2, 0.9], [0.5, 0.5, 1.5], [0.7, 0.4, 1.8], [0.2, 0.9, 1.0]])  # mm
    if n_cells == 24:
        xyz = np.vstack([xyz, [[3.3, 2.2, 0.9], [1.5, 1.5, 1.5], [3.7, 0.4, 1.8], [2.0, 1.0, 1.0]]])
    got = sample_sed(field, ReceptorLayout(xyz * 1e-3)).values[0]
    np.testing.assert_allclose(got, 1 + 2 * xyz[:, 0] + 3 * xyz[:, 1] + xyz[:, 2], rtol=1e-12)


def test_a_series_of_pieced_steps_reads_every_cell():
    raw = read_vtu_series([str(PIECES), str(PIECES)])
    assert raw.n_times == 2 and raw.cells.n_cells == 24
    np.testing.assert_array_equal(raw.arrays["cell_id"].values, np.tile(np.arange(24.0), (2, 1)))


def _with_cell_data(tmp_path, counts):
    """pieces2_ascii.vtu with a cell array 'E' of counts[k] values in piece k."""
    text = PIECES_ASCII.read_text()
    parts = text.split("</Piece>")
    for k, n in enumerate(counts):
        values = " ".join(str(float(v)) for v in range(n))
        parts[k] += f'<CellData><DataArray type="Float64" Name="E" format="ascii">{values}</DataArray></CellData>'
    path = tmp_path / "pieces_e.vtu"
    path.write_text("</Piece>".join(parts))
    return path


def test_cell_data_is_counted_piece_by_piece(tmp_path):
    read_raw(str(_with_cell_data(tmp_path, [12, 12])))  # the right counts read
    path = _with_cell_data(tmp_path, [13, 11])  # 24 in all, one value in the wrong piece
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(path)!r}: cell array 'E' must have one value per cell in piece 0 of 2 (NumberOfCells = 12); "
            "got 13 instead.")):
        read_raw(str(path))


def test_an_empty_number_of_components_is_read_as_one_component(tmp_path):
    """Firedrake writes NumberOfComponents="" for scalars: meshio drops the attribute, and so does afferent's reader."""
    text = (DATA_DIR / "bad" / "cell_array_long.vtu").read_text()
    text = text.split("<CellData>")[0] + text.split("</CellData>")[1]  # the hexahedron and its point SED
    path = tmp_path / "firedrake.vtu"
    path.write_text(text.replace('Name="SED" format="ascii"', 'Name="SED" NumberOfComponents="" format="ascii"'))
    raw = read_raw(str(path))
    assert raw.arrays["SED"].values.shape == (1, 8) and raw.cells.n_cells == 1


def test_only_an_export_that_may_hold_copies_has_every_cell_measured(sample_sed_dir, monkeypatch):
    """The coincident-copy search measured every cell's shortest edge on every read (3.5 of the 10 ms of
    assembling sample_sed/block4); a sample of the cells sizes the quick test now, and only an export that
    may hold copies (the two pieces' shared face here) goes on to the full measure and the KD-tree."""
    from afferent.io import _coincident

    calls = []
    original = _coincident.coincident_labels
    monkeypatch.setattr(_coincident, "coincident_labels", lambda *a, **k: calls.append(a[1].shape[0]) or original(*a, **k))
    _coincident._LAST.clear()
    field = read_sed(sample_sed_dir / "block4" / "indent_0p88mm.vtu", length_unit="mm", sed_unit="MPa")
    assert calls == [] and field.provenance.coincident is None
    field = read_sed(PIECES, length_unit="mm", sed_unit="Pa")
    assert calls == [24] and field.provenance.coincident["n_copies_merged"] == 20


def test_the_coincident_search_is_remembered_for_the_same_cells_and_coordinates(monkeypatch):
    """A mesh reader's coordinates are read-only and remembered by reference (no digest of every read);
    writable ones by a digest, so that coordinates changed in place are searched again."""
    from afferent.io import _coincident

    raw = read_raw(str(PIECES))
    assert not raw.points.flags.writeable
    calls = []
    original = _coincident.coincident_labels
    monkeypatch.setattr(_coincident, "coincident_labels", lambda *a, **k: calls.append(1) or original(*a, **k))
    _coincident._LAST.clear()
    first = _coincident._labels_of(raw.points, raw.cells, 1e-6)[0]  # (labels found, what is kept beside them)
    assert _coincident._labels_of(raw.points.copy(), raw.cells, 1e-6)[0] is first and len(calls) == 1  # equal values
    moved = raw.points.copy()
    moved[:, 0] *= 2.0
    assert _coincident._labels_of(moved, raw.cells, 1e-6)[0] is not first and len(calls) == 2
    assert _coincident._labels_of(moved, raw.cells, 1e-6)[0] is not first and len(calls) == 2  # the digest matches
    moved[:, 0] *= 2.0  # changed in place
    _coincident._labels_of(moved, raw.cells, 1e-6)
    assert len(calls) == 3
