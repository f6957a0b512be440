"""Reading mesh exports (VTU, VTK, PVD, XDMF, file lists) into an SEDField."""

from __future__ import annotations

import json
import re
import warnings

import meshio
import numpy as np
import pytest

from afferent import read_sed
from afferent.exceptions import AfferentWarning, SEDFormatError, UnitError
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
                    sed_from="exact", preset="vtk", shear="engineering").provenance  # the file's shear (issue 34)
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
    with pytest.raises(SEDFormatError, match=re.escape("the file's shear strain looks engineering")):
        read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="vtk")  # refused (issue 34)
    with pytest.warns(AfferentWarning, match=re.escape("the file's shear strain looks engineering")):
        wrong = read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="vtk", shear="tensor")
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


def test_clearly_negative_sed_is_refused(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    sed[7] = -0.5 * sed.max()  # half the peak, negative: a wrong column or sign, not an artefact
    p = write_vtu(tmp_path / "neg.vtu", points, hexes, point_data={"SED": sed})
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r}: SED must be >= 0 J/m^3 up to the nodal-extrapolation artefacts of FE tools; got 1 "
            "negative value(s) down to -9.975e-05 in file units (-0.5 x the largest SED; the negatives sum to 0.0255 x the "
            "positives; first at row 7), beyond the tolerance 0.25.")):
        read_sed(p, length_unit="mm", sed_unit="MPa")
    # ... unless the user says the tool's extrapolation is that coarse
    with pytest.warns(AfferentWarning, match="1 of 27 SED value"):
        field = read_sed(p, length_unit="mm", sed_unit="MPa", negative_tolerance=0.6)
    assert field.sed[0, 7] == 0.0
    # a field negative over a large share (a stress component read as SED) is refused on its share alone
    share = np.full(len(points), -0.1)
    share[:7] = 1.0  # 20 of 27 values at -0.1 x the largest: each small, together 0.29 x the positives
    q = write_vtu(tmp_path / "share.vtu", points, hexes, point_data={"SED": share * 1e-4})
    with pytest.raises(SEDFormatError, match=re.escape("(-0.1 x the largest SED; the negatives sum to 0.286 x the positives")):
        read_sed(q, length_unit="mm", sed_unit="MPa")


def test_nodal_extrapolation_artefacts_are_set_to_zero_counted_and_recorded(tmp_path):
    # What CalculiX/Abaqus/ANSYS write at nodes near steep gradients (see the real .frd tests)
    points, hexes = hex_box(2, 2, 2)
    sed = linear_sed(points)
    top = sed.max()
    sed[[3, 7]] = [-1e-5 * top, -0.02 * top]
    p = write_vtu(tmp_path / "artefacts.vtu", points, hexes, point_data={"SED": sed})
    with pytest.warns(AfferentWarning, match=re.escape(
            "2 of 27 SED value(s) are negative (down to -0.02 x the largest SED; they sum to 0.001 x the positive values; "
            "tolerance 0.25), as FE tools write where they extrapolate integration-point values to the nodes near steep "
            "gradients; set to 0.")):
        field = read_sed(p, length_unit="mm", sed_unit="MPa")
    assert field.sed[0, 3] == 0.0 and field.sed[0, 7] == 0.0 and field.sed.min() == 0.0
    rec = field.provenance.to_dict()["negative_sed"]
    assert rec["count"] == 2 and rec["n_values"] == 27 and rec["action"] == "set to 0"
    assert rec["min_pa"] == pytest.approx(-0.02 * top * 1e6, rel=1e-12) and rec["min_relative"] == pytest.approx(-0.02)
    # a strictly tighter tolerance refuses the same file
    with pytest.raises(SEDFormatError, match=re.escape("beyond the tolerance 0.001.")):
        read_sed(p, length_unit="mm", sed_unit="MPa", negative_tolerance=1e-3)
    clean = read_sed(write_vtu(tmp_path / "clean.vtu", points, hexes, point_data={"SED": linear_sed(points)}),
                     length_unit="mm", sed_unit="MPa")
    assert clean.provenance.negative_sed is None


def test_a_field_with_no_positive_value_cannot_pass_as_artefacts(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    sed = -linear_sed(points)
    p = write_vtu(tmp_path / "allneg.vtu", points, hexes, point_data={"SED": sed})
    with pytest.raises(SEDFormatError, match=re.escape("got 27 negative value(s) down to -0.0001995 in file units (and no value is positive; first at row 0)")):
        read_sed(p, length_unit="mm", sed_unit="MPa", negative_tolerance=0.999)


@pytest.mark.parametrize("bad", [-1e-3, 1.0, "x", True])
def test_negative_tolerance_is_validated(box_vtu, bad):
    with pytest.raises(ValueError, match=re.escape(f"'negative_tolerance' must be a number in [0, 1) (a fraction of the largest SED); got {bad!r} instead.")):
        read_sed(box_vtu, length_unit="mm", sed_unit="MPa", negative_tolerance=bad)


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


def test_units_declared_orders_of_magnitude_off_are_warned_robustly(tmp_path):
    # A 1.3 x 0.7 x 1.9 mm block with SED ~1e-4 MPa (~100 Pa), and one singular corner node 1000x
    # the rest (a punch edge): the level is the 99th percentile, so the corner does not decide.
    points, hexes = hex_box(6, 6, 6)
    sed = linear_sed(points)
    sed[0] = 1000 * sed.max()
    p = write_vtu(tmp_path / "corner.vtu", points, hexes, point_data={"SED": sed})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = read_sed(p, length_unit="mm", sed_unit="MPa")  # right units: silent despite the corner
    assert ok.sed.max() > 1e5  # the corner alone would be "implausible" if the maximum were used
    with pytest.warns(AfferentWarning, match=re.escape(
            "(Pa declared): SED of 0.000") ) as rec:
        read_sed(p, length_unit="mm", sed_unit="Pa")
    assert "is far below what skin under touch holds (0.01..1e+07 J/m^3); check 'sed_unit' (MPa vs Pa is a factor 1e6)." in str(rec[0].message)
    with pytest.warns(AfferentWarning, match=re.escape(
            "(length unit m declared): the points span 1.9 m, far larger than a skin model (0.1 mm..0.5 m); "
            "check 'length_unit' (mm vs m is a factor 1e3).")) as rec:
        f = read_sed(p, length_unit="m", sed_unit="MPa")
    assert any("points span" in n for n in f.provenance.notes)


def test_a_valid_file_in_an_unsupported_layout_says_what_is_unsupported(tmp_path):
    poly = tmp_path / "surface.vtu"
    poly.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian"><PolyData>'
        '<Piece NumberOfPoints="3" NumberOfPolys="1"><Points><DataArray type="Float32" NumberOfComponents="3" '
        'format="ascii">0 0 0 1 0 0 0 1 0</DataArray></Points><Polys><DataArray type="Int32" Name="connectivity" '
        'format="ascii">0 1 2</DataArray><DataArray type="Int32" Name="offsets" format="ascii">3</DataArray></Polys>'
        '</Piece></PolyData></VTKFile>\n')
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(poly)!r} holds a surface (PolyData), not the UnstructuredGrid (volume mesh) afferent reads from "
            "a .vtu; export the volume mesh, or the surface points as a CSV table.")):
        read_raw(poly)
    version = tmp_path / "v30.vtu"
    version.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="3.0"><UnstructuredGrid><Piece NumberOfPoints="1" '
        'NumberOfCells="0"><Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0</DataArray>'
        '</Points></Piece></UnstructuredGrid></VTKFile>\n')
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(version)!r} is a VTU of file version 3.0; afferent reads VTU versions 0.1 to 2.x. Save it with "
            "an older VTK or ParaView, or as legacy VTK (.vtk).")):
        read_raw(version)


def test_location_that_the_tensors_or_sed_do_not_have_is_named(tmp_path):
    points, hexes = hex_box(2, 2, 2)
    six = np.ones((len(hexes), 6))
    p = write_vtu(tmp_path / "cell_tensors.vtu", points, hexes, cell_data={"S": [six], "E": [six], "SED": [np.ones(len(hexes))]})
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r}: the stress tensor 'S' is cell data, not point data as location='point' asks; "
            "drop location= or pass location='cell'.")):
        read_sed(p, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="vtk", location="point")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(p)!r}: the SED array 'SED' is cell data, not point data as location='point' asks")):
        read_sed(p, length_unit="mm", sed_unit="MPa", location="point")
