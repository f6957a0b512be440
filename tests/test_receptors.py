"""Receptor layouts: the CSV reader, section grouping, the ridge/papilla grid, papilla tips on a mesh.

The papilla-tip tests build a small structured hexahedral skin block in code (meshio-style
helpers): three material layers, and on the epidermis/dermis interface smooth bumps whose
apexes sit on mesh nodes at known (x, z). The tips found must be exactly those nodes.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest

from afferent.exceptions import AfferentWarning, SEDFormatError, UnitError
from afferent.field import Cells
from afferent.io._cell_blocks import cells_from_meshio
from afferent.receptors import (
    ReceptorLayout,
    grid_layout,
    group_coordinates,
    interface_nodes,
    interface_tips,
    read_receptors,
    tips_from_export,
)

from conftest import hex_box

PITCH_X, PITCH_Z = 0.44e-3, 0.22e-3  # m, docs/method.md, "1. The FE skin model"


# --------------------------------------------------------------------------------------
# read_receptors
# --------------------------------------------------------------------------------------
def write(tmp_path, text, name="receptors.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_read_receptors_mm_file(tmp_path):
    path = write(
        tmp_path,
        "# papilla tips, mm\nid,x,y,z\n7,0.6813,2.4517,0.2371\n8,0.6813,2.4517,0.4571\n9,1.1213,2.4517,0.2371\n",
    )
    layout = read_receptors(path, length_unit="mm")
    # one float multiplication by 1e-3 per coordinate
    np.testing.assert_allclose(
        layout.positions,
        np.array([[0.6813, 2.4517, 0.2371], [0.6813, 2.4517, 0.4571], [1.1213, 2.4517, 0.2371]]) * 1e-3,
        rtol=1e-15,
    )
    assert layout.ids.tolist() == ["7", "8", "9"]
    assert layout.longitudinal.tolist() == [0, 0, 1]
    assert layout.cross.tolist() == [0, 1, 0]


def test_read_receptors_missing_column_message(tmp_path):
    path = write(tmp_path, "id,x,y,depth\n1,0.1,0.2,0.3\n")
    expected = (
        f"Receptor file {str(path)!r} must have columns 'x', 'y', 'z'; missing 'z'. "
        "Found columns 'id', 'x', 'y', 'depth'."
    )
    with pytest.raises(SEDFormatError, match=re.escape(expected)):
        read_receptors(path, length_unit="mm")


def test_read_receptors_non_numeric_cell_message(tmp_path):
    path = write(tmp_path, "x,y,z\n0.1,0.2,0.3\n0.4,0.5,abc\n")
    expected = f"Receptor file {str(path)!r}: column 'z' must hold finite numbers; got 'abc' on data row 2 instead."
    with pytest.raises(SEDFormatError, match=re.escape(expected)):
        read_receptors(path, length_unit="mm")


def test_read_receptors_duplicate_ids(tmp_path):
    path = write(tmp_path, "id,x,y,z\nA,0.1,0.2,0.3\nB,0.4,0.2,0.3\nA,0.7,0.2,0.3\n")
    expected = f"Receptor file {str(path)!r}: Receptor ids must be unique; got 'A' more than once."
    with pytest.raises(SEDFormatError, match=re.escape(expected)):
        read_receptors(path, length_unit="mm")


def test_read_receptors_unit_is_required(tmp_path):
    path = write(tmp_path, "x,y,z\n0.1,0.2,0.3\n")
    with pytest.raises(UnitError, match=re.escape("'length_unit' must be a length unit")):
        read_receptors(path, length_unit="furlong")


# --------------------------------------------------------------------------------------
# group_coordinates and section labels
# --------------------------------------------------------------------------------------
def test_group_coordinates_tolerates_noise(rng):
    grid = 0.1371e-3 + np.arange(12) * PITCH_Z
    index = np.repeat(np.arange(12), 5)
    jittered = grid[index] + rng.uniform(-1e-6, 1e-6, index.size)  # 1 um noise on a 0.22 mm grid
    perm = rng.permutation(index.size)
    labels, centres = group_coordinates(jittered[perm])
    np.testing.assert_array_equal(labels, index[perm])
    # mean of 5 values jittered by at most 1 um
    np.testing.assert_allclose(centres, grid, rtol=0, atol=1e-6)


def test_layout_sections_from_noisy_grid(rng):
    exact = grid_layout(x_range=(0.0, 1.32e-3), z_range=(0.0, 0.88e-3), y=2.45e-3)
    noisy = exact.positions + rng.uniform(-1e-6, 1e-6, exact.positions.shape)
    layout = ReceptorLayout(noisy)
    np.testing.assert_array_equal(layout.longitudinal, exact.longitudinal)
    np.testing.assert_array_equal(layout.cross, exact.cross)


# --------------------------------------------------------------------------------------
# grid_layout
# --------------------------------------------------------------------------------------
def test_grid_layout_counts_positions_sections():
    layout = grid_layout(x_range=(0.1e-3, 1.5e-3), z_range=(-0.3e-3, 0.5e-3), y=2.45e-3)
    # x: floor(1.4 / 0.44) + 1 = 4 rows, z: floor(0.8 / 0.22) + 1 = 4 columns, both centred
    assert layout.n_receptors == 16
    xs = 0.8e-3 + (np.arange(4) - 1.5) * PITCH_X
    zs = 0.1e-3 + (np.arange(4) - 1.5) * PITCH_Z
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    np.testing.assert_allclose(layout.positions[:, 0], X.ravel(), rtol=0, atol=1e-18)  # round-off of x0 + i*p
    np.testing.assert_allclose(layout.positions[:, 2], Z.ravel(), rtol=0, atol=1e-18)
    np.testing.assert_array_equal(layout.positions[:, 1], 2.45e-3)
    assert layout.longitudinal.tolist() == np.repeat(np.arange(4), 4).tolist()
    assert layout.cross.tolist() == np.tile(np.arange(4), 4).tolist()
    assert layout.ids[:5].tolist() == ["L0C0", "L0C1", "L0C2", "L0C3", "L1C0"]
    np.testing.assert_allclose(layout.section_positions("longitudinal"), xs, rtol=1e-12)
    np.testing.assert_allclose(layout.section_positions("cross"), zs, rtol=0, atol=1e-15)


def test_grid_layout_range_ends_are_included():
    layout = grid_layout(x_range=(0.0, 0.88e-3), z_range=(0.0, 2.2e-3), y=0.0)
    assert layout.n_receptors == 3 * 11
    np.testing.assert_allclose(layout.positions[[0, -1]][:, [0, 2]], [[0.0, 0.0], [0.88e-3, 2.2e-3]], atol=1e-18)
    # zero-padded ids sort like the grid
    assert layout.ids[-1] == "L2C10" and layout.ids[1] == "L0C01"


def test_grid_layout_origin_fixes_the_phase():
    layout = grid_layout(x_range=(0.0, 1.0e-3), z_range=(0.0, 0.5e-3), y=1e-3, origin=(0.05e-3, -0.43e-3))
    # x = 0.05 + k 0.44 in [0, 1] mm -> 0.05, 0.49, 0.93; z = -0.43 + k 0.22 in [0, 0.5] -> 0.01, 0.23, 0.45
    np.testing.assert_allclose(np.unique(layout.positions[:, 0]), [0.05e-3, 0.49e-3, 0.93e-3], rtol=1e-12)
    np.testing.assert_allclose(np.unique(layout.positions[:, 2]), [0.01e-3, 0.23e-3, 0.45e-3], rtol=1e-9)
    assert layout.longitudinal.max() == 2 and layout.cross.min() == 0


def test_grid_layout_callable_surface():
    def tips_surface(x, z):  # a tilted, curved papilla-tip surface, heights in m
        return 2.45e-3 + 0.1 * x - 0.05 * z + 30.0 * (x - 1e-3) ** 2

    layout = grid_layout(x_range=(0.0, 2e-3), z_range=(0.0, 1e-3), y=tips_surface)
    x, y, z = layout.positions.T
    np.testing.assert_allclose(y, tips_surface(x, z), rtol=1e-15)
    assert len(np.unique(y)) > 10


def test_grid_layout_callable_must_return_one_height_per_point():
    with pytest.raises(ValueError, match=re.escape("'y' must return one height in m per grid point, an array of shape (6,); got shape (2,) instead.")):
        grid_layout(x_range=(0.0, 0.44e-3), z_range=(0.0, 0.44e-3), y=lambda x, z: np.zeros(2))


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"x_range": (1e-3, 0.0)}, ValueError, "'x_range' must be a pair (min, max) in m with min <= max; got (0.001, 0.0) instead."),
        ({"z_range": 3e-3}, TypeError, "'z_range' must be a pair (min, max) in m; got 0.003 instead."),
        ({"y": "top"}, TypeError, "'y' must be a height in m (a finite float) or a callable y(x, z) returning heights in m; got 'top' instead."),
        ({"pitch_x": 0.0}, ValueError, "'pitch_x' must be > 0 m; got 0.0 instead."),
        (
            {"origin": (0.1e-3, 0.0), "x_range": (0.2e-3, 0.3e-3)},
            ValueError,
            "'x_range' must contain at least one grid line x = 0.0001 + k * 0.00044 m (from 'origin' and 'pitch_x'); got (0.0002, 0.0003) m instead.",
        ),
        (
            {"x_range": (0.0, 4.0), "z_range": (0.0, 4.0)},
            ValueError,
            "Ranges and pitches are in m: pass 4e-3, not 4, for 4 mm.",
        ),
    ],
)
def test_grid_layout_errors(kwargs, error, message):
    args = {"x_range": (0.0, 1e-3), "z_range": (0.0, 1e-3), "y": 2.45e-3, **kwargs}
    with pytest.raises(error, match=re.escape(message)):
        grid_layout(**args)


def test_subset_keeps_labels():
    layout = grid_layout(x_range=(0.0, 1.32e-3), z_range=(0.0, 0.66e-3), y=2.45e-3)
    mask = (layout.longitudinal != 1) & (layout.cross >= 2)
    sub = layout.subset(mask)
    assert sub.n_receptors == 3 * 2
    np.testing.assert_array_equal(sub.longitudinal, layout.longitudinal[mask])
    np.testing.assert_array_equal(sub.cross, layout.cross[mask])
    assert sub.ids.tolist() == ["L0C2", "L0C3", "L2C2", "L2C3", "L3C2", "L3C3"]
    sec = sub.section_positions("longitudinal")
    assert np.isnan(sec[1])  # section 1 was removed; its label is not reused
    np.testing.assert_allclose(sec[[0, 2, 3]], [0.0, 0.88e-3, 1.32e-3], atol=1e-18)


# --------------------------------------------------------------------------------------
# interface_tips on a synthetic papillary skin block
# --------------------------------------------------------------------------------------
HX, HZ = 0.055, 0.0275          # mm: 8 elements per papilla pitch in x and in z
X_OFF, Z_OFF = 0.0137, 0.0093   # mm: non-terminating offsets
Y_LINES = np.array([0.0, 0.0913, 0.1931, 0.2877, 0.3791])  # mm; the interface is level 2
BUMP_H = 0.0517                 # mm: papilla height
HALF_X, HALF_Z = 0.11, 0.055    # mm: papilla half-footprint (2 elements each way)
N_TIP_X, N_TIP_Z = 3, 4


def bump(s):
    return np.where(np.abs(s) < 1.0, np.cos(0.5 * np.pi * s) ** 2, 0.0)


def papilla_block():
    """Hex block in mm; returns (points, hexes, layer, apex_nodes, cut_nodes).

    Papilla rows at x-grid index 4 + 8 i (i < N_TIP_X) and z-grid index 8 j - 1: row j = 0
    lies one element outside the block (z index -1), so the block's z = Z_OFF face cuts it;
    rows j = 1..N_TIP_Z are whole. Layers: 3 (subcutis) below level 1, 2 (dermis) between
    levels 1 and 2, 1 (epidermis) above the interface (level 2).
    """
    nx, ny, nz = 8 * N_TIP_X, len(Y_LINES) - 1, 8 * N_TIP_Z + 3
    _, hexes = hex_box(nx, ny, nz)  # connectivity only; node (i, j, k) = (i * (ny + 1) + j) * (nz + 1) + k
    I, J, K = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    x, z = X_OFF + I * HX, Z_OFF + K * HZ
    apex_x = X_OFF + (4 + 8 * np.arange(N_TIP_X)) * HX
    apex_z = Z_OFF + (8 * np.arange(N_TIP_Z + 1) - 1) * HZ
    relief = sum(bump((x - ax) / HALF_X) * bump((z - az) / HALF_Z) for ax in apex_x for az in apex_z)
    y = Y_LINES[J] + np.where(J == 2, BUMP_H * relief, 0.0)
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    nid = lambda i, j, k: (i * (ny + 1) + j) * (nz + 1) + k  # noqa: E731
    j_first = (hexes[:, 0] // (nz + 1)) % (ny + 1)
    layer = np.where(j_first < 1, 3, np.where(j_first < 2, 2, 1))
    apex = np.array([nid(4 + 8 * i, 2, 8 * j - 1) for i in range(N_TIP_X) for j in range(1, N_TIP_Z + 1)])
    cut = np.array([nid(4 + 8 * i, 2, 0) for i in range(N_TIP_X)])
    return points, hexes, layer, apex, cut


@pytest.fixture
def block():
    return papilla_block()


def test_synthetic_block_is_what_it_claims(block):
    points, hexes, layer, apex, cut = block
    np.testing.assert_allclose(points[apex, 1], Y_LINES[2] + BUMP_H, rtol=1e-15)
    np.testing.assert_allclose(points[cut, 1], Y_LINES[2] + 0.5 * BUMP_H, rtol=1e-15)  # bump(1/2) = 1/2
    assert set(np.unique(layer)) == {1, 2, 3}


def test_interface_nodes_are_the_shared_layer(block):
    points, hexes, layer, _, _ = block
    nodes = interface_nodes(points * 1e-3, hexes, layer, upper=1, lower=2)
    level = (np.arange(len(points)) // (8 * N_TIP_Z + 4)) % len(Y_LINES)
    np.testing.assert_array_equal(nodes, np.flatnonzero(level == 2))


def test_interface_tips_are_exactly_the_bump_apexes(block):
    points, hexes, layer, apex, _ = block
    tips = interface_tips(points * 1e-3, hexes, layer, upper=1, lower=2)
    np.testing.assert_array_equal(tips.positions, points[apex] * 1e-3)
    assert tips.longitudinal.tolist() == np.repeat(np.arange(N_TIP_X), N_TIP_Z).tolist()
    assert tips.cross.tolist() == np.tile(np.arange(N_TIP_Z), N_TIP_X).tolist()
    assert tips.ids[:2].tolist() == ["L0C0", "L0C1"]


def test_interface_tips_with_cells_object_match_connectivity(block):
    points, hexes, layer, apex, _ = block
    cells = cells_from_meshio([meshio.CellBlock("hexahedron", hexes)], "grid")
    assert isinstance(cells, Cells)
    tips = interface_tips(points * 1e-3, cells, layer, upper=1, lower=2)
    np.testing.assert_array_equal(tips.positions, points[apex] * 1e-3)


def test_interface_tips_keep_edge_adds_the_cut_papilla(block):
    points, hexes, layer, apex, cut = block
    tips = interface_tips(points * 1e-3, hexes, layer, upper=1, lower=2, keep_edge=True)
    expected = points[np.concatenate([apex, cut])] * 1e-3
    order = np.lexsort((expected[:, 2], expected[:, 0]))
    np.testing.assert_array_equal(tips.positions, expected[order])


def test_interface_tips_tolerate_coordinate_noise(block, rng):
    points, hexes, layer, apex, _ = block
    noisy = points * 1e-3 + rng.uniform(-0.5e-6, 0.5e-6, points.shape)  # 0.5 um jitter, below the 1 um default
    tips = interface_tips(noisy, hexes, layer, upper=1, lower=2)
    np.testing.assert_array_equal(tips.positions, noisy[apex])
    assert tips.longitudinal.tolist() == np.repeat(np.arange(N_TIP_X), N_TIP_Z).tolist()


def test_interface_tips_flat_topped_papilla_gives_one_tip(block):
    points, hexes, layer, apex, _ = block
    points = points.copy()
    twin = apex[0] + (len(Y_LINES)) * (8 * N_TIP_Z + 4)  # the node one element further in x
    points[twin, 1] = points[apex[0], 1]
    tips = interface_tips(points * 1e-3, hexes, layer, upper=1, lower=2)
    # ties are resolved towards smaller x: the apex itself is kept
    np.testing.assert_array_equal(tips.positions, points[apex] * 1e-3)


def test_interface_tips_ranges_select_tips(block):
    points, hexes, layer, apex, _ = block
    x_lo = (X_OFF + 4 * HX + 0.5 * 8 * HX) * 1e-3  # between the first and second papilla rows
    tips = interface_tips(points * 1e-3, hexes, layer, upper=1, lower=2, x_range=(x_lo, 1.0))
    np.testing.assert_array_equal(tips.positions, points[apex[N_TIP_Z:]] * 1e-3)
    assert tips.longitudinal.min() == 0  # sections are numbered within the selection


def test_interface_tips_duplicated_interface_nodes(block):
    """Layers tied with duplicated nodes (no shared node): copies within 'noise' are merged."""
    points, hexes, layer, apex, _ = block
    n = len(points)
    level = (np.arange(n) // (8 * N_TIP_Z + 4)) % len(Y_LINES)
    copy_of = np.flatnonzero(level == 2)
    new_index = np.arange(n)
    new_index[copy_of] = n + np.arange(copy_of.size)
    dup_points = np.vstack([points, points[copy_of] + 0.3e-4])  # 0.3e-4 mm = 0.03 um apart
    hexes2 = hexes.copy()
    upper = layer == 1
    hexes2[upper] = new_index[hexes[upper]]  # epidermis cells use the copies
    tips = interface_tips(dup_points * 1e-3, hexes2, layer, upper=1, lower=2)
    # the 'upper' (epidermis-side) copy of each apex is the one returned
    np.testing.assert_array_equal(tips.positions, dup_points[new_index[apex]] * 1e-3)


def test_interface_tips_flat_interface_has_no_tips():
    points, hexes = hex_box(8, 2, 8, size=(1.3, 0.7, 1.9))
    layer = np.where(points[hexes[:, 0], 1] < 0.3, 2, 1)
    expected = (
        "The interface between materials upper=1 and lower=2 must have papilla tips (highs rising >= 1e-05 m "
        "within pitch 0.00044 x 0.00022 m windows); got none on its 81 nodes, spanning x [0, 0.0013], "
        "y [0.00035, 0.00035], z [0, 0.0019] m, instead. Points must be in m."
    )
    with pytest.raises(ValueError, match=re.escape(expected)):
        interface_tips(points * 1e-3, hexes, layer, upper=1, lower=2)


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"upper": 4}, ValueError, "'upper' must be material id(s) present in 'cell_material'; got 4 instead. Found ids 1, 2, 3."),
        ({"lower": [2, 1]}, ValueError, "'upper' and 'lower' must be different materials; got upper=1, lower=[2, 1] instead."),
        ({"lower": 3}, ValueError, "Materials upper=1 and lower=3 must touch; got no node shared by their cells (nor any pair of nodes within noise = 1e-06 m) instead."),
        ({"upper": "epidermis"}, TypeError, "'upper' must be a material id (a number) or a list of them; got 'epidermis' instead."),
        ({"pitch_z": -0.22e-3}, ValueError, "'pitch_z' must be > 0 m; got -0.00022 instead."),
    ],
)
def test_interface_tips_errors(block, kwargs, error, message):
    points, hexes, layer, _, _ = block
    args = {"upper": 1, "lower": 2, **kwargs}
    with pytest.raises(error, match=re.escape(message)):
        interface_tips(points * 1e-3, hexes, layer, **args)


def test_interface_tips_material_shape_message(block):
    points, hexes, layer, _, _ = block
    expected = f"'cell_material' must have one id per FE cell, shape ({len(hexes)},); got shape ({len(hexes) - 1},) instead."
    with pytest.raises(ValueError, match=re.escape(expected)):
        interface_tips(points * 1e-3, hexes, layer[1:], upper=1, lower=2)


# --------------------------------------------------------------------------------------
# tips_from_export
# --------------------------------------------------------------------------------------
@pytest.fixture
def block_vtu(tmp_path, block):
    points, hexes, layer, _, _ = block
    path = tmp_path / "block.vtu"
    mesh = meshio.Mesh(points, [("hexahedron", hexes)], cell_data={"layer": [layer.astype(np.int32)]})
    meshio.write(path, mesh, binary=True, compression="zlib")
    return path


def test_tips_from_export_mm(block_vtu, block):
    points, _, _, apex, _ = block
    tips = tips_from_export(block_vtu, length_unit="mm", upper=1, lower=2)
    np.testing.assert_array_equal(tips.positions, points[apex] * 1e-3)  # mm -> m, one multiplication


def test_tips_from_export_missing_array(block_vtu):
    expected = (
        f"Export {str(block_vtu)!r} must have a cell array 'Layer' of material ids; found cell arrays 'layer' "
        "instead. Did you mean 'layer'?"
    )
    with pytest.raises(SEDFormatError, match=re.escape(expected)):
        tips_from_export(block_vtu, length_unit="mm", material_array="Layer", upper=1, lower=2)


def test_tips_from_export_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match=re.escape(f"SED file {str(tmp_path / 'no.vtu')!r} not found.")):
        tips_from_export(tmp_path / "no.vtu", length_unit="mm", upper=1, lower=2)


# --------------------------------------------------------------------------------------
# The bundled FE sample: the tips the FE generator placed
# --------------------------------------------------------------------------------------
def test_sample_block4_tips_match_generator(sample_sed_dir):
    """sample_sed/block4 (make_samples.py): receptors.csv lists the papilla-tip nodes at least one
    pitch from the side faces; the mesh also has whole papillae in the outer rows x = 0.24 and
    3.76 mm, so the comparison restricts x and z to the CSV's extent."""
    vtu = Path(sample_sed_dir) / "block4" / "indent_0p88mm.vtu"
    csv = Path(sample_sed_dir) / "block4" / "receptors.csv"
    if not (vtu.is_file() and csv.is_file()):
        pytest.skip("sample_sed/block4 not generated (python sample_sed/make_samples.py)")
    placed = read_receptors(csv, length_unit="mm")
    lo, hi = placed.positions.min(axis=0), placed.positions.max(axis=0)
    tips = tips_from_export(vtu, length_unit="mm", upper=1, lower=2, x_range=(lo[0], hi[0]), z_range=(lo[2], hi[2]))
    assert tips.n_receptors == placed.n_receptors
    order = np.lexsort((placed.positions[:, 2], placed.positions[:, 0]))
    # receptors.csv holds 10 significant digits in mm
    np.testing.assert_allclose(tips.positions, placed.positions[order], rtol=0, atol=1e-11)
    np.testing.assert_array_equal(tips.longitudinal, placed.longitudinal[order])
    np.testing.assert_array_equal(tips.cross, placed.cross[order])
    every = tips_from_export(vtu, length_unit="mm", upper=1, lower=2)
    assert every.n_receptors >= placed.n_receptors


@pytest.mark.parametrize("header", ["receptor_id", "Receptor ID", "ReceptorId", "site_id", "id"])
def test_common_receptor_id_spellings_are_read(tmp_path, header):
    path = tmp_path / "R.csv"
    path.write_text(f"{header},x,y,z\nm7,0,0,0\nm9,1,0,0\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every column used: no warning
        layout = read_receptors(path, length_unit="mm")
    assert list(layout.ids) == ["m7", "m9"] and layout.source == str(path)


def test_columns_afferent_does_not_use_are_named(tmp_path):
    path = tmp_path / "R.csv"
    path.write_text("receptor_id,x,y,z,depth_mm,afferent\nm7,0,0,0,1,3\nm9,1,0,0,1,3\n")
    with pytest.warns(AfferentWarning, match=re.escape(
            f"Receptor file {str(path)!r}: column(s) 'depth_mm', 'afferent' not used (afferent reads x, y, z, a receptor id "
            "such as 'id' or 'receptor_id', 'longitudinal' and 'cross'); receptor ids from 'receptor_id'.")):
        layout = read_receptors(path, length_unit="mm")
    assert list(layout.ids) == ["m7", "m9"]


def test_a_plain_receptor_csv_is_read_without_pandas(tmp_path):
    """Issue 23: importing pandas costs more than reading 119 rows. A plain table is read by
    _tables.TextTable (same layout, ids, sections and messages as through pandas, which still
    reads everything else); the bundled sample is read in a fresh process without importing it."""
    import subprocess
    import sys

    from afferent import _tables
    from afferent.receptors import read_receptors

    code = ("import sys; from afferent.receptors import read_receptors; "
            "l = read_receptors(sys.argv[1], length_unit='mm'); print(l.n_receptors, 'pandas' in sys.modules)")
    sample = Path(__file__).resolve().parents[1] / "sample_sed" / "block4" / "receptors.csv"
    out = subprocess.run([sys.executable, "-c", code, str(sample)], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["119", "False"]
    files = {
        "comma.csv": "# sites\nid, x, y, z, longitudinal\na1, 1.0, 2.0, 0.5, 3\nb2,1.5,2.0,0.5,4 # tip\n",
        "semicolon.csv": "Receptor ID;X;Y;Z\nr 1;1;2;3\nr 2;4;5;6\n",
        "tab.csv": "x\ty\tz\tcross\n1e-1\t2\t3\t7\n4\t5\t6\t8\n",
    }
    for name, text in files.items():
        path = tmp_path / name
        path.write_text(text)
        table, _ = _tables.read_table(path, what="Receptor file", expected="x, y, z", as_text=True, frame=False)
        assert isinstance(table, _tables.TextTable), name
        frame, _ = _tables.read_table(path, what="Receptor file", expected="x, y, z", as_text=True)
        assert [str(c) for c in frame.columns] == table.columns and len(frame) == len(table)
        for c in table.columns:
            assert frame[c].tolist() == table[c], (name, c)
        assert read_receptors(path, length_unit="mm").n_receptors == 2
    fast = read_receptors(tmp_path / "comma.csv", length_unit="mm")
    assert fast.ids.tolist() == ["a1", "b2"] and fast.longitudinal.tolist() == [3, 4]
    (tmp_path / "bad.csv").write_text("x,y,z\n1,2,3\n4,n/a,6\n")
    with pytest.raises(SEDFormatError, match=r"column 'y' must hold finite numbers; got 'n/a' on data row 2 instead\."):
        read_receptors(tmp_path / "bad.csv", length_unit="mm")
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbfx,y,z\n1,2,3\n")  # a byte-order mark (Excel) is not a name
    assert read_receptors(tmp_path / "bom.csv", length_unit="m").positions.tolist() == [[1.0, 2.0, 3.0]]
    (tmp_path / "quoted.csv").write_text('x,y,z\n"1",2,3\n')  # not plain: pandas reads it
    assert _tables._plain_table(str(tmp_path / "quoted.csv")) is None
    assert read_receptors(tmp_path / "quoted.csv", length_unit="m").positions.tolist() == [[1.0, 2.0, 3.0]]


@pytest.mark.parametrize("swap, flip, message", [
    ((0, 2, 1), False, r"must face up along y .*; got a mean normal along z \(90 degrees from y\) instead\. Export the model "
                       r"with y up"),
    ((0, 1, 2), True, r"Material upper=1 must lie above lower=2 in y .*; got mean heights -0\.0002876 m \(upper\) and "
                      r"-0\.0001437 m \(lower\) instead\. Either the ids are swapped"),
])
def test_a_model_that_is_not_y_up_is_refused_not_searched(block, swap, flip, message):
    """Before: z up gave 'tips' on the block's side face, y down the papillae's feet, with plausible SED and no word."""
    points, hexes, layer, _, _ = block
    pts = points[:, list(swap)] * 1e-3
    if flip:
        pts[:, 1] *= -1.0
        hexes = hexes[:, [0, 3, 2, 1, 4, 7, 6, 5]]  # keep the cells right-handed
    with pytest.raises(ValueError, match=message):
        interface_tips(pts, hexes, layer, upper=1, lower=2)


def test_a_tilted_interface_within_the_limit_is_searched(block):
    """A block turned 3 degrees about z still faces up: the check lets it through, its tips are found."""
    points, hexes, layer, apex, _ = block
    a = np.radians(3.0)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    tips = interface_tips(points @ rot.T * 1e-3, hexes, layer, upper=1, lower=2)
    assert tips.positions.shape[0] == apex.size
