"""SED from the stress alone (sed_from='stress', issue 36 item 4): closed forms, real exports, refusals.

Every real export of tests/data that carries stress and strain from a linear-elastic model is read with
its model's E and nu (its regeneration script or README): the SED of the stress alone must equal 1/2
sigma:eps of the file's tensors (sed_from='exact') to the file's precision, and the tool's own SED where
it is the same quantity at the same places.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import SEDFormatError, UnitError
from afferent.io._elastic import HOOKE_RTOL
from afferent.strain_energy import sed_from_stress

DATA = Path(__file__).parent / "data"
E_PA, NU = 1.0e5, 0.45


def test_closed_forms_uniaxial_hydrostatic_and_shear():
    sigma, p = 1234.5, 678.9
    assert sed_from_stress([sigma, 0, 0, 0, 0, 0], E_PA, NU) == pytest.approx(sigma**2 / (2 * E_PA), rel=1e-14)
    assert sed_from_stress([0, 0, sigma, 0, 0, 0], E_PA, NU) == pytest.approx(sigma**2 / (2 * E_PA), rel=1e-14)
    assert sed_from_stress([-p, -p, -p, 0, 0, 0], E_PA, NU) == pytest.approx(3 * (1 - 2 * NU) * p**2 / (2 * E_PA),
                                                                               rel=1e-14)
    tau, g = 31.7, E_PA / (2 * (1 + NU))
    for k in (3, 4, 5):
        s = np.zeros(6)
        s[k] = tau
        assert sed_from_stress(s, E_PA, NU) == pytest.approx(tau**2 / (2 * g), rel=1e-14)  # U = tau^2 / 2G
    # incompressible: no volumetric energy, U = 3/(4E) s_dev:s_dev
    assert sed_from_stress([-p, -p, -p, 0, 0, 0], E_PA, 0.5) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match=re.escape("'poisson' must be in (-1, 0.5]; got 0.6 instead.")):
        sed_from_stress([1, 0, 0, 0, 0, 0], E_PA, 0.6)
    with pytest.raises(ValueError, match=re.escape("'young' must be finite and > 0 Pa; got 0.0 instead.")):
        sed_from_stress([1, 0, 0, 0, 0, 0], 0.0, NU)


def test_it_is_half_sigma_eps_of_hookes_law_for_any_stress():
    rng = np.random.default_rng(3)
    lam, mu = E_PA * NU / ((1 + NU) * (1 - 2 * NU)), E_PA / (2 * (1 + NU))
    eps = rng.standard_normal((50, 6)) * 1e-3
    sig = 2 * mu * eps
    sig[:, :3] += lam * eps[:, :3].sum(1, keepdims=True)
    half = 0.5 * (np.sum(sig[:, :3] * eps[:, :3], 1) + 2 * np.sum(sig[:, 3:] * eps[:, 3:], 1))
    np.testing.assert_allclose(sed_from_stress(sig, E_PA, NU), half, rtol=1e-12)


#: Real exports with stress and strain of a linear-elastic model: (file, read options, (E, nu), E unit, compare with
#: the tool's own SED array (same quantity, same places), tolerance on the SED relative to its largest value).
REAL = [
    ("calculix/block_c3d8.dat", dict(length_unit="mm", stress_unit="MPa", coordinates=str(DATA / "calculix/block_c3d8.frd")),
     (0.1, 0.45), "MPa", True, 1e-6),  # integration points, 6 digits
    ("calculix/block_c3d8.frd", dict(length_unit="mm", stress_unit="MPa"), (0.1, 0.45), "MPa", False, 1e-5),
    ("calculix/block_c3d10.frd", dict(length_unit="mm", stress_unit="MPa"), (0.1, 0.45), "MPa", False, 2e-5),
    ("calculix/block_c3d20r.frd", dict(length_unit="mm", stress_unit="MPa"), (0.1, 0.45), "MPa", False, 1e-5),
    ("calculix/block_c3d15.frd", dict(length_unit="mm", stress_unit="MPa"), (0.1, 0.45), "MPa", False, 1e-5),
    ("dolfinx/block.xdmf", dict(length_unit="mm", stress_unit="MPa"), (0.1, 0.45), "MPa", True, 1e-12),
    ("freefem/block_cell.vtk", dict(length_unit="mm", stress_unit="MPa", preset="vtk"), (0.1, 0.45), "MPa", True, 1e-12),
    ("sfepy/block.vtk", dict(length_unit="mm", stress_unit="MPa", preset="sfepy"), (0.1, 0.45), "MPa", False, 1e-12),
    ("kratos/vtk/Structure_0_1.vtk", dict(length_unit="m", stress_unit="Pa", preset="kratos"), (1e5, 0.45), "Pa", False,
     1e-6),
    ("med/block_hexa.rmed", dict(length_unit="m", stress_unit="Pa"), (1e5, 0.45), "Pa", False, 1e-12),
    ("med/block_tetra.med", dict(length_unit="m", stress_unit="Pa"), (1e5, 0.45), "Pa", True, 1e-12),
]


@pytest.mark.parametrize("name, kw, pair, unit, tool, tol", REAL, ids=[r[0] for r in REAL])
def test_real_exports_sed_from_stress_equals_half_sigma_eps_and_the_tools_sed(name, kw, pair, unit, tool, tol):
    path = DATA / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # plausibility and nodal-extrapolation warnings of these small test models
        stress = read_sed(path, sed_from="stress", elastic=pair, modulus_unit=unit, **kw)
        exact = read_sed(path, sed_from="exact", **kw)
    assert stress.provenance.sed_from == "stress" and stress.location == exact.location
    big = np.abs(exact.sed).max()
    np.testing.assert_allclose(stress.sed, exact.sed, rtol=0, atol=tol * big)
    checks = stress.provenance.checks["elastic"]
    assert checks["hooke"]["relative"] < HOOKE_RTOL and checks["hooke"]["scale"] == pytest.approx(1.0, rel=1e-3)
    note = next(n for n in stress.provenance.notes if n.startswith("SED computed from the stress alone"))
    assert "U = (1 + nu)/(2E) sigma:sigma - nu/(2E) tr(sigma)^2 (linear elastic, isotropic, small strain)" in note
    assert f"all: E = {pair[0]:g} {unit}, nu = {pair[1]:g} (from elastic=, E unit {unit} declared)" in note
    if tool:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            field = read_sed(path, location=stress.location,
                             **{k: v for k, v in kw.items() if k not in ("stress_unit", "preset")},
                             sed_unit=kw["stress_unit"])
        np.testing.assert_allclose(stress.sed, field.sed, rtol=0, atol=tol * np.abs(field.sed).max())


def _materials(tmp_path, text: str) -> Path:
    p = tmp_path / "materials.csv"
    p.write_text(text)
    return p


LAYERS = DATA / "exodus" / "layers_ioss.e"  # SfePy: block 1 dermis E = 0.1 MPa, block 2 epidermis E = 0.5 MPa


def test_a_two_material_export_with_a_materials_table(tmp_path):
    table = _materials(tmp_path, "# SfePy's layers (make_exodus.py)\nmaterial,name,E (MPa),nu\n1,dermis,0.1,0.45\n"
                                 "2,epidermis,0.5,0.45\n")
    kw = dict(length_unit="mm", stress_unit="MPa", location="cell")
    stress = read_sed(LAYERS, sed_from="stress", materials=table, shear="tensor", **kw)
    exact = read_sed(LAYERS, sed_from="exact", shear="tensor", **kw)
    np.testing.assert_allclose(stress.sed, exact.sed, rtol=0, atol=1e-12 * exact.sed.max())
    assert stress.provenance.checks["elastic"]["hooke"]["relative"] < 1e-12
    assert stress.provenance.columns["material"] == "material" and str(table) in stress.provenance.files
    assert any("material 1 (dermis): E = 0.1 MPa, nu = 0.45; material 2 (epidermis): E = 0.5 MPa, nu = 0.45" in n
               for n in stress.provenance.notes)
    # the constants swapped: the stress is 0.2 x Hooke's law of the strain under them, refused
    swapped = _materials(tmp_path, "material,E (MPa),nu\n2,0.1,0.45\n1,0.5,0.45\n")
    with pytest.raises(UnitError, match=r"its stress \(MPa declared\) is 0\.2\d* x Hooke's law of its strain 'strain_xx, "
                                        r".*: a unit of E or of the stress is off, or the constants are not the model's"):
        read_sed(LAYERS, sed_from="stress", materials=swapped, shear="tensor", **kw)
    # a material without constants is refused, named
    with pytest.raises(SEDFormatError, match=re.escape(
            f"Materials file {str(_materials(tmp_path, 'material,E,nu' + chr(10) + '1,0.1,0.45' + chr(10)))!r} has no "
            f"constants for material(s) 2 of SED file {str(LAYERS)!r} (array 'material', cell data); it lists 1. Add a "
            "row for each.")):
        read_sed(LAYERS, sed_from="stress", materials=tmp_path / "materials.csv", modulus_unit="MPa", **kw)


def test_point_stress_at_nodes_shared_by_two_materials_is_refused_and_copies_per_cell_are_read(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.0]])
    cells = [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))]
    s = np.array([[1e3, 0, 0, 0, 0, 0]] * 5)  # uniaxial 1 kPa everywhere, VTK order
    table = _materials(tmp_path, "material,E (kPa),nu\n1,100,0.45\n2,400,0.3\n")
    shared = tmp_path / "shared.vtu"
    meshio.write(shared, meshio.Mesh(pts, cells, point_data={"S": s}, cell_data={"material": [np.array([1, 2])]}))
    kw = dict(sed_from="stress", materials=table, length_unit="mm", stress_unit="Pa", preset="vtk")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(shared)!r}: 3 of its 5 stress points are nodes shared by cells of different materials (array "
            "'material'; first: point 1, materials 1 and 2): a nodal stress there is an average across materials that "
            "the constants of neither fit. Use the stress of the cells (location='cell'), or an export with a copy of "
            "each node per cell (discontinuous output).")):
        read_sed(shared, **kw)
    copies = tmp_path / "copies.vtu"  # discontinuous output: each cell its own nodes
    meshio.write(copies, meshio.Mesh(pts[[0, 1, 2, 3, 1, 2, 3, 4]], [("tetra", np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))],
                                     point_data={"S": np.array([[1e3, 0, 0, 0, 0, 0]] * 8)},
                                     cell_data={"material": [np.array([1, 2])]}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        field = read_sed(copies, **kw)
    # each copy has its own material's SED, sigma^2 / 2E with E = 100 and 400 kPa: at a node of one material that
    # value, at the shared nodes their mean (the coincident copies merged, each kept as a side)
    u1, u2 = 1e6 / (2 * 1e5), 1e6 / (2 * 4e5)
    assert field.sed[0, 0] == pytest.approx(u1, rel=1e-12) and field.sed[0, 4] == pytest.approx(u2, rel=1e-12)
    assert np.all((field.sed[0, 1:4] > u2) & (field.sed[0, 1:4] < u1)) and field.sides is not None


@pytest.mark.parametrize("preset, order", [("vtk", "xx yy zz xy yz xz"), ("abaqus", "xx yy zz xy xz yz"),
                                           ("openfoam", "xx xy xz yy yz zz")])
def test_every_component_order_reads_the_same_stress(tmp_path, preset, order):
    canonical = np.array([400.0, -250.0, 120.0, 90.0, -60.0, 30.0])  # xx yy zz xy yz xz, Pa
    written = canonical[["xx yy zz xy yz xz".split().index(c) for c in order.split()]]
    path = tmp_path / f"{preset}.vtu"
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    meshio.write(path, meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))], cell_data={"S": [written[None]]}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        field = read_sed(path, sed_from="stress", elastic=(100, 0.45), modulus_unit="kPa", preset=preset,
                         length_unit="mm", stress_unit="Pa")
    assert field.sed[0, 0] == pytest.approx(sed_from_stress(canonical, 1e5, 0.45), rel=1e-14)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(path)!r}: the 6-component stress array 'S' has no component names, so its order must be "
            "declared (the SED from stress alone mixes normal and shear components otherwise): pass preset= (xx yy zz "
            "xy xz yz: 'abaqus', 'calculix-dat', 'sfepy', 'code_aster'; xx yy zz xy yz xz: 'ansys', 'comsol', 'febio', "
            "'calculix-frd', 'lsdyna', 'elmer', 'kratos', 'vtk'; xx xy xz yy yz zz: 'openfoam').")):
        read_sed(path, sed_from="stress", elastic=(100, 0.45), modulus_unit="kPa", length_unit="mm", stress_unit="Pa")


def test_large_strain_of_a_finite_strain_model_is_refused_unless_accepted(tmp_path):
    """FEBio's neo-Hookean blocks (E = 0.8 / 0.2 MPa, nu = 0.45): pressed 25 % and slid, refused; at strains up to 8 %
    read, its stress off Hooke's law by a few percent (said), the SED near FEBio's own W."""
    table = _materials(tmp_path, "material,name,E (MPa),nu\n1,epidermis,0.8,0.45\n2,dermis,0.2,0.45\n")  # README
    kw = dict(sed_from="stress", materials=table, length_unit="mm", stress_unit="MPa")
    large = DATA / "febio" / "block_hex8_large.xplt"
    with pytest.raises(UnitError, match=r"is -0\.22\d* x Hooke's law of its strain 'Lagrange strain' under the elastic "
                                        r"constants given .*, or the model is far from linear elasticity \(its strain is "
                                        r"large: 0\.466\); if it is intended, confirm it with accept='modulus'"):
        read_sed(large, **kw)
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(large)!r}: its strain is large (the 99th percentile of |eps| at the most strained step is "
            "0.466, measured on the strain tensor 'Lagrange strain'; small strain: at most 0.1), where the SED from "
            "stress alone assumes linear elasticity at small strain; export the SED or the strain (sed_from='exact'); "
            "if it is intended, confirm it with accept='large-strain'")):
        read_sed(large, accept="modulus", **kw)
    with pytest.warns(UserWarning, match="confirmed: accept='large-strain'"):
        read_sed(large, accept=["modulus", "large-strain"], **kw)
    small = DATA / "febio" / "block_hex8.xplt"
    with pytest.warns(UserWarning, match="the model is not linear elastic with these constants"):
        field = read_sed(small, **kw)
    own = read_sed(small, length_unit="mm", sed_unit="MPa")
    rel = np.abs(field.sed - own.sed).max() / own.sed.max()
    assert 1e-3 < rel < 0.5  # neo-Hookean, not linear: near, not equal (measured 0.28 of the largest SED)
    assert 1e-3 < field.provenance.checks["elastic"]["hooke"]["relative"] < 0.5  # measured 0.22


def test_a_unit_slip_of_e_is_caught_by_hookes_law_of_the_files_strain():
    path = DATA / "dolfinx" / "block.xdmf"
    with pytest.raises(UnitError, match=re.escape(
            f"SED file {str(path)!r}: its stress (MPa declared) is 1e+03 x Hooke's law of its strain 'strain' under the "
            "elastic constants given (all: E = 0.1 kPa, nu = 0.45 (from elastic=, E unit kPa declared)): a unit of E or "
            "of the stress is off, or the constants are not the model's, or the model is far from linear elasticity (its "
            "strain is large: 0.117); if it is intended, confirm it with accept='modulus'")):
        read_sed(path, sed_from="stress", elastic=(0.1, 0.45), modulus_unit="kPa", length_unit="mm", stress_unit="MPa")


@pytest.mark.parametrize("kw, error, message", [
    (dict(), ValueError, "sed_from='stress' needs the elastic constants: elastic=(E, NU) with modulus_unit= for a "
                         "homogeneous model, or materials='materials.csv' (columns material, E, nu) - one of them."),
    (dict(elastic=(0.1, 0.45)), UnitError, "The unit of E in 'elastic' is neither stated nor declared; pass "
                                           "modulus_unit= (--modulus-unit, e.g. 'MPa'), or write it in the header: "
                                           "'E (MPa)'."),
    (dict(elastic=(0.1, 0.5001), modulus_unit="MPa"), ValueError,
     "'elastic': Poisson's ratio nu must be in (-1, 0.5]; got 0.5001 instead."),
    (dict(elastic=(-0.1, 0.45), modulus_unit="MPa"), ValueError,
     "'elastic': Young's modulus E must be a finite number > 0; got -0.1 instead."),
    (dict(elastic=(0.1,), modulus_unit="MPa"), ValueError, "'elastic' must be a pair (E, nu) of numbers; got (0.1,) "
                                                           "instead."),
    (dict(elastic=(0.1, 0.45), modulus_unit="MPa", poisson=0.45), ValueError,
     "'poisson' applies to sed_from='equivalent'; with sed_from='stress' give nu in elastic= or in the materials table."),
])
def test_the_constants_are_checked(kw, error, message):
    with pytest.raises(error, match=re.escape(message)):
        read_sed(DATA / "dolfinx" / "block.xdmf", sed_from="stress", length_unit="mm", stress_unit="MPa", **kw)


def test_materials_tables_are_checked(tmp_path):
    kw = dict(sed_from="stress", length_unit="mm", stress_unit="MPa", location="cell", shear="tensor")
    cases = [
        ("material,E (MPa),nu\n1,0.1,0.45\n2,0.5,0.45\n", dict(modulus_unit="kPa"),
         UnitError, "'modulus_unit' is 'kPa' but materials file {p!r} states 'MPa' for E; drop modulus_unit or make "
                    "it agree."),
        ("material,E,nu\ndermis,0.1,0.45\n", dict(modulus_unit="MPa"), SEDFormatError,
         "Materials file {p!r}, line 2: 'material' must be the integer id the export's material array holds (afferent "
         "info lists them; a 'name' column may label it); got 'dermis' instead."),
        ("material,E (MPa),nu\n1,0.1,0.45\n2,0,0.45\n", {}, ValueError,
         "Materials file {p!r}, line 3 (material 2): Young's modulus E must be a finite number > 0; got 0.0 instead."),
        ("material,E (MPa),nu\n1,0.1,-1\n", {}, ValueError,
         "Materials file {p!r}, line 2 (material 1): Poisson's ratio nu must be in (-1, 0.5]; got -1.0 instead."),
        ("id,modulus (MPa)\n1,0.1\n", {}, SEDFormatError,
         "Materials file {p!r} must have the columns material, E and nu (header e.g. 'material, E (MPa), nu'); missing "
         "nu in header ['id', 'modulus (MPa)']."),
    ]
    for text, extra, error, message in cases:
        p = _materials(tmp_path, text)
        with pytest.raises(error, match=re.escape(message.format(p=str(p)))):
            read_sed(LAYERS, materials=p, **kw, **extra)
    p = _materials(tmp_path, "material,E (MPa),nu\n1,0.1,0.45\n2,0.5,0.45\n")
    with pytest.raises(SEDFormatError, match=re.escape(
            f"SED file {str(LAYERS)!r} has no material array 'block' (cell data of material ids, or point data constant "
            "over each cell) to look the materials table up with; name it with material_array= (--material-array), or "
            "give one pair elastic=(E, nu) for a homogeneous model.")):
        read_sed(LAYERS, materials=p, material_array="block", **kw)


def test_cli_sed_from_stress(tmp_path, capsys):
    table = _materials(tmp_path, "material,E (MPa),nu\n1,0.1,0.45\n")
    receptors = tmp_path / "r.csv"
    receptors.write_text("x,y,z\n0.5,0.5,0.5\n")
    base = ["sample", str(LAYERS), "--receptors", str(receptors), "--length-unit", "mm", "--stress-unit", "MPa",
            "--sed-from", "stress", "--shear", "tensor", "--location", "cell", "-q"]
    assert main(base + ["--materials", str(table), "-o", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("afferent: error: Materials file") and "no constants for material(s) 2" in err
    assert err.count("\n") == 1
    table.write_text("material,E (MPa),nu\n1,0.1,0.45\n2,0.5,0.45\n")
    assert main(base + ["--materials", str(table), "-o", str(tmp_path / "b")]) == 0
    assert main(base + ["--elastic", "0.1", "--modulus-unit", "MPa", "-o", str(tmp_path / "c")]) == 2
    assert "--elastic must be E,NU (two comma-separated numbers, E in --modulus-unit); got '0.1' instead." in \
        capsys.readouterr().err
