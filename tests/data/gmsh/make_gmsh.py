"""Write the Gmsh result files of tests/data/gmsh with Gmsh itself (the PyPI wheel ``gmsh``, see README.md).

A two-layer block (x, y in 0..1.5, z in 0..1.5, model units): below z = 1, 3 x 3 x 2 hexahedra
(physical volume 1); above, 3 x 3 x 1 cubes split into 6 tetrahedra each (physical volume 2); the
top face as triangles (physical surface 3). Node tags are not contiguous (10 k + 7). Views, each at
two steps (times 0.5 and 1.0):

- ``SED`` (NodeData, scalar): f(x, y, z) t with f = 1 + x + 2 y + 3 z;
- ``displacement`` (NodeData, 3 components): (x z, y z, -z^2) t / 10;
- ``stress`` (ElementData, 9 components, row-major xx xy xz yx yy yz zx zy zz): symmetric, from the
  element's centroid c: diag (c_x, c_y, c_z) + 0.1 off-diagonal, times t;
- ``SED_nodal_elements`` (ElementNodeData, scalar): f at each element node times (1 + 0.05 (e mod 3)) t,
  e the element's index among the volume elements: discontinuous from element to element.

Each is written with gmsh.view.write(tag, file, append=True) in MSH 2.2 and 4.1, ASCII and binary
(Gmsh writes the mesh again before each view); ``block_v41_nodal.msh`` holds ``SED`` and ``stress``
with the mesh once (``PostProcessing.SaveMesh = 0`` after the first view); ``sed_without_mesh.msh``
is ``SED`` alone without its mesh (refused). ``reference.npz`` holds what was put in (per node, per element, per
element node, with their coordinates, the elements' volumes and the times).
"""

import os
import sys

import gmsh
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TIMES = (0.5, 1.0)


def build():
    h = 0.5
    grid = np.array([[i * h, j * h, k * h] for k in range(4) for j in range(4) for i in range(4)])
    tags = 10 * np.arange(len(grid)) + 7

    def node(i, j, k):
        return (k * 4 + j) * 4 + i

    hexes, tets, tris = [], [], []
    for k in range(3):
        for j in range(3):
            for i in range(3):
                c = [node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
                     node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
                if k < 2:
                    hexes.append(c)
                else:  # the cube split into 6 tetrahedra around its diagonal 0-6
                    for a, b in ((1, 2), (2, 3), (3, 7), (7, 4), (4, 5), (5, 1)):
                        tets.append([c[0], c[a], c[b], c[6]])
    for j in range(3):
        for i in range(3):
            a, b, c, d = node(i, j, 3), node(i + 1, j, 3), node(i + 1, j + 1, 3), node(i, j + 1, 3)
            tris += [[a, b, c], [a, c, d]]
    return grid, tags, np.array(hexes), np.array(tets), np.array(tris)


def tet_volume(p):
    return abs(np.linalg.det(np.stack([p[1] - p[0], p[2] - p[0], p[3] - p[0]]))) / 6


def main():
    grid, ntags, hexes, tets, tris = build()
    gmsh.initialize(sys.argv[:1])
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("block")
    v1 = gmsh.model.addDiscreteEntity(3, 1)
    v2 = gmsh.model.addDiscreteEntity(3, 2)
    s3 = gmsh.model.addDiscreteEntity(2, 3)
    gmsh.model.mesh.addNodes(3, v1, ntags.tolist(), grid.ravel().tolist())
    hex_tags = 1 + np.arange(len(hexes))
    tet_tags = 101 + np.arange(len(tets))
    tri_tags = 501 + np.arange(len(tris))
    gmsh.model.mesh.addElementsByType(v1, 5, hex_tags.tolist(), ntags[hexes].ravel().tolist())
    gmsh.model.mesh.addElementsByType(v2, 4, tet_tags.tolist(), ntags[tets].ravel().tolist())
    gmsh.model.mesh.addElementsByType(s3, 2, tri_tags.tolist(), ntags[tris].ravel().tolist())
    gmsh.model.addPhysicalGroup(3, [v1], 1, "dermis")
    gmsh.model.addPhysicalGroup(3, [v2], 2, "epidermis")
    gmsh.model.addPhysicalGroup(2, [s3], 3, "top")

    f = 1 + grid[:, 0] + 2 * grid[:, 1] + 3 * grid[:, 2]
    disp = np.column_stack([grid[:, 0] * grid[:, 2], grid[:, 1] * grid[:, 2], -grid[:, 2] ** 2]) / 10
    conns = [hexes[e] for e in range(len(hexes))] + [tets[e] for e in range(len(tets))]
    elem_tags = np.concatenate([hex_tags, tet_tags])
    centroid = np.array([grid[c].mean(axis=0) for c in conns])
    volume = np.array([0.125] * len(hexes) + [tet_volume(grid[c]) for c in tets])
    stress = np.zeros((len(conns), 3, 3)) + 0.1
    stress[:, [0, 1, 2], [0, 1, 2]] = centroid
    stress = stress.reshape(-1, 9)
    scale = 1 + 0.05 * (np.arange(len(conns)) % 3)

    views = {name: gmsh.view.add(name) for name in ("SED", "displacement", "stress", "SED_nodal_elements")}
    for step, t in enumerate(TIMES):
        gmsh.view.addHomogeneousModelData(views["SED"], step, "block", "NodeData", ntags.tolist(), (f * t).tolist(),
                                          time=t, numComponents=1)
        gmsh.view.addHomogeneousModelData(views["displacement"], step, "block", "NodeData", ntags.tolist(),
                                          (disp * t).ravel().tolist(), time=t, numComponents=3)
        gmsh.view.addHomogeneousModelData(views["stress"], step, "block", "ElementData", elem_tags.tolist(),
                                          (stress * t).ravel().tolist(), time=t, numComponents=9)
        en = [(f[c] * scale[e] * t).tolist() for e, c in enumerate(conns)]
        gmsh.view.addModelData(views["SED_nodal_elements"], step, "block", "ElementNodeData", elem_tags.tolist(), en,
                               time=t, numComponents=1)

    for version in (2.2, 4.1):
        for binary in (0, 1):
            gmsh.option.setNumber("Mesh.MshFileVersion", version)
            gmsh.option.setNumber("Mesh.Binary", binary)
            gmsh.option.setNumber("PostProcessing.SaveMesh", 1)
            name = os.path.join(HERE, f"block_v{str(version).replace('.', '')}_{'binary' if binary else 'ascii'}.msh")
            if os.path.exists(name):
                os.remove(name)
            for k, tag in enumerate(views.values()):
                gmsh.view.write(tag, name, append=k > 0)

    # the mesh written once: the views after the first with PostProcessing.SaveMesh = 0 (nodal SED and stress only)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    name = os.path.join(HERE, "block_v41_nodal.msh")
    if os.path.exists(name):
        os.remove(name)
    for k, view in enumerate(("SED", "stress")):
        gmsh.option.setNumber("PostProcessing.SaveMesh", int(k == 0))
        gmsh.view.write(views[view], name, append=k > 0)
    gmsh.view.write(views["SED"], os.path.join(HERE, "sed_without_mesh.msh"))  # SaveMesh = 0 still: data only

    # the four views in Gmsh's parsed format (.pos: the file name selects it): each element with its own
    # coordinates and values, the triangles' too (NodeData); no TIME list (Gmsh writes none for model data)
    name = os.path.join(HERE, "block_views.pos")
    if os.path.exists(name):
        os.remove(name)
    for k, tag in enumerate(views.values()):
        gmsh.view.write(tag, name, append=k > 0)
    list_views(grid, hexes, tets, f)

    copies_xyz = np.concatenate([grid[c] for c in conns])
    copies_sed = np.stack([np.concatenate([f[c] * scale[e] * t for e, c in enumerate(conns)]) for t in TIMES])
    np.savez_compressed(
        os.path.join(HERE, "reference.npz"), times=np.array(TIMES), node_xyz=grid, node_tags=ntags,
        node_sed=np.stack([f * t for t in TIMES]), node_displacement=np.stack([disp * t for t in TIMES]),
        elem_tags=elem_tags, elem_centroid=centroid, elem_volume=volume,
        elem_stress=np.stack([stress * t for t in TIMES]), copy_xyz=copies_xyz,
        copy_elem=np.repeat(np.arange(len(conns)), [len(c) for c in conns]), copy_sed=copies_sed,
        gmsh_version=np.array(gmsh.__version__))
    gmsh.finalize()


def list_views(grid, hexes, tets, f):
    """``lists.pos``: three list-based views (gmsh.view.addListData) on the first 2 hexahedra and the first
    6 tetrahedra of the block, 2 steps each (Gmsh writes TIME{0,1}), a point and a triangle in the
    scalar view (left out by afferent); ``reference_pos.npz``: each element's node coordinates and values."""
    hx, tt = hexes[:2], tets[:6]
    tri = tets[0][:3]

    def coords(conn):  # addListData wants each element's x of every node, then y, then z
        return grid[conn].transpose(0, 2, 1)

    def vals(conn, ncomp, scale):  # (elements, steps, nodes, components): pi-scaled, not short decimals
        base = f[conn][:, None, :, None] * np.pi * scale * (1 + np.arange(ncomp))[None, None, None, :]
        return np.concatenate([base * t for t in (1.0, 2.0)], axis=1) + np.arange(len(conn))[:, None, None, None] / 7

    ref = {}
    for view, letter, ncomp in (("sed_list", "S", 1), ("displacement_list", "V", 3), ("stress_list", "T", 9)):
        tag = gmsh.view.add(view)
        for shape, conn in (("S", tt), ("H", hx)):
            v = vals(conn, ncomp, 1 + 0.1 * ncomp)
            data = np.concatenate([coords(conn).reshape(len(conn), -1), v.reshape(len(conn), -1)], axis=1)
            gmsh.view.addListData(tag, letter + shape, len(conn), data.ravel().tolist())
            ref[f"{view}/{shape}/xyz"], ref[f"{view}/{shape}/values"] = grid[conn], v
        if letter == "S":  # a point and a triangle: not volume elements
            gmsh.view.addListData(tag, "SP", 1, grid[0].tolist() + [1.0, 2.0])
            gmsh.view.addListData(tag, "ST", 1, grid[tri].T.ravel().tolist() + [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        gmsh.view.write(tag, os.path.join(HERE, "lists.pos"), append=letter != "S")
    np.savez_compressed(os.path.join(HERE, "reference_pos.npz"), **ref)


if __name__ == "__main__":
    main()
