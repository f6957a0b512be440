"""Run the field's own checkers on a run's outputs: compliance-checker and cfchecks on ``currents.nc``,
nwbinspector on ``spikes.nwb`` (issue 37).

    python benchmarks/check_outputs.py [RUN_FOLDER] [--bin DIR] [--cf-tables DIR]

Without a folder, a run of the bundled sample is made first in a temporary folder (block4, receptors.csv,
a ramp-and-hold waveform, spikes, ``--nwb``; its ``spikes.nwb`` therefore has no ``[nwb]`` metadata and
nwbinspector names what is missing). The checkers are command-line tools found in ``--bin`` (a virtual
environment's ``bin``), else on the PATH; install them apart from the project's environment::

    python3.11 -m venv /tmp/checkers && /tmp/checkers/bin/pip install compliance-checker cfchecker nwbinspector

compliance-checker and nwbinspector are also in the ``test`` extra: tests/test_field_tools.py and
tests/test_nwb.py run them in ``make test``. cfchecks is not: it needs the UDUNITS-2 C library (a system
package, ``libudunits2-0`` on Debian, not a wheel) and downloads the CF standard-name, area-type and
region tables at every run unless given files (``--cf-tables DIR`` holding ``cf-standard-name-table.xml``,
``area-type-table.xml`` and ``standardized-region-list.xml``). cfchecker 4.1.0 knows CF up to 1.8: it says
it cannot determine the version of a CF-1.11 file and checks it against CF-1.8.

Exit status 1 when compliance-checker (CF 1.11) reports a high or medium finding, nwbinspector one above
BEST_PRACTICE_SUGGESTION on a file written with ``[nwb]`` metadata, or cfchecks stops before its summary.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def sample_run(folder: Path) -> Path:
    """A ramp run of the bundled block4 sample with spikes and NWB into ``folder/run``."""
    sample = ROOT / "afferent" / "data" / "sample" / "block4"
    out = folder / "run"
    subprocess.run([sys.executable, "-m", "afferent", "run", str(sample / "indent_0p88mm.vtu"), "--receptors",
                    str(sample / "receptors.csv"), "--length-unit", "mm", "--sed-unit", "MPa", "--params", "start",
                    "--waveform", "ramp:0.5,5,0.2", "--d-ref-mm", "0.88", "--spikes", "--drive", "rheobase", "--nwb",
                    "--no-plots", "--no-cache", "-q", "-o", str(out)], check=True)
    return out


def tool(name: str, bin_dir) -> str | None:
    """The command ``name`` in ``bin_dir``, else on the PATH, else None."""
    if bin_dir is not None and (Path(bin_dir) / name).is_file():
        return str(Path(bin_dir) / name)
    return shutil.which(name)


def check(title: str, argv: list[str], bad) -> bool:
    """Run ``argv``, print its output; True when ``bad(output)`` finds nothing wrong."""
    print(f"\n=== {title}\n$ {' '.join(argv)}", flush=True)
    done = subprocess.run(argv, capture_output=True, text=True)
    text = done.stdout + done.stderr
    print(text.strip()[-6000:])
    problem = bad(text)
    print(f"--> {'OK' if not problem else problem}")
    return not problem


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", nargs="?", help="a run's output folder (default: a run of the bundled sample)")
    ap.add_argument("--bin", help="folder of the checkers' commands (a virtual environment's bin)")
    ap.add_argument("--cf-tables", help="folder with the CF tables cfchecks would download")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.folder) if args.folder else sample_run(Path(tmp))
        ok = True
        nc, nwb = folder / "currents.nc", folder / "spikes.nwb"
        cc = tool("compliance-checker", args.bin)
        if cc and nc.is_file():
            for version in ("1.11", "1.10"):
                ok &= check(f"compliance-checker, CF {version}", [cc, "--test", f"cf:{version}", str(nc)],
                            lambda t, v=version: (("Errors" in t or "Warnings" in t) and v == "1.11"
                                                  and "high or medium findings"))
        cf = tool("cfchecks", args.bin)
        if cf and nc.is_file():
            tables = []
            if args.cf_tables:
                d = Path(args.cf_tables)
                tables = ["-s", str(d / "cf-standard-name-table.xml"), "-a", str(d / "area-type-table.xml"),
                          "-r", str(d / "standardized-region-list.xml")]
            ok &= check("cfchecks", [cf, *tables, "-v", "auto", str(nc)],
                        lambda t: "ERRORS detected" not in t and "cfchecks stopped before its summary")
        inspector = tool("nwbinspector", args.bin)
        if inspector and nwb.is_file():
            check("nwbinspector", [inspector, str(nwb)], lambda t: None)
        missing = [n for n, c in (("compliance-checker", cc), ("cfchecks", cf), ("nwbinspector", inspector)) if not c]
        if missing:
            print(f"\nnot found (--bin or PATH): {', '.join(missing)}")
    return 0 if ok else 1


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
