#!/usr/bin/env python
"""Print the number tables of ``sample_sed/README.md`` from the run records, so they cannot go stale.

``build_info.json`` is the run of ``make_samples.py`` (the study's bottom-edges restraint);
the chapter-4 findings table is measured on ``chapter4/`` and ``vibration/`` by ``afferent.findings``;
``vibration/build_info.json`` is the run of ``make_vibration.py`` (the vibration tables);
``build_info_bottom_face.json`` is the record of the earlier run with the whole bottom face fixed
(``make_samples.py --bottom face``), kept for the comparison table. ``tests/test_samples.py``
checks that every line printed here is in the README. Units: SED in Pa, force in N, widths mm.

    python sample_sed/readme_tables.py
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import chapter4_reasons  # noqa: E402  (sample_sed/chapter4_reasons.py: the stated reasons, one at a time)
STUDY_PEAK_SED_PA = 190.0      # the study's figure 4-7 scale, 1.9e-4 MPa


def _cases(info):
    for blk in ("block4", "block8"):
        for tag, case in info["blocks"][blk]["cases"].items():
            yield blk, tag, case


def receptor_table(info) -> list[str]:
    rows = ["| case | force (N) | tips near | tip SED min / median / max (Pa) | dermis-side median / max (Pa) "
            "| max at (x, z) | edge offset x, z (mm) |", "|---|---|---|---|---|---|---|"]
    for blk, tag, c in _cases(info):
        ch, s = c["checks"], c["solve"]
        t, d, m = ch["tip_node_SED_Pa"], ch["dermis_side_SED_Pa"], ch["max_at"]
        rows.append(f"| {blk} {s['width_mm']:.2f} | {s['punch_force_N']:.4f} | {ch['n_receptors_near']} | "
                    f"{t['min']:.0f} / {t['median']:.0f} / {t['max']:.0f} | {d['median']:.0f} / {d['max']:.0f} | "
                    f"({m['x']:.2f}, {m['z']:.2f}) | {m['dx_from_edge_mm']:+.2f}, {m['dz_from_edge_mm']:+.2f} |")
    return rows


def interchange_table(info) -> list[str]:
    rows = ["| case | tip SED along x through the centre (Pa) | peak-valley-peak? | valley/peak |", "|---|---|---|---|"]
    for blk, tag, c in _cases(info):
        ch = c["checks"]
        p, z = ch["profile_x_tips"], ch["interchange_zone_tips"]
        xc = 4.0 if blk == "block8" else 2.0
        reach = max(0.89, c["solve"]["width_mm"] / 2 + 0.3)     # the tips near the edges and the centre
        near = [(x, v) for x, v in zip(p["x"], p["SED_Pa"]) if abs(x - xc) <= reach]
        prof = ", ".join(f"{v:.0f}" for _, v in near)
        rows.append(f"| {blk} {c['solve']['width_mm']:.2f} | x = {near[0][0]:.2f} ... {near[-1][0]:.2f}: {prof} | "
                    f"{'yes' if z['present'] else 'no'} | {z['valley_to_peak_ratio']:.3f} |")
    return rows


def ramp_table(info) -> list[str]:
    s = info["blocks"]["block4"]["series"]
    return ["| d (mm) | " + " | ".join(f"{r['depth_mm']:g}" for r in s) + " |",
            "|---" * (len(s) + 1) + "|",
            "| force (N) | " + " | ".join(f"{r['punch_force_N'] + 0.0:.4f}".replace("-0.0000", "0.0000") for r in s) + " |",
            "| max receptor SED (Pa) | " + " | ".join(f"{r['max_receptor_SED_Pa']:.0f}" for r in s) + " |"]


def comparison_table(edges, face) -> list[str]:
    rows = ["| case | force (N), face -> edges | max tip SED (Pa), face -> edges | max / study's 190 Pa, face -> edges "
            "| interchange zone, face -> edges |", "|---|---|---|---|---|"]
    for (blk, tag, e), (_, _, f) in zip(_cases(edges), _cases(face)):
        fe, ff = e["checks"], f["checks"]
        me, mf = fe["tip_node_SED_Pa"]["max"], ff["tip_node_SED_Pa"]["max"]
        yn = {True: "yes", False: "no"}
        rows.append(f"| {blk} {e['solve']['width_mm']:.2f} | {f['solve']['punch_force_N']:.4f} -> "
                    f"{e['solve']['punch_force_N']:.4f} | {mf:.0f} -> {me:.0f} | {mf / STUDY_PEAK_SED_PA:.1f} -> "
                    f"{me / STUDY_PEAK_SED_PA:.1f} | {yn[ff['interchange_zone_tips']['present']]} -> "
                    f"{yn[fe['interchange_zone_tips']['present']]} |")
    return rows


def mesh_check_table(edges, face) -> list[str]:
    """The 2x-refined mesh check (0.88 mm case, the 45 tips near the punch) with the bottom edges fixed (the
    sample) and, for comparison, with the whole bottom face fixed."""
    rows = ["| restraint | quantity | production mesh | refined mesh | difference |", "|---|---|---|---|---|"]
    for label, info in (("bottom edges", edges), ("bottom face", face)):
        m = info["blocks"]["block4"]["mesh_check"]
        f, t = m["punch_force_N"], m["receptor_tip_SED_Pa"]
        rows.append(f"| {label} | punch force (N) | {f['mesh']:.4f} | {f['refined']:.4f} | "
                    f"{100 * (f['refined'] / f['mesh'] - 1):+.1f} % |")
        rows.append(f"| {label} | tip SED, nodal (Pa), median / max | {t['mesh_median']:.0f} / {t['mesh_max']:.0f} | "
                    f"{t['refined_median']:.0f} / {t['refined_max']:.0f} | median \\|rel diff\\| "
                    f"{100 * t['median_rel_diff']:.1f} %, max {100 * t['max_rel_diff']:.0f} % |")
        if "dermis_side" in m:
            d, n = m["dermis_side"], m["normalised_tip_SED"]
            rows.append(f"| {label} | tip SED, dermis side (Pa), median / max | {d['mesh_median']:.0f} / "
                        f"{d['mesh_max']:.0f} | {d['refined_median']:.0f} / {d['refined_max']:.0f} | median "
                        f"\\|rel diff\\| {100 * d['median_rel_diff']:.1f} %, max {100 * d['max_rel_diff']:.0f} % |")
            rows.append(f"| {label} | tip SED over its largest (profile shape) | 1 | 1 | median \\|diff\\| "
                        f"{n['median_abs_diff']:.3f}, max {n['max_abs_diff']:.3f}; peak at the same tip: "
                        f"{'yes' if n['same_peak_tip'] else 'no'} |")
    return rows


def chapter4_solves_table(info) -> list[str]:
    """Per model and indenter (``chapter4/build_info.json``): force, CG iterations, solve time, the SED at both tables."""
    rows = ["| model | indenter | force (N) | CG its | solve (s) | RA-I table SED min / median / max (Pa), max at (dx, dz) mm "
            "| SA-I table SED min / median / max (Pa), max at (dx, dz) mm |", "|---|---|---|---|---|---|---|"]
    for model, m in info["models"].items():
        for name, c in m["cases"].items():
            cells = []
            for key in ("ra_table", "sa_table"):
                t = c[key]
                dx, dz = t["max_at_dx_dz_mm"]
                cells.append(f"{t['min_Pa']:.1f} / {t['median_Pa']:.1f} / {t['max_Pa']:.1f} at ({dx:+.2f}, {dz:+.2f})")
            rows.append(f"| {model.upper()[0]}-D | {name} | {c['punch_force_N']:.4f} | {c['cg_iterations']} | "
                        f"{c['solve_s']:.0f} | {cells[0]} | {cells[1]} |")
    return rows


def chapter4_findings_table(sample: Path = HERE) -> list[str]:
    """Every chapter-4 headline claim on ``chapter4/`` and ``vibration/``, as ``afferent demo`` writes it into
    findings.csv (``afferent.findings``: the package's readers and the one rule per claim)."""
    from afferent.findings import chapter4_findings, measure_chapter4

    rows = ["| the study's claim | study | the sample | criterion | holds? |", "|---|---|---|---|---|"]
    for r in chapter4_findings(measure_chapter4(sample)):
        cells = [r["finding"], r["study"], r["sample"], r["criterion"], "yes" if r["holds"] else "**no**"]
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return rows


def vibration_table(vib) -> list[str]:
    """SED (Pa, the dermis side) at the vibration site at each deepest point, the largest tip and the plane's force,
    per model and frequency (``vibration/build_info.json``)."""
    freqs = [20, 30, 50, 80]
    rows = ["| model | site (x, z) mm | deepest point | " + " | ".join(f"{f} Hz" for f in freqs) + " | 80 / 20 Hz |",
            "|---" * (len(freqs) + 4) + "|"]
    ser = {m: [vib["models"][m]["series"][f"{m}_{f}Hz"]["deepest"] for f in freqs] for m in ("3d", "2d")}

    def row(m, site, label, vals, fmt):
        ratio = f"{vals[-1] / vals[0]:.3f}" if vals[0] > 0 else ""
        return f"| {m.upper()} | {site} | {label} | " + " | ".join(fmt.format(v) for v in vals) + f" | {ratio} |"

    names = ("1st (t = T/4)", "2nd (5T/4)", "3rd (9T/4)")
    for m, ds in ser.items():
        site = ds[0]["site"]
        assert all(d["site"] == site for d in ds), "the site differs between frequencies"
        for i, name in enumerate(names):
            rows.append(row(m, f"({site['x']:.2f}, {site['z']:.2f})", name, [d["site_SED_Pa"][i] for d in ds], "{:.1f}"))
    for m, ds in ser.items():
        rows.append(row(m, "largest tip", "3rd", [d["max_tip_SED_Pa"][-1] for d in ds], "{:.1f}"))
    for m, ds in ser.items():
        rows.append(row(m, "plane force (N)", "3rd", [d["force_N"][-1] for d in ds], "{:.4f}"))
        rows.append(f"| {m.upper()} | least plane force (N), any step | | "
                    + " | ".join(f"{d['min_force_N']:.4f}" for d in ds) + " | |")
    return rows


def vibration_files_table(vib) -> list[str]:
    """Size of each series (PVD + its VTUs, bytes) and the data total (``vibration/build_info.json``)."""
    rows = ["| file(s) | size (bytes) |", "|---|---|", f"| `receptors.csv` | {vib['files']['receptors.csv']:,} |"]
    for m in ("3d", "2d"):
        for f in (20, 30, 50, 80):
            tag = f"{m}_{f}Hz"
            vtu = [v for k, v in vib["files"].items() if k.startswith(tag + "/") and k.endswith(".vtu")]
            total = vib["files"][f"{tag}/vib.pvd"] + sum(vtu)
            rows.append(f"| `{tag}/vib.pvd` + {len(vtu)} VTUs | {total:,} (VTU {min(vtu):,} - {max(vtu):,}) |")
    rows.append(f"| data total: {len(vib['files'])} files (build_info.json aside) | {vib['total_size_MB']} MB |")
    return [r.replace(",", " ") for r in rows]


def all_tables(edges=None, face=None) -> dict[str, list[str]]:
    edges = edges or json.loads((HERE / "build_info.json").read_text())
    face = face or json.loads((HERE / "build_info_bottom_face.json").read_text())
    vib = json.loads((HERE / "vibration" / "build_info.json").read_text())
    return {"receptor SED": receptor_table(edges), "interchange zone": interchange_table(edges),
            "loading ramp": ramp_table(edges), "bottom face -> bottom edges": comparison_table(edges, face),
            "mesh check": mesh_check_table(edges, face),
            "chapter 4 solves": chapter4_solves_table(json.loads((HERE / "chapter4" / "build_info.json").read_text())),
            "chapter 4 findings": chapter4_findings_table(),
            "chapter 4 reasons": chapter4_reasons.ratio_rows(json.loads(chapter4_reasons.RESULT.read_text())),
            "vibration SED": vibration_table(vib), "vibration files": vibration_files_table(vib)}


if __name__ == "__main__":
    for name, rows in all_tables().items():
        print(f"<!-- {name}: python sample_sed/readme_tables.py -->")
        print("\n".join(rows) + "\n")
