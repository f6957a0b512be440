"""The study's chapter-4 headline claims measured on an FE sample, each with its criterion and verdict.

Chapter 4 of the study compares a **3-D ridged** and a **2-D ridged** skin block (docs/method.md,
"Chapter 4"). Its headline claims, each decided here by one stated criterion on the sample's own
numbers (nothing is left out because it fails):

- focalizing (4.4.2, 4.5.1): the peak SED at the RA-I sites of the 3-D model exceeds the 2-D model's;
- the 3-D model's hot-spot maps tell the four indenters apart better than the 2-D model's, which
  barely distinguish solid from gap;
- the peaks sit at the indenter's edges in the 3-D model, at its corners in the 2-D model;
- the interchange zone (peaks near the edges, a valley at the centre) under the bar;
- along x and along z (4.4.2): the interchange zone is equally noticeable along x in both models and
  more significant along z in the 3-D model than in the 2-D model; (4.5.2) more marked along x;
- the SED scale under the 2 x 2 mm bar (~190 Pa, fig. 4-7);
- vibration (figs. 4-10, 4-11): the SED at the RA-I site near the plane's edge, at the deepest point,
  rises from 20 to 80 Hz in the 3-D model and stays flat in the 2-D model.

:func:`measure_chapter4` reads a sample laid out as ``sample_sed/`` (``chapter4/ridged{3d,2d}/`` with
``ra_sites.csv``, ``sa_sites.csv`` and one VTU per indenter; ``vibration/{3d,2d}_{f}Hz/`` series)
through the package's readers and samplers; :func:`chapter4_findings` is a pure function of its
measurements (SED in Pa, positions in mm from the indenter centre), so a changed number changes the
verdict. ``afferent demo`` writes both chapters' rows into ``findings.csv``.
"""

from __future__ import annotations

from ._typing import PathLike

from pathlib import Path

import numpy as np

__all__ = ["INDENTERS", "MODELS", "FREQUENCIES_HZ", "measure_chapter4", "chapter4_findings", "CHAPTER4_CLAIMS"]

#: The four indenters of fig. 4-9 (file stems of the chapter-4 sample).
INDENTERS = ("bar", "gap", "gap90", "circle")
#: model key -> folder of the chapter-4 sample
MODELS = {"3d": "ridged3d", "2d": "ridged2d"}
#: The vibration frequencies of figs. 4-10/4-11, Hz.
FREQUENCIES_HZ = (20, 30, 50, 80)
#: Half the width of the 2 x 2 mm bar and plane, mm.
BAR_HALF_MM = 1.0
#: A site is "at" an edge line when within this distance of it, mm: half the 0.44 mm ridge pitch plus a
#: little, so that one row of sites on either side of an edge line counts (a choice; the study gives none).
EDGE_BAND_MM = 0.25
#: The band around the plane's outline from which the vibration site is chosen, mm (the vibration scenes'
#: ``cycles_edge_mm``: one papilla pitch along z).
VIBRATION_EDGE_MM = 0.22
#: A difference of normalised SED (fraction of a map's range) counts when larger than this: the demo's
#: peak threshold (``afferent demo --peak-prominence`` default), a choice, the study gives no number.
MARGIN = 0.05
#: "Flat" and "rising" with frequency: the 20 -> 80 Hz change of the SED, relative. A choice: the study's
#: fig. 4-11 gives no number.
FLAT_REL = 0.05
#: The study's SED scale under the 2 x 2 mm bar, Pa (fig. 4-7), and the factor within which a sample matches.
STUDY_BAR_SED_PA, SED_FACTOR = 190.0, 2.0
#: The hot-spot threshold of the study's maps (normalised SED).
HOT = 0.6
#: The side of the epidermis/dermis interface the chapter-4 maps read at a site node: the dermis, material id 2
#: of the samples' ``layer`` array. The study's tool (ANSYS) does not average nodal results across materials by
#: default (``AVRES,2``) and its fig. 4-6 shows only the dermis (sample_sed/README.md, "Chapter 4").
STUDY_SIDE = 2

#: The claim keys :func:`chapter4_findings` returns, in order (tests check every one is present).
CHAPTER4_CLAIMS = ("focalizing", "separates", "solid_vs_gap", "edges_vs_corners", "interchange_zone", "x_equal",
                   "z_more_3d", "x_more_than_z", "sed_scale", "vibration_3d_rises", "vibration_2d_flat")


def _sites(path: Path):
    from .receptors import read_receptors

    return read_receptors(str(path), length_unit="mm")


def _sample(export: Path, layout, side="average"):
    """:func:`afferent.sample_sed` at ``layout``'s sites (``.times`` s, ``.values`` SED in Pa, (n_t, n_sites));
    ``side`` as there.

    A material ``side`` reads the export's **cell** SED (``location='cell'``): the samples carry a nodal SED too,
    averaged across the materials, on which a material's side cannot be told (refused)."""
    from .io import read_sed
    from .sampling import sample_sed

    cell = side != "average"
    field = read_sed(str(export), length_unit="mm", sed_unit="MPa", location="cell" if cell else None)
    return sample_sed(field, layout, side=side)


def _series_file(folder: Path) -> Path:
    for name in ("vib.pvd", "vib.xdmf"):
        if (folder / name).is_file():
            return folder / name
    raise FileNotFoundError(f"{str(folder)!r} holds no vibration series (vib.pvd or vib.xdmf); regenerate with "
                            "'python sample_sed/make_vibration.py'.")


def measure_chapter4(sample: PathLike) -> dict | None:
    """The chapter-4 measurements of a sample folder laid out as ``sample_sed/``; None without ``chapter4/``.

    Returns
    -------
    dict
        ``maps``: {(model, site kind 'ra'/'sa', indenter): SED at the table's sites, Pa, at the last step, the
        dermis side (``STUDY_SIDE``)};
        ``pos``: {(model, kind): site (x, z) in mm from the indenter centre (the RA-I table's centre)};
        ``vibration`` (absent without ``vibration/``): {model: {frequency Hz: (SED Pa at the site at the first
        deepest point, at the last deepest point)}}, the dermis side (``STUDY_SIDE``), the site chosen as ``afferent cycles`` does
        (:func:`afferent.cycles.cycle_table`: largest SED at the last deepest point within
        ``VIBRATION_EDGE_MM`` (0.22 mm) of the plane's outline).
    """
    from .cycles import cycle_table, edge_sites

    sample = Path(sample)
    if not (sample / "chapter4").is_dir():
        return None
    maps, pos = {}, {}
    centre = None
    for model, folder in MODELS.items():
        for kind in ("ra", "sa"):
            layout = _sites(sample / "chapter4" / folder / f"{kind}_sites.csv")
            xz = np.asarray(layout.positions, dtype=float)[:, [0, 2]] * 1e3
            if centre is None:
                centre = xz.mean(axis=0)
            pos[(model, kind)] = xz - centre
            for ind in INDENTERS:
                maps[(model, kind, ind)] = np.asarray(_sample(sample / "chapter4" / folder / f"{ind}.vtu", layout,
                                                           STUDY_SIDE).values, dtype=float)[-1]
    out = {"maps": maps, "pos": pos, "centre_mm": [float(c) for c in centre]}
    vib = sample / "vibration"
    if vib.is_dir():
        layout = _sites(vib / "receptors.csv")
        p = np.asarray(layout.positions, dtype=float)
        lo, hi = (centre - BAR_HALF_MM) * 1e-3, (centre + BAR_HALF_MM) * 1e-3
        cand = edge_sites(p, (lo[0], hi[0]), (lo[1], hi[1]), VIBRATION_EDGE_MM * 1e-3)
        out["vibration"] = {}
        for model in MODELS:
            per = {}
            for f in FREQUENCIES_HZ:
                series = _series_file(vib / f"{model}_{f}Hz")
                sed = _sample(series, layout, STUDY_SIDE)
                table, _ = cycle_table(sed.times, np.asarray(sed.values, dtype=float), f, positions_m=p,
                                       candidates=cand)
                per[f] = (float(table["sed_pa"].iloc[0]), float(table["sed_pa"].iloc[-1]))
            out["vibration"][model] = per
    return out


def _norm(v):
    from .hotspots import normalise_map

    return normalise_map(v)


def _contrast(values, xz, axis: int) -> float:
    """Interchange-zone contrast along ``axis`` (0 = x, 1 = z) of a map: on the line(s) of sites nearest the
    centre across ``axis``, the largest normalised SED minus the mean of the sites nearest the centre along it."""
    n = _norm(values)
    across = np.abs(xz[:, 1 - axis])
    line = np.isclose(across, across.min(), atol=1e-6)
    along = np.abs(xz[line, axis])
    mid = np.isclose(along, along.min(), atol=1e-6)
    return float(n[line].max() - n[line][mid].mean())


def _place(xz_site) -> str:
    """'corner', 'edge' or 'inside'/'outside' for a site (mm from the centre) against the 2 x 2 mm bar's outline."""
    near = [abs(abs(c) - BAR_HALF_MM) <= EDGE_BAND_MM + 1e-9 for c in xz_site]
    if all(near):
        return "corner"
    if any(near):
        return "edge" if all(abs(c) <= BAR_HALF_MM + EDGE_BAND_MM for c in xz_site) else "outside"
    return "inside" if all(abs(c) < BAR_HALF_MM for c in xz_site) else "outside"


def _row(key, finding, study, sample, criterion, holds, note):
    return {"claim": key, "finding": finding, "study": study, "sample": sample, "criterion": criterion,
            "holds": bool(holds), "note": note}


def chapter4_findings(m: dict) -> list[dict]:
    """Every chapter-4 headline claim on the measurements ``m`` of :func:`measure_chapter4`.

    Returns one dict per claim of :data:`CHAPTER4_CLAIMS`, in that order: ``claim`` (the key), ``finding``
    (with the thesis section), ``study``, ``sample`` (the sample's numbers), ``criterion`` (how "holds" is
    decided, thresholds included), ``holds`` (bool) and ``note`` (what the number means; why it may differ).
    A claim whose data the sample lacks (no vibration series) is listed with ``holds`` False and says so.
    """
    maps, pos = m["maps"], m["pos"]
    ra = {(mod, ind): maps[(mod, "ra", ind)] for mod in MODELS for ind in INDENTERS}
    return (_peak_rows(maps, ra) + _map_rows(ra, pos) + _xz_rows(ra, pos) + _scale_rows(ra)
            + _vibration_rows(m.get("vibration")))


def _peak_rows(maps, ra) -> list[dict]:
    out = []
    ratio = {ind: ra[("3d", ind)].max() / ra[("2d", ind)].max() for ind in INDENTERS}
    ratio_sa = {ind: maps[("3d", "sa", ind)].max() / maps[("2d", "sa", ind)].max() for ind in INDENTERS}
    out.append(_row(
        "focalizing", "ch. 4 (4.4.2, 4.5.1): focalizing, the peak SED at the RA-I sites is larger in the 3-D ridged "
        "model than in the 2-D ridged model", "3-D peak > 2-D peak",
        "3-D/2-D peak RA-I SED: " + ", ".join(f"{k} {v:.3f}" for k, v in ratio.items())
        + "; SA-I: " + ", ".join(f"{k} {v:.3f}" for k, v in ratio_sa.items()),
        "ratio > 1 under every one of the four indenters", all(v > 1 for v in ratio.values()),
        "the study attributes the focalizing to the papillae as discrete pegs and to epidermis and dermis of "
        "'significantly different' stiffness (the relaxed dermis during the hold); sample_sed/README.md, "
        "'Chapter 4', measures each reason"))
    return out


def _map_rows(ra, pos) -> list[dict]:
    from .hotspots import map_distance

    out = []
    pairs = [(a, b) for i, a in enumerate(INDENTERS) for b in INDENTERS[i + 1:]]
    dist = {mod: {(a, b): map_distance(ra[(mod, a)], ra[(mod, b)]) for a, b in pairs} for mod in MODELS}
    mean = {mod: float(np.mean(list(dist[mod].values()))) for mod in MODELS}
    out.append(_row(
        "separates", "ch. 4 (4.4.2): the 3-D model's RA-I hot-spot maps tell the four indenters apart better than "
        "the 2-D model's", "3-D separates better", f"mean map distance 1 - r over the six pairs: 3-D {mean['3d']:.4f}, "
        f"2-D {mean['2d']:.4f}", "3-D mean 1 - r > 2-D mean 1 - r", mean["3d"] > mean["2d"],
        "1 - r of the min-max normalised maps over the RA-I table (afferent hotspots, distances.csv)"))
    bg = {mod: dist[mod][("bar", "gap")] for mod in MODELS}
    out.append(_row(
        "solid_vs_gap", "ch. 4 (4.4.2): the 2-D model barely distinguishes the solid bar from the gap indenter",
        "2-D solid vs gap closer than 3-D", f"1 - r bar vs gap: 3-D {bg['3d']:.4f}, 2-D {bg['2d']:.4f}",
        "2-D bar-gap 1 - r < 3-D bar-gap 1 - r", bg["2d"] < bg["3d"],
        "the gap indenter's two bars leave a 1 mm gap; a model that spreads the load fills it"))
    where = {}
    for mod in MODELS:
        v = np.asarray(ra[(mod, "bar")], dtype=float)
        top = np.nanmax(v)  # mirror images tie to round-off (a cropped copy of the mesh differs in the last bits)
        i = int(np.flatnonzero(v >= top - 1e-6 * abs(top))[0])
        where[mod] = (tuple(float(c) for c in pos[(mod, "ra")][i]), _place(pos[(mod, "ra")][i]))
    out.append(_row(
        "edges_vs_corners", "ch. 4 (4.4.2): under the bar the RA-I peak sits at the indenter's edges in the 3-D model, "
        "at its corners in the 2-D model", "3-D edge, 2-D corner",
        "; ".join(f"{mod.upper()} peak at (dx, dz) = ({p[0]:+.2f}, {p[1]:+.2f}) mm: {k}" for mod, (p, k) in where.items()),
        f"corner: within {EDGE_BAND_MM:g} mm of both edge lines of the 2 x 2 mm bar; edge: of one only",
        where["3d"][1] == "edge" and where["2d"][1] == "corner",
        "the largest site of the RA-I table under the bar (mirror images are equal: of the sites within 1e-6 of the "
        "largest, the first in the table's order)"))
    zone = {}
    for mod in MODELS:
        n, xz = _norm(ra[(mod, "bar")]), pos[(mod, "ra")]
        r = np.hypot(xz[:, 0], xz[:, 1])
        centre = float(n[np.isclose(r, r.min(), atol=1e-6)].mean())
        zone[mod] = (centre, _place(xz[int(np.argmax(n))]) in ("edge", "corner"))
    out.append(_row(
        "interchange_zone", "ch. 4 (4.4.2): interchange zone, SED peaks near the bar's edges with a valley at its centre",
        "peak-valley-peak in both models",
        "; ".join(f"{mod.upper()}: centre sites at {c:.2f} of the range, peak {'at' if e else 'not at'} the outline"
                  for mod, (c, e) in zone.items()),
        f"the sites nearest the centre below the hot-spot threshold {HOT:g} and the peak within {EDGE_BAND_MM:g} mm "
        "of the outline, in both models", all(c < HOT and e for c, e in zone.values()),
        "RA-I table under the 2 x 2 mm bar, min-max normalised"))
    return out


def _xz_rows(ra, pos) -> list[dict]:
    out = []
    con = {mod: (_contrast(ra[(mod, "bar")], pos[(mod, "ra")], 0), _contrast(ra[(mod, "bar")], pos[(mod, "ra")], 1))
           for mod in MODELS}
    txt = "; ".join(f"{mod.upper()} along x {cx:.3f}, along z {cz:.3f}" for mod, (cx, cz) in con.items())
    what = ("contrast = largest normalised SED on the central line minus its centre sites (RA-I table, bar)")
    out.append(_row(
        "x_equal", "ch. 4 (4.4.2): the interchange zone is equally noticeable along x (across the ridges) in both "
        "models", "x contrast 3-D = 2-D", txt, f"|3-D - 2-D| of the x contrast <= {MARGIN:g}",
        abs(con["3d"][0] - con["2d"][0]) <= MARGIN, what))
    out.append(_row(
        "z_more_3d", "ch. 4 (4.4.2): the interchange zone is more significant along z (along the ridges) in the 3-D "
        "model than in the 2-D model", "z contrast 3-D > 2-D", txt, f"3-D z contrast > 2-D z contrast + {MARGIN:g}",
        con["3d"][1] > con["2d"][1] + MARGIN, what))
    out.append(_row(
        "x_more_than_z", "ch. 4 (4.5.2): in the 3-D model the interchange zone is more marked along x than along z",
        "x contrast > z contrast (3-D)", txt, f"3-D x contrast > 3-D z contrast + {MARGIN:g}",
        con["3d"][0] > con["3d"][1] + MARGIN, what))
    return out


def _scale_rows(ra) -> list[dict]:
    peak = ra[("3d", "bar")].max()
    lo, hi = STUDY_BAR_SED_PA / SED_FACTOR, STUDY_BAR_SED_PA * SED_FACTOR
    return [_row(
        "sed_scale", "ch. 4 (fig. 4-7): SED scale under the 2 x 2 mm bar 0.5 mm deep", f"~{STUDY_BAR_SED_PA:g} Pa",
        f"peak RA-I SED 3-D {peak:.0f} Pa, 2-D {ra[('2d', 'bar')].max():.0f} Pa",
        f"3-D within {SED_FACTOR:g}x: {lo:g}-{hi:g} Pa", lo <= peak <= hi,
        "the figure's colour scale; a magnitude, so mesh, moduli and relaxation all move it")]


def _vibration_rows(vib) -> list[dict]:
    out = []
    fs = FREQUENCIES_HZ
    for mod, key, claim in (("3d", "vibration_3d_rises", "rises from 20 to 80 Hz"),
                            ("2d", "vibration_2d_flat", "stays flat from 20 to 80 Hz")):
        finding = (f"ch. 4 (figs. 4-10, 4-11): at fixed amplitude the SED at the RA-I site near the plane's edge, at "
                   f"the deepest point, {claim} in the {mod.upper()} model")
        crit = (f"rises at every step and by > {FLAT_REL:.0%} from 20 to 80 Hz" if mod == "3d"
                else f"changes by <= {FLAT_REL:.0%} from 20 to 80 Hz")
        if not vib:
            out.append(_row(key, finding, claim, "not measured: the sample has no vibration/ series", crit, False,
                            "run on sample_sed/ of a source checkout (afferent demo --sample-dir sample_sed)"))
            continue
        first = np.array([vib[mod][f][0] for f in fs])
        last = np.array([vib[mod][f][1] for f in fs])
        rel = first[-1] / first[0] - 1
        holds = bool(np.all(np.diff(first) > 0) and rel > FLAT_REL) if mod == "3d" else abs(rel) <= FLAT_REL
        out.append(_row(
            key, finding, claim, f"first deepest point {', '.join(f'{v:.1f}' for v in first)} Pa at "
            f"{', '.join(map(str, fs))} Hz ({rel:+.1%}); last deepest point {last[-1] / last[0] - 1:+.1%}", crit, holds,
            "the study's example deepest point (t = 0.005 s at 50 Hz) is in the first cycle; the site: largest SED "
            "at the last deepest point within 0.22 mm of the plane's outline (afferent cycles)"))
    return out
