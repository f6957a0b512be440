"""Quadratic cells: interpolated with their own shape functions (afferent/_shape_functions.py), the
readers' node orders mapped to VTK's, quadratic and Lagrange cell types of VTK files.

Meshes: CalculiX 2.20's own .frd files (tests/data/calculix), 8 irregular HEX20 from VTK 9.7.2's IOSS writer
(tests/data/exodus), VTK 9.7's files (tests/data/vtk), and structured meshes of every quadratic
type written with meshio. A field exactly quadratic in x, y, z is interpolated exactly by a
quadratic cell whose isoparametric map is affine (straight edges, a parallelepiped hexahedron);
on a curved cell a field linear in x, y, z still is (the map interpolates the coordinates).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest

from afferent import read_sed
from afferent._shape_functions import QUADRATIC, SHAPED, _nodes, natural_coordinates, node_offsets, shape_functions
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.field import Cells, SEDField
from afferent.io import read_raw
from afferent.io._cell_blocks import _complete_meshio_dimensions, cells_from_meshio
from afferent.receptors import ReceptorLayout
from afferent.sampling import PLACEMENTS, build_sampler

DATA = Path(__file__).parent / "data"
CCX = DATA / "calculix"
VTKDIR = DATA / "vtk"
HEX20 = DATA / "exodus" / "hex20_ioss.e"  # 8 irregular HEX20 written by VTK's IOSS writer (Exodus node order)


def quadratic(p):
    x, y, z = np.asarray(p, float).T
    return 1 + x + y**2 + x * z


def linear(p):
    x, y, z = np.asarray(p, float).T
    return 1 + x - 2 * y + 3 * z


def _sample(points, cells, values, pos):
    """SED at pos from point values on a mesh; (values, sampler)."""
    field = SEDField(points, np.asarray(values, float)[None], np.zeros(1), "point", cells)
    s = build_sampler(field, ReceptorLayout(pos, np.arange(len(pos)).astype(str)))
    return s.apply(field.sed)[0], s


class _Block:  # what cells_from_meshio reads (meshio's own CellBlock needs meshio to know the type)
    def __init__(self, ctype, data):
        self.type, self.data = ctype, data


def _corners_only(cells):
    return Cells(cells.tetra, cells.parent, cells.n_cells, cells.cell_types)


def _inside(points, n, seed=0, margin=0.02):
    lo, hi = points.min(axis=0), points.max(axis=0)
    return lo + (hi - lo) * (margin + (1 - 2 * margin) * np.random.default_rng(seed).random((n, 3)))


# --- the shape functions -------------------------------------------------------------------------

@pytest.mark.parametrize("ctype", SHAPED)
def test_shape_functions_interpolate_their_nodes_and_sum_to_one(ctype):
    assert np.allclose(shape_functions(ctype, _nodes(ctype)), np.eye(len(_nodes(ctype))), atol=1e-12)
    xi = np.random.default_rng(1).random((20, 3)) * [0.5, 0.5, 1.0]
    n, dn = shape_functions(ctype, xi, derivatives=True)
    assert np.allclose(n.sum(axis=1), 1) and np.allclose(dn.sum(axis=1), 0, atol=1e-12)


VTK_CELLS = {"tetra10": "vtkQuadraticTetra", "hexahedron20": "vtkQuadraticHexahedron",
             "hexahedron27": "vtkTriQuadraticHexahedron", "wedge15": "vtkQuadraticWedge",
             "wedge18": "vtkBiQuadraticQuadraticWedge", "hexahedron": "vtkHexahedron", "wedge": "vtkWedge",
             "pyramid": "vtkPyramid"}


@pytest.mark.parametrize("ctype", SHAPED)
def test_shape_functions_and_nodes_are_vtks(ctype):
    vtk = pytest.importorskip("vtk")
    cell = getattr(vtk, VTK_CELLS[ctype])()
    n = cell.GetNumberOfPoints()
    pc = cell.GetParametricCoords()
    assert np.array_equal(np.array([pc[i] for i in range(3 * n)]).reshape(n, 3), _nodes(ctype))
    xi = np.random.default_rng(2).random((6, 3)) * [0.5, 0.4, 0.9]
    ours, dours = shape_functions(ctype, xi, derivatives=True)
    for k, p in enumerate(xi):
        w, d = [0.0] * n, [0.0] * (3 * n)
        cell.InterpolationFunctions(list(p), w)
        cell.InterpolationDerivs(list(p), d)
        assert np.allclose(w, ours[k], atol=1e-14)
        assert np.allclose(np.reshape(d, (3, n)).T, dours[k], atol=1e-13)


def test_vtk_lagrange_cells_of_degree_2_number_their_nodes_as_the_quadratic_cells():
    vtk = pytest.importorskip("vtk")
    for cls, ctype in (("vtkLagrangeHexahedron", "hexahedron27"), ("vtkLagrangeWedge", "wedge18")):
        ijk = np.rint(_nodes(ctype) * 2).astype(int)
        index = [getattr(vtk, cls).PointIndexFromIJK(int(i), int(j), int(k), [2, 2, 2]) for i, j, k in ijk]
        assert index == list(range(len(ijk))), cls


def test_newton_finds_the_natural_coordinates_in_a_curved_cell():
    rng = np.random.default_rng(3)
    for ctype in SHAPED:
        nodes = _nodes(ctype) @ np.array([[2, 0.3, 0], [0, 1, 0.2], [0.1, 0, 1.5]]).T
        nodes[len(nodes) // 2:] += 0.04 * rng.standard_normal((len(nodes) - len(nodes) // 2, 3))  # curved edges
        xi = np.array([[0.2, 0.3, 0.25], [0.1, 0.1, 0.7]])
        p = shape_functions(ctype, xi) @ nodes
        got, ok = natural_coordinates(ctype, p, np.repeat(nodes[None], 2, axis=0))
        assert ok.all() and np.allclose(got, xi, atol=1e-12), ctype


# --- real files: node orders and exact quadratic fields --------------------------------------------

CCX_FILES = {"tetra10": "block_c3d10.frd", "hexahedron20": "block_c3d20r.frd", "wedge15": "block_c3d15.frd"}


@pytest.mark.parametrize("path", [CCX / f for f in CCX_FILES.values()] + [HEX20], ids=lambda p: p.name)
def test_the_readers_put_the_nodes_in_vtk_order(path):
    # .frd and Exodus list the vertical edges' mid-nodes before the top face's (20-node brick, 15-node wedge)
    raw = read_raw(path)
    for ctype, conn in zip(raw.cells.cell_types, raw.cells.nodes):
        assert node_offsets(ctype, conn, raw.points).max() < 1e-6, ctype  # Exodus: float32 coordinates


@pytest.mark.parametrize("ctype", list(CCX_FILES))
def test_a_quadratic_field_is_exact_in_calculix_quadratic_cells(ctype):
    f = read_sed(CCX / CCX_FILES[ctype], length_unit="mm", sed_unit="MPa")
    assert f.cells.cell_types == (ctype,)
    pos = _inside(f.points, 400)
    scale = 1e3  # the field in mm
    exact = quadratic(pos * scale)
    got, s = _sample(f.points, f.cells, quadratic(f.points * scale), pos)
    span = np.ptp(quadratic(f.points * scale))
    assert np.abs(got - exact).max() < 1e-12 * span
    assert s.placement == PLACEMENTS[("point", "shape")] and not s.outside.any()
    before, s0 = _sample(f.points, _corners_only(f.cells), quadratic(f.points * scale), pos)
    assert s0.placement == PLACEMENTS[("point", "linear")]
    assert np.abs(before - exact).max() > 0.01 * span  # corners only: several % of the range off


def test_corner_only_error_on_a_coarse_tet10_mesh():
    """The figure quoted in docs/fe-export.md: 2,000 random points in block_c3d10.frd (24 tetra10)."""
    f = read_sed(CCX / "block_c3d10.frd", length_unit="mm", sed_unit="MPa")
    pos = _inside(f.points, 2000, margin=0.0)
    L = np.ptp(f.points, axis=0).max()
    nodal, exact = quadratic(f.points / L), quadratic(pos / L)
    span = np.ptp(nodal)
    before = np.abs(_sample(f.points, _corners_only(f.cells), nodal, pos)[0] - exact) / span
    after = np.abs(_sample(f.points, f.cells, nodal, pos)[0] - exact) / span
    assert 0.04 < before.max() < 0.06 and 0.02 < np.sqrt(np.mean(before**2)) < 0.035
    assert after.max() < 1e-13


def test_exodus_hex20_linear_exact_and_quadratic_closer_than_corners():
    # 8 irregular straight-edged HEX20: their map is trilinear, not affine, so the serendipity
    # space does not hold x^2 exactly; a linear field it does, and the quadratic error shrinks.
    f = read_raw(HEX20)
    assert f.cells.cell_types == ("hexahedron20",)
    pos = _inside(f.points, 300)
    got, _ = _sample(f.points, f.cells, linear(f.points), pos)
    assert np.abs(got - linear(pos)).max() < 1e-12
    after = np.abs(_sample(f.points, f.cells, quadratic(f.points), pos)[0] - quadratic(pos))
    before = np.abs(_sample(f.points, _corners_only(f.cells), quadratic(f.points), pos)[0] - quadratic(pos))
    both = np.isfinite(before)  # the corner tetrahedra of warped faces miss a few points the cells hold
    assert np.isfinite(after).all() and both.sum() > 250 and after[both].max() < before[both].max() / 3


# --- meshio-built meshes of every quadratic type -----------------------------------------------

_TRIANGLES = (lambda r, s: (r + s, s), lambda r, s: (r, r + s))  # a unit square's two halves
_KUHN = [np.array([[1, 0, 0], [1, 1, 0], [1, 1, 1]])[:, list(p)] for p in  # a unit cube's 6 tetrahedra
         ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0))]


def _structured(ctype, n=2):
    """A grid of n x n x n unit boxes in cells of ``ctype`` (wedges: 2 per box, tetrahedra: 6):
    (points (grid of spacing 1/2), connectivity in VTK order)."""
    g = np.arange(2 * n + 1)
    points = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) / 2.0
    index = lambda ijk: (ijk[..., 0] * (2 * n + 1) + ijk[..., 1]) * (2 * n + 1) + ijk[..., 2]  # noqa: E731
    xi = _nodes(ctype)
    if ctype.startswith("tetra"):
        local = [xi @ k for k in _KUHN]  # natural -> box coordinates: the corners to 0, v1, v2, (1, 1, 1)
    elif ctype.startswith("wedge"):
        local = [np.column_stack([*m(xi[:, 0], xi[:, 1]), xi[:, 2]]) for m in _TRIANGLES]
    else:
        local = [xi]
    conn = [index(np.rint(2 * (base + loc)).astype(int))
            for base in np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3) for loc in local]
    return points, np.array(conn)


AFFINE = np.array([[1.0, 0.35, 0.1], [0.05, 0.8, 0.25], [0.15, -0.1, 1.2]])


@pytest.mark.parametrize("ctype", ["hexahedron20", "hexahedron27", "wedge15", "wedge18"])
def test_a_quadratic_field_is_exact_in_meshio_written_cells(ctype, tmp_path):
    points, conn = _structured(ctype)
    points = points @ AFFINE.T + [0.3, -0.2, 0.1]  # sheared: no face parallel to an axis
    path = tmp_path / f"{ctype}.vtu"
    _complete_meshio_dimensions()  # meshio 5.3.5 cannot write a wedge15 without it
    meshio.write(str(path), meshio.Mesh(points, [(ctype, conn)], point_data={"SED": quadratic(points)}))
    f = read_sed(path, length_unit="m", sed_unit="Pa")
    assert f.cells.cell_types == (ctype,)
    pos = (np.random.default_rng(4).random((300, 3)) * 1.9 + 0.05) @ AFFINE.T + [0.3, -0.2, 0.1]
    got, s = _sample(f.points, f.cells, f.sed[0], pos)
    assert not s.outside.any() and np.abs(got - quadratic(pos)).max() < 1e-12


@pytest.mark.parametrize("ctype", QUADRATIC)
def test_curved_cells_give_a_linear_field_exactly_and_find_points_beyond_their_corners(ctype):
    points, conn = _structured(ctype)
    bend = points.copy()
    # corners stay, mid-edge nodes rise by 0.08, face centres by 0.16: every cell's edges curve
    bend[:, 2] += 0.08 * (np.sin(np.pi * points[:, 0]) ** 2 + np.sin(np.pi * points[:, 1]) ** 2)
    cells = cells_from_meshio([_Block(ctype, conn)], "cells")
    # points on the curved cells: mapped from natural coordinates of each cell
    rng = np.random.default_rng(5)
    xi = rng.random((len(conn), 3)) * {"t": 0.3, "w": [0.45, 0.45, 0.9], "h": 0.9}[ctype[0]] + 0.03
    pos = np.einsum("cn,cnd->cd", shape_functions(ctype, xi), bend[conn])
    top = np.array([[0.5, 0.25, 2.03]])  # under the bulging top face, above its corners' plane (z = 2)
    got, s = _sample(bend, cells, linear(bend), np.vstack([pos, top]))
    assert not s.outside.any()
    assert np.abs(got - linear(np.vstack([pos, top]))).max() < 1e-11
    corners = _sample(bend, _corners_only(cells), linear(bend), top)[1]
    assert corners.outside.all()  # the corner tetrahedra miss it


# --- fallbacks: nodes without values, a node order that is not VTK's --------------------------------

def test_a_cell_with_a_node_left_out_is_interpolated_from_its_corners():
    f = read_sed(CCX / "block_c3d20r.frd", length_unit="mm", sed_unit="MPa")
    nodes = f.cells.nodes[0].copy()
    nodes[0, 12] = -1  # as drop_valueless_nodes marks a mid-side node without values
    cells = Cells(f.cells.tetra, f.cells.parent, f.cells.n_cells, f.cells.cell_types, nodes=(nodes,))
    pos = _inside(f.points, 200)
    got, s = _sample(f.points, cells, linear(f.points), pos)
    assert np.abs(got - linear(pos)).max() < 1e-12
    assert re.search(r"; \d+ receptor\(s\) interpolated linearly in the tetrahedra of their cell's corners \(\d+ with "
                     r"a node without values\)$", s.placement)


def test_drop_valueless_nodes_marks_the_mid_side_nodes_it_leaves_out():
    from afferent.io._raw import RawArray, drop_valueless_nodes

    raw = read_raw(CCX / "block_c3d20r.frd")
    corner = np.zeros(raw.points.shape[0], bool)
    corner[np.unique(raw.cells.tetra)] = True
    values = np.where(corner, 1.0, np.nan)[None]
    out = drop_valueless_nodes(type(raw)(files=raw.files, format=raw.format, points=raw.points,
                                         arrays={"SED": RawArray("SED", values, "point")}, cells=raw.cells))
    assert out.points.shape[0] == corner.sum()
    assert (out.cells.nodes[0][:, :8] >= 0).all() and (out.cells.nodes[0][:, 8:] == -1).all()


def test_a_node_order_that_is_not_vtks_warns_and_uses_the_corners():
    f = read_sed(CCX / "block_c3d20r.frd", length_unit="mm", sed_unit="MPa")
    swapped = f.cells.nodes[0][:, np.r_[0:12, 16:20, 12:16]]  # the .frd's own order, unmapped
    cells = Cells(f.cells.tetra, f.cells.parent, f.cells.n_cells, f.cells.cell_types, nodes=(swapped,))
    pos = _inside(f.points, 50)
    with pytest.warns(AfferentWarning, match=r"50 receptor\(s\) lie in quadratic cells whose nodes sit more than 0.3 "
                                             r"of the longest edge from where the corners put them: a node order other "
                                             r"than VTK's\?"):
        got, s = _sample(f.points, cells, linear(f.points), pos)
    assert np.abs(got - linear(pos)).max() < 1e-12 and s.placement.endswith("(50 with a node order)")


def test_cells_nodes_must_match_the_cell_types():
    with pytest.raises(ValueError, match=re.escape(
            "'nodes' must hold one connectivity array per cell type (1) and n_cells = 2 cells in all; got 1 array(s) "
            "of 1 cells instead.")):
        Cells(np.array([[0, 1, 2, 3]]), np.array([0]), 2, ("tetra10",), nodes=(np.zeros((1, 10), int),))


# --- VTK files: quadratic wedges and pyramids, Lagrange cells ---------------------------------------

@pytest.mark.parametrize("name", ["wedge15_pyramid13.vtu", "wedge15_pyramid13.vtk"])
def test_quadratic_wedges_and_pyramids_load(name, monkeypatch):
    from meshio._mesh import topological_dimension

    for missing in ("wedge15", "pyramid13"):  # as meshio 5.3.5 ships, whatever ran before
        monkeypatch.delitem(topological_dimension, missing, raising=False)
    f = read_sed(VTKDIR / name, length_unit="m", sed_unit="Pa")  # meshio alone: KeyError 'wedge15'
    assert f.cells.cell_types == ("wedge15", "pyramid13")
    wedge = f.points[f.cells.nodes[0][0]]
    xi = np.random.default_rng(6).random((50, 3)) * [0.45, 0.45, 0.95]
    pos = shape_functions("wedge15", xi) @ wedge
    pyramid = f.points[f.cells.nodes[1][0, :5]]  # its corners: interpolated linearly between them
    apex_side = pyramid[:4].mean(axis=0) * 0.6 + pyramid[4] * 0.4
    got, s = _sample(f.points, f.cells, f.sed[0], np.vstack([pos, apex_side]))
    assert np.abs(got[:-1] - quadratic(pos)).max() < 1e-12
    corner_weights = s.weights[len(pos)].toarray().ravel()
    assert set(np.flatnonzero(corner_weights)) <= set(f.cells.nodes[1][0, :5]) and np.isfinite(got[-1])
    assert s.placement == PLACEMENTS[("point", "shape")]


@pytest.mark.parametrize("name", ["lagrange_hex27.vtk", "lagrange_hex27.vtu"])
def test_a_lagrange_hexahedron_of_degree_2_is_a_27_node_hexahedron(name, tmp_path, monkeypatch):
    # the .vtu is VTK XML version 2.3, which meshio.vtu.read refuses: afferent's VTU reader reads it, writing nothing
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    f = read_sed(VTKDIR / name, length_unit="m", sed_unit="Pa")
    assert list(tmp_path.iterdir()) == []  # no temporary copy (before: one, deleted after reading)
    assert f.cells.cell_types == ("hexahedron27",)
    pos = _inside(f.points, 100, margin=0.3)
    got, s = _sample(f.points, f.cells, f.sed[0], pos)
    inside = ~s.outside
    assert inside.sum() > 20 and np.abs(got[inside] - quadratic(pos[inside])).max() < 1e-12


def test_lagrange_cells_afferent_cannot_interpolate_in_are_refused_not_triangulated():
    path = VTKDIR / "lagrange_hex64.vtk"
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(path)!r} holds 1 volume cell(s) of type 'VTK_LAGRANGE_HEXAHEDRON' (64 nodes), which "
            "afferent cannot interpolate in;")):
        read_sed(path, length_unit="m", sed_unit="Pa")


@pytest.mark.parametrize("version", ["1.0", "2.0", "2.1"])
def test_a_vtu_written_before_vtk_9_numbers_lagrange_hexahedra_as_vtk_reads_them(version, tmp_path):
    # VTU file version < 2.1: VTK's reader swaps nodes 18 and 19 of a quadratic Lagrange hexahedron
    old = tmp_path / "old.vtu"
    old.write_text((VTKDIR / "lagrange_hex27.vtu").read_text().replace('version="2.3"', f'version="{version}"', 1))
    raw = read_raw(old)
    swapped = version < "2.1"
    assert raw.cells.nodes[0][0].tolist() == list(range(18)) + ([19, 18] if swapped else [18, 19]) + list(range(20, 27))
    vtk = pytest.importorskip("vtk")
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(old))
    reader.Update()
    cell = reader.GetOutput().GetCell(0)
    assert [cell.GetPointId(i) for i in range(27)] == raw.cells.nodes[0][0].tolist()


def test_cropping_for_a_scene_keeps_the_quadratic_cells():
    from afferent.scene.stages import _crop

    f = read_sed(CCX / "block_c3d20r.frd", length_unit="mm", sed_unit="MPa")
    cropped, info = _crop(f, np.array([[1e-4, 1e-4, 1e-4], [4e-4, 4e-4, 4e-4]]), "linear")
    assert info is not None and cropped.cells.nodes[0] is not None
    assert all(np.array_equal(a, b) for a, b in zip(cropped.cells.nodes, f.cells.nodes))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got, s = _sample(cropped.points, cropped.cells, quadratic(cropped.points * 1e3), np.array([[3e-4, 2e-4, 1e-4]]))
    assert abs(got[0] - quadratic(np.array([[0.3, 0.2, 0.1]]))[0]) < 1e-12


def test_quadratic_overshoot_below_zero_between_non_negative_nodes_is_zero():
    # ccx's nodal ENER (negative artefacts set to 0 by read_sed): the shape functions dip below 0
    f = read_sed(CCX / "block_c3d15.frd", length_unit="mm", sed_unit="MPa")
    assert f.sed.min() >= 0
    pos = _inside(f.points, 5000, margin=0.0)
    _, s = _sample(f.points, f.cells, f.sed[-1], pos)
    raw = np.asarray(s.weights @ f.sed.T).T
    assert (raw < -1e-3 * f.sed.max()).sum() > 10  # what the weights alone give
    values = s.apply(f.sed)
    assert values.min() == 0 and np.array_equal(values[raw >= 0], raw[raw >= 0])
    assert "values below 0 between non-negative nodes set to 0" in s.placement
    signed = f.sed - 0.5 * f.sed.max()  # negative nodes: nothing is clipped
    assert np.allclose(s.apply(signed), np.asarray(s.weights @ signed.T).T)
