"""Regenerate block_ascii.vtk and block_binary.vtk with GetFEM (Debian's python3-getfem 5.4.2).

    /usr/bin/python3 make_getfem.py      # Debian's Python, where python3-getfem installs

A 4 x 4 x 2 mm block (mm, N, MPa) of 4 x 4 x 2 trilinear hexahedra (FEM_QK(3,1)), linear elastic
(E = 0.1 MPa, nu = 0.45), bottom fixed, a downward traction of 0.002 MPa on the top face. GetFEM
evaluates von Mises, the SED 1/2 sigma:eps, the stress and the strain at the nodes
(``Model.interpolation`` on the same Lagrange space) and ``MeshFem.export_to_vtk`` writes them as
legacy VTK, one section an array: VECTORS displacement, SCALARS von_mises, SCALARS SED, TENSORS
stress, TENSORS strain. The SED is the second SCALARS section and the strain the second TENSORS.
"""
import numpy as np
import getfem as gf

gf.util_trace_level(0)
E, nu = 0.1, 0.45  # MPa
lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
m = gf.Mesh('cartesian', np.linspace(0, 4, 5), np.linspace(0, 4, 5), np.linspace(0, 2, 3))  # mm
mfu = gf.MeshFem(m, 3)
mfu.set_fem(gf.Fem('FEM_QK(3,1)'))
mfs = gf.MeshFem(m, 1)
mfs.set_fem(gf.Fem('FEM_QK(3,1)'))
mft = gf.MeshFem(m, 3, 3)
mft.set_fem(gf.Fem('FEM_QK(3,1)'))
mim = gf.MeshIm(m, gf.Integ('IM_HEXAHEDRON(5)'))
m.set_region(1, m.outer_faces_with_direction([0, 0, -1], 0.01))
m.set_region(2, m.outer_faces_with_direction([0, 0, 1], 0.01))
md = gf.Model('real')
md.add_fem_variable('u', mfu)
md.add_initialized_data('lambda', [lam])
md.add_initialized_data('mu', [mu])
md.add_isotropic_linearized_elasticity_brick(mim, 'u', 'lambda', 'mu')
md.add_Dirichlet_condition_with_multipliers(mim, 'u', mfu, 1)
md.add_initialized_data('F', [0.0, 0.0, -0.002])  # MPa, on the top face
md.add_source_term_brick(mim, 'u', 'F', 2)
md.solve()
U = md.variable('u')
eps = "Sym(Grad_u)"
sig = f"(lambda*Trace({eps})*Id(meshdim)+2*mu*{eps})"
sed = md.interpolation(f"0.5*{sig}:{eps}", mfs)
vm = md.interpolation(f"sqrt(1.5)*Norm(Deviator({sig}))", mfs)
stress = md.interpolation(sig, mft)
strain = md.interpolation(eps, mft)
for name, fmt in (("block_ascii.vtk", ("ascii",)), ("block_binary.vtk", ())):  # binary is GetFEM's default
    mfs.export_to_vtk(name, *fmt, mfu, U, "displacement", mfs, vm, "von_mises", mfs, sed, "SED",
                      mft, stress, "stress", mft, strain, "strain")
print(f"SED {sed.min():.6g} .. {sed.max():.6g} MPa")
