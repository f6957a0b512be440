"""The sample shipped inside the package (afferent/data/sample/) and the wheel that carries it.

* The packaged sample is a crop of sample_sed/ (its README.md says how): every packaged VTU is
  checked against the full file it comes from, node by node and element by element, and the SED
  sampled at the receptors is the full sample's, for every case the demo covers.
* The wheel and the sdist, built from a copy of the source tree with ``python -m build``, carry
  the packaged sample and neither sample_sed/ nor tests/data; the wheel, installed in a new
  venv, runs ``afferent demo`` with the source tree neither on the path nor the working
  directory, and writes the same results as the demo run from the source tree on the full
  sample_sed/.

The venv of the wheel test has no site packages of its own but the wheel: the dependencies
(numpy, scipy, brian2, ...) are those of the interpreter running the tests, reached through a
``.pth`` line. A ``.pth`` line only puts a folder on ``sys.path``; the ``.pth`` files inside
that folder (an editable install of afferent) are not run, and the venv's own site-packages
comes first, so ``afferent`` resolves to the installed wheel (checked). A venv that installs the
dependencies from the package index instead takes about a minute on this machine (measured:
55 s); set ``AFFERENT_WHEEL_FRESH_VENV=1`` to run the test that way.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import meshio
import numpy as np
import pandas as pd
import pytest
from scipy.spatial import cKDTree

import afferent
from afferent.cli import main as cli_main
from afferent.cli._demo import CASES, packaged_sample_dir

from conftest import ROOT, SAMPLE_DIR

PACKAGED = packaged_sample_dir()
SERIES = [f"block4/series_0p88mm/indent_{k:03d}.vtu" for k in range(6)]
VTUS = [f"{block}/{fname}" for _, block, fname, _ in CASES] + SERIES
full_sample = pytest.mark.skipif(not (SAMPLE_DIR / "block4" / "receptors.csv").is_file(),
                                 reason="sample_sed not generated")
WHEEL_MAX_BYTES = 5_000_000


def readme_table():
    """{file: (bytes, sha256, source sha256)} from the packaged sample's README.md."""
    rows = re.findall(r"^\| `([^`]+)` \| ([\d ]+) \| `([0-9a-f]{64})` \| `([0-9a-f]{64})` \|$",
                      (PACKAGED / "README.md").read_text(), flags=re.M)
    return {name: (int(size.replace(" ", "")), sha, src) for name, size, sha, src in rows}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_packaged_sample_is_the_files_its_readme_lists():
    """Every packaged file is listed in README.md with its size and sha256, and nothing else is there."""
    table = readme_table()
    on_disk = sorted(p.relative_to(PACKAGED).as_posix() for p in PACKAGED.rglob("*") if p.is_file())
    assert sorted(table) == [f for f in on_disk if f != "README.md"]
    assert set(VTUS) | {"block4/receptors.csv", "block8/receptors.csv", "scenes/spikes_ramp.toml"} <= set(table)
    for name, (size, sha, _) in table.items():
        assert (PACKAGED / name).stat().st_size == size, name
        assert sha256(PACKAGED / name) == sha, name
    total = sum(size for size, _, _ in table.values())
    # a crop, not the 37 MB sample: 2.9 MB with the chapter-4 findings' files, whose vibration series carry the cells'
    # SED and layer around each tip so that the dermis side can be read (issue 35)
    assert total < 3_300_000


@full_sample
def test_packaged_sample_was_made_from_the_sample_sed_of_this_tree(monkeypatch):
    """The source sha256 in the README are those of sample_sed/ now: regenerating sample_sed/
    without ``make_samples.py --packaged`` fails here."""
    import importlib

    monkeypatch.syspath_prepend(str(SAMPLE_DIR))
    make_samples = importlib.import_module("make_samples")
    for name, (_, _, src) in readme_table().items():
        path = SAMPLE_DIR / name
        if name == "scenes/spikes_ramp.toml":  # copied with a two-line header
            text = (PACKAGED / name).read_text()
            assert text.split("\n", 2)[2] == path.read_text()
        # a vibration series' XDMF: the sha256 of its PVD and step VTUs (make_samples.source_sha256)
        assert make_samples.source_sha256(SAMPLE_DIR, name) == src, \
            f"{name}: sample_sed/ changed since the packaged sample was written"


def _receptor_nodes(points, block):
    xyz = np.loadtxt(PACKAGED / block / "receptors.csv", delimiter=",", skiprows=1)[:, 1:4]
    dist, idx = cKDTree(points).query(xyz)
    assert dist.max() == 0.0  # every receptor is a mesh node, exactly
    return idx


@full_sample
@pytest.mark.parametrize("name", VTUS)
def test_packaged_vtu_is_the_full_solution_on_the_elements_around_the_receptors(name):
    """Node by node and element by element: the packaged VTU holds the full file's elements that
    touch a receptor node (and only those), with the same coordinates and the same values, bit for bit."""
    small, full = meshio.read(PACKAGED / name), meshio.read(SAMPLE_DIR / name)
    dist, node = cKDTree(full.points).query(small.points)
    assert dist.max() == 0.0 and np.unique(node).size == node.size
    # the elements: exactly those of the full mesh with a receptor among their corners, in the same order
    full_hex, small_hex = full.cells_dict["hexahedron"], small.cells_dict["hexahedron"]
    keep = np.isin(full_hex, _receptor_nodes(full.points, name.split("/")[0])).any(axis=1)
    assert np.array_equal(node[small_hex], full_hex[keep])
    assert sorted(small.point_data) == sorted(set(full.point_data) - {"U"})
    for key, values in small.point_data.items():
        assert values.dtype == full.point_data[key].dtype
        assert np.array_equal(values, full.point_data[key][node]), key
    assert sorted(small.cell_data) == sorted(full.cell_data)
    for key, (values,) in small.cell_data.items():
        assert np.array_equal(values, full.cell_data[key][0][keep]), key


def _sample(path, location, method):
    field = afferent.read_sed(str(path), length_unit="mm", sed_unit="MPa", location=location)
    layout = afferent.read_receptors(path.parent.parent / "receptors.csv" if path.suffix == ".pvd"
                                     else path.parent / "receptors.csv", length_unit="mm")
    return afferent.sample_sed(field, layout, method=method).values


SAMPLINGS = [(f"{block}/{fname}", location, method) for _, block, fname, _ in CASES
             for location, method in [("point", "linear"), ("point", "nearest"), ("cell", "linear")]]
SAMPLINGS += [("block4/series_0p88mm/indent.pvd", "point", method) for method in ("linear", "nearest")]  # point SED only


@full_sample
@pytest.mark.parametrize(("name", "location", "method"), SAMPLINGS)
def test_packaged_sample_gives_the_full_samples_sed_at_the_receptors(name, location, method):
    """Through afferent's own reading and sampling: the SED at every receptor (J/m^3) from the
    packaged file equals the full file's to float rounding, for every case and step the demo uses,
    whichever values are sampled (cell values are averaged to the nodes: every receptor node keeps
    all its elements)."""
    small = _sample(PACKAGED / name, location, method)
    full = _sample(SAMPLE_DIR / name, location, method)
    assert small.shape == full.shape and np.all(np.isfinite(small))
    assert full.max() > 100  # Pa: the indented state, not an empty field (the sample's tips: 221-1819 Pa at peak)
    np.testing.assert_allclose(small, full, rtol=1e-12, atol=0)


def _copy_source_tree(dst: Path) -> Path:
    """The working tree without version control, venvs, build outputs and caches."""
    skip = shutil.ignore_patterns(".git", ".venv", "venv", "build", "dist", "*.egg-info", "results", "__pycache__",
                                  ".pytest_cache", ".hypothesis", ".ruff_cache", "*.part")
    shutil.copytree(ROOT, dst, ignore=skip)
    return dst


def _dependency_dirs(wheel: Path) -> list[str]:
    """The folders the running interpreter has the wheel's dependencies (its Requires-Dist) in."""
    import importlib.metadata as md

    with zipfile.ZipFile(wheel) as zf:
        (meta,) = [n for n in zf.namelist() if n.endswith(".dist-info/METADATA")]
        requires = [line.split(":", 1)[1].strip() for line in zf.read(meta).decode().splitlines()
                    if line.startswith("Requires-Dist:") and "extra ==" not in line]
    names = [re.match(r"[A-Za-z0-9_.-]+", r).group(0) for r in requires]
    assert {"numpy", "scipy", "brian2", "meshio"} <= set(names), names
    return sorted({str(Path(md.distribution(n).locate_file("")).resolve()) for n in names})


def _clean_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "AFFERENT_", "VIRTUAL_ENV", "PYTEST_", "COV_"))}
    return {**env, "MPLBACKEND": "Agg", **extra}


@pytest.mark.slow
@full_sample
def test_wheel_runs_the_demo_without_the_source_tree(tmp_path):
    """Build sdist and wheel (python -m build: the wheel is built from the sdist), install the wheel
    in a new venv, run ``afferent demo`` outside the source tree, compare with the source tree's
    demo on the full sample_sed/."""
    import time

    clock, took = time.perf_counter(), {}

    def lap(what):
        nonlocal clock
        took[what], clock = round(time.perf_counter() - clock, 1), time.perf_counter()

    src = _copy_source_tree(tmp_path / "src")
    dist = tmp_path / "dist"
    build = subprocess.run([sys.executable, "-m", "build", "--outdir", str(dist), str(src)], capture_output=True,
                           text=True, env=_clean_env())
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    lap("copy + build")
    (wheel,) = dist.glob("afferent_skin-*.whl")
    (sdist,) = dist.glob("afferent_skin-*.tar.gz")

    # what they carry: the packaged sample, never sample_sed/ or tests/data
    names = zipfile.ZipFile(wheel).namelist()
    assert {f"afferent/data/sample/{f}" for f in readme_table()} | {"afferent/data/sample/README.md"} <= set(names)
    assert not [n for n in names if not n.startswith(("afferent/", "afferent_skin-"))], names
    # typed (PEP 561) and licensed: the marker file, the licence text and the metadata naming both
    assert "afferent/py.typed" in names
    assert [n for n in names if n.endswith(".dist-info/licenses/LICENSE")], names
    with zipfile.ZipFile(wheel) as zf:
        meta = zf.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert "License-Expression: BSD-3-Clause" in meta and "License-File: LICENSE" in meta
    assert "Classifier: Programming Language :: Python :: 3.11" in meta and "Classifier: Typing :: Typed" in meta
    import tarfile

    members = tarfile.open(sdist).getnames()
    top = members[0].split("/")[0]
    assert f"{top}/afferent/data/sample/block8/indent_4p00mm.vtu" in members
    assert not [m for m in members if m.startswith((f"{top}/sample_sed", f"{top}/tests/data"))]
    assert wheel.stat().st_size < WHEEL_MAX_BYTES and sdist.stat().st_size < WHEEL_MAX_BYTES
    print(f"wheel {wheel.stat().st_size} bytes, sdist {sdist.stat().st_size} bytes")

    # a venv holding only the wheel; the dependencies come from the running interpreter (module docstring)
    venv = tmp_path / "venv"
    fresh = os.environ.get("AFFERENT_WHEEL_FRESH_VENV") == "1"
    subprocess.run([sys.executable, "-m", "venv", *([] if fresh else ["--without-pip"]), str(venv)], check=True)
    py = venv / "bin" / "python"
    if fresh:
        install = [str(py), "-m", "pip", "install", "-q", str(wheel)]
    else:
        purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                 check=True, capture_output=True, text=True).stdout.strip()
        Path(purelib, "_afferent_test_deps.pth").write_text("\n".join(_dependency_dirs(wheel)) + "\n")
        install = [sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index", str(wheel)]
    inst = subprocess.run(install, capture_output=True, text=True, env=_clean_env())
    assert inst.returncode == 0, inst.stderr[-3000:]
    lap("venv + install")

    work = tmp_path / "elsewhere"
    work.mkdir()
    where = subprocess.run(
        [str(py), "-c", "import afferent, afferent.cli._demo as d; print(afferent.__file__); print(d.default_sample_dir())"],
        cwd=work, capture_output=True, text=True, env=_clean_env(), check=True).stdout.split("\n")
    for line in where[:2]:
        assert Path(line).resolve().is_relative_to(venv.resolve()), where  # the installed wheel, not the source tree
    # the wheel's demo, and meanwhile the source tree's demo on the full sample (the reference)
    demo = subprocess.Popen([str(venv / "bin" / "afferent"), "demo", "-o", "out"], cwd=work, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=_clean_env())
    ref = tmp_path / "ref"
    assert cli_main(["demo", "-o", str(ref), "--sample-dir", str(SAMPLE_DIR), "-q"]) == 0
    stderr = demo.communicate()[1]
    lap("demo from the wheel, demo from the source tree on sample_sed/ (concurrent)")
    assert demo.returncode == 0, stderr[-3000:]
    assert "(installed with the package)" in stderr
    out = work / "out"
    for name, *_ in CASES:
        assert (out / name / "afferents.csv").is_file() and (out / name / "run.json").is_file(), name
    assert (out / "indenters_x.png").stat().st_size > 10_000
    assert (out / "spikes_ramp" / "spikes.csv").is_file()

    # the same numbers
    got, want = pd.read_csv(out / "summary.csv"), pd.read_csv(ref / "summary.csv")
    assert list(got["case"]) == [c[0] for c in CASES]
    assert 100 < want["sed_max_pa"].min() < want["sed_max_pa"].max() < 1e4  # Pa: 221-1819 Pa (sample_sed/README.md)
    pd.testing.assert_frame_equal(got, want, check_exact=False, rtol=1e-12)
    pd.testing.assert_frame_equal(pd.read_csv(out / "findings.csv"), pd.read_csv(ref / "findings.csv"))
    for rel in ["spikes_ramp/spikes.csv", "indent_2p00mm/afferents.csv", "indent_4p00mm/receptors.csv"]:
        pd.testing.assert_frame_equal(pd.read_csv(out / rel), pd.read_csv(ref / rel), check_exact=False, rtol=1e-12)
    assert len(pd.read_csv(out / "spikes_ramp" / "spikes.csv")) > 0

    # never silently over existing results: a second run refuses and leaves them as they were
    before = sha256(out / "summary.csv")
    again = subprocess.run([str(venv / "bin" / "afferent"), "demo", "-o", "out", "-q"], cwd=work, capture_output=True,
                           text=True, env=_clean_env())
    assert again.returncode == 2 and again.stderr.startswith("afferent: error: ") and "--overwrite" in again.stderr
    assert sha256(out / "summary.csv") == before
    lap("refused rerun")
    print("wall time (s):", took)
