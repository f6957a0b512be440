"""Inputs at the extremes (issue 26, item 10): each gives the right number or a sentence naming
what is wrong, never a crash, a silent wrong number or a numpy warning.

The numeric properties run with every warning an error except :class:`AfferentWarning` (the
package's own, which say something on purpose): a RuntimeWarning ("overflow encountered in
...") leaking from numpy fails them.
"""

from __future__ import annotations

import contextlib
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from afferent.exceptions import AfferentWarning, SEDFormatError
from afferent.field import Cells, SEDField
from afferent.io import read_sed
from afferent.receptors import ReceptorLayout, read_receptors
from afferent.sampling import sample_sed
from afferent.scene import SceneError, load_scene, parse_scene, resolve
from afferent.synthesis import Branching, synthesize
from afferent.transduction import SigmoidParams, saturation_report, transduce

from conftest import DATA_DIR

#: finite floats up to the float maximum, with the values where overflow starts written in
EXTREME = st.one_of(st.floats(-1.7e308, 1.7e308, allow_nan=False),
                    st.sampled_from([0.0, 5e-324, 1e-300, 1e160, -1e160, 1e300, -1e300, 1.7e308, -1.7e308]))
QUICK = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))


@contextlib.contextmanager
def numpy_warnings_are_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", AfferentWarning)
        yield


def _cube_field(cells: bool) -> SEDField:
    """The unit cube (1 mm) as 8 points, SED 1..8 Pa; as a table, or as 5 tetrahedra."""
    pts = np.array([[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)]) * 1e-3
    tets = Cells(np.array([[0, 1, 2, 4], [1, 2, 4, 7], [1, 3, 2, 7], [1, 4, 5, 7], [2, 4, 6, 7]]), np.zeros(5, int), 1)
    return SEDField(pts, np.arange(1.0, 9.0)[None], np.array([0.0]), cells=tets if cells else None)


# ---------------------------------------------------------------------------- sampling
@settings(QUICK, max_examples=20)
@given(far=arrays(float, (2, 3), elements=EXTREME), cells=st.booleans(), method=st.sampled_from(["linear", "nearest"]))
@example(far=np.array([[1.7e308, -1e307, -1e307], [-1e307, -1e307, -1e307]]), cells=False, method="linear")
@example(far=np.array([[1e160, 0.0, 0.0], [1.8e305, 1.8e305, 1.8e305]]), cells=True, method="linear")
def test_receptors_anywhere_are_inside_with_a_value_or_outside_never_a_crash(far, cells, method):
    """Before: a receptor 1e160 m away made scipy's KD-tree return its 'no neighbour' index (n)
    and the tetrahedron lookup failed with IndexError."""
    field = _cube_field(cells)
    centre = np.full(3, 0.5e-3)
    with numpy_warnings_are_errors():
        out = sample_sed(field, ReceptorLayout(np.vstack([centre, far])), method=method, on_outside="nan")
    assert np.isfinite(out.values[0, 0]) and not out.outside[0]
    near_box = np.all((far >= -1e-8) & (far <= 1e-3 + 1e-8), axis=1)  # within 1e-8 m: either (tolerance 1e-9 m)
    assert np.all(out.outside[1:] | near_box)
    assert np.array_equal(np.isnan(out.values[0, 1:]), out.outside[1:])


def test_a_receptor_1e160_m_away_on_a_mesh_is_outside():
    field = _cube_field(cells=True)
    out = sample_sed(field, ReceptorLayout(np.array([[1e160, 0.0, 0.0], [0.5e-3, 0.5e-3, 0.5e-3]])), on_outside="nan")
    assert out.outside.tolist() == [True, False] and out.values[0, 1] == pytest.approx(4.5)


@pytest.mark.parametrize("cells", [False, True], ids=["table", "mesh"])
def test_every_node_of_the_field_including_the_hull_corners_samples_its_own_value(cells):
    """Before: a receptor exactly on a corner of a point table's hull was called outside
    (scipy's directed walk stops at the hull)."""
    field = _cube_field(cells)
    out = sample_sed(field, ReceptorLayout(field.points.copy()), method="linear")
    assert not out.outside.any()
    np.testing.assert_allclose(out.values[0], field.sed[0], rtol=1e-6)


def test_every_point_of_a_surface_table_including_its_corners_samples_its_own_value():
    pts = np.array([[x, y, 0.0] for y in (0.0, 0.5, 1.0) for x in (0.0, 0.5, 1.0)]) * 1e-3
    field = SEDField(pts, np.arange(1.0, 10.0)[None], np.array([0.0]))
    out = sample_sed(field, ReceptorLayout(pts.copy()), method="linear")
    np.testing.assert_allclose(out.values[0], field.sed[0], rtol=1e-6)


@pytest.mark.parametrize("scale", [1e-9, 1.0, 1e150])
def test_a_point_table_at_any_scale_samples_the_same(scale):
    pts = _cube_field(False).points / 1e-3 * scale
    field = SEDField(pts, np.arange(1.0, 9.0)[None], np.array([0.0]))
    with numpy_warnings_are_errors():
        out = sample_sed(field, ReceptorLayout(np.array([[0.25, 0.5, 0.5]]) * scale))
    assert out.values[0, 0] == pytest.approx(4.25)


# --------------------------------------------------------------- transduction, synthesis
@QUICK
@given(sed=arrays(float, st.tuples(st.integers(1, 3), st.integers(1, 4)), elements=EXTREME),
       gamma=st.sampled_from([0.0, 1e-300, 4.6e-3, 1.0, 1e12, 1e300]), lam=EXTREME,
       pos=arrays(float, (4, 3), elements=EXTREME))
@example(sed=np.array([[-1e300, 1e300]]), gamma=1e12, lam=0.0, pos=np.zeros((4, 3)))
@example(sed=np.array([[1.7e308, -1e307]]), gamma=0.0, lam=0.0, pos=np.zeros((4, 3)))  # 0 x inf range
@example(sed=np.zeros((1, 2)), gamma=1.0, lam=0.0, pos=np.full((4, 3), 8.98846567e307))
def test_transduce_and_synthesize_at_the_extremes_leak_no_numpy_warning(sed, gamma, lam, pos):
    """Before: gamma 1e12 over SED +-1e300 leaked 'overflow encountered in scalar multiply' from the
    modulation diagnostic, and receptors near 1e308 m gave sections at inf m (a ValueError)."""
    params = SigmoidParams(alpha=1e-6, gamma=gamma, lambda_=lam)
    layout = ReceptorLayout(pos[:sed.shape[1]])
    with numpy_warnings_are_errors():
        current = transduce(sed, params)
        report = saturation_report(sed, params)
        for branching in (Branching.longitudinal(layout), Branching.cross(layout)):
            assert np.all(np.isfinite(branching.positions))
            assert np.all(np.isfinite(synthesize(current, branching).values))
    assert 0.0 <= report.fraction_sensitive <= 1.0 and not np.isnan(report.gamma_sed_range)


def test_the_modulation_diagnostic_of_gamma_1e12_over_sed_1e300_is_inf():
    with numpy_warnings_are_errors():
        report = saturation_report(np.array([[-1e300, 1e300]]), SigmoidParams(alpha=1e-6, gamma=1e12, lambda_=0.0))
    assert report.gamma_sed_range == np.inf


def test_sections_of_receptors_near_the_float_maximum_have_finite_positions():
    layout = ReceptorLayout(np.full((2, 3), 8.98846567e307))
    assert np.isfinite(layout.section_positions("longitudinal")).all()
    assert Branching.longitudinal(layout).positions.tolist() == [8.98846567e307]


# ---------------------------------------------------------------------- section labels
@pytest.mark.parametrize("value, shown", [("1e20", "1e+20"), ("-1", "-1.0"), ("1000000", "1000000.0")])
def test_a_section_label_out_of_range_is_refused_not_wrapped(tmp_path, value, shown):
    """Before: 1e20 became -2**63 (numpy's float -> int64 cast); -1 failed later in np.bincount."""
    path = tmp_path / "receptors.csv"
    path.write_text(f"id,x,y,z,longitudinal\nr0,0.5,0.5,0.5,{value}\nr1,0.25,0.5,0.5,0\n")
    message = (f"Receptor file {str(path)!r}: column 'longitudinal' must hold whole-number section labels from 0 to "
               f"999,999; got {shown} on data row 1 instead.")
    with pytest.raises(SEDFormatError, match=f"^{re.escape(message)}$"):
        read_receptors(path, length_unit="mm")


def test_negative_section_labels_given_in_code_are_refused():
    with pytest.raises(ValueError, match=r"^'cross' section labels must lie from 0 to 999,999; got -3 for receptor 1 "
                                         r"instead\.$"):
        ReceptorLayout(np.zeros((2, 3)), cross=np.array([0, -3]))


# -------------------------------------------------------------------------------- meshes
def test_negative_connectivity_given_in_code_is_refused():
    cells = Cells(np.array([[0, 1, 2, -1]]), np.zeros(1, int), 1)
    with pytest.raises(ValueError, match=r"'cells' refer to point -1; point indices must be >= 0"):
        SEDField(np.vstack([np.zeros(3), np.eye(3)]) * 1e-3, np.ones((1, 4)), np.array([0.0]), cells=cells)


def test_an_all_zero_field_warns_and_the_provenance_keeps_it():
    with pytest.warns(AfferentWarning, match=r"every SED value is 0 J/m\^3 \(8 values\): the wrong column"):
        field = read_sed(DATA_DIR / "bad" / "all_zero.csv", length_unit="mm", sed_unit="MPa")
    assert any("every SED value is 0" in note for note in field.provenance.notes)


def test_a_first_step_of_zeros_in_a_loading_series_does_not_warn(tmp_path):
    path = tmp_path / "series.csv"
    rows = [f"{t},{x},{y},{z},{t * (1 + x + y + z)}" for t in (0.0, 1.0) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    path.write_text("time,x,y,z,SED\n" + "\n".join(rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)
        read_sed(path, length_unit="mm", sed_unit="kPa", time_unit="s")


def test_a_first_step_of_zeros_streamed_step_by_step_does_not_warn_but_a_series_of_zeros_does(tmp_path):
    """iter_sed assembles each step alone: its first step (the undeformed state of a ramp) warned as an all-zero
    field (notebook 06 caught it); the warning now comes once, after the last step, only if every step was zero."""
    import meshio

    from afferent.io import iter_sed

    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    hexa = [("hexahedron", np.array([[0, 1, 3, 2, 4, 5, 7, 6]]))]
    ramp, flat = [], []
    for k in range(3):
        meshio.Mesh(pts, hexa, point_data={"SED": k * (1 + pts.sum(axis=1))}).write(tmp_path / f"r{k}.vtu")
        meshio.Mesh(pts, hexa, point_data={"SED": np.zeros(8)}).write(tmp_path / f"z{k}.vtu")
        ramp.append(str(tmp_path / f"r{k}.vtu"))
        flat.append(str(tmp_path / f"z{k}.vtu"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", AfferentWarning)
        assert len(list(iter_sed(ramp, length_unit="mm", sed_unit="kPa", times=[0.0, 1.0, 2.0]))) == 3
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        list(iter_sed(flat, length_unit="mm", sed_unit="kPa", times=[0.0, 1.0, 2.0]))
    zero = [w for w in caught if "every SED value is 0 J/m^3" in str(w.message)]
    assert len(zero) == 1, [str(w.message) for w in caught]


# -------------------------------------------------------------------------------- scenes
SCENE = """\
[export]
file = "ok.csv"
length_unit = "mm"
sed_unit = "MPa"
[receptors]
grid = "regular"
y_mm = 0.5
{extra}
[outputs]
want = ["sed_map"]
"""


@pytest.mark.parametrize("key", ["pitch_x_mm", "pitch_z_mm"])
def test_a_grid_pitch_of_0_is_refused_not_replaced_by_the_default(tmp_path, key):
    """Before: `pitch or default` turned 0 into 0.44 mm (0.22 mm) without a word."""
    path = tmp_path / "scene.toml"
    path.write_text(SCENE.format(extra=f"{key} = 0"))
    with pytest.raises(SceneError, match=rf"^Scene file {re.escape(repr(str(path)))}, line 8: \[receptors\] '{key}' must "
                                         r"be > 0; got 0\.0 m instead\.$"):
        load_scene(path)
    assert resolve(parse_scene(SCENE.format(extra=""))).receptors.pitch_x_m == pytest.approx(0.44e-3)


def test_a_scene_written_with_a_byte_order_mark_reads(tmp_path):
    (tmp_path / "ok.csv").write_text((DATA_DIR / "bad" / "ok.csv").read_text())
    plain, bom = tmp_path / "plain.toml", tmp_path / "bom.toml"
    plain.write_text(SCENE.format(extra=""), encoding="utf-8")
    bom.write_text(SCENE.format(extra=""), encoding="utf-8-sig")
    assert bom.read_bytes().startswith(b"\xef\xbb\xbf")
    assert load_scene(bom).receptors == load_scene(plain).receptors


@pytest.mark.parametrize("nested", ["[" * 3000 + "]" * 3000, "{a = " * 3000 + "1" + "}" * 3000])
def test_toml_nested_too_deeply_is_an_error_of_the_file(tmp_path, nested):
    """Before: tomllib's RecursionError, an internal error of the CLI (exit 1)."""
    path = tmp_path / "deep.toml"
    path.write_text(f"[export]\nfile = {nested}\n")
    with pytest.raises(SceneError, match=rf"^Scene file {re.escape(repr(str(path)))} nests arrays or inline "
                                         r"tables too deeply to be read; a scene needs at most a list of lists\.$"):
        load_scene(path)


def test_a_sweep_file_nested_too_deeply_is_an_error_of_the_file(tmp_path):
    from afferent._sweep.spec import load_sweep

    path = tmp_path / "sweep.toml"
    path.write_text("[sweep]\nx = " + "[" * 3000 + "]" * 3000 + "\n")
    with pytest.raises(SceneError, match="^Sweep file .* nests arrays or inline tables too deeply to be read"):
        load_sweep(path)


def test_a_negative_node_in_an_xdmf_topology_is_named_as_it_is(tmp_path):
    """Before: the message named the largest index (7), not the negative one."""
    xyz = " ".join(f"{v:g}" for p in range(8) for v in ((p & 1), (p >> 1) & 1, (p >> 2) & 1))
    path = tmp_path / "neg.xdmf"
    path.write_text(
        '<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>\n<Grid Name="mesh" GridType="Uniform">'
        '<Topology TopologyType="Hexahedron" NumberOfElements="1" NodesPerElement="8"><DataItem Dimensions="1 8" '
        f'Format="XML">0 1 3 2 4 5 7 -1</DataItem></Topology><Geometry GeometryType="XYZ"><DataItem Dimensions="8 3" '
        f'Format="XML">{xyz}</DataItem></Geometry></Grid>\n<Grid Name="f" GridType="Collection" '
        'CollectionType="Temporal"><Grid Name="f" GridType="Uniform"><xi:include xmlns:xi="http://www.w3.org/2001/XInclude" '
        'xpointer="xpointer(/Xdmf/Domain/Grid[1]/*)"/><Time Value="0"/><Attribute Name="SED" Center="Node">'
        '<DataItem Dimensions="8 1" Format="XML">1 2 3 4 5 6 7 8</DataItem></Attribute></Grid></Grid>\n</Domain></Xdmf>\n')
    with pytest.raises(SEDFormatError, match=r"the topology refers to point -1, but the geometry has 8 points "
                                             r"\(numbered from 0\)\.$"):
        read_sed(path, length_unit="mm", sed_unit="Pa")
