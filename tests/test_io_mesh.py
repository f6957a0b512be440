"""Reading mesh exports (VTU, VTK, PVD, XDMF, file lists) into an SEDField."""

from __future__ import annotations

import json
import re

import meshio
import numpy as np
import pytest

from afferent import read_sed
from afferent.exceptions import SEDFormatError, UnitError
from afferent.io import read_raw

from conftest import hex_box, linear_sed


def write_vtu(path, points, hexes, point_data=None, cell_data=None):
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data=point_data or {},
                                   cell_data=cell_data or {}), binary=True, compression="zlib")
    return path


def test_point_data_in_si(box_vtu):
    field = read_sed(box_vtu, length_unit="mm", sed_unit="MPa")
    points, _ = hex_box()
    np.testing.assert_allclose(field.points, points * 1e-3, rtol=1e-15)
    np.testing.assert_allclose(field.sed[0], linear_sed(points) * 1e6, rtol=1e-15)
    assert field.location == "point" and field.n_times == 1
    assert field.provenance.units["length"] == "mm" and field.provenance.factors["sed"] == 1e6
    assert field.cells.n_cells == 60 and field.cells.tetra.shape == (360, 4)


def test_cell_data_on_request(box_vtu):
    field = read_sed(box_vtu, length_unit="mm", sed_unit="kPa", location="cell")
    points, hexes = hex_box()
    assert field.location == "cell"
    np.testing.assert_allclose(field.sed[0], linear_sed(points[hexes].mean(axis=1)) * 1e3, rtol=1e-15)
    assert (field.provenance.location, field.provenance.location_source) == ("cell", "declared")


def test_provenance_records_where_the_values_live_and_why(box_vtu, tmp_path, sample_sed_dir):
    # box_vtu holds 'SED' as point and as cell data: point data is the default
    prov = read_sed(box_vtu, length_unit="mm", sed_unit="MPa").provenance
    assert (prov.location, prov.location_source) == ("point", "point preferred over cell")
    assert read_sed(box_vtu, length_unit="mm", sed_unit="MPa", location="point").provenance.location_source == "declared"
    points, hexes = hex_box(2, 1, 1)
    only_cells = tmp_path / "cells.vtu"
    meshio.write(only_cells, meshio.Mesh(points, [("hexahedron", hexes)], cell_data={"SED": [np.array([1.0, 2.0])]}))
    prov = read_sed(only_cells, length_unit="mm", sed_unit="MPa").provenance
    assert (prov.location, prov.location_source) == ("cell", "only cell data")
    only_points = tmp_path / "points.vtu"
    meshio.write(only_points, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": points[:, 0] + 1.0},
                                          cell_data={"layer": [np.array([1, 2])]}))
    prov = read_sed(only_points, length_unit="mm", sed_unit="MPa").provenance
    assert (prov.location, prov.location_source) == ("point", "only point data")
    # tensors: the bundled tensor file holds stress and strain as cell data only
    prov = read_sed(sample_sed_dir / "block4" / "indent_0p88mm_tensors.vtu", length_unit="mm", stress_unit="MPa",
                    sed_from="exact", preset="vtk").provenance
    assert (prov.location, prov.location_source) == ("cell", "only cell data")
    d = prov.to_dict()
    assert json.loads(json.dumps(d)) == d and d["location"] == "cell" and d["location_source"] == "only cell data"


def test_units_are_required_not_guessed(box_vtu):
    with pytest.raises(UnitError, match=re.escape("The length unit of the coordinates in SED file")):
        read_sed(box_vtu, sed_unit="MPa")
    with pytest.raises(UnitError, match=re.escape("pass sed_unit= (e.g. sed_unit='MPa')")):
        read_sed(box_vtu, length_unit="mm")
    with pytest.raises(UnitError, match=re.escape("'length_unit' must be a length unit, one of 'm', 'cm', 'mm', 'um', 'micron'; got 'inch' instead.")):
        read_sed(box_vtu, length_unit="inch", sed_unit="MPa")


def test_tensor_vtu_gives_exact_sed(tmp_path):
    """6-component cell arrays in Abaqus order with engineering shear; 1/2 sigma:eps is exact."""
    points, hexes = hex_box(2, 2, 2)
    rng = np.random.default_rng(3)
    eps = rng.normal(0, 1e-3, (len(hexes), 6))  # canonical xx yy zz xy yz xz, tensor shear
    sig = rng.normal(0, 10.0, (len(hexes), 6))
    expected = 0.5 * ((sig[:, :3] * eps[:, :3]).sum(1) + 2 * (sig[:, 3:] * eps[:, 3:]).sum(1))
    # make it physical (positive) by construction: use sig = 2G eps + lam tr
    lam, G = 1e5, 3e4
    sig = 2 * G * eps.copy()
    sig[:, :3] += lam * eps[:, :3].sum(1, keepdims=True)
    expected = 0.5 * ((sig[:, :3] * eps[:, :3]).sum(1) + 2 * (sig[:, 3:] * eps[:, 3:]).sum(1))
    abq = [0, 1, 2, 3, 5, 4]  # canonical -> abaqus 11 22 33 12 13 23
    e_written = eps[:, abq].copy()
    e_written[:, 3:] *= 2
    path = write_vtu(tmp_path / "t.vtu", points, hexes, cell_data={"S": [sig[:, abq] / 1e6], "E": [e_written]})
    with pytest.raises(SEDFormatError, match=re.escape("has no strain-energy-density array or column")):
        read_sed(path, length_unit="mm", stress_unit="MPa")
    with pytest.raises(ValueError, match=re.escape("needs the tool's shear convention: pass preset=")):
        read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact")
    field = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="abaqus")
    np.testing.assert_allclose(field.sed[0], expected, rtol=1e-12)
    assert field.location == "cell" and field.provenance.sed_from == "exact"
    wrong = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="vtk")
    assert not np.allclose(wrong.sed[0], expected, rtol=1e-6)  # order/shear matter
    eq = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="equivalent", preset="abaqus", poisson=0.48)
    assert eq.provenance.sed_from == "equivalent" and np.all(eq.sed >= 0)


def _series(tmp_path, n=4):
    points, hexes = hex_box(2, 2, 2)
    paths = []
    for k in range(n):
        paths.append(write_vtu(tmp_path / f"step_{k:03d}.vtu", points, hexes,
                               point_data={"SED": (k + 1) ** 2 * linear_sed(points)}))
    return points, paths


def test_pvd_series_reads_mesh_once_and_times(tmp_path):
    points, paths = _series(tmp_path)
    times = [0.0, 0.025, 0.05, 0.1]
    pvd = tmp_path / "run.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>\n' + "\n".join(
        f'<DataSet timestep="{t}" group="" part="0" file="{p.name}"/>' for t, p in zip(times, paths)) +
        "\n</Collection></VTKFile>\n")
    field = read_sed(pvd, length_unit="mm", sed_unit="MPa")
    np.testing.assert_allclose(field.times, times)
    for k in range(4):
        np.testing.assert_allclose(field.sed[k], (k + 1) ** 2 * linear_sed(points) * 1e6, rtol=1e-15)
    assert "mesh decoded once" in " ".join(field.provenance.notes)


def test_vtu_list_is_a_series(tmp_path):
    points, paths = _series(tmp_path, 3)
    field = read_sed(paths, length_unit="mm", sed_unit="MPa", times=[0, 10, 20], time_unit="ms")
    np.testing.assert_allclose(field.times, [0, 0.01, 0.02])
    np.testing.assert_allclose(field.sed[2], 9 * linear_sed(points) * 1e6, rtol=1e-15)


def test_xdmf_time_series(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    path = tmp_path / "ts.xdmf"
    with meshio.xdmf.TimeSeriesWriter(path, data_format="XML") as w:
        w.write_points_cells(points, [("hexahedron", hexes)])
        for k, t in enumerate([0.0, 0.5, 1.0]):
            w.write_data(t, point_data={"SED": (k + 1) * linear_sed(points)})
    field = read_sed(path, length_unit="mm", sed_unit="MPa")
    np.testing.assert_allclose(field.times, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(field.sed[1], 2 * linear_sed(points) * 1e6, rtol=1e-12)


def test_legacy_vtk(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    path = tmp_path / "f.vtk"
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"strain_energy_density": linear_sed(points)}))
    field = read_sed(path, length_unit="mm", sed_unit="MPa")
    assert field.provenance.columns["sed"] == "strain_energy_density"


# ---- bad input: every message names the file and what was wrong ---------------------------------

def test_missing_file(tmp_path):
    p = str(tmp_path / "nope.vtu")
    with pytest.raises(FileNotFoundError, match=re.escape(f"SED file {p!r} not found.")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_empty_file(tmp_path):
    p = tmp_path / "empty.vtu"
    p.write_bytes(b"")
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} is empty.")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_unknown_extension(tmp_path):
    p = tmp_path / "run3.odb"
    p.write_bytes(b"x")
    with pytest.raises(SEDFormatError, match=re.escape(f"Could not deduce the SED file format from {str(p)!r}. Known extensions are")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_truncated_vtu(box_vtu, tmp_path):
    data = box_vtu.read_bytes()
    p = tmp_path / "truncated.vtu"
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} could not be read as .vtu (truncated or corrupt?)")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_corrupt_vtu_bytes(box_vtu, tmp_path):
    data = bytearray(box_vtu.read_bytes())
    i = data.index(b"<DataArray")
    j = data.index(b">", i) + 40  # inside the first base64 payload
    data[j:j + 30] = b"!" * 30
    p = tmp_path / "corrupt.vtu"
    p.write_bytes(bytes(data))
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(p)!r} could not be read as .vtu")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


@pytest.mark.parametrize("bad, kind", [(np.nan, "NaN"), (np.inf, "infinite")])
def test_nan_or_inf_sed(tmp_path, bad, kind):
    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    sed[5] = bad
    p = write_vtu(tmp_path / "nan.vtu", points, hexes, point_data={"SED": sed})
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r}: SED column 'SED' must be finite; got 1 non-finite value(s) (first: {kind} at row 5) instead.")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_negative_sed(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    sed[7] = -2.5e-5
    p = write_vtu(tmp_path / "neg.vtu", points, hexes, point_data={"SED": sed})
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r}: SED must be >= 0 J/m^3; got 1 negative value(s) (first: -2.5e-05 in file units at row 7) instead.")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_round_off_negative_sed_is_clipped_and_noted(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    sed[7] = -1e-17
    p = write_vtu(tmp_path / "roundoff.vtu", points, hexes, point_data={"SED": sed})
    field = read_sed(p, length_unit="mm", sed_unit="MPa")
    assert field.sed[0, 7] == 0.0 and "round-off negative" in " ".join(field.provenance.notes)


def test_energy_not_density_is_refused(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    p = write_vtu(tmp_path / "else.vtu", points, hexes, cell_data={"ELSE": [np.ones(len(hexes))]})
    with pytest.raises(SEDFormatError, match=re.escape("column 'ELSE' holds an energy, not an energy density")):
        read_sed(p, length_unit="mm", sed_unit="MPa")


def test_series_on_different_meshes(tmp_path):
    points, paths = _series(tmp_path, 2)
    p2, h2 = hex_box(3, 2, 2)
    other = write_vtu(tmp_path / "other.vtu", p2, h2, point_data={"SED": linear_sed(p2)})
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(other)!r} is not on the same mesh as")):
        read_sed([paths[0], other], length_unit="mm", sed_unit="MPa")


def test_series_missing_array(tmp_path):
    points, paths = _series(tmp_path, 2)
    _, hexes = hex_box(2, 2, 2)
    other = write_vtu(tmp_path / "nosed.vtu", points, hexes, point_data={"U": points})
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(other)!r} lacks the point array 'SED'")):
        read_sed([paths[0], other], length_unit="mm", sed_unit="MPa")


def test_pvd_non_monotonic_times(tmp_path):
    _, paths = _series(tmp_path, 2)
    pvd = tmp_path / "bad.pvd"
    pvd.write_text('<VTKFile type="Collection"><Collection>'
                   f'<DataSet timestep="0.2" file="{paths[0].name}"/><DataSet timestep="0.1" file="{paths[1].name}"/>'
                   "</Collection></VTKFile>")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(pvd)!r}: timesteps must be strictly increasing; got 0.2 followed by 0.1 (DataSets 0 and 1) instead.")):
        read_sed(pvd, length_unit="mm", sed_unit="MPa")


def test_declared_times_non_monotonic(tmp_path):
    _, paths = _series(tmp_path, 3)
    with pytest.raises(SEDFormatError, match=re.escape("time steps must be strictly increasing; got 0.2 followed by 0.1 (steps 1 and 2) instead.")):
        read_sed(paths, length_unit="mm", sed_unit="MPa", times=[0.0, 0.2, 0.1])


def test_mismatched_times_length(tmp_path):
    _, paths = _series(tmp_path, 2)
    with pytest.raises(ValueError, match=re.escape("'times' must have one entry per time step (2); got 3 instead.")):
        read_sed(paths, length_unit="mm", sed_unit="MPa", times=[0, 1, 2])


def test_no_sed_suggests_names(box_vtu):
    with pytest.raises(SEDFormatError, match=re.escape("has no array or column 'SEDD' (asked for as the SED). Found 'SED', 'SED' (cell), 'layer' (cell). Did you mean 'SED'?")):
        read_sed(box_vtu, length_unit="mm", sed_unit="MPa", sed_column="SEDD")


def test_raw_reader_keeps_file_units(box_vtu):
    raw = read_raw(box_vtu)
    assert raw.points.max() == pytest.approx(1.9)  # mm, untouched
    assert {(a.name, a.location) for a in raw.arrays.values()} == {("SED", "point"), ("SED", "cell"), ("layer", "cell")}
