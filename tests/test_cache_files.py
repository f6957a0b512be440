"""The sampled-SED cache and run.json know every file a reader opened (docs/scenes.md, afferent.cache).

Each reader lists the files it really opened in ``RawExport.files`` (the export first): the HDF5
files an XDMF names (any name: spaces, upper case), the targets of HDF5 external links, the raw
``.bin`` files of XDMF ``Format="Binary"`` data items. A cache entry records them with their
sha256 and is stale as soon as one changed; ``run.json`` lists each with its sha256.

Files: the DOLFINx 0.5.2 export of tests/data/dolfinx (block.xdmf + block.h5), renamed and
rewritten here; HDF5 external links made with h5py; a Binary XDMF written by meshio.
"""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from afferent import read_sed
from afferent.cache import SEDCache
from afferent.export import file_sha256
from afferent.scene import load_scene, run_scene

from conftest import DATA_DIR

DX = DATA_DIR / "dolfinx"


def _block(folder: Path, h5name: str) -> Path:
    """block.xdmf + its HDF5 file under the name ``h5name``, in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    xdmf = folder / "block.xdmf"
    xdmf.write_text((DX / "block.xdmf").read_text().replace("block.h5:", f"{h5name}:"))
    shutil.copy(DX / "block.h5", folder / h5name)
    return xdmf


def _scene(folder: Path, export: Path, out: str = "out") -> Path:
    (folder / "receptors.csv").write_text("id,x,y,z\n1,0.5,0.5,0.5\n2,1.5,1.0,0.5\n3,1.0,1.5,0.25\n")
    path = folder / "scene.toml"
    path.write_text(textwrap.dedent(f"""
        [export]
        file = {str(export)!r}
        length_unit = "mm"
        sed_unit = "MPa"
        sed_column = "sed"

        [receptors]
        file = {str(folder / 'receptors.csv')!r}

        [outputs]
        want = ["sed_map"]
        dir = {str(folder / out)!r}
        """))
    return path


def _run(scene_file: Path, cache: Path):
    return run_scene(load_scene(scene_file), overwrite=True, cache_dir=cache)


def _scale(h5file: Path, group: str, factor: float) -> None:
    with h5py.File(h5file, "r+") as h5:
        for name in h5[group]:
            ds = h5[f"{group}/{name}"]
            ds[...] = ds[()] * factor


@pytest.mark.parametrize("h5name", ["my data.h5", "DATA.H5", "block.hdf"])
def test_rewritten_heavy_data_file_is_not_served_from_the_cache(tmp_path, h5name):
    xdmf = _block(tmp_path / "export", h5name)
    scene = _scene(tmp_path, xdmf)
    first = _run(scene, tmp_path / "cache")
    assert first.cache_hit is False and _run(scene, tmp_path / "cache").cache_hit is True
    _scale(tmp_path / "export" / h5name, "Function/sed", 2.0)
    third = _run(scene, tmp_path / "cache")
    assert third.cache_hit is False
    assert h5name in third.record["cache"]["miss"] and "changed" in third.record["cache"]["miss"]
    np.testing.assert_allclose(third.sed.values, 2 * first.sed.values, rtol=1e-12)
    assert np.nanmax(first.sed.values) > 0
    # the rebuilt entry serves the new values
    fourth = _run(scene, tmp_path / "cache")
    assert fourth.cache_hit is True
    np.testing.assert_array_equal(fourth.sed.values, third.sed.values)


def _linked_block(folder: Path) -> Path:
    """block.xdmf whose HDF5 file holds Function/sed as an external link to target.h5."""
    xdmf = _block(folder, "main.h5")
    with h5py.File(folder / "main.h5", "r+") as main, h5py.File(folder / "target.h5", "w") as target:
        main.copy(main["Function/sed"], target["/"], name="sed_data")
        del main["Function/sed"]
        main["Function/sed"] = h5py.ExternalLink("target.h5", "/sed_data")
    return xdmf


def test_external_link_target_is_a_file_read_and_keys_the_cache(tmp_path):
    xdmf = _linked_block(tmp_path / "export")
    direct = read_sed(DX / "block.xdmf", length_unit="mm", sed_unit="MPa", sed_column="sed")
    linked = read_sed(xdmf, length_unit="mm", sed_unit="MPa", sed_column="sed")
    np.testing.assert_array_equal(linked.sed, direct.sed)
    names = [Path(f).name for f in linked.provenance.files]
    assert names == ["block.xdmf", "main.h5", "target.h5"]

    scene = _scene(tmp_path, xdmf)
    first = _run(scene, tmp_path / "cache")
    assert _run(scene, tmp_path / "cache").cache_hit is True
    _scale(tmp_path / "export" / "target.h5", "sed_data", 3.0)
    third = _run(scene, tmp_path / "cache")
    assert third.cache_hit is False and "target.h5" in third.record["cache"]["miss"]
    np.testing.assert_allclose(third.sed.values, 3 * first.sed.values, rtol=1e-12)


def test_a_chain_of_external_links_is_followed_file_by_file(tmp_path):
    """main.h5 -> hop.h5 -> target.h5: re-pointing the middle link to another file is a change."""
    xdmf = _linked_block(tmp_path / "export")
    folder = tmp_path / "export"
    shutil.copy(folder / "target.h5", folder / "other.h5")
    _scale(folder / "other.h5", "sed_data", 5.0)
    with h5py.File(folder / "main.h5", "r+") as main, h5py.File(folder / "hop.h5", "w") as hop:
        del main["Function/sed"]
        main["Function/sed"] = h5py.ExternalLink("hop.h5", "/sed")
        hop["sed"] = h5py.ExternalLink("target.h5", "/sed_data")
    field = read_sed(xdmf, length_unit="mm", sed_unit="MPa", sed_column="sed")
    assert [Path(f).name for f in field.provenance.files] == ["block.xdmf", "main.h5", "hop.h5", "target.h5"]
    scene = _scene(tmp_path, xdmf)
    first = _run(scene, tmp_path / "cache")
    with h5py.File(folder / "hop.h5", "r+") as hop:
        del hop["sed"]
        hop["sed"] = h5py.ExternalLink("other.h5", "/sed_data")
    second = _run(scene, tmp_path / "cache")
    assert second.cache_hit is False and "hop.h5" in second.record["cache"]["miss"]
    np.testing.assert_allclose(second.sed.values, 5 * first.sed.values, rtol=1e-12)


def test_run_json_lists_every_file_read_with_its_sha256(tmp_path):
    xdmf = _linked_block(tmp_path / "export")
    scene = _scene(tmp_path, xdmf)
    for expect_hit in (False, True):  # read, then from the cache: the same list
        result = _run(scene, tmp_path / "cache")
        assert result.cache_hit is expect_hit
        inputs = json.loads((tmp_path / "out" / "run.json").read_text())["inputs"]
        by_name = {Path(p).name: h for p, h in inputs.items()}
        for name in ("block.xdmf", "main.h5", "target.h5"):
            assert by_name[name] == file_sha256(tmp_path / "export" / name), name
        assert by_name["receptors.csv"] == file_sha256(tmp_path / "receptors.csv")


def test_a_file_modified_while_being_read_is_not_cached(tmp_path):
    """Its hash, taken after reading, may not describe the values read: no entry is written."""
    import os
    import time

    xdmf = _block(tmp_path / "export", "data.h5")
    later = time.time() + 3600  # as if rewritten during the read
    os.utime(tmp_path / "export" / "data.h5", (later, later))
    result = _run(_scene(tmp_path, xdmf), tmp_path / "cache")
    assert result.cache_hit is False and "written" not in result.record["cache"]
    assert "data.h5" in result.record["cache"]["not_written"] and "modified after reading began" in \
        result.record["cache"]["not_written"]
    assert _run(_scene(tmp_path, xdmf), tmp_path / "cache").cache_hit is False


def test_copied_export_with_a_changed_side_file_misses(tmp_path):
    """The key ignores folders (a copy still hits), but the side files are checked where the copy is."""
    xdmf = _block(tmp_path / "a", "data.h5")
    first = _run(_scene(tmp_path, xdmf), tmp_path / "cache")
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    copy = _scene(tmp_path, tmp_path / "b" / "block.xdmf")
    assert _run(copy, tmp_path / "cache").cache_hit is True  # identical copy: hit
    # the copy's run lists (and read) the copy's files only, not the first export's left in a/
    inputs = json.loads((tmp_path / "out" / "run.json").read_text())["inputs"]
    assert not [p for p in inputs if Path(p).is_relative_to(tmp_path / "a")], inputs
    assert {Path(p).name for p in inputs if Path(p).is_relative_to(tmp_path / "b")} == {"block.xdmf", "data.h5"}
    _scale(tmp_path / "b" / "data.h5", "Function/sed", 0.5)
    changed = _run(copy, tmp_path / "cache")
    assert changed.cache_hit is False
    np.testing.assert_allclose(changed.sed.values, 0.5 * first.sed.values, rtol=1e-12)


def _binary_xdmf(folder: Path, monkeypatch, factor: float = 1.0) -> Path:
    """A single-grid XDMF with Format="Binary" data items, written by meshio (a tetra per cube corner)."""
    import meshio

    folder.mkdir(parents=True, exist_ok=True)
    monkeypatch.chdir(folder)  # meshio names the .bin files as it writes them, relative to the working folder
    pts = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 1], [2, 2, 1]], float)
    cells = [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))]
    sed = factor * np.array([1.0, 2.0, 3.0, 4.0, 5.0]) * 1e-3
    meshio.write("bin.xdmf", meshio.Mesh(pts, cells, point_data={"sed": sed}), data_format="Binary")
    return folder / "bin.xdmf"


def test_binary_data_items_are_files_read(tmp_path, monkeypatch):
    xdmf = _binary_xdmf(tmp_path / "export", monkeypatch)
    bins = sorted(p.name for p in xdmf.parent.glob("*.bin"))
    assert len(bins) == 3  # points, cells, sed
    field = read_sed(xdmf, length_unit="mm", sed_unit="MPa")
    assert sorted(Path(f).name for f in field.provenance.files[1:]) == bins
    np.testing.assert_allclose(field.sed[0], [1e3, 2e3, 3e3, 4e3, 5e3])

    scene = _scene(tmp_path, xdmf)
    first = _run(scene, tmp_path / "cache")
    assert _run(scene, tmp_path / "cache").cache_hit is True
    _binary_xdmf(tmp_path / "export", monkeypatch, factor=2.0)  # same .xdmf text, new .bin content
    third = _run(scene, tmp_path / "cache")
    assert third.cache_hit is False and ".bin" in third.record["cache"]["miss"]
    np.testing.assert_allclose(third.sed.values, 2 * first.sed.values, rtol=1e-12)


def test_entry_without_its_side_file_is_ignored(tmp_path):
    xdmf = _block(tmp_path / "export", "data.h5")
    result = _run(_scene(tmp_path, xdmf), tmp_path / "cache")
    entry = SEDCache(tmp_path / "cache").get(result.record["cache"]["key"])
    assert [Path(f["path"]).name for f in entry.meta["files"]] == ["block.xdmf", "data.h5"]
    (tmp_path / "export" / "data.h5").unlink()
    cache = SEDCache(tmp_path / "cache")
    assert cache.get(result.record["cache"]["key"], base=str(tmp_path / "export")) is None
    assert "data.h5" in cache.last_miss and "missing" in cache.last_miss


ROOT = Path(__file__).resolve().parents[1]
SERIES = ROOT / "sample_sed" / "block4" / "series_0p88mm"


@pytest.mark.parametrize("export, side", [
    (DATA_DIR / "calculix" / "block_c3d8.frd", []),
    (DATA_DIR / "calculix" / "block_c3d8.frd.gz", []),
    (DATA_DIR / "exodus" / "layers_ioss.e", []),
    (DATA_DIR / "csv" / "abaqus_sener.rpt", []),
    (DX / "block.xdmf", ["block.h5"]),
    (DX / "sed_only.xdmf", ["sed_only.h5"]),
    (SERIES / "indent.pvd", [f"indent_00{k}.vtu" for k in range(6)]),
])
def test_each_reader_lists_the_files_it_opened(export, side):
    from afferent.io import read_raw

    if not export.is_file():
        pytest.skip("bundled sample not present")
    files = read_raw(export).files
    assert files[0] == str(export) and [Path(f).name for f in files[1:]] == side
    assert all(Path(f).is_file() for f in files)


def test_rewritten_pvd_member_is_not_served_from_the_cache(tmp_path):
    if not SERIES.is_dir():
        pytest.skip("bundled sample not present")
    shutil.copytree(SERIES, tmp_path / "series")
    scene = _scene(tmp_path, tmp_path / "series" / "indent.pvd")
    scene.write_text(scene.read_text().replace('sed_column = "sed"\n', ""))
    (tmp_path / "receptors.csv").write_bytes((ROOT / "sample_sed" / "block4" / "receptors.csv").read_bytes())
    first = _run(scene, tmp_path / "cache")
    assert _run(scene, tmp_path / "cache").cache_hit is True
    shutil.copy(tmp_path / "series" / "indent_005.vtu", tmp_path / "series" / "indent_003.vtu")
    third = _run(scene, tmp_path / "cache")
    assert third.cache_hit is False and "indent_003.vtu" in third.record["cache"]["miss"]
    np.testing.assert_array_equal(third.sed.values[3], first.sed.values[5])
    assert not np.array_equal(first.sed.values[3], first.sed.values[5])
