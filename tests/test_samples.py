"""The bundled FE sample (sample_sed/, a scikit-fem solve; see its README) read back through
every route, and the study's qualitative findings checked on it (docs/method.md, "8. What the study found").

What holds and what does not is stated per test; the data are never adjusted to fit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import afferent
from afferent.cli._demo import count_peaks
from afferent.pipeline import run_pipeline
from afferent.plotting import _central_line
from afferent.synthesis import Branching, synthesize
from afferent.transduction import STUDY_PARAMS

from conftest import SAMPLE_DIR

B4 = SAMPLE_DIR / "block4"
pytestmark = pytest.mark.skipif(not (B4 / "receptors.csv").is_file(), reason="sample_sed not generated")


def read(name, **kw):
    kw.setdefault("length_unit", "mm")
    return afferent.read_sed(str(B4 / name), **kw)


def test_sed_from_tensors_matches_the_fe_librarys_own_sed():
    """1/2 sigma:eps from the exported tensors (Abaqus order, engineering shear) against the SED
    scikit-fem computed at the same points (cell centroids), within 1e-6 relative."""
    exact = read("indent_0p88mm_tensors.vtu", stress_unit="MPa", sed_from="exact", preset="abaqus")
    fe = read("indent_0p88mm.vtu", sed_unit="MPa", location="cell")
    assert exact.location == fe.location == "cell"
    rel = np.abs(exact.sed - fe.sed) / np.maximum(fe.sed, 1e-300)
    assert rel.max() < 1e-6
    # the wrong convention is visibly wrong: a test that can fail
    wrong = read("indent_0p88mm_tensors.vtu", stress_unit="MPa", sed_from="exact", preset="abaqus", shear="tensor")
    assert (np.abs(wrong.sed - fe.sed) / np.maximum(fe.sed, 1e-300)).max() > 1e-2


def test_abaqus_element_table_gives_the_same_sed_at_the_same_centroids():
    table = read("indent_0p88mm_abaqus_elements.csv", stress_unit="MPa", sed_from="exact", preset="abaqus")
    fe = read("indent_0p88mm.vtu", sed_unit="MPa", location="cell")
    ids = pd.read_csv(B4 / "indent_0p88mm_abaqus_elements.csv", usecols=["Element"])["Element"].to_numpy() - 1
    # the CSV prints 10 significant digits: that bounds the agreement
    np.testing.assert_allclose(table.sed[0], fe.sed[0, ids], rtol=1e-6, atol=1e-6 * fe.sed.max())


def test_comsol_csv_matches_the_vtu_nodes():
    comsol = afferent.read_sed(str(B4 / "indent_0p88mm_comsol.csv"))  # units from the file
    assert comsol.provenance.units["length_source"] == "file" and comsol.provenance.units["sed"] == "J/m^3"
    vtu = read("indent_0p88mm.vtu", sed_unit="MPa")
    layout = afferent.ReceptorLayout(comsol.points[::97])
    # the COMSOL rows are mesh nodes: nearest sampling of the VTU returns the same values
    s = afferent.sample_sed(vtu, layout, method="nearest").values[0]
    np.testing.assert_allclose(s, comsol.sed[0, ::97], rtol=1e-8, atol=1e-9 * vtu.sed.max())


def test_loading_series_grows_with_depth():
    series = read("series_0p88mm/indent.pvd", sed_unit="MPa")
    np.testing.assert_allclose(series.times, [0.0, 0.02, 0.04, 0.06, 0.08, 0.1])
    peak = series.sed.max(axis=1)
    assert peak[0] == 0.0 and np.all(np.diff(peak) > 0)


def test_receptor_sites_are_the_papilla_tips_of_the_mesh():
    from afferent.receptors import tips_from_export

    layout = afferent.read_receptors(B4 / "receptors.csv", length_unit="mm")
    lo, hi = layout.positions.min(axis=0), layout.positions.max(axis=0)
    tips = tips_from_export(str(B4 / "indent_0p88mm.vtu"), length_unit="mm", upper=1, lower=2,
                            x_range=(lo[0] - 1e-6, hi[0] + 1e-6), z_range=(lo[2] - 1e-6, hi[2] + 1e-6))
    a = layout.positions[np.lexsort(layout.positions.T[::-1])]
    b = tips.positions[np.lexsort(tips.positions.T[::-1])]
    np.testing.assert_allclose(a, b, atol=1e-9)


@pytest.mark.parametrize("tag", ["0p44mm", "0p88mm", "2p00mm"])
def test_sed_at_the_tips_equals_the_fe_generators_own_values(tag):
    """The generator (sample_sed/make_samples.py) recorded in build_info.json the SED it computed
    itself (scikit-fem, nodal SED in MPa x 1e6) at the papilla-tip nodes near the punch: min,
    median and max over the tips with |x - 2| and |z - 2| <= w/2 + 0.44 mm. Receptors sit on
    those nodes, so afferent's read (units) + linear sampling must return the same numbers, to
    the float32 precision of the VTU. Also checks the study's order of magnitude: ~1e2-1e3 Pa."""
    import json

    width = float(tag[:-2].replace("p", "."))
    ref = json.loads((SAMPLE_DIR / "build_info.json").read_text())["blocks"]["block4"]["cases"][tag]["checks"]
    layout = afferent.read_receptors(B4 / "receptors.csv", length_unit="mm")
    sed = afferent.sample_sed(read(f"indent_{tag}.vtu", sed_unit="MPa"), layout).values[0]
    x, z = layout.positions[:, 0] * 1e3, layout.positions[:, 2] * 1e3
    near = (np.abs(x - 2.0) <= width / 2 + 0.44 + 1e-9) & (np.abs(z - 2.0) <= width / 2 + 0.44 + 1e-9)
    assert near.sum() == ref["n_receptors_near"]
    got = [sed[near].min(), np.median(sed[near]), sed[near].max()]
    want = [ref["tip_node_SED_Pa"][k] for k in ("min", "median", "max")]
    np.testing.assert_allclose(got, want, rtol=1e-6)
    assert 100 < want[1] < 1000  # the study's order of magnitude (~190 Pa peak), within a decade


def _afferent_profiles(name, block="block4"):
    field = afferent.read_sed(str(SAMPLE_DIR / block / name), length_unit="mm", sed_unit="MPa")
    layout = afferent.read_receptors(SAMPLE_DIR / block / "receptors.csv", length_unit="mm")
    res = run_pipeline(field, layout, STUDY_PARAMS["start"], synthesis="longitudinal")
    idx, _, _ = _central_line(layout, "x")
    return res, res.sed.values[-1, idx]


@pytest.mark.parametrize("name", ["indent_1p32mm.vtu", "indent_2p00mm.vtu"])
def test_interchange_zone_from_1p32mm(name):
    """Holds from 1.32 mm (and 4 mm, below): peak-valley-peak SED across the central cross-section."""
    _, line = _afferent_profiles(name)
    assert count_peaks(line) == 2


@pytest.mark.parametrize("name", ["indent_0p88mm.vtu", "indent_1p10mm.vtu"])
def test_no_interchange_zone_up_to_1p10mm_in_this_sample(name):
    """Does NOT hold as in the study (which sees the zone from 0.66-0.88 mm): in this sample the
    edge peaks of indenters up to 1.10 mm merge on the central receptors (0.44 mm apart across
    the ridges, 0.65 mm deep), so the central line has a single maximum, with the study's
    bottom-edges restraint as with the bottom face fixed. Recorded so that a change shows."""
    _, line = _afferent_profiles(name)
    assert count_peaks(line) == 1


@pytest.mark.parametrize("name", ["indent_0p88mm.vtu", "indent_1p32mm.vtu"])
def test_longitudinal_synthesis_gives_one_peak(name):
    """Holds: summing along the ridges gives one peak for the 0.88 mm indenter (the study's case)."""
    res, _ = _afferent_profiles(name)
    assert count_peaks(res.afferent.values[-1]) == 1


def test_longitudinal_synthesis_keeps_the_2mm_valley_in_this_sample():
    """Differs from a "valley filled" reading for 2 mm: here the 2.0 mm longitudinal profile keeps
    two peaks (the study states the filling for 0.88 mm and two peaks for 4 mm)."""
    res, _ = _afferent_profiles("indent_2p00mm.vtu")
    assert count_peaks(res.afferent.values[-1]) == 2


def test_four_mm_indenter_keeps_two_separated_peaks():
    """Holds: the 4 x 4 mm indenter's longitudinal profile keeps two peaks (RA-I afferents
    resolve stimuli wider than ~3 mm). The receptor line itself has three maxima: the 8 mm block,
    restrained at its bottom edges only, bends, and the tips just outside the punch edges carry
    the most SED, with a smaller bump at the centre (sample_sed/README.md, "Interchange zone")."""
    res, line = _afferent_profiles("indent_4p00mm.vtu", block="block8")
    assert count_peaks(line) == 3
    profile = res.afferent.values[-1]
    assert count_peaks(profile) == 2
    centre = np.argmin(np.abs(res.afferent.positions - res.afferent.positions.mean()))
    assert profile[centre] < 0.95 * profile.max()  # a real valley between the peaks


def test_synthesis_conserves_current_on_the_sample():
    res, _ = _afferent_profiles("indent_1p32mm.vtu")
    cross = synthesize(res.current, Branching.cross(res.sed.layout))
    total = res.current.values.sum()
    np.testing.assert_allclose([res.afferent.values.sum(), cross.values.sum()], total, rtol=1e-13)


def _rows(prominence=0.05, over=None):
    """summary.csv rows as afferent demo writes them (SED Pa, widths mm), the sample's shape made up."""
    rows = []
    for w, zone, lon, cross in [(0.44, False, 1, 1), (0.66, False, 1, 1), (0.88, True, 1, 1), (1.10, True, 1, 1),
                                (1.32, True, 1, 1), (2.00, True, 1, 1), (4.00, True, 2, 2)]:
        rows.append({"indenter_mm": w, "sed_max_pa": 300.0, "interchange_zone": zone, "afferent_peaks_longitudinal": lon,
                     "afferent_peaks_cross": cross, "peak_prominence": prominence})
    for (w, key), v in (over or {}).items():
        next(r for r in rows if r["indenter_mm"] == w)[key] = v
    return rows


def test_study_findings_decide_by_stated_criteria():
    """Each finding names its criterion (the 2x SED band, the 0.88 mm width, the peak threshold) and flips
    when the sample crosses it."""
    from afferent.cli._demo import study_findings

    f = {d["finding"].split(",")[0][:40]: d for d in study_findings(_rows(0.07))}
    assert all(d["holds"] for d in study_findings(_rows(0.07))), f
    assert "prominence >= 0.07" in f["interchange zone (peak-valley-peak SED a"]["criterion"]
    assert f["peak SED at the papilla tips"]["criterion"] == "within 2x: 95-380 Pa"
    off = {d["finding"]: d["holds"] for d in study_findings(_rows(over={(2.0, "sed_max_pa"): 381.0,
                                                                     (0.88, "interchange_zone"): False,
                                                                     (4.0, "afferent_peaks_cross"): 1}))}
    assert [k for k, v in off.items() if not v] == [
        "peak SED at the papilla tips, 2 mm indenter 0.5 mm deep",
        "interchange zone (peak-valley-peak SED across the central x line) from width",
        "afferent peaks after cross synthesis, 4 mm indenter"]
    gap = study_findings(_rows(over={(1.10, "interchange_zone"): False}))[1]  # must hold at every wider indenter
    assert gap["sample"] == "1.32 mm (also at 0.88 mm, not at every wider one)" and not gap["holds"]


def test_demo_peak_prominence_is_checked(tmp_path, capsys):
    from afferent.cli import main

    assert main(["demo", "-o", str(tmp_path / "d"), "--peak-prominence", "1.5"]) == 2
    assert "afferent: error: --peak-prominence must be a fraction of the profile's range, 0 < p < 1; got 1.5" in \
        capsys.readouterr().err
    assert not (tmp_path / "d").exists()


def test_sample_readme_tables_come_from_the_run_records():
    """Every table row of sample_sed/README.md's numbers is what sample_sed/readme_tables.py prints from
    build_info.json (and build_info_bottom_face.json for the before/after table): no stale numbers."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("readme_tables", SAMPLE_DIR / "readme_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    readme = (SAMPLE_DIR / "README.md").read_text(encoding="utf-8")
    for name, rows in mod.all_tables().items():
        missing = [r for r in rows if r not in readme]
        assert not missing, f"{name}: run python sample_sed/readme_tables.py and paste; missing {missing[:2]}"


def test_every_finding_says_why():
    from afferent.cli._demo import study_findings

    for f in study_findings(_rows()):
        assert set(f) == {"claim", "finding", "study", "sample", "criterion", "holds", "note"} and len(f["note"]) > 40


def test_demo_case_records_its_peak_threshold(tmp_path):
    """One indenter through the demo's case runner: the threshold is in the summary row and in run.json."""
    import json

    from afferent.cli._demo import CASES, _run_case

    row, _ = _run_case(SAMPLE_DIR, {"dir": str(SAMPLE_DIR), "packaged": False}, CASES[2], str(tmp_path), 0.02)
    assert row["peak_prominence"] == 0.02 and row["afferent_peaks_longitudinal"] == 1
    assert row["sed_max_over_study"] == pytest.approx(row["sed_max_pa"] / 190.0)
    rec = json.loads((tmp_path / "indent_0p88mm" / "run.json").read_text())
    assert rec["peak_prominence"]["value"] == 0.02


def test_demo_case_is_a_scene_on_the_one_route(tmp_path):
    """An indenter of the demo is a scene run by run_scene (the planner, writer and run.json of `afferent run`),
    not a route of its own: its run.json holds the scene, the plan and the inputs' hashes, and `afferent run`
    given the same scene writes the same tables (fails before: the demo's own run.json had no scene nor plan)."""
    import json
    from pathlib import Path

    from afferent.cli._demo import CASES, _run_case, case_scene
    from afferent.scene import run_scene

    _run_case(SAMPLE_DIR, {"dir": str(SAMPLE_DIR), "packaged": False}, CASES[0], str(tmp_path / "demo"))
    rec = json.loads((tmp_path / "demo" / "indent_0p44mm" / "run.json").read_text())
    assert rec["afferent_scene"] == 1 and rec["command"] == "afferent demo" and rec["case"] == "indent_0p44mm"
    assert rec["plan"] == ["reading", "sampling", "transduction", "synthesis"]
    assert rec["scene"]["outputs"]["format"] == "csv" and rec["scene"]["transduction"]["params"] == "start"
    assert {Path(p).name for p in rec["inputs"]} == {"indent_0p44mm.vtu", "receptors.csv"}
    run_scene(case_scene(SAMPLE_DIR, CASES[0]).with_output(tmp_path / "run"), use_cache=False)
    for name in ("afferents.csv", "receptors.csv", "profiles.csv", "sed_map.csv"):
        pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "demo" / "indent_0p44mm" / name),
                                      pd.read_csv(tmp_path / "run" / name), check_exact=True)


def test_demo_on_a_sample_missing_an_export_names_the_file_and_writes_nothing(tmp_path, capsys):
    """A sample folder without one of the demo's exports: one line naming the file, exit 2, no output folder
    (the scene is refused before anything runs)."""
    import shutil

    from afferent.cli import main

    sample = tmp_path / "sample"
    (sample / "block4").mkdir(parents=True)
    shutil.copy(SAMPLE_DIR / "block4" / "receptors.csv", sample / "block4" / "receptors.csv")
    assert main(["demo", "-o", str(tmp_path / "d"), "--sample-dir", str(sample), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"afferent: error: Sample file '{sample / 'block4' / 'indent_0p44mm.vtu'}' is missing: "
                          "expected the layout of sample_sed/"), err
    assert not (tmp_path / "d").exists()
