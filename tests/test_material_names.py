"""Material-id arrays by any common name, and by the user's name for any receptor source (issue 36 item 6).

Copies of the chapter-4 ridged block (sample_sed/chapter4/ridged3d/bar.vtu, cell array 'layer': 1 epidermis,
2 dermis) with the array renamed; receptors at the papilla tips (ra_sites.csv), on the interface, sampled on
the dermis side (--side 2), which needs the material of each cell.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
import pandas as pd
import pytest

from afferent.cli import main

ROOT = Path(__file__).resolve().parent.parent
BAR = ROOT / "sample_sed" / "chapter4" / "ridged3d" / "bar.vtu"
SITES = ROOT / "sample_sed" / "chapter4" / "ridged3d" / "ra_sites.csv"


def _renamed(tmp_path: Path, name: str) -> Path:
    mesh = meshio.read(BAR)
    mesh.cell_data = {(name if k == "layer" else k): v for k, v in mesh.cell_data.items()}
    path = tmp_path / f"bar_{name.replace(':', '_')}.vtu"
    mesh.write(path)
    return path


def _sample(export: Path, out: Path, *extra) -> int:
    return main(["sample", str(export), "--receptors", str(SITES), "--length-unit", "mm", "--sed-unit", "MPa",
                 "--side", "2", "--location", "cell", "-q", "-o", str(out), *extra])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.csv"
    assert _sample(BAR, out) == 0
    return pd.read_csv(out)


@pytest.mark.parametrize("name", ["region_id", "material_index", "cell_tags", "PhysicalIds", "elem_set"])
def test_common_material_array_names_are_recognised(name, tmp_path, reference):
    # before: none of these names was recognised and --side 2 was refused ("has none")
    assert _sample(_renamed(tmp_path, name), tmp_path / "s.csv") == 0
    np.testing.assert_allclose(pd.read_csv(tmp_path / "s.csv")["sed_pa"], reference["sed_pa"], rtol=1e-12)


def test_material_array_names_any_array_with_a_receptor_file(tmp_path, capsys, reference):
    export = _renamed(tmp_path, "zz_groups")
    assert _sample(export, tmp_path / "a.csv") == 2  # an unusual name is not guessed
    assert "--side 2 needs the material id of each cell" in capsys.readouterr().err
    # before: "--material-array applies to sites generated with --grid, not to a receptor file"
    assert _sample(export, tmp_path / "b.csv", "--material-array", "zz_groups") == 0
    np.testing.assert_allclose(pd.read_csv(tmp_path / "b.csv")["sed_pa"], reference["sed_pa"], rtol=1e-12)
    capsys.readouterr()
    assert _sample(export, tmp_path / "c.csv", "--material-array", "tissue") == 2  # named, absent: said, not ignored
    assert capsys.readouterr().err == (
        f"afferent: error: SED file {str(export)!r} has no cell array 'tissue' of whole-number material ids "
        "(material_array, --material-array); its cell arrays: 'SED', 'zz_groups'.\n")
