"""Check before the work (issue 34, item 7): every named file, material array and option combination is checked
before an export is read; sites found on the export (--grid tips|bases, hotspot_beside) come from the one read;
a receptor file takes the materials of the sites hotspot_beside finds beside it.

Reads are counted, not timed: ``afferent.io._meshio.read_vtu`` (the one parse of a .vtu, every route through
the readers) is wrapped in a counter. All on the real exports in sample_sed/ and tests/data/.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pandas as pd
import pytest

from afferent.cli import main
from conftest import ROOT

BLOCK4 = ROOT / "sample_sed" / "block4" / "indent_0p88mm.vtu"
RIDGED = ROOT / "sample_sed" / "chapter4" / "ridged3d"
UNITS = ["--length-unit", "mm", "--sed-unit", "MPa"]


@pytest.fixture
def parses(monkeypatch):
    """The .vtu files parsed so far (a list that grows as the command reads)."""
    import afferent.io._meshio as meshio_reader

    seen = []
    original = meshio_reader.read_vtu

    def counted(path, *args, **kwargs):
        seen.append(str(path))
        return original(path, *args, **kwargs)

    monkeypatch.setattr(meshio_reader, "read_vtu", counted)
    return seen


def _error(capsys) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("afferent: error:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ------------------------------------------------------------------------------------------- files before reading
@pytest.mark.parametrize("argv, message", [
    (["sample", str(BLOCK4), "--receptors", "{tmp}/none.csv", *UNITS, "-o", "{tmp}/s.csv"],
     "Receptor file '{tmp}/none.csv' (--receptors) not found."),
    (["run", str(BLOCK4), "--grid", "tips", *UNITS, "--params", "start", "--waveform", "{tmp}/none.csv",
      "--d-ref-mm", "0.88", "--spikes", "-o", "{tmp}/out"],
     "Waveform file '{tmp}/none.csv' (--waveform) not found."),
    (["run", str(BLOCK4), "--grid", "tips", *UNITS, "--params", "start", "--observed", "{tmp}/none.csv",
      "--observed-unit", "mm", "-o", "{tmp}/out"],
     "Observed profile file '{tmp}/none.csv' (--observed) not found."),
    (["run", str(BLOCK4), "--grid", "tips", *UNITS, "--params", "start", "--synthesis", "map:{tmp}/none.csv",
      "-o", "{tmp}/out"],
     "Branching map file '{tmp}/none.csv' (--synthesis) not found."),
])
def test_a_missing_file_is_named_before_the_export_is_read(argv, message, tmp_path, parses, capsys):
    """Before: each came after the export was read (a missing receptor file of ``sample`` after the mesh, a
    waveform or an observed profile after sampling)."""
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    assert _error(capsys) == "afferent: error: " + message.replace("{tmp}", str(tmp_path))
    assert parses == []


def _scene(tmp_path, body: str, name: str = "scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return path


def test_a_scene_names_its_missing_waveform_file_before_reading(tmp_path, parses, capsys):
    scene = _scene(tmp_path, f"""
        [export]
        file = "{BLOCK4}"
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        grid = "tips"
        [stimulus]
        waveform = "file"
        file = "none.csv"
        length_unit = "mm"
        d_ref_mm = 0.88
        [outputs]
        want = ["spikes"]
        """)
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "--no-cache"]) == 2
    assert _error(capsys) == (f"afferent: error: Waveform file {str(tmp_path / 'none.csv')!r} ([stimulus] file) "
                              "not found.")
    assert parses == []


def test_run_scene_checks_its_files_before_reading(tmp_path, parses):
    """The Python route: the same check, before any read (run_scene, whatever started it). Before: the observed
    profile was found missing after the export was read and sampled."""
    from afferent.scene import run_scene, scene_from_dict

    scene = scene_from_dict({"export": {"file": str(BLOCK4), "length_unit": "mm", "sed_unit": "MPa"},
                             "receptors": {"grid": "tips"},
                             "fit": {"observed": str(tmp_path / "none.csv"), "length_unit": "mm"},
                             "outputs": {"want": ["fit"], "dir": str(tmp_path / "out")}})
    with pytest.raises(FileNotFoundError, match=r"^Observed profile file '.*none\.csv' not found\.$"):
        run_scene(scene, use_cache=False)
    assert parses == []


# ---------------------------------------------------------------------------------- material array on the header
@pytest.mark.parametrize("command", ["sample", "run", "info"])
def test_a_wrong_material_array_is_refused_on_the_header(command, tmp_path, parses, capsys):
    """Before: refused after the export was read (twice for sample and run: the read, then the site finder's)."""
    argv = [command, str(BLOCK4), "--grid", "tips", "--material-array", "layr", *UNITS]
    argv += {"sample": ["-o", str(tmp_path / "s.csv")], "run": ["--params", "start", "-o", str(tmp_path / "o")],
             "info": []}[command]
    assert main(argv) == 2
    assert _error(capsys) == (f"afferent: error: Export {str(BLOCK4)!r} must have a cell array 'layr' "
                              "(--material-array) of material ids; found cell arrays 'SED', 'layer' instead. "
                              "Did you mean 'layer'?")
    assert parses == []


def test_a_scene_material_array_is_refused_on_the_header_with_its_line(tmp_path, parses, capsys):
    scene = _scene(tmp_path, f"""
        [export]
        file = "{RIDGED / 'bar.vtu'}"
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        file = "{RIDGED / 'ra_sites.csv'}"
        material_array = "layr"
        [outputs]
        want = ["hotspots"]
        hotspot_beside = "bases"
        """)
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "--no-cache"]) == 2
    assert _error(capsys).startswith(f"afferent: error: Scene file {str(scene)!r}, line 8: Export "
                                     f"{str(RIDGED / 'bar.vtu')!r} must have a cell array 'layr' of material ids")
    assert parses == []


def test_the_header_of_a_pvd_step_is_read_not_its_arrays(tmp_path, parses, capsys):
    """A .pvd: its first step file's header (a copy of the block-4 export as the one step of a collection)."""
    import shutil

    shutil.copy(BLOCK4, tmp_path / "step0.vtu")
    pvd = tmp_path / "series.pvd"
    pvd.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1"><Collection>\n'
                   '<DataSet timestep="0.5" part="0" file="step0.vtu"/>\n</Collection></VTKFile>\n')
    assert main(["sample", str(pvd), "--grid", "bases", "--material-array", "Layers", *UNITS,
                 "-o", str(tmp_path / "s.csv")]) == 2
    assert _error(capsys) == (f"afferent: error: Export {str(tmp_path / 'step0.vtu')!r} must have a cell array "
                              "'Layers' (--material-array) of material ids; found cell arrays 'SED', 'layer' instead. "
                              "Did you mean 'layer'?")
    assert parses == []


def test_the_header_names_agree_with_the_reader():
    """cell_array_names (no data decoded) lists the cell arrays read_raw reads, where it lists any."""
    import warnings

    from afferent.io import read_raw
    from afferent.io._vtu import cell_array_names

    files = [BLOCK4, RIDGED / "bar.vtu", ROOT / "tests" / "data" / "vtk" / "pieces2.vtu",
             ROOT / "tests" / "data" / "mfem" / "block" / "Cycle000001" / "proc000000.vtu"]
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raw = read_raw(str(path))
        assert cell_array_names(str(path)) == tuple(a.name for a in raw.arrays.values() if a.location == "cell")


# ------------------------------------------------------------------------------------------- option combinations
@pytest.mark.parametrize("extra, message", [
    (["--receptors", str(ROOT / "sample_sed" / "block4" / "receptors.csv"), "--material-array", "layer"],
     "--material-array applies to sites generated with --grid, not to a receptor file"),
    (["--receptors", str(ROOT / "sample_sed" / "block4" / "receptors.csv"), "--pitch-x-mm", "0.5"],
     "--pitch-x-mm applies to sites generated with --grid, not to a receptor file"),
    (["--grid", "y=2.3", "--upper", "3"], "--upper applies to --grid tips|bases (sites found on the export's "
                                          "materials), not to --grid y=2.3; remove --upper."),
    (["--grid", "tips", "--receptor-unit", "mm"], "--receptor-unit is the unit of a receptor file"),
])
def test_receptor_options_that_would_be_ignored_are_refused(extra, message, tmp_path, parses, capsys):
    """Before: ignored (a receptor file's sites never use the material array or the pitches; a grid, the receptor
    unit), the command ran."""
    assert main(["sample", str(BLOCK4), *extra, *UNITS, "-o", str(tmp_path / "s.csv")]) == 2
    assert message in _error(capsys)
    assert parses == []


# --------------------------------------------------------------------------------------------- one read per export
@pytest.mark.parametrize("command", ["sample", "run", "info"])
def test_found_sites_come_from_the_one_read(command, tmp_path, parses, capsys):
    """Before: sample and run read the export twice (info three times): the sites were found on a second read."""
    argv = [command, str(BLOCK4), "--grid", "tips", *UNITS]
    argv += {"sample": ["-o", str(tmp_path / "s.csv")],
             "run": ["--params", "start", "--no-plots", "--no-cache", "-o", str(tmp_path / "o")], "info": []}[command]
    assert main(argv) == 0, capsys.readouterr().err
    assert parses == [str(BLOCK4)]


def test_sites_from_the_one_read_are_those_of_the_export():
    """sites_from_raw on the raw export iter_sed hands over = sites_from_export, which reads the file itself."""
    from afferent.io import iter_sed
    from afferent.receptors import sites_from_export
    from afferent.receptors._tips import sites_from_raw

    raws = []
    field = next(iter_sed(str(BLOCK4), length_unit="mm", sed_unit="MPa", on_first_raw=raws.append))
    assert field.n_points > 0 and len(raws) == 1
    kw = dict(length_unit="mm", upper=1, lower=2, kind="tips")
    np.testing.assert_array_equal(sites_from_raw(raws[0], BLOCK4, **kw).positions,
                                  sites_from_export(BLOCK4, **kw).positions)


def _beside_scene(tmp_path, export, receptors: str, extra: str = "", name: str = "beside.toml"):
    return _scene(tmp_path, f"""
        [scene]
        name = "{name[:-5]}"
        [export]
        file = "{export}"
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        {receptors}
        {extra}
        [outputs]
        want = ["hotspots"]
        hotspot_beside = "bases"
        """, name)


def test_hotspot_beside_reads_the_export_once(tmp_path, parses, capsys):
    """grid tips + hotspot_beside bases: before, four parses (read, tips' finder, read again, bases' finder)."""
    scene = _beside_scene(tmp_path, RIDGED / "bar.vtu", 'grid = "tips"')
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "--no-cache", "-q"]) == 0, capsys.readouterr().err
    assert parses == [str(RIDGED / "bar.vtu")]
    table = pd.read_csv(tmp_path / "out" / "hotspots.csv")
    assert table["map"].nunique() == 2


# ---------------------------------------------------------------------- a receptor file with bases found beside it
def test_a_receptor_file_takes_the_material_array_of_the_bases_found_beside_it(tmp_path, capsys):
    """The chapter-4 3D block with its cell array renamed 'tissue' (same length, bytes replaced in the XML header):
    the RA-I sites from ra_sites.csv, the SA-I bases found on 'tissue' beside them; the same maps as the
    original file with 'layer'. Before: "[receptors] 'material_array' applies to a generated grid, not to a
    receptor file" (exit 2), so the bases could only be found on an array named 'layer'."""
    data = (RIDGED / "bar.vtu").read_bytes()
    assert data.count(b'Name="layer"') == 1
    renamed = tmp_path / "bar_tissue.vtu"
    renamed.write_bytes(data.replace(b'Name="layer"', b'Name="tissue"'))
    ra = f'file = "{RIDGED / "ra_sites.csv"}"'
    a = _beside_scene(tmp_path, renamed, ra, 'material_array = "tissue"\nupper = 1\nlower = 2', "a.toml")
    b = _beside_scene(tmp_path, RIDGED / "bar.vtu", ra, "", "b.toml")
    for scene, out in ((a, "a"), (b, "b")):
        assert main(["run", str(scene), "-o", str(tmp_path / out), "--no-cache", "-q"]) == 0, capsys.readouterr().err
    ta, tb = (pd.read_csv(tmp_path / o / "hotspots.csv") for o in ("a", "b"))
    assert len(ta) == len(tb) and ta["map"].nunique() == 2
    np.testing.assert_allclose(ta.select_dtypes("number").to_numpy(), tb.select_dtypes("number").to_numpy(),
                               rtol=1e-12, atol=0)


def test_material_array_with_a_receptor_file_and_no_found_sites_is_still_refused(tmp_path, capsys):
    scene = _scene(tmp_path, f"""
        [export]
        file = "{BLOCK4}"
        length_unit = "mm"
        sed_unit = "MPa"
        [receptors]
        file = "{ROOT / 'sample_sed' / 'block4' / 'receptors.csv'}"
        material_array = "layer"
        [outputs]
        want = ["sed_map"]
        """)
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "--no-cache"]) == 2
    assert ("[receptors] 'material_array' applies to a generated grid, not to a receptor file (material_array, "
            "upper, lower and the pitches also apply to the sites [outputs] hotspot_beside = 'tips' | 'bases' finds "
            "beside the file's); remove it") in _error(capsys)
