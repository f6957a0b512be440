"""FEBio plot files (.xplt) read by afferent's own reader, on files FEBio wrote.

The files in tests/data/febio/ were written by FEBio 4 from the inputs beside them (a two-layer
skin block pressed on top; make_febio.py, README.md there); ``<name>.reference.npz`` holds what
the independent parser **pyfebio 0.3.0** reads from each (nodes, element tables, every variable
at every state; for the compressed file, from the same run written plain): the reference here.
"""

from __future__ import annotations

import json
import re
import shutil
import struct
import warnings

import numpy as np
import pytest

from afferent import read_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.io import format_of, iter_sed, read_raw
from afferent.io._export_checks import shear_consistency
from afferent.io._read_options import SHEAR_RATIO_BAND
from afferent.io._xplt import _open, xplt_step_count

from conftest import DATA_DIR

FEBIO = DATA_DIR / "febio"
HEX8 = FEBIO / "block_hex8.xplt"
TET10 = FEBIO / "block_tet10_z.xplt"  # states zlib-compressed
PENTA15 = FEBIO / "block_penta15.xplt"
LARGE = FEBIO / "block_hex8_large.xplt"  # pressed 0.25 mm and slid 0.2 mm: Green-Lagrange strains up to 0.47
FORMATS = FEBIO / "block_hex8_formats.xplt"  # 'SPR stress' per domain node (NODE), 'total energy' per domain (REGION)
ELEMENTS = [FEBIO / f"block_{kind}.xplt" for kind in ("hex20", "hex27", "tet15", "tet20", "pyra13")]  # one step each
FILES = [HEX8, TET10, PENTA15, LARGE, FORMATS, *ELEMENTS]
UNITS = dict(length_unit="mm", sed_unit="MPa")


def _reference(path):
    with np.load(path.with_suffix(".reference.npz")) as data:
        return {k: data[k] for k in data.files}


def test_xplt_ending_selects_the_febio_reader():
    assert format_of("model.xplt") == "xplt" and format_of("RUN.XPLT") == "xplt"


def _domains(path):
    f, model, _, volume, _ = _open(str(path))
    f.close()
    return model, volume


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_mesh_and_every_state_as_pyfebio_reads_them(path):
    ref, raw = _reference(path), read_raw(path)
    model, volume = _domains(path)
    np.testing.assert_array_equal(raw.points, ref["nodes"].astype(np.float64))
    for domain in model.domains:  # pyfebio keys a domain's element table (id, nodes) by its part id
        np.testing.assert_array_equal(domain.conn, ref[f"domain/{domain.part}"][:, 1:])
    n_states = raw.times.size
    np.testing.assert_array_equal(raw.times, [float(ref[f"time/{k}"][0]) for k in range(n_states)])
    np.testing.assert_allclose(raw.times, {LARGE: [0, 1, 2], HEX8: [0, .5, 1], TET10: [0, .5, 1],
                                           PENTA15: [0, .5, 1]}.get(path, [0, 1]))
    names = {key.split("/")[0] for key in ref if key.startswith(("node:", "elem:"))}
    assert len(names) >= 2
    fmt = {var.name: var.fmt for var in model.variables["domain"]}
    for key in names:
        got = raw.arrays[key.split(":", 1)[1]]
        for k in range(n_states):
            if key.startswith("node:"):
                np.testing.assert_array_equal(got.values[k].reshape(ref[f"{key}/{k}"].shape), ref[f"{key}/{k}"])
            elif got.location == "cell":  # the element blocks in the domains' order (block id = domain number)
                expected = np.concatenate([np.repeat(ref[f"{key}/{k}/{d.number}"].reshape(1, -1), d.conn.shape[0], 0)
                                           if fmt[got.name] == "REGION" else ref[f"{key}/{k}/{d.number}"] for d in volume])
                np.testing.assert_array_equal(got.values[k].reshape(expected.shape), expected)
            elif fmt[got.name] == "NODE":  # each domain's block over its nodes (FEBio's order): the mean where shared
                total, count = np.zeros(got.values[k].shape), np.zeros(got.values.shape[1])
                for d in volume:
                    np.add.at(total, d.nodes, ref[f"{key}/{k}/{d.number}"].reshape(d.nodes.size, -1))
                    np.add.at(count, d.nodes, 1)
                np.testing.assert_allclose(got.values[k], total / count[:, None], rtol=1e-6)
    assert raw.preset == "febio" and raw.files == (str(path),)


def test_region_and_node_formats_on_a_real_file():
    """'total energy' (one value per domain, REGION) becomes cell data repeated over the domain's elements: the
    domain's W integrated, so the sum of its elements' 'strain energy density' x their volume (0.25 mm^3; equal
    Gauss weights and detJ on these boxes); 'SPR stress' (per domain node, NODE) point data, equal to FEBio's own
    VTK output of the same run where one domain holds the node, the two domains' mean where they meet (z = 0.75 mm;
    FEBio's VTK writes the last domain's value there)."""
    raw, ref = read_raw(FORMATS), _reference(FORMATS)
    model, volume = _domains(FORMATS)
    assert {v.name: v.fmt for v in model.variables["domain"]} == {
        "stress": "ITEM", "strain energy density": "ITEM", "SPR stress": "NODE", "total energy": "REGION"}
    energy, spr, sed = (raw.arrays[k].values[1] for k in ("total energy", "SPR stress", "strain energy density"))
    assert raw.arrays["total energy"].location == "cell" and raw.arrays["SPR stress"].location == "point"
    dermis = slice(0, volume[0].conn.shape[0])  # 12 elements, then the epidermis' 4
    for part in (dermis, slice(dermis.stop, None)):
        assert np.unique(energy[part]).size == 1
        assert energy[part][0] == pytest.approx(sed[part].sum() * 0.25, rel=1e-5)
    shared = np.intersect1d(volume[0].nodes, volume[1].nodes)
    assert shared.size == 9 and np.allclose(raw.points[shared, 2], 0.75)
    alone = np.setdiff1d(np.arange(raw.points.shape[0]), shared)
    vtk = ref["vtk:SPR stress/1"]
    np.testing.assert_allclose(spr[alone], vtk[alone], rtol=1e-5, atol=1e-6 * np.abs(vtk).max())
    block = ref["elem:SPR stress/1/1"].reshape(-1, 6)  # the dermis' own values at its nodes (FEBio's order)
    own = block[[list(volume[0].nodes).index(n) for n in shared]]
    np.testing.assert_allclose(spr[shared], (own + vtk[shared]) / 2, rtol=1e-5, atol=1e-6 * np.abs(vtk).max())


_VTK_EDGES = {  # VTK's quadratic cells: the node after the corners on each edge, in order
    "hexahedron20": [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)],
    "pyramid13": [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)],
    "tetra10": [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)],
    "wedge15": [(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)],
}


@pytest.mark.parametrize("path", [HEX8, TET10, PENTA15, *ELEMENTS], ids=lambda p: p.stem)
def test_every_solid_element_type_becomes_cells_in_vtk_order(path):
    """FEBio's quadratic HEX20, PENTA15, TET10, PYRA13 keep every node, each mid-edge node at the middle of VTK's
    edge; TET15, TET20 and HEX27 are read by their corners (a note says so); every cell's tetrahedra (the split
    used to locate receptors) have positive volumes and fill the block (2 x 2 x 1 mm)."""
    raw = read_raw(path)
    _, volume = _domains(path)
    etype = volume[0].etype
    for ctype, nodes in zip(raw.cells.cell_types, raw.cells.nodes):
        xyz, edges = raw.points[nodes], _VTK_EDGES.get(ctype, ())  # linear cells: no mid-edge nodes
        for k, (a, b) in enumerate(edges):
            np.testing.assert_allclose(xyz[:, nodes.shape[1] - len(edges) + k], (xyz[:, a] + xyz[:, b]) / 2, atol=1e-6)
    if etype not in ("HEX8", "TET15", "TET20", "HEX27"):
        np.testing.assert_array_equal(np.concatenate(raw.cells.nodes), np.concatenate([d.conn for d in volume]))
    elif etype in ("HEX8", "HEX27"):  # hexahedra keep their 8 corners: sampled with their own trilinear functions
        assert raw.cells.cell_types == ("hexahedron", "hexahedron")
        assert [n.shape[1] for n in raw.cells.nodes] == [8, 8]
        if etype == "HEX8":
            np.testing.assert_array_equal(np.concatenate(raw.cells.nodes), np.concatenate([d.conn for d in volume]))
    else:  # tetrahedra by their corners: the tetrahedra themselves
        assert raw.cells.nodes == () and len(raw.cells.cell_types) == 2
    if etype in ("TET15", "TET20", "HEX27"):
        assert f"{etype} elements read by their corner nodes (point data linear between corners)." in raw.notes
    p0, p1, p2, p3 = (raw.points[raw.cells.tetra[:, c]] for c in range(4))
    signed = np.einsum("ij,ij->i", np.cross(p1 - p0, p2 - p0), p3 - p0) / 6
    assert (signed > 0).all() and signed.sum() == pytest.approx(4.0, rel=1e-6)


def test_element_variables_are_cell_data_with_febio_component_names():
    raw = read_raw(HEX8)
    assert raw.arrays["strain energy density"].location == "cell"
    assert raw.arrays["stress"].components == ("xx", "yy", "zz", "xy", "yz", "xz")
    assert raw.arrays["displacement"].location == "point" and raw.arrays["displacement"].components == ("x", "y", "z")
    # each layer is a domain of its own part (dermis 2, epidermis 1): the cell array 'material', in cell order
    _, volume = _domains(HEX8)
    np.testing.assert_array_equal(raw.arrays["material"].values[0], np.repeat([2.0, 1.0], [32, 16]))
    assert [d.name for d in volume] == ["dermis", "epidermis"]
    assert "FEBio plot file version 3.5 (0x0035), written by FEBio 4.11.0" in raw.notes[0]


def test_nodal_stress_per_element_node_is_the_mean_of_the_copies_at_each_node():
    ref, raw = _reference(HEX8), read_raw(HEX8)
    _, volume = _domains(HEX8)
    nodal = raw.arrays["nodal stress"]
    assert nodal.location == "point" and nodal.values.shape == (3, raw.points.shape[0], 6)
    # pyfebio's element-node values (8 per hexahedron, in connectivity order), averaged at each node here
    copies = np.concatenate([ref[f"elem:nodal stress/2/{d.number}"] for d in volume])
    conn = np.concatenate([d.conn for d in volume]).ravel()
    counts = np.bincount(conn, minlength=raw.points.shape[0])
    for node in (0, int(np.argmax(counts)), 60, 99):  # a corner (1 copy), an inner node (8 copies), ...
        expected = copies[conn == node].astype(np.float64).mean(axis=0)
        np.testing.assert_allclose(nodal.values[2, node], expected, rtol=1e-6)
    assert counts.max() == 8 and np.isfinite(nodal.values).all()


def test_sed_array_read_with_declared_units_in_j_per_m3():
    raw = read_raw(HEX8)
    field = read_sed(HEX8, **UNITS)
    assert field.provenance.columns["sed"] == "strain energy density"
    np.testing.assert_allclose(field.sed, raw.arrays["strain energy density"].values * 1e6)
    np.testing.assert_allclose(field.times, [0.0, 0.5, 1.0])
    assert field.sed[-1].max() > 0 and any("Gauss points" in n for n in field.provenance.notes)


def test_sed_from_stress_and_lagrange_strain_with_the_implied_febio_convention():
    raw = read_raw(TET10)  # no 'strain energy density' plot variable in this file
    assert "strain energy density" not in raw.arrays
    assert any("no 'strain energy density' plot variable" in n for n in raw.notes)
    field = read_sed(TET10, length_unit="mm", stress_unit="MPa", sed_from="exact")
    assert field.provenance.sed_from == "exact" and field.provenance.columns["stress"] == "stress"
    assert field.provenance.columns["strain"] == "Lagrange strain"
    stress, strain = raw.arrays["stress"].values[-1] * 1e6, raw.arrays["Lagrange strain"].values[-1]
    expected = 0.5 * (stress[:, :3] * strain[:, :3]).sum(1) + (stress[:, 3:] * strain[:, 3:]).sum(1)  # tensor shear
    np.testing.assert_allclose(field.sed[-1], expected, rtol=1e-12)
    with pytest.raises(ValueError, match="preset='abaqus' contradicts SED file .*block_tet10_z.xplt', which only 'febio' "
                                         "writes"):
        read_sed(TET10, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="abaqus")


def test_febio_tensors_pass_the_shear_and_sed_cross_checks():
    """FEBio's element-averaged Cauchy stress and Lagrange strain, read with tensor shear: deviatoric shear and
    normal stiffness agree (1 for an isotropic solid; 0.5 or 2 with the wrong convention), and 1/2 sigma:E agrees
    with FEBio's own element-averaged W best under the tensor-shear presets (a median 0.74 of it on this coarse
    block: the average of W over the Gauss points exceeds W of the averaged tensors)."""
    field = read_sed(HEX8, length_unit="mm", stress_unit="MPa", sed_from="exact")
    shear, versus = field.provenance.checks["shear_convention"], field.provenance.checks["tensor_sed_vs_export_sed"]
    assert shear["consistent"] and 0.85 < shear["ratio"] < 1.1, shear
    assert versus["agree"] and versus["by_preset"]["febio"] < versus["by_preset"]["abaqus"], versus
    w = read_sed(HEX8, **UNITS).sed[-1]
    big = w > 0.1 * w.max()
    assert 0.6 < np.median(field.sed[-1][big] / w[big]) < 1.0


def test_iter_sed_streams_the_states_as_read_sed_reads_them():
    whole = read_sed(TET10, length_unit="mm", stress_unit="MPa", sed_from="exact")
    steps = list(iter_sed(TET10, length_unit="mm", stress_unit="MPa", sed_from="exact"))
    assert len(steps) == 3 == xplt_step_count(str(TET10))
    np.testing.assert_array_equal(np.concatenate([s.sed for s in steps]), whole.sed)
    assert [float(s.times[0]) for s in steps] == list(whole.times)


def test_quadratic_cells_keep_their_nodes_in_vtk_order():
    raw = read_raw(PENTA15)  # two domains (dermis, epidermis): two blocks
    assert raw.cells.cell_types == ("wedge15", "wedge15") and raw.cells.nodes[0].shape[1] == 15
    _, volume = _domains(PENTA15)
    np.testing.assert_array_equal(np.concatenate(raw.cells.nodes), np.concatenate([d.conn for d in volume]))
    raw = read_raw(TET10)
    assert set(raw.cells.cell_types) == {"tetra10"} and raw.cells.nodes[0].shape[1] == 10


def test_info_describes_a_plot_file(capsys):
    assert main(["info", str(HEX8)]) == 0
    out = capsys.readouterr().out
    for text in ("xplt", "'strain energy density'", "cell", "(xx yy zz xy yz xz)", "'material'", "FEBio 4",
                 "--sed-from exact|equivalent (preset 'febio' implied by the format)"):
        assert text in out, text


def test_run_end_to_end_on_a_plot_file(tmp_path, capsys):
    receptors = tmp_path / "receptors.csv"
    receptors.write_text("id,x,y,z\n" + "".join(f"{k + 1},{x},{y},0.8\n" for k, (x, y) in enumerate(
        [(1.0, 1.0), (0.75, 1.0), (1.25, 1.0), (1.0, 0.75), (1.0, 1.25), (0.6, 0.6)])))
    out = tmp_path / "run"
    code = main(["run", str(HEX8), "--receptors", str(receptors), "--receptor-unit", "mm", "--length-unit", "mm",
                 "--sed-unit", "MPa", "--params", "start", "--no-plots", "-q", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    record = json.loads((out / "run.json").read_text())
    assert "block_hex8.xplt" in json.dumps(record)
    assert "strain energy density" in json.dumps(record)


def _state_offset(data: bytes) -> int:
    """Byte offset of the first state chunk of a plain plot file."""
    off = 4
    for _ in range(2):  # root, mesh
        off += 8 + struct.unpack_from("<I", data, off + 4)[0]
    return off


def test_truncated_and_corrupt_files_are_named(tmp_path):
    data = HEX8.read_bytes()
    cut = tmp_path / "cut.xplt"
    cut.write_bytes(data[:_state_offset(data) + 200])
    with pytest.raises(SEDFormatError, match=r"cut.xplt'.*state 0 \(chunk 0x02000000\) declares \d+ bytes but the file "
                                             r"ends after 192: truncated .xplt"):
        read_raw(cut)
    mesh_cut = tmp_path / "mesh_cut.xplt"
    mesh_cut.write_bytes(data[:_state_offset(data) - 10])
    with pytest.raises(SEDFormatError, match="mesh_cut.xplt'.*the mesh chunk .*declares"):
        read_raw(mesh_cut)
    other = tmp_path / "other.xplt"
    other.write_bytes(b"PK\x03\x04" + data[4:])
    with pytest.raises(SEDFormatError, match=r"other.xplt' is not an FEBio plot file: it must start with the tag"):
        read_raw(other)
    zdata = bytearray(TET10.read_bytes())
    start = _state_offset(bytes(zdata))
    zdata[start + 40:start + 60] = b"\xff" * 20
    broken = tmp_path / "broken_z.xplt"
    broken.write_bytes(bytes(zdata))
    with pytest.raises(SEDFormatError, match=r"broken_z.xplt': state 0 is not a valid zlib stream"):
        read_raw(broken)


def test_plot_file_versions_outside_3_0_to_3_5_are_refused(tmp_path):
    data = bytearray(HEX8.read_bytes())
    at = data.index(struct.pack("<II", 0x01010001, 4)) + 8
    for version, why in ((0x0008, "FEBio 2.x's layout"), (0x0036, "newer than the versions this reader knows")):
        data[at:at + 4] = struct.pack("<I", version)
        path = tmp_path / f"v{version:x}.xplt"
        path.write_bytes(bytes(data))
        with pytest.raises(SEDFormatError, match=rf"plot file version {version:#06x} is not read \({why}\); versions 3.0 "
                                                 r"to 3.5"):
            read_raw(path)


def test_cli_on_a_truncated_plot_file_prints_one_line_and_exits_2(tmp_path, capsys):
    cut = tmp_path / "cut.xplt"
    shutil.copy(HEX8, cut)
    cut.write_bytes(HEX8.read_bytes()[:-100])
    assert main(["info", str(cut)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("afferent: error: SED file ") and "truncated .xplt" in err


def test_shell_domains_and_their_variables_are_ignored_and_named():
    raw = read_raw(FEBIO / "block_hex8_shell.xplt")  # block_hex8 under 16 QUAD4 shells (a third domain)
    assert raw.cells.n_cells == 48 and raw.arrays["strain energy density"].values.shape == (3, 48)
    assert "shell thickness" not in raw.arrays
    assert "ignored domain(s) 3 (QUAD4, 16 elements)" in raw.notes[0]
    assert "plot variable(s) 'shell thickness' only on ignored domains: not read." in raw.notes



def test_large_deformation_is_judged_only_within_the_small_strain_bound():
    """FEBio's tensor shear, neo-Hookean: at the last state (|E| up to 0.47) Cauchy stress against Lagrange strain
    gives a shear/normal stiffness ratio of 0.57, where engineering shear read as tensor would put it; the checks judge
    the state at 15 % of the load (|E| up to 0.066) only, and a state beyond the bound alone is not checkable."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)  # no "looks engineering"
        field = read_sed(LARGE, length_unit="mm", stress_unit="MPa", sed_from="exact")
    shear, versus = field.provenance.checks["shear_convention"], field.provenance.checks["tensor_sed_vs_export_sed"]
    assert shear["checkable"] and shear["consistent"] and 0.8 < shear["ratio"] < 0.9, shear
    assert shear["steps_judged"] == 2 and shear["n_steps"] == 3 and shear["max_strain"] == pytest.approx(0.066, abs=1e-3)
    assert shear["note"] == "1 step(s) with strains beyond the small-strain bound 0.1 (up to 0.466) not judged"
    assert versus["checkable"] and versus["step"] == 1 and versus["agree"], versus
    raw = read_raw(LARGE)
    stress, strain = raw.arrays["stress"].values[-1], raw.arrays["Lagrange strain"].values[-1]
    linear = shear_consistency(stress, strain)  # judged as linear theory (a strain not named finite): it looks wrong
    assert linear["ratio"] < SHEAR_RATIO_BAND[0] and linear["note"].startswith(
        "strains up to 0.466 exceed the small-strain bound 0.1: judged as a linear (small-strain) analysis")
    last = list(iter_sed(LARGE, length_unit="mm", stress_unit="MPa", sed_from="exact"))[-1]
    for name in ("shear_convention", "tensor_sed_vs_export_sed"):
        check = last.provenance.checks[name]
        assert not check["checkable"] and check["max_strain"] == pytest.approx(0.466, abs=1e-3), check
        assert check["note"].startswith("not checkable: strains up to 0.466 exceed the small-strain bound 0.1 at "
                                        "every loaded step (a finite-strain analysis")


def test_a_ratio_no_convention_explains_is_not_blamed_on_the_convention():
    """FEBio's small-strain state (tensor shear, ratio 0.93): with the strain's shear halved it is ~2 x as stiff.
    Read as tensor that is no convention's signature (engineering would make it ~4): the warning must not advise
    shear='engineering'; read as engineering (what the halving also is), it names tensor."""
    from afferent.io._export_checks import _shear_message
    from afferent.io._find_arrays import _convention
    from afferent.io._read_options import ReadOptions

    raw = read_raw(HEX8)
    stress, strain = raw.arrays["stress"].values[1:2], raw.arrays["Lagrange strain"].values[1:2].copy()
    strain[..., 3:] /= 2
    shear = shear_consistency(stress, strain, finite=True)
    assert shear["checkable"] and 1.7 < shear["ratio"] < 2.1 and not shear["consistent"]
    said = _shear_message(raw, shear, _convention(ReadOptions(), raw), "preset='febio'")
    assert "and 3.7 x with the shear read as engineering: no shear convention explains it" in said, said
    assert "pass shear=" not in said
    said = _shear_message(raw, shear, _convention(ReadOptions(shear="engineering"), raw), "shear='engineering'")
    assert said.endswith("the file's shear strain looks tensor. Check the preset or pass shear='tensor'.")


PARTIAL = FEBIO / "block_hex8_partial.xplt"  # 'strain energy density' written with elem_set="epidermis"


def test_a_variable_written_for_some_domains_only_is_refused_naming_the_domains(capsys):
    """NaN on the dermis' cells (no value there: a receptor in the dermis would get none) is refused, and the
    refusal says which domains carry the variable, which lack it and how to request it for all of them."""
    raw = read_raw(PARTIAL)
    sed = raw.arrays["strain energy density"].values
    assert np.isnan(sed[:, :32]).all() and np.isfinite(sed[:, 32:]).all()  # dermis (domain 1) first, then epidermis
    np.testing.assert_array_equal(sed[:, 32:], np.stack([_reference(PARTIAL)[f"elem:strain energy density/{k}/2"]
                                                         for k in range(3)]).reshape(3, 16))
    said = ("plot variable 'strain energy density' is written for domain(s) 2 (epidermis, 16 elements) only: NaN on "
            "domain(s) 1 (dermis, 32 elements). To read it there, request it for every domain: in the .feb, "
            "<var type=\"strain energy density\"/> without elem_set= or a domain list")
    assert any(n.startswith(said) for n in raw.notes)
    with pytest.raises(SEDFormatError, match=r"block_hex8_partial.xplt': SED column 'strain energy density' must be "
                                             r"finite; got 96 non-finite value\(s\) .* The file's " + re.escape(said)):
        read_sed(PARTIAL, **UNITS)
    assert main(["info", str(PARTIAL)]) == 0 and said in capsys.readouterr().out


def test_a_run_streaming_the_large_deformation_records_which_states_were_not_checkable(tmp_path, capsys):
    """afferent run reads a plot file state by state: the last state (|E| 0.47) alone is not checkable - no false
    "looks engineering" warning - and run.json says so, beside the verdict of the state that was judged."""
    receptors = tmp_path / "receptors.csv"
    receptors.write_text("id,x,y,z\n1,1.0,1.0,0.8\n2,0.75,1.0,0.8\n3,1.25,1.0,0.8\n")
    out = tmp_path / "run"
    code = main(["run", str(LARGE), "--receptors", str(receptors), "--receptor-unit", "mm", "--length-unit", "mm",
                 "--stress-unit", "MPa", "--sed-from", "exact", "--params", "start", "--no-plots", "--no-cache", "-o",
                 str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "shear strain looks" not in err and "differs from the file's own SED" not in err
    checks = json.loads((out / "run.json").read_text())["field"]["checks"]
    for name in ("shear_convention", "tensor_sed_vs_export_sed"):
        check = checks[name]
        assert check["series_step"] == 1 and check["steps_not_checkable"] == [2] and "steps_failed" not in check
        assert check["checkable"] and check["max_strain"] == pytest.approx(0.066, abs=1e-3)
    assert checks["shear_convention"]["consistent"] and checks["tensor_sed_vs_export_sed"]["agree"]


def test_a_streamed_series_lists_the_states_whose_check_failed():
    """FEBio's tensor shear read as engineering, state by state: both loaded states fail the shear check (ratio ~1.9,
    'looks tensor'); the series' record keeps the first loaded state's verdict and lists both."""
    from afferent.io import series_provenance

    with pytest.warns(AfferentWarning, match="the file's shear strain looks tensor"):
        steps = list(iter_sed(HEX8, length_unit="mm", stress_unit="MPa", sed_from="exact", shear="engineering"))
    shear = series_provenance(s.provenance for s in steps).checks["shear_convention"]
    assert shear["series_step"] == 1 and shear["steps_failed"] == [1, 2] and not shear["consistent"]
    assert 1.7 < shear["ratio"] < 2.1 and "steps_not_checkable" not in shear


def test_info_on_a_large_deformation_state_says_the_cross_check_is_not_checkable():
    from dataclasses import replace

    from afferent.io._describe import describe_raw

    raw = read_raw(LARGE)
    last = replace(raw, arrays={k: replace(a, values=a.values[-1:]) for k, a in raw.arrays.items()}, times=raw.times[-1:])
    lines = describe_raw(last)
    assert any("1/2 sigma:eps from the tensors vs the SED array 'strain energy density': not checkable: strains up to "
               "0.466 exceed the small-strain bound 0.1" in line for line in lines), lines
    assert any("(step 1, relative L2 after the best scale" in line for line in describe_raw(raw))


def test_an_energy_named_array_beyond_the_small_strain_bound_says_why_the_values_cannot_decide():
    """Before: 'the file has no stress and strain tensors', of a file that has them at large strain
    (the density-by-values check is not checkable there: the refusal of an energy-named array said so)."""
    from afferent.io import read_raw
    from afferent.io._find_arrays import _undecided

    raw = read_raw(str(FEBIO / "block_hex8_large.xplt"))
    assert _undecided(raw) == ("the file's stress and strain tensors cannot decide it from the values (none at the "
                               "array's location, or strains beyond the small-strain bound 0.1 at every step)")
