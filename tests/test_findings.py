"""Every headline claim of the study's chapters 4 and 5 is in the demo's findings, with a verdict computed from the
sample's numbers (afferent.findings, afferent.cli._demo.study_findings; issue 35, item A)."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from afferent.findings import CHAPTER4_CLAIMS, FREQUENCIES_HZ, INDENTERS, chapter4_findings, measure_chapter4

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_DIR = ROOT / "sample_sed"
PACKAGED = ROOT / "afferent" / "data" / "sample"


@pytest.fixture(scope="module")
def measured():
    if not (SAMPLE_DIR / "chapter4").is_dir():
        pytest.skip("sample_sed/chapter4 is not in this checkout")
    return measure_chapter4(SAMPLE_DIR)


def _verdicts(m) -> dict:
    return {r["claim"]: r["holds"] for r in chapter4_findings(m)}


def test_every_chapter4_claim_is_listed_with_numbers_and_criterion(measured):
    rows = chapter4_findings(measured)
    assert [r["claim"] for r in rows] == list(CHAPTER4_CLAIMS)
    for r in rows:
        assert set(r) == {"claim", "finding", "study", "sample", "criterion", "holds", "note"}
        assert isinstance(r["holds"], bool) and r["finding"].startswith("ch. 4") and any(c.isdigit() for c in r["sample"])
    assert "4.4.2" in rows[CHAPTER4_CLAIMS.index("x_equal")]["finding"]
    assert "4.4.2" in rows[CHAPTER4_CLAIMS.index("z_more_3d")]["finding"]


def test_the_packaged_sample_gives_the_same_chapter4_numbers(measured):
    """The packaged crop (chapter4/ cropped to the sites, vibration/ as XDMF time series) measures as sample_sed/."""
    small = measure_chapter4(PACKAGED)
    for key, v in measured["maps"].items():
        np.testing.assert_allclose(small["maps"][key], v, rtol=1e-6, err_msg=str(key))
    for model, per in measured["vibration"].items():
        for f, v in per.items():
            np.testing.assert_allclose(small["vibration"][model][f], v, rtol=1e-6)


def test_focalizing_verdict_follows_the_peak_ratio(measured):
    m = copy.deepcopy(measured)
    for ind in INDENTERS:
        m["maps"][("3d", "ra", ind)] = m["maps"][("2d", "ra", ind)] * 1.05
    assert _verdicts(m)["focalizing"]
    m["maps"][("3d", "ra", "circle")] = m["maps"][("2d", "ra", "circle")] * 0.99  # one indenter below: fails
    row = next(r for r in chapter4_findings(m) if r["claim"] == "focalizing")
    assert not row["holds"] and "circle 0.990" in row["sample"]


def test_separation_verdicts_follow_the_map_distances(measured):
    m = copy.deepcopy(measured)
    for ind in INDENTERS:  # the 2-D maps all the bar's: it tells nothing apart
        m["maps"][("2d", "ra", ind)] = m["maps"][("2d", "ra", "bar")] + 0.01 * np.arange(m["maps"][("2d", "ra", "bar")].size)
    v = _verdicts(m)
    assert v["separates"] and v["solid_vs_gap"]
    m["maps"][("2d", "ra", "gap")] = m["maps"][("3d", "ra", "circle")]  # 2-D bar-gap now far apart
    assert not _verdicts(m)["solid_vs_gap"]


def test_edges_vs_corners_verdict_follows_where_the_peaks_are(measured):
    m = copy.deepcopy(measured)
    pos = m["pos"][("3d", "ra")]
    edge = int(np.argmin(np.hypot(np.abs(pos[:, 0]) - 1.1, pos[:, 1])))  # beside an x edge, z centred
    corner = int(np.argmin(np.hypot(np.abs(pos[:, 0]) - 1.1, np.abs(pos[:, 1]) - 1.1)))
    m["maps"][("3d", "ra", "bar")][edge] = m["maps"][("2d", "ra", "bar")][corner] = 1e4
    assert _verdicts(m)["edges_vs_corners"]
    m["maps"][("2d", "ra", "bar")][edge] = 2e4
    assert not _verdicts(m)["edges_vs_corners"]


def test_vibration_verdicts_follow_the_sed_at_the_deepest_points(measured):
    m = copy.deepcopy(measured)
    m["vibration"]["2d"] = {f: (300.0, 300.0) for f in FREQUENCIES_HZ}
    m["vibration"]["3d"] = {f: (300.0 + f, 300.0) for f in FREQUENCIES_HZ}
    v = _verdicts(m)
    assert v["vibration_3d_rises"] and v["vibration_2d_flat"]
    m["vibration"]["2d"][80] = (330.0, 300.0)  # +10 %: not flat
    m["vibration"]["3d"][50] = (300.0, 300.0)  # falls from 30 to 50 Hz: not rising at every step
    v = _verdicts(m)
    assert not v["vibration_3d_rises"] and not v["vibration_2d_flat"]
    del m["vibration"]
    rows = {r["claim"]: r for r in chapter4_findings(m)}
    assert not rows["vibration_2d_flat"]["holds"] and rows["vibration_2d_flat"]["sample"].startswith("not measured")


def test_x_and_z_verdicts_follow_the_contrast(measured):
    """4.4.2: equally noticeable along x in both models, more significant along z in 3-D; a shallower valley along z
    in the 2-D map (sites on the central z lines, nearest the centre, raised to the map's top) turns z_more_3d on."""
    m = copy.deepcopy(measured)
    pos = m["pos"][("3d", "ra")]
    m["maps"][("2d", "ra", "bar")] = m["maps"][("3d", "ra", "bar")].copy()
    v = _verdicts(m)
    assert v["x_equal"] and not v["z_more_3d"]
    ax = np.abs(pos[:, 0])
    centre_col = np.isclose(ax, ax.min())
    flat = m["maps"][("2d", "ra", "bar")]
    inner = centre_col & (np.abs(pos[:, 1]) < 0.5)
    flat[inner] = flat.max()
    assert _verdicts(m)["z_more_3d"]


def test_chapter5_branching_claim_is_decided_on_the_rows():
    from afferent.cli._demo import study_findings

    def rows(lon_2mm):
        out = []
        for w, zone, lon in [(0.44, False, 1), (0.88, False, 1), (1.32, True, 1), (2.0, True, lon_2mm), (4.0, True, 2)]:
            out.append({"indenter_mm": w, "sed_max_pa": 300.0, "interchange_zone": zone, "afferent_peaks_longitudinal": lon,
                        "afferent_peaks_cross": 1, "peak_prominence": 0.05})
        return out

    def branching(r):
        return next(f for f in study_findings(r) if f["claim"] == "ch5_branching_fills_zone")

    assert branching(rows(1))["holds"]
    row = branching(rows(2))
    assert not row["holds"] and "2 (2 mm)" in row["sample"]


def test_the_demo_lists_every_claim_of_both_chapters(tmp_path):
    """findings.csv of afferent demo (packaged sample) holds every claim key, each with a verdict."""
    import pandas as pd

    from afferent.cli import main

    assert main(["demo", "-o", str(tmp_path / "d"), "-q"]) == 0
    f = pd.read_csv(tmp_path / "d" / "findings.csv")
    want = {"ch5_sed_scale", "ch5_interchange_width", "ch5_peaks_longitudinal_0.88mm", "ch5_peaks_longitudinal_4mm",
            "ch5_peaks_cross_0.88mm", "ch5_peaks_cross_4mm", "ch5_branching_fills_zone", *CHAPTER4_CLAIMS}
    assert set(f["claim"]) == want and f["holds"].isin([True, False]).all()
    assert not f.loc[f["claim"] == "ch5_interchange_width", "holds"].item()  # the sample's 1.32 mm, listed as failing


def test_the_maps_read_the_dermis_side_of_the_cell_sed(measured):
    """STUDY_SIDE reads the dermis cells at a site node. The samples also carry a nodal SED averaged across the
    materials, which the reader prefers and on which a side changes nothing: the maps must not be that average."""
    import warnings

    import afferent
    from afferent.findings import STUDY_SIDE

    vtu = SAMPLE_DIR / "chapter4" / "ridged3d" / "bar.vtu"
    layout = afferent.read_receptors(str(SAMPLE_DIR / "chapter4" / "ridged3d" / "ra_sites.csv"), length_unit="mm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dermis = afferent.sample_sed(afferent.read_sed(str(vtu), length_unit="mm", sed_unit="MPa", location="cell"),
                                     layout, side=STUDY_SIDE).values[-1]
    average = afferent.sample_sed(afferent.read_sed(str(vtu), length_unit="mm", sed_unit="MPa"), layout).values[-1]
    assert STUDY_SIDE == 2 and np.median(np.abs(dermis / average - 1.0)) > 0.05
    np.testing.assert_allclose(measured["maps"][("3d", "ra", "bar")], dermis, rtol=1e-9)
