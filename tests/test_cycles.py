"""The 'cycles' output (afferent.cycles) and ``afferent cycles``: per-cycle deepest points, the site rule, SED and
rate vs frequency (the study's figs. 4-11/4-12) on a closed-form series and on the bundled vibration runs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from afferent.cycles import cycle_bounds, cycle_table, edge_sites, frequency_summary

ROOT = Path(__file__).resolve().parents[1]
VIB = ROOT / "sample_sed" / "scenes" / "vibration"
needs_sample = pytest.mark.skipif(not VIB.is_dir(), reason="bundled vibration sample not present")


def _series(f=20.0, cycles=3, steps=20, phase=0.0):
    """SED_i(t) = a_i (1 - cos(2 pi f t)) / 2 + b_i t: deepest (largest total) at t = (k + 1/2) / f when b = 0."""
    t = np.arange(cycles * steps + 1) / (steps * f) + phase
    a = np.array([1.0, 3.0, 2.0])
    return t, a[None, :] * (1 - np.cos(2 * np.pi * f * (t[:, None] - phase))) / 2


def test_deepest_points_of_a_closed_form_series():
    t, v = _series()
    table, site = cycle_table(t, v, 20.0)
    assert table["deepest_time_s"].tolist() == pytest.approx([0.025, 0.075, 0.125], abs=1e-12)
    assert table["deepest_step"].tolist() == [10, 30, 50]
    assert site == 1 and table["sed_pa"].tolist() == pytest.approx([3.0, 3.0, 3.0])
    assert table["t_start_s"].tolist() == pytest.approx([0.0, 0.05, 0.1])
    assert np.isnan(table["rate_hz"]).all()
    # a series starting at 1 s: cycles counted from the first step
    t2, v2 = _series(phase=1.0)
    assert cycle_table(t2, v2, 20.0)[0]["deepest_time_s"].tolist() == pytest.approx([1.025, 1.075, 1.125])


def test_site_rule_edge_band_and_spikes_per_cycle():
    t, v = _series()
    pos = np.array([[0.0, 0, 0.0], [5e-3, 0, 5e-3], [1.1e-3, 0, 0.5e-3]])  # site 1 (largest) far from the outline
    near = edge_sites(pos, (0.0, 1e-3), (0.0, 1e-3), 0.2e-3)
    assert near.tolist() == [True, False, True]
    spikes = np.array([0.01, 0.02, 0.06, 0.149, 0.15, 0.2])  # 2, 1, 2 (the end of the last cycle counts), 0.2 out
    table, site = cycle_table(t, v, 20.0, positions_m=pos, ids=["a", "b", "c"], candidates=near, spike_times=spikes,
                              n_afferents=2)
    assert site == 2 and set(table["site"]) == {"c"} and table["sed_pa"].tolist() == pytest.approx([2.0] * 3)
    assert table["spikes"].tolist() == [2, 1, 2]
    assert table["rate_hz"].tolist() == pytest.approx([20.0, 10.0, 20.0])  # spikes / (2 afferents x 0.05 s)


def test_cycle_errors_are_pinned():
    t, v = _series()
    with pytest.raises(ValueError, match=r"cycle frequency must be a number > 0 Hz; got -1"):
        cycle_bounds(t, -1)
    with pytest.raises(ValueError, match=r"a 5 Hz cycle lasts 0.2 s but the series spans 0.15 s .*not one whole cycle"):
        cycle_table(t, v, 5.0)
    with pytest.raises(ValueError, match=r"no site near the indenter's edge among the 3 sites; widen the band"):
        cycle_table(t, v, 20.0, candidates=[False] * 3)


def test_scene_keys_are_checked():
    from afferent.scene import SceneError, parse_scene, resolve

    base = '[export]\nfile = "x.vtu"\n[receptors]\ngrid = "tips"\n[outputs]\n'
    with pytest.raises(SceneError, match=r"want 'cycles' needs the periodic input's frequency 'cycles_frequency_hz'"):
        resolve(parse_scene(base + 'want = ["cycles"]\n'))
    with pytest.raises(SceneError, match=r"'cycles_frequency_hz' applies to want = \[..., 'cycles'\]"):
        resolve(parse_scene(base + 'want = ["sed_map"]\ncycles_frequency_hz = 20\n'))
    with pytest.raises(SceneError, match=r"outline for 'cycles' needs all of .* missing 'cycles_edge_m'"):
        resolve(parse_scene(base + 'want = ["cycles"]\ncycles_frequency_hz = 20\ncycles_x_range_mm = [1, 2]\n'
                            'cycles_z_range_mm = [1, 2]\n'))


def _build_info():
    return json.loads((ROOT / "sample_sed" / "vibration" / "build_info.json").read_text())


@needs_sample
def test_command_on_the_vibration_runs_gives_build_info_numbers(tmp_path, capsys):
    from afferent.cli._main import main
    from afferent.scene import load_scene, run_scene

    runs = []
    for s in sorted(VIB.glob("*.toml")):
        res = run_scene(load_scene(s).with_output(tmp_path / s.stem), cache_dir=tmp_path / "c")
        runs.append(str(tmp_path / s.stem))
        assert res.record["cycles"]["site"] == "25"
        assert res.record["cycles"]["candidates"] == ["5", "10", "15", "20", "21", "22", "23", "24", "25"]
        spikes = np.loadtxt(tmp_path / s.stem / "spikes.csv", delimiter=",", skiprows=1, usecols=1, ndmin=1)
        cyc = np.genfromtxt(tmp_path / s.stem / "cycles.csv", delimiter=",", names=True)
        assert cyc["spikes"].sum() == np.sum(spikes <= 3 / cyc["frequency_hz"][0] + 1e-12)
    assert main(["cycles", *runs, "-o", str(tmp_path / "freq"), "--group", "3d=ridged3d_*",
                 "--group", "2d=ridged2d_*"]) == 0
    import pandas as pd

    summ = pd.read_csv(tmp_path / "freq" / "frequency.csv")
    assert (tmp_path / "freq" / "frequency.png").stat().st_size > 10_000
    info = _build_info()["models"]
    for row in summ.itertuples():
        deep = info[row.group]["series"][f"{row.group}_{int(row.frequency_hz)}Hz"]["deepest"]
        assert deep["site"]["index"] == 24   # the corner tip (3.41, 3.41) mm; the package's cell volumes: 2e-4
        assert row.sed_first_pa == pytest.approx(deep["site_SED_Pa"][0], rel=5e-4)
        assert row.sed_last_pa == pytest.approx(deep["site_SED_Pa"][-1], rel=5e-4)
    # sample_sed/README.md's table, 80 / 20 Hz at the third deepest point: 1.163 (3-D), 1.164 (2-D)
    last = summ[summ.frequency_hz == 80].set_index("group")["last_vs_lowest"]
    assert round(last["3d"], 3) == 1.163 and round(last["2d"], 3) == 1.164
    assert main(["cycles", runs[0], str(tmp_path / "freq"), "-o", str(tmp_path / "x")]) == 2
    assert "no cycles.csv; expected the output folder of a run whose scene wants 'cycles'" in capsys.readouterr().err


def test_two_runs_at_one_frequency_in_a_group_is_an_error(tmp_path):
    import pandas as pd

    from afferent.cli._cycles import read_cycle_runs

    (tmp_path / "sweep.json").write_text("{}")
    with pytest.raises(ValueError, match=r"a sweep with no finished task wanting 'cycles'; add 'cycles'"):
        read_cycle_runs([str(tmp_path)])

    t, v = _series()
    tab = cycle_table(t, v, 20.0)[0]
    with pytest.raises(ValueError, match=r"group 'all': runs 'a' and 'b' are both at 20 Hz"):
        frequency_summary({"a": tab, "b": tab}, {"all": ["a", "b"]})
    with pytest.raises(ValueError, match=r"run 'a': the cycles table lacks the column\(s\) \['rate_hz'\]; expected the table"):
        frequency_summary({"a": tab.drop(columns="rate_hz")}, {"all": ["a"]})
    assert isinstance(frequency_summary({"a": tab}, {"all": ["a"]}), pd.DataFrame)


@needs_sample
def test_a_sine_stimulus_gives_its_frequency_and_closed_form_deepest_points(tmp_path):
    """d(t) = 0.25 + 0.25 sin(2 pi 40 t) mm on the 0.88 mm export solved at 0.5 mm: SED = (d / 0.5)^2 x the export's,
    deepest at t = (k + 1/4) / 40 s with the export's own SED there."""
    from afferent.scene import parse_scene, run_scene

    sed_map = ROOT / "sample_sed" / "scenes" / "sed_map.toml"
    text = (f'[export]\nfile = "{ROOT}/sample_sed/block4/indent_0p88mm.vtu"\nlength_unit = "mm"\nsed_unit = "MPa"\n'
            f'[receptors]\nfile = "{ROOT}/sample_sed/block4/receptors.csv"\n'
            '[stimulus]\nwaveform = "sine"\nd_ref_mm = 0.5\nfrequency_hz = 40\namplitude_mm = 0.25\noffset_mm = 0.25\n'
            'duration_s = 0.075\ndt_ms = 0.25\n[outputs]\nwant = ["cycles", "currents"]\n')
    assert sed_map.is_file()
    res = run_scene(parse_scene(text).with_output(tmp_path / "sine"), cache_dir=tmp_path / "c")
    rec = res.record["cycles"]
    assert rec["frequency_hz"] == 40.0 and rec["frequency_from"] == "the scene's [stimulus] sine frequency_hz"
    cyc = np.genfromtxt(tmp_path / "sine" / "cycles.csv", delimiter=",", names=True, dtype=None, encoding=None)
    assert cyc["deepest_time_s"].tolist() == pytest.approx([0.00625, 0.03125, 0.05625], abs=1e-9)
    static = np.asarray(res.sed.values)[-1]
    assert cyc["sed_pa"] == pytest.approx([np.nanmax(static)] * 3, rel=1e-9)
    assert rec["site_rule"] == "the site with the largest SED at the last cycle's deepest point"
    alone = run_scene(parse_scene(text.replace('"cycles", "currents"', '"cycles"')).with_output(tmp_path / "alone"),
                      cache_dir=tmp_path / "c")  # SED only: the stimulus stage still runs for the cycles
    assert alone.stages.keys() >= {"stimulus"} and "transduction" not in alone.stages
    assert alone.record["cycles"]["n_cycles"] == 3


@needs_sample
def test_command_reads_the_vibration_sweep_as_its_runs(tmp_path):
    """afferent sweep sample_sed/scenes/sweep_vibration.toml, then afferent cycles on its folder: build_info's SED."""
    import pandas as pd

    from afferent.cli._main import main

    assert main(["sweep", str(ROOT / "sample_sed" / "scenes" / "sweep_vibration.toml"), "-o", str(tmp_path / "sw"),
                 "-q"]) == 0
    assert main(["cycles", str(tmp_path / "sw"), "-o", str(tmp_path / "freq"), "--group", "3d=ridged3d_*",
                 "--group", "2d=ridged2d_*"]) == 0
    summ = pd.read_csv(tmp_path / "freq" / "frequency.csv")
    assert len(summ) == 8 and set(summ["site"].astype(str)) == {"25"}
    info = _build_info()["models"]
    for row in summ.itertuples():
        deep = info[row.group]["series"][f"{row.group}_{int(row.frequency_hz)}Hz"]["deepest"]
        assert [row.sed_first_pa, row.sed_last_pa] == pytest.approx(deep["site_SED_Pa"][::2], rel=5e-4)
    assert summ.groupby("group")["rate_hz"].apply(lambda r: r.is_monotonic_increasing).all()


# ------------------------------------------------------------ issue 33, items 11 and 13: damaged cycles tables
@pytest.mark.parametrize("column, value, message", [
    ("frequency_hz", np.nan, "Run table '{csv}': column 'frequency_hz' must hold finite numbers; got nan on data row 1 "
                             "instead; expected the 'cycles' output of a run (cycles.csv)."),
    ("frequency_hz", 0.0, "run 'r': the cycles table: column 'frequency_hz' must hold one frequency > 0 Hz in every "
                          "row; got [0.0] instead."),
    ("rate_hz", -5.0, "run 'r': the cycles table: column 'rate_hz' must be >= 0 (or empty: not counted); got -5.0 in "
                      "cycle 1 instead."),
    ("spikes", -1.0, "run 'r': the cycles table: column 'spikes' must be >= 0 (or empty: not counted); got -1.0 in "
                     "cycle 1 instead."),
    ("sed_pa", "abc", "Run table '{csv}': column 'sed_pa' must hold finite numbers; got 'abc' on data row 1 instead; "
                      "expected the 'cycles' output of a run (cycles.csv)."),
])
def test_cli_cycles_refuses_a_table_of_no_frequency_or_negative_rates(tmp_path, capsys, column, value, message):
    """Before: NaN or 0 frequency_hz and negative rates were tabulated (exit 0); text in sed_pa was an internal
    error (ValueError from float(), exit 1)."""
    from afferent.cli import main

    t, v = _series()
    tab = cycle_table(t, v, 20.0, spike_times=[0.01, 0.06], n_afferents=1)[0]
    tab[column] = tab[column].astype(object)
    tab.loc[0 if column != "frequency_hz" else slice(None), column] = value  # a frequency: the whole column
    (tmp_path / "r").mkdir()
    tab.to_csv(tmp_path / "r" / "cycles.csv", index=False)
    assert main(["cycles", str(tmp_path / "r"), "-o", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert err == "afferent: error: " + message.format(csv=tmp_path / "r" / "cycles.csv") + "\n", err
    assert not (tmp_path / "out").exists()
