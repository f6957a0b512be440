"""Issue 37: ``spikes.nwb`` as the NWB tools expect it. The class the run simulated, the Units table's
resolution, epochs for the stimulus phases, the waveform as a stimulus, input and drive, the scene's ``[nwb]``
metadata (nwbinspector then finds nothing; without it, it names what is missing), names Neo keeps."""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pandas as pd
import pytest

from afferent.scene import SceneError, parse_scene, run_scene
from conftest import write_bump

pynwb = pytest.importorskip("pynwb")

_META = """
[nwb]
description = "Ramp-and-hold indentation of a finite-element skin block"
experimenter = ["Doe, Jane"]
institution = "Example University"
keywords = ["touch", "mechanoreceptor"]
subject_id = "fe-block-8"
species = "Homo sapiens"
sex = "U"
age = "P30Y"
subject_description = "finite-element model of fingertip skin"
"""


def _scene(folder, *, meta: bool, engine: str = "auto", aclass: str = "SA-I") -> str:
    vtu, receptors = write_bump(folder, 8)[:2]
    return textwrap.dedent(f"""
        [export]
        file = {str(vtu)!r}
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        file = {str(receptors)!r}
        [transduction]
        params = "start"
        [stimulus]
        waveform = "ramp"
        depth_mm = 0.5
        speed_mm_per_s = 5
        hold_s = 0.05
        d_ref_mm = 0.5
        [afferent]
        class = {aclass!r}
        [spikes]
        drive = "rheobase"
        engine = {engine!r}
        [outputs]
        want = ["spikes", "nwb"]
        dir = {str(folder / "out")!r}
        """) + (_META if meta else "")


@pytest.fixture(scope="module")
def with_meta(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nwb_meta")
    return run_scene(parse_scene(_scene(folder, meta=True)), use_cache=False)


@pytest.fixture(scope="module")
def without_meta(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nwb_plain")
    return run_scene(parse_scene(_scene(folder, meta=False, engine="fast", aclass="RA-I")), use_cache=False)


def _read(res):
    io = pynwb.NWBHDF5IO(f"{res.output}/spikes.nwb", "r")
    return io, io.read()


def test_the_file_says_which_class_engine_input_and_drive_and_holds_the_scene_metadata(with_meta):
    """Before: every run was 'spike trains (RA-I LIF)', no subject, experimenter, institution, keywords."""
    io, nwb = _read(with_meta)
    with io:
        assert nwb.session_description == ("afferent: simulated SA-I tactile afferent spike trains (leaky "
                                           "integrate-and-fire, exact engine; input 'slowly-adapting', drive "
                                           "'rheobase')")
        assert nwb.experiment_description == "Ramp-and-hold indentation of a finite-element skin block"
        assert list(nwb.experimenter) == ["Doe, Jane"] and nwb.institution == "Example University"
        assert list(nwb.keywords[:]) == ["touch", "mechanoreceptor"]
        s = nwb.subject
        assert (s.subject_id, s.species, s.sex, s.age, s.description) == (
            "fe-block-8", "Homo sapiens", "U", "P30Y", "finite-element model of fingertip skin")
        notes = json.loads(nwb.stimulus_notes)
    spikes = with_meta.record["spikes"]
    assert notes["input"] == spikes["input"] == "slowly-adapting" and notes["drive"]["mapping"] == "rheobase"
    assert notes["input_params"] == spikes["input_params"] and with_meta.record["nwb"] == {"missing": []}


def test_units_resolution_epochs_stimulus_and_the_names_neo_reads(with_meta, without_meta):
    """Before: no resolution (nwbinspector's violation), no epochs, no stimulus, no '_name' column (Neo's
    NWBIO gave every train the name None)."""
    for res in (with_meta, without_meta):
        io, nwb = _read(res)
        with io:
            units = nwb.units
            table = units.to_dataframe()
            spikes = res.spikes
            t1 = spikes.t_start + spikes.duration
            if spikes.dt > 0:
                assert units.resolution == spikes.dt == 1e-4
            else:  # exact engine: float64 precision at the end of the window (0.35 s: 5.6e-17 s)
                assert units.resolution == np.spacing(t1) and 1e-17 < units.resolution < 1e-16
            assert list(table["_name"]) == list(table["afferent"]) == [str(a) for a in spikes.afferent_ids]
            epochs = nwb.epochs.to_dataframe()
            phases = [(n, max(a, spikes.t_start), min(b, t1)) for n, a, b in res.waveform.phases()]
            assert [tuple(t) for t in epochs["tags"]] == [(n,) for n, a, b in phases if b > a]
            assert [t[0] for t in epochs["tags"]] == ["loading", "hold", "unloading", "off"]
            np.testing.assert_allclose(epochs[["start_time", "stop_time"]].to_numpy(),
                                       [(a, b) for n, a, b in phases if b > a], rtol=1e-15)
            depth = nwb.stimulus["indentation_depth"]
            wave = pd.read_csv(f"{res.output}/waveform.csv")
            assert depth.unit == "m" and depth.rate == pytest.approx(1 / np.diff(wave["time_s"]).mean(), rel=1e-12)
            np.testing.assert_allclose(depth.data[:], wave["depth_m"], rtol=1e-15)
            np.testing.assert_allclose(depth.get_timestamps(), wave["time_s"], rtol=1e-9, atol=1e-15)
    io, nwb = _read(without_meta)
    with io:
        assert "simulated RA-I tactile" in nwb.session_description and nwb.subject is None


def test_nwbinspector_finds_nothing_with_the_metadata_and_names_what_is_missing_without(with_meta, without_meta):
    """nwbinspector 0.7.2 before: CRITICAL 'Subject is missing', a violation (no resolution), 4 suggestions."""
    pytest.importorskip("nwbinspector", reason="nwbinspector is in the test extra (pyproject.toml)")
    from nwbinspector import Importance, inspect_nwbfile

    found = list(inspect_nwbfile(nwbfile_path=f"{with_meta.output}/spikes.nwb"))
    assert found == [], [(m.check_function_name, m.message) for m in found]
    found = list(inspect_nwbfile(nwbfile_path=f"{without_meta.output}/spikes.nwb"))
    above = [(m.check_function_name, m.message) for m in found if m.importance != Importance.BEST_PRACTICE_SUGGESTION]
    assert above == [("check_subject_exists", "Subject is missing.")], above
    assert {m.check_function_name for m in found} == {"check_subject_exists", "check_experimenter_exists",
                                                      "check_experiment_description", "check_institution",
                                                      "check_keywords"}
    assert without_meta.record["nwb"]["missing"] == ["subject_id", "species", "sex", "age", "experimenter",
                                                     "institution", "keywords", "description"]


@pytest.mark.parametrize("extra, message", [
    ('[nwb]\ninstitution = "X"\n', r"\[nwb\] 'institution' describes spikes.nwb, the output 'nwb', which is not "
                                   r"requested \(want = \['currents'\]\)."),
    ('[nwb]\nage = "30 years"\n', r"\[nwb\] 'age' must be an ISO 8601 duration such as 'P30Y' \(30 years\) or "
                                  r"'P25Y/P35Y' \(a range\); got '30 years' instead."),
    ('[nwb]\nsex = "male"\n', r"\[nwb\] 'sex'"),
])
def test_nwb_table_errors(tmp_path, extra, message):
    from afferent.scene import resolve

    want = '"currents"' if "institution" in extra else '"spikes", "nwb"'
    text = ('[export]\nfile = "a.vtu"\nlength_unit = "mm"\nsed_unit = "MPa"\n[receptors]\nfile = "r.csv"\n'
            f'[transduction]\nparams = "start"\n[outputs]\nwant = [{want}]\n{extra}')
    with pytest.raises(SceneError, match=message):
        resolve(parse_scene(text))
