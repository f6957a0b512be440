"""Sampling the SED field at receptor sites: 'linear' is exact on linear fields, 'nearest' is not."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pandas as pd
import pytest

from afferent import read_receptors, read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, FieldCoverageError, UnitError
from afferent.field import Provenance, SEDField
from afferent.receptors import ReceptorLayout
from afferent.sampling import build_sampler, node_average

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


# -- cell data averaged to nodes ('linear' on cell data) ------------------------------------------------------------


def write_cells(path, points, blocks, sed):
    """A VTU with the given cell blocks and one cell 'SED' value (MPa) per cell, in block order."""
    sizes = np.cumsum([0] + [len(c) for _, c in blocks])
    cell_sed = [np.asarray(sed[a:b], float) for a, b in zip(sizes[:-1], sizes[1:])]
    meshio.write(path, meshio.Mesh(points, [(t, np.asarray(c)) for t, c in blocks], cell_data={"SED": cell_sed}))
    return read_sed(path, length_unit="mm", sed_unit="MPa", location="cell")


def test_two_equal_hexes_average_to_one_half_on_their_shared_face(tmp_path):
    # two unit hexes side by side along x, SED 1 MPa and 0: every node of the shared face x = 1 has
    # one cell of each, of equal volume, so its average is exactly 0.5 MPa (was 0.25 / 0.5 / 0.5 / 0.75:
    # weights from the tetrahedral split of each hexahedron)
    points, hexes = hex_box(2, 1, 1, size=(2.0, 1.0, 1.0))
    field = write_cells(tmp_path / "two.vtu", points, [("hexahedron", hexes)], [1.0, 0.0])
    face = np.array([[1, 0, 0], [1, 1, 0], [1, 0, 1], [1, 1, 1], [1, 0.3, 0.6], [1, 0.9, 0.2]], float)
    s = sample_sed(field, ReceptorLayout(face * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], 0.5e6, rtol=1e-14)
    ends = np.array([[0, 0, 0], [0, 1, 1], [2, 0, 1], [2, 1, 0]], float)  # nodes of one hex only
    s = sample_sed(field, ReceptorLayout(ends * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], [1e6, 1e6, 0.0, 0.0], rtol=1e-14, atol=1e-9)


def test_linear_cell_field_is_reproduced_at_interior_nodes(tmp_path, rng):
    # regular grid, cell value = linear field at the centroid: an interior node is the centroid of the
    # 8 equal cells around it, so their (equal-weight) mean is the field at the node, exactly. Every
    # other hexahedron starts at another corner (its nodes rotated a quarter turn about y, still a
    # valid VTK ordering, as meshers write them): its tetrahedral split then runs along another
    # diagonal, which must not matter.
    points, hexes = hex_box()
    hexes[::2] = hexes[::2][:, [1, 2, 3, 0, 5, 6, 7, 4]]
    field = write_cells(tmp_path / "lin.vtu", points, [("hexahedron", hexes)], linear_sed(points[hexes].mean(axis=1)))
    lo, hi = points.min(axis=0), points.max(axis=0)
    interior = points[np.all((points > lo + 1e-9) & (points < hi - 1e-9), axis=1)]
    s = sample_sed(field, ReceptorLayout(interior * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], linear_sed(interior) * 1e6, rtol=1e-13)
    # and anywhere between interior nodes (linear interpolation of exact node values)
    a, b = interior.min(axis=0), interior.max(axis=0)
    pos = a + rng.uniform(0, 1, (50, 3)) * (b - a)
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], linear_sed(pos) * 1e6, rtol=1e-13)


def test_cells_of_mixed_types_weigh_by_their_volume(tmp_path):
    # unit hexahedron (volume 1 mm^3, SED 1 MPa) and a tetrahedron on its face x = 1 (legs 1 mm:
    # volume 1/6 mm^3, SED 0): the 3 shared nodes get (1 * 1 + 1/6 * 0) / (1 + 1/6) = 6/7 MPa,
    # the hexahedron's other nodes 1 MPa, the tetrahedron's apex 0
    points, hexes = hex_box(1, 1, 1, size=(1.0, 1.0, 1.0))
    points = np.vstack([points, [[2.0, 0.0, 0.0]]])
    node = {tuple(p): i for i, p in enumerate(points)}
    tet = [[node[(1.0, 0.0, 0.0)], node[(1.0, 1.0, 0.0)], node[(1.0, 0.0, 1.0)], node[(2.0, 0.0, 0.0)]]]
    field = write_cells(tmp_path / "mixed.vtu", points, [("hexahedron", hexes), ("tetra", tet)], [1.0, 0.0])
    pos = np.array([[1, 0, 0], [1, 1, 0], [1, 0, 1], [1, 1, 1], [0, 0, 0], [2, 0, 0]], float)
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], np.array([6 / 7, 6 / 7, 6 / 7, 1, 1, 0]) * 1e6, rtol=1e-14, atol=1e-9)


def test_cells_averaged_to_nodes_match_the_sample_nodal_sed(sample_sed_dir):
    # The bundled sample's point SED is, by construction (sample_sed/README.md, "Nodal SED"), the
    # average of its cell SED over the cells sharing each node, weighted by the true (2x2x2 Gauss)
    # hexahedron volumes. Averaging with tetrahedral-split volumes reproduces it to 0.80 % (0.52 % on
    # the sample before issue 21, with the bottom face fixed): the split volume of the sample's warped
    # hexahedra differs from the true one by up to 1.15 %, which bounds it; the tetrahedral weights
    # used before were off by up to 57 %.
    path = sample_sed_dir / "block4" / "indent_0p88mm.vtu"
    cells = read_sed(path, length_unit="mm", sed_unit="MPa", location="cell")
    nodal = read_sed(path, length_unit="mm", sed_unit="MPa", location="point").sed[0]
    averaged = node_average(cells.cells, cells.points, cells.n_points) @ cells.sed[0]
    rel = np.abs(averaged - nodal) / nodal
    assert rel.max() < 0.0115 and np.median(rel) < 1e-4


def test_flat_tetrahedra_of_a_mesh_are_skipped(tmp_path):
    # A mesh with a flat tetrahedron (4 coplanar nodes: a sliver of a Delaunay mesher, a collapsed
    # cell) next to a good one. In m its round-off determinant (~1e-28) passed the old fixed
    # threshold and reached a singular solve ('Singular matrix'); it is now skipped by its
    # volume relative to its edge lengths, and the receptor is found in the good tetrahedron.
    a, b, c = np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    flat = a + 0.2 * (b - a) + 0.37 * (c - a)  # on the face x + y + z = 1
    points = np.array([[0.0, 0, 0], a, b, c, flat]) * 0.7
    path = tmp_path / "flat.vtu"
    meshio.write(path, meshio.Mesh(points, [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))],
                                   point_data={"SED": linear_sed(points)}))
    field = read_sed(path, length_unit="mm", sed_unit="MPa")
    pos = np.array([[0.3, 0.3, 0.3], [0.1, 0.2, 0.3], [0.32, 0.23, 0.13]]) * 0.7  # inside the good tetrahedron
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), method="linear")
    np.testing.assert_allclose(s.values[0], linear_sed(pos) * 1e6, rtol=1e-12)


# -- tables of points without cells (CSV): Delaunay ------------------------------------------------------------------

SAMPLE_OPTS = ["--length-unit", "mm", "--sed-unit", "Pa", "--method", "linear"]
#: A linear field in Pa over mm coordinates: 'linear' reproduces it up to the joggle of the
#: triangulation (sampling.JOGGLE = 1e-9 of the extent, times the gradient): < 1e-8 relative here.
GRAD = np.array([1.0, 2.0, 3.0])


def write_table(path, xyz_mm, sed_pa):
    pd.DataFrame({"x": xyz_mm[:, 0], "y": xyz_mm[:, 1], "z": xyz_mm[:, 2], "SED": sed_pa}).to_csv(path, index=False)
    return path


def write_receptors(path, ids, xyz_mm):
    pd.DataFrame({"id": ids, "x": xyz_mm[:, 0], "y": xyz_mm[:, 1], "z": xyz_mm[:, 2]}).to_csv(path, index=False)
    return path


def cli(capsys, *argv):
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def grid(*axes):
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(axes))


def test_table_on_a_grid_samples_linear_and_reports_outside_receptors(capsys, tmp_path):
    # FE nodes on a regular grid (a table export of a structured mesh): co-spherical points, whose
    # Delaunay tetrahedralisation holds flat tetrahedra. Receptors outside and below the points
    # crashed ('Singular matrix', also with --on-outside nan).
    xyz = grid(*[np.linspace(0, 1, 6)] * 3)
    table = write_table(tmp_path / "grid.csv", xyz, 1 + xyz @ GRAD)
    ids, pos = ["a", "c", "out", "below"], np.array([[0.5, 0.5, 0.5], [0.3, 0.4, 0.5], [3, 0.5, 0.5], [0.5, -2, 0.5]])
    receptors = write_receptors(tmp_path / "R.csv", ids, pos)
    out = tmp_path / "sed.csv"
    msg = ("2 of 4 receptors lie outside the SED field (first: receptor 'out' at [0.003, 0.0005, 0.0005] m; the field "
           "is the convex hull of its 216 points; field bounds x [0, 0.001] y [0, 0.001] z [0, 0.001] m). Pass "
           "on_outside='nan' to keep them as NaN or on_outside='warn' to continue.")
    cli_msg = (msg.replace("2 of 4 receptors lie", f"2 of 4 receptors of receptor file {str(receptors)!r} lie")
               .replace("on_outside='nan'", "--on-outside nan").replace("on_outside='warn'", "--on-outside warn"))
    code, err = cli(capsys, "sample", table, "--receptors", receptors, *SAMPLE_OPTS, "-o", out)
    assert (code, err) == (2, f"afferent: error: {cli_msg}\n") and not out.exists()
    code, err = cli(capsys, "sample", table, "--receptors", receptors, *SAMPLE_OPTS, "--on-outside", "nan", "-o", out)
    assert code == 0, err
    assert err.endswith("2 receptor(s) outside the field written as NaN\n")
    sed = pd.read_csv(out)["sed_pa"].to_numpy()
    np.testing.assert_allclose(sed[:2], 1 + pos[:2] @ GRAD, rtol=1e-8)
    assert np.isnan(sed[2:]).all()
    # the same through the Python API
    field = read_sed(table, length_unit="mm", sed_unit="Pa")
    assert (field.provenance.location, field.provenance.location_source) == ("point", "only point data")
    layout = ReceptorLayout(pos * 1e-3, ids=ids)
    with pytest.raises(FieldCoverageError, match=re.escape(msg)):
        sample_sed(field, layout)
    s = sample_sed(field, layout, on_outside="nan")
    assert s.outside.tolist() == [False, False, True, True]
    assert s.placement == "linear in a Delaunay tetrahedralisation of the points"


def test_receptor_over_one_layer_of_a_layered_table_is_found(tmp_path):
    # Points on three layers y = 0, 0.5, 1 mm (15 x 15 each): the 48 nearest points of a receptor
    # just under the top layer all lie in that layer (coplanar), which was refused as 'degenerate';
    # the triangulation now grows to the other layers.
    xz = grid(np.linspace(0, 1, 15), np.linspace(0, 1, 15))
    xyz = np.vstack([np.column_stack([xz[:, 0], np.full(len(xz), y), xz[:, 1]]) for y in (0.0, 0.5, 1.0)])
    field = SEDField(xyz * 1e-3, (1 + xyz @ GRAD)[None], np.zeros(1), provenance=Provenance(format="csv"))
    pos = np.array([[0.52, 0.99, 0.47], [0.21, 0.999, 0.83], [0.52, 1.2, 0.47]])
    s = sample_sed(field, ReceptorLayout(pos * 1e-3), on_outside="nan")
    assert s.outside.tolist() == [False, False, True]
    np.testing.assert_allclose(s.values[0, :2], 1 + pos[:2] @ GRAD, rtol=1e-8)


def test_surface_only_table_is_interpolated_in_its_plane(capsys, tmp_path):
    # SED exported on the skin surface only: all points in the plane y = 0.7 mm (a 9 x 9 grid).
    # 'linear' triangulates in that plane; receptors off it (under the surface) or beside the
    # points are outside. Was refused: 'needs a 3-D point cloud ... (coplanar?)'.
    xz = grid(np.linspace(0, 1, 9), np.linspace(0, 1, 9))
    xyz = np.column_stack([xz[:, 0], np.full(len(xz), 0.7), xz[:, 1]])
    table = write_table(tmp_path / "surface.csv", xyz, 1 + xyz @ GRAD)
    ids, pos = ["on", "edge", "under", "beside"], np.array([[0.3, 0.7, 0.6], [1.0, 0.7, 0.25], [0.3, 0.5, 0.6], [1.5, 0.7, 0.5]])
    receptors = write_receptors(tmp_path / "R.csv", ids, pos)
    out = tmp_path / "sed.csv"
    msg = ("2 of 4 receptors lie outside the SED field (first: receptor 'under' at [0.0003, 0.0005, 0.0006] m; the "
           "field is a surface: its 81 points lie in one plane (normal [0, 1, 0]); receptors farther than 1e-07 m from "
           "it, or off its points' hull in it, are outside; field bounds x [0, 0.001] y [0.0007, 0.0007] z [0, 0.001] m). "
           "Pass on_outside='nan' to keep them as NaN or on_outside='warn' to continue.")
    cli_msg = (msg.replace("2 of 4 receptors lie", f"2 of 4 receptors of receptor file {str(receptors)!r} lie")
               .replace("on_outside='nan'", "--on-outside nan").replace("on_outside='warn'", "--on-outside warn"))
    code, err = cli(capsys, "sample", table, "--receptors", receptors, *SAMPLE_OPTS, "-o", out)
    assert (code, err) == (2, f"afferent: error: {cli_msg}\n")
    code, err = cli(capsys, "sample", table, "--receptors", receptors, *SAMPLE_OPTS, "--on-outside", "nan", "-o", out)
    assert code == 0, err
    sed = pd.read_csv(out)["sed_pa"].to_numpy()
    np.testing.assert_allclose(sed[:2], 1 + pos[:2] @ GRAD, rtol=1e-8)
    assert np.isnan(sed[2:]).all()
    field = read_sed(table, length_unit="mm", sed_unit="Pa")
    with pytest.raises(FieldCoverageError, match=re.escape(msg)):
        sample_sed(field, ReceptorLayout(pos * 1e-3, ids=ids))
    s = sample_sed(field, ReceptorLayout(pos[:2] * 1e-3))
    assert s.placement == "linear in a Delaunay triangulation of the points' plane (surface-only table)"


def test_table_on_a_line_is_a_clear_error(capsys, tmp_path):
    xyz = np.column_stack([np.linspace(0, 1, 5), np.full(5, 0.7), np.full(5, 0.2)])
    table = write_table(tmp_path / "line.csv", xyz, np.ones(5))
    receptors = write_receptors(tmp_path / "R.csv", ["r"], np.array([[0.5, 0.7, 0.2]]))
    msg = (f"Linear sampling needs the points of SED file {str(table)!r} to span a volume or a surface; its 5 point(s) "
           "lie on a line (extent 0.001 m, width across 0 m). Use method='nearest'.")
    code, err = cli(capsys, "sample", table, "--receptors", receptors, *SAMPLE_OPTS, "-o", tmp_path / "o.csv")
    cli_msg = msg.replace("method='nearest'", "--method nearest")
    assert (code, err) == (2, f"afferent: error: {cli_msg}\n")
    field = read_sed(table, length_unit="mm", sed_unit="Pa")
    with pytest.raises(FieldCoverageError, match=re.escape(msg)):
        sample_sed(field, ReceptorLayout(np.array([[0.5, 0.7, 0.2]]) * 1e-3))
    # 'nearest' needs no triangulation
    assert sample_sed(field, ReceptorLayout(np.array([[0.5, 0.7, 0.2]]) * 1e-3), method="nearest").values[0, 0] == 1.0


def test_bundled_comsol_table_matches_the_mesh_at_the_papilla_tips(sample_sed_dir):
    # The bundled COMSOL-style table holds the VTU's nodes with y >= 1.8 mm and |x - 2|, |z - 2| <= 1.5 mm
    # (sample_sed/README.md), values printed with 10 digits. The papilla-tip receptors are nodes: inside
    # that region 'linear' in the table gives the VTU's nodal SED (to the 10 digits and the joggle);
    # the 28 tips outside the region are outside. Crashed: 'Singular matrix'.
    block = sample_sed_dir / "block4"
    table = read_sed(block / "indent_0p88mm_comsol.csv")
    mesh = read_sed(block / "indent_0p88mm.vtu", length_unit="mm", sed_unit="MPa")
    layout = read_receptors(block / "receptors.csv", length_unit="mm")
    s = sample_sed(table, layout, on_outside="nan")
    lo, hi = table.bounds
    assert s.outside.tolist() == np.any((layout.positions < lo) | (layout.positions > hi), axis=1).tolist()
    assert s.outside.sum() == 28
    inside = ~s.outside
    np.testing.assert_allclose(s.values[0, inside], sample_sed(mesh, layout).values[0, inside], rtol=1e-7)


def test_receptors_declared_in_another_unit_are_named_as_such(tmp_path, field):
    # field: the hex box of these tests (mm); receptors written in mm but declared m -> 1000x too far
    path = tmp_path / "R.csv"
    path.write_text("x,y,z\n0.2,0.3,0.4\n0.6,0.5,0.9\n")
    far = read_receptors(path, length_unit="m")
    with pytest.raises(FieldCoverageError, match=re.escape(
            f"The receptors of receptor file {str(path)!r} span 263 x the field's extent: check the length unit declared "
            "for the receptor positions (mm vs m is a factor 1e3).")):
        sample_sed(field, far)
    # written in um, declared mm: 1000x too close together, all in one cell of the field: refused (issue 22)
    path.write_text("x,y,z\n0.2,0.3,0.4\n0.6,0.5,0.9\n")
    near = ReceptorLayout(read_receptors(path, length_unit="mm").positions * 1e-3, source=str(path))
    with pytest.raises(UnitError, match=re.escape("span 0.000263 x the field's extent")):
        sample_sed(field, near)


# --------------------------------------------------------------------- properties
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from scipy.spatial import Delaunay  # noqa: E402

from afferent.field import Cells  # noqa: E402


@settings(max_examples=120, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), log_length=st.floats(-6, 0), log_sed=st.floats(-6, 8),
       with_cells=st.booleans(), n_points=st.integers(8, 200))
def test_property_linear_sampling_reproduces_any_linear_field(seed, log_length, log_sed, with_cells, n_points):
    """Any point cloud (1 um to 1 m across), tetrahedralised or scattered, any linear field
    (1e-6 to 1e8 J/m^3, any gradient direction), receptors anywhere inside: 'linear' returns the
    field's own value to float rounding."""
    rng = np.random.default_rng(seed)
    scale = 10.0**log_length
    pts = rng.uniform(0, 1, (n_points, 3)) * scale * rng.uniform(0.2, 1.0, 3)
    tri = Delaunay(pts)
    keep = np.abs(np.linalg.det(pts[tri.simplices[:, 1:]] - pts[tri.simplices[:, :1]])) > 1e-9 * scale**3
    simplices = tri.simplices[keep]
    if simplices.size == 0:
        return
    grad = rng.standard_normal(3)
    offset = 10.0**log_sed
    slope = 0.5 * offset / (np.abs(grad).sum() * scale)  # the field stays positive inside the box
    f = lambda x: offset + slope * (x @ grad)  # noqa: E731
    cells = Cells(simplices, np.arange(len(simplices)), len(simplices), ("tetra",)) if with_cells else None
    field = SEDField(pts, f(pts)[None, :], np.array([0.0]), cells=cells)
    pick = rng.integers(0, len(simplices), 30)
    bary = rng.dirichlet(np.ones(4), 30)
    receptors = np.einsum("rk,rkj->rj", bary, pts[simplices[pick]])
    got = sample_sed(field, ReceptorLayout(receptors), method="linear").values[0]
    np.testing.assert_allclose(got, f(receptors), rtol=1e-9)


def test_scattered_points_are_located_without_scipy_walking_every_simplex(monkeypatch):
    """Issue 23: scipy's find_simplex often fails its walk in the Delaunay of a structured mesh's
    nodes and then tests every simplex (1.6-3.5 s for 200 receptors in the 22,099-point COMSOL
    sample). Candidates by nearest centroids find every receptor inside; find_simplex only sees
    those they miss (none here), and the values are those of linear interpolation."""
    from conftest import SAMPLE_DIR

    from afferent import _mesh_geometry

    path = SAMPLE_DIR / "block4" / "indent_0p88mm_comsol.csv"
    if not path.is_file():
        pytest.skip("bundled sample not generated")
    field = read_sed(path, length_unit="mm", sed_unit="Pa")
    lo, hi = field.points.min(axis=0), field.points.max(axis=0)
    inside = np.random.default_rng(0).uniform(lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo), (60, 3))
    seen = []
    real = _mesh_geometry._find_simplex
    monkeypatch.setattr(_mesh_geometry, "_find_simplex", lambda tri, x: seen.append(len(x)) or real(tri, x))
    sampler = build_sampler(field, ReceptorLayout(inside), method="linear")
    assert not sampler.outside.any() and sum(seen) == 0
    # a linear field is reproduced (the weights are barycentric in a containing tetrahedron)
    lin = SEDField(field.points, (field.points @ np.array([3.0, -2.0, 5.0]) * 1e3 + 7.0)[None, :], np.zeros(1))
    got = build_sampler(lin, ReceptorLayout(inside), method="linear").apply(lin.sed)
    # rtol 1e-7: the Delaunay of a structured mesh's nodes has sliver tetrahedra whose barycentric
    # solve amplifies round-off (1.1e-9 seen with scipy 1.18 on Python 3.13); a wrong weight is O(1)
    np.testing.assert_allclose(got[0], inside @ np.array([3.0, -2.0, 5.0]) * 1e3 + 7.0, rtol=1e-7)


def test_points_located_in_chunks_find_the_tetrahedra_of_one_chunk(monkeypatch, rng):
    """Issue 33 item 12: locate_in_tets searches LOCATE_CHUNK points at a time (memory that does not grow with
    the receptors: 1e6 at once took 1.2 GB); each point's tetrahedron and weights are those of one chunk,
    points outside the mesh included (they go through the wider and the brute-force searches)."""
    from afferent import _mesh_geometry

    field = read_sed(Path(__file__).resolve().parents[1] / "sample_sed" / "block4" / "indent_0p88mm.vtu",
                     length_unit="mm", sed_unit="MPa")
    lo, hi = field.bounds
    points = np.concatenate([lo + (hi - lo) * rng.random((3000, 3)), lo + (hi - lo) * rng.uniform(-0.05, 1.05, (20, 3)),
                             field.points[:500]])
    whole = _mesh_geometry.locate_in_tets(points, field.points, field.cells.tetra)
    assert (whole[0] < 0).sum() > 3 and (whole[0] >= 0).sum() > 3000
    monkeypatch.setattr(_mesh_geometry, "LOCATE_CHUNK", 37)
    for got, want in zip(_mesh_geometry.locate_in_tets(points, field.points, field.cells.tetra), whole):
        np.testing.assert_array_equal(got, want)
