"""SA-I ridge bases and RA-I papilla tips on a ridged skin block of known geometry (interface_sites).

The block is built here on a structured lattice (mm): x across the fingerprint ridges, y up,
z along them. On the epidermis/dermis interface (y = Y_IF) sit, per ridge pitch 0.44 mm:

* an intermediate ridge projecting down into the dermis under each surface ridge: a trough
  with a trapezoid apex (flat bottom 2 lattice steps wide, flanks 2 steps each), depth DEPTH,
  running the block's whole length along z, at x lattice index 8 + 16 i;
* a row of dermal papillae beside it, half a ridge pitch away (x index 16 i), each a cos^2
  bump of height HEIGHT, at z index 2 + 8 j (the 3-D ridged model), or a papilla ridge
  even along z (the 2-D ridged model).

The outer papilla rows (x index 0 and 48) are cut by the block's faces. Every expected site is
a lattice node, so the finder must return exactly those nodes.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import meshio
import numpy as np
import pytest

from afferent.io import read_raw
from afferent.receptors import (
    grid_layout,
    interface_nodes,
    interface_sites,
    interface_tips,
    read_receptors,
    sites_from_export,
)

H = 0.0275                       # mm: lattice step in x and z (16 per ridge pitch, 8 per papilla pitch)
X_OFF, Z_OFF = 0.0113, 0.0071    # mm: non-terminating offsets
Y_LINES = np.array([0.0, 0.1, 0.3, 0.45, 0.6])  # mm; the interface is corner level 2
Y_IF, DEPTH, HEIGHT = 0.3, 0.08, 0.06          # mm
NX, NZ = 48, 36                  # lattice steps; 36 steps = 0.99 mm = 4.5 papilla pitches along z
RIDGES = 8 + 16 * np.arange(3)   # x index of the intermediate ridges (all interior)
PAPILLAE = 16 * np.arange(4)     # x index of the papilla rows: 0 and 48 are cut by the faces
ROWS_Z = 2 + 8 * np.arange(5)    # z index of the papillae, and of the sites along a ridge line


def trough(ix):
    """Depth profile of the intermediate ridges (0..1) at x lattice index ix: a trapezoid."""
    d = np.min(np.abs(np.asarray(ix, float)[..., None] - RIDGES), axis=-1)
    return np.clip((3.0 - d) / 2.0, 0.0, 1.0)  # 1 for d <= 1, 0 for d >= 3


def papillae(ix, kz, three_d: bool):
    """Papilla relief (0..1): cos^2 bumps 5 steps half-wide in x, 2 in z (3-D) or even along z (2-D)."""
    bump = lambda s: np.where(np.abs(s) < 1.0, np.cos(0.5 * np.pi * s) ** 2, 0.0)  # noqa: E731
    bx = sum(bump((ix - p) / 5.0) for p in PAPILLAE)
    if not three_d:
        return bx
    return bx * sum(bump((kz - r) / 2.0) for r in ROWS_Z)


def waffle(ix, kz):
    """The chapter-4 kind of 3-D interface (0 at the apex level, 1 on papilla tops): flat-topped papillae whose
    bases, between papillae along z, lie at the intermediate ridges' apex level, so that level is one connected
    waffle. Across x: apex |d| <= 1 step, flanks to 5, papilla top 6 steps (0.165 mm) wide; along z: top
    |dz| <= 1, flanks to 3, 2 steps of apex-level floor between papillae."""
    d = np.min(np.abs(np.asarray(ix, float)[..., None] - RIDGES), axis=-1)
    dz = np.min(np.abs(np.asarray(kz, float)[..., None] - ROWS_Z), axis=-1)
    return np.clip((d - 1.0) / 4.0, 0.0, 1.0) * np.clip((3.0 - dz) / 2.0, 0.0, 1.0)


def ridged_block(*, three_d=True, quadratic=False, ridges=True, chapter4=False):
    """(points mm, cells, layer, index(i, k) of the interface node at lattice x index i, z index k).

    Linear: 8-node hexahedra one lattice step wide. Quadratic: 20-node hexahedra two steps wide
    (their midside nodes are the odd lattice nodes; y gets mid-levels between Y_LINES). Without
    ``ridges`` the interface is a flat base with papilla bumps; ``chapter4``: the :func:`waffle` interface."""
    ys = Y_LINES if not quadratic else np.sort(np.r_[Y_LINES, 0.5 * (Y_LINES[1:] + Y_LINES[:-1])])
    j_if = 2 if not quadratic else 4
    ny = ys.size - 1
    I, J, K = np.meshgrid(np.arange(NX + 1), np.arange(ny + 1), np.arange(NZ + 1), indexing="ij")
    relief = np.where(J == j_if, HEIGHT * papillae(I, K, three_d) - DEPTH * ridges * trough(I), 0.0)
    if chapter4:
        relief = np.where(J == j_if, (HEIGHT + DEPTH) * waffle(I, K) - DEPTH, 0.0)
    points = np.column_stack([(X_OFF + I * H).ravel(), (ys[J] + relief).ravel(), (Z_OFF + K * H).ravel()])
    nid = lambda i, j, k: (i * (ny + 1) + j) * (NZ + 1) + k  # noqa: E731
    s = 2 if quadratic else 1
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    edges = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
    local = [tuple(s * c for c in corner) for corner in corners]
    if quadratic:  # VTK hexahedron20: corners, then the midpoints of the 12 edges in this order
        local += [tuple((a + b) // 2 for a, b in zip(local[e0], local[e1])) for e0, e1 in edges]
    cells, layer = [], []
    for i in range(0, NX, s):
        for j in range(0, ny, s):
            for k in range(0, NZ, s):
                cells.append([nid(i + a, j + b, k + c) for a, b, c in local])
                layer.append(1 if j >= j_if else 2 if j >= j_if // 2 else 3)
    return points, np.array(cells), np.array(layer), lambda i, k: nid(i, j_if, k)


def expected(index, xs, zs):
    return np.array([index(i, k) for i in xs for k in zs])


@pytest.fixture(scope="module")
def block3d():
    return ridged_block()


def test_block_is_what_it_claims(block3d):
    points, _, _, index = block3d
    np.testing.assert_allclose(points[expected(index, RIDGES, [0, 17, NZ]), 1], Y_IF - DEPTH, rtol=1e-15)
    np.testing.assert_allclose(points[expected(index, PAPILLAE, ROWS_Z), 1], Y_IF + HEIGHT, rtol=1e-15)
    # the trapezoid's flat bottom is 3 nodes wide, its flanks reach 2 more each side
    np.testing.assert_allclose(points[[index(7, 5), index(9, 5)], 1], Y_IF - DEPTH, rtol=1e-15)
    np.testing.assert_allclose(points[index(10, 5), 1], Y_IF - DEPTH / 2, rtol=1e-15)


def test_bases_are_the_intermediate_ridges_one_per_papilla_pitch(block3d):
    points, cells, layer, index = block3d
    bases = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="bases")
    np.testing.assert_array_equal(bases.positions, points[expected(index, RIDGES, ROWS_Z)] * 1e-3)
    assert bases.site == "SA-I"
    assert bases.longitudinal.tolist() == np.repeat(np.arange(3), 5).tolist()
    assert bases.ids[:2].tolist() == ["L0C0", "L0C1"]


def test_tips_beside_them_cut_papillae_dropped(block3d):
    points, cells, layer, index = block3d
    tips = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="tips")
    np.testing.assert_array_equal(tips.positions, points[expected(index, PAPILLAE[1:3], ROWS_Z)] * 1e-3)
    assert tips.site == "RA-I"
    same = interface_tips(points * 1e-3, cells, layer, upper=1, lower=2)
    np.testing.assert_array_equal(same.positions, tips.positions)
    every = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="tips", keep_edge=True)
    np.testing.assert_array_equal(every.positions, points[expected(index, PAPILLAE, ROWS_Z)] * 1e-3)


def test_two_d_ridged_block_gives_ridge_lines_of_sites():
    """Papillae even along z: tips, like bases, are ridge lines with one site per papilla pitch."""
    points, cells, layer, index = ridged_block(three_d=False)
    tips = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2)
    bases = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="bases")
    np.testing.assert_array_equal(tips.positions, points[expected(index, PAPILLAE[1:3], ROWS_Z)] * 1e-3)
    np.testing.assert_array_equal(bases.positions, points[expected(index, RIDGES, ROWS_Z)] * 1e-3)


def test_chapter4_waffle_bases_beside_each_papilla_only():
    """Apex level connected through the gaps between papillae: bases only where papillae flank the ridge."""
    points, cells, layer, index = ridged_block(chapter4=True)
    assert np.isclose(points[index(8, 6), 1], points[index(16, 6), 1])  # ridge and gap between papillae: one level
    bases = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="bases")
    tips = interface_sites(points * 1e-3, cells, layer, upper=1, lower=2)
    np.testing.assert_array_equal(bases.positions, points[expected(index, RIDGES, ROWS_Z)] * 1e-3)
    np.testing.assert_array_equal(tips.positions, points[expected(index, PAPILLAE[1:3], ROWS_Z)] * 1e-3)
    with pytest.raises(ValueError, match=re.escape("lie on flat stretches wider across x than max_flat = 0.0001 m "
                                                   "(the narrowest 0.000165 m, at y = 0.00036 m): a flat top, not "
                                                   "papilla tips.")):
        interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, max_flat=0.1e-3)


def test_jittered_coordinates_give_the_same_nodes(block3d, rng):
    points, cells, layer, index = block3d
    noisy = points * 1e-3 + rng.uniform(-0.4e-6, 0.4e-6, points.shape)  # below the 1 um default noise
    for kind, xs in (("bases", RIDGES), ("tips", PAPILLAE[1:3])):
        found = interface_sites(noisy, cells, layer, upper=1, lower=2, kind=kind)
        np.testing.assert_array_equal(found.positions, noisy[expected(index, xs, ROWS_Z)])


def test_quadratic_cells_from_an_export(tmp_path):
    """20-node bricks (as the study's chapter-4 model): read back from a VTU, midside nodes are interface nodes."""
    points, cells, layer, index = ridged_block(quadratic=True)
    path = tmp_path / "ridged_hex20.vtu"
    meshio.write(path, meshio.Mesh(points, [("hexahedron20", cells)], cell_data={"layer": [layer.astype(np.int32)]}))
    raw = read_raw(str(path))
    on_interface = interface_nodes(raw.points * 1e-3, raw.cells, raw.arrays["layer"].values[0], upper=1, lower=2)
    assert on_interface.size == 49 * 37 - 24 * 18  # every lattice node of the level but the face centres
    bases = sites_from_export(path, length_unit="mm", upper=1, lower=2, kind="bases")
    tips = sites_from_export(path, length_unit="mm", upper=1, lower=2, kind="tips")
    np.testing.assert_allclose(bases.positions, points[expected(index, RIDGES, ROWS_Z)] * 1e-3, rtol=0, atol=1e-15)
    np.testing.assert_allclose(tips.positions, points[expected(index, PAPILLAE[1:3], ROWS_Z)] * 1e-3, rtol=0, atol=1e-15)


def test_flat_base_is_refused_naming_file_materials_and_prominence(tmp_path):
    """A flat base with papilla bumps (the bundled sample's kind of interface) has no ridge bases."""
    flat, cells, layer, _ = ridged_block(ridges=False)
    path = tmp_path / "flat_base.vtu"
    meshio.write(path, meshio.Mesh(flat, [("hexahedron", cells)], cell_data={"layer": [layer.astype(np.int32)]}))
    message = (
        f"Export {str(path)!r}: The interface between materials upper=1 and lower=2 must have intermediate-ridge "
        "bases (lows sinking >= 1e-05 m within pitch 0.00044 x 0.00022 m windows); got none on its 1813 nodes, "
        "spanning x [1.13e-05, 0.001331], y [0.0003, 0.00036], z [7.1e-06, 0.0009971] m, instead. Its 1393 local "
        "lows lie on flat stretches wider across x than max_flat = 0.00011 m (the narrowest 0.000165 m, at "
        "y = 0.0003 m): a flat base, not intermediate-ridge bases. Points must be in m."
    )
    with pytest.raises(ValueError, match=re.escape(message)):
        sites_from_export(path, length_unit="mm", upper=1, lower=2, kind="bases")
    assert sites_from_export(path, length_unit="mm", upper=1, lower=2).n_receptors == 10  # its tips still there


def test_kind_is_checked(block3d):
    points, cells, layer, _ = block3d
    with pytest.raises(ValueError, match=re.escape("'kind' must be 'tips' or 'bases'; got 'base' instead.")):
        interface_sites(points * 1e-3, cells, layer, upper=1, lower=2, kind="base")
    with pytest.raises(ValueError, match=re.escape("'kind' must be 'tips' or 'bases'; got 'SA-I' instead.")):
        grid_layout(x_range=(0, 1e-3), z_range=(0, 1e-3), y=0.0, kind="SA-I")


def test_grid_layout_bases_lie_half_a_ridge_pitch_from_the_papilla_rows():
    tips = grid_layout(x_range=(0.0, 1.32e-3), z_range=(0.0, 0.44e-3), y=2.3e-3)
    bases = grid_layout(x_range=(0.0, 1.32e-3), z_range=(0.0, 0.44e-3), y=2.3e-3, kind="bases")
    assert tips.site == "RA-I" and bases.site == "SA-I"
    np.testing.assert_allclose(np.unique(tips.positions[:, 0]), [0.0, 0.44e-3, 0.88e-3, 1.32e-3], atol=1e-18)
    np.testing.assert_allclose(np.unique(bases.positions[:, 0]), [0.22e-3, 0.66e-3, 1.10e-3], atol=1e-18)
    np.testing.assert_array_equal(np.unique(bases.positions[:, 2]), np.unique(tips.positions[:, 2]))
    shifted = grid_layout(x_range=(0.0, 1.0e-3), z_range=(0.0, 0.5e-3), y=0.0, origin=(0.05e-3, 0.0), kind="bases")
    np.testing.assert_allclose(np.unique(shifted.positions[:, 0]), [0.27e-3, 0.71e-3], atol=1e-18)
    assert bases.subset(np.arange(2)).site == "SA-I"


# --------------------------------------------------------------------------------------
# The site kind through the CLI: afferent info --grid tips|bases
# --------------------------------------------------------------------------------------
def test_info_grid_says_the_site_kind_and_refuses_bases_on_a_flat_base(tmp_path, capsys):
    from afferent.cli import main

    path = tmp_path / "ridged.vtu"
    points, cells, layer, _ = ridged_block()
    meshio.write(path, meshio.Mesh(points, [("hexahedron", cells)], point_data={"SENER": points[:, 1] * 1e-4},
                                   cell_data={"layer": [layer.astype(np.int32)]}))
    unit = ["--length-unit", "mm", "--sed-unit", "MPa"]
    assert main(["info", str(path), "--grid", "bases", *unit]) == 0
    out = capsys.readouterr().out
    assert "receptor sites: 15 SA-I sites (intermediate-ridge bases, Merkel cells); x [0.2313, 1.111], " in out
    assert main(["info", str(path), "--grid", "tips", *unit]) == 0
    assert "receptor sites: 10 RA-I sites (dermal-papilla tips, Meissner corpuscles); x [0.4513, 0.8913], " \
        in capsys.readouterr().out
    flat, cells, layer, _ = ridged_block(ridges=False)
    meshio.write(path, meshio.Mesh(flat, [("hexahedron", cells)], point_data={"SENER": flat[:, 1] * 1e-4},
                                   cell_data={"layer": [layer.astype(np.int32)]}))
    assert main(["info", str(path), "--grid", "bases", *unit]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"afferent: error: Export {str(path)!r}: The interface between "
                                               "materials --upper 1 and --lower 2 must have intermediate-ridge bases")
    assert main(["info", str(path), "--grid", "base", *unit]) == 2
    assert "--grid must be 'tips', 'bases' or 'y=H'; got 'base' instead." in capsys.readouterr().err


# --------------------------------------------------------------------------------------
# A real FE export with intermediate ridges: the chapter-4 blocks (sample_sed/make_chapter4.py)
# --------------------------------------------------------------------------------------
CHAPTER4 = Path(__file__).resolve().parents[1] / "sample_sed" / "chapter4"
C4_CENTRE, C4_APEX_Y, C4_TIP_Y, C4_PITCH = 2.42, 2.35, 2.50, 0.22  # mm, sample_sed/README.md "Chapter 4"


@pytest.mark.parametrize("model", ["ridged3d", "ridged2d"])
def test_chapter4_export_sites_are_the_generators(model):
    """Every intermediate-ridge apex and papilla tip of the solved block is found, at the generator's positions
    (pitch_x 0.22 mm: twelve intermediate ridges under six fingerprints): bases on the ridges x = c + k 0.22 mm,
    tips on the papilla rows x = c + (k + 1/2) 0.22 mm (c = 2.42 mm, the block's centre), one site per 0.22 mm
    along z; on the 3-D block the tips are the pegs, z = c + (j + 1/2) 0.22 mm, and both site tables the
    chapter-4 scenes map (sa_sites.csv, ra_sites.csv) are among the sites found, exactly."""
    vtu = CHAPTER4 / model / "bar.vtu"
    if not vtu.is_file():
        pytest.skip(f"{vtu} not generated (python sample_sed/make_chapter4.py)")
    kw = dict(length_unit="mm", upper=1, lower=2, pitch_x=C4_PITCH * 1e-3)
    bases = sites_from_export(vtu, kind="bases", **kw)
    tips = sites_from_export(vtu, kind="tips", **kw)
    for found, y, offset in ((bases, C4_APEX_Y, 0.0), (tips, C4_TIP_Y, 0.5)):
        pos = found.positions * 1e3  # mm
        np.testing.assert_allclose(pos[:, 1], y, rtol=0, atol=1e-9)
        kx = (pos[:, 0] - C4_CENTRE) / C4_PITCH - offset
        np.testing.assert_allclose(kx, np.round(kx), rtol=0, atol=1e-6)  # on the ridge / papilla row lines
        z = np.unique(np.round(pos[:, 2], 6))
        np.testing.assert_allclose(np.diff(z), C4_PITCH, rtol=0, atol=1e-6)  # one site per papilla pitch along z
        if model == "ridged3d":
            kz = (pos[:, 2] - C4_CENTRE) / C4_PITCH - 0.5
            np.testing.assert_allclose(kz, np.round(kz), rtol=0, atol=1e-6)  # at the pegs
    for found, csv in ((bases, "sa_sites.csv"), (tips, "ra_sites.csv")):
        table = read_receptors(CHAPTER4 / model / csv, length_unit="mm").positions
        gap = np.min(np.linalg.norm(table[:, None, :] - found.positions[None, :, :], axis=2), axis=1)
        if model == "ridged3d":
            np.testing.assert_array_less(gap, 1e-12)  # every table site found exactly
        else:  # continuous ridges: the same x lines, the sites along z where the finder places them
            assert np.all(np.isin(np.round(table[:, 0], 9), np.round(found.positions[:, 0], 9)))
            assert gap.max() <= 0.5 * C4_PITCH * 1e-3 + 1e-12


def test_a_sweep_over_the_site_kind_records_it_per_task(tmp_path):
    """Sweeps inherit the site kind through the scene: receptors.grid = tips | bases, each task says which."""
    from afferent._sweep import sweep

    vtu = CHAPTER4 / "ridged3d" / "bar.vtu"
    if not vtu.is_file():
        pytest.skip(f"{vtu} not generated (python sample_sed/make_chapter4.py)")
    src = tmp_path / "s.toml"
    src.write_text(f'[export]\nfile = {str(vtu)!r}\nlength_unit = "mm"\nsed_unit = "MPa"\n[receptors]\ngrid = "tips"\npitch_x_mm = 0.22\n'
                   '[transduction]\nparams = "start"\n[outputs]\nwant = ["currents"]\n'
                   '[sweep]\n"receptors.grid" = ["tips", "bases"]\n')
    out = sweep(src, tmp_path / "out", scheduler="serial", use_cache=False)
    recs = [json.loads(line) for f in (tmp_path / "out" / "tasks").glob("*.jsonl") for line in f.read_text().splitlines()]
    sites = {r["params"]["receptors.grid"]: r["record"]["receptors"] for r in recs}
    assert sites["tips"]["site"] == "RA-I" and sites["tips"]["n_receptors_total"] == 14 * 14  # the crop's tips
    assert sites["bases"]["site"] == "SA-I" and sites["bases"]["n_receptors_total"] == 15 * 14
    assert set(out.table["receptors.grid"]) == {"tips", "bases"}


def test_no_bases_on_a_mesh_without_floors_is_a_sentence_not_numpys():
    """Found testing issue 33's input modes: on the packaged crop (no wide floors), 'bases' ended in numpy's
    'zero-size array to reduction operation minimum' (the mask of floors was tested by its size, not its content)."""
    import re
    from pathlib import Path

    from afferent.receptors import sites_from_export

    crop = Path(__file__).resolve().parents[1] / "afferent" / "data" / "sample" / "block4" / "indent_0p88mm.vtu"
    with pytest.raises(ValueError, match=re.escape("must have intermediate-ridge bases (lows sinking >= 1e-05 m "
                                                   "within pitch 0.00044 x 0.00022 m windows); got none on its ")):
        sites_from_export(crop, length_unit="mm", kind="bases", upper=1, lower=2)
