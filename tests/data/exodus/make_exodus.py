"""Solve a small two-layer skin block with SfePy and write it as Exodus II files.

Regenerate (SfePy, netCDF4 and VTK from PyPI, in their own environment)::

    python3.11 -m venv /work/venvs/exodus
    /work/venvs/exodus/bin/pip install sfepy==2026.3 netCDF4 meshio   # vtk 9.7.2 comes with sfepy
    /work/venvs/exodus/bin/python tests/data/exodus/make_exodus.py

The model, in mm / N / s (stress and SED in MPa): a 2 x 2 x 1 mm block (gen_block_mesh, 4 x 4 x 3
hexahedra, 100 nodes): the top layer of elements (z > 2/3 mm, 16 cells) is the epidermis
(E = 0.5 MPa), the two below (32 cells) the dermis (E = 0.1 MPa), both nu = 0.45
(stiffness_from_youngpoisson); the bottom face is fixed and the central 1 x 1 mm patch of the top
face moved by (0, 0, -d) mm, d = 0.025, 0.05, 0.075, 0.1 mm at t = 0.25, 0.5, 0.75, 1 s (one
linear solve per step).

Files:

- ``layers_ioss.e``: every step in one file, written by VTK's ``vtkIOSSWriter`` (SEACAS's IOSS
  and Exodus libraries, as bundled in VTK 9.7.2) from SfePy's results: netCDF-3 (64-bit offset),
  two HEX8 element blocks named ``dermis`` (id 1) and ``epidermis`` (id 2) sharing the interface
  nodes (global node ids), nodal ``displacement_x/y/z`` (SfePy's solution), element variables
  ``stress_xx .. stress_xz`` (SfePy's ``ev_cauchy_stress``, ``mode='el_avg'``, reordered from its
  11 22 33 12 13 23 to xx yy zz xy yz xz), ``strain_xx .. strain_xz`` (``ev_cauchy_strain``, its
  doubled shear halved: **tensor** shear, as MOOSE writes it) and ``sed`` (SfePy's own element
  average: 1/2 of ``dw_lin_elastic(m.D, u, u)`` over ``ev_volume``). SfePy's own Exodus output
  (below) cannot hold several steps, element variables or two blocks of one cell type: that is
  why the solution goes through VTK's Exodus writer here.
- ``layers_sfepy.e``: the last step as SfePy writes Exodus itself (``pb.save_state`` -> meshio
  5.3.5's Exodus writer -> netCDF4): netCDF-4 (HDF5), one HEX8 block, the nodal vector ``u`` as
  one (time, node, 3) variable, SfePy's node groups ``exodus:ref``, meshio's dummy time 0 (float32),
  no element variable (meshio's writer drops cell data).
- ``hex20_ioss.e``: 2 x 2 x 2 straight-edged HEX20 over the block (its centre corner node moved),
  written from VTK quadratic hexahedra by vtkIOSSWriter (which puts them in Exodus's node order),
  with the last step's displacement and nodal SED evaluated at its nodes by SfePy (``evaluate_at``).
- ``plate_ioss.e``: a 2-D plane-strain version (a 2 x 1 mm section, 8 x 3 QUAD4, y up, the top
  third epidermis, d = 0.05 and 0.1 mm at t = 0.5, 1 s) through vtkIOSSWriter: no volume elements.
"""

from pathlib import Path

import numpy as np
import vtk
from sfepy.base.base import Struct
from sfepy.discrete import Equation, Equations, FieldVariable, Integral, Material, Problem
from sfepy.discrete.conditions import Conditions, EssentialBC
from sfepy.discrete.fem import FEDomain, Field
from sfepy.mechanics.matcoefs import stiffness_from_youngpoisson
from sfepy.mesh.mesh_generators import gen_block_mesh
from sfepy.solvers.ls import ScipyDirect
from sfepy.solvers.nls import Newton
from sfepy.terms import Term
from vtkmodules.util import numpy_support as ns
from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
from vtkmodules.vtkIOIOSS import vtkIOSSWriter

HERE = Path(__file__).resolve().parent
E_EPIDERMIS, E_DERMIS, NU = 0.5, 0.1, 0.45
DEPTHS, TIMES = (0.025, 0.05, 0.075, 0.1), (0.25, 0.5, 0.75, 1.0)
SFEPY_ORDER = (0, 1, 2, 3, 5, 4)  # SfePy 11 22 33 12 13 23 -> xx yy zz xy yz xz
COMPONENTS = ("xx", "yy", "zz", "xy", "yz", "xz")
SDDP = vtk.vtkStreamingDemandDrivenPipeline


def problem(dim):
    """The two-layer block (3-D) or its x-z section (2-D): Problem, regions by layer, the push patch."""
    if dim == 3:
        mesh = gen_block_mesh([2.0, 2.0, 1.0], [5, 5, 4], [1.0, 1.0, 0.5], name="block", verbose=False)
        top, patch = "z", "vertices in (z > 0.999) & (x > 0.499) & (x < 1.501) & (y > 0.499) & (y < 1.501)"
    else:
        mesh = gen_block_mesh([2.0, 1.0], [9, 4], [1.0, 0.5], name="plate", verbose=False)
        top, patch = "y", "vertices in (y > 0.999) & (x > 0.499) & (x < 1.501)"
    centres = mesh.coors[mesh.get_conn(mesh.descs[0])].mean(1)
    mesh.cmesh.cell_groups[:] = np.where(centres[:, dim - 1] > 2.0 / 3.0, 2, 1)  # 2 epidermis, 1 dermis
    domain = FEDomain("domain", mesh)
    omega = domain.create_region("Omega", "all")
    regions = {g: domain.create_region(name, f"cells of group {g}") for g, name in ((1, "Dermis"), (2, "Epidermis"))}
    bottom = domain.create_region("Bottom", f"vertices in ({top} < 0.001)", "facet")
    push = domain.create_region("Patch", patch, "facet")
    field = Field.from_args("fu", np.float64, "vector", omega, approx_order=1)
    u = FieldVariable("u", "unknown", field)
    v = FieldVariable("v", "test", field, primary_var_name="u")
    mats = {1: Material("m1", D=stiffness_from_youngpoisson(dim, E_DERMIS, NU)),
            2: Material("m2", D=stiffness_from_youngpoisson(dim, E_EPIDERMIS, NU))}
    integral = Integral("i", order=2)
    terms = [Term.new(f"dw_lin_elastic(m{g}.D, v, u)", integral, regions[g], **{f"m{g}": mats[g]}, v=v, u=u)
             for g in (1, 2)]
    pb = Problem("indentation", equations=Equations([Equation("balance", sum(terms[1:], terms[0]))]))
    pb.set_solver(Newton({}, lin_solver=ScipyDirect({})))
    return pb, mesh, regions, bottom, push


def solve(pb, bottom, push, dim, depth):
    """One linear solve with the patch pushed by ``depth`` mm; the state."""
    fixed = {f"u.{i}": 0.0 for i in range(dim - 1)}
    pb.set_bcs(ebcs=Conditions([EssentialBC("fix", bottom, {"u.all": 0.0}),
                                EssentialBC("push", push, {**fixed, f"u.{dim - 1}": -depth})]))
    return pb.solve(save_results=False)


def nodal_sed(pb, regions, n_cells):
    """SfePy's L2 projection (make_l2_projection_data) of 1/2 sigma:eps at the quadrature points
    (order 2; SfePy's engineering strain vector, so sigma . eps = sigma:eps) onto the P1 nodal field."""
    from sfepy.discrete.projections import make_l2_projection_data

    qp = None
    for g, reg in regions.items():
        s = pb.evaluate(f"ev_cauchy_stress.2.{reg.name}(m{g}.D, u)", mode="qp", copy_materials=False)
        e = pb.evaluate(f"ev_cauchy_strain.2.{reg.name}(u)", mode="qp")
        if qp is None:
            qp = np.zeros((n_cells, s.shape[1], 1, 1))
        qp[reg.cells] = 0.5 * (s * e).sum(axis=2, keepdims=True)
    omega = pb.domain.regions["Omega"]
    target = FieldVariable("sed_nodal", "parameter", Field.from_args("fs", np.float64, 1, omega, approx_order=1),
                           primary_var_name="(set-to-None)")
    make_l2_projection_data(target, qp, order=2)
    return target


def element_results(pb, regions, n_cells):
    """stress, strain (tensor shear) and SfePy's element SED, (n_cells, 6/3) and (n_cells,), in cell order."""
    ncomp = 6 if pb.domain.mesh.dim == 3 else 3
    stress, strain, sed = np.zeros((n_cells, ncomp)), np.zeros((n_cells, ncomp)), np.zeros(n_cells)
    for g, reg in regions.items():
        name = reg.name
        cells = reg.cells
        strain[cells] = pb.evaluate(f"ev_cauchy_strain.2.{name}(u)", mode="el_avg")[:, 0, :, 0]
        stress[cells] = pb.evaluate(f"ev_cauchy_stress.2.{name}(m{g}.D, u)", mode="el_avg",
                                    copy_materials=False)[:, 0, :, 0]
        energy = pb.evaluate(f"dw_lin_elastic.2.{name}(m{g}.D, u, u)", mode="el_eval", copy_materials=False)
        sed[cells] = 0.5 * energy.ravel() / pb.evaluate(f"ev_volume.2.{name}(u)", mode="el_eval").ravel()
    shear = slice(3, None) if ncomp == 6 else slice(2, None)
    strain[:, shear] /= 2  # SfePy's engineering shear -> tensor shear
    if ncomp == 6:
        stress, strain = stress[:, SFEPY_ORDER], strain[:, SFEPY_ORDER]
    return stress, strain, sed


class _Steps(VTKPythonAlgorithmBase):
    """A VTK source of one vtkPartitionedDataSetCollection per time step (what vtkIOSSWriter writes)."""

    def __init__(self, collections, times):
        super().__init__(nInputPorts=0, nOutputPorts=1, outputType="vtkPartitionedDataSetCollection")
        self.collections, self.times = collections, list(times)

    def RequestInformation(self, request, in_info, out_info):
        info = out_info.GetInformationObject(0)
        info.Set(SDDP.TIME_STEPS(), self.times, len(self.times))
        info.Set(SDDP.TIME_RANGE(), [self.times[0], self.times[-1]], 2)
        return 1

    def RequestData(self, request, in_info, out_info):
        info = out_info.GetInformationObject(0)
        t = info.Get(SDDP.UPDATE_TIME_STEP()) if info.Has(SDDP.UPDATE_TIME_STEP()) else self.times[0]
        k = int(np.argmin(np.abs(np.asarray(self.times) - t)))
        out = vtk.vtkPartitionedDataSetCollection.GetData(out_info)
        out.ShallowCopy(self.collections[k])
        out.GetInformation().Set(vtk.vtkDataObject.DATA_TIME_STEP(), self.times[k])
        return 1


def _array(values, name, ids=False):
    a = ns.numpy_to_vtkIdTypeArray(np.ascontiguousarray(values, dtype=np.int64), deep=True) if ids else \
        ns.numpy_to_vtk(np.ascontiguousarray(values, dtype=float), deep=True)
    a.SetName(name)
    return a


def collection(mesh, groups, nodal, cell_data):
    """The blocks (dermis id 1, epidermis id 2) of one step with global node / element ids (1-based)."""
    coors = np.column_stack([mesh.coors, np.zeros((mesh.n_nod, 3 - mesh.dim))])
    conn = mesh.get_conn(mesh.descs[0])
    vtk_type = vtk.VTK_HEXAHEDRON if conn.shape[1] == 8 else vtk.VTK_QUAD
    pdc = vtk.vtkPartitionedDataSetCollection()
    for j, (g, name) in enumerate(((1, "dermis"), (2, "epidermis"))):
        cells = np.flatnonzero(groups == g)
        used = np.unique(conn[cells])
        grid = vtk.vtkUnstructuredGrid()
        points = vtk.vtkPoints()
        points.SetData(ns.numpy_to_vtk(coors[used], deep=True))
        grid.SetPoints(points)
        for c in np.searchsorted(used, conn[cells]):
            grid.InsertNextCell(vtk_type, len(c), [int(i) for i in c])
        for key, values in nodal.items():
            grid.GetPointData().AddArray(_array(values[used], key))
        grid.GetPointData().SetGlobalIds(_array(used + 1, "node_ids", ids=True))
        for key, values in cell_data.items():
            grid.GetCellData().AddArray(_array(values[cells], key))
        grid.GetCellData().SetGlobalIds(_array(cells + 1, "element_ids", ids=True))
        part = vtk.vtkPartitionedDataSet()
        part.SetPartition(0, grid)
        pdc.SetPartitionedDataSet(j, part)
        pdc.GetMetaData(j).Set(vtk.vtkCompositeDataSet.NAME(), name)
    return pdc


def write_ioss(path, collections, times):
    """Every step into one Exodus file through vtkIOSSWriter (written to a temporary name, then renamed)."""
    tmp = path.with_name(path.stem + ".tmp.e")
    writer = vtkIOSSWriter()
    writer.SetFileName(str(tmp))
    source = _Steps(collections, times)  # kept referenced while the writer runs
    writer.SetInputConnection(source.GetOutputPort())
    writer.Write()
    tmp.replace(path)


HEX20_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))


def hex20_mesh():
    """2 x 2 x 2 HEX20 over the block, its centre corner node moved to (1.1, 0.93, 0.56) mm: straight
    edges (mid-nodes at their midpoints), faces not parallel. Points, connectivity in VTK order."""
    grid = np.array([[x, y, z] for z in (0, 0.5, 1) for y in (0, 1, 2) for x in (0, 1, 2)], float)
    grid[13] = (1.1, 0.93, 0.56)
    index = {}

    def node(a, b):  # the mid-node of corner a and corner b, shared by the cells on that edge
        key = (min(a, b), max(a, b))
        if key not in index:
            index[key] = len(grid) + len(index)
        return index[key]

    cells = []
    for k in range(2):
        for j in range(2):
            for i in range(2):
                o = i + 3 * j + 9 * k
                corners = [o, o + 1, o + 4, o + 3, o + 9, o + 10, o + 13, o + 12]
                cells.append(corners + [node(corners[a], corners[b]) for a, b in HEX20_EDGES])
    mids = np.array([(grid[a] + grid[b]) / 2 for a, b in sorted(index, key=index.get)])
    return np.vstack([grid, mids]), np.array(cells)


def write_hex20(path, u, sed):
    """SfePy's last-step displacement and nodal SED (evaluate_at) on the HEX20 mesh, through vtkIOSSWriter."""
    points, conn = hex20_mesh()
    grid = vtk.vtkUnstructuredGrid()
    vtk_points = vtk.vtkPoints()
    vtk_points.SetData(ns.numpy_to_vtk(points, deep=True))
    grid.SetPoints(vtk_points)
    for c in conn:
        grid.InsertNextCell(vtk.VTK_QUADRATIC_HEXAHEDRON, 20, [int(i) for i in c])
    values = u.evaluate_at(points)
    for i, a in enumerate("xyz"):
        grid.GetPointData().AddArray(_array(values[:, i], f"displacement_{a}"))
    grid.GetPointData().AddArray(_array(sed.evaluate_at(points)[:, 0], "sed"))
    part = vtk.vtkPartitionedDataSet()
    part.SetPartition(0, grid)
    pdc = vtk.vtkPartitionedDataSetCollection()
    pdc.SetPartitionedDataSet(0, part)
    write_ioss(path, [pdc], [1.0])


def run(dim, depths, times, path, sfepy_path=None):
    pb, mesh, regions, bottom, push = problem(dim)
    groups = mesh.cmesh.cell_groups.copy()
    names = COMPONENTS if dim == 3 else ("xx", "yy", "xy")
    axes = "xyz"[:dim]
    steps = []
    for depth in depths:
        state = solve(pb, bottom, push, dim, depth)
        u = state.get_state_parts()["u"].reshape(-1, dim)
        stress, strain, sed = element_results(pb, regions, mesh.n_el)
        projected = nodal_sed(pb, regions, mesh.n_el)
        nodal = {**{f"displacement_{a}": u[:, i] for i, a in enumerate(axes)}, "sed": projected()}
        cell_data = {**{f"stress_{c}": stress[:, i] for i, c in enumerate(names)},
                     **{f"strain_{c}": strain[:, i] for i, c in enumerate(names)}, "sed": sed}
        steps.append(collection(mesh, groups, nodal, cell_data))
    write_ioss(path, steps, times)
    if sfepy_path is not None:  # the last step as SfePy writes Exodus itself
        out = state.create_output()
        out["sed"] = Struct(name="output_data", mode="cell", data=sed[:, None, None, None])
        pb.save_state(str(sfepy_path), out=out)
        write_hex20(HERE / "hex20_ioss.e", state["u"], projected)
    print("written", path.name, mesh.n_nod, "nodes", mesh.n_el, "cells", len(depths), "steps")


if __name__ == "__main__":
    run(3, DEPTHS, TIMES, HERE / "layers_ioss.e", HERE / "layers_sfepy.e")
    run(2, DEPTHS[1::2], TIMES[1::2], HERE / "plate_ioss.e")
