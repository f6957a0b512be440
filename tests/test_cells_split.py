"""Cells split into tetrahedra on first use (issue 38): a large hexahedral mesh is sampled without the
tetrahedra of its every cell (a 2,000,376-node VTU: 882 -> 379 MB at peak, benchmarks/bench_large_vtu.py)."""

from __future__ import annotations

import numpy as np
import pytest

from _memory import in_child


def _mixed_blocks():
    """meshio-like blocks of hexahedra, wedges, pyramids and quadratic tetrahedra over 40 points."""
    from types import SimpleNamespace as Block

    rng = np.random.default_rng(0)
    return [Block(type="hexahedron", data=rng.integers(3, 40, (5, 8))), Block(type="wedge", data=rng.integers(1, 40, (4, 6))),
            Block(type="pyramid", data=rng.integers(2, 38, (3, 5))), Block(type="tetra10", data=rng.integers(0, 40, (2, 10)))]


def _eager(blocks):
    """The split as cells_from_meshio made it before (every cell at once)."""
    from afferent.io._cell_blocks import _HIGHER, _TETS

    tets, parents, offset = [], [], 0
    for b in blocks:
        pattern = np.asarray(_TETS[_HIGHER.get(b.type, b.type)])
        tets.append(b.data[:, pattern].reshape(-1, 4))
        parents.append(np.repeat(np.arange(offset, offset + len(b.data)), len(pattern)))
        offset += len(b.data)
    return np.concatenate(tets), np.concatenate(parents)


def test_split_cells_are_the_eager_split_row_for_row():
    from afferent.io._cell_blocks import cells_from_meshio

    blocks = _mixed_blocks()
    tetra, parent = _eager(blocks)
    cells = cells_from_meshio(blocks, "mixed.vtu")
    assert not cells.split_done and cells.n_tetra == len(tetra)
    # the index range from the corner nodes: the tetra10's mid-side nodes (columns 4-9) are not the tetrahedra's
    assert cells.index_range == (int(tetra.min()), int(tetra.max()))
    t = np.array([0, 7, 29, 30, len(tetra) - 1, 3])
    got = cells.rows(t)
    assert np.array_equal(got[0], tetra[t]) and np.array_equal(got[1], parent[t])
    some = np.array([0, 4, 5, 9, 13])
    assert np.array_equal(cells.tetra_rows(some), np.flatnonzero(np.isin(parent, some)))
    assert np.array_equal(cells.tetra_rows(some, first=True), np.searchsorted(parent, some))
    assert not cells.split_done  # none of the above split every cell
    assert np.array_equal(cells.tetra, tetra) and np.array_equal(cells.parent, parent) and cells.split_done
    assert not cells.tetra.flags.writeable and not cells.parent.flags.writeable
    with_mat = cells.with_materials(np.arange(cells.n_cells))
    assert np.array_equal(with_mat.tetra, tetra) and np.array_equal(with_mat.materials, np.arange(cells.n_cells))


def _box(path, n: int) -> None:
    import meshio

    xs = np.linspace(0.0, 10.0, n)
    x, y, z = (a.ravel() for a in np.meshgrid(xs, xs, xs, indexing="ij"))
    i, j, k = (a.ravel() for a in np.meshgrid(*(np.arange(n - 1),) * 3, indexing="ij"))

    def node(a, b, c):
        return (a * n + b) * n + c

    hexes = np.column_stack([node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
                             node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)])
    sed = 1e-4 * (1 + np.sin(x) * np.cos(y) + 0.1 * z)  # MPa
    meshio.write(str(path), meshio.Mesh(np.column_stack([x, y, z]), [("hexahedron", hexes)], point_data={"SED": sed}))


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    """A 216,000-node hexahedral box (mm, SED in MPa): 205,379 cells, 1,232,274 tetrahedra (above NEAR_NODES_FROM)."""
    path = tmp_path_factory.mktemp("box") / "box.vtu"
    _box(path, 60)
    return path


def test_sampling_a_large_hexahedral_mesh_splits_only_the_cells_near_the_receptors(box):
    """The same weights as with every cell split, and the cells left unsplit."""
    import afferent
    from afferent._mesh_geometry import NEAR_NODES_FROM
    from afferent.sampling import build_sampler

    rng = np.random.default_rng(1)
    sites = rng.uniform(0.3, 9.7, (200, 3)) * 1e-3
    layout = afferent.ReceptorLayout(sites)
    field = afferent.read_sed(str(box), length_unit="mm", sed_unit="MPa")
    assert field.cells.n_tetra > NEAR_NODES_FROM
    lazy = build_sampler(field, layout, method="linear")
    assert not field.cells.split_done
    other = afferent.read_sed(str(box), length_unit="mm", sed_unit="MPa")
    assert other.cells.tetra.shape == (field.cells.n_tetra, 4)  # every cell split before the sampler
    eager = build_sampler(other, layout, method="linear")
    assert not lazy.outside.any()
    assert np.array_equal(lazy.outside, eager.outside)
    assert abs(lazy.weights - eager.weights).max() == 0


def test_reading_and_sampling_a_hexahedral_mesh_needs_no_tetrahedra_of_every_cell(box, tmp_path):
    """Peak memory of read_sed + build_sampler above the imports (a child process): the points, the
    connectivity and the SED (20 MB here) and a few copies, not the 1,232,274 tetrahedra and their cells
    (49 MB) nor meshio's index array and copy of the cells (26 MB) on top. Before: 90 MB; after: 36 MB."""
    got = in_child(f"""
        import numpy as np
        import scipy.sparse, scipy.spatial
        import afferent
        from afferent.sampling import build_sampler
        def rss():
            with open("/proc/self/status") as status:
                return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:")) / 1024
        start = rss()
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # the peak starts again from here (Linux >= 4.0)
        layout = afferent.ReceptorLayout(np.random.default_rng(1).uniform(0.3, 9.7, (200, 3)) * 1e-3)
        field = afferent.read_sed({str(box)!r}, length_unit="mm", sed_unit="MPa")
        build_sampler(field, layout, method="linear")
        open({str(tmp_path / "start")!r}, "w").write(str(start))
    """)
    assert got["error"] is None
    above = got["peak_mb"] - float((tmp_path / "start").read_text())
    print(f"{above:.1f} MB above the imports")
    assert above < 60


def test_afferent_sample_writes_its_table_without_importing_pandas(tmp_path):
    """pandas' import (0.45 s) was a fifth of `afferent sample`'s own time on a 2M-node export; its CSV is written
    byte for byte as pandas wrote it (afferent._tables.write_table, tested there)."""
    import subprocess
    import sys

    from _memory import ROOT

    out = tmp_path / "sed.csv"
    code = ("import runpy, sys\n"
            "sys.argv = ['afferent', 'sample', 'sample_sed/block4/indent_0p88mm.vtu', '--receptors', "
            f"'sample_sed/block4/receptors.csv', '--length-unit', 'mm', '--sed-unit', 'MPa', '-o', {str(out)!r}, '-q']\n"
            "try:\n    runpy.run_module('afferent', run_name='__main__', alter_sys=True)\n"
            "except SystemExit as e:\n    assert not e.code, e.code\n"
            "print('pandas' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=str(ROOT), timeout=300,
                          env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "False"
    assert out.read_text().startswith("receptor,x_m,y_m,z_m,time_s,sed_pa\n1,0.00068,0.0024500000000000004,0.00024,0.0,")
