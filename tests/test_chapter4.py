"""The chapter-4 samples (sample_sed/chapter4, made by sample_sed/make_chapter4.py; see sample_sed/README.md,
"Chapter 4") read back through the package: site tables, the generator's recorded SED, the site finder."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import afferent
from afferent.receptors import read_receptors, sites_from_export

CH4 = Path(__file__).resolve().parents[1] / "sample_sed" / "chapter4"
INDENTERS = ("bar", "gap", "gap90", "circle")
MODELS = ("3d", "2d")

pytestmark = pytest.mark.skipif(not (CH4 / "build_info.json").is_file(), reason="sample_sed/chapter4 not generated")


def _info():
    return json.loads((CH4 / "build_info.json").read_text())


@pytest.mark.parametrize("model", MODELS)
def test_site_tables_are_the_stated_grids(model):
    ra = read_receptors(CH4 / f"ridged{model}" / "ra_sites.csv", length_unit="mm")
    sa = read_receptors(CH4 / f"ridged{model}" / "sa_sites.csv", length_unit="mm")
    c = 2.42e-3
    offsets = (np.arange(10) - 4.5) * 0.22e-3  # every tip: the inner 10 x 10 of the 144 (sample_sed/README.md)
    assert ra.n_receptors == 100 and sa.n_receptors == 90
    assert np.allclose(np.unique(ra.positions[:, 0]), c + offsets) and np.allclose(np.unique(ra.positions[:, 2]), c + offsets)
    assert np.allclose(np.unique(sa.positions[:, 0]), c + np.arange(-4, 5) * 0.22e-3)
    assert np.allclose(ra.positions[:, 1], 2.50e-3) and np.allclose(sa.positions[:, 1], 2.35e-3)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("indenter", INDENTERS)
def test_sampled_sed_is_what_the_generator_recorded(model, indenter):
    """Read as mm / MPa, the SED at the site nodes (Pa) is the generator's (build_info.json, float32 export)."""
    field = afferent.read_sed(CH4 / f"ridged{model}" / f"{indenter}.vtu", length_unit="mm", sed_unit="MPa")
    case = _info()["models"][model]["cases"][indenter]
    for table, name in (("ra_table", "ra_sites.csv"), ("sa_table", "sa_sites.csv")):
        layout = read_receptors(CH4 / f"ridged{model}" / name, length_unit="mm")
        sed = afferent.sample_sed(field, layout, method="nearest").values[0]
        rec = case[table]
        assert sed.max() == pytest.approx(rec["max_Pa"], rel=1e-6)
        assert np.median(sed) == pytest.approx(rec["median_Pa"], rel=1e-6)


def test_site_finder_finds_every_tabled_site_on_the_3d_export():
    """RA-I tips and SA-I bases found on the 3-D export (afferent.receptors.sites_from_export, with the block's
    0.22 mm intermediate-ridge pitch) are every tabled site, exactly (the pegs' tips are single nodes), and the
    tips found are the 12 x 12 of the block plus the ring the crop keeps (14 x 14).

    With the finder's default pitch (0.44 mm, one papilla row per fingerprint) every second row is missed."""
    path = str(CH4 / "ridged3d" / "bar.vtu")
    for kind, name in (("tips", "ra_sites.csv"), ("bases", "sa_sites.csv")):
        found = sites_from_export(path, length_unit="mm", upper=1, lower=2, kind=kind, pitch_x=0.22e-3).positions
        table = read_receptors(CH4 / "ridged3d" / name, length_unit="mm").positions
        gap = np.min(np.linalg.norm(table[:, None, :] - found[None, :, :], axis=2), axis=1)
        assert gap.max() < 1e-12, (kind, gap.max())
        if kind == "tips":
            assert len(found) == 14 * 14
            every = np.asarray(json.loads((CH4 / "build_info.json").read_text())["models"]["3d"]["sites"]["all_tips_xyz_mm"])
            assert len(every) == 144
            assert np.min(np.linalg.norm(every[:, None, :] * 1e-3 - found[None], axis=2), axis=1).max() < 1e-12
    coarse = sites_from_export(path, length_unit="mm", upper=1, lower=2, kind="tips").positions
    assert len(coarse) < len(found) / 1.5


def test_hotspots_beside_bases_found_on_the_export(tmp_path, monkeypatch):
    """``hotspot_beside = "bases"``: the second map's sites are the SA-I apexes the finder gives (run.json says SA-I)."""
    import pandas as pd

    from afferent.scene import load_scene, run_scene

    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(f"""
[export]
file = {str(CH4 / "ridged3d" / "bar.vtu")!r}
length_unit = "mm"
sed_unit = "MPa"

[receptors]
file = {str(CH4 / "ridged3d" / "ra_sites.csv")!r}
pitch_x_mm = 0.22

[region]
x_range_mm = [0.4, 4.45]
z_range_mm = [0.4, 4.45]

[outputs]
want = ["hotspots"]
hotspot_beside = "bases"
""")
    res = run_scene(load_scene(tmp_path / "s.toml"), cache_dir=tmp_path / "cache")
    t = pd.read_csv(tmp_path / "results" / "s" / "hotspots.csv")
    sa = t[t["map"] == "SA-I"]
    assert res.record["hotspots_beside"]["receptors"]["site"] == "SA-I" and len(sa) > 90
    # every found base lies on an apex line x = 2.42 + k 0.22 mm
    k = (sa["x_m"] * 1e3 - 2.42) / 0.22
    assert np.abs(k - np.round(k)).max() * 0.22 <= 1e-6
    assert sa["normalised"].min() == 0.0 and sa["normalised"].max() == 1.0
