"""Solve a small indentation of a skin-like block with SfePy and write it as SfePy does.

Regenerate (SfePy from PyPI, in its own environment)::

    python3.11 -m venv /tmp/sfepy-venv && /tmp/sfepy-venv/bin/pip install sfepy
    /tmp/sfepy-venv/bin/python tests/data/sfepy/make_sfepy.py

The model, in mm / N / s (stress and SED in MPa): a 2 x 2 x 1 mm block (gen_block_mesh, 4 x 4 x 2
hexahedra), bottom face fixed, the central 1 x 1 mm patch of the top face moved by
(0, 0, -0.1) mm, linear elastic E = 0.1 MPa, nu = 0.45 (stiffness_from_youngpoisson).
Written the way SfePy's examples write derived quantities: ``ev_cauchy_strain`` and
``ev_cauchy_stress`` evaluated with ``mode='el_avg'`` and stored as cell data
``cauchy_strain`` / ``cauchy_stress`` (SfePy's 6-vector order 11 22 33 12 13 23; the strain's
shear is doubled: engineering), plus SfePy's own strain energy density per element:
``dw_lin_elastic`` evaluated on (u, u) with ``mode='el_eval'`` is the element integral of eps:D:eps and
``ev_volume`` the element volume, so ``sed`` = 1/2 of their ratio: SfePy's own element-average
SED, computed from its elasticity matrix, not from the written tensors. ``pb.save_state``
writes ``block.vtk`` through SfePy's meshio writer.
"""

from pathlib import Path

import numpy as np
from sfepy.base.base import Struct
from sfepy.discrete import Equation, Equations, FieldVariable, Integral, Material, Problem
from sfepy.discrete.conditions import Conditions, EssentialBC
from sfepy.discrete.fem import FEDomain, Field
from sfepy.mechanics.matcoefs import stiffness_from_youngpoisson
from sfepy.mesh.mesh_generators import gen_block_mesh
from sfepy.solvers.ls import ScipyDirect
from sfepy.solvers.nls import Newton
from sfepy.terms import Term

HERE = Path(__file__).resolve().parent

mesh = gen_block_mesh([2.0, 2.0, 1.0], [5, 5, 3], [1.0, 1.0, 0.5], name="block", verbose=False)
domain = FEDomain("domain", mesh)
omega = domain.create_region("Omega", "all")
bottom = domain.create_region("Bottom", "vertices in (z < 0.001)", "facet")
patch = domain.create_region("Patch", "vertices in (z > 0.999) & (x > 0.499) & (x < 1.501) & (y > 0.499) & (y < 1.501)",
                             "facet")
field = Field.from_args("fu", np.float64, "vector", omega, approx_order=1)
u = FieldVariable("u", "unknown", field)
v = FieldVariable("v", "test", field, primary_var_name="u")
m = Material("m", D=stiffness_from_youngpoisson(3, 0.1, 0.45))
integral = Integral("i", order=2)
balance = Equation("balance", Term.new("dw_lin_elastic(m.D, v, u)", integral, omega, m=m, v=v, u=u))
pb = Problem("indentation", equations=Equations([balance]))
pb.set_bcs(ebcs=Conditions([EssentialBC("fix", bottom, {"u.all": 0.0}),
                            EssentialBC("push", patch, {"u.0": 0.0, "u.1": 0.0, "u.2": -0.1})]))
pb.set_solver(Newton({}, lin_solver=ScipyDirect({})))
state = pb.solve(save_results=False)

strain = pb.evaluate("ev_cauchy_strain.2.Omega(u)", mode="el_avg")
stress = pb.evaluate("ev_cauchy_stress.2.Omega(m.D, u)", mode="el_avg", copy_materials=False)
energy = pb.evaluate("dw_lin_elastic.2.Omega(m.D, u, u)", mode="el_eval", copy_materials=False)  # int eps:D:eps
volume = pb.evaluate("ev_volume.2.Omega(u)", mode="el_eval")
out = state.create_output()
out["cauchy_strain"] = Struct(name="output_data", mode="cell", data=strain)
out["cauchy_stress"] = Struct(name="output_data", mode="cell", data=stress)
out["sed"] = Struct(name="output_data", mode="cell", data=0.5 * energy / volume)
pb.save_state(str(HERE / "block.vtk"), out=out)
print("sfepy written", strain.shape, stress.shape, energy.shape)
