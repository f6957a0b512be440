"""The viscoelastic vibration series (sample_sed/vibration/, made by make_vibration.py) read back by
the package, and their scenes (sample_sed/scenes/vibration/, sweep_vibration.toml).

What the series show against the study (SED at an RA-I site vs frequency) is recorded in
sample_sed/README.md, "Vibration series"; it is measured, not asserted here.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import afferent
from afferent.scene import load_scene, run_scene

from conftest import SAMPLE_DIR

VIB = SAMPLE_DIR / "vibration"
SCENES = SAMPLE_DIR / "scenes"
pytestmark = pytest.mark.skipif(not (VIB / "build_info.json").is_file(), reason="vibration series not generated")
SERIES = [f"{m}_{f}Hz" for m in ("3d", "2d") for f in (20, 30, 50, 80)]


@pytest.fixture(scope="module")
def info():
    return json.loads((VIB / "build_info.json").read_text())


def test_every_series_is_on_disk_as_recorded(info):
    for tag in SERIES:
        model = tag.split("_")[0]
        rec = info["models"][model]["series"][tag]
        assert rec["n_steps"] == 61 and rec["dt_s"] == pytest.approx(1.0 / (20 * rec["frequency_Hz"]))
        for name in [f"{tag}/vib.pvd"] + [f"{tag}/vib_{k:03d}.vtu" for k in range(61)]:
            assert (VIB / name).stat().st_size == info["files"][name], name
    assert sum(info["files"].values()) < 10e6


def test_the_receptors_are_the_quarters_table_tips(info):
    """The series are solved on the quarter x, z >= c (c = 2.42 mm) of make_chapter4's block: the receptors are its
    5 x 5 tips of the RA-I table, x, z = c + 0.11 ... 0.99 mm (pitch 0.22 mm), at the tip height 2.50 mm."""
    xyz = np.loadtxt(VIB / "receptors.csv", delimiter=",", skiprows=1)[:, 1:]
    t = 2.42 + np.arange(0.11, 1.0, 0.22)
    np.testing.assert_allclose(xyz[:, 0], np.repeat(t, 5), atol=1e-9)
    np.testing.assert_allclose(xyz[:, 2], np.tile(t, 5), atol=1e-9)
    np.testing.assert_allclose(xyz[:, 1], 2.5, atol=1e-9)
    for model in ("3d", "2d"):
        assert info["models"][model]["mesh"]["n_elements"] == 7560
        assert info["models"][model]["mesh"]["whole_block_elements"] == 30240


@pytest.mark.parametrize("tag", ["3d_80Hz", "2d_20Hz"])
def test_the_package_reads_the_recorded_sed_at_the_deepest_points(info, tag):
    """The dermis-side SED the generator recorded at the site (build_info, float64) is what the package samples
    from the series' cell SED (float32 in the VTU) with side=2 at each deepest point (t = T/4, 5T/4, 9T/4), and
    no value is negative (the stored energy, not 1/2 sigma:eps)."""
    rec = info["models"][tag.split("_")[0]]["series"][tag]
    field = afferent.read_sed(str(VIB / tag / "vib.pvd"), length_unit="mm", sed_unit="MPa", location="cell")
    assert field.sed.shape[0] == 61 and field.sed.min() >= 0
    layout = afferent.read_receptors(str(VIB / "receptors.csv"), length_unit="mm")
    s = afferent.sample_sed(field, layout, side=2)                   # (61, 25) Pa
    assert s.interface["n_changed"] == 25 and s.interface["separable"]
    s = s.values
    d = rec["deepest"]
    k = [round(t / rec["dt_s"]) for t in d["deepest_t_s"]]
    assert k == [5, 25, 45]
    # the generator weights the dermis cells by their volume from 2 x 2 x 2 Gauss points, the package by its own
    # cell volumes: 2e-4 apart on the curved pegs
    np.testing.assert_allclose(s[k, d["site"]["index"]], d["site_SED_Pa"], rtol=5e-4)
    depths = [rec["steps"][i]["depth_mm"] for i in k]
    np.testing.assert_allclose(depths, 0.5)
    # the point SED at the tips (what the reader takes without location='cell') is the average across epidermis and
    # dermis, 1-5 % off the dermis side at this site: side=2 on it is refused
    point = afferent.read_sed(str(VIB / tag / "vib.pvd"), length_unit="mm", sed_unit="MPa")
    with pytest.raises(ValueError, match=r"side=2 asks for material 2's SED at the 25 receptors"):
        afferent.sample_sed(point, layout, side=2)
    avg = afferent.sample_sed(point, layout).values
    assert np.max(np.abs(avg[k, d["site"]["index"]] / np.asarray(d["site_SED_Pa"]) - 1.0)) > 0.03


def test_the_vibration_sweep_lists_the_eight_scenes():
    from afferent._sweep.spec import load_sweep

    spec = load_sweep(str(SCENES / "sweep_vibration.toml"))
    assert sorted(t.label for t in spec.tasks) == sorted(f"ridged{t}" for t in SERIES)


@pytest.mark.slow
def test_a_vibration_scene_runs_to_spikes(tmp_path, info):
    res = run_scene(load_scene(SCENES / "vibration" / "ridged3d_80Hz.toml").with_output(tmp_path / "r"),
                    cache_dir=tmp_path / "c")
    skipped = {s["stage"]: s["reason"] for s in res.record["skipped"]}
    assert skipped["stimulus"].startswith("the scene has no [stimulus] waveform")
    assert (tmp_path / "r" / "spike_summary.csv").is_file()
    # its sed_map.csv holds the SED at the edge site at the deepest points that build_info records
    import pandas as pd

    d = info["models"]["3d"]["series"]["3d_80Hz"]["deepest"]
    m = pd.read_csv(tmp_path / "r" / "sed_map.csv")
    at = m[(abs(m.x_m - d["site"]["x"] * 1e-3) < 1e-9) & (abs(m.z_m - d["site"]["z"] * 1e-3) < 1e-9)]
    np.testing.assert_allclose(at.sort_values("time_s").sed_pa.to_numpy()[[5, 25, 45]], d["site_SED_Pa"], rtol=5e-4)
