"""Sweeps at scale (issue 38): tasks made without a resolved scene each, a combination a scene refuses failing
its task only, the table streamed to its file, and a sweep on a separate Dask scheduler with two workers over TCP."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

from afferent._sweep import load_sweep, sweep

ROOT = Path(__file__).resolve().parents[1]
BLOCK4 = ROOT / "sample_sed" / "block4"
pytestmark = pytest.mark.skipif(not (BLOCK4 / "receptors.csv").is_file(), reason="sample_sed/ not present")

# a static export of the sample, the study's ramp-and-hold, rate-sensitive input; tests write their own [sweep]
BASE = f"""\
[scene]
name = "scale"
[export]
file = "{(BLOCK4 / 'indent_0p88mm.vtu').as_posix()}"
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = "{(BLOCK4 / 'receptors.csv').as_posix()}"
[region]
x_range_mm = [1.5, 2.5]
[transduction]
params = "start"
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5
depth_mm = 0.5
speed_mm_per_s = 5.0
hold_s = 0.2
dt_ms = 1.0
[spikes]
input = "rate-sensitive"
gain_s = 0.2
[outputs]
want = ["spikes", "profiles"]
"""


def write_sweep(tmp_path, sweep_table: str, name="s.toml", base=BASE) -> Path:
    p = tmp_path / name
    p.write_text(base + "[sweep]\n" + textwrap.dedent(sweep_table))
    return p


# ------------------------------------------------------------- making tasks (issue 38, row 4)
def test_tasks_are_made_without_resolving_a_scene_each_with_the_groups_of_their_scenes(tmp_path, monkeypatch):
    """Each task was a resolved scene (~1 ms: 10^6 tasks 20 min, again on resume); now its id and group come
    from a scene resolved once per distinct value of the sampling and file keys, and its scene when it runs."""
    from afferent._sweep import spec as sp

    src = write_sweep(tmp_path, f"""\
        "export.file" = ["{(BLOCK4 / 'indent_0p44mm.vtu').as_posix()}", "{(BLOCK4 / 'indent_0p88mm.vtu').as_posix()}"]
        "transduction.gamma_per_pa" = {{start = 1e-3, stop = 2e-2, num = 50, spacing = "log"}}
        "spikes.gain_ms" = [100, 200, 300, 400, 500]
        """)
    spec = load_sweep(src)
    builds = []
    real = sp._build
    monkeypatch.setattr(sp, "_build", lambda *a, **k: builds.append(1) or real(*a, **k))
    tasks = list(spec.iter_tasks())
    assert len(tasks) == 500 and len(builds) <= 3, len(builds)  # was 500: one resolved scene a task
    assert len({t.id for t in tasks}) == 500 and len({t.group for t in tasks}) == 2
    assert [t.id for t in load_sweep(src).iter_tasks()] == [t.id for t in tasks]  # a re-run makes the same ids
    monkeypatch.setattr(sp, "_build", real)
    for t in tasks[::37]:  # the scene built when the task runs is the parameter set's; its group is the scene's
        assert t.scene.transduction.gamma_per_pa == t.params["transduction.gamma_per_pa"]
        assert t.scene.spikes.gain_s == pytest.approx(t.params["spikes.gain_ms"] / 1e3)
        assert t.scene.export.files == (t.params["export.file"],)
        assert t.group == sp._sampling_of(t.scene, {})[0]


def test_a_combination_a_scene_refuses_fails_its_task_and_the_others_run(tmp_path):
    """Before, a parameter set the scene refuses that no probe holds (each value alone is fine; together they are
    not) stopped the sweep midway with SceneError; now that task fails with the error at its [sweep] line."""
    base = re.sub(r"\[stimulus\].*?\[spikes\]", '[stimulus]\nwaveform = "sine"\nd_ref_mm = 0.5\namplitude_mm = 0.1\n'
                  'duration_s = 0.05\n[spikes]', BASE, flags=re.S)
    src = write_sweep(tmp_path, '"stimulus.dt_ms" = [0.1, 1.0]\n"stimulus.frequency_hz" = [10, 100]\n', base=base)
    res = sweep(src, tmp_path / "out", scheduler="serial")
    assert (res.n_tasks, res.n_ran, res.n_failed) == (4, 4, 1)
    (f,) = res.failures
    assert f["params"] == {"stimulus.dt_ms": 1.0, "stimulus.frequency_hz": 100} and f["stage"] == "scene"
    assert re.match(r"SceneError: Sweep file .*s\.toml', line \d+: \[sweep\] 'stimulus\.dt_ms' = 1\.0: \[stimulus\] "
                    r"'dt_ms' \(1 ms\) samples the 100 Hz sine 10 times a period", f["error"]), f["error"]
    assert set(res.table.task) == {t.id for t in load_sweep(src).iter_tasks()} - {f["task"]}
