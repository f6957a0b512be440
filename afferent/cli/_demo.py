"""Run the main job on the FE sample shipped with the package: every indenter, SED -> receptors -> afferents.

The sample is ``afferent/data/sample/`` (installed with the package, so the demo runs from a
wheel): a crop of the source repository's FE sample ``sample_sed/`` to the elements around the
receptors, whose SED at the receptors is the full sample's (its README.md says how it was made).
``--sample-dir sample_sed`` (or ``$AFFERENT_SAMPLE_DIR``) runs the demo on the full sample of a
source checkout instead, with the same results.

For each square indenter of the sample (0.44-2.0 mm on the 4 mm block, 4 mm on the 8 mm
block) the static pipeline runs with the study's start parameters (``STUDY_PARAMS['start']``)
and longitudinal synthesis, writing one folder per indenter (as ``afferent run`` does), plus:

- ``summary.csv``: per indenter, SED at the receptors (max, median), whether the SED along the
  central cross-section shows an interchange zone (peak-valley-peak), and how many peaks the
  longitudinal and cross-section afferent profiles have;
- ``indenters_x.png``: normalised receptor SED and longitudinal afferent current along x for
  every indenter on one figure (the study's chapter-5 comparison);
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
    parser.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="output folder (created whole, or not at all)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output folder")
    parser.add_argument("--sample-dir", metavar="DIR",
                        help="the sample folder, laid out as sample_sed/ (default: the sample installed with the package, "
                             "a crop of sample_sed/ with the same SED at the receptors)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress output")


def count_peaks(profile, *, rel_prominence: float = 0.05) -> int:
    """Number of local maxima of a 1-D profile standing out by at least ``rel_prominence`` of its range
    (scipy.signal.find_peaks; plateau ends count once)."""
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


def _run_case(sample: Path, sample_record: dict, case, folder: str):
    """One indenter through the static pipeline, written into ``folder``; its summary row and profiles."""
    from ..export import write_pipeline_outputs
    from ..io import read_sed
    from ..pipeline import run_pipeline
    from ..receptors import central_line, read_receptors
    from ..synthesis import Branching, synthesize
    from ..transduction import STUDY_PARAMS

    name, block, fname, width = case
    path = sample / block / fname
    if not path.is_file():
        raise AfferentError(f"Sample file {str(path)!r} is missing: expected the layout of sample_sed/ "
                            "(block4/, block8/, scenes/); regenerate with 'make samples'.")
    params = STUDY_PARAMS["start"]
    field = read_sed(str(path), length_unit="mm", sed_unit="MPa")
    layout = read_receptors(sample / block / "receptors.csv", length_unit="mm")
    res = run_pipeline(field, layout, params, synthesis="longitudinal")
    record = {"command": "afferent demo", "case": name, "indenter_mm": width, "sample": sample_record,
              "field": field.provenance.to_dict(),
              "transduction": {"alpha_a": params.alpha, "gamma_per_pa": params.gamma, "lambda_pa": params.lambda_,
                               "source": "the study's start parameters, afferent.transduction.STUDY_PARAMS['start']"}}
    write_pipeline_outputs(res, os.path.join(folder, name), record=record)
    idx, coord, _ = central_line(layout, "x")
    sed_line = res.sed.values[-1, idx]
    cross = synthesize(res.current, Branching.cross(layout))
    lon = res.afferent.values[-1]
    row = {
        "case": name, "indenter_mm": width,
        "sed_max_pa": float(res.sed.values.max()), "sed_median_pa": float(np.median(res.sed.values)),
        "sed_peaks_central_x": count_peaks(sed_line),
        "interchange_zone": count_peaks(sed_line) >= 2,
        "afferent_peaks_longitudinal": count_peaks(lon),
        "afferent_peaks_cross": count_peaks(cross.values[-1]),
        "fraction_sensitive": res.saturation.fraction_sensitive,
    }
    return row, (width, coord - coord.mean(), sed_line, res.afferent.positions - res.afferent.positions.mean(), lon)


def _plot_indenters(profiles, path: str) -> None:
    """``indenters_x.png``: normalised receptor SED and longitudinal afferent current along x, every indenter."""
    import matplotlib.pyplot as plt

    from .. import plotting
    from ..profiles import minmax_normalise

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), layout="constrained", sharey=True)
    for width, x, sed_line, xa, lon in profiles:
        axes[0].plot(x * 1e3, minmax_normalise(sed_line), "o-", ms=3, label=f"{width:g} mm")
        axes[1].plot(xa * 1e3, minmax_normalise(lon), "^-", ms=3, label=f"{width:g} mm")
    axes[0].set_title("SED at receptors, central cross-section")
    axes[1].set_title("afferent current, longitudinal sections")
    for ax in axes:
        ax.set_xlabel("x from the indenter centre (mm)")
        ax.legend(title="indenter", fontsize="small")
    axes[0].set_ylabel("normalised (min-max)")
    plotting.save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    import pandas as pd

    from ..scene import load_scene, run_scene

    sample, sample_record = _sample(args)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    say(f"afferent demo: sample {str(sample)!r}" + (" (installed with the package)" if sample_record["packaged"] else ""))
    rows, profiles = [], []
    with atomic_dir(args.output, overwrite=args.overwrite, inputs=(sample,)) as tmp:
        for case in CASES:
            say(f"afferent demo: {case[0]} ...")
            row, profile = _run_case(sample, sample_record, case, tmp)
            rows.append(row)
            profiles.append(profile)
        pd.DataFrame(rows).to_csv(os.path.join(tmp, "summary.csv"), index=False)
        _plot_indenters(profiles, os.path.join(tmp, "indenters_x.png"))
        scene_path = sample / "scenes" / "spikes_ramp.toml"
        say(f"afferent demo: scene {scene_path.name} ...")
        spikes = run_scene(load_scene(scene_path).with_output(os.path.join(tmp, "spikes_ramp")), use_cache=False)
    say(pd.DataFrame(rows).to_string(index=False))
    n = sum(len(t) for t in spikes.spikes.spike_times)
    say(f"spikes_ramp: {n} spikes from {len(spikes.spikes.spike_times)} afferents (rate-sensitive input: onset and release)")
    say(f"afferent demo: wrote {args.output}")
    return 0
