"""Gmsh's parsed views (.pos) read by afferent's own parser (issue 36, item 3).

tests/data/gmsh/lists.pos (gmsh.view.addListData: scalar, vector, tensor lists on tetrahedra and
hexahedra, 2 steps, a point and a triangle left out) and block_views.pos (the four views of the
.msh files, on the block mesh, written as parsed views) were written by Gmsh 4.15.2 with
make_gmsh.py; reference_pos.npz and reference.npz hold what the script gave Gmsh: the reference.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import format_of, read_raw

from conftest import DATA_DIR

GMSH = DATA_DIR / "gmsh"
LISTS, BLOCK = GMSH / "lists.pos", GMSH / "block_views.pos"


def _load(name):
    with np.load(GMSH / name) as data:
        return {k: data[k] for k in data.files}


def _key(xyz) -> tuple:
    return tuple(np.round(np.asarray(xyz, float) * 1e6).astype(np.int64))


def test_pos_is_a_known_format():
    assert format_of("a/b.POS") == "pos"


def test_every_list_view_equals_what_the_script_gave_gmsh():
    ref, raw = _load("reference_pos.npz"), read_raw(LISTS)
    assert raw.format == "pos" and raw.times.tolist() == [0.0, 1.0]  # Gmsh's TIME{0,1}: list data has step indices
    assert raw.cells.n_cells == 8 and raw.points.shape == (6 * 4 + 2 * 8, 3)  # tetrahedra first, then hexahedra
    tets, hexes = slice(0, 24), slice(24, 40)
    for view, ncomp in (("sed_list", 1), ("displacement_list", 3), ("stress_list", 9)):
        point, cell = raw.arrays[view], raw.arrays[f"{view}@cell"]
        assert (point.location, cell.location) == ("point", "cell")
        for shape, rows, cells in (("S", tets, slice(0, 6)), ("H", hexes, slice(6, 8))):
            xyz, vals = ref[f"{view}/{shape}/xyz"], ref[f"{view}/{shape}/values"]  # (k, nn, 3), (k, steps, nn, ncomp)
            np.testing.assert_array_equal(raw.points[rows], xyz.reshape(-1, 3))
            want = vals.transpose(1, 0, 2, 3).reshape(2, -1, ncomp)
            got = point.values[:, rows].reshape(2, -1, ncomp)
            np.testing.assert_allclose(got, want, rtol=1e-12)
            np.testing.assert_allclose(cell.values[:, cells].reshape(2, -1, ncomp),
                                       vals.mean(axis=2).transpose(1, 0, 2), rtol=1e-12)
    assert any("1 SP, 1 ST element(s) left out" in n for n in raw.notes)


def test_views_on_a_mesh_written_as_parsed_views_equal_the_msh_reference():
    ref, raw = _load("reference.npz"), read_raw(BLOCK)
    assert sorted(raw.arrays) == sorted(f"{v}{s}" for v in ("SED", "displacement", "stress", "SED_nodal_elements")
                                        for s in ("", "@cell"))
    assert raw.times is None and raw.points.shape == (18 * 8 + 54 * 4, 3)  # Gmsh writes no TIME for model data
    node = {_key(x): k for k, x in enumerate(ref["node_xyz"])}
    at = np.array([node[_key(p)] for p in raw.points])
    np.testing.assert_allclose(raw.arrays["SED"].values, ref["node_sed"][:, at], rtol=1e-12)
    np.testing.assert_allclose(raw.arrays["displacement"].values, ref["node_displacement"][:, at], rtol=1e-12)
    # ElementData: the element's value at each of its nodes; by the element's centroid
    copy = {(_key(x), int(e)): k for k, (x, e) in enumerate(zip(ref["copy_xyz"], ref["copy_elem"]))}
    by_centroid = {_key(c): k for k, c in enumerate(ref["elem_centroid"])}
    n = [4] * 54 + [8] * 18  # tetrahedra first
    starts = np.cumsum([0] + n)
    elem = np.array([by_centroid[_key(raw.points[a:b].mean(axis=0))] for a, b in zip(starts[:-1], starts[1:])])
    np.testing.assert_allclose(raw.arrays["stress@cell"].values, ref["elem_stress"][:, elem], rtol=1e-12)
    np.testing.assert_allclose(raw.arrays["stress"].values, ref["elem_stress"][:, np.repeat(elem, n)], rtol=1e-12)
    rows = [copy[_key(p), int(e)] for p, e in zip(raw.points, np.repeat(elem, n))]
    np.testing.assert_allclose(raw.arrays["SED_nodal_elements"].values, ref["copy_sed"][:, rows], rtol=1e-12)


def test_a_pos_view_reads_like_the_same_msh_view_once_merged():
    """The parsed view's copies merge by the element-node rule to the nodes' values of the .msh's ElementNodeData."""
    kw = dict(length_unit="mm", sed_unit="kPa", sed_column="SED_nodal_elements")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pos, msh = read_sed(BLOCK, **kw), read_sed(GMSH / "block_v41_ascii.msh", **kw)
    assert pos.provenance.coincident["n_nodes"] == msh.provenance.coincident["n_nodes"] == 64
    order_p, order_m = np.lexsort(pos.points.T), np.lexsort(msh.points.T)
    np.testing.assert_allclose(pos.points[order_p], msh.points[order_m], rtol=1e-12)
    np.testing.assert_allclose(pos.sed[:, order_p], msh.sed[:, order_m], rtol=1e-12)


def test_info_and_sample_on_a_pos_file(tmp_path, capsys):
    assert main(["info", str(LISTS)]) == 0
    out = capsys.readouterr().out
    for name in ("sed_list", "displacement_list", "stress_list"):
        assert f"'{name}'" in out and f"'{name}@cell'" in out, out
    receptors = tmp_path / "receptors.csv"
    receptors.write_text("x,y,z\n0.2,0.3,0.4\n0.6,0.2,0.3\n0.2,0.3,1.2\n")  # in the hexahedra and the tetrahedra (mm)
    out_csv = tmp_path / "sed.csv"
    code = main(["sample", str(LISTS), "--receptors", str(receptors), "--length-unit", "mm", "--sed-unit", "kPa",
                 "--sed-column", "sed_list", "-o", str(out_csv)])
    err = capsys.readouterr().err
    assert code == 0, err and out_csv.exists()
    rows = [line.split(",") for line in out_csv.read_text().splitlines() if line and not line.startswith("#")]
    assert rows[0][-1] == "sed_pa" and len(rows) == 1 + 3 * 2
    sed = np.array([float(r[-1]) for r in rows[1:]]).reshape(2, 3)
    # the script's values: step 1 is twice step 0 less each element's index / 7 kPa (0..5 / 7): linear throughout
    assert np.all(sed > 0) and np.all((2 * sed[0] - sed[1] >= -1e-6) & (2 * sed[0] - sed[1] <= 5e3 / 7 + 1e-6))


def _bad(tmp_path, text: str, name: str = "bad.pos"):
    path = tmp_path / name
    path.write_text(text)
    return path


_TET = "0,0,0,1,0,0,0,1,0,0,0,1"


@pytest.mark.parametrize("text, match", [
    (f'View "a" {{ SS({_TET},9){{1,2,3,4}}; }};', r"view 'a', SS element 1: 13 coordinates; a tetra \(S\) has 4 nodes "
                                                   r"\(12 coordinates\)"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}}; SS({_TET}){{1,2,3}}; }};',
     r"view 'a', SS element 2: 3 values, not a multiple of 4 nodes x 1 component\(s\) \(4 a step\)"),
    (f'View "a" {{ VS({_TET}){{1,2,3,4}}; }};', r"view 'a', VS element 1: 4 values, not a multiple of 4 nodes x 3"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}}; SS({_TET}){{1,2,3,4,5,6,7,8}}; }};',
     r"view 'a', SS element 2: 2 step\(s\); its first SS element has 1"),
    (f'View "a" {{ TIME{{0,1}}; SS({_TET}){{1,2,3,4}}; }};', r"view 'a': TIME lists 2 time\(s\); its elements hold 1"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}}; VS({_TET}){{{",".join("1" * 12)}}}; }};',
     r"view 'a' mixes S, V values \(SS, VS\): afferent reads one kind"),
    (f'View "a" {{ SS2({_TET},{_TET[:17]}){{1}}; }};', r"view 'a': SS2 elements \(order 2\) are not read"),
    (f'View "a" {{ SS({_TET}){{1,Sin(2),3,4}}; }};', r"view 'a', SS values: expected numbers; got 'Sin\(2\)' instead"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}}; Plugin(Smooth).Run; }};', r"view 'a': unexpected at byte 49 \('Plugin"),
    (f'View "a" {{ SS({_TET}){{1,x,3,4}}; }};', r"view 'a', SS values: expected numbers; got 'x' instead"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}};', r"view 'a': the file ends inside the view \(truncated\?\)"),
    ('$PostFormat /* Gmsh 1.3, ascii */\n1.3 0 8\n$EndPostFormat\n',
     r"Gmsh's legacy post-processing format \(\$PostFormat, PostProcessing.Format 0 or 1\) is not read"),
    ("Point(1) = {0, 0, 0};", r"expected a view \(View \"name\" \{ ... \};\) at byte 0 .*not a Gmsh parsed .pos file"),
    ('View "a" { ST(0,0,0,1,0,0,0,1,0){1,2,3}; };', r"no view holds volume elements \(S, H, I, Y\) or points"),
    (f'View "a" {{ SS({_TET}){{1,2,3,4}}; }}; View "b" {{ SS({_TET.replace("1", "2")}){{1,2,3,4}}; }};',
     r"view 'b' is on other elements than view 'a' \(S: 1 vs 1\): afferent reads views over one mesh"),
])
def test_malformed_views_are_refused_naming_the_view_and_element_type(tmp_path, text, match):
    with pytest.raises(SEDFormatError, match=r"bad.pos'?: " + match):
        read_raw(_bad(tmp_path, text))


def test_comments_and_text_annotations_are_skipped(tmp_path):
    path = _bad(tmp_path, f'// a comment\nView "a" {{ /* here */ T2(10,20,0){{"a label"}};\nSS({_TET}){{1,2,3,4}}; }};\n')
    raw = read_raw(path)
    np.testing.assert_array_equal(raw.arrays["a"].values, [[1, 2, 3, 4]])
    assert any("1 text (T2, T3)" in n for n in raw.notes)


def test_a_pos_holding_an_msh_file_is_read_as_msh(tmp_path):
    path = tmp_path / "as.pos"
    path.write_bytes((GMSH / "block_v41_ascii.msh").read_bytes())
    assert read_raw(path).format == "msh"
