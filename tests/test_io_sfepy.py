"""A VTK file written by SfePy itself (tests/data/sfepy/make_sfepy.py, SfePy 2026.3): cell data
`cauchy_stress`, `cauchy_strain` as SfePy's examples write them (el_avg, order 11 22 33 12 13 23,
engineering shear strain) and SfePy's own element-average SED computed from its elasticity
matrix. The 'sfepy' preset is checked against the tool's own numbers.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from afferent import read_sed
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import read_raw

from conftest import DATA_DIR

VTK = DATA_DIR / "sfepy" / "block.vtk"
E, NU = 0.1, 0.45  # MPa


def test_sfepy_tensors_obey_hookes_law_in_sfepys_order_with_engineering_shear():
    raw = read_raw(VTK)
    s, g = raw.arrays["cauchy_stress"].values[0], raw.arrays["cauchy_strain"].values[0]  # (32, 6): 11 22 33 12 13 23
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    hooke = np.concatenate([lam * g[:, :3].sum(1, keepdims=True) + 2 * mu * g[:, :3], mu * g[:, 3:]], axis=1)
    np.testing.assert_allclose(hooke, s, rtol=1e-9, atol=1e-12 * np.abs(s).max())  # tau = G gamma: engineering


def test_the_sfepy_preset_reads_sfepys_file_and_the_wrong_presets_are_caught():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        right = read_sed(VTK, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="sfepy")
    shear = right.provenance.checks["shear_convention"]
    assert shear["consistent"] and shear["ratio"] == pytest.approx(1.0, abs=1e-9)
    assert shear["k_shear"] == pytest.approx(2 * E / (2 * (1 + NU)) * 1e6, rel=1e-9)  # 2G, Pa
    # SfePy's own element-average SED is larger than 1/2 sigma:eps of its element-averaged tensors
    # (the average of a square exceeds the square of the average) by 9 % (relative L2): recorded
    own = read_sed(VTK, length_unit="mm", sed_unit="MPa")
    assert np.all(own.sed >= right.sed * (1 - 1e-9))
    chk = right.provenance.checks["tensor_sed_vs_export_sed"]
    assert chk["agree"] and 0.05 < chk["relative_difference"] < 0.15 and chk["best_preset"] in ("abaqus", "ansys", "sfepy")
    for wrong in ("vtk", "comsol"):  # tensor-shear presets on engineering shear: refused, naming the presets that fit
        with pytest.raises(SEDFormatError, match=re.escape(
                "the file's shear strain looks engineering, and read as tensor the SED from its tensors is wrong (its "
                "shear terms doubled), the likely cause the preset of another tool; give the preset of the tool that "
                "wrote it, one of 'abaqus', 'ansys', 'sfepy', 'kratos' (engineering shear), or confirm the tensor "
                "convention with shear='tensor'.")):
            read_sed(VTK, length_unit="mm", stress_unit="MPa", sed_from="exact", preset=wrong)
        with pytest.warns(AfferentWarning, match=re.escape("the file's shear strain looks engineering")):  # confirmed
            read_sed(VTK, length_unit="mm", stress_unit="MPa", sed_from="exact", preset=wrong, shear="tensor")
