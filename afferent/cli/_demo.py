"""Run the main job on the FE sample shipped with the package: every indenter, SED -> receptors -> afferents.

The sample is ``afferent/data/sample/`` (installed with the package, so the demo runs from a
wheel): a crop of the source repository's FE sample ``sample_sed/`` to the elements around the
receptors, whose SED at the receptors is the full sample's (its README.md says how it was made).
``--sample-dir sample_sed`` (or ``$AFFERENT_SAMPLE_DIR``) runs the demo on the full sample of a
source checkout instead, with the same results.

Each square indenter of the sample (0.44-2.0 mm on the 4 mm block, 4 mm on the 8 mm block) is
one scene (``case_scene``: the study's start parameters, ``STUDY_PARAMS['start']``, and
longitudinal synthesis) run by ``afferent.scene.run_scene``, the planner, writer and run record
of ``afferent run``: one folder per indenter holds what ``afferent run`` writes for that scene
(the time courses as CSV tables) and its ``run.json``. Then:

- ``summary.csv``: per indenter, SED at the receptors (max, median; the max over the study's peak
  ``STUDY_PEAK_SED_PA``), whether the SED along the central cross-section shows an
  interchange zone (peak-valley-peak), how many peaks the longitudinal and cross-section afferent
  profiles have, and the peak-decision threshold used (``peak_prominence``);
- ``findings.csv``: every headline claim of the study's chapters 4 and 5 beside the sample's number,
  each with its criterion and whether it holds, and why (``study_findings`` for chapter 5 on the
  indenters above, ``afferent.findings`` for chapter 4 on the sample's ``chapter4/`` and
  ``vibration/``); a claim that fails is listed like one that holds; printed and drawn on the figure
  by one function, ``finding_text``, from the rows themselves;
- ``indenters_x.png``: normalised receptor SED and longitudinal afferent current along x for
  every indenter (the study's chapter-5 comparison), with the findings and the threshold;
- ``spikes_ramp/``: the sample's scene ``scenes/spikes_ramp.toml`` (the study's ramp-and-hold on
  the 0.88 mm loading series, RA-I rate-sensitive input, leaky integrate-and-fire spikes).

Example::

    $ afferent demo -o results/demo
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from .._output import atomic_dir
from ..exceptions import AfferentError
from ._options import add_output_options, reads

#: (case name, block folder, file, indenter width mm)
CASES = [
    ("indent_0p44mm", "block4", "indent_0p44mm.vtu", 0.44),
    ("indent_0p66mm", "block4", "indent_0p66mm.vtu", 0.66),
    ("indent_0p88mm", "block4", "indent_0p88mm.vtu", 0.88),
    ("indent_1p10mm", "block4", "indent_1p10mm.vtu", 1.10),
    ("indent_1p32mm", "block4", "indent_1p32mm.vtu", 1.32),
    ("indent_2p00mm", "block4", "indent_2p00mm.vtu", 2.00),
    ("indent_4p00mm", "block8", "indent_4p00mm.vtu", 4.00),
]


def packaged_sample_dir() -> Path:
    """The sample installed with the package, ``afferent/data/sample/`` (lengths mm, SED MPa)."""
    from importlib.resources import files

    return Path(str(files("afferent").joinpath("data", "sample")))


def default_sample_dir() -> Path:
    """``$AFFERENT_SAMPLE_DIR``, else the packaged sample (:func:`packaged_sample_dir`)."""
    env = os.environ.get("AFFERENT_SAMPLE_DIR")
    return Path(env) if env else packaged_sample_dir()


def add_args(parser: argparse.ArgumentParser) -> None:
    add_output_options(parser, what="output folder (created whole, or not at all)", metavar="OUTDIR")
    reads(parser.add_argument("--sample-dir", metavar="DIR",
                              help="the sample folder, laid out as sample_sed/ (default: the sample installed with the "
                                   "package, a crop of sample_sed/ with the same SED at the receptors)"))
    parser.add_argument("--peak-prominence", type=float, default=PEAK_PROMINENCE, metavar="FRACTION",
                        help="a local maximum of a profile counts as a peak when it stands out by this fraction of the "
                             f"profile's range (default {PEAK_PROMINENCE}); recorded in summary.csv, findings.csv and the figure")


#: Default peak-decision threshold (dimensionless): a local maximum of a profile counts as a peak
#: when it stands out from its surroundings by this fraction of the profile's range (max - min).
#: ``afferent demo --peak-prominence`` changes it; summary.csv, findings.csv and the figure record it.
PEAK_PROMINENCE = 0.05
#: The study's peak SED at the papilla tips, Pa: 1.9e-4 MPa, the scale of its figure 4-7 (2 x 2 mm bar,
#: 0.5 mm deep; docs/method.md, "The FE skin model").
STUDY_PEAK_SED_PA = 190.0
#: A sample's peak tip SED "matches" the study's magnitude within this factor either way.
SED_MAGNITUDE_FACTOR = 2.0
#: The narrowest indenter (mm) at which the study sees the interchange zone: 0.66-0.88 mm.
STUDY_INTERCHANGE_FROM_MM = 0.88
#: RA-I afferents fail to resolve stimuli narrower than about this (mm; the study, chapter 5).
RA_RESOLUTION_MM = 3.0


def count_peaks(profile, *, rel_prominence: float = PEAK_PROMINENCE) -> int:
    """Number of local maxima of a 1-D profile standing out by at least ``rel_prominence`` (a fraction,
    dimensionless) of its range (scipy.signal.find_peaks prominence; plateau ends count once)."""
    from scipy.signal import find_peaks

    p = np.asarray(profile, dtype=float)
    span = p.max() - p.min()
    if span <= 0:
        return 0
    padded = np.concatenate([[p.min() - span], p, [p.min() - span]])  # so edge maxima count
    peaks, _ = find_peaks(padded, prominence=rel_prominence * span)
    return int(peaks.size)


def _sample(args: argparse.Namespace) -> tuple[Path, dict]:
    """The sample folder to run on and its record (``dir``, ``packaged``)."""
    sample = Path(args.sample_dir) if args.sample_dir else default_sample_dir()
    if not (sample / "block4" / "receptors.csv").is_file():
        raise FileNotFoundError(
            f"The FE sample was not found in {str(sample)!r} (expected block4/receptors.csv); "
            "pass --sample-dir or set AFFERENT_SAMPLE_DIR to a folder laid out as sample_sed/."
        )
    packaged = sample.resolve() == packaged_sample_dir().resolve()
    return sample, {"dir": str(sample), "packaged": packaged}


#: What each indenter's scene writes: the tables and figures of ``afferent run`` (time courses as long
#: CSV tables, ``receptors.csv`` and ``afferents.csv``, small enough here to open in a spreadsheet).
CASE_OUTPUTS = {"want": ["currents", "profiles", "sed_map", "vtu", "plots"], "format": "csv"}


def case_scene(sample: Path, case):
    """The scene of one indenter of the sample: the static pipeline with the study's start parameters.

    Parameters
    ----------
    sample : Path
        The sample folder, laid out as ``sample_sed/`` (coordinates mm, SED MPa).
    case : tuple
        One entry of :data:`CASES`: (name, block folder, file, indenter width in mm).

    Returns
    -------
    afferent.scene.Scene
        Not yet resolved, without an output folder (``with_output`` gives it one); the same as a
        scene file with these tables in the sample folder, run by ``afferent run``.

    Raises
    ------
    AfferentError
        The sample has no such file.
    """
    from ..scene import scene_from_dict

    name, block, fname, width = case
    path = sample / block / fname
    if not path.is_file():
        raise AfferentError(f"Sample file {str(path)!r} is missing: expected the layout of sample_sed/ "
                            "(block4/, block8/, scenes/); regenerate with 'make samples'.")
    return scene_from_dict({
        "scene": {"name": name, "description": f"{width:g} mm square indenter 0.5 mm deep: SED -> receptors -> "
                                               "afferents, the study's start parameters, longitudinal synthesis"},
        "export": {"file": f"{block}/{fname}", "length_unit": "mm", "sed_unit": "MPa"},
        "receptors": {"file": f"{block}/receptors.csv"},
        "transduction": {"params": "start"},
        "synthesis": {"kind": "longitudinal"},
        "outputs": dict(CASE_OUTPUTS),
    }, base_dir=sample)


def _run_case(sample: Path, sample_record: dict, case, folder: str, prominence: float = PEAK_PROMINENCE):
    """One indenter's scene (:func:`case_scene`) run into ``folder``/name; its summary row and profiles."""
    from ..receptors import central_line
    from ..scene import run_scene
    from ..synthesis import Branching, synthesize

    name, _, _, width = case
    scene = case_scene(sample, case).with_output(os.path.join(folder, name))
    record = {"command": "afferent demo", "case": name, "indenter_mm": width, "sample": sample_record,
              "peak_prominence": {"value": prominence, "meaning": "a local maximum of a profile counts as a peak when it "
                                  "stands out by this fraction of the profile's range (summary.csv peak counts)"}}
    res = run_scene(scene, use_cache=False, record_extra=record)
    layout = res.sed.layout
    idx, coord, _ = central_line(layout, "x")
    sed_line = res.sed.values[-1, idx]
    cross = synthesize(res.current, Branching.cross(layout))
    lon = res.afferent.values[-1]
    n_sed, n_lon, n_cross = (count_peaks(p, rel_prominence=prominence) for p in (sed_line, lon, cross.values[-1]))
    sed_max = float(res.sed.values.max())
    row = {
        "case": name, "indenter_mm": width,
        "sed_max_pa": sed_max, "sed_median_pa": float(np.median(res.sed.values)),
        "sed_max_over_study": sed_max / STUDY_PEAK_SED_PA,
        "sed_peaks_central_x": n_sed, "interchange_zone": n_sed >= 2,
        "afferent_peaks_longitudinal": n_lon, "afferent_peaks_cross": n_cross,
        "peak_prominence": prominence,
        "fraction_sensitive": res.record["saturation"]["fraction_sensitive"],
    }
    return row, (width, coord - coord.mean(), sed_line, res.afferent.positions - res.afferent.positions.mean(), lon)


def study_findings(rows: list[dict]) -> list[dict]:
    """The study's chapter-5 findings beside the sample's (docs/method.md, "What the study found").

    Parameters
    ----------
    rows : list of dict
        The ``summary.csv`` rows of :func:`run` (one per indenter, keys as there; SED in Pa,
        widths in mm, peak counts decided at the row's ``peak_prominence``).

    Returns
    -------
    list of dict
        One per finding: ``claim`` (a key), ``finding``, ``study``, ``sample``, ``criterion`` (how "holds" is decided,
        thresholds included), ``holds`` (bool) and ``note`` (why the result comes out as it does, for
        the study's geometry; sample_sed/README.md gives the measurements).
    """
    by_w = {round(r["indenter_mm"], 2): r for r in rows}
    prom = rows[0]["peak_prominence"]
    peaks = f"peaks counted at prominence >= {prom:g} of the profile's range"
    two = by_w[2.0]["sed_max_pa"]
    lo, hi = STUDY_PEAK_SED_PA / SED_MAGNITUDE_FACTOR, STUDY_PEAK_SED_PA * SED_MAGNITUDE_FACTOR
    out = [{
        "claim": "ch5_sed_scale", "finding": "peak SED at the papilla tips, 2 mm indenter 0.5 mm deep",
        "study": f"~{STUDY_PEAK_SED_PA:g} Pa (1.9e-4 MPa, figure 4-7 scale)",
        "sample": f"{two:.0f} Pa ({two / STUDY_PEAK_SED_PA:.2f} x); all indenters "
                  f"{min(r['sed_max_pa'] for r in rows):.0f}-{max(r['sed_max_pa'] for r in rows):.0f} Pa",
        "criterion": f"within {SED_MAGNITUDE_FACTOR:g}x: {lo:g}-{hi:g} Pa", "holds": bool(lo <= two <= hi),
        "note": "the study's 190 Pa is the scale of a 2 x 2 mm bar (its figure 4-7); narrower punches put the same "
                "depth on fewer tips and concentrate the SED"}]
    widths = sorted(by_w)
    zone_from = next((w for i, w in enumerate(widths) if all(by_w[v]["interchange_zone"] for v in widths[i:])), None)
    also = [w for w in widths if by_w[w]["interchange_zone"] and (zone_from is None or w < zone_from)]
    sample = "none" if zone_from is None else f"{zone_from:g} mm"
    if also:  # the table's narrower indenters with a zone, not followed by one at every wider indenter
        sample += f" (also at {', '.join(f'{w:g}' for w in also)} mm, not at every wider one)"
    out.append({
        "claim": "ch5_interchange_width",
        "finding": "interchange zone (peak-valley-peak SED across the central x line) from width",
        "study": "0.66-0.88 mm", "sample": sample,
        "criterion": f"appears at <= {STUDY_INTERCHANGE_FROM_MM:g} mm and at every wider indenter; {peaks}",
        "holds": zone_from is not None and zone_from <= STUDY_INTERCHANGE_FROM_MM + 1e-9,
        "note": "the receptor tips sit about 0.65 mm deep and the papilla rows 0.44 mm apart across the ridges: a punch "
                "narrower than about two row pitches puts both edge maxima on the central tip (left panel)"})
    for kind in ("longitudinal", "cross"):
        for w, want in ((0.88, 1), (4.0, 2)):
            got = by_w[w][f"afferent_peaks_{kind}"]
            out.append({
                "claim": f"ch5_peaks_{kind}_{w:g}mm", "finding": f"afferent peaks after {kind} synthesis, {w:g} mm indenter",
                "study": f"{want} (RA-I recordings; the study's longitudinal synthesis)", "sample": str(got),
                "criterion": f"{want} peak(s); {peaks}", "holds": got == want,
                "note": "summing receptors along a section fills a narrow punch's valley and keeps a wide one's"})
    zoned = [w for w in widths if by_w[w]["interchange_zone"] and w < RA_RESOLUTION_MM]
    filled = [w for w in zoned if by_w[w]["afferent_peaks_longitudinal"] == 1]
    out.append({
        "claim": "ch5_branching_fills_zone",
        "finding": "branching explains the recordings: longitudinal synthesis fills the interchange zone's valley of "
                   f"every indenter narrower than {RA_RESOLUTION_MM:g} mm (RA-I afferents do not resolve it)",
        "study": "one afferent peak wherever the receptor SED has two, below ~3 mm",
        "sample": (f"interchange zone at {', '.join(f'{w:g}' for w in zoned)} mm; longitudinal peaks "
                   + ", ".join(f"{by_w[w]['afferent_peaks_longitudinal']} ({w:g} mm)" for w in zoned)) if zoned
        else "no indenter below 3 mm shows an interchange zone: nothing to fill",
        "criterion": f"at least one indenter < {RA_RESOLUTION_MM:g} mm with an interchange zone, and one longitudinal "
                     f"peak at every such indenter; {peaks}",
        "holds": bool(zoned) and filled == zoned,
        "note": "the study's explanation of why RA-I recordings show one peak for narrow stimuli: receptors along a "
                "ridge share an afferent, whose current sums the two edge maxima into one"})
    return out


def finding_text(f: dict, *, why: str = "; why: ") -> str:
    """One finding of :func:`study_findings` as the demo prints it and draws it on ``indenters_x.png`` (one
    source: its values are the findings.csv row's, themselves made from the summary.csv rows): verdict, finding,
    study, sample, criterion, and after ``why`` the note when it does not hold."""
    return (f"[{'holds' if f['holds'] else 'does NOT hold'}] {f['finding']}: study {f['study']}, sample {f['sample']} "
            f"({f['criterion']})" + ("" if f["holds"] else f"{why}{f['note']}"))


def chapter4_rows(sample: Path, say=lambda msg: None) -> list[dict]:
    """The chapter-4 headline claims on the sample's ``chapter4/`` and ``vibration/`` (:mod:`afferent.findings`);
    without ``chapter4/`` every claim is listed as not measured (``holds`` False), none left out."""
    from ..findings import CHAPTER4_CLAIMS, chapter4_findings, measure_chapter4

    say("afferent demo: chapter 4 (3-D and 2-D ridged blocks, four indenters, vibration) ...")
    m = measure_chapter4(sample)
    if m is not None:
        return chapter4_findings(m)
    return [{"claim": k, "finding": f"ch. 4: {k}", "study": "see docs/method.md, 'Chapter 4'",
             "sample": "not measured: the sample has no chapter4/ folder", "criterion": "see afferent.findings",
             "holds": False, "note": "run on sample_sed/ of a source checkout (afferent demo --sample-dir sample_sed)"}
            for k in CHAPTER4_CLAIMS]


def _plot_indenters(profiles, findings: list[dict], path: str) -> None:
    """``indenters_x.png``: normalised receptor SED and longitudinal afferent current along x, every indenter."""
    import matplotlib.pyplot as plt

    from .. import plotting
    from ..profiles import minmax_normalise

    fig = plt.figure(figsize=(11, 6.2), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[4, 2.2])
    axes = top.subplots(1, 2, sharey=True)
    text = "\n".join(finding_text(f, why="\n    why: ") for f in findings)
    bottom.text(0.01, 0.95, "The study's findings on this sample\n" + text, va="top", ha="left", fontsize=7.5,
                family="monospace", wrap=True)
    for width, x, sed_line, xa, lon in profiles:
        axes[0].plot(x * 1e3, minmax_normalise(sed_line), "o-", ms=3, label=f"{width:g} mm")
        axes[1].plot(xa * 1e3, minmax_normalise(lon), "^-", ms=3, label=f"{width:g} mm")
    axes[0].set_title("SED at receptors, central cross-section")
    axes[1].set_title("afferent current, longitudinal sections")
    for ax in axes:
        ax.set_xlabel("x from the indenter centre (mm)")
    plotting.legend_beside(axes[1], title="indenter")  # one box for both panels (same colours), beside the data
    axes[0].set_ylabel("normalised (min-max)")
    plotting.save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    from ..scene import load_scene, run_scene

    if not 0.0 < args.peak_prominence < 1.0:
        raise ValueError(f"--peak-prominence must be a fraction of the profile's range, 0 < p < 1; "
                         f"got {args.peak_prominence!r} instead.")
    sample, sample_record = _sample(args)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    say(f"afferent demo: sample {str(sample)!r}" + (" (installed with the package)" if sample_record["packaged"] else ""))
    rows, profiles = [], []
    with atomic_dir(args.output, overwrite=args.overwrite, inputs=(sample,)) as tmp:
        for case in CASES:
            say(f"afferent demo: {case[0]} ...")
            row, profile = _run_case(sample, sample_record, case, tmp, args.peak_prominence)
            rows.append(row)
            profiles.append(profile)
        pd.DataFrame(rows).to_csv(os.path.join(tmp, "summary.csv"), index=False)
        findings = study_findings(rows) + chapter4_rows(sample, say)
        pd.DataFrame(findings).to_csv(os.path.join(tmp, "findings.csv"), index=False)
        _plot_indenters(profiles, findings, os.path.join(tmp, "indenters_x.png"))
        scene_path = sample / "scenes" / "spikes_ramp.toml"
        say(f"afferent demo: scene {scene_path.name} ...")
        spikes = run_scene(load_scene(scene_path).with_output(os.path.join(tmp, "spikes_ramp")), use_cache=False)
    say(pd.DataFrame(rows).to_string(index=False))
    for f in findings:
        say(finding_text(f))
    n = sum(len(t) for t in spikes.spikes.spike_times)
    say(f"spikes_ramp: {n} spikes from {len(spikes.spikes.spike_times)} afferents (rate-sensitive input: onset and release)")
    say(f"afferent demo: wrote {args.output}")
    return 0
