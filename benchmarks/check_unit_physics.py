"""The unit check from physics on every real export of tests/data and sample_sed (docs/fe-export.md, "Units from physics").

    python benchmarks/check_unit_physics.py [--markdown]

For each export (a ``.pvd`` for its files; the pieces of a ``.pvtu``, the steps of a series and the
hostile files of ``tests/data/bad`` and ``tests/data/fuzz`` left out), read without options: the SED
array afferent finds (else 1/2 sigma:eps of the stress and strain tensors), in the unit of the model
that wrote it (MPa for the mm/N/s models, Pa for Kratos and code_aster, MAPDL's psi read as Pa), and
:func:`afferent.io._unit_physics.implied_modulus` on it: the stiffness 2 SED / eps:eps, where the
strain came from, the verdict, and the unit the check names for a slip of 1e-3 (kPa declared for MPa)
and of 1e3 (GPa for MPa). Then the exports that cannot tell, and why. Exit status 1 when an export
that can tell is not plausible in its own unit or a slip would pass.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SKIP = ("tests/data/fuzz", "tests/data/golden", "tests/data/report", "tests/data/bad")
ENDINGS = (".vtu", ".vtk", ".pvtu", ".vtm", ".pvd", ".xdmf", ".frd", ".frd.gz", ".e", ".rst", ".med", ".rmed", ".xplt",
           ".csv", ".txt", ".rpt", ".dat", ".lis", ".csv.gz", ".dat.gz", ".tsv", ".series")
NOT_EXPORTS = ("receptors", "reference.csv", "sites.csv", "sample_sed/observed/", "nodes.csv", "nlist")
SI = ("tests/data/kratos", "tests/data/med")


def exports() -> list[str]:
    """The exports, as paths relative to the repository, sorted."""
    out = []
    for base in ("tests/data", "sample_sed"):
        for folder, _, names in os.walk(ROOT / base):
            rel = os.path.relpath(folder, ROOT)
            if rel.startswith(SKIP):
                continue
            for name in sorted(names):
                p = os.path.join(rel, name)
                if not p.lower().endswith(ENDINGS) or any(s in p for s in NOT_EXPORTS):
                    continue
                parts = ("sample_sed/vibration/" in p and not p.endswith(".pvd")) or "/series_0p88mm/indent_0" in p \
                    or "/Cycle0" in p or "Structure/Structure_el" in p or p.endswith((".0.vtu", ".1.vtu"))
                if not parts:
                    out.append(p)
    return sorted(out)


def main(argv=None) -> int:
    from afferent.io import read_raw
    from afferent.io._find_arrays import find_sed_array, find_tensors
    from afferent.io._read_options import ReadOptions
    from afferent.io._unit_physics import implied_modulus, modulus_verdict
    from afferent.strain_energy import sed_exact

    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    warnings.simplefilter("ignore")
    os.chdir(ROOT)
    rows, cannot, bad = [], [], 0
    for p in exports():
        try:
            raw = read_raw(p)
        except Exception as err:  # noqa: BLE001 - a file this survey cannot read is listed, not fatal
            cannot.append((p, f"not read without options ({type(err).__name__})"))
            continue
        unit, factor = ("Pa", 1.0) if p.startswith(SI) or "mapdl" in p else ("MPa", 1e6)
        try:
            arr = find_sed_array(raw, ReadOptions())[0]
            values, location, what = np.asarray(arr.values, float).reshape(arr.shape[0], -1), arr.location, repr(arr.name)
        except Exception:  # noqa: BLE001 - no SED array: the tensors, if any
            try:
                (_, s, location), (_, e, _) = find_tensors(raw, ReadOptions(sed_from="exact"), need_convention=False)
                values, what = sed_exact(s, e), "1/2 sigma:eps"
            except Exception:  # noqa: BLE001
                cannot.append((p, "no SED array or tensors found without options"))
                continue
        record = implied_modulus(raw, ReadOptions(), values * factor, location)
        if not record["checkable"]:
            cannot.append((p, record["note"]))
            continue
        m = record["modulus_pa"]
        verdict = modulus_verdict(record, unit=unit, factor=factor)["verdict"]
        down = modulus_verdict(dict(record, modulus_pa=m * 1e-3), unit="kPa" if unit == "MPa" else "mPa", factor=factor * 1e-3)
        up = modulus_verdict(dict(record, modulus_pa=m * 1e3), unit="GPa" if unit == "MPa" else "kPa", factor=factor * 1e3)
        slips = [v.get("likely_unit", v["verdict"]) for v in (down, up)]
        bad += verdict != "plausible" or any(s != unit for s in slips)
        rows.append(f"| `{p}` | {what} | {unit} | {m:.3g} Pa | {record['strain_from']} | {verdict} | {slips[0]} | {slips[1]} |")
    print("| export | SED | unit | 2 SED / eps:eps | strain from | verdict | unit named for x1e-3 | for x1e3 |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\n{len(rows)} exports can tell ({len(rows) - bad} plausible in their unit, both slips refused); "
          f"{len(cannot)} cannot:")
    for p, why in cannot:
        print(f"- `{p}`: {why}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
