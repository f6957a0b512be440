"""Mistakes that used to pass (issue 22): receptors collapsing onto one cell in the wrong unit, observed
positions in the wrong unit, a series' negative SED reported for one step, ``afferent sample`` reading
before refusing its output."""

from __future__ import annotations

import re
import warnings

import meshio
import numpy as np
import pandas as pd
import pytest

from afferent.cli import main
from afferent.exceptions import AfferentWarning, UnitError

from conftest import hex_box


@pytest.fixture
def block(tmp_path):
    """A 4 x 3.1 x 4 mm hex block (coordinates in mm) with a smooth SED (MPa), receptors in m and in mm."""
    folder, vtu = _block(tmp_path)
    mm = pd.read_csv(folder / "R_mm.csv")
    (folder / "R_m.csv").write_text((mm / 1000).to_csv(index=False))  # positions in m, to be read as mm
    return folder, vtu


def test_receptors_in_the_wrong_unit_collapsing_onto_one_cell_are_refused_naming_the_unit_flag(block, capsys):
    from afferent import read_receptors, read_sed, sample_sed

    folder, vtu = block
    field = read_sed(vtu, length_unit="mm", sed_unit="MPa")
    ok = sample_sed(field, read_receptors(folder / "R_mm.csv", length_unit="mm"))
    assert np.unique(ok.values).size > 50
    with pytest.raises(UnitError, match=r"All 162 receptors of receptor file '.*R_m.csv' inside the field fall in one "
                                        r"cell or on one point \(\d+ field value\(s\) feed them all\)"):
        sample_sed(field, read_receptors(folder / "R_m.csv", length_unit="mm"), method="linear")
    with pytest.raises(UnitError, match="Declare the receptors' unit"):
        sample_sed(field, read_receptors(folder / "R_m.csv", length_unit="mm"), method="nearest")
    argv = ["run", str(vtu), "--receptors", str(folder / "R_m.csv"), "--length-unit", "mm", "--sed-unit", "MPa",
            "--params", "start", "--no-cache", "--no-plots", "-o", str(folder / "out")]
    assert main(argv) == 2 and not (folder / "out").exists()
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: All 162 receptors") and "(--receptor-unit, [receptors] length_unit)" in err
    assert main(argv[:4] + ["--receptor-unit", "m"] + argv[4:]) == 0, capsys.readouterr().err


def test_calibrate_refuses_observed_positions_whose_span_is_orders_from_the_afferents_either_way(tmp_path):
    from afferent import read_receptors, read_sed, sample_sed
    from afferent.calibration import calibrate
    from afferent.profiles import ObservedProfile

    folder, vtu = _block(tmp_path)
    sed = sample_sed(read_sed(vtu, length_unit="mm", sed_unit="MPa"), read_receptors(folder / "R_mm.csv",
                                                                                       length_unit="mm"))
    pos = np.linspace(0.0, 4.0, 12)
    for factor, ratio in ((1.0, "0.000"), (1e-6, "[0-9.]+e\\+03|[0-9]{3,}")):  # mm read as m; um read as mm
        obs = ObservedProfile(pos * factor, np.exp(-(pos - 2.0) ** 2), source="obs.csv")
        with pytest.raises(UnitError, match=rf"The afferent positions span [0-9.e-]+ m, the observed positions of "
                                            rf"'obs.csv' [0-9.e+-]+ m \(({ratio})"):
            calibrate(sed, obs, max_iter=1)
        with pytest.raises(UnitError, match="Declare the unit they are written in \\(--observed-unit; "):
            calibrate(sed, obs, max_iter=1)


def _block(tmp_path):
    points, hexes = hex_box(8, 4, 8, size=(4.0, 3.1, 4.0))
    x, y, z = points.T
    vtu = tmp_path / "b.vtu"
    meshio.write(vtu, meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": 1e-4 * (1 + x + z) * (y / 3.1)}))
    X, Z = np.meshgrid(np.arange(0.22, 4.0, 0.44), np.arange(0.11, 4.0, 0.22), indexing="ij")
    pd.DataFrame({"x": X.ravel(), "y": 2.35, "z": Z.ravel()}).to_csv(tmp_path / "R_mm.csv", index=False)
    return tmp_path, vtu


def test_a_series_negative_sed_warning_counts_every_step_truthfully(tmp_path):
    from afferent import iter_sed

    points, hexes = hex_box(3, 3, 3, size=(1.0, 1.0, 1.0))
    files = []
    for k in range(5):
        sed = 1e-3 * (k + 1) * (1 + points[:, 0])
        sed[:2] = -1e-7  # a nodal-extrapolation artefact, within the tolerance, in every step
        if k == 2:
            sed[2] = -2e-7
        files.append(tmp_path / f"s{k}.vtu")
        meshio.write(files[-1], meshio.Mesh(points, [("hexahedron", hexes)], point_data={"SED": sed}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        steps = list(iter_sed([str(f) for f in files], length_unit="mm", sed_unit="MPa",
                              times=[0.0, 0.1, 0.2, 0.3, 0.4]))
    assert len(steps) == 5 and all(s.sed.min() == 0.0 for s in steps)
    neg = [str(w.message) for w in caught if issubclass(w.category, AfferentWarning) and "negative" in str(w.message)]
    assert len(neg) == 1, neg
    assert re.match(r"SED series '.*s0.vtu' and 4 more file\(s\): negative SED values in 5 of 5 step\(s\) \(step\(s\) "
                    r"0, 1, 2, 3, 4; counted from 0\): 11 of 320 values in total", neg[0]), neg[0]


def test_sample_refuses_an_existing_output_before_reading_the_export(tmp_path, capsys):
    bad = tmp_path / "broken.vtu"
    bad.write_text("<VTKFile>not a mesh")  # reading it would fail with another message
    (tmp_path / "R.csv").write_text("x,y,z\n0,0,0\n")
    out = tmp_path / "sed.csv"
    out.write_text("keep me\n")
    assert main(["sample", str(bad), "--receptors", str(tmp_path / "R.csv"), "--length-unit", "mm",
                 "--sed-unit", "MPa", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "exists" in err and "broken.vtu" not in err, err
    assert out.read_text() == "keep me\n"
