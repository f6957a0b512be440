"""Regenerate the FEBio plot files of tests/data/febio (see README.md here).

Writes each model's FEBio input (``<name>.feb``, spec 4.0), runs FEBio on it
(``$FEBIO``, default ``febio4`` on the PATH: ``febio4 -i <name>.feb -silent``), keeps the
``.xplt`` it writes and deletes FEBio's ``.log``. Then, when the independent parser ``pyfebio``
(0.3.0, whose reader follows FEBio Studio's) is importable, writes ``<name>.reference.npz``: the
node coordinates, each domain's element table and every nodal and element variable at every state
as pyfebio reads them, for tests/test_io_xplt.py to compare afferent's reader against.

The models: a two-layer skin block (an "epidermis" 0.25 mm over a "dermis" 0.75 mm, neo-Hookean,
mm-N-s units, so stress and SED in MPa), its bottom fixed, a square patch of its top pressed
0.05 mm in two steps (plus FEBio's zero state), meshed with

- ``block_hex8``: 4 x 4 x 3 linear hexahedra, plot variables displacement, stress, Lagrange
  strain, strain energy density, nodal stress (per element node);
- ``block_tet10_z``: the same block in quadratic tetrahedra (each hexahedron split in 6), states
  zlib-compressed (``<compression>1</compression>``), stress, Lagrange strain and no strain
  energy density (SED from the tensors);
- ``block_penta15``: quadratic wedges (each hexahedron split in 2), strain energy density;
- ``block_hex8_shell``: ``block_hex8`` under a layer of QUAD4 shells 0.02 mm thick on its top face
  (a stratum corneum, the epidermis' material), strain energy density and shell thickness.

Usage::

    python tests/data/febio/make_febio.py [name ...]  # FEBio 4 as febio4 on the PATH, or FEBIO=/path/febio4
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
NX, NY, NZ = 4, 4, 3
SIZE = (2.0, 2.0, 1.0)  # mm
EPIDERMIS_Z = 0.75  # elements above this height (mm) are epidermis
PRESS_MM = 0.05

# VTK/FEBio corner numbering of a hexahedron and its splits
_HEX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
_TETS = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
_TET_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
_WEDGES = [(0, 1, 2, 4, 5, 6), (0, 2, 3, 4, 6, 7)]
_WEDGE_EDGES = [(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)]
_PYRAMIDS = [(0, 1, 2, 3, 8), (4, 7, 6, 5, 8), (0, 4, 5, 1, 8), (3, 2, 6, 7, 8), (0, 3, 7, 4, 8), (1, 5, 6, 2, 8)]

# The other solid elements, split from the hexahedron (its corners 0-7 and its centre 8): FEBio's type, the
# sub-elements' corners, and each node as the mean of the sub-element's corners listed (a corner repeated weighs
# more: (0, 0, 1) is the third-point of edge 0-1 next to corner 0), in FEBio's node order
# (FECore/FESolidElementShape.cpp, the shape functions' nodes).
_EDGES_OF_TET = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
_OTHER = {
    "hex20": ([tuple(range(8))], [(k,) for k in range(8)] + _HEX_EDGES),
    "hex27": ([tuple(range(8))], [(k,) for k in range(8)] + _HEX_EDGES + [
        (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (0, 1, 2, 3), (4, 5, 6, 7), tuple(range(8))]),
    "tet15": (_TETS, [(k,) for k in range(4)] + _EDGES_OF_TET + [(0, 1, 2), (0, 1, 3), (1, 2, 3), (2, 0, 3),
                                                                (0, 1, 2, 3)]),
    "tet20": (_TETS, [(k,) for k in range(4)] + [
        (0, 0, 1), (1, 1, 0), (1, 1, 2), (2, 2, 1), (0, 0, 2), (2, 2, 0), (0, 0, 3), (3, 3, 0), (1, 1, 3), (3, 3, 1),
        (2, 2, 3), (3, 3, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3), (0, 1, 2)]),
    "pyra5": (_PYRAMIDS, [(k,) for k in range(5)]),
    "pyra13": (_PYRAMIDS, [(k,) for k in range(5)] + [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)]),
}


def _grid(grid=None):
    nx, ny, nz = grid or (NX, NY, NZ)
    xs, ys, zs = (np.linspace(0, s, n + 1) for s, n in zip(SIZE, (nx, ny, nz)))
    nodes = [(x, y, z) for z in zs for y in ys for x in xs]

    def nid(i, j, k):
        return k * (ny + 1) * (nx + 1) + j * (nx + 1) + i

    hexes = [[nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
              nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)]
             for k in range(nz) for j in range(ny) for i in range(nx)]
    return nodes, hexes


def _other_mesh(kind: str, grid):
    """(nodes, elements) of an element type of :data:`_OTHER`: nodes shared by position."""
    nodes, hexes = _grid(grid)
    at = {tuple(np.round(xyz, 9)): k for k, xyz in enumerate(nodes)}
    splits, spec = _OTHER[kind]

    def node(xyz):
        key = tuple(np.round(xyz, 9))
        if key not in at:
            at[key] = len(nodes)
            nodes.append(tuple(float(v) for v in xyz))
        return at[key]

    elements = []
    for h in hexes:
        corners = np.array([nodes[n] for n in h] + [np.mean([nodes[n] for n in h], axis=0).tolist()])
        for sub in splits:
            xyz = corners[list(sub)]
            elements.append((kind, [node(xyz[list(s)].mean(axis=0)) for s in spec]))
    return nodes, elements


def _mesh(kind: str, grid=None):
    """(nodes [(x, y, z)], elements [(febio type, [0-based nodes])]) of the block."""
    if kind in _OTHER:
        return _other_mesh(kind, grid)
    nodes, hexes = _grid(grid)
    mid: dict = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mid:
            mid[key] = len(nodes)
            nodes.append(tuple((np.add(nodes[a], nodes[b]) / 2).tolist()))
        return mid[key]

    elements = []
    for h in hexes:
        if kind == "hex8":
            elements.append(("hex8", h))
        elif kind == "tet10":
            for t in _TETS:
                c = [h[i] for i in t]
                elements.append(("tet10", c + [midpoint(c[a], c[b]) for a, b in _TET_EDGES]))
        elif kind == "penta15":
            for w in _WEDGES:
                c = [h[i] for i in w]
                elements.append(("penta15", c + [midpoint(c[a], c[b]) for a, b in _WEDGE_EDGES]))
    return nodes, elements


def _shells(nodes) -> list:
    """Quad4 shells over the block's top face (a stratum corneum), on the top nodes."""
    index = {(round(x, 9), round(y, 9)): k for k, (x, y, z) in enumerate(nodes) if abs(z - SIZE[2]) < 1e-9}
    xs, ys = np.linspace(0, SIZE[0], NX + 1), np.linspace(0, SIZE[1], NY + 1)
    return [[index[(round(xs[i], 9), round(ys[j], 9))], index[(round(xs[i + 1], 9), round(ys[j], 9))],
             index[(round(xs[i + 1], 9), round(ys[j + 1], 9))], index[(round(xs[i], 9), round(ys[j + 1], 9))]]
            for j in range(NY) for i in range(NX)]


def _feb(kind: str, variables: list[str], compression: int, load: dict | None = None) -> str:
    """The .feb text of a model; ``load`` overrides the default loading: ``press`` (mm), ``slide`` (mm, the
    punch's x displacement), ``curve`` (the load curve's points (t, fraction)), ``steps`` and ``step_size``;
    ``var_sets`` maps a plot variable to the element set (here a domain's name) named in its ``<var>`` tag; ``grid``
    the hexahedra along x, y, z (NX, NY, NZ by default); ``vtk_twin``: add FEBio's VTK output of the run to the
    reference (:func:`_vtk_twin`)."""
    load = {"press": PRESS_MM, "slide": 0.0, "curve": ((0, 0), (1, 1)), "steps": 2, "step_size": 0.5,
            "var_sets": {}, **(load or {})}
    shell = kind.endswith("+shell")
    kind = kind.removesuffix("+shell")
    nodes, elements = _mesh(kind, load.get("grid"))
    layer = {"epidermis": [], "dermis": []}
    for e in elements:
        zc = np.mean([nodes[n][2] for n in e[1]])
        layer["epidermis" if zc > EPIDERMIS_Z else "dermis"].append(e)
    top = [k + 1 for k, (x, y, z) in enumerate(nodes) if abs(z - SIZE[2]) < 1e-9 and 0.5 - 1e-9 <= x <= 1.5 + 1e-9
           and 0.5 - 1e-9 <= y <= 1.5 + 1e-9]
    bottom = [k + 1 for k, (x, y, z) in enumerate(nodes) if abs(z) < 1e-9]
    out = ['<?xml version="1.0" encoding="ISO-8859-1"?>', '<febio_spec version="4.0">', '\t<Module type="solid"/>',
           "\t<Control>", "\t\t<analysis>STATIC</analysis>", f"\t\t<time_steps>{load['steps']}</time_steps>",
           f"\t\t<step_size>{load['step_size']}</step_size>", "\t\t<plot_zero_state>1</plot_zero_state>",
           '\t\t<solver type="solid">', "\t\t\t<symmetric_stiffness>symmetric</symmetric_stiffness>",
           "\t\t</solver>", "\t</Control>", "\t<Material>"]
    for mid_, (name, e_mpa) in enumerate((("epidermis", 0.8), ("dermis", 0.2)), start=1):
        out += [f'\t\t<material id="{mid_}" name="{name}" type="neo-Hookean">', f"\t\t\t<E>{e_mpa}</E>",
                "\t\t\t<v>0.45</v>", "\t\t</material>"]
    out += ["\t</Material>", "\t<Mesh>", '\t\t<Nodes name="all">']
    out += [f'\t\t\t<node id="{k + 1}">{x:.9g},{y:.9g},{z:.9g}</node>' for k, (x, y, z) in enumerate(nodes)]
    out.append("\t\t</Nodes>")
    eid = 1
    for name in ("dermis", "epidermis"):
        etype = layer[name][0][0]
        out.append(f'\t\t<Elements type="{etype}" name="{name}">')
        for _, conn in layer[name]:
            out.append(f'\t\t\t<elem id="{eid}">{",".join(str(n + 1) for n in conn)}</elem>')
            eid += 1
        out.append("\t\t</Elements>")
    if shell:
        out.append('\t\t<Elements type="quad4" name="corneum">')
        for conn in _shells(nodes):
            out.append(f'\t\t\t<elem id="{eid}">{",".join(str(n + 1) for n in conn)}</elem>')
            eid += 1
        out.append("\t\t</Elements>")
    out += [f'\t\t<NodeSet name="bottom">{",".join(map(str, bottom))}</NodeSet>',
            f'\t\t<NodeSet name="punch">{",".join(map(str, top))}</NodeSet>', "\t</Mesh>", "\t<MeshDomains>",
            '\t\t<SolidDomain name="dermis" mat="dermis"/>', '\t\t<SolidDomain name="epidermis" mat="epidermis"/>',
            *(['\t\t<ShellDomain name="corneum" mat="epidermis">', "\t\t\t<shell_thickness>0.02</shell_thickness>",
               "\t\t</ShellDomain>"] if shell else []),
            "\t</MeshDomains>", "\t<Boundary>",
            '\t\t<bc name="fixed" type="zero displacement" node_set="bottom">',
            "\t\t\t<x_dof>1</x_dof>", "\t\t\t<y_dof>1</y_dof>", "\t\t\t<z_dof>1</z_dof>", "\t\t</bc>",
            '\t\t<bc name="press" type="prescribed displacement" node_set="punch">', "\t\t\t<dof>z</dof>",
            f'\t\t\t<value lc="1">{-load["press"]}</value>', "\t\t\t<relative>0</relative>", "\t\t</bc>",
            *(['\t\t<bc name="slide" type="prescribed displacement" node_set="punch">', "\t\t\t<dof>x</dof>",
               f'\t\t\t<value lc="1">{load["slide"]}</value>', "\t\t\t<relative>0</relative>", "\t\t</bc>"]
              if load["slide"] else []),
            "\t</Boundary>",
            "\t<LoadData>", '\t\t<load_controller id="1" type="loadcurve">', "\t\t\t<interpolate>LINEAR</interpolate>",
            "\t\t\t<points>", *(f"\t\t\t\t<pt>{a:g},{b:g}</pt>" for a, b in load["curve"]), "\t\t\t</points>",
            "\t\t</load_controller>", "\t</LoadData>", "\t<Output>", '\t\t<plotfile type="febio">']
    out += [f'\t\t\t<var type="{v}"' + (f' elem_set="{load["var_sets"][v]}"' if v in load["var_sets"] else "") + "/>"
            for v in variables]
    out += ([f"\t\t\t<compression>{compression}</compression>"] if compression else [])
    out += ["\t\t</plotfile>", "\t</Output>", "</febio_spec>", ""]
    return "\n".join(out)


MODELS = {
    "block_hex8": ("hex8", ["displacement", "stress", "Lagrange strain", "strain energy density", "nodal stress"], 0),
    "block_tet10_z": ("tet10", ["displacement", "stress", "Lagrange strain"], 1),
    "block_penta15": ("penta15", ["displacement", "strain energy density"], 0),
    "block_hex8_shell": ("hex8+shell", ["displacement", "strain energy density", "shell thickness"], 0),
    # large deformation: the punch pressed 0.25 mm (25 % of the block) and slid 0.2 mm, 15 % of it at t = 1
    "block_hex8_large": ("hex8", ["displacement", "stress", "Lagrange strain", "strain energy density"], 0,
                         {"press": 0.25, "slide": 0.2, "curve": ((0, 0), (1, 0.15), (2, 1)), "step_size": 1}),
    # strain energy density written for the epidermis only (elem_set=; FEBio 4.11's other way, a list of domain
    # indices in the <var> tag, crashes it unless every domain is listed: WriteDomainDataField loops over all domains)
    "block_hex8_partial": ("hex8", ["displacement", "strain energy density", "stress"], 0,
                           {"var_sets": {"strain energy density": "epidermis"}}),
    # FEBio's other storage formats of domain variables: per domain node (SPR stress, NODE), per domain (total
    # energy, REGION); one step on a 2 x 2 x 4 grid
    "block_hex8_formats": ("hex8", ["displacement", "stress", "strain energy density", "SPR stress", "total energy"], 0,
                           {"grid": (2, 2, 4), "steps": 1, "step_size": 1, "vtk_twin": True}),
    # the other solid elements, one step, small grids (1 x 1 x 4 for the many-node tetrahedra)
    **{f"block_{kind}": (kind, ["displacement", "stress", "strain energy density"], 0,
                         {"grid": grid, "steps": 1, "step_size": 1})
       for kind, grid in (("hex20", (2, 2, 4)), ("hex27", (2, 2, 4)), ("tet15", (1, 1, 4)), ("tet20", (1, 1, 4)),
                          ("pyra13", (2, 2, 4)))},
}


def _reference(xplt: Path) -> None:
    """pyfebio's reading of ``xplt`` as ``<name>.reference.npz`` (skipped when pyfebio is not installed).

    pyfebio 0.3.0 (``pyfebio.xplt.to_hdf5``) names each state's data block after the domain whose
    *part id* equals the block's id, where FEBio numbers the blocks by the domains' order
    (``FEBioPlotFile::WriteDomainDataField``: ``item[i] + 1``); so the blocks are stored here by
    that id (``<var>/<state>/<block id>``), not by pyfebio's domain names.
    """
    try:
        import h5py
        from pyfebio import xplt as pyfebio_xplt
    except ImportError:
        print("pyfebio not installed: no reference values written", file=sys.stderr)
        return
    h5 = xplt.with_suffix(".pyfebio.h5")
    try:
        pyfebio_xplt.to_hdf5(str(xplt), str(h5))
    except KeyError as err:  # pyfebio 0.3.0 wants a name chunk in every domain; FEBio writes none for shells
        print(f"pyfebio cannot read {xplt.name} ({err!r}): no reference values written", file=sys.stderr)
        h5.unlink(missing_ok=True)
        return
    out = {}
    with h5py.File(h5, "r") as f:
        nodes = f["meshes/0/nodes"][()]
        out["nodes"] = np.column_stack([nodes["x"], nodes["y"], nodes["z"]])
        domains = f["meshes/0/domains"]
        for name in domains:
            out[f"domain/{int(domains[name].attrs['id'][0])}"] = domains[name][()]
        for k in range(len(f["states"])):
            state = f[f"states/{k}"]
            out[f"time/{k}"] = state.attrs["time"]
            for var, groups in state["element_data"].items():
                for group, values in groups.items():
                    out[f"elem:{var}/{k}/{int(domains[group].attrs['id'][0])}"] = values[()]
            for var, groups in state["node_data"].items():
                out[f"node:{var}/{k}"] = groups["all"][()]
    h5.unlink()
    np.savez_compressed(xplt.with_suffix(".reference.npz"), **out)


def _run(febio: str, name: str, text: str) -> Path:
    """Write ``<name>.feb``, run FEBio on it, delete its log: the ``.xplt`` path."""
    (HERE / f"{name}.feb").write_text(text)
    subprocess.run([febio, "-i", f"{name}.feb", "-silent"], cwd=HERE, check=True)
    (HERE / f"{name}.log").unlink(missing_ok=True)
    return HERE / f"{name}.xplt"


def _vtk_twin(febio: str, name: str, text: str) -> None:
    """Add to ``<name>.reference.npz`` what FEBio's own VTK output of the same run holds at the nodes
    (``vtk:<variable>/<state>``, 3 x 3 tensors as xx yy zz xy yz xz): for domain variables per domain node
    (NODE), FEBio's ``VTKPlotFile`` writes each domain's values over the nodes, the last domain's where they
    are shared - an independent check of how a domain's node list maps to the mesh's nodes."""
    import meshio

    twin = f"{name}_vtk"
    _run(febio, twin, text.replace('<plotfile type="febio">', '<plotfile type="vtk">'))
    out = dict(np.load(HERE / f"{name}.reference.npz"))
    for k, path in enumerate(sorted(HERE.glob(f"{twin}.*.vtk"), key=lambda f: int(f.suffixes[-2][1:]))):
        for var, values in meshio.read(path).point_data.items():
            if values.ndim == 3:
                values = values[:, [0, 1, 2, 0, 1, 0], [0, 1, 2, 1, 2, 2]]
            out[f"vtk:{var.replace('_', ' ')}/{k}"] = values
        path.unlink()
    (HERE / f"{twin}.feb").unlink()
    np.savez_compressed(HERE / f"{name}.reference.npz", **out)


def main(names: list[str]) -> None:
    """Regenerate the models ``names`` (all when empty)."""
    febio = os.environ.get("FEBIO", "febio4")
    for name, (kind, variables, compression, *load) in MODELS.items():
        if names and name not in names:
            continue
        xplt = _run(febio, name, _feb(kind, variables, compression, *load))
        if compression:  # pyfebio reads no compressed states: its reference is the same run written plain
            twin = _run(febio, f"{name}_plain", _feb(kind, variables, 0, *load))
            _reference(twin)
            twin.with_suffix(".reference.npz").replace(xplt.with_suffix(".reference.npz"))
            for leftover in (twin, twin.with_suffix(".feb")):
                leftover.unlink()
        else:
            _reference(xplt)
        if load and load[0].get("vtk_twin") and xplt.with_suffix(".reference.npz").is_file():
            _vtk_twin(febio, name, _feb(kind, variables, compression, *load))
        print(name, xplt.stat().st_size, "bytes")


if __name__ == "__main__":
    main(sys.argv[1:])
