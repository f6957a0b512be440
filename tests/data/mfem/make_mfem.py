"""Two-layer skin block solved and exported by MFEM itself (PyMFEM), for afferent's tests.

Run with PyMFEM 4.10 (``pip install mfem==4.10.0.1``, serial ``mfem.ser``), from this folder:

    python make_mfem.py

A 2 x 2 x 1 mm block (mm, N, MPa) of 4 x 4 x 5 hexahedra: dermis (attribute 1, E = 0.08 MPa)
below z = 0.8 mm, epidermis (attribute 2, E = 0.136 MPa) above, Poisson's ratio 0.45; the bottom
face (boundary attribute 1) fixed, the top face (6) pressed by a Gaussian pressure centred on
(1, 1) (peak 0.004, 0.008, 0.012 MPa in three load steps). Linear elasticity
(ElasticityIntegrator), order-2 H1 displacement, as in MFEM's example 2. MFEM has no stress
output of its own: SED = 1/2 sigma:eps (MPa = mJ/mm^3) is computed from the displacement's
gradient (GridFunction.GetVectorGradient) at the nodes of an order-2 L2 (discontinuous) space,
one value per element node, as MFEM users project derived fields.

Writes (ParaViewDataCollection, BINARY32 (Float32), zlib compression):
  block/block.pvd, block/Cycle00000{1,2,3}/proc000000.vtu
            three load steps (time 1, 2, 3), SetHighOrderOutput(True), SetLevelsOfDetail(2):
            VTK Lagrange hexahedra of degree 2; fields displacement, sed, attribute (MFEM writes
            the element attribute itself)
  linear/linear.pvd, linear/Cycle000003/proc000000.vtu
            last step, SetHighOrderOutput(False), SetLevelsOfDetail(2): each hexahedron split
            into 2 x 2 x 2 linear hexahedra
  order3/order3.pvd, order3/Cycle000003/proc000000.vtu
            last step, SetHighOrderOutput(True), SetLevelsOfDetail(3): Lagrange hexahedra of
            degree 3 (what a user of order-3 elements writes)
  notime/notime.pvd, notime/Cycle00000{0,1}/proc000000.vtu
            last step saved twice with SetCycle but no SetTime, SetLevelsOfDetail(1) and
            SetHighOrderOutput(False) (MFEM's defaults): linear hexahedra, corner values
  reference.csv
            MFEM's own evaluation (Mesh.FindPoints, GridFunction.GetValue) of sed and the
            displacement at five points (mm) for every load step
"""

import os
import shutil

import mfem.ser as mfem
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
NU, YOUNG = 0.45, {1: 0.08, 2: 0.136}
PEAKS = (0.004, 0.008, 0.012)
POINTS = [(0.95, 1.05, 0.9), (0.7, 1.2, 0.95), (1.3, 0.6, 0.5), (0.6, 0.55, 0.85), (1.1, 1.4, 0.3)]

mesh = mfem.Mesh.MakeCartesian3D(4, 4, 5, mfem.Element.HEXAHEDRON, 2.0, 2.0, 1.0)
for e in range(mesh.GetNE()):
    centre = np.mean([mesh.GetVertexArray(v) for v in mesh.GetElementVertices(e)], axis=0)
    mesh.SetAttribute(e, 2 if centre[2] > 0.8 else 1)
mesh.SetAttributes()

space = mfem.FiniteElementSpace(mesh, mfem.H1_FECollection(2, 3), 3)
sed_space = mfem.FiniteElementSpace(mesh, mfem.L2_FECollection(2, 3))
lam = mfem.Vector([YOUNG[a] * NU / ((1 + NU) * (1 - 2 * NU)) for a in (1, 2)])
mu = mfem.Vector([YOUNG[a] / (2 * (1 + NU)) for a in (1, 2)])
lam_c, mu_c = mfem.PWConstCoefficient(lam), mfem.PWConstCoefficient(mu)
a = mfem.BilinearForm(space)
a.AddDomainIntegrator(mfem.ElasticityIntegrator(lam_c, mu_c))
a.Assemble()
fixed = mfem.intArray([1, 0, 0, 0, 0, 0])
tdofs = mfem.intArray()
space.GetEssentialTrueDofs(fixed, tdofs)
top = mfem.intArray([0, 0, 0, 0, 0, 1])
u = mfem.GridFunction(space)
sed = mfem.GridFunction(sed_space)


class Traction(mfem.VectorPyCoefficient):
    def __init__(self, peak):
        mfem.VectorPyCoefficient.__init__(self, 3)
        self.peak = peak

    def EvalValue(self, x):
        return (0.0, 0.0, -self.peak * np.exp(-((x[0] - 1) ** 2 + (x[1] - 1) ** 2) / 0.3))


def solve(peak):
    traction = Traction(peak)
    b = mfem.LinearForm(space)
    b.AddBoundaryIntegrator(mfem.VectorBoundaryLFIntegrator(traction), top)
    b.Assemble()
    u.Assign(0.0)
    A, X, B = mfem.SparseMatrix(), mfem.Vector(), mfem.Vector()
    a.FormLinearSystem(tdofs, u, b, A, X, B)
    mfem.PCG(A, mfem.GSSmoother(A), B, X, 0, 4000, 1e-24, 0.0)
    a.RecoverFEMSolution(X, b, u)


def project_sed():
    """1/2 sigma:eps at every node of each element's L2 space, from MFEM's gradient of u."""
    grad = mfem.DenseMatrix(3, 3)
    for e in range(mesh.GetNE()):
        T = mesh.GetElementTransformation(e)
        nodes = sed_space.GetFE(e).GetNodes()
        dofs = sed_space.GetElementDofs(e)
        m = mesh.GetAttribute(e)
        for k in range(nodes.GetNPoints()):
            ip = nodes.IntPoint(k)
            T.SetIntPoint(ip)
            u.GetVectorGradient(T, grad)
            g = grad.GetDataArray().copy()
            eps = 0.5 * (g + g.T)
            sig = 2 * mu[m - 1] * eps + lam[m - 1] * np.trace(eps) * np.eye(3)
            sed[dofs[k]] = 0.5 * np.sum(sig * eps)


def collection(name, high_order, lod):
    shutil.rmtree(os.path.join(HERE, name), ignore_errors=True)
    dc = mfem.ParaViewDataCollection(name, mesh)
    dc.SetPrefixPath(HERE)
    dc.SetHighOrderOutput(high_order)
    dc.SetLevelsOfDetail(lod)
    dc.SetDataFormat(mfem.VTKFormat_BINARY32)
    dc.SetCompression(True)
    dc.RegisterField("displacement", u)
    dc.RegisterField("sed", sed)
    return dc


def save(dc, step):
    dc.SetCycle(step)
    dc.SetTime(float(step))
    dc.Save()


def reference(step):
    count, elems, ips = mesh.FindPoints(np.array(POINTS))
    assert count == len(POINTS)
    rows = []
    for k, p in enumerate(POINTS):
        val = mfem.Vector(3)
        u.GetVectorValue(elems[k], ips[k], val)
        rows.append([step, *p, sed.GetValue(elems[k], ips[k]), *val.GetDataArray()])
    return rows


series = collection("block", True, 2)
rows = []
for step, peak in enumerate(PEAKS, start=1):
    solve(peak)
    project_sed()
    save(series, step)
    rows += reference(step)
save(collection("linear", False, 2), 3)
untimed = collection("notime", False, 1)  # MFEM's defaults, and no SetTime: timestep="0" at every step
for cycle in range(2):
    untimed.SetCycle(cycle)
    untimed.Save()
save(collection("order3", True, 3), 3)
np.savetxt(os.path.join(HERE, "reference.csv"), np.array(rows), delimiter=",", fmt="%.10g",
           header="step,x,y,z,sed,ux,uy,uz", comments="")
print(mesh.GetNE(), "hexahedra;", space.GetTrueVSize(), "displacement dofs")
