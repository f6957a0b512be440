"""Write the EnSight Gold test cases (run: python tests/data/ensight/make_ensight.py; needs OpenFOAM's
foamToEnsight on PATH, Debian's ``openfoam`` 1912 package, for the OpenFOAM cases).

- ``openfoam_ascii/`` and ``openfoam_binary/``: OpenFOAM 1912's ``foamToEnsight`` (``-ascii``, and its
  default C Binary) of a 3 x 2 x 2 blockMesh box of unit hexahedra (m) with hand-written fields at t = 0 and
  1: cell ``SED`` = i + 1 + 10 t, ``D`` = (i, 2i, 3i) (t + 1), ``sigma`` (symmTensor, OpenFOAM's order
  xx xy xz yy yz zz) = (1, 2, 3, 4, 5, 6) (i + 1) (t + 1), i the cell number. foamToEnsight writes part 1
  (the hexahedra) and part 2 (the boundary patch ``walls``, quad4 faces on copies of the nodes).
- ``vtk/``: VTK 9.7.2's ``vtkEnSightWriter`` (C Binary) of the grid of tests/data/vtkhdf/make_vtkhdf.py at
  three steps (its case file's ``time values`` are the step numbers 0 1 2: the writer is given no times).
"""

import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
HEAD = 'FoamFile { version 2.0; format ascii; class %s; location "%s"; object %s; }\n'
DICTS = {
    "system/controlDict": "application blockMesh; startFrom startTime; startTime 0; stopAt endTime; endTime 1; "
                          "deltaT 1; writeControl timeStep; writeInterval 1; writeFormat ascii; writePrecision 8; "
                          "writeCompression off; timeFormat general; timePrecision 6;",
    "system/blockMeshDict": "convertToMeters 1; vertices ((0 0 0) (3 0 0) (3 2 0) (0 2 0) (0 0 2) (3 0 2) (3 2 2) "
                            "(0 2 2)); blocks (hex (0 1 2 3 4 5 6 7) (3 2 2) simpleGrading (1 1 1)); boundary ( walls "
                            "{ type wall; faces ((0 3 2 1) (4 5 6 7) (0 4 7 3) (1 2 6 5) (0 1 5 4) (3 7 6 2)); } );",
    "system/fvSchemes": "ddtSchemes { default steadyState; } gradSchemes { default Gauss linear; } divSchemes "
                        "{ default none; } laplacianSchemes { default Gauss linear corrected; } interpolationSchemes "
                        "{ default linear; } snGradSchemes { default corrected; }",
    "system/fvSolution": "",
}


def openfoam(case: str) -> None:
    for name, body in DICTS.items():
        os.makedirs(os.path.join(case, os.path.dirname(name)), exist_ok=True)
        with open(os.path.join(case, name), "w") as fh:
            fh.write(HEAD % ("dictionary", os.path.dirname(name), os.path.basename(name)) + body + "\n")
    for t in (0, 1):
        os.makedirs(os.path.join(case, str(t)), exist_ok=True)
        for name, cls, kind, dim, value in (
                ("SED", "volScalarField", "scalar", "[1 -1 -2 0 0 0 0]", lambda i: f"{i + 1 + 10 * t}"),
                ("D", "volVectorField", "vector", "[0 1 0 0 0 0 0]",
                 lambda i: f"({i * (t + 1)} {2 * i * (t + 1)} {3 * i * (t + 1)})"),
                ("sigma", "volSymmTensorField", "symmTensor", "[1 -1 -2 0 0 0 0]",
                 lambda i: "(" + " ".join(str(c * (i + 1) * (t + 1)) for c in range(1, 7)) + ")")):
            with open(os.path.join(case, str(t), name), "w") as fh:
                fh.write(HEAD % (cls, t, name) + f"dimensions {dim};\ninternalField nonuniform List<{kind}> 12 (\n"
                         + "\n".join(value(i) for i in range(12)) + "\n);\nboundaryField { walls { type zeroGradient; } }\n")
    subprocess.run(["blockMesh", "-case", case], check=True, capture_output=True)
    for out, args in (("openfoam_ascii", ["-ascii"]), ("openfoam_binary", [])):
        subprocess.run(["foamToEnsight", "-case", case, *args], check=True, capture_output=True)
        shutil.rmtree(os.path.join(HERE, out), ignore_errors=True)
        shutil.move(os.path.join(case, "EnSight"), os.path.join(HERE, out))
        named = [f for f in os.listdir(os.path.join(HERE, out)) if f.endswith(".case")]  # named after the case folder
        os.rename(os.path.join(HERE, out, named[0]), os.path.join(HERE, out, "foam.case"))


def vtk_case() -> None:
    sys.path.insert(0, os.path.join(HERE, "..", "vtkhdf"))
    from make_vtkhdf import TIMES, grid
    from vtkmodules.vtkIOParallel import vtkEnSightWriter

    folder = os.path.join(HERE, "vtk")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    for k, t in enumerate(TIMES):
        w = vtkEnSightWriter()
        w.SetInputData(grid(t))
        w.SetPath(folder)
        w.SetBaseName("block")
        w.SetTimeStep(k)
        w.Write()
    w.WriteCaseFile(len(TIMES))


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        openfoam(tmp)
    vtk_case()
