"""Sampling the SED field at receptor sites: 'linear' is exact on linear fields, 'nearest' is not."""

from __future__ import annotations

import re
import warnings

import meshio
import numpy as np
import pytest

from afferent import read_sed, sample_sed
from afferent.exceptions import AfferentWarning, FieldCoverageError
from afferent.field import Provenance, SEDField
from afferent.receptors import ReceptorLayout
from afferent.sampling import build_sampler

from conftest import hex_box, linear_sed

BOX_MM = np.array([1.3, 0.7, 1.9])


def inside_points(rng, n=200):
    return rng.uniform(0.0, 1.0, (n, 3)) * BOX_MM


@pytest.fixture
def field(box_vtu):
    return read_sed(box_vtu, length_unit="mm", sed_unit="MPa")


def test_linear_is_exact_on_a_linear_field(field, rng):
    pos = inside_points(rng)
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear")
    # float64 round-off only: barycentric weights of unit-size tetrahedra
    np.testing.assert_allclose(s.values[0], linear_sed(pos) * 1e6, rtol=1e-12)


def test_linear_is_more_accurate_than_nearest(field, rng):
    pos = inside_points(rng)
    exact = linear_sed(pos) * 1e6
    lin = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear").values[0]
    near = sample_sed(field, ReceptorLayout(pos * 1e-3), method="nearest").values[0]
    err_lin, err_near = np.abs(lin - exact).max(), np.abs(near - exact).max()
    assert err_lin < 1e-9 * exact.max() < err_near
    # nearest on this 0.33 mm grid is off by up to half a cell times the gradient (~10 Pa here)
    assert 1.0 < err_near < 20.0


def test_nearest_returns_node_values_exactly(field):
    points, _ = hex_box()
    inward = points[[0, 17, 42]] + 1e-6 * (points.mean(axis=0) - points[[0, 17, 42]])
    s = sample_sed(field, ReceptorLayout(inward * 1e-3), method="nearest")
    np.testing.assert_allclose(s.values[0], linear_sed(points[[0, 17, 42]]) * 1e6, rtol=1e-15)


def test_cell_data_nearest_is_the_containing_cell(box_vtu, rng):
    field = read_sed(box_vtu, length_unit="mm", sed_unit="MPa", location="cell")
    points, hexes = hex_box()
    centres = points[hexes].mean(axis=1)
    pos = centres[[3, 11, 50]] + rng.uniform(-0.05, 0.05, (3, 3))
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), method="nearest")
    np.testing.assert_allclose(s.values[0], linear_sed(centres[[3, 11, 50]]) * 1e6, rtol=1e-14)


def test_weights_are_reused_for_every_time_step(tmp_path, rng):
    points, hexes = hex_box()
    paths = []
    for k in range(3):
        p = tmp_path / f"s{k}.vtu"
        meshio.write(p, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": (k + 1.5) * linear_sed(points)}))
        paths.append(p)
    field = read_sed(paths, length_unit="mm", sed_unit="MPa")
    pos = inside_points(rng, 20)
    layout = ReceptorLayout(pos * 1e-3)
    sampler = build_sampler(field, layout, method="linear")
    s = sample_sed(field, layout, sampler=sampler)
    assert s.values.shape == (3, 20)
    for k in range(3):
        np.testing.assert_allclose(s.values[k], (k + 1.5) * linear_sed(pos) * 1e6, rtol=1e-12)


def test_outside_raise_warn_nan(field):
    pos = np.array([[0.5, 0.3, 0.9], [2.0, 0.3, 0.9]]) * 1e-3
    layout = ReceptorLayout(pos, ids=["inner", "far"])
    with pytest.raises(FieldCoverageError, match=re.escape(
            "1 of 2 receptors lie outside the SED field (first: receptor 'far' at [0.002, 0.0003, 0.0009] m; field bounds x [0, 0.0013] y [0, 0.0007] z [0, 0.0019] m).")):
        sample_sed(field, layout)
    with pytest.warns(AfferentWarning, match="1 of 2 receptors lie outside"):
        s = sample_sed(field, layout, on_outside="warn")
    assert np.isnan(s.values[0, 1]) and np.isfinite(s.values[0, 0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = sample_sed(field, layout, on_outside="nan")
    assert s.outside.tolist() == [False, True]


def test_receptors_on_the_boundary_are_inside(field):
    pos = np.array([[0.0, 0.0, 0.0], [1.3, 0.7, 1.9], [0.65, 0.7, 0.95]])
    s = sample_sed(field, ReceptorLayout(pos * 1e-3))
    np.testing.assert_allclose(s.values[0], linear_sed(pos) * 1e6, rtol=1e-12)


def scattered_field(rng, n=4000):
    pts = rng.uniform(0, 1, (n, 3)) * BOX_MM
    return SEDField(pts * 1e-3, (linear_sed(pts) * 1e6)[None], np.zeros(1), provenance=Provenance(format="csv"))


def test_scattered_points_linear_and_nearest(rng):
    field = scattered_field(rng)
    pos = 0.2 * BOX_MM + inside_points(rng, 50) * 0.6
    exact = linear_sed(pos) * 1e6
    lin = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear").values[0]
    near = sample_sed(field, ReceptorLayout(pos * 1e-3), method="nearest").values[0]
    np.testing.assert_allclose(lin, exact, rtol=1e-9)
    assert np.abs(near - exact).max() > 10 * np.abs(lin - exact).max()


def test_bad_options(field):
    layout = ReceptorLayout(np.zeros((1, 3)))
    with pytest.raises(ValueError, match=re.escape(
            "Invalid value for the 'method' parameter. Allowed values are 'linear' and 'nearest', but got 'cubic' instead.")):
        sample_sed(field, layout, method="cubic")
    with pytest.raises(ValueError, match=re.escape("Allowed values are 'raise', 'warn' and 'nan', but got 'ignore' instead.")):
        sample_sed(field, layout, on_outside="ignore")


def test_dataframe_long_form(field, rng):
    pos = inside_points(rng, 4)
    df = sample_sed(field, ReceptorLayout(pos * 1e-3, ids=list("abcd"))).to_dataframe()
    assert list(df.columns) == ["receptor", "x_m", "y_m", "z_m", "time_s", "sed_pa"]
    assert df["receptor"].tolist() == list("abcd")


def test_a_receptor_sed_table_in_other_units_is_warned(tmp_path):
    from afferent.sampling import read_receptor_sed

    path = tmp_path / "sed.csv"
    # positions written in mm and SED in MPa under the SI column names
    path.write_text("receptor,x_m,y_m,z_m,time_s,sed_pa\n0,0.5,3.0,1.0,0,2e-4\n1,2.5,3.0,1.0,0,3e-4\n")
    with pytest.warns(AfferentWarning) as rec:
        read_receptor_sed(path)
    text = " | ".join(str(w.message) for w in rec)
    assert re.search(r"SED of 0\.000\d+ J/m\^3 \(99th percentile of the nonzero values\) is far below", text), text
    assert "check that sed_pa is in Pa" in text and "(receptor positions): the points span 2 m" in text
