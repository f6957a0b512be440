"""Regenerate the Kratos Multiphysics test files of tests/data/kratos/ (see README.md there).

A 4 x 4 x 2 mm block (SI units: m, Pa) of 8 x 8 x 4 linear hexahedra
(SmallDisplacementElement3D8N, LinearElastic3DLaw, E = 100 kPa, nu = 0.45), bottom fixed, the
top nodes within 0.8 mm of the centre pushed down by 0.05 mm per step (a flat punch), two
static steps (t = 1, 2). Kratos' VtkOutputProcess writes its default legacy binary .vtk, one
file per step, with STRAIN_ENERGY, CAUCHY_STRESS_VECTOR and GREEN_LAGRANGE_STRAIN_VECTOR
extrapolated to the nodes (POINT_DATA) and averaged per element (CELL_DATA); VtuOutputProcess
writes its .vtm multiblock files (one .vtu block each) and a .vtm.series of the same steps,
with STRAIN_ENERGY extrapolated to the nodes by integration_values_extrapolation_to_nodes_process.

Run with Kratos from PyPI (KratosMultiphysics, KratosStructuralMechanicsApplication,
KratosLinearSolversApplication 10.4.4), from this folder:

    python3 -m venv /tmp/kratos && /tmp/kratos/bin/pip install KratosMultiphysics \
        KratosStructuralMechanicsApplication KratosLinearSolversApplication
    /tmp/kratos/bin/python make_kratos.py
"""

import json
import os
import shutil
import tempfile

import KratosMultiphysics as KM
from KratosMultiphysics.StructuralMechanicsApplication.structural_mechanics_analysis import StructuralMechanicsAnalysis

HERE = os.path.dirname(os.path.abspath(__file__))
NX, NY, NZ = 8, 8, 4
LX, LY, LZ = 4e-3, 4e-3, 2e-3
GAUSS = ["STRAIN_ENERGY", "CAUCHY_STRESS_VECTOR", "GREEN_LAGRANGE_STRAIN_VECTOR"]


def node_id(i, j, k):
    return 1 + i + (NX + 1) * (j + (NY + 1) * k)


def write_mdpa(path):
    lines = ["Begin ModelPartData", "End ModelPartData", "Begin Properties 1", "End Properties", "Begin Nodes"]
    fixed, punch = [], []
    for k in range(NZ + 1):
        for j in range(NY + 1):
            for i in range(NX + 1):
                x, y, z = LX * i / NX, LY * j / NY, LZ * k / NZ
                n = node_id(i, j, k)
                lines.append(f"{n} {x:.9g} {y:.9g} {z:.9g}")
                if k == 0:
                    fixed.append(n)
                if k == NZ and (x - LX / 2) ** 2 + (y - LY / 2) ** 2 <= (0.8e-3) ** 2 + 1e-12:
                    punch.append(n)
    lines += ["End Nodes", "Begin Elements SmallDisplacementElement3D8N"]
    e = 0
    for k in range(NZ):
        for j in range(NY):
            for i in range(NX):
                e += 1
                c = [node_id(i, j, k), node_id(i + 1, j, k), node_id(i + 1, j + 1, k), node_id(i, j + 1, k),
                     node_id(i, j, k + 1), node_id(i + 1, j, k + 1), node_id(i + 1, j + 1, k + 1), node_id(i, j + 1, k + 1)]
                lines.append(f"{e} 1 " + " ".join(map(str, c)))
    lines.append("End Elements")
    for name, nodes in (("fixed", fixed), ("punch", punch)):
        lines += [f"Begin SubModelPart {name}", "Begin SubModelPartNodes", *map(str, nodes), "End SubModelPartNodes",
                  "End SubModelPart"]
    lines += ["Begin SubModelPart solid", "Begin SubModelPartElements", *map(str, range(1, e + 1)),
              "End SubModelPartElements", "End SubModelPart"]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


def parameters(work):
    fix = {"python_module": "assign_vector_variable_process", "kratos_module": "KratosMultiphysics",
           "Parameters": {"model_part_name": "Structure.fixed", "variable_name": "DISPLACEMENT",
                          "constrained": [True, True, True], "value": [0.0, 0.0, 0.0], "interval": [0.0, "End"]}}
    push = {"python_module": "assign_vector_variable_process", "kratos_module": "KratosMultiphysics",
            "Parameters": {"model_part_name": "Structure.punch", "variable_name": "DISPLACEMENT",
                           "constrained": [False, False, True], "value": [None, None, "-5e-5*t"], "interval": [0.0, "End"]}}
    vtk = {"python_module": "vtk_output_process", "kratos_module": "KratosMultiphysics",
           "Parameters": {"model_part_name": "Structure", "output_path": os.path.join(work, "vtk"),
                          "nodal_solution_step_data_variables": ["DISPLACEMENT"],
                          "gauss_point_variables_extrapolated_to_nodes": GAUSS,
                          "gauss_point_variables_in_elements": GAUSS}}
    vtu = {"python_module": "vtu_output_process", "kratos_module": "KratosMultiphysics",
           "Parameters": {"model_part_name": "Structure", "output_path": os.path.join(work, "vtu"),
                          "nodal_solution_step_data_variables": ["DISPLACEMENT"],
                          "nodal_data_value_variables": ["STRAIN_ENERGY"]}}
    extrapolate = {"python_module": "integration_values_extrapolation_to_nodes_process",
                   "kratos_module": "KratosMultiphysics",
                   "Parameters": {"model_part_name": "Structure", "list_of_variables": ["STRAIN_ENERGY"]}}
    return {
        "problem_data": {"problem_name": "block", "parallel_type": "OpenMP", "echo_level": 0,
                         "start_time": 0.0, "end_time": 2.0},
        "solver_settings": {
            "solver_type": "Static", "model_part_name": "Structure", "domain_size": 3, "echo_level": 0,
            "analysis_type": "linear", "time_stepping": {"time_step": 1.0},
            "model_import_settings": {"input_type": "mdpa", "input_filename": os.path.join(work, "block")},
            "material_import_settings": {"materials_filename": os.path.join(work, "materials.json")},
            "linear_solver_settings": {"solver_type": "LinearSolversApplication.sparse_lu"},
        },
        "processes": {"constraints_process_list": [fix, push], "auxiliar_process_list": [extrapolate]},
        "output_processes": {"vtk_output": [vtk], "vtu_output": [vtu]},
    }


def main():
    work = tempfile.mkdtemp()
    write_mdpa(os.path.join(work, "block.mdpa"))
    materials = {"properties": [{"model_part_name": "Structure.solid", "properties_id": 1, "Material": {
        "constitutive_law": {"name": "LinearElastic3DLaw"},
        "Variables": {"YOUNG_MODULUS": 1e5, "POISSON_RATIO": 0.45, "DENSITY": 1000.0}, "Tables": {}}}]}
    with open(os.path.join(work, "materials.json"), "w") as fh:
        json.dump(materials, fh)
    model = KM.Model()
    StructuralMechanicsAnalysis(model, KM.Parameters(json.dumps(parameters(work)))).Run()
    for sub in ("vtk", "vtu"):
        for root, _, files in os.walk(os.path.join(work, sub)):
            for f in sorted(files):
                print(os.path.join(root, f), os.path.getsize(os.path.join(root, f)))
    for sub in ("vtk", "vtu"):
        shutil.rmtree(os.path.join(HERE, sub), ignore_errors=True)
        shutil.copytree(os.path.join(work, sub), os.path.join(HERE, sub))
    shutil.rmtree(work)


if __name__ == "__main__":
    main()
