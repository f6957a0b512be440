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
    offsets = (np.arange(10) - 4.5) * 0.44e-3
    assert ra.n_receptors == 100 and sa.n_receptors == 90
    assert np.allclose(np.unique(ra.positions[:, 0]), c + offsets) and np.allclose(np.unique(ra.positions[:, 2]), c + offsets)
    assert np.allclose(np.unique(sa.positions[:, 0]), c + np.arange(-4, 5) * 0.44e-3)
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
    """RA-I tips and SA-I bases found on the 3-D export (afferent.receptors.sites_from_export) lie on every
    tabled site's flat top or apex: at its height, within half the flat (papilla top 0.16 mm in x, apex 0.08 mm).

    The finder may return any node of a flat top, not its centre (found: up to 0.08 mm off on the papilla tops)."""
    path = str(CH4 / "ridged3d" / "bar.vtu")
    for kind, name, half_flat in (("tips", "ra_sites.csv", 0.08e-3), ("bases", "sa_sites.csv", 0.04e-3)):
        found = sites_from_export(path, length_unit="mm", upper=1, lower=2, kind=kind).positions
        table = read_receptors(CH4 / "ridged3d" / name, length_unit="mm").positions
        near = np.argmin(np.linalg.norm(table[:, None, :] - found[None, :, :], axis=2), axis=1)
        off = found[near] - table
        assert np.abs(off[:, 1]).max() < 1e-9, kind                     # same height: on the top / apex
        assert np.abs(off[:, 0]).max() <= half_flat + 1e-9, (kind, np.abs(off[:, 0]).max())
        assert np.abs(off[:, 2]).max() <= 0.04e-3 + 1e-9, (kind, np.abs(off[:, 2]).max())


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
    # every found base lies on an apex line x = 2.42 + k 0.44 mm (within the 0.04 mm half-apex)
    k = (sa["x_m"] * 1e3 - 2.42) / 0.44
    assert np.abs(k - np.round(k)).max() * 0.44 <= 0.04 + 1e-9
    assert sa["normalised"].min() == 0.0 and sa["normalised"].max() == 1.0
