#!/usr/bin/env python
"""The stated reasons for the chapter-4 3-D/2-D difference, one at a time: the peak RA-I SED under the bar.

Chapter 4 of the study finds **focalizing**: under the 2 x 2 mm bar the peak SED at the RA-I sites (papilla
tips) is larger in the 3-D ridged block than in the 2-D ridged one. Issue 35 lists what could make a sample
miss it; each is tried here with everything else kept, on the bar indenter of ``make_chapter4.py``:

* **geometry**: the blocks as the study describes them (discrete concave-convex pegs, 144 tips, twelve
  intermediate ridges at 0.22 mm; ``make_chapter4.py``) against the earlier blocks (a continuous papilla
  wall along z cut by V-grooves, intermediate ridges at 0.44 mm, tables every second papilla): the earlier
  row is that script's output at commit 2a6edff (``git show 2a6edff:sample_sed/chapter4_reasons.py``), its
  blocks are no longer generated;
* **side**: the SED at a tip node as the nodal average over every element around it (what a generic export
  carries), from the dermis elements only (ANSYS's default for nodal results at a material boundary,
  ``AVRES,2``, and the study's fig. 4-6 "only the dermis is shown"), or from the epidermis elements only;
* **relaxation**: the layers' instantaneous moduli (``elastic``) or the dermis and subcutis relaxed to the end
  of the 2 s hold (``relaxed``, the samples; make_chapter4.py "Material");
* **mesh**: every element split into 2 x 2 x 2 (``refine 2``) against the samples' mesh;
* **table**: the inner 10 x 10 tips (the hot-spot table) or all 144.

Units: SED in Pa. ``python sample_sed/chapter4_reasons.py --solve`` solves (about 30 min on 2 cores) and
writes ``chapter4/reasons.json``; without ``--solve`` it prints the table from that file.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESULT = HERE / "chapter4" / "reasons.json"
#: variant name -> (material, refine)
VARIANTS = {"elastic": ("elastic", 1), "relaxed (the samples)": ("relaxed", 1), "relaxed, mesh refine 2": ("relaxed", 2)}
READINGS = ("nodal average", "dermis side", "epidermis side")
#: The earlier blocks (commit 2a6edff, ``python sample_sed/chapter4_reasons.py`` there): 3-D/2-D peak ratio under
#: the bar, table (every second papilla) and every tip; elastic, their own mesh.
EARLIER = {"nodal average": (0.941, 0.963), "dermis side": (0.926, 0.938), "epidermis side": (0.968, None)}


def peaks(sm, csed: np.ndarray, vol: np.ndarray) -> dict:
    """{reading: {"table": peak Pa over the 10 x 10 table, "all": over the 144 tips}} of one solve."""
    import make_chapter4 as mc
    import make_samples as ms

    tips = mc.all_sites(sm)["tips"]
    every = ms.interface_nodes(sm, tips[:, 0], tips[:, 2])
    out = {}
    for reading, cells in (("nodal average", None), ("dermis side", sm.layer == ms.LAYER_DERMIS),
                           ("epidermis side", sm.layer == ms.LAYER_EPIDERMIS)):
        nodal = ms.nodal_average(sm.mesh, csed, vol, cells) * 1e6
        out[reading] = {"table": float(np.max(nodal[sm.tip_nodes])), "all": float(np.max(nodal[every]))}
    return out


def solve_all(log=print) -> dict:
    """Every variant, both models, the bar: the record written to ``reasons.json``."""
    import make_chapter4 as mc
    import make_samples as ms

    rec = {"generator": "python sample_sed/chapter4_reasons.py --solve", "indenter": "bar", "units": "Pa",
           "versions": {"python": platform.python_version(), "numpy": np.__version__, "scikit-fem": ms.skfem.__version__,
                        "pyamg": ms.pyamg.__version__},
           "earlier_blocks_ratio": {k: {"table": v[0], "all": v[1]} for k, v in EARLIER.items()}, "variants": {}}
    for variant, (material, refine) in VARIANTS.items():
        per = {}
        for model in mc.MODELS:
            t0 = time.perf_counter()
            _, sm, csed, vol, sinfo, setup = next(mc.solve_model(model, False, ["bar"], material, refine, log=log))
            per[model] = {"peaks": peaks(sm, csed, vol), "n_elements": setup["mesh"]["n_elements"],
                          "punch_force_N": sinfo["punch_force_N"], "seconds": round(time.perf_counter() - t0, 1)}
            log(f"{variant} {model}: {per[model]}")
        rec["variants"][variant] = per
    return rec


def ratio_rows(rec: dict) -> list[str]:
    """Markdown rows: 3-D/2-D peak ratio under the bar per variant and reading (> 1: the study's focalizing)."""
    rows = ["| blocks, material, mesh | read as | 3-D/2-D: 10 x 10 table | 3-D/2-D: every tip | 3-D, 2-D peak (table, Pa) |",
            "|---|---|---|---|---|"]
    for reading, (table, every) in EARLIER.items():
        rows.append(f"| earlier blocks (2a6edff), elastic | {reading} | {table:.3f} | "
                    f"{'-' if every is None else f'{every:.3f}'} | - |")
    for variant, per in rec["variants"].items():
        for reading in READINGS:
            a, b = per["3d"]["peaks"][reading], per["2d"]["peaks"][reading]
            rows.append(f"| as described, {variant} | {reading} | {a['table'] / b['table']:.3f} | "
                        f"{a['all'] / b['all']:.3f} | {a['table']:.0f}, {b['table']:.0f} |")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--solve", action="store_true", help=f"solve every variant and write {RESULT.name}")
    args = ap.parse_args(argv)
    if args.solve:
        sys.path.insert(0, str(HERE))
        rec = solve_all()
        tmp = RESULT.with_name(RESULT.name + ".part")
        tmp.write_text(json.dumps(rec, indent=1) + "\n")
        tmp.replace(RESULT)
    print("\n".join(ratio_rows(json.loads(RESULT.read_text()))))


if __name__ == "__main__":
    main()
