"""The figures of a run drawn in a second process (afferent._figure_process): the same PNGs, warnings,
errors and record as drawn in the run's own process; the switch; no process left behind.

The rest of the suite draws in the run's own process: its exports are under 16 MB (MIN_EXPORT_BYTES).
The tests here set AFFERENT_FIGURE_PROCESS=1 (a second process whatever the export) or 0.
"""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import sys

import numpy as np
import pytest

from afferent import _figure_process as figure_process
from afferent._figure_process import ENV, MIN_EXPORT_BYTES, FigureProcess, SameProcess, choose, usable_cores
from afferent.cli import main
from afferent.cli._main import raised_on_purpose
from conftest import DATA_DIR, SAMPLE_DIR

#: a short ramp on the 0.88 mm sample, SED map, profiles, spikes and hot spots: all 7 figures of ``afferent run``
#: and the hot-spot maps (hotspots.png, drawn in the run's own process: export.write_outputs says why)
SCENE_TEXT = f"""[export]
file = "{(SAMPLE_DIR / "block4" / "indent_0p88mm.vtu").as_posix()}"
length_unit = "mm"
sed_unit = "MPa"
[receptors]
file = "{(SAMPLE_DIR / "block4" / "receptors.csv").as_posix()}"
[region]
x_range_mm = [1.5, 2.5]
[transduction]
params = "start"
[stimulus]
waveform = "ramp"
d_ref_mm = 0.5
depth_mm = 0.5
speed_mm_per_s = 5.0
hold_s = 0.1
dt_ms = 1.0
[spikes]
input = "rate-sensitive"
gain_s = 0.2
[outputs]
want = ["sed_map", "profiles", "spikes", "hotspots", "plots"]
"""


def _ignores_sigint(pid: int) -> bool:
    """Whether process ``pid`` ignores SIGINT (Linux /proc: bit 2 of SigIgn): the figure process's own code sets it
    first thing. Before that, a Ctrl-C while its interpreter starts can still make it print a traceback of
    multiprocessing's start (SIGINT is blocked for the start, but not in every path of it): noted in docs/performance.md."""
    try:
        with open(f"/proc/{pid}/status") as f:
            line = next(x for x in f if x.startswith("SigIgn:"))
    except (OSError, StopIteration):
        return False
    return bool(int(line.split()[1], 16) & (1 << 1))


def _children(parent: int | None = None) -> list[tuple[int, str]]:
    """(pid, command line) of the live children of ``parent`` (default: this process) but multiprocessing's resource
    tracker (Linux /proc)."""
    parent = os.getpid() if parent is None else parent
    out = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if int(fields[1]) == parent and fields[0] != "Z" and "resource_tracker" not in cmd:
            out.append((int(pid), cmd))
    return out


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (an exited child its new parent has not reaped yet)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


linux_only = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads /proc")


def _run_cli(capsys, monkeypatch, value: str, *argv):
    monkeypatch.setenv(ENV, value)
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    """:data:`SCENE_TEXT` run by the command both ways: {'separate': folder, 'same': folder}."""
    base = tmp_path_factory.mktemp("figproc")
    scene = base / "ramp.toml"
    scene.write_text(SCENE_TEXT)
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        for value, kind in (("1", "separate"), ("0", "same")):
            mp.setenv(ENV, value)
            assert main(["run", str(scene), "-o", str(base / kind), "--quiet", "--no-cache"]) == 0
            out[kind] = base / kind
    return out


def test_the_pngs_are_byte_identical_drawn_in_either_process(both):
    sep, same = both["separate"], both["same"]
    pngs = sorted(p.name for p in same.glob("*.png"))
    assert pngs == ["hotspots.png", "profiles_x.png", "profiles_z.png", "psth.png", "raster.png", "rates.png",
                    "sed_map.png", "waveform.png"]
    assert sorted(p.name for p in sep.iterdir()) == sorted(p.name for p in same.iterdir())
    for name in pngs:
        assert (sep / name).read_bytes() == (same / name).read_bytes(), name


def test_run_json_records_where_the_figures_were_drawn(both):
    sep = json.loads((both["separate"] / "run.json").read_text())
    same = json.loads((both["same"] / "run.json").read_text())
    if usable_cores() >= 2:  # two usable cores
        assert sep["figures"]["process"] == "separate"
        assert sep["figures"]["seconds"] > 0 and sep["figures"]["start_s"] > 0 and sep["figures"]["waited_s"] >= 0
        assert sep["figures"]["here_s"] > 0  # the run drew its part (RUN_DRAWS: raster, rates) while the child drew
    assert same["figures"] == {"process": "same", "why": f"{ENV}=0", "seconds": same["figures"]["seconds"]}
    assert sorted(sep["outputs"]) == sorted(same["outputs"])
    assert [w["message"] for w in sep["warnings"]] == [w["message"] for w in same["warnings"]]


needs_two_cores = pytest.mark.skipif(not usable_cores() >= 2, reason="one usable core: the figures are drawn in-process")


@pytest.fixture(scope="module")
def all_outside(tmp_path_factory):
    """A scene whose receptors all lie above the block, kept as NaN: its SED map warns while drawn (numpy's
    'All-NaN slice encountered')."""
    base = tmp_path_factory.mktemp("outside")
    block = SAMPLE_DIR / "block4"
    lines = (block / "receptors.csv").read_text().splitlines()
    rows = [",".join((*r.split(",")[:2], "9.0", r.split(",")[3])) for r in lines[1:]]
    (base / "rec.csv").write_text("\n".join([lines[0], *rows]) + "\n")
    (base / "s.toml").write_text(f'[export]\nfile = "{(block / "indent_0p88mm.vtu").as_posix()}"\nlength_unit = "mm"\n'
                                 'sed_unit = "MPa"\n[receptors]\nfile = "rec.csv"\n[sampling]\non_outside = "nan"\n'
                                 '[outputs]\nwant = ["sed_map", "plots"]\n')
    return base


@needs_two_cores
def test_warnings_raised_while_drawing_in_the_child_land_in_run_json(all_outside, capsys, monkeypatch):
    records = {}
    for value in ("1", "0"):
        code, _ = _run_cli(capsys, monkeypatch, value, "run", all_outside / "s.toml", "-o", all_outside / value,
                           "--quiet", "--no-cache")
        assert code == 0
        records[value] = json.loads((all_outside / value / "run.json").read_text())
    assert records["1"]["figures"]["process"] == "separate"
    assert records["1"]["warnings"] == records["0"]["warnings"]
    assert {"category": "RuntimeWarning", "message": "All-NaN slice encountered"} in records["1"]["warnings"]


@needs_two_cores
@linux_only
def test_a_disk_error_in_the_child_is_the_in_process_one_line_error_exit_2(tmp_path, capsys, monkeypatch):
    """A file-size limit below a PNG's size (EFBIG, as a full disk): the figure fails, the tables do not."""
    import resource

    scene = tmp_path / "s.toml"
    scene.write_text((SAMPLE_DIR / "scenes" / "sed_map.toml").read_text().replace(
        '"../block4/', f'"{(SAMPLE_DIR / "block4").as_posix()}/'))
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    errors = {}
    try:
        resource.setrlimit(resource.RLIMIT_FSIZE, (60_000, hard))  # sed_map.csv ~10 kB, sed_map.png ~170 kB
        for value in ("1", "0"):
            code, err = _run_cli(capsys, monkeypatch, value, "run", scene, "-o", tmp_path / f"out{value}",
                                 "--quiet", "--no-cache")
            assert code == 2, err
            errors[value] = re.sub(r"out[01]", "OUT", err)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert errors["1"] == errors["0"]
    assert errors["1"] == (f"afferent: error: cannot write '{tmp_path / 'OUT'}': the file is too large for this file "
                           "system (EFBIG)\n")
    assert not any(tmp_path.glob("out*"))  # nothing half-written
    assert _children() == []


def _figure_objects():
    """A SED map's objects whose colour array does not match the sites (a bug: matplotlib's ValueError)."""
    from afferent.receptors import ReceptorLayout
    from afferent.sampling import ReceptorSED

    layout = ReceptorLayout(positions=np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 1e-3], [2e-3, 0.0, 0.0]]))
    sed = ReceptorSED(values=np.array([[1.0, 2.0, 3.0]]), times=np.array([0.0]), layout=layout, method="linear",
                      outside=np.zeros(3, bool))
    broken = ReceptorSED(values=sed.values, times=sed.times, layout=layout, method="linear", outside=sed.outside)
    object.__setattr__(broken, "values", np.array([[1.0, 2.0]]))
    return dict(sed_static=broken, sed=sed, current=None, branching=None, afferent=None, fit=None, waveform=None,
                spikes=None, profile_index=0)


@needs_two_cores
def test_a_bug_in_the_child_is_raised_again_as_the_same_bug(tmp_path):
    raised = {}
    for kind, drawer in (("separate", FigureProcess), ("same", SameProcess)):
        folder = tmp_path / kind
        folder.mkdir()
        with drawer() as d:
            d.draw(folder, {"sed_map"}, _figure_objects())
            with pytest.raises(ValueError) as info:
                d.result()
        raised[kind] = info.value
    assert str(raised["separate"]) == str(raised["same"])
    assert type(raised["separate"]) is type(raised["same"])
    assert not raised_on_purpose(raised["same"]) and not raised_on_purpose(raised["separate"])  # exit 1 both
    assert "Traceback" in str(raised["separate"].__cause__)  # the child's traceback, for AFFERENT_DEBUG


def test_the_switch_and_the_cores_decide(monkeypatch):
    monkeypatch.setenv(ENV, "0")
    assert choose(True) == (False, f"{ENV}=0")
    monkeypatch.setenv(ENV, "yes")
    with pytest.raises(ValueError, match=rf"{ENV} must be 0 .* or 1 .*; got 'yes' instead"):
        choose(True)
    monkeypatch.setenv(ENV, "1")
    assert choose(False)[0] is False
    if usable_cores() >= 2:
        assert choose(True, None)[0] and choose(True, 1000)[0]  # 1: whatever the export
        monkeypatch.delenv(ENV, raising=False)  # unset: only an export read while the process starts, and large enough
        assert choose(True, None) == (False, "nothing to read (the sampled SED came from the cache) while a second "
                                             "process starts")
        assert choose(True, 3_900_000) == (False, "the export (3.9 MB) is read before a second process could start "
                                                  "(under 16 MB)")
        monkeypatch.setattr(figure_process, "runnable", lambda: 1)  # this process alone
        assert choose(True, MIN_EXPORT_BYTES) == (True, f"{usable_cores()} usable cores; started while the export "
                                                        "(16 MB) was read")
        monkeypatch.setattr(figure_process, "runnable", lambda: usable_cores())  # no idle core
        assert choose(True, MIN_EXPORT_BYTES) == (False, f"no idle core: {usable_cores()} processes ready to run on "
                                                         f"{usable_cores()} cores (/proc/loadavg)")
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)
    assert choose(True) == (False, "1 usable core: a second process would only wait for this one")


def test_a_bad_switch_is_one_line_from_the_command(capsys, monkeypatch, tmp_path):
    code, err = _run_cli(capsys, monkeypatch, "2", "run", SAMPLE_DIR / "scenes" / "sed_map.toml", "-o", tmp_path / "o",
                         "--quiet")
    assert code == 2
    assert err == f"afferent: error: The environment variable {ENV} must be 0 (draw the figures in the run's own " \
                  "process) or 1 (in a second process where there are 2 cores); got '2' instead.\n"


@linux_only
def test_the_command_draws_a_small_exports_figures_in_its_own_process(tmp_path, capsys, monkeypatch):
    """Unset switch, the bundled 4 MB sample: a second process would start after the reading is done."""
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.setenv("AFFERENT_CACHE_DIR", str(tmp_path / "cache"))  # empty: the worker's may hold this scene
    whys = []
    for out in ("o1", "o2"):  # the second from the sampled-SED cache: nothing read
        assert main(["run", str(SAMPLE_DIR / "scenes" / "sed_map.toml"), "-o", str(tmp_path / out), "-q"]) == 0
        figures = json.loads((tmp_path / out / "run.json").read_text())["figures"]
        assert figures["process"] == "same"
        whys.append(figures["why"])
    if usable_cores() >= 2:
        assert whys[0].startswith("the export (") and whys[0].endswith(") is read before a second process could "
                                                                       "start (under 16 MB)")
        assert whys[1] == "nothing to read (the sampled SED came from the cache) while a second process starts"
    assert _children() == []


@linux_only
def test_the_python_api_starts_no_process_unless_asked(tmp_path, monkeypatch):
    from afferent.scene import load_scene, run_scene

    monkeypatch.setenv(ENV, "1")
    before = _children()
    res = run_scene(load_scene(SAMPLE_DIR / "scenes" / "sed_map.toml").with_output(tmp_path / "o"), use_cache=False)
    assert res.record["figures"]["process"] == "same"
    assert res.record["figures"]["why"].startswith("not asked")
    assert _children() == before == []


@needs_two_cores
@linux_only
def test_an_error_of_the_run_stops_the_child(tmp_path, capsys, monkeypatch):
    """The export is broken: reading fails while the child imports; the child is stopped, nothing is left."""
    scene = tmp_path / "s.toml"
    (tmp_path / "broken.vtu").write_text("<VTKFile type='UnstructuredGrid'>\n")
    shutil.copy(SAMPLE_DIR / "block4" / "receptors.csv", tmp_path / "rec.csv")
    scene.write_text('[export]\nfile = "broken.vtu"\nlength_unit = "mm"\nsed_unit = "MPa"\n[receptors]\n'
                     'file = "rec.csv"\n[outputs]\nwant = ["sed_map", "plots"]\n')
    code, err = _run_cli(capsys, monkeypatch, "1", "run", scene, "-o", tmp_path / "o", "--quiet", "--no-cache")
    assert code == 2 and err.startswith("afferent: error: ") and "broken.vtu" in err
    assert _children() == []
    assert not (tmp_path / "o").exists()


def test_the_figures_objects_pickle(both):
    """What the run hands the child survives pickling (a waveform's read-only parameters, an OutputWriteError)."""
    from afferent.exceptions import OutputWriteError
    from afferent.stimulus import ramp_and_hold

    w = ramp_and_hold(5e-4, 5e-3, 0.1, dt=1e-3)
    back = pickle.loads(pickle.dumps(w))
    assert dict(back.parameters) == dict(w.parameters) and np.array_equal(back.depth, w.depth)
    err = pickle.loads(pickle.dumps(OutputWriteError(28, "Output 'a.png': the disk is full", "a.png")))
    assert (err.errno, str(err), err.filename) == (28, "Output 'a.png': the disk is full", "a.png")


@pytest.mark.slow
def test_the_command_line_runs_under_python_dash_m(tmp_path):
    """``python -m afferent``: spawn does not run the package's __main__ again in the child."""
    import subprocess

    env = dict(os.environ, **{ENV: "1"}, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "afferent", "run", str(SAMPLE_DIR / "scenes" / "sed_map.toml"),
                           "-o", str(tmp_path / "o"), "--quiet", "--no-cache"], env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    record = json.loads((tmp_path / "o" / "run.json").read_text())
    assert record["figures"]["process"] == ("separate" if usable_cores() >= 2 else "same")


@needs_two_cores
@linux_only
def test_ctrl_c_stops_the_run_and_its_figure_process(tmp_path):
    """SIGINT to the command's process group (a terminal's Ctrl-C) once the figure process runs: exit 130, one
    line, no process and no temporary folder left."""
    import signal
    import subprocess
    import time

    env = dict(os.environ, **{ENV: "1"}, MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "afferent", "run", str(SAMPLE_DIR / "scenes" / "sed_map.toml"), "-o",
           str(tmp_path / "o"), "--no-cache"]
    proc = subprocess.Popen(cmd, env=env, start_new_session=True, stderr=subprocess.PIPE, text=True)
    kids: list[int] = []
    for _ in range(3000):  # until the figure process runs (its own code has set SIGINT ignored)
        kids = [pid for pid, cmd in _children(proc.pid) if "spawn_main" in cmd and _ignores_sigint(pid)]
        if kids or proc.poll() is not None:
            break
        time.sleep(0.01)
    assert kids, "the figure process did not start"
    os.killpg(proc.pid, signal.SIGINT)
    assert proc.wait(timeout=30) == 130
    assert proc.stderr.read() == "afferent: interrupted\n"
    time.sleep(0.2)
    assert not [k for k in kids if _alive(k)]
    assert os.listdir(tmp_path) == []


def _kill_when(ready, out, timeout: float = 60.0, sig: int | None = None):
    """A thread that SIGKILLs (or sends ``sig``) this process's figure process once ``ready(pid, temporary output
    folders)`` is true; its ``killed`` list gets the pid (Linux /proc)."""
    import signal
    import threading
    import time

    killed: list[int] = []
    sig = signal.SIGKILL if sig is None else sig

    def watch():
        end = time.monotonic() + timeout
        while time.monotonic() < end and not killed:
            parts = list(out.parent.glob(f".{out.name}.*.part"))
            for pid, cmd in _children():
                if "spawn_main" in cmd and _ignores_sigint(pid) and ready(pid, parts):
                    os.kill(pid, sig)
                    killed.append(pid)
                    return
            time.sleep(0.002)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread, killed


@needs_two_cores
@linux_only
@pytest.mark.parametrize("when", ["starting", "drawing"])
def test_a_figure_process_killed_leaves_the_figures_to_the_run(both, tmp_path, capsys, monkeypatch, when):
    """SIGKILL (the out-of-memory killer's signal) once the child runs its own code, before it has its objects
    ('starting'), or once it has written its first PNG ('drawing'): the run draws the figures itself over what the
    child left, exit 0, the PNGs byte-identical, one warning, run.json says so; no process left."""
    scene = tmp_path / "ramp.toml"
    scene.write_text(SCENE_TEXT)
    out = tmp_path / "o"
    if when == "starting":
        ready = lambda pid, parts: True  # noqa: E731
    else:
        ready = lambda pid, parts: any(next(p.glob("*.png"), None) for p in parts)  # noqa: E731
    thread, killed = _kill_when(ready, out)
    code, err = _run_cli(capsys, monkeypatch, "1", "run", scene, "-o", out, "--quiet", "--no-cache")
    thread.join(timeout=5)
    assert killed, "the figure process was not killed"
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in both["same"].iterdir())
    for png in both["same"].glob("*.png"):
        assert (out / png.name).read_bytes() == png.read_bytes(), png.name
    record = json.loads((out / "run.json").read_text())
    said = f"the figure process (pid {killed[0]}) was killed by SIGKILL before it had drawn the figures"
    assert record["figures"]["process"] == "same"
    assert record["figures"]["fallback"] == f"{said}; drawn in the run's own process"
    assert record["figures"]["why"].startswith(f"{ENV}=1")
    same = json.loads((both["same"] / "run.json").read_text())
    fell = {"category": "AfferentWarning", "message": f"The figures were drawn in the run's own process: {said} "
                                                      "(out of memory?)."}
    assert record["warnings"] == same["warnings"] + [fell]
    assert _children() == []


@needs_two_cores
@linux_only
def test_a_stopped_figure_process_is_not_waited_for_forever(both, tmp_path, capsys, monkeypatch):
    """Issue 33.9: a figure process alive but stopped (SIGSTOP) made the run wait forever. Stopped for STOPPED_S
    (here 0.5 s), it is killed and the run draws the figures itself, as for a child that died: exit 0, the same
    PNGs, run.json says why. (A watchdog continues the child after 60 s, so that a run without the bound ends.)"""
    import signal
    import threading

    monkeypatch.setattr(figure_process, "STOPPED_S", 0.5, raising=False)
    scene = tmp_path / "ramp.toml"
    scene.write_text(SCENE_TEXT)
    out = tmp_path / "o"
    thread, stopped = _kill_when(lambda pid, parts: True, out, sig=signal.SIGSTOP)

    def watchdog():
        thread.join(timeout=60)
        for _ in range(600):
            if stopped and _alive(stopped[0]):
                threading.Event().wait(0.1)
        if stopped and _alive(stopped[0]):
            os.kill(stopped[0], signal.SIGCONT)

    threading.Thread(target=watchdog, daemon=True).start()
    code, err = _run_cli(capsys, monkeypatch, "1", "run", scene, "-o", out, "--quiet", "--no-cache")
    assert stopped, "the figure process was not stopped"
    assert code == 0, err
    for png in both["same"].glob("*.png"):
        assert (out / png.name).read_bytes() == png.read_bytes(), png.name
    record = json.loads((out / "run.json").read_text())["figures"]
    assert record["process"] == "same"
    assert record["fallback"] == (f"the figure process (pid {stopped[0]}) was stopped (state T: SIGSTOP or a "
                                  "debugger) for 0.5 s before it had drawn the figures; drawn in the run's own process")
    assert not _alive(stopped[0]) and _children() == []


def test_a_dead_childs_leftovers_are_replaced_when_the_run_draws(tmp_path):
    """What a figure process killed while saving leaves in the run's temporary folder (a whole PNG, a temporary
    '.NAME.*.part') is removed as the run draws that figure itself; the other files stay."""
    from afferent._figure_process import _figures_into

    objects = _figure_objects()
    objects["sed_static"] = objects["sed"]
    stale = {"sed_map.png": b"half a figure", ".sed_map.png.k2j4x_a1.part": b"half", "sed_map.csv": b"a table"}
    for name, data in stale.items():
        (tmp_path / name).write_bytes(data)
    assert _figures_into(str(tmp_path), {"sed_map"}, objects, replace=True) == ["sed_map.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sed_map.csv", "sed_map.png"]
    assert (tmp_path / "sed_map.csv").read_bytes() == b"a table"
    assert (tmp_path / "sed_map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


#: small real index exports (tests/data/*/README.md): each names its data in other files
INDEXES = ["dealii/block.pvd", "dealii/block_00.pvtu", "kratos/vtu/Structure.vtm.series", "kratos/vtu/Structure_1.vtm",
           "dolfinx/block.xdmf", "dolfinx/sed_only.xdmf"]


@pytest.mark.parametrize("name", INDEXES)
def test_an_index_export_counts_the_files_its_reader_opens(name):
    """The gate's size of a .pvd/.pvtu/.vtm/.xdmf is the sum of the files its reader opens (RawExport.files: the
    VTU steps and pieces, the HDF5 file), counted from the index alone."""
    from afferent._figure_process import export_bytes
    from afferent.io import data_files, read_raw

    path = DATA_DIR / name
    opened = read_raw(path).files
    assert sorted(map(os.path.abspath, data_files(path))) == sorted(map(os.path.abspath, opened))
    assert export_bytes([str(path)]) == sum(os.path.getsize(p) for p in opened) > 2 * os.path.getsize(path)


def test_a_binary_xdmf_counts_its_bin_files(tmp_path, monkeypatch):
    """meshio's Format="Binary" XDMF (a .bin file per array, named relative to the folder it was written in)."""
    import meshio

    from afferent._figure_process import export_bytes
    from afferent.io import read_raw

    monkeypatch.chdir(tmp_path)
    cells = [("tetra", np.array([[0, 1, 2, 3]]))]
    meshio.write("bin.xdmf", meshio.Mesh(np.eye(4, 3), cells, point_data={"sed": np.arange(4.0)}), data_format="Binary")
    opened = read_raw("bin.xdmf").files
    assert len(opened) == 4  # the .xdmf, points, cells, sed
    assert export_bytes(["bin.xdmf"]) == sum(os.path.getsize(p) for p in opened)


def test_an_index_that_cannot_be_listed_counts_as_itself(tmp_path):
    """A broken index is sized as the file named (its reader says what is wrong); a missing file counts 0."""
    from afferent._figure_process import export_bytes

    bad = DATA_DIR / "bad" / "nan_timestep.pvd"
    assert export_bytes([str(bad)]) == os.path.getsize(bad)
    (tmp_path / "broken.xdmf").write_text("<Xdmf><Domain>")
    assert export_bytes([str(tmp_path / "broken.xdmf")]) == len("<Xdmf><Domain>")
    assert export_bytes([str(tmp_path / "none.vtu")]) == 0
    csv = SAMPLE_DIR / "block4" / "receptors.csv"
    assert export_bytes([str(bad)], side=[str(csv), None]) == os.path.getsize(bad) + os.path.getsize(csv)


@linux_only
def test_the_run_sizes_a_pvd_series_by_its_vtu_steps(tmp_path, monkeypatch):
    """The bundled 6-step .pvd (554 bytes) names 4.5 MB of VTU files: the run's gate counts those."""
    from afferent.scene import load_scene, run_scene

    monkeypatch.delenv(ENV, raising=False)
    series = SAMPLE_DIR / "block4" / "series_0p88mm"
    size = sum(p.stat().st_size for p in series.iterdir())
    scene = tmp_path / "s.toml"
    scene.write_text(f'[export]\nfile = "{(series / "indent.pvd").as_posix()}"\nlength_unit = "mm"\nsed_unit = "MPa"\n'
                     f'[receptors]\nfile = "{(SAMPLE_DIR / "block4" / "receptors.csv").as_posix()}"\n'
                     '[outputs]\nwant = ["sed_map", "plots"]\n')
    res = run_scene(load_scene(scene).with_output(tmp_path / "o"), use_cache=False, figure_process=True)
    if usable_cores() >= 2:
        assert res.record["figures"]["why"] == (f"the export ({size / 1e6:.3g} MB) is read before a second process "
                                                "could start (under 16 MB)")
    assert _children() == []
