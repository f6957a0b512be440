"""Solve a small indentation of a skin-like block with DOLFINx and write it as XDMF.

Regenerate (DOLFINx 0.5.2, Debian package python3-dolfinx, run with the system Python)::

    /usr/bin/python3 tests/data/dolfinx/make_dolfinx.py

The model, in mm / N / s (stress and SED in MPa): a 2 x 2 x 1 mm block of 4 x 4 x 2 hexahedra
(Q1), bottom face fixed, the nodes of the central 1 x 1 mm patch of the top face moved by
(0, 0, -d) with d = 1/3, 2/3 and 3/3 of 0.1 mm (three linear solves, written at t = 1, 2, 3),
linear elastic E = 0.1 MPa, nu = 0.45, eps = sym(grad(u)) (tensor shear).

Written with ``XDMFFile.write_mesh`` once and ``XDMFFile.write_function`` per function and
step (one grid per function and time: what meshio's XDMF reader refuses):

- ``block.xdmf`` / ``block.h5``: displacement ``u`` (P1 vector, point data), ``stress`` and
  ``strain`` (DG0 3x3 tensors, cell data), ``sed`` (DG0, 1/2 sigma:eps per cell) and
  ``sed_nodal`` (P1, the L2 projection of the same SED onto the nodes);
- ``sed_only.xdmf`` / ``.h5``: ``sed`` (DG0) alone, one step.
"""

from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem, io, mesh
from dolfinx.fem.petsc import LinearProblem
from mpi4py import MPI
from petsc4py import PETSc

HERE = Path(__file__).resolve().parent
E, NU, DEPTH = 0.1, 0.45, 0.1
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))

domain = mesh.create_box(MPI.COMM_WORLD, [np.array([0.0, 0.0, 0.0]), np.array([2.0, 2.0, 1.0])], [4, 4, 2],
                         cell_type=mesh.CellType.hexahedron)
V = fem.VectorFunctionSpace(domain, ("CG", 1))
T = fem.TensorFunctionSpace(domain, ("DG", 0))
S0 = fem.FunctionSpace(domain, ("DG", 0))
S1 = fem.FunctionSpace(domain, ("CG", 1))


def bottom(x):
    return np.isclose(x[2], 0.0)


def patch(x):
    return np.isclose(x[2], 1.0) & (np.abs(x[0] - 1.0) <= 0.5 + 1e-9) & (np.abs(x[1] - 1.0) <= 0.5 + 1e-9)


def eps(w):
    return ufl.sym(ufl.grad(w))


def sigma(w):
    return 2 * MU * eps(w) + LAM * ufl.tr(eps(w)) * ufl.Identity(3)


u_tr, v = ufl.TrialFunction(V), ufl.TestFunction(V)
a = ufl.inner(sigma(u_tr), eps(v)) * ufl.dx
zero = fem.Constant(domain, PETSc.ScalarType((0.0, 0.0, 0.0)))
L = ufl.dot(zero, v) * ufl.dx
fixed = fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), fem.locate_dofs_geometrical(V, bottom), V)
pushed = fem.Function(V)
patch_dofs = fem.locate_dofs_geometrical(V, patch)

u = fem.Function(V, name="u")
stress, strain = fem.Function(T, name="stress"), fem.Function(T, name="strain")
sed, sed_nodal = fem.Function(S0, name="sed"), fem.Function(S1, name="sed_nodal")

with io.XDMFFile(MPI.COMM_WORLD, HERE / "block.xdmf", "w") as xdmf:
    xdmf.write_mesh(domain)
    for k in (1, 2, 3):
        d = DEPTH * k / 3
        pushed.interpolate(lambda x: np.vstack([np.zeros(x.shape[1]), np.zeros(x.shape[1]), np.full(x.shape[1], -d)]))
        bcs = [fixed, fem.dirichletbc(pushed, patch_dofs)]
        problem = LinearProblem(a, L, bcs=bcs, u=u, petsc_options={"ksp_type": "preonly", "pc_type": "lu"})
        problem.solve()
        stress.interpolate(fem.Expression(sigma(u), T.element.interpolation_points()))
        strain.interpolate(fem.Expression(eps(u), T.element.interpolation_points()))
        sed.interpolate(fem.Expression(0.5 * ufl.inner(sigma(u), eps(u)), S0.element.interpolation_points()))
        p, q = ufl.TrialFunction(S1), ufl.TestFunction(S1)
        proj = LinearProblem(p * q * ufl.dx, 0.5 * ufl.inner(sigma(u), eps(u)) * q * ufl.dx, u=sed_nodal,
                             petsc_options={"ksp_type": "preonly", "pc_type": "lu"})
        proj.solve()
        for f in (u, stress, strain, sed, sed_nodal):
            xdmf.write_function(f, float(k))

with io.XDMFFile(MPI.COMM_WORLD, HERE / "sed_only.xdmf", "w") as xdmf:
    xdmf.write_mesh(domain)
    xdmf.write_function(sed, 3.0)
print("dolfinx written")
