"""MED files (code_aster / Salome-Meca result layouts) read by afferent's own h5py reader.

The files in tests/data/med/ were written by Salome's MED library (medcoupling 9.15 wheel,
med-fichier 4.2) with code_aster's field names, components and supports; ``reference.npz``
holds what **medcoupling** reads back from them (raw values per step, connectivity, Gauss
weights): the independent reference here. See tests/data/med/README.md.
"""

from __future__ import annotations

import re
import shutil
import warnings

import numpy as np
import pytest

from afferent import read_sed, sample_sed
from afferent.cli import main
from afferent.exceptions import AfferentWarning, SEDFormatError, UnitError
from afferent.io import format_of, read_raw
from afferent.receptors import ReceptorLayout

from conftest import DATA_DIR

MED = DATA_DIR / "med"
HEXA = MED / "block_hexa.rmed"
TETRA = MED / "block_tetra.med"


@pytest.fixture(scope="module")
def ref():
    with np.load(MED / "reference.npz") as data:
        return {k: data[k] for k in data.files}


def _connectivity(ref, prefix: str) -> np.ndarray:
    """medcoupling's nodal connectivity (type id, then the nodes of each cell) -> (n_cells, nodes per cell)."""
    conn, index = ref[f"{prefix}/conn"], ref[f"{prefix}/conn_index"]
    return np.stack([conn[a + 1:b] for a, b in zip(index[:-1], index[1:])])


def test_med_endings_select_the_med_reader():
    assert format_of("job.rmed") == "med" and format_of("JOB.MED") == "med"


def test_every_field_and_step_as_medcoupling_reads_them(ref):
    raw = read_raw(HEXA)
    conn = _connectivity(ref, "block_hexa")
    np.testing.assert_array_equal(raw.points, ref["block_hexa/coords"])
    np.testing.assert_array_equal(raw.times, ref["block_hexa/RESU____ENEL_NOEU/times"])  # INST 1, 2, 3
    assert sorted(raw.arrays) == ["DEPL", "ENEL_ELGA", "ENEL_ELNO", "ENEL_NOEU", "EPSI_NOEU", "SIEF_NOEU"]
    for name in ("ENEL_NOEU", "SIEF_NOEU", "EPSI_NOEU", "DEPL"):  # nodal: as stored
        expected = ref[f"block_hexa/RESU____{name}/values"]
        got = raw.arrays[name].values.reshape(expected.shape)
        np.testing.assert_array_equal(got, expected)
        assert raw.arrays[name].location == "point"
        comps = tuple(ref[f"block_hexa/RESU____{name}/components"])
        assert raw.arrays[name].components == (comps if len(comps) > 1 else ())
    # ELNO: the arithmetic mean of each node's element-node copies
    elno = ref["block_hexa/RESU____ENEL_ELNO/values"][..., 0].reshape(3, -1, 8)
    total = np.zeros((3, raw.points.shape[0]))
    for k in range(3):
        np.add.at(total[k], conn.ravel(), elno[k].ravel())
    np.testing.assert_allclose(raw.arrays["ENEL_ELNO"].values, total / np.bincount(conn.ravel()), rtol=1e-14)
    # ELGA: one value per hexahedron, the Gauss-weighted mean of its 8 points
    w = ref["block_hexa/RESU____ENEL_ELGA/weights"]
    elga = ref["block_hexa/RESU____ENEL_ELGA/values"][..., 0].reshape(3, -1, 8)
    np.testing.assert_allclose(raw.arrays["ENEL_ELGA"].values, elga @ (w / w.sum()), rtol=1e-14)
    assert raw.arrays["ENEL_ELGA"].location == "cell" and raw.cells.n_cells == 32
    assert raw.preset == "code_aster"


def test_elno_averaged_at_the_nodes_is_code_aster_noeu(ref):
    """code_aster builds _NOEU as the mean of the _ELNO copies: the file's ENEL_NOEU, from the
    discontinuous ENEL_ELNO, is what afferent's ELNO rule gives."""
    raw = read_raw(HEXA)
    np.testing.assert_allclose(raw.arrays["ENEL_ELNO"].values, raw.arrays["ENEL_NOEU"].values, rtol=1e-12, atol=1e-12)
    elno = ref["block_hexa/RESU____ENEL_ELNO/values"][-1, :, 0]
    conn = _connectivity(ref, "block_hexa").ravel()
    spread = max(np.ptp(elno[conn == node]) for node in np.unique(conn))
    assert spread > 0.01 * elno.max()  # the copies at a node differ (by 2 %): averaging is a real choice


def test_elno_stored_per_cell_with_the_gauss_elno_localisation(tmp_path):
    """MED also stores element-node values per cell (MAI.<type>) under its reserved localisation
    MED_GAUSS_ELNO: read as ELNO too."""
    import h5py

    path = tmp_path / "gauss_elno.rmed"
    shutil.copy(HEXA, path)
    with h5py.File(path, "r+") as h5:
        for step in h5["CHA"]["RESU____ENEL_ELNO"].values():
            step.move("NOE.HE8", "MAI.HE8")
            step["MAI.HE8"].attrs["GAU"] = np.bytes_(b"MED_GAUSS_ELNO")
            step["MAI.HE8"]["MED_NO_PROFILE_INTERNAL"].attrs["GAU"] = np.bytes_(b"MED_GAUSS_ELNO")
    raw = read_raw(path)
    assert raw.arrays["ENEL_ELNO"].location == "point"
    np.testing.assert_array_equal(raw.arrays["ENEL_ELNO"].values, read_raw(HEXA).arrays["ENEL_ELNO"].values)


def test_read_sed_takes_enel_noeu_with_declared_units():
    with pytest.raises(UnitError, match=re.escape("declared; pass length_unit=")):
        read_sed(HEXA, sed_unit="Pa")
    with pytest.warns(AfferentWarning, match="negative"):  # ELNO extrapolation near the corner: -0.025 x the largest
        field = read_sed(HEXA, length_unit="m", sed_unit="Pa")
    raw = read_raw(HEXA)
    assert field.provenance.columns["sed"] == "ENEL_NOEU"
    np.testing.assert_array_equal(field.times, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(field.sed, np.maximum(raw.arrays["ENEL_NOEU"].values, 0))
    with pytest.warns(AfferentWarning, match=r"sed_unit='kPa' implies an elastic stiffness .* \(confirmed: accept='modulus'\)"):
        mm = read_sed(HEXA, length_unit="mm", sed_unit="kPa", negative_tolerance=0.25, accept="modulus")  # a Pa export
    np.testing.assert_allclose(mm.points, field.points * 1e-3)
    np.testing.assert_allclose(mm.sed, field.sed * 1e3)


def test_tensors_are_ordered_by_their_names_with_tensor_shear():
    """SIGM_NOEU / EPSI_NOEU (SIXX ... SIYZ, EPXX ... EPYZ, tensor shear: code_aster's eps1mc.f
    halves the engineering shear): 1/2 sigma:eps equals ENEL_NOEU, and the shear check agrees."""
    field = read_sed(TETRA, length_unit="m", stress_unit="Pa", sed_from="exact")  # preset implied by the file
    enel = read_sed(TETRA, length_unit="m", sed_unit="Pa")
    np.testing.assert_allclose(field.sed, enel.sed, rtol=1e-12)
    assert field.provenance.checks["shear_convention"]["consistent"]
    with pytest.warns(AfferentWarning, match="shear"):
        wrong = read_sed(TETRA, length_unit="m", stress_unit="Pa", sed_from="exact", shear="engineering")
    assert not wrong.provenance.checks["shear_convention"]["consistent"]
    assert np.abs(wrong.sed - enel.sed).max() > 0.02 * enel.sed.max()
    hexa = read_sed(HEXA, length_unit="m", stress_unit="Pa", sed_from="exact")  # nodal averages: Hooke holds
    assert hexa.provenance.checks["shear_convention"]["ratio"] == pytest.approx(1.0, abs=1e-6)


def test_gauss_point_energy_is_cell_data_sampled_in_its_element(ref):
    field = read_sed(HEXA, length_unit="m", sed_unit="Pa", sed_column="ENEL_ELGA", location="cell")
    conn = _connectivity(ref, "block_hexa")
    centroids = ref["block_hexa/coords"][conn].mean(axis=1)
    sampled = sample_sed(field, ReceptorLayout(centroids), method="nearest")
    np.testing.assert_allclose(sampled.values, field.sed, rtol=1e-14)  # every centroid lies in its own element


def test_enel_elem_is_an_energy_and_refused(tmp_path):
    import h5py

    path = tmp_path / "elem_only.med"
    shutil.copy(TETRA, path)
    with h5py.File(path, "r+") as h5:
        for name in ("ENEL_NOEU", "SIGM_NOEU", "EPSI_NOEU"):
            del h5["CHA"][name]
    with pytest.raises(SEDFormatError, match=re.escape("'ENEL_ELEM' holds an energy, not an energy density (code_aster "
                                                       "ENEL_ELEM is the elastic energy per element")):
        read_sed(path, length_unit="m", sed_unit="Pa")


def test_fields_keep_only_the_steps_they_share(tmp_path):
    import h5py

    path = tmp_path / "steps.rmed"
    shutil.copy(HEXA, path)
    with h5py.File(path, "r+") as h5:
        group = h5["CHA"]["RESU____SIEF_NOEU"]
        del group[sorted(group)[-1]]  # SIEF_NOEU at INST 1 and 2 only
    raw = read_raw(path)
    np.testing.assert_array_equal(raw.times, [1.0, 2.0])
    assert ("field 'RESU____ENEL_NOEU': 1 of its 3 step(s) left out (not every field has them; an array holds the "
            "steps all fields share)") in raw.notes


def test_not_a_med_file(tmp_path):
    text = tmp_path / "text.med"
    text.write_text("not hdf5\n")
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(text)!r} is not a MED file: it must be HDF5")):
        read_raw(text)
    import h5py

    other = tmp_path / "other.med"
    with h5py.File(other, "w") as h5:
        h5.create_group("data")
    with pytest.raises(SEDFormatError, match=re.escape("is HDF5 but not a MED file: it has no mesh group '/ENS_MAA' "
                                                       "(top-level groups: data)")):
        read_raw(other)
    cut = tmp_path / "cut.rmed"
    cut.write_bytes(HEXA.read_bytes()[:40000])
    with pytest.raises(SEDFormatError, match=re.escape(f"SED file {str(cut)!r}")):
        read_raw(cut)


def test_meshio_refuses_the_file_afferent_reads():
    """Why a reader of its own: meshio 5.3.5 fails on element fields that skip the skin faces."""
    import meshio

    with warnings.catch_warnings(), pytest.raises(Exception):
        warnings.simplefilter("ignore")
        meshio.med.read(str(HEXA))


def test_info_lists_fields_components_and_steps(capsys):
    assert main(["info", str(HEXA)]) == 0
    out = capsys.readouterr().out
    assert "field 'RESU____SIEF_NOEU' -> point array 'SIEF_NOEU': on nodes; components SIXX SIYY SIZZ SIXY SIXZ SIYZ; " \
           "3 step(s), t = 1 .. 3" in out
    assert "field 'RESU____ENEL_ELNO' -> point array 'ENEL_ELNO': on element nodes (ELNO), averaged at each node" in out
    assert "QU4 x 64 (not a volume: ignored)" in out
    assert re.search(r"'EPSI_NOEU' +point 6 components .*\(EPXX EPYY EPZZ EPXY EPXZ EPYZ\)", out)


def test_a_mesh_written_by_kratos_reads_with_its_nodes_and_hexahedra():
    """KratosMedApplication 10.4.4 (a second MED writer, int32 attributes, mesh only): the 18 nodes
    in Kratos's numbering and 4 hexahedra; no field, so no time step."""
    raw = read_raw(MED / "kratos_block.med")
    grid = np.array([(i, j, k) for k in range(2) for j in range(3) for i in range(3)], float) * 1e-3
    np.testing.assert_allclose(raw.points, grid, rtol=0, atol=1e-15)
    assert raw.cells.n_cells == 4 and raw.cells.cell_types == ("hexahedron",) and not raw.arrays
    assert "The file holds a mesh and no field: no results to read." in raw.notes


@pytest.mark.parametrize("name", ["block_hexa.rmed", "block_tetra.med", "kratos_block.med"])
def test_med_cells_split_into_tetrahedra_tile_the_block(name):
    """MED orders element nodes in the mirror of VTK's; the tetrahedra split from MED's order
    still tile each 2 x 2 x 1 mm block exactly (4e-9 m^3), none degenerate."""
    raw = read_raw(MED / name)
    t = raw.points[raw.cells.tetra]
    vol = np.abs(np.linalg.det(np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0], t[:, 3] - t[:, 0]], 1))) / 6
    assert vol.sum() == pytest.approx(4e-9, rel=1e-12) and vol.min() > 1e-3 * vol.max()


@pytest.mark.parametrize("name", ["block_hexa.rmed", "block_tetra.med"])
def test_linear_sampling_in_med_cells_is_exact_for_a_linear_field(name):
    from dataclasses import replace

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        field = read_sed(MED / name, length_unit="m", sed_unit="Pa")
    linear = lambda p: 5.0 + 2e3 * p[:, 0] - 1e3 * p[:, 1] + 4e3 * p[:, 2]  # noqa: E731
    field = replace(field, sed=np.tile(linear(field.points), (field.n_times, 1)))
    rng = np.random.default_rng(0)
    sites = rng.uniform([0.1e-3, 0.1e-3, 0.1e-3], [1.9e-3, 1.9e-3, 0.9e-3], size=(50, 3))
    sampled = sample_sed(field, ReceptorLayout(sites), method="linear")
    np.testing.assert_allclose(sampled.values, np.tile(linear(sites), (field.n_times, 1)), rtol=1e-12)


def test_cli_on_a_truncated_med_file_prints_one_line_and_exits_2(tmp_path, capsys):
    cut = tmp_path / "cut.rmed"
    cut.write_bytes(HEXA.read_bytes()[:60000])
    assert main(["info", str(cut)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"afferent: error: SED file {str(cut)!r}")


def test_values_on_a_profile_are_placed_on_its_entities_nan_elsewhere(tmp_path):
    """code_aster writes a field computed on a group of elements with a MED profile (/PROFILS):
    the values land on the profile's elements, the others are NaN."""
    import h5py

    path = tmp_path / "profile.rmed"
    shutil.copy(HEXA, path)
    full = read_raw(HEXA).arrays["ENEL_ELGA"].values
    keep = np.arange(1, 32, 2)  # 0-based: every second hexahedron
    with h5py.File(path, "r+") as h5:
        pfl = h5.require_group("PROFILS").create_group("EVEN")
        pfl.attrs["NBR"] = np.int64(keep.size)
        pfl.create_dataset("PFL", data=(keep + 1).astype(np.int64))
        for step in h5["CHA"]["RESU____ENEL_ELGA"].values():
            support = step["MAI.HE8"]
            old = support["MED_NO_PROFILE_INTERNAL"]
            values = old["CO"][()].reshape(32, 8)[keep].ravel()
            new = support.create_group("EVEN")
            for key, value in old.attrs.items():
                new.attrs[key] = value
            new.attrs["NBR"] = np.int64(keep.size)
            new.create_dataset("CO", data=values)
            del support["MED_NO_PROFILE_INTERNAL"]
            support.attrs["PFL"] = np.bytes_(b"EVEN")
    got = read_raw(path).arrays["ENEL_ELGA"].values
    np.testing.assert_array_equal(got[:, keep], full[:, keep])
    assert np.isnan(np.delete(got, keep, axis=1)).all()


def test_field_values_larger_than_their_count_are_refused_before_they_are_read(tmp_path):
    """Issue 33 item 10: a MED field whose values dataset holds 1e9 values (chunks never written: 8 GB of
    HDF5's fill value) where its NBR and the mesh say 18. Before: read whole (8 GB); now refused from its
    shape, in a child that stays under 400 MB."""
    import h5py
    from _memory import in_child

    path = tmp_path / "bomb.med"
    shutil.copy(TETRA, path)
    key = "CHA/ENEL_NOEU/00000000000000000001-0000000000000000001/NOE/MED_NO_PROFILE_INTERNAL/CO"
    with h5py.File(path, "r+") as f:
        del f[key]
        f.create_dataset(key, shape=(10**9,), dtype="f8", chunks=(1 << 20,))
    got = in_child(f"""
        from afferent.io import read_raw
        read_raw({str(path)!r})
    """)
    assert got["error"] == ["SEDFormatError", f"SED file {str(path)!r}: the values of 'NOE' ('/{key.rpartition('/')[0]}/CO'): "
                            "the dataset holds 1,000,000,000 values (shape (1000000000,)) where 18 are expected: the file is corrupt; "
                            "refused before reading it."], got
    assert got["peak_mb"] < 400, got
