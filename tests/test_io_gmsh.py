"""Gmsh's own result files (.msh 2.2 and 4.1, ASCII and binary) read by afferent's own parser.

The files in tests/data/gmsh/ were written by Gmsh 4.15.2 (the PyPI wheel) with make_gmsh.py;
``reference.npz`` holds the values put in (per node, per element, per element node) with their
coordinates: the independent reference here. See tests/data/gmsh/README.md.
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError
from afferent.io import format_of, read_raw

from conftest import DATA_DIR

GMSH = DATA_DIR / "gmsh"
FILES = [GMSH / f"block_v{v}_{m}.msh" for v in ("22", "41") for m in ("ascii", "binary")]
NODAL = GMSH / "block_v41_nodal.msh"


@pytest.fixture(scope="module")
def ref():
    with np.load(GMSH / "reference.npz") as data:
        return {k: data[k] for k in data.files}


def _key(xyz) -> tuple:
    return tuple(np.round(np.asarray(xyz, float) * 1e6).astype(np.int64))


def _cell_points(cells) -> list[np.ndarray]:
    """The points of each cell (the union of its tetrahedra's corners: every node of a linear cell)."""
    order = np.argsort(cells.parent, kind="stable")
    tets, parent = cells.tetra[order], cells.parent[order]
    starts = np.searchsorted(parent, np.arange(cells.n_cells + 1))
    return [np.unique(tets[a:b]) for a, b in zip(starts[:-1], starts[1:])]


def _element_index(ref, raw) -> np.ndarray:
    """Each raw cell's index among the reference's volume elements (matched by centroid)."""
    by_centroid = {_key(c): k for k, c in enumerate(ref["elem_centroid"])}
    return np.array([by_centroid[_key(raw.points[p].mean(axis=0))] for p in _cell_points(raw.cells)])


@pytest.mark.parametrize("path", FILES + [NODAL], ids=lambda p: p.name)
def test_every_view_equals_what_gmsh_was_given(path, ref):
    raw = read_raw(path)
    assert raw.format == "msh" and np.allclose(raw.times, ref["times"])
    node = {_key(x): k for k, x in enumerate(ref["node_xyz"])}
    at = np.array([node[_key(p)] for p in raw.points])
    np.testing.assert_allclose(raw.arrays["SED"].values, ref["node_sed"][:, at], rtol=1e-14)
    elem = _element_index(ref, raw)
    np.testing.assert_allclose(raw.arrays["stress"].values, ref["elem_stress"][:, elem], rtol=1e-14)
    assert raw.arrays["stress"].location == "cell" and raw.arrays["stress"].shape == (2, 72, 9)
    np.testing.assert_array_equal(raw.arrays["material"].values[0], np.where(ref["elem_volume"][elem] > 0.1, 1, 2))
    if path == NODAL:
        assert raw.points.shape == (64, 3) and set(raw.arrays) == {"SED", "stress", "material"}
        return
    np.testing.assert_allclose(raw.arrays["displacement"].values, ref["node_displacement"][:, at], rtol=1e-14)
    copy = {(int(e), _key(x)): k for k, (e, x) in enumerate(zip(ref["copy_elem"], ref["copy_xyz"]))}
    points = _cell_points(raw.cells)
    assert raw.points.shape == (360, 3) and sum(p.size for p in points) == 360  # each element its own copies
    expected = np.empty((2, 360))
    for c, pts in enumerate(points):
        for p in pts:
            expected[:, p] = ref["copy_sed"][:, copy[(int(elem[c]), _key(raw.points[p]))]]
    np.testing.assert_allclose(raw.arrays["SED_nodal_elements"].values, expected, rtol=1e-14)


@pytest.mark.parametrize("path", FILES + [NODAL], ids=lambda p: p.name)
def test_info_lists_every_view_the_file_declares(path, capsys):
    names = set(re.findall(rb"\$(?:NodeData|ElementData|ElementNodeData)\r?\n\d+\r?\n\"([^\"]*)\"", path.read_bytes()))
    assert len(names) == (2 if path == NODAL else 4)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    for name in names:
        assert f"'{name.decode()}'" in out, out
    assert "time steps   2, t = 0.5 .. 1" in out


def test_element_node_data_is_merged_as_discontinuous_output(ref):
    """ElementNodeData: each element's own copies of its nodes, merged into the 64 nodes by the element-node rule
    (the mean of the copies, each element once); tests/test_element_node_rule.py compares every reader."""
    field = read_sed(FILES[3], sed_column="SED_nodal_elements", length_unit="mm", sed_unit="kPa")
    report = field.provenance.coincident
    assert report["n_points"] == 360 and report["n_nodes"] == 64 and report["n_copies_merged"] == 296
    assert report["max_relative"] > 0.01  # the copies really differ (5 % steps from element to element)
    node = {_key(x): k for k, x in enumerate(ref["node_xyz"])}
    total, count = np.zeros((2, 64)), np.zeros(64)
    for x, k in zip(ref["copy_xyz"], range(ref["copy_elem"].size)):
        total[:, node[_key(x)]] += ref["copy_sed"][:, k]
        count[node[_key(x)]] += 1
    at = np.array([node[_key(p * 1e3)] for p in field.points])
    np.testing.assert_allclose(field.sed, 1e3 * (total / count)[:, at], rtol=1e-12)
    np.testing.assert_allclose(field.times, [0.5, 1.0])


def test_node_data_of_a_discontinuous_file_reads_as_the_nodes_values(ref):
    field = read_sed(FILES[0], sed_column="SED", length_unit="mm", sed_unit="kPa")
    node = {_key(x): k for k, x in enumerate(ref["node_xyz"])}
    at = np.array([node[_key(p * 1e3)] for p in field.points])
    assert field.points.shape == (64, 3)
    np.testing.assert_allclose(field.sed, 1e3 * ref["node_sed"][:, at], rtol=1e-12)


def test_msh_is_a_known_format():
    assert format_of("a/b.MSH") == "msh"


def test_a_view_without_its_mesh_is_refused():
    with pytest.raises(SEDFormatError, match=r"sed_without_mesh.msh'?: \$Nodes: the file holds no \$Nodes section \(a "
                                             r"view saved without its mesh, Gmsh's PostProcessing.SaveMesh = 0\?\)"):
        read_raw(GMSH / "sed_without_mesh.msh")


def _edited(tmp_path, source, old: bytes, new: bytes, count: int = 1):
    data = source.read_bytes()
    assert old in data
    out = tmp_path / f"edited_{source.name}"
    out.write_bytes(data.replace(old, new, count))
    return out


def test_counts_larger_than_the_file_are_refused_before_allocating(tmp_path):
    # MSH 2.2 binary: 10^9 nodes announced (28 GB) in a 50 kB file
    bad = _edited(tmp_path, FILES[1], b"$Nodes\n64\n", b"$Nodes\n1000000000\n")
    with pytest.raises(SEDFormatError, match=r"\$Nodes: the nodes \(1,000,000,000 values\) take 28,000,000,000 bytes "
                                             r"where [\d,]+ are left in the file: truncated or corrupt; refused"):
        read_raw(bad)
    # MSH 2.2 ASCII: the same count against the numbers the section holds
    bad = _edited(tmp_path, FILES[0], b"$Nodes\n64\n", b"$Nodes\n1000000000\n")
    with pytest.raises(SEDFormatError, match=r"\$Nodes: 1,000,000,000 nodes announced \(4 numbers each\); the section "
                                             r"holds 256 numbers"):
        read_raw(bad)
    # MSH 4.1 binary: a data block announcing 2^31 - 1 entities
    data = FILES[3].read_bytes()
    at = data.index(b'"SED"\n1\n0.5\n4\n0\n1\n64\n')
    bad = tmp_path / "entities.msh"
    bad.write_bytes(data[:at] + data[at:].replace(b"\n64\n", b"\n2147483647\n", 1))
    with pytest.raises(SEDFormatError, match=r"\$NodeData: view 'SED' step 0 \(2,147,483,647 values\) take "
                                             r"25,769,803,764 bytes where"):
        read_raw(bad)


def test_malformed_sections_are_refused_naming_file_and_section(tmp_path):
    bad = _edited(tmp_path, FILES[2], b"\n0.5 0 0\n", b"\n0.5 zero 0\n")
    with pytest.raises(SEDFormatError, match=r"edited_block_v41_ascii.msh'?: \$Nodes: expected numbers; got 'zero'"):
        read_raw(bad)
    bad = _edited(tmp_path, FILES[2], b"4.1 0 8", b"4.0 0 8")
    with pytest.raises(SEDFormatError, match=r"\$MeshFormat: MSH version 4: afferent reads MSH 2.2 and 4.1"):
        read_raw(bad)
    data = FILES[0].read_bytes()
    at = data.index(b"$ElementNodeData")
    bad = tmp_path / "nine.msh"  # an element announcing 9 nodes: the counts no longer add up
    bad.write_bytes(data[:at] + re.sub(rb"\n(\d+) 8 ", rb"\n\1 9 ", data[at:], count=1))
    with pytest.raises(SEDFormatError, match=r"\$ElementNodeData: view 'SED_nodal_elements' step 0: "):
        read_raw(bad)
    with pytest.raises(SEDFormatError, match=r"not_gmsh.msh'?: \$Nodes: the file does not start with \$MeshFormat"):
        (tmp_path / "not_gmsh.msh").write_bytes(b"$Nodes\n1\n1 0 0 0\n$EndNodes\n")
        read_raw(tmp_path / "not_gmsh.msh")


def test_a_second_different_mesh_is_refused(tmp_path):
    data = FILES[2].read_bytes()
    second = data.index(b"$Nodes", data.index(b"$EndNodes"))
    bad = tmp_path / "two_meshes.msh"
    bad.write_bytes(data[:second] + data[second:].replace(b"\n1.5 1.5 1.5\n", b"\n1.5 1.5 1.6\n", 1))
    with pytest.raises(SEDFormatError, match=r"\$Nodes: a second, different mesh in the file"):
        read_raw(bad)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_every_truncation_is_read_or_refused_with_a_sentence(path, tmp_path):
    """Cut anywhere: either the views before the cut (a cut between sections) or a SEDFormatError, never another error."""
    data = path.read_bytes()
    cut = tmp_path / path.name
    refused = 0
    for n in range(7, len(data), 613):
        cut.write_bytes(data[:n])
        try:
            read_raw(cut)
        except SEDFormatError as err:
            refused += 1
            assert str(err).startswith(f"SED file {str(cut)!r}"), err
    assert refused > len(data) // 613 // 2


def test_a_surface_mesh_reads_as_points_and_its_element_node_views_are_named(tmp_path):
    text = ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n"
            "$Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n"
            '$NodeData\n1\n"SED"\n1\n0\n3\n0\n1\n3\n1 1.0\n2 2.0\n3 3.0\n$EndNodeData\n'
            '$ElementNodeData\n1\n"E"\n1\n0\n3\n0\n1\n1\n1 3 1 2 3\n$EndElementNodeData\n')
    (tmp_path / "flat.msh").write_text(text)
    raw = read_raw(tmp_path / "flat.msh")
    assert raw.cells is None and set(raw.arrays) == {"SED"}
    np.testing.assert_array_equal(raw.arrays["SED"].values, [[1.0, 2.0, 3.0]])
    assert "View 'E' (ElementNodeData) left out: the file has no volume elements." in raw.notes


def test_cli_reads_a_msh_file(tmp_path):
    shutil.copy(FILES[1], tmp_path / "b.msh")
    assert main(["info", str(tmp_path / "b.msh")]) == 0
