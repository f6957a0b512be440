"""Two-layer skin block solved and exported by NGSolve itself (VTKOutput), for afferent's tests.

Run with NGSolve 6.2.2608 (``pip install ngsolve==6.2.2608``), from this folder:

    python make_ngsolve.py

A 2 x 2 x 1 mm block (mm, N, MPa): dermis (E = 0.08 MPa) below z = 0.8 mm, epidermis
(E = 0.136 MPa) above, Poisson's ratio 0.45; the bottom face fixed, the top face pressed by a
Gaussian pressure centred on (1, 1) (peak 0.004, 0.008, 0.012 MPa in three load steps). Linear
elasticity, P2 displacement on the tetrahedra of Netgen's OCC mesher. SED = 1/2 sigma:eps
(MPa = mJ/mm^3) is a CoefficientFunction written beside the stress and strain tensors.

Writes (VTKOutput, floatsize="single", raw binary appended data):
  block.vtu, block_step0000{1,2}.vtu, block.pvd
                     three load steps (times 1, 2, 3), order 1, subdivision 0: sed, material_id (mesh.MaterialCF: 1 dermis, 2 epidermis)
  block_tensors.vtu  last step, order 1: sed, stress, strain (3 x 3, 9 components)
  block_order2.vtu   last step, order=2 (quadratic cells): sed, material_id
  block_sub1.vtu     last step, subdivision=1 (each tetrahedron cut into 1 wedge and 5 tetrahedra,
                     a block of each per element): sed
  block_order3.vtu   last step, order=3 (VTK Lagrange tetrahedra of degree 3), one element
                     (only_element=0): sed
  notime.pvd, notime.vtu, notime_step00001.vtu
                     Do() twice without a time (the last load both times): sed
  plane_2d.vtu       the two layers as a 2-D plane-strain section (2 x 1 mm, 80 triangles), last
                     load: sed
  reference.csv      NGSolve's own mesh(x, y, z) evaluation of sed, u and sigma at five points
                     (mm) for every load step
"""

import os

import numpy as np
from netgen.occ import Box, Glue, OCCGeometry, Pnt, Z
from ngsolve import (
    BilinearForm, Grad, GridFunction, Id, InnerProduct, LinearForm, Mesh, TaskManager, Trace,
    VTKOutput, VectorH1, ds, dx, exp, ngsglobals, specialcf, x, y,
)

ngsglobals.msg_level = 0
HERE = os.path.dirname(os.path.abspath(__file__))

dermis = Box(Pnt(0, 0, 0), Pnt(2, 2, 0.8))
dermis.mat("dermis")
epidermis = Box(Pnt(0, 0, 0.8), Pnt(2, 2, 1.0))
epidermis.mat("epidermis")
shape = Glue([dermis, epidermis])
shape.faces.Min(Z).name = "bottom"
shape.faces.Max(Z).name = "top"
mesh = Mesh(OCCGeometry(shape).GenerateMesh(maxh=0.6))

nu = 0.45
young = mesh.MaterialCF({"dermis": 0.08, "epidermis": 0.136})
mu = young / (2 * (1 + nu))
lam = young * nu / ((1 + nu) * (1 - 2 * nu))

space = VectorH1(mesh, order=2, dirichlet="bottom")
u, v = space.TnT()


def strain(w):
    return 0.5 * (Grad(w) + Grad(w).trans)


def stress(eps):
    return 2 * mu * eps + lam * Trace(eps) * Id(3)


a = BilinearForm(InnerProduct(stress(strain(u)), strain(v)) * dx).Assemble()
inv = a.mat.Inverse(space.FreeDofs(), inverse="sparsecholesky")
gfu = GridFunction(space)
eps = strain(gfu)
sig = stress(eps)
sed = 0.5 * InnerProduct(sig, eps)
material = mesh.MaterialCF({"dermis": 1, "epidermis": 2})  # the regions, as point data constant per cell
fields = {"displacement": gfu, "sed": sed, "stress": sig, "strain": eps, "material_id": material}


def vtk(name, keys, **kwargs):
    return VTKOutput(mesh, coefs=[fields[k] for k in keys], names=list(keys),
                     filename=os.path.join(HERE, name), floatsize="single", **kwargs)


normal = specialcf.normal(3)
peaks = (0.004, 0.008, 0.012)
points = [(0.95, 1.05, 0.9), (0.7, 1.2, 0.95), (1.3, 0.6, 0.5), (0.6, 0.55, 0.85), (1.1, 1.4, 0.3)]
series = vtk("block", ("sed", "material_id"))
rows = []
with TaskManager():
    for step, peak in enumerate(peaks, start=1):
        pressure = peak * exp(-((x - 1) ** 2 + (y - 1) ** 2) / 0.3)
        f = LinearForm(-pressure * normal * v * ds("top")).Assemble()
        gfu.vec.data = inv * f.vec
        series.Do(time=float(step))
        for px, py, pz in points:
            mp = mesh(px, py, pz)
            s = np.array(sig(mp)).ravel()
            rows.append([step, px, py, pz, sed(mp), *gfu(mp), s[0], s[4], s[8], s[1], s[5], s[2]])
    vtk("block_tensors", ("sed", "stress", "strain")).Do()
    counted = vtk("notime", ("sed",))  # Do() without a time: the .pvd states the step counter 0, 1
    for _ in range(2):
        counted.Do()
    vtk("block_order2", ("sed", "material_id"), order=2).Do()
    vtk("block_sub1", ("sed",), subdivision=1).Do()
    vtk("block_order3", ("sed",), order=3, only_element=0).Do()  # one cell: enough to be refused



def plane_strain():
    """The same two layers as a 2-D plane-strain section (x across, y up, mm): what a 2-D model writes."""
    from ngsolve import IfPos
    from ngsolve.meshes import MakeStructured2DMesh

    m2 = MakeStructured2DMesh(quads=False, nx=8, ny=5, mapping=lambda px, py: (2 * px, py))
    e2 = IfPos(y - 0.8, 0.136, 0.08)
    mu2, lam2 = e2 / (2 * (1 + nu)), e2 * nu / ((1 + nu) * (1 - 2 * nu))
    fes = VectorH1(m2, order=2, dirichlet="bottom")
    w, q = fes.TnT()
    eps2 = 0.5 * (Grad(w) + Grad(w).trans)
    sig2 = 2 * mu2 * eps2 + lam2 * Trace(eps2) * Id(2)
    a2 = BilinearForm(InnerProduct(sig2, 0.5 * (Grad(q) + Grad(q).trans)) * dx).Assemble()
    f2 = LinearForm(-0.012 * exp(-((x - 1) ** 2) / 0.3) * specialcf.normal(2) * q * ds("top")).Assemble()
    g = GridFunction(fes)
    g.vec.data = a2.mat.Inverse(fes.FreeDofs()) * f2.vec
    e = 0.5 * (Grad(g) + Grad(g).trans)
    s2 = 2 * mu2 * e + lam2 * Trace(e) * Id(2)
    VTKOutput(m2, coefs=[0.5 * InnerProduct(s2, e)], names=["sed"], filename=os.path.join(HERE, "plane_2d"),
              floatsize="single").Do()


plane_strain()
header = "step,x,y,z,sed,ux,uy,uz,sxx,syy,szz,sxy,syz,sxz"
np.savetxt(os.path.join(HERE, "reference.csv"), np.array(rows), delimiter=",", header=header,
           comments="", fmt="%.10g")
print(mesh.ne, "tetrahedra,", mesh.nv, "vertices")
