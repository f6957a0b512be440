"""One element-node rule for every reader (issue 36): a node's value is the mean of the values the elements
around it give it, each element once (afferent.io._coincident.element_node_mean; docs/fe-export.md,
"Discontinuous output and material interfaces").

Each reader is checked on a real file against the mean computed here from the file's own copies;
the Gmsh files (hexahedra of volume 0.125 beside tetrahedra of 0.0208 at z = 1) tell the rule from
the volume-weighted mean afferent used before for discontinuous output (3.0 % off it, either way,
at 16 of the 64 nodes there); code_aster's own ``_NOEU`` equals the rule on its ``_ELNO``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from afferent import read_sed
from afferent.io import _coincident, read_raw

from conftest import DATA_DIR

GMSH = DATA_DIR / "gmsh"


def _key(xyz) -> tuple:
    return tuple(np.round(np.asarray(xyz, float) * 1e6).astype(np.int64))


def _means(ref, weights=None):
    """Each node's mean of the element-node copies of reference.npz (weights per element: None, each once)."""
    node = {_key(x): k for k, x in enumerate(ref["node_xyz"])}
    w = np.ones(ref["elem_tags"].size) if weights is None else weights
    total, count = np.zeros((2, len(node))), np.zeros(len(node))
    for x, e, k in zip(ref["copy_xyz"], ref["copy_elem"], range(ref["copy_elem"].size)):
        total[:, node[_key(x)]] += w[e] * ref["copy_sed"][:, k]
        count[node[_key(x)]] += w[e]
    return node, total / count


@pytest.mark.parametrize("path", [GMSH / "block_v22_binary.msh", GMSH / "block_views.pos"], ids=lambda p: p.name)
def test_gmsh_element_node_views_merge_by_the_rule_not_by_volume(path):
    with np.load(GMSH / "reference.npz") as data:
        ref = {k: data[k] for k in data.files}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        field = read_sed(path, sed_column="SED_nodal_elements", length_unit="mm", sed_unit="kPa")
    node, mean = _means(ref)
    _, by_volume = _means(ref, ref["elem_volume"])
    at = np.array([node[_key(p * 1e3)] for p in field.points])
    np.testing.assert_allclose(field.sed, 1e3 * mean[:, at], rtol=1e-12)
    # the two rules differ on this mesh (at z = 1, where hexahedra meet 6x smaller tetrahedra): the test tells them apart
    assert np.abs(by_volume / mean - 1).max() > 0.01
    assert field.provenance.coincident["rule"] == _coincident.RULE


def test_discontinuous_vtu_merges_by_the_rule():
    """deal.II's DataOut (one patch per cell): each node the plain mean of its copies in the file."""
    path = DATA_DIR / "dealii" / "indent_block.vtu"
    raw = read_raw(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        field = read_sed(path, length_unit="mm", sed_unit="MPa")
    groups: dict = {}
    for k, p in enumerate(raw.points):
        groups.setdefault(_key(p * 1e-3), []).append(k)
    sed = raw.arrays["sed"].values[-1]
    want = np.array([sed[groups[_key(p)]].mean() for p in field.points]) * 1e6
    np.testing.assert_allclose(field.sed[-1], want, rtol=1e-9, atol=1e-12 * np.abs(want).max())


def test_every_reader_of_element_node_values_goes_through_the_one_function(monkeypatch):
    """MED _ELNO, FEBio per-element-node variables, and the merge of Gmsh's (and any discontinuous) copies:
    each calls afferent.io._coincident.element_node_operator, the rule's one implementation."""
    calls = []
    real = _coincident.element_node_operator

    def spy(*args, **kwargs):
        calls.append(args[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(_coincident, "element_node_operator", spy)
    med = read_raw(DATA_DIR / "med" / "block_hexa.rmed")
    assert calls, "the MED reader did not use the element-node rule"
    # code_aster's own ENEL_NOEU (built by code_aster from ENEL_ELNO) is what the rule gives
    np.testing.assert_allclose(med.arrays["ENEL_ELNO"].values, med.arrays["ENEL_NOEU"].values, rtol=1e-12, atol=1e-12)
    calls.clear()
    read_raw(DATA_DIR / "febio" / "block_hex8.xplt").arrays["nodal stress"].values
    assert calls, "the FEBio reader did not use the element-node rule"
    calls.clear()
    _coincident._LAST.clear()  # no remembered search: the merge runs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read_sed(GMSH / "block_views.pos", sed_column="SED_nodal_elements", length_unit="mm", sed_unit="kPa")
    assert 64 in calls, "the merge of coincident copies did not use the element-node rule"


def test_element_node_mean_skips_missing_copies_and_leaves_uncovered_nodes_nan():
    got = _coincident.element_node_mean(np.array([0, 1, 1, 2]), np.array([[1.0], [2.0], [np.nan], [4.0]]), 4)
    np.testing.assert_array_equal(got[:3, 0], [1.0, 2.0, 4.0])
    assert np.isnan(got[3, 0])
