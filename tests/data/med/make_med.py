"""Write small MED result files in code_aster's layouts with Salome's MED library (medcoupling).

Regenerate (needs ``pip install medcoupling==9.15.0`` in a separate venv; a few seconds)::

    /work/venvs/med/bin/python tests/data/med/make_med.py

code_aster itself cannot be installed here, so the files are written by medcoupling, the MED
library of Salome / Salome-Meca that code_aster's IMPR_RESU(FORMAT='MED') also goes through
(med-fichier 4.x HDF5 layout), with code_aster's field names, component names and supports:

- field names ``<result name padded to 8 with '_'><option>`` (``RESU____ENEL_ELNO``), or a plain
  name as ``NOM_CHAM_MED`` gives it (``SIGM_NOEU``);
- ``ENEL_*`` one component ``TOTALE``; ``SIEF_*``/``SIGM_*`` ``SIXX SIYY SIZZ SIXY SIXZ SIYZ``;
  ``EPSI_*`` ``EPXX EPYY EPZZ EPXY EPXZ EPYZ`` with **tensor** shear (code_aster halves the
  B-matrix's engineering shear, ``bibfor/elements/eps1mc.f``); ``DEPL`` ``DX DY DZ``;
- ``_ELGA`` on Gauss points (a localisation with its weights), ``_ELNO`` on element nodes
  (MED_NODE_ELEMENT), ``_NOEU`` on nodes (the arithmetic mean of the ELNO copies at each node),
  ``_ELEM`` one value per element (``ENEL_ELEM`` is the element's elastic *energy*);
- several time steps (INST) with their times; skin faces next to the volume cells, as Salome
  meshes have them.

The mechanics are manufactured, in SI units as code_aster's examples (m, Pa, J/m^3): a
2 x 2 x 1 mm block (graded mesh), linear elastic E = 0.1 MPa, nu = 0.45, a quadratic displacement field
scaled by INST / 3 (so the strain is linear in space), stress = Hooke's law with tensor shear,
SED = 1/2 sigma:eps at the Gauss points; ELNO = the Gauss values extrapolated to the element's
nodes with the trilinear fit through its 8 Gauss points (as code_aster extrapolates ELGA to
ELNO), so ELNO is discontinuous between elements.

Besides the .med files the script writes ``reference.npz``: every field read back **by
medcoupling** (raw arrays per step, times, connectivity, coordinates, Gauss weights), the
independent reference tests/test_io_med.py compares afferent's h5py reader with.
"""

from __future__ import annotations

from pathlib import Path

import medcoupling as mc
import numpy as np

HERE = Path(__file__).resolve().parent
L, H = 2e-3, 1e-3                    # block, m
E_PA, NU = 1e5, 0.45
LAM = E_PA * NU / ((1 + NU) * (1 - 2 * NU))
MU = E_PA / (2 * (1 + NU))
SIEF = ["SIXX", "SIYY", "SIZZ", "SIXY", "SIXZ", "SIYZ"]
EPSI = ["EPXX", "EPYY", "EPZZ", "EPXY", "EPXZ", "EPYZ"]


def strain(xyz: np.ndarray, scale: float) -> np.ndarray:
    """Tensor strain (n, 6) in code_aster's order xx yy zz xy xz yz of the displacement
    u = scale * 0.01 * L * (X Z + 0.3 Y^2, 0.5 Y Z + 0.2 X Y, -0.25 X^2 + 0.1 Z^2 + 0.3 X Y), X = x / L."""
    X, Y, Z = (xyz / L).T
    a = 0.01 * scale
    exx, eyy, ezz = a * Z, a * (0.5 * Z + 0.2 * X), a * 0.2 * Z
    exy = a * 0.5 * (0.6 * Y + 0.2 * Y)                   # (du/dy + dv/dx) / 2
    exz = a * 0.5 * (X + (-0.5 * X + 0.3 * Y))            # (du/dz + dw/dx) / 2
    eyz = a * 0.5 * (0.5 * Y + 0.3 * X)                   # (dv/dz + dw/dy) / 2
    return np.column_stack([exx, eyy, ezz, exy, exz, eyz])


def stress(eps: np.ndarray) -> np.ndarray:
    tr = eps[:, :3].sum(1, keepdims=True)
    return np.column_stack([LAM * tr + 2 * MU * eps[:, :3], 2 * MU * eps[:, 3:]])


def sed(sig: np.ndarray, eps: np.ndarray) -> np.ndarray:
    return 0.5 * ((sig[:, :3] * eps[:, :3]).sum(1) + 2 * (sig[:, 3:] * eps[:, 3:]).sum(1))


def block_mesh(n_xy: int, n_z: int, tetra: bool) -> tuple[mc.MEDCouplingUMesh, mc.MEDFileUMesh]:
    cm = mc.MEDCouplingCMesh()
    # graded spacing: the Gauss-to-node extrapolation of a quadratic field is then discontinuous between elements
    cm.setCoords(*(mc.DataArrayDouble(s * np.linspace(0, 1, n + 1) ** 1.3) for s, n in ((L, n_xy), (L, n_xy), (H, n_z))))
    um = cm.buildUnstructured()
    if tetra:  # each hexahedron split into 6 tetrahedra (a conforming split of the grid)
        um = um.tetrahedrize(mc.PLANAR_FACE_6)[0].buildUnstructured()
    um.setName("MAIL")
    mm = mc.MEDFileUMesh()
    mm.setMeshAtLevel(0, um)
    skin = um.computeSkin()
    skin.setName("MAIL")
    mm.setMeshAtLevel(-1, skin)
    return um, mm


def _field(um, on, name: str, comps: list[str], values: np.ndarray, t: float, k: int):
    f = mc.MEDCouplingFieldDouble(on, mc.ONE_TIME)
    f.setMesh(um)
    f.setName(name)
    if on == mc.ON_GAUSS_PT:
        ct = um.getAllGeoTypes()[0]
        f.setGaussLocalizationOnType(ct, *_gauss(ct))
    arr = mc.DataArrayDouble(np.ascontiguousarray(values.reshape(values.shape[0], -1)))
    arr.setInfoOnComponents(comps)
    f.setArray(arr)
    f.setTime(t, k, -1)
    f.checkConsistencyLight()
    return f


def _gauss(ct):
    """2 x 2 x 2 Gauss points of the MED reference hexahedron (weights 1)."""
    ref = [float(c) for c in mc.MEDCouplingGaussLocalization.GetDefaultReferenceCoordinatesOf(ct).toNumPyArray().ravel()]
    a = 1 / np.sqrt(3)
    pts = [float(c) for z in (-a, a) for y in (-a, a) for x in (-a, a) for c in (x, y, z)]
    return ref, pts, [1.0] * 8


def hexa_fields(um) -> dict[str, list]:
    """code_aster-named fields of the hexahedral block at INST 1, 2, 3."""
    ref, pts, w = _gauss(mc.NORM_HEXA8)
    loc = mc.MEDCouplingGaussLocalization(mc.NORM_HEXA8, ref, pts, w)
    shape = loc.getShapeFunctionValues().toNumPyArray().reshape(8, 8)     # N_i at each Gauss point
    conn = um.getNodalConnectivity().toNumPyArray().reshape(-1, 9)[:, 1:]  # type id, then 8 nodes (MED order)
    coords = um.getCoords().toNumPyArray()
    gauss_xyz = np.einsum("gi,cid->cgd", shape, coords[conn]).reshape(-1, 3)
    to_nodes = np.linalg.inv(shape)                                      # Gauss values -> element nodes
    fields: dict[str, list] = {}
    for k, t in enumerate((1.0, 2.0, 3.0), start=1):
        eps_g = strain(gauss_xyz, t / 3)
        sig_g = stress(eps_g)
        per_gauss = {"ENEL": sed(sig_g, eps_g)[:, None], "SIEF": sig_g, "EPSI": eps_g}
        elno = {key: np.einsum("ig,cgk->cik", to_nodes, v.reshape(-1, 8, v.shape[1])) for key, v in per_gauss.items()}
        noeu = {key: _node_mean(v, conn, coords.shape[0]) for key, v in elno.items()}
        disp = np.zeros_like(coords)  # DEPL: code_aster writes it first; not used by afferent
        for name, on, comps, values in (
            ("RESU____DEPL", mc.ON_NODES, ["DX", "DY", "DZ"], disp),
            ("RESU____ENEL_ELGA", mc.ON_GAUSS_PT, ["TOTALE"], per_gauss["ENEL"]),
            ("RESU____ENEL_ELNO", mc.ON_GAUSS_NE, ["TOTALE"], elno["ENEL"].reshape(-1, 1)),
            ("RESU____ENEL_NOEU", mc.ON_NODES, ["TOTALE"], noeu["ENEL"]),
            ("RESU____SIEF_NOEU", mc.ON_NODES, SIEF, noeu["SIEF"]),
            ("RESU____EPSI_NOEU", mc.ON_NODES, EPSI, noeu["EPSI"]),
        ):
            fields.setdefault(name, []).append(_field(um, on, name, comps, values, t, k))
    return fields


def _node_mean(elno: np.ndarray, conn: np.ndarray, n_nodes: int) -> np.ndarray:
    """code_aster's _NOEU from _ELNO: the arithmetic mean of the element-node copies at each node."""
    total = np.zeros((n_nodes, elno.shape[2]))
    np.add.at(total, conn.ravel(), elno.reshape(-1, elno.shape[2]))
    return total / np.bincount(conn.ravel(), minlength=n_nodes)[:, None]


def tetra_fields(um) -> dict[str, list]:
    """One step (INST 0.5) on linear tetrahedra, names as NOM_CHAM_MED gives them, constant strain."""
    coords = um.getCoords().toNumPyArray()
    eps = np.tile(strain(np.array([[L, L / 2, H]]), 1.0), (coords.shape[0], 1))
    sig = stress(eps)
    volumes = um.getMeasureField(True).getArray().toNumPyArray()
    fields = {}
    for name, on, comps, values in (
        ("SIGM_NOEU", mc.ON_NODES, SIEF, sig),
        ("EPSI_NOEU", mc.ON_NODES, EPSI, eps),
        ("ENEL_NOEU", mc.ON_NODES, ["TOTALE"], sed(sig, eps)),
        ("ENEL_ELEM", mc.ON_CELLS, ["TOTALE"], sed(sig[:1], eps[:1]) * volumes),  # an energy per element, J
    ):
        fields[name] = [_field(um, on, name, comps, values, 0.5, 1)]
    return fields


def write(path: Path, mm, fields: dict[str, list]) -> None:
    path.unlink(missing_ok=True)
    mm.write(str(path), 2)
    for steps in fields.values():
        ts = mc.MEDFileFieldMultiTS()
        for f in steps:
            ts.appendFieldNoProfileSBT(f)
        ts.write(str(path), 0)


def reference(path: Path) -> dict[str, np.ndarray]:
    """What medcoupling reads back from ``path``: the independent reference of the tests."""
    prefix = path.stem
    mesh = mc.MEDFileMesh.New(str(path))
    um = mesh.getMeshAtLevel(0)
    out = {f"{prefix}/coords": um.getCoords().toNumPyArray(),
           f"{prefix}/conn": um.getNodalConnectivity().toNumPyArray(),
           f"{prefix}/conn_index": um.getNodalConnectivityIndex().toNumPyArray()}
    for name in mc.GetAllFieldNames(str(path)):
        ts = mc.MEDFileFieldMultiTS.New(str(path), name)
        times, values = [], []
        for it, order, t in ts.getTimeSteps():
            f = mc.ReadField(str(path), name, it, order)
            times.append(t)
            values.append(f.getArray().toNumPyArray().reshape(f.getArray().getNumberOfTuples(), -1))
            if f.getTypeOfField() == mc.ON_GAUSS_PT:
                out[f"{prefix}/{name}/weights"] = np.array(f.getGaussLocalization(0).getWeights())
            out[f"{prefix}/{name}/on"] = np.array(int(f.getTypeOfField()))
            out[f"{prefix}/{name}/components"] = np.array(f.getArray().getInfoOnComponents())
        out[f"{prefix}/{name}/times"] = np.array(times)
        out[f"{prefix}/{name}/values"] = np.stack(values)
    return out


def main() -> None:
    um, mm = block_mesh(4, 2, tetra=False)
    write(HERE / "block_hexa.rmed", mm, hexa_fields(um))
    um, mm = block_mesh(2, 1, tetra=True)
    write(HERE / "block_tetra.med", mm, tetra_fields(um))
    ref = {**reference(HERE / "block_hexa.rmed"), **reference(HERE / "block_tetra.med")}
    ref["versions"] = np.array([f"medcoupling {mc.MEDCouplingVersionStr()}", f"med-fichier {mc.MEDFileVersionStr()}"])
    np.savez_compressed(HERE / "reference.npz", **ref)


if __name__ == "__main__":
    main()
