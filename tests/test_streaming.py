"""Series read and sampled one step at a time (afferent.io.iter_sed + afferent.sampling.sample_steps).

The reference is the in-memory route, read_sed + sample_sed, on the same files: the streamed
values and times must be equal to it bit for bit, on files real tools wrote (the bundled
scikit-fem PVD series, DOLFINx 0.5.2's XDMF) and on generated series; memory must not grow
with the number of steps.
"""

from __future__ import annotations

import re
import tracemalloc
import warnings

import meshio
import numpy as np
import pytest

import afferent
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import iter_sed
from afferent.receptors import ReceptorLayout
from afferent.sampling import sample_steps

from conftest import DATA_DIR, SAMPLE_DIR, hex_box, linear_sed

PVD = SAMPLE_DIR / "block4" / "series_0p88mm" / "indent.pvd"


def _both(path, layout, **kw):
    whole = afferent.sample_sed(afferent.read_sed(path, **kw), layout)
    streamed = sample_steps(iter_sed(path, **kw), layout)
    return whole, streamed


def test_streamed_pvd_equals_the_in_memory_route_on_the_bundled_series():
    layout = afferent.read_receptors(SAMPLE_DIR / "block4" / "receptors.csv", length_unit="mm")
    whole, streamed = _both(PVD, layout, length_unit="mm", sed_unit="MPa")
    assert whole.values.shape == (6, layout.n_receptors)
    np.testing.assert_array_equal(streamed.values, whole.values)
    np.testing.assert_array_equal(streamed.times, whole.times)
    assert streamed.placement == whole.placement


@pytest.mark.filterwarnings("ignore:SED file .* (SED of|the points span)")
def test_streamed_dolfinx_xdmf_equals_the_in_memory_route():
    path = DATA_DIR / "dolfinx" / "sed_only.xdmf"
    field = afferent.read_sed(path, length_unit="m", sed_unit="Pa")
    lo, hi = field.bounds
    layout = ReceptorLayout(lo + (hi - lo) * np.random.default_rng(1).uniform(0.1, 0.9, (20, 3)))
    whole, streamed = _both(path, layout, length_unit="m", sed_unit="Pa")
    np.testing.assert_array_equal(streamed.values, whole.values)
    np.testing.assert_array_equal(streamed.times, whole.times)
    steps = list(iter_sed(path, length_unit="m", sed_unit="Pa"))
    assert len(steps) == field.n_times and all(s.n_times == 1 for s in steps)
    assert all(s.cells is steps[0].cells for s in steps)  # the mesh is read once and shared


def _series(tmp_path, n, *, moved_step=None, negative=False):
    points, hexes = hex_box()
    paths = []
    for k in range(n):
        sed = linear_sed(points) * (k + 1)
        if negative:
            sed[0] = -1e-3 * sed.max()  # a nodal-extrapolation artefact in every step
        pts = points + (1e-3 if k == moved_step else 0.0)
        p = tmp_path / f"s{k}.vtu"
        meshio.write(p, meshio.Mesh(pts, [("hexahedron", hexes)], point_data={"SED": sed}))
        paths.append(str(p))
    return paths


def test_vtu_list_without_times_is_numbered_like_read_sed(tmp_path):
    paths = _series(tmp_path, 4)
    layout = ReceptorLayout(np.array([[0.5, 0.3, 0.9], [1.0, 0.6, 1.5]]) * 1e-3)
    whole, streamed = _both(paths, layout, length_unit="mm", sed_unit="MPa")
    np.testing.assert_array_equal(streamed.values, whole.values)
    np.testing.assert_array_equal(streamed.times, [0.0, 1.0, 2.0, 3.0])
    # times declared by the user are sliced per step
    streamed = sample_steps(iter_sed(paths, length_unit="mm", sed_unit="MPa", times=[0, 5, 10, 15], time_unit="ms"), layout)
    np.testing.assert_allclose(streamed.times, [0.0, 0.005, 0.01, 0.015])
    with pytest.raises(ValueError, match=re.escape("'times' must have one entry per time step (4); got 3 instead.")):
        next(iter_sed(paths, length_unit="mm", sed_unit="MPa", times=[0, 1, 2]))


def test_a_step_on_another_mesh_is_an_error_naming_its_file(tmp_path):
    paths = _series(tmp_path, 3, moved_step=2)
    layout = ReceptorLayout(np.array([[0.5, 0.3, 0.9]]) * 1e-3)
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {paths[2]!r} is not on the same mesh as {paths[0]!r}")):
        sample_steps(iter_sed(paths, length_unit="mm", sed_unit="MPa"), layout)


def test_a_warning_repeated_by_every_step_is_shown_once(tmp_path):
    paths = _series(tmp_path, 5, negative=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        steps = list(iter_sed(paths, length_unit="mm", sed_unit="MPa"))
    negative = [w for w in caught if issubclass(w.category, AfferentWarning) and "negative" in str(w.message)]
    assert len(negative) == 1 and paths[0] in str(negative[0].message)
    assert all(s.provenance.negative_sed["count"] == 1 for s in steps)  # still recorded for every step


def test_empty_iterable_is_an_error():
    with pytest.raises(ValueError, match=re.escape("'fields' must hold at least one SEDField; got none.")):
        sample_steps(iter([]), ReceptorLayout(np.zeros((1, 3))))


def test_unknown_keyword_is_named():
    with pytest.raises(TypeError, match=re.escape("iter_sed() got an unexpected keyword argument 'sed_units'.")):
        next(iter_sed(str(PVD), sed_units="MPa"))


def _peak(paths, layout):
    tracemalloc.start()
    try:
        sample_steps(iter_sed(paths, length_unit="mm", sed_unit="MPa"), layout)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_peak_memory_does_not_grow_with_the_number_of_steps(tmp_path):
    """4 vs 24 steps of a 36,000-point mesh: streaming holds one step; the in-memory route's
    stacked SED alone would grow by 20 x 36,000 x 8 B = 5.8 MB."""
    points, hexes = hex_box(32, 32, 32)
    paths = []
    for k in range(24):
        p = tmp_path / f"big{k}.vtu"
        meshio.write(p, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": linear_sed(points) * (k + 1)}))
        paths.append(str(p))
    layout = ReceptorLayout(np.array([[0.5, 0.3, 0.9]]) * 1e-3)
    _peak(paths[:2], layout)  # first use: imports and caches, not part of the measure
    few, many = _peak(paths[:4], layout), _peak(paths, layout)
    assert many < few + 1_000_000, (few, many)  # measured: +160 B; read_sed + sample_sed: +5.8 MB


def test_cli_sample_streams_and_writes_the_same_table(tmp_path):
    out_a, out_b = tmp_path / "a.csv", tmp_path / "b.csv"
    rec = SAMPLE_DIR / "block4" / "receptors.csv"
    assert main(["sample", str(PVD), "--receptors", str(rec), "--length-unit", "mm", "--sed-unit", "MPa",
                 "-o", str(out_a), "--quiet"]) == 0
    layout = afferent.read_receptors(rec, length_unit="mm")
    whole = afferent.sample_sed(afferent.read_sed(PVD, length_unit="mm", sed_unit="MPa"), layout)
    whole.to_dataframe().to_csv(out_b, index=False)
    import pandas as pd

    pd.testing.assert_frame_equal(pd.read_csv(out_a), pd.read_csv(out_b))


def test_series_provenance_sums_the_steps_negatives_and_keeps_every_file(tmp_path):
    from afferent.io import series_provenance

    paths = _series(tmp_path, 3, negative=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AfferentWarning)
        steps = list(iter_sed(paths, length_unit="mm", sed_unit="MPa"))
        whole = afferent.read_sed(paths, length_unit="mm", sed_unit="MPa")
    merged = series_provenance(s.provenance for s in steps)
    assert merged.files == tuple(paths) == whole.provenance.files
    neg = merged.negative_sed
    assert (neg["count"], neg["n_values"], neg["steps_with_negatives"], neg["first_step"]) == (3, 3 * steps[0].n_points, 3, 0)
    assert neg["count"] == whole.provenance.negative_sed["count"]
    assert merged.units == whole.provenance.units and merged.columns == whole.provenance.columns


def test_a_scene_on_a_pvd_records_the_series_it_streamed(tmp_path):
    import json

    out = tmp_path / "out"
    assert main(["run", str(SAMPLE_DIR / "scenes" / "spikes_ramp.toml"), "-o", str(out), "--quiet", "--no-cache"]) == 0
    field = json.loads((out / "run.json").read_text())["field"]
    assert field["n_times"] == 6 and field["files"][0].endswith("indent.pvd") and len(field["files"]) == 7


def test_reading_without_progress_does_not_import_tqdm_and_with_it_draws_a_bar():
    """tqdm.auto prints "IProgress not found" in a Jupyter kernel without ipywidgets even for a
    disabled bar: with progress off it is not imported at all."""
    import subprocess
    import sys

    code = ("import sys, afferent; afferent.read_sed({p!r}, length_unit='mm', sed_unit='MPa', progress={on}); "
            "print('tqdm' in sys.modules)")
    off = subprocess.run([sys.executable, "-c", code.format(p=str(PVD), on=False)], capture_output=True, text=True)
    on = subprocess.run([sys.executable, "-c", code.format(p=str(PVD), on=True)], capture_output=True, text=True)
    assert off.stdout.strip() == "False", off.stderr
    assert on.stdout.strip() == "True" and "reading series" in on.stderr, on.stderr


def test_a_streamed_series_searches_its_coincident_copies_once_and_merges_every_step(tmp_path, monkeypatch):
    """The coincident-copy search (shortest edge, then a KD-tree) ran again at every streamed step of one
    mesh (45 steps of 101k nodes in the quick report: ~2 s); it runs once per series now, and every step's
    copies are still merged as the in-memory route merges them."""
    from afferent.io import _coincident

    # two unit hexahedra side by side, each with its own copies of the four shared corners (discontinuous output)
    unit = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    points = np.vstack([unit, unit + [1.0, 0.0, 0.0]])
    hexes = np.arange(16).reshape(2, 8)
    paths = []
    for k in range(3):
        sed = (k + 1.0) * (1.0 + points[:, 0]) + np.r_[np.zeros(8), np.full(8, 0.1)]  # the copies differ a little
        paths.append(str(tmp_path / f"s{k}.vtu"))
        meshio.write(paths[-1], meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}))
    calls = []
    original = _coincident.coincident_labels
    monkeypatch.setattr(_coincident, "coincident_labels", lambda *a, **k: calls.append(1) or original(*a, **k))
    _coincident._LAST.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        steps = list(iter_sed(paths, length_unit="mm", sed_unit="kPa"))
        whole = afferent.read_sed(paths, length_unit="mm", sed_unit="kPa")
    assert len(calls) == 2  # the stream's first step, then read_sed's own (other Cells)
    assert [f.points.shape for f in steps] == [(12, 3)] * 3 and whole.points.shape == (12, 3)
    np.testing.assert_array_equal(np.vstack([f.sed for f in steps]), whole.sed)
    assert all(f.provenance.coincident["n_nodes"] == 12 for f in steps)


def _discontinuous_series(folder) -> list[str]:
    """Three steps of four hexahedra in two materials, each cell with its own copies of its nodes (deal.II's
    DataOut), the copies differing a little: coincident points merged, material sides kept."""
    unit = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    points = np.vstack([unit + [i, j, 0.0] for i in (0, 1) for j in (0, 1)])
    paths = []
    for k in range(3):
        sed = (k + 1.0) * (1.0 + points[:, 1]) + np.repeat([0.0, 0.1, 0.0, 0.1], 8)
        paths.append(str(folder / f"d{k}.vtu"))
        meshio.write(paths[-1], meshio.Mesh(points, [("hexahedron", np.arange(32).reshape(4, 8))],
                                            point_data={"SED": sed}, cell_data={"material": [np.array([1, 2, 1, 2])]}))
    return paths


@pytest.mark.filterwarnings("ignore:SED file .* (SED of|the points span|points are)")
@pytest.mark.parametrize("case", ["pvd", "xdmf", "discontinuous"])
def test_a_series_mesh_is_checked_once_and_each_step_equals_a_fresh_read(case, tmp_path, monkeypatch):
    """iter_sed's steps share the reader's points and cells: what depends on the mesh alone (the coordinates'
    check and conversion to m, the span's plausibility, the coincident search, the merged cells, the copies'
    weights, the cells' index range) is done at the first step and reused; every step is bit for bit what a
    fresh assemble of that step gives."""
    from afferent.io import _assemble, _coincident, _raw_steps, _read_options

    path, units = {"pvd": (PVD, ("mm", "MPa")), "xdmf": (DATA_DIR / "dolfinx" / "block.xdmf", ("mm", "MPa")),
                   "discontinuous": (_discontinuous_series(tmp_path), ("mm", "kPa"))}[case]
    path = path if isinstance(path, list) else str(path)
    opts = _read_options(**{**{n: p.default for n, p in __import__("inspect").signature(afferent.read_sed).parameters.items()
                                if p.kind is p.KEYWORD_ONLY and n not in ("format", "progress")},
                            "length_unit": units[0], "sed_unit": units[1]})
    fresh = []
    for raw in _raw_steps(path, None, False)[1]:
        _coincident._LAST.clear()  # a fresh search at every step
        fresh.append(_assemble.assemble(raw, opts))
    spans, pairs = [], []
    original, original_pairs = _assemble.span_warning, _coincident._point_cells
    monkeypatch.setattr(_assemble, "span_warning", lambda *a, **k: spans.append(1) or original(*a, **k))
    monkeypatch.setattr(_coincident, "_point_cells", lambda *a, **k: pairs.append(1) or original_pairs(*a, **k))
    steps = list(iter_sed(path, length_unit=units[0], sed_unit=units[1]))
    assert len(steps) == len(fresh) > 1 and len(spans) == 1 and len(pairs) == (case == "discontinuous")
    assert all(s.points is steps[0].points and s.cells is steps[0].cells for s in steps)
    for s, f in zip(steps, fresh):
        np.testing.assert_array_equal(s.points, f.points)
        np.testing.assert_array_equal(s.sed, f.sed)
        np.testing.assert_array_equal(s.cells.tetra, f.cells.tetra)
        numbered = "The export states no step times"  # iter_sed's own note on a list of VTUs
        assert [n for n in s.provenance.notes if not n.startswith(numbered)] == list(f.provenance.notes)
        assert s.cells.index_range == f.cells.index_range and s.provenance.coincident == f.provenance.coincident
        if case == "discontinuous":
            assert s.provenance.coincident["n_nodes"] == 18 and s.sides is not None
            for name in ("nodes", "materials", "sed"):
                np.testing.assert_array_equal(getattr(s.sides, name), getattr(f.sides, name))
