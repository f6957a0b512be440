"""``afferent report``: every section, every plot, sane figures; the output folder is never overwritten silently.

The report runs once per session at the ``'tiny'`` size (a few seconds); its figures are checked
against what each measurement must give whatever the machine: the exact engine against itself
(and its numpy backend) has no error, ``'linear'`` sampling beats ``'nearest'`` on a smooth
field, streamed and whole reads give the same SED, least squares recovers noise-free parameters.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from afferent.cli import main
from afferent.report import SECTIONS, SIZES, hex_block, machine_info, run_report


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "rep"
    results = run_report(out, size="tiny")
    return out, results, (out / "report.md").read_text(encoding="utf-8")


@pytest.mark.slow  # brian2 runs and calibration loops (a few seconds)
def test_report_has_every_section_and_plot(report):
    out, _, md = report
    headings = re.findall(r"^## (.+)$", md, flags=re.M)
    assert headings == [title for _, title in SECTIONS]
    pngs = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert sorted(pngs) == ["calibration.png", "receptors.png", "sampling.png", "series.png", "spiking.png"]
    for name in pngs:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((out / "results.json").read_text())["size"]["name"] == "tiny"
    assert "Written by `afferent report -o " in md


@pytest.mark.slow
def test_report_figures_are_sane(report):
    _, r, md = report
    sampling = {row["method"]: row for row in r["sampling"]}
    assert sampling["linear"]["err_median"] < sampling["nearest"]["err_median"]
    assert sampling["linear"]["err_max"] < sampling["nearest"]["err_max"]
    assert all(np.isfinite(row[k]) for row in r["sampling"] for k in ("err_max", "weights_s", "per_step_s"))
    spiking = {(row["engine"], row["dt_s"]): row for row in r["spiking"]}
    exact = spiking["exact", None]
    assert exact["rate_err_median"] == exact["spike_err_max_s"] == exact["count_differs"] == 0 and exact["spikes"] > 0
    if ("exact-numpy", None) in spiking:  # numba installed: the numpy backend gives the same spikes to rounding
        assert spiking["exact-numpy", None]["rate_err_max"] == 0
        assert spiking["exact-numpy", None]["spike_err_max_s"] < 1e-9
    coarse, fine = spiking["fast", 1e-3], spiking["fast", 1e-4]
    assert coarse["rate_err_median"] > fine["rate_err_median"] > 0  # the grid error falls with dt
    assert fine["latency_err_max_s"] <= 1e-4 + 1e-12  # a first spike is at most one step off
    cf = r["closed_form"]
    assert abs(cf["exact_hz"] - cf["closed_form_hz"]) <= 1.0  # whole spikes in 1 s
    counts = r["receptors"]
    assert counts[-1]["profile_error"] == 0 and counts[0]["profile_error"] > 0
    ls = [row for row in r["calibration"] if row["method"] == "least_squares"]
    assert ls and all(max(row[f"err_{p}"] or 0 for p in ("alpha", "gamma", "lambda")) < 1e-5 for row in ls)
    series = r["series"]
    assert all(row["max_diff_pa"] == 0 for row in series)
    assert "linear" in md and "| exact | " in md


def test_machine_info_names_every_version():
    info = machine_info()
    assert set(info["versions"]) >= {"python", "numpy", "scipy", "brian2", "numba", "afferent"}
    assert info["cpus"] >= 1


def test_hex_block_cells_have_unit_volume_in_vtk_order():
    points, hexes = hex_block(2, 1, 3, size=(2.0, 1.0, 3.0))
    assert points.shape == (3 * 2 * 4, 3) and hexes.shape == (6, 8)
    p = points[hexes]  # (6, 8, 3): edges from node 0 along x, y, z (VTK order: 1, 3, 4)
    vol = np.einsum("ij,ij->i", p[:, 1] - p[:, 0], np.cross(p[:, 3] - p[:, 0], p[:, 4] - p[:, 0]))
    np.testing.assert_allclose(vol, 1.0)


def test_report_refuses_existing_folder(tmp_path, capsys):
    out = tmp_path / "rep"
    out.mkdir()
    code = main(["report", "-o", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err == f"afferent: error: Output folder {str(out)!r} already exists; pass --overwrite to replace it.\n"
    assert list(out.iterdir()) == []


def test_report_size_is_checked(tmp_path):
    with pytest.raises(ValueError, match=r"'size' must be one of \['full', 'quick', 'tiny'\]; got 'huge' instead."):
        run_report(tmp_path / "x", size="huge")
    assert set(SIZES) == {"tiny", "quick", "full"}


def test_spiking_without_brian2_says_so(monkeypatch):
    import afferent.report as report
    import afferent.report.measure as measure
    from afferent.spiking import LIF_PRESETS

    monkeypatch.setattr(measure, "_has_brian2", lambda: False)
    times, current = report.synthetic_afferent_current(5, duration=0.2)
    rows = report.measure_spiking(current, times, 0.2, LIF_PRESETS["ra"], fast_dts=(1e-4,), brian2_dts=(1e-3,), repeat=1)
    assert rows[-1] == {"engine": "brian2", "backend": None, "dt_s": None, "wall_s": None, "spikes": None,
                        "skipped": "brian2 does not import"}
    assert [r["engine"] for r in rows if r["engine"] == "fast"] == ["fast"]


@pytest.mark.slow
def test_report_renders_without_brian2(report, tmp_path):
    """A machine without brian2: its rows say skipped, the plots and headline leave it out."""
    import afferent.report.render as rep

    _, results, _ = report
    results = dict(results, spiking=[r for r in results["spiking"] if r["engine"] != "brian2"]
                   + [{"engine": "brian2", "backend": None, "dt_s": None, "wall_s": None, "spikes": None,
                       "skipped": "brian2 does not import"}])
    results["headline"] = rep.headline(results)
    assert not any(k.startswith("brian2") for k in results["headline"])
    png = rep._plots(results, str(tmp_path))
    md = rep._markdown(results, SIZES["tiny"], png, "afferent report -o x")
    assert "| brian2 | - | none | - | - | skipped: brian2 does not import |" in md


def test_series_files_are_meshios_bytes_with_one_meshio_write(tmp_path, monkeypatch):
    """The report's generated series (45 VTUs of 101k nodes, quick size) took meshio's zlib compression of
    the same mesh once per step; now the mesh is compressed once and each step's SED array spliced in.
    The files must be exactly what meshio.write gives for every step."""
    import meshio

    from afferent.report import write_series
    from afferent.report.measure import block_dims, manufactured_sed

    calls = []
    original = meshio.write
    monkeypatch.setattr(meshio, "write", lambda *a, **k: (calls.append(a[0]), original(*a, **k))[1])
    paths = write_series(tmp_path, 3_000, 4)
    assert len(calls) == 1 and len(paths) == 4
    monkeypatch.setattr(meshio, "write", original)
    points, hexes = hex_block(*block_dims(3_000))
    base = manufactured_sed(points * 1e-3 + [0.0, 2.45e-3 - 3.1e-3, 0.0]) / 1e6
    for k, path in enumerate(paths):
        expected = tmp_path / f"meshio_{k}.vtu"
        meshio.write(expected, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": (k + 1) / 4 * base}),
                     binary=True, compression="zlib")
        assert expected.read_bytes() == open(path, "rb").read(), path
        np.testing.assert_array_equal(meshio.read(path).point_data["SED"], (k + 1) / 4 * base)
