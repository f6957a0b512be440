"""'linear' sampling in hexahedra, wedges and pyramids uses each cell's own shape functions
(issue 36, item 5), not the tetrahedra of its split: trilinear in a hexahedron, linear x linear in a
wedge, VTK's basis in a pyramid (afferent/_shape_functions.py; the bases are checked against VTK's
in tests/test_quadratic.py). Each test field is one the cell reproduces exactly; the tetrahedral
split does not (and its answer depended on which diagonals the split took).
"""

from __future__ import annotations

import numpy as np
import pytest

from afferent._shape_functions import natural_coordinates, shape_functions
from afferent.field import SEDField
from afferent.io._cell_blocks import cells_from_meshio
from afferent.receptors import ReceptorLayout
from afferent.sampling import PLACEMENTS, build_sampler

HEX = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], float)
ROTATED = [1, 2, 3, 0, 5, 6, 7, 4]  # the same hexahedron from another corner: its split takes other diagonals


class _Block:
    def __init__(self, ctype, data):
        self.type, self.data = ctype, np.asarray(data)


def _sample(points, blocks, values, pos, location="point"):
    """(values at pos, sampler) of point (or cell) values on a mesh of ``blocks`` [(type, conn)]."""
    cells = cells_from_meshio([_Block(t, c) for t, c in blocks], "test")
    field = SEDField(np.asarray(points, float), np.asarray(values, float)[None], np.zeros(1), location, cells)
    s = build_sampler(field, ReceptorLayout(np.asarray(pos, float), np.arange(len(pos)).astype(str)))
    return s.apply(field.sed)[0], s


def test_the_issue_example_hex_centre_reads_the_trilinear_value_whatever_the_node_order():
    # f = 1.75 + 2/3 (xy + yz + zx): bilinear terms, which a trilinear hexahedron holds exactly; its
    # centre is f(1/2, 1/2, 1/2) = 2.25. The split's 6 tetrahedra share the diagonal 0-6 through the
    # centre and gave (f0 + f6) / 2 = 2.75; from another corner the diagonal is 1-7 and gave 2.083.
    def f(p):
        x, y, z = p.T
        return 1.75 + 2 / 3 * (x * y + y * z + z * x)

    for order in (list(range(8)), ROTATED):
        got, s = _sample(HEX, [("hexahedron", [order])], f(HEX), [[0.5, 0.5, 0.5]])
        assert got[0] == pytest.approx(2.25, abs=1e-14)
        assert s.placement == PLACEMENTS[("point", "shape")]


def _trilinear(p, c):
    x, y, z = p.T
    return c[0] + c[1] * x + c[2] * y + c[3] * z + c[4] * x * y + c[5] * y * z + c[6] * x * z + c[7] * x * y * z


def test_a_trilinear_field_is_exact_in_a_box_hexahedron_and_a_linear_one_in_a_general_one():
    rng = np.random.default_rng(0)
    c = rng.normal(size=8)
    box = HEX * [2.0, 0.5, 1.5] + [0.3, -1.0, 2.0]  # axis-aligned box: x, y, z each linear in r, s, t
    xi = rng.uniform(0, 1, (200, 3))
    pos = shape_functions("hexahedron", xi) @ box
    got, _ = _sample(box, [("hexahedron", [ROTATED])], _trilinear(box, c), pos)
    np.testing.assert_allclose(got, _trilinear(pos, c), rtol=0, atol=1e-12)
    # a general hexahedron (non-planar faces: a trilinear map): a field linear in x, y, z is exact, and
    # any nodal values give sum N_j(xi) v_j at the point x(xi)
    general = HEX + 0.15 * rng.standard_normal((8, 3))
    pos = shape_functions("hexahedron", xi) @ general
    v = rng.normal(size=8)
    got, s = _sample(general, [("hexahedron", [range(8)])], v, pos)
    assert not s.outside.any()
    np.testing.assert_allclose(got, shape_functions("hexahedron", xi) @ v, rtol=0, atol=1e-12)
    lin = general @ [1.0, -2.0, 0.5] + 3.0
    got, _ = _sample(general, [("hexahedron", [range(8)])], lin, pos)
    np.testing.assert_allclose(got, pos @ [1.0, -2.0, 0.5] + 3.0, rtol=0, atol=1e-12)


def test_linear_in_the_triangle_times_linear_along_the_extrusion_is_exact_in_a_wedge():
    tri = np.array([[0.0, 0.0], [2.0, 0.3], [0.4, 1.5]])
    nodes = np.vstack([np.c_[tri, np.zeros(3)], np.c_[tri, np.full(3, 1.2)]])

    def f(p):
        x, y, z = p.T
        return (1 + x - 2 * y) * (0.5 + 3 * z)  # (linear in the triangle) x (linear in z): holds xz, yz terms

    rng = np.random.default_rng(1)
    rs = rng.dirichlet([1, 1, 1], 100)[:, 1:]
    xi = np.c_[rs, rng.uniform(0, 1, 100)]
    pos = shape_functions("wedge", xi) @ nodes
    got, s = _sample(nodes, [("wedge", [range(6)])], f(nodes), pos)
    np.testing.assert_allclose(got, f(pos), rtol=0, atol=1e-12)
    assert s.placement == PLACEMENTS[("point", "shape")]


def test_a_linear_field_is_exact_in_a_pyramid_and_its_apex_is_its_apex_value():
    rng = np.random.default_rng(2)
    base = np.array([(0, 0, 0), (1.2, 0.1, 0), (1.0, 1.1, 0.2), (-0.1, 0.9, 0)], float)  # a non-planar base
    nodes = np.vstack([base, [0.5, 0.4, 1.3]])
    xi = rng.uniform(0, 1, (200, 3)) * [1, 1, 0.98]
    pos = shape_functions("pyramid", xi) @ nodes
    lin = nodes @ [0.7, -1.1, 2.0] + 0.3
    got, s = _sample(nodes, [("pyramid", [range(5)])], lin, np.vstack([pos, nodes[4]]))
    assert not s.outside.any() and s.placement == PLACEMENTS[("point", "shape")]  # no receptor left to tetrahedra
    np.testing.assert_allclose(got[:-1], pos @ [0.7, -1.1, 2.0] + 0.3, rtol=0, atol=1e-12)
    assert got[-1] == pytest.approx(lin[4], abs=1e-12)
    v = rng.normal(size=5)  # any values: VTK's pyramid interpolant at x(xi)
    got, _ = _sample(nodes, [("pyramid", [range(5)])], v, pos)
    np.testing.assert_allclose(got, shape_functions("pyramid", xi) @ v, rtol=0, atol=1e-10)


def test_newton_reaches_a_pyramids_apex_where_its_map_is_singular():
    nodes = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 0.5, 1)], float)
    xi, ok = natural_coordinates("pyramid", nodes[4:], nodes[None])
    assert ok.all() and xi[0, 2] == pytest.approx(1.0, abs=1e-12)


def test_a_mixed_mesh_reproduces_a_linear_field_and_cell_data_use_the_shapes_too():
    # a hexahedron with a wedge and a pyramid on its faces, tetrahedra beside: a linear field is exact everywhere
    pts = np.vstack([HEX, [(2, 0, 0), (2, 0, 1)], [(0.5, 0.5, -1)], [(0.5, 2, 0.5)]])
    blocks = [("hexahedron", [range(8)]), ("wedge", [[1, 8, 2, 5, 9, 6]]), ("pyramid", [[3, 2, 1, 0, 10]]),
              ("tetra", [[3, 2, 6, 11]])]
    lin = pts @ [1.0, 2.0, -0.5] + 1.0
    rng = np.random.default_rng(3)
    pos = np.vstack([shape_functions("hexahedron", rng.uniform(0, 1, (30, 3))) @ HEX,
                     shape_functions("wedge", np.c_[rng.dirichlet([1, 1, 1], 30)[:, 1:], rng.uniform(0, 1, 30)])
                     @ pts[[1, 8, 2, 5, 9, 6]],
                     shape_functions("pyramid", rng.uniform(0, 1, (30, 3)) * [1, 1, 0.95]) @ pts[[3, 2, 1, 0, 10]]])
    got, s = _sample(pts, blocks, lin, pos)
    assert not s.outside.any()
    np.testing.assert_allclose(got, pos @ [1.0, 2.0, -0.5] + 1.0, rtol=0, atol=1e-12)
    # cell data: averaged to the nodes, then each cell's own functions: at the hexahedron's centre the mean
    # of its 8 nodes' averages (its split's tetrahedra gave the mean of nodes 0 and 6)
    from afferent.sampling import node_average

    cell_values = np.array([1.0, 0.0, 5.0, 2.0])
    got, s = _sample(pts, blocks, cell_values, [[0.5, 0.5, 0.5]], location="cell")
    assert s.placement == PLACEMENTS[("cell", "shape")]
    cells = cells_from_meshio([_Block(t, c) for t, c in blocks], "test")
    nodal = node_average(cells, pts, len(pts)) @ cell_values
    assert got[0] == pytest.approx(nodal[:8].mean(), rel=1e-14)
    assert abs(got[0] - (nodal[0] + nodal[6]) / 2) > 0.05


def test_receptors_all_outside_a_hexahedral_mesh_are_nan_not_an_index_error():
    # the shape-function step took the containing cell of every receptor, inside or not: with none inside it
    # indexed an empty array (IndexError, exit 1) - found by test_figure_process's all-outside scene
    got, s = _sample(HEX, [("hexahedron", [list(range(8))])], np.arange(8.0), [[0.5, 0.5, 9.0], [3, 3, 3]])
    assert np.isnan(got).all() and s.outside.all()
