"""Hot-spot maps (chapter 4): normalisation, map distance and classifier against closed forms; the
``hotspots`` scene output on the packaged sample; ``afferent hotspots``."""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from afferent.hotspots import (compare_runs, distance_table, group_runs, hotspot_table, map_distance,
                               nearest_centroid_accuracy, normalise_map)
from afferent.scene import SceneError, load_scene, run_scene

ROOT = Path(__file__).resolve().parents[1]
PACKAGED = ROOT / "afferent" / "data" / "sample" / "block4"
EXPORT = PACKAGED / "indent_0p88mm.vtu"
RECEPTORS = PACKAGED / "receptors.csv"


# ------------------------------------------------------------------ closed forms
def test_normalise_map_min_max_and_its_errors():
    assert np.allclose(normalise_map([2.0, 4.0, 3.0]), [0.0, 1.0, 0.5])
    with pytest.raises(ValueError, match=r"tips: every site has the same SED \(5.0\)"):
        normalise_map([5.0, 5.0], name="tips")
    with pytest.raises(ValueError, match=r"m: every site needs a finite SED; site 1 has nan"):
        normalise_map([1.0, np.nan], name="m")
    with pytest.raises(ValueError, match="at least one site"):
        normalise_map([])


@pytest.mark.parametrize("a, b, expected", [
    ([0, 1, 2, 5], [0, 1, 2, 5], 0.0),                   # identical maps
    ([0, 1, 2, 5], [3, 5, 7, 13], 0.0),                  # b = 2 a + 3: same normalised map
    ([0, 1, 2, 5], [0, -1, -2, -5], 2.0),                # opposite
    ([0, 1, 0, 1], [0, 0, 1, 1], 1.0),                   # centred maps orthogonal: r = 0
    ([0, 1, 2], [0, 2, 1], 0.5),                         # r = 1/2 by hand
])
def test_map_distance_closed_forms(a, b, expected):
    assert map_distance(a, b) == pytest.approx(expected, abs=1e-12)


def test_map_distance_needs_the_same_sites():
    with pytest.raises(ValueError, match="maps over different sites: 3 and 2 values"):
        map_distance([0, 1, 2], [0, 1])


def test_distance_table_is_symmetric_with_zero_diagonal():
    t = distance_table({"a": [0, 1, 2], "b": [0, 2, 1], "c": [2, 1, 0]})
    assert list(t.index) == ["a", "b", "c"]
    assert np.allclose(t.to_numpy(), t.to_numpy().T) and np.allclose(np.diag(t), 0.0)
    assert t.loc["a", "c"] == pytest.approx(2.0) and t.loc["a", "b"] == pytest.approx(0.5)


def test_nearest_centroid_accuracy_matches_the_two_class_closed_form():
    # templates [0, 1] and [1, 0]: Euclidean distance D = sqrt(2); accuracy Phi(D / (2 sigma))
    sigma = 0.5
    acc = nearest_centroid_accuracy({"a": [0.0, 1.0], "b": [1.0, 0.0]}, noise=sigma, trials=20000, seed=1)
    expected = 0.5 * (1.0 + math.erf(math.sqrt(2.0) / (2.0 * sigma) / math.sqrt(2.0)))
    assert acc == pytest.approx(expected, abs=0.01)
    # identical maps cannot be told apart: chance (ties go to the first template)
    assert nearest_centroid_accuracy({"a": [0, 1, 2], "b": [0, 1, 2]}, noise=0.1, trials=500) == pytest.approx(0.5)
    # far apart relative to the noise: always right
    assert nearest_centroid_accuracy({"a": [0, 1], "b": [1, 0]}, noise=0.01, trials=500) == 1.0
    with pytest.raises(ValueError, match="noise must be > 0"):
        nearest_centroid_accuracy({"a": [0, 1], "b": [1, 0]}, noise=0.0)
    with pytest.raises(ValueError, match="at least two maps; got 1"):
        nearest_centroid_accuracy({"a": [0, 1]}, noise=0.1)


def test_hotspot_table_flags_sites_at_or_above_the_threshold():
    pos = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], float) * 1e-3
    t = hotspot_table(["a", "b", "c", "d"], pos, [10.0, 16.0, 20.0, 14.0], threshold=0.6, site="RA-I")
    assert list(t.columns) == ["site_kind", "site", "x_m", "z_m", "sed_pa", "normalised", "hot"]
    assert np.allclose(t["normalised"], [0.0, 0.6, 1.0, 0.4])
    assert list(t["hot"]) == [False, True, True, False]
    with pytest.raises(ValueError, match=r"threshold must be within 0..1 \(normalised SED\); got 1.5"):
        hotspot_table(["a", "b"], pos[:2], [1.0, 2.0], threshold=1.5)


def _runs():
    sites = pd.DataFrame({"x_m": [0.0, 1e-3, 2e-3], "z_m": [0.0, 0.0, 0.0]})
    def run(values, kind="ra"):
        return sites.assign(map=kind, sed_pa=values)
    return {"m3_bar": run([1.0, 2.0, 3.0]), "m3_gap": run([3.0, 2.0, 1.0]), "m2_bar": run([1.0, 2.0, 3.0]),
            "m2_gap": run([1.0, 2.1, 3.0])}


def test_compare_runs_per_group_and_map():
    dist, acc = compare_runs(_runs(), {"3d": "m3_*", "2d": "m2_*"}, noise=0.05, trials=400)
    d = dist.set_index("group")["distance"]
    assert d["3d"] == pytest.approx(2.0) and d["2d"] == pytest.approx(0.00166, abs=1e-4)
    a = acc.set_index("group")
    assert a.loc["3d", "accuracy"] == 1.0 and a.loc["3d", "chance"] == 0.5
    assert a.loc["2d", "accuracy"] < 0.9
    with pytest.raises(ValueError, match=r"group 'x': pattern 'q\*' matches none of the runs"):
        group_runs(["a"], {"x": "q*"})
    runs = _runs()
    runs["m3_gap"] = runs["m3_gap"].assign(x_m=[0.0, 1e-3, 5e-3])
    with pytest.raises(ValueError, match="run 'm3_gap' maps other sites than 'm3_bar'"):
        compare_runs(runs, {"3d": "m3_*"})


# ------------------------------------------------------------ the scene output
def _scene(folder: Path, extra: str) -> Path:
    path = folder / "hot.toml"
    path.write_text(textwrap.dedent(f"""
        [export]
        file = {str(EXPORT)!r}
        length_unit = "mm"
        sed_unit = "MPa"

        [receptors]
        file = {str(RECEPTORS)!r}

        [outputs]
        want = ["hotspots", "plots"]
        """) + textwrap.dedent(extra))
    return path


def test_hotspots_output_maps_the_scene_sites_and_a_second_set_beside(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                               # the default output folder: results/<name>
    beside = tmp_path / "some_sites.csv"
    rows = RECEPTORS.read_text().splitlines()
    beside.write_text("\n".join(rows[:31]) + "\n")           # header + the first 30 tips
    scene = load_scene(_scene(tmp_path, f"hotspot_threshold = 0.7\nhotspot_beside_file = {str(beside)!r}\n"))
    res = run_scene(scene, cache_dir=tmp_path / "cache")
    assert {"hotspots.csv", "hotspots.png", "run.json"} <= set(res.files)
    t = pd.read_csv(Path(res.output) / "hotspots.csv")
    n = len(rows) - 1
    assert list(t["map"].unique()) == ["receptors.csv", "some_sites.csv"]
    assert (t["map"] == "receptors.csv").sum() == n and (t["map"] == "some_sites.csv").sum() == 30
    for _, m in t.groupby("map"):
        assert m["normalised"].min() == 0.0 and m["normalised"].max() == 1.0
        assert (m["hot"] == (m["normalised"] >= 0.7)).all()
    # the same SED at the shared sites, and the scene's SED (Pa) at its own sites
    first = t[t["map"] == "receptors.csv"].reset_index(drop=True)
    second = t[t["map"] == "some_sites.csv"].reset_index(drop=True)
    assert np.allclose(first["sed_pa"][:30], second["sed_pa"])
    assert np.allclose(first["sed_pa"], res.sed.values[-1])
    record = json.loads((Path(res.output) / "run.json").read_text())
    assert record["hotspots_beside"]["receptors"]["source"] == str(beside)
    # issue 37: the maps for ParaView, the values at the sites as receptors.vtu holds them
    import meshio

    vtu = meshio.read(Path(res.output) / "hotspots.vtu")
    assert "hotspots.vtu" in res.files and len(vtu.points) == len(t) == len(vtu.cells_dict["vertex"])
    np.testing.assert_allclose(vtu.points[:, [0, 2]], t[["x_m", "z_m"]].to_numpy(), rtol=1e-15)
    for name in ("sed_pa", "normalised"):
        np.testing.assert_allclose(vtu.point_data[name], t[name], rtol=1e-15, err_msg=name)
    np.testing.assert_array_equal(vtu.point_data["hot"], t["hot"].astype(int))
    np.testing.assert_array_equal(vtu.point_data["map"], (t["map"] == "some_sites.csv").astype(int))


@pytest.mark.parametrize("extra, message", [
    ("hotspot_threshold = 1.5\n", r"'hotspot_threshold' is a normalised SED and must be within 0..1; got 1.5"),
    ('hotspot_beside = "bases"\nhotspot_beside_file = "x.csv"\n', "at most one of 'hotspot_beside'"),
])
def test_hotspot_keys_checked(tmp_path, extra, message):
    with pytest.raises(SceneError, match=message):
        load_scene(_scene(tmp_path, extra))


def test_hotspot_keys_need_the_hotspots_output(tmp_path):
    path = _scene(tmp_path, "hotspot_threshold = 0.5\n")
    path.write_text(path.read_text().replace('want = ["hotspots", "plots"]', 'want = ["sed_map"]'))
    with pytest.raises(SceneError, match=r"\[outputs\] 'hotspot_threshold' applies to want = \[..., 'hotspots'\]"):
        load_scene(path)


def test_cli_hotspots_tabulates_runs_and_errors_in_one_line(tmp_path, capsys):
    from afferent.cli import main

    for name, values in (("a_one", [1.0, 2.0, 3.0]), ("a_two", [3.0, 2.0, 1.0])):
        d = tmp_path / "runs" / name
        d.mkdir(parents=True)
        hotspot_table(["1", "2", "3"], np.eye(3) * 1e-3, values, site="RA-I").assign(map="RA-I").to_csv(
            d / "hotspots.csv", index=False)
    runs = sorted(map(str, (tmp_path / "runs").iterdir()))
    assert main(["hotspots", *runs, "-o", str(tmp_path / "out"), "--trials", "200", "--noise", "0.1,5"]) == 0
    dist = pd.read_csv(tmp_path / "out" / "distances.csv")
    assert dist["distance"].tolist() == pytest.approx([2.0])
    assert pd.read_csv(tmp_path / "out" / "accuracy.csv")["accuracy"].tolist()[0] == 1.0
    assert (tmp_path / "out" / "summary.png").is_file() and (tmp_path / "out" / "distances.png").is_file()
    capsys.readouterr()
    assert main(["hotspots", *runs, "-o", str(tmp_path / "out2"), "--group", "nonsense"]) == 2
    assert capsys.readouterr().err.strip() == ("afferent: error: --group must be NAME=PATTERN (e.g. 3d='ridged3d_*'); "
                                               "got 'nonsense' instead.")
    assert main(["hotspots", str(tmp_path / "runs"), "-o", str(tmp_path / "out3")]) == 2
    assert "no hotspots.csv; expected the output folder of a run" in capsys.readouterr().err


# ------------------------------------------------------------ issue 33, items 11 and 13: damaged runs
def _run_folders(tmp_path, n=3):
    folders = []
    for k in range(n):
        d = tmp_path / "runs" / f"r{k}"
        d.mkdir(parents=True)
        values = np.roll([1.0, 2.0, 3.0], k)
        hotspot_table(["1", "2", "3"], np.eye(3) * 1e-3, values, site="RA-I").assign(map="RA-I").to_csv(
            d / "hotspots.csv", index=False)
        folders.append(d)
    return folders


@pytest.mark.parametrize("damage, message", [
    (lambda d: (d / "hotspots.csv").write_text((d / "hotspots.csv").read_text().replace(",2.0,", ",abc,")),
     "Run table '{d}/hotspots.csv': column 'sed_pa' must hold finite numbers; got 'abc' on data row "),
    (lambda d: (d / "hotspots.csv").write_bytes((d / "hotspots.csv").read_bytes() + b"RA-I,\xe9,0,0,1,0,False,RA-I\n"),
     "Run table '{d}/hotspots.csv' could not be read as UTF-8 CSV ("),
    (lambda d: (d / "hotspots.csv").write_text(""),
     "Run table '{d}/hotspots.csv' is empty; expected the 'hotspots' output of a run (hotspots.csv)."),
    (lambda d: (d / "hotspots.csv").write_text((d / "hotspots.csv").read_text().splitlines()[0] + "\n"),
     "Run table '{d}/hotspots.csv' has no rows; expected the 'hotspots' output of a run (hotspots.csv)."),
    (lambda d: (d / "hotspots.csv").write_text("site,x_m\n1,0\n"),
     "Run table '{d}/hotspots.csv' lacks the column(s) ['z_m', 'sed_pa', 'map']; expected the 'hotspots' output"),
    (lambda d: (d / "run.json").write_text("{broken"),
     "Run record '{d}/run.json' is not UTF-8 JSON text (Expecting property name enclosed in double quotes: line 1 "
     "column 2 (char 1)); expected the run record afferent writes."),
])
def test_cli_hotspots_names_a_damaged_run_file(tmp_path, capsys, damage, message):
    """Before: 'internal error (please report)' with ValueError (text in sed_pa), UnicodeDecodeError, EmptyDataError,
    JSONDecodeError (exit 1); a run whose hotspots.csv had a header and no rows was left out without a word (the
    chance level then 1/2, not 1/3)."""
    from afferent.cli import main

    folders = _run_folders(tmp_path)
    damage(folders[2])
    assert main(["hotspots", *map(str, folders), "-o", str(tmp_path / "out"), "--trials", "50", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: " + message.format(d=folders[2])) and err.count("\n") == 1, err
    assert not (tmp_path / "out").exists()


def test_a_run_without_a_map_the_others_have_is_left_out_with_a_warning(tmp_path, capsys):
    from afferent.cli import main

    folders = _run_folders(tmp_path)
    t = pd.read_csv(folders[2] / "hotspots.csv")
    t.assign(map="SA-I").to_csv(folders[2] / "hotspots.csv", index=False)
    assert main(["hotspots", *map(str, folders), "-o", str(tmp_path / "out"), "--trials", "50"]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if line.startswith("afferent: warning: ")]
    assert said == ["afferent: warning: group 'all', map 'RA-I': run(s) ['r2'] have no sites of that "
                    "map; compared without them (2 of 3 runs).",
                    "afferent: warning: group 'all', map 'SA-I': run(s) ['r0', 'r1'] have no sites of "
                    "that map; compared without them (1 of 3 runs)."]
