"""Write small CalculiX models of an indented skin-like block and run ccx on them.

Regenerate (CalculiX ccx 2.20, Debian package calculix-ccx)::

    python tests/data/calculix/make_calculix.py        # needs `ccx` on PATH

The model, in mm / N / s (so stresses, ENER and E in MPa): a 2 x 2 x 1 mm block (x, y across,
z up), bottom face z = 0 fixed, the nodes of a 1 x 1 mm patch at the centre of the top face
pushed down by 0.1 mm in three linear *STATIC steps (1/3, 2/3 and 3/3 of the depth, step times
1, 2, 3), linear elastic
E = 0.1 MPa, nu = 0.45 (dermis-like). Every step writes U (nodes) and S, E, ENER
(extrapolated to and averaged at the nodes) to the .frd. Four meshes: C3D8 (linear hexahedra),
C3D20R (quadratic, reduced integration), C3D10 (quadratic tetrahedra, the hexahedra split
into 6) and C3D15 (quadratic wedges, the hexahedra split into 2). The C3D8 run also prints S, E, ENER at the integration points to the .dat (*EL PRINT);
``block_c3d8_binary`` is the same C3D8 model written with *NODE OUTPUT / *ELEMENT OUTPUT, which
make ccx write the .frd records in binary; ``block_c3d8.frd.gz`` is the ASCII .frd gzipped;
``block_c3d8_print.dat`` (and its gzip) is the C3D8 model printing S, E, ENER (*EL PRINT) and U
(*NODE PRINT) to the .dat, element and node tables interleaved at every step.
"""

from __future__ import annotations

import gzip
import subprocess
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
L, H = 2.0, 1.0          # block size, mm
PATCH = 0.5              # half-width of the pushed patch, mm
DEPTH = 0.1              # indentation, mm
E_MPA, NU = 0.1, 0.45
N_STEPS = 3              # depths 1/3, 2/3, 3/3 of DEPTH


def _grid(n_xy: int, n_z: int, quadratic: bool):
    """Nodes of a structured grid (mid-side nodes included when quadratic)."""
    k = 2 if quadratic else 1
    xs = np.linspace(0, L, k * n_xy + 1)
    zs = np.linspace(0, H, k * n_z + 1)
    ids = {}
    nodes = []
    for iz, z in enumerate(zs):
        for iy, y in enumerate(xs):
            for ix, x in enumerate(xs):
                ids[(ix, iy, iz)] = len(nodes) + 1
                nodes.append((x, y, z))
    return np.array(nodes), ids, k


def _hex8(n_xy, n_z, ids, k=1):
    els = []
    for iz in range(n_z):
        for iy in range(n_xy):
            for ix in range(n_xy):
                a, b, c = k * ix, k * iy, k * iz
                corner = lambda dx, dy, dz: ids[(a + k * dx, b + k * dy, c + k * dz)]  # noqa: E731
                els.append([corner(0, 0, 0), corner(1, 0, 0), corner(1, 1, 0), corner(0, 1, 0),
                            corner(0, 0, 1), corner(1, 0, 1), corner(1, 1, 1), corner(0, 1, 1)])
    return els


def _hex20(n_xy, n_z, ids):
    """C3D20 node order: 8 corners, then mid-edges 9-12 (bottom), 13-16 (top), 17-20 (vertical)."""
    els = []
    for iz in range(n_z):
        for iy in range(n_xy):
            for ix in range(n_xy):
                a, b, c = 2 * ix, 2 * iy, 2 * iz
                n = lambda dx, dy, dz: ids[(a + dx, b + dy, c + dz)]  # noqa: E731
                els.append([n(0, 0, 0), n(2, 0, 0), n(2, 2, 0), n(0, 2, 0), n(0, 0, 2), n(2, 0, 2), n(2, 2, 2), n(0, 2, 2),
                            n(1, 0, 0), n(2, 1, 0), n(1, 2, 0), n(0, 1, 0), n(1, 0, 2), n(2, 1, 2), n(1, 2, 2), n(0, 1, 2),
                            n(0, 0, 1), n(2, 0, 1), n(2, 2, 1), n(0, 2, 1)])
    return els


def _wedge15(n_xy, n_z, ids):
    """Each hexahedron split into 2 wedges by the diagonal (0,0)-(1,1) of its bottom face.

    C3D15 node order (the input deck's): corners 1-3 (bottom) and 4-6 (top), mid-edges 7-9 of the
    bottom triangle (1-2, 2-3, 3-1), 10-12 of the top one, 13-15 of the vertical edges.
    """
    els = []
    for iz in range(n_z):
        for iy in range(n_xy):
            for ix in range(n_xy):
                a, b, c = 2 * ix, 2 * iy, 2 * iz
                n = lambda dx, dy, dz: ids[(a + dx, b + dy, c + dz)]  # noqa: E731
                for tri in (((0, 0), (2, 0), (2, 2)), ((0, 0), (2, 2), (0, 2))):
                    mid = [((tri[i][0] + tri[j][0]) // 2, (tri[i][1] + tri[j][1]) // 2) for i, j in ((0, 1), (1, 2), (2, 0))]
                    els.append([n(*p, 0) for p in tri] + [n(*p, 2) for p in tri] + [n(*p, 0) for p in mid]
                               + [n(*p, 2) for p in mid] + [n(*p, 1) for p in tri])
    return els


def _tet10(n_xy, n_z, ids, nodes):
    """Each hexahedron split into 6 tetrahedra around its 0-6 diagonal; mid-edge nodes added."""
    els = []
    extra = {}
    coords = list(map(tuple, nodes))
    split = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
    for h in _hex8(n_xy, n_z, ids):
        for t in split:
            c = [h[i] for i in t]
            # right-handed: positive volume
            p = np.array([coords[i - 1] for i in c])
            if np.linalg.det(np.array([p[1] - p[0], p[2] - p[0], p[3] - p[0]])) < 0:
                c[1], c[2] = c[2], c[1]
            mids = []
            for i, j in ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)):
                key = tuple(sorted((c[i], c[j])))
                if key not in extra:
                    coords.append(tuple((np.array(coords[c[i] - 1]) + np.array(coords[c[j] - 1])) / 2))
                    extra[key] = len(coords)
                mids.append(extra[key])
            els.append(c + mids)
    return np.array(coords), els


def _lines(values, per_line=8):
    out = []
    for i in range(0, len(values), per_line):
        out.append(", ".join(str(v) for v in values[i:i + per_line]))
    return ",\n".join(out)


def write_inp(path: Path, kind: str, n_xy: int = 4, n_z: int = 2, el_print: bool = False, binary: bool = False,
              node_print: bool = False) -> None:
    quadratic = kind in ("C3D20R", "C3D10", "C3D15")
    nodes, ids, k = _grid(n_xy, n_z, quadratic and kind in ("C3D20R", "C3D15"))
    if kind == "C3D8":
        els = _hex8(n_xy, n_z, ids)
    elif kind == "C3D20R":
        els = _hex20(n_xy, n_z, ids)
    elif kind == "C3D15":
        els = _wedge15(n_xy, n_z, ids)
    else:
        nodes, els = _tet10(n_xy, n_z, ids, nodes)
    used = sorted({n for e in els for n in e})
    x, y, z = nodes[:, 0], nodes[:, 1], nodes[:, 2]
    idx = np.arange(1, len(nodes) + 1)
    in_use = np.isin(idx, used)
    bottom = idx[in_use & (np.abs(z) < 1e-9)]
    top = idx[in_use & (np.abs(z - H) < 1e-9) & (np.abs(x - L / 2) <= PATCH + 1e-9) & (np.abs(y - L / 2) <= PATCH + 1e-9)]
    with open(path, "w") as f:
        f.write(f"** afferent test model: {kind}, {n_xy}x{n_xy}x{n_z}, mm/N/s\n*NODE, NSET=NALL\n")
        for i in used:
            f.write(f"{i}, {nodes[i - 1, 0]:.10g}, {nodes[i - 1, 1]:.10g}, {nodes[i - 1, 2]:.10g}\n")
        f.write(f"*ELEMENT, TYPE={kind}, ELSET=EALL\n")
        for j, e in enumerate(els, start=1):
            f.write(f"{j}, " + _lines(e, 15).replace(",\n", ",\n") + "\n")
        f.write("*NSET, NSET=BOTTOM\n" + _lines(list(bottom)) + "\n")
        f.write("*NSET, NSET=PATCH\n" + _lines(list(top)) + "\n")
        f.write(f"*MATERIAL, NAME=DERMIS\n*ELASTIC\n{E_MPA}, {NU}\n*SOLID SECTION, ELSET=EALL, MATERIAL=DERMIS\n")
        f.write("*BOUNDARY\nBOTTOM, 1, 3\nPATCH, 1, 2\n")
        for k in range(1, N_STEPS + 1):  # one linear step per depth: one result set (time k) each
            f.write(f"*STEP\n*STATIC\n*BOUNDARY\nPATCH, 3, 3, {-DEPTH * k / N_STEPS:.6g}\n")
            if binary:  # the Abaqus-style cards make ccx write the .frd records in binary
                f.write("*NODE OUTPUT\nU\n*ELEMENT OUTPUT\nS, E, ENER\n")
            else:
                f.write("*NODE FILE\nU\n*EL FILE\nS, E, ENER\n")
            if el_print:
                f.write("*EL PRINT, ELSET=EALL\nS, E, ENER\n")
            if node_print:  # displacement tables at the nodes between the element tables
                f.write("*NODE PRINT, NSET=NALL\nU\n")
            f.write("*END STEP\n")


#: The layered model (``block_layers``): a 1.5 x 1 x 1.5 mm block of two materials with y up (the
#: thickness axis afferent assumes), their interface a relief y = 0.5 + RELIEF cos(2 pi x / RELIEF_PITCH)
#: cos(2 pi z / RELIEF_PITCH) mm: its local maxima (papilla-tip-like, both cosines of one sign) and minima
#: (ridge-base-like) sit on nodes.
LAYERS_L, LAYERS_N_XZ, LAYERS_N_Y = 1.5, 12, 6
RELIEF, RELIEF_PITCH = 0.08, 0.5
LAYER_MATERIALS = (("EPIDERMIS", 0.136), ("DERMIS", 0.08))  # in this order in the deck: frd material 1, 2


def layered_nodes():
    """Node coordinates (n, 3) and ids {(ix, iz, iy): id} of the layered block (interface at node level N_Y // 2)."""
    xs = np.linspace(0, LAYERS_L, LAYERS_N_XZ + 1)
    nodes, ids = [], {}
    half = LAYERS_N_Y // 2
    for iy in range(LAYERS_N_Y + 1):
        for iz, z in enumerate(xs):
            for ix, x in enumerate(xs):
                yi = 0.5 + RELIEF * np.cos(2 * np.pi * x / RELIEF_PITCH) * np.cos(2 * np.pi * z / RELIEF_PITCH)
                y = yi * iy / half if iy <= half else yi + (H - yi) * (iy - half) / (LAYERS_N_Y - half)
                ids[(ix, iz, iy)] = len(nodes) + 1
                nodes.append((x, y, z))
    return np.array(nodes), ids


def write_layered_inp(path: Path, binary: bool = False) -> None:
    """Two materials (ELSETs DERMIS below the relief, EPIDERMIS above), one indentation step, U and ENER."""
    nodes, ids = layered_nodes()
    # _hex8 walks (x, z, y) as its (x, y, z): with y and z swapped the faces turn inside out, so each
    # element's two faces are listed the other way round to keep a positive volume
    els = [[e[0], e[3], e[2], e[1], e[4], e[7], e[6], e[5]] for e in _hex8(LAYERS_N_XZ, LAYERS_N_Y, ids)]
    per_layer = LAYERS_N_XZ * LAYERS_N_XZ
    half = LAYERS_N_Y // 2
    x, y, z = nodes[:, 0], nodes[:, 1], nodes[:, 2]
    idx = np.arange(1, len(nodes) + 1)
    bottom = idx[np.abs(y) < 1e-9]
    c, p = LAYERS_L / 2, PATCH / 2
    top = idx[(np.abs(y - H) < 1e-9) & (np.abs(x - c) <= p + 1e-9) & (np.abs(z - c) <= p + 1e-9)]
    with open(path, "w") as f:
        f.write("** afferent test model: two layers with a relief interface, C3D8, mm/N/s, y up\n*NODE, NSET=NALL\n")
        for i in idx:
            f.write(f"{i}, {nodes[i - 1, 0]:.10g}, {nodes[i - 1, 1]:.10g}, {nodes[i - 1, 2]:.10g}\n")
        f.write("*ELEMENT, TYPE=C3D8, ELSET=EALL\n")
        for j, e in enumerate(els, start=1):
            f.write(f"{j}, " + _lines(e, 15) + "\n")
        lower = list(range(1, half * per_layer + 1))
        upper = list(range(half * per_layer + 1, len(els) + 1))
        f.write("*ELSET, ELSET=DERMIS\n" + _lines(lower) + "\n")
        f.write("*ELSET, ELSET=EPIDERMIS\n" + _lines(upper) + "\n")
        f.write("*NSET, NSET=BOTTOM\n" + _lines(list(bottom)) + "\n")
        f.write("*NSET, NSET=PATCH\n" + _lines(list(top)) + "\n")
        for name, young in LAYER_MATERIALS:
            f.write(f"*MATERIAL, NAME={name}\n*ELASTIC\n{young}, {NU}\n")
        for name, _ in reversed(LAYER_MATERIALS):  # sections in the other order: the frd number follows *MATERIAL
            f.write(f"*SOLID SECTION, ELSET={name}, MATERIAL={name}\n")
        f.write("*BOUNDARY\nBOTTOM, 1, 3\nPATCH, 1\nPATCH, 3\n")
        out = "*NODE OUTPUT\nU\n*ELEMENT OUTPUT\nENER\n" if binary else "*NODE FILE\nU\n*EL FILE\nENER\n"
        f.write(f"*STEP\n*STATIC\n*BOUNDARY\nPATCH, 2, 2, {-DEPTH:.6g}\n{out}*END STEP\n")


def run(job: str, *extra: str) -> None:
    subprocess.run(["ccx", "-i", job, *extra], cwd=HERE, check=True, capture_output=True)
    for junk in (".sta", ".cvg", ".12d"):
        (HERE / f"{job}{junk}").unlink(missing_ok=True)
    (HERE / "spooles.out").unlink(missing_ok=True)


def main() -> None:
    write_inp(HERE / "block_c3d8.inp", "C3D8", el_print=True)
    run("block_c3d8")
    write_inp(HERE / "block_c3d8_binary.inp", "C3D8", binary=True)
    run("block_c3d8_binary")
    (HERE / "block_c3d8_binary.dat").unlink(missing_ok=True)
    write_inp(HERE / "block_c3d20r.inp", "C3D20R", n_xy=2, n_z=1)
    run("block_c3d20r")
    write_inp(HERE / "block_c3d10.inp", "C3D10", n_xy=2, n_z=1)
    run("block_c3d10")
    write_inp(HERE / "block_c3d15.inp", "C3D15", n_xy=2, n_z=1)
    run("block_c3d15")
    for job in ("block_c3d20r", "block_c3d10", "block_c3d15"):
        (HERE / f"{job}.dat").unlink(missing_ok=True)  # empty: no *EL PRINT
    (HERE / "block_c3d8.frd.gz").write_bytes(gzip.compress((HERE / "block_c3d8.frd").read_bytes(), mtime=0))
    # *EL PRINT (S, E, ENER at the integration points) and *NODE PRINT (U) blocks in one .dat, and its gzip;
    # the mesh is block_c3d8's, so its .frd is left out
    write_inp(HERE / "block_c3d8_print.inp", "C3D8", el_print=True, node_print=True)
    run("block_c3d8_print")
    (HERE / "block_c3d8_print.frd").unlink(missing_ok=True)
    (HERE / "block_c3d8_print.dat.gz").write_bytes(gzip.compress((HERE / "block_c3d8_print.dat").read_bytes(), mtime=0))
    write_layered_inp(HERE / "block_layers.inp")
    run("block_layers")
    write_layered_inp(HERE / "block_layers_binary.inp", binary=True)
    run("block_layers_binary")
    for job in ("block_layers", "block_layers_binary"):
        (HERE / f"{job}.dat").unlink(missing_ok=True)


if __name__ == "__main__":
    main()
