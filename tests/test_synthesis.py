"""Stage 4: receptor currents -> afferent currents (afferent.synthesis)."""

from __future__ import annotations

import re
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import sparse

from afferent._csr import CSRWeights
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.receptors import ReceptorLayout
from afferent.synthesis import AfferentCurrent, Branching, synthesize
from afferent.transduction import STUDY_PARAMS, transduce

NX, NZ = 5, 4
X0 = 1e-5 / 3  # non-terminating offsets so rounding shows up


@pytest.fixture
def layout():
    x, z = np.meshgrid(np.arange(NX) * 4.4e-4 + X0, np.arange(NZ) * 2.2e-4 + X0, indexing="ij")
    y = 7.5e-4 + 1e-6 * np.random.default_rng(3).standard_normal(NX * NZ)  # papilla-tip depth jitter
    return ReceptorLayout(np.column_stack([x.ravel(), y, z.ravel()]))


@pytest.fixture
def current(layout):
    rng = np.random.default_rng(11)
    sed = rng.uniform(0.0, 190.0, size=(3, layout.n_receptors))
    return transduce(SimpleNamespace(values=sed, times=np.array([0.0, 0.05, 0.1]), layout=layout), STUDY_PARAMS["start"])


# --------------------------------------------------------------------- sections
def test_longitudinal_groups_by_x(layout):
    b = Branching.longitudinal(layout)
    assert (b.kind, b.axis, b.n_afferents, b.n_receptors) == ("longitudinal", "x", NX, NX * NZ)
    np.testing.assert_allclose(b.positions, np.arange(NX) * 4.4e-4 + X0, rtol=1e-15)
    assert b.afferent_ids.tolist() == [f"L{i}" for i in range(NX)]
    assert b.receptor_counts.tolist() == [NZ] * NX
    assert b.is_partition and b.unassigned.size == 0
    assert isinstance(b.weights, CSRWeights) and not b.weights.data.flags.writeable
    assert not b.weights.indices.flags.writeable and not b.weights.indptr.flags.writeable


def test_cross_groups_by_z(layout):
    b = Branching.cross(layout)
    assert (b.kind, b.axis, b.n_afferents) == ("cross", "z", NZ)
    np.testing.assert_allclose(b.positions, np.arange(NZ) * 2.2e-4 + X0, rtol=1e-15)
    assert b.receptor_counts.tolist() == [NX] * NZ and b.is_partition


def test_synthesize_is_the_sum_over_each_section(layout, current):
    out = synthesize(current, Branching.longitudinal(layout))
    x = layout.positions[:, 0]
    for k, xk in enumerate(np.unique(x)):
        # Closed form: the afferent current is the plain sum of its receptors' currents.
        np.testing.assert_allclose(out.values[:, k], current.values[:, x == xk].sum(axis=1), rtol=1e-15)


def shuffled_map(layout, seed=5):
    """A one-receptor-one-afferent map with arbitrary names and shuffled rows."""
    rng = np.random.default_rng(seed)
    groups = rng.integers(0, 6, size=layout.n_receptors)
    df = pd.DataFrame({"receptor": layout.ids, "afferent": [f"a{g}" for g in groups]})
    return df.iloc[rng.permutation(len(df))].reset_index(drop=True)


@pytest.mark.parametrize("make", [Branching.longitudinal, Branching.cross,
                                  lambda lay: Branching.from_map(shuffled_map(lay), lay)],
                         ids=["longitudinal", "cross", "map"])
def test_partitions_conserve_total_current(layout, current, make):
    b = make(layout)
    assert b.is_partition
    out = synthesize(current, b)
    # Summation order differs (per afferent, then over afferents): rounding only.
    np.testing.assert_allclose(out.values.sum(axis=1), current.values.sum(axis=1), rtol=1e-14)
    np.testing.assert_array_equal(out.times, current.times)


def test_empty_section_after_subset_gives_no_nan(layout, current):
    # Drop the middle longitudinal section: labels become non-contiguous.
    keep = layout.longitudinal != 2
    sub = layout.subset(keep)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b = Branching.longitudinal(sub)
    assert b.afferent_ids.tolist() == ["L0", "L1", "L3", "L4"]
    assert np.all(np.isfinite(b.positions))
    out = synthesize(current.values[:, keep], b)
    np.testing.assert_allclose(out.values.sum(axis=1), current.values[:, keep].sum(axis=1), rtol=1e-14)


def test_one_receptor_one_time():
    lay = ReceptorLayout(np.array([[1e-3 / 3, 7.5e-4, 0.0]]))
    out = synthesize(np.array([[2.5e-9]]), Branching.cross(lay))
    assert out.values.shape == (1, 1) and out.values[0, 0] == 2.5e-9 and out.times is None


# --------------------------------------------------------------------- from_map
def test_from_map_csv_with_weights_and_shared_receptor(layout, tmp_path):
    path = tmp_path / "map.csv"
    path.write_text("# test map\nReceptor,Afferent,Weight\n0,A,1.0\n1,A,0.5\n1,B,0.5\n5,B,2\n"
                    + "".join(f"{i},C,1\n" for i in range(2, 20) if i != 5))
    b = Branching.from_map(path, layout)
    assert b.kind == "map" and b.axis == "x"
    assert b.afferent_counts[1] == 2 and not b.is_partition
    cur = np.arange(1.0, 21.0)[None, :] * 1e-9
    out = synthesize(cur, b)
    got = dict(zip(out.afferent_ids.tolist(), out.values[0].tolist()))
    np.testing.assert_allclose(
        [got["A"], got["B"], got["C"]],
        [(1 + 0.5 * 2) * 1e-9, (0.5 * 2 + 2 * 6) * 1e-9, (sum(range(3, 21)) - 6) * 1e-9],
        rtol=1e-14,
    )
    # positions: unweighted mean x of each afferent's receptors, afferents sorted by it.
    x = layout.positions[:, 0]
    pos = dict(zip(out.afferent_ids.tolist(), out.positions.tolist()))
    np.testing.assert_allclose(pos["B"], (x[1] + x[5]) / 2, rtol=1e-15)
    assert np.all(np.diff(b.positions) >= 0)


def test_from_map_round_trip_and_axis(layout):
    b = Branching.cross(layout)
    again = Branching.from_map(b.to_dataframe(), layout, axis="z")
    assert np.array_equal(again.weights.toarray(), b.weights.toarray())
    np.testing.assert_allclose(again.positions, b.positions, rtol=1e-15)
    assert again.afferent_ids.tolist() == b.afferent_ids.tolist()


def test_from_map_unknown_receptors_are_named(layout):
    df = pd.DataFrame({"receptor": ["0", "99", "r7", "99"], "afferent": ["A", "A", "B", "B"]})
    msg = "Branching map: 2 receptor id(s) are not in the layout: '99', 'r7'. Layout ids are '0', '1', '2', ...."
    with pytest.raises(ValueError, match=re.escape(msg)):
        Branching.from_map(df, layout)


def test_from_map_reports_missing_receptors(layout):
    df = pd.DataFrame({"receptor": range(14), "afferent": ["A"] * 7 + ["B"] * 7})
    msg = "6 of 20 receptors are not in the branching map and feed no afferent: '14', '15', '16', '17', '18', ...."
    with pytest.warns(AfferentWarning, match=re.escape(msg)):
        b = Branching.from_map(df, layout)
    assert b.unassigned.tolist() == list(range(14, 20))


def test_from_map_errors(layout, tmp_path):
    with pytest.raises(ValueError, match=re.escape("Branching map: receptor '3' is listed twice for afferent 'A'.")):
        Branching.from_map(pd.DataFrame({"receptor": [3, 3], "afferent": ["A", "A"]}), layout)
    with pytest.raises(ValueError, match=re.escape(
        "Branching map: 'weight' must be a finite number >= 0 (dimensionless); got -1 on data row 2 instead."
    )):
        Branching.from_map(pd.DataFrame({"receptor": [1, 2], "afferent": ["A", "A"], "weight": [1, -1]}), layout)
    bad = tmp_path / "bad.csv"
    bad.write_text("receptor,fibre\n1,A\n")
    with pytest.raises(SEDFormatError, match=re.escape(
        f"Branching map {str(bad)!r} must have columns 'receptor' and 'afferent'; missing 'afferent'. "
        "Found columns 'receptor', 'fibre'."
    )):
        Branching.from_map(bad, layout)
    missing = tmp_path / "nope.csv"
    with pytest.raises(FileNotFoundError, match=re.escape(f"Branching map file {str(missing)!r} not found.")):
        Branching.from_map(missing, layout)
    with pytest.raises(ValueError, match=re.escape(
        "Invalid value for the 'axis' parameter. Allowed values are 'x' and 'z', but got 'y' instead."
    )):
        Branching.from_map(pd.DataFrame({"receptor": [1], "afferent": ["A"]}), layout, axis="y")


# --------------------------------------------------------------------- random
def test_random_is_reproducible_and_seed_dependent(layout):
    a = Branching.random(layout, 9, rng=42)
    b = Branching.random(layout, 9, rng=42)
    c = Branching.random(layout, 9, rng=43)
    assert np.array_equal(a.weights.toarray(), b.weights.toarray()) and np.array_equal(a.positions, b.positions)
    assert not np.array_equal(a.weights.toarray(), c.weights.toarray())
    g = Branching.random(layout, 9, rng=np.random.default_rng(42))
    assert np.array_equal(a.weights.toarray(), g.weights.toarray())


def test_random_fields_are_compact_nearest_neighbour_patches(layout):
    k = 9
    b = Branching.random(layout, k, rng=7)
    assert b.kind == "random" and b.n_afferents == round(layout.n_receptors / k)
    assert b.receptor_counts.tolist() == [k] * b.n_afferents
    plane = layout.positions[:, [0, 2]]
    for row in range(b.n_afferents):
        members = b.weights.indices[b.weights.indptr[row]:b.weights.indptr[row + 1]]
        # Some member (the seed) has these k receptors as its k nearest neighbours in the
        # skin plane: every receptor strictly closer than the farthest member is a member
        # (ties on the grid may go either way). 1e-12 m absorbs rounding of distances.
        def is_knn_of(m):
            dist = np.linalg.norm(plane - plane[m], axis=1)
            inside = np.flatnonzero(dist < dist[members].max() - 1e-12)
            return set(inside.tolist()) <= set(members.tolist())

        assert any(is_knn_of(m) for m in members), row
    np.testing.assert_allclose(
        b.positions, [layout.positions[b.weights.to_scipy()[[r]].indices, 0].mean() for r in range(b.n_afferents)], rtol=1e-15
    )


def test_random_options_and_errors(layout):
    b = Branching.random(layout, 17, rng=0, n_afferents=5, axis="z")
    assert b.n_afferents == 5 and b.axis == "z"
    assert not b.is_partition  # overlapping fields: receptors are shared
    with pytest.raises(ValueError, match=re.escape(
        "'receptors_per_afferent' must be between 1 and the number of receptors (20); got 21 instead."
    )):
        Branching.random(layout, 21)
    with pytest.raises(TypeError, match=re.escape("'receptors_per_afferent' must be an int; got 9.0 instead.")):
        Branching.random(layout, 9.0)
    with pytest.raises(ValueError, match=re.escape(
        "'n_afferents' must be between 1 and the number of receptors (20); got 0 instead."
    )):
        Branching.random(layout, 3, n_afferents=0)
    with pytest.raises(TypeError, match=re.escape(
        "'rng' must be None, an int seed or a numpy.random.Generator; got 'seed' instead."
    )):
        Branching.random(layout, 3, rng="seed")


# --------------------------------------------------------------------- weights (afferent._csr)
def test_csr_weights_product_is_scipys_bit_for_bit():
    rng = np.random.default_rng(5)
    n_aff, n_rec, nnz = 40, 300, 2000
    rows, cols = rng.integers(0, n_aff - 3, nnz), rng.integers(0, n_rec, nnz)  # 3 empty rows at the end
    data = rng.lognormal(0.0, 1.0, nnz) * (rng.random(nnz) > 0.05)  # some stored zeros
    ref = sparse.csr_array((data, (rows, cols)), shape=(n_aff, n_rec))
    ref.sum_duplicates()
    ours = CSRWeights.from_coo(data, rows, cols, (n_aff, n_rec))
    assert np.array_equal(ours.indptr, ref.indptr) and np.array_equal(ours.indices, ref.indices)
    assert np.array_equal(ours.data, ref.data)  # repeated positions summed in scipy's order
    x = rng.normal(0.0, 1e-8, (500, n_rec))  # currents over (time, receptor), as synthesize multiplies them
    for operand in (x.T, np.ascontiguousarray(x.T), x[0], x[:, :7].T[:, 1]):
        if operand.shape[0] != n_rec:
            continue
        assert np.array_equal(ours @ operand, ref @ operand)
    assert np.array_equal(ours.toarray(), ref.toarray())
    assert (ours.to_scipy() != ref).nnz == 0
    lean = ours.eliminate_zeros()
    assert lean.nnz == int(np.count_nonzero(ref.data)) and np.array_equal(lean.toarray(), ref.toarray())
    assert np.array_equal(lean @ x.T, ref @ x.T)


def test_branching_takes_scipy_sparse_dense_or_csr_weights_alike():
    dense = np.array([[1.0, 0.0, 2.0], [0.0, 0.0, 0.5]])
    made = [Branching(w, [0.0, 1e-3], "x", "map", ["a", "b"])
            for w in (dense, sparse.csr_array(dense), sparse.coo_array(dense), CSRWeights.from_coo(
                [2.0, 1.0, 0.5, 0.0], [0, 0, 1, 1], [2, 0, 2, 0], (2, 3)),
                      CSRWeights(np.array([2.0, 1.0, 0.5, 0.0]), np.array([2, 0, 2, 0]), np.array([0, 2, 4]), (2, 3)))]
    for b in made:
        assert isinstance(b.weights, CSRWeights) and b.weights.nnz == 3  # the stored 0 dropped
        assert b.weights.indices.tolist() == [0, 2, 2] and not b.weights.data.flags.writeable  # sorted, read-only
        assert np.array_equal(b.weights.toarray(), dense) and b.receptor_counts.tolist() == [2, 1]
    with pytest.raises(ValueError, match=re.escape(
        "'weights' must be a 2-D array of shape (n_afferents, n_receptors); got 3-D."
    )):
        Branching(np.ones((1, 2, 3)), [0.0], "x", "map", ["a"])


# --------------------------------------------------------------------- Branching validation
def test_branching_validation_messages():
    w = np.array([[1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match=re.escape(
        "'weights' must be finite and >= 0 (dimensionless); got -1.0 for afferent 1, receptor 1 instead."
    )):
        Branching(np.array([[1.0, 0.0], [0.0, -1.0]]), [0.0, 1e-3], "x", "map", ["a", "b"])
    with pytest.raises(ValueError, match=re.escape("Afferent ids must be unique; got 'a' more than once.")):
        Branching(w, [0.0, 1e-3], "x", "map", ["a", "a"])
    with pytest.raises(ValueError, match=re.escape(
        "'positions' must be finite, of shape (n_afferents,) = (2,), in m; got shape (3,) instead."
    )):
        Branching(w, [0.0, 1e-3, 2e-3], "x", "map", ["a", "b"])
    with pytest.raises(ValueError, match=re.escape(
        "Invalid value for the 'kind' parameter. Allowed values are 'longitudinal', 'cross', 'map' and 'random', "
        "but got 'longitudinl' instead. Did you mean 'longitudinal'?"
    )):
        Branching(w, [0.0, 1e-3], "x", "longitudinl", ["a", "b"])
    with pytest.raises(TypeError, match=re.escape("'layout' must be a ReceptorLayout; got ndarray instead.")):
        Branching.longitudinal(np.zeros((3, 3)))


# --------------------------------------------------------------------- synthesize errors, AfferentCurrent
def test_synthesize_checks_receptor_count_and_order(layout, current):
    b = Branching.longitudinal(layout)
    with pytest.raises(ValueError, match=re.escape(
        "'current' must have one column per receptor of the branching (n_receptors = 20); got shape (3, 19) instead."
    )):
        synthesize(current.values[:, :19], b)
    other = ReceptorLayout(layout.positions[::-1], layout.ids[::-1])
    with pytest.raises(ValueError, match=re.escape(
        "The current's receptors must match the branching's, in order; receptor column 0 is '19' in the current "
        "but '0' in the branching. Build the Branching from the layout the SED was sampled on."
    )):
        synthesize(SimpleNamespace(values=current.values, times=current.times, layout=other), b)
    with pytest.raises(TypeError, match=re.escape("'branching' must be a Branching; got ndarray instead.")):
        synthesize(current, np.eye(20))
    with pytest.raises(ValueError, match=re.escape("'current' must be finite; got 1 non-finite value(s)")):
        synthesize(np.where(np.eye(3, 20) > 0, np.nan, 0.0)[:1], b)


def test_afferent_current_accessors(layout, current):
    out = synthesize(current, Branching.longitudinal(layout))
    assert isinstance(out, AfferentCurrent)
    assert (out.n_times, out.n_afferents, out.kind, out.axis) == (3, NX, "longitudinal", "x")
    np.testing.assert_array_equal(np.asarray(out), out.values)
    np.testing.assert_array_equal(out.profile(), out.values[-1])
    np.testing.assert_array_equal(out.profile(0), out.values[0])
    with pytest.raises(ValueError, match=re.escape(
        "'time_index' must be in [-3, 2] for 3 time step(s); got 3 instead."
    )):
        out.profile(3)
    df = out.to_dataframe()
    assert list(df.columns) == ["afferent", "position_m", "step", "time_s", "current_a"]
    assert len(df) == 3 * NX
    row = df.iloc[NX + 2]  # time step 1, afferent 2
    assert (row.afferent, row.step, row.time_s) == ("L2", 1, 0.05)
    np.testing.assert_allclose([row.position_m, row.current_a], [out.positions[2], out.values[1, 2]], rtol=0)
    assert np.isnan(synthesize(current.values, Branching.longitudinal(layout)).to_dataframe().time_s).all()


# --------------------------------------------------------------------- properties
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(groups=st.lists(st.integers(0, NX * NZ - 1), min_size=NX * NZ, max_size=NX * NZ),
       log_amp=st.floats(-30, 3), n_times=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_property_any_partition_conserves_current(layout, groups, log_amp, n_times, seed):
    """Every grouping of the receptors into afferents (1 to 20 afferents, any sizes), with
    currents from 1e-30 A to 1e3 A: the afferent currents sum to the receptor currents, each
    afferent is the plain sum of its own receptors, and nothing is NaN."""
    rng = np.random.default_rng(seed)
    values = 10.0**log_amp * rng.uniform(0, 1, size=(n_times, layout.n_receptors))
    cur = SimpleNamespace(values=values, times=np.arange(n_times) * 1e-3, layout=layout)
    df = pd.DataFrame({"receptor": layout.ids, "afferent": [f"g{g}" for g in groups]})
    b = Branching.from_map(df, layout)
    out = synthesize(transduce_free(cur), b)
    assert b.is_partition and np.isfinite(out.values).all()
    np.testing.assert_allclose(out.values.sum(axis=1), values.sum(axis=1), rtol=1e-13, atol=0)
    for k, aid in enumerate(out.afferent_ids):
        members = np.array([f"g{g}" for g in groups]) == aid
        np.testing.assert_allclose(out.values[:, k], values[:, members].sum(axis=1), rtol=1e-13, atol=0)


def transduce_free(cur):
    """Receptor currents given directly (A), as a ReceptorCurrent, without the sigmoid."""
    from afferent.transduction import ReceptorCurrent

    return ReceptorCurrent(cur.values, cur.times, cur.layout)
