"""Benchmark: model evaluations and wall time of each calibration method on the bundled FE sample.

Run from the repository root:  python benchmarks/bench_calibration.py [--repeat 3]

Data: SED at the 119 receptors of sample_sed/block4 (1.32 mm indenter; 12-572 Pa since issue 21), longitudinal
sections (7 afferents), from the study's start (2.46e-8 A, 4.6e-3 1/Pa, 300 Pa). Profiles:

* ``noisy``: sample_sed/observed/synthetic_1p32mm_longitudinal.csv (the model's own profile for
  alpha 3e-8 A, gamma 8e-3 1/Pa, lambda 250 Pa plus 2 % noise; it leaves gamma and lambda on a
  ridge, so the reference slides along it);
* ``clean g.. l..``: noise-free profiles of known (3e-8 A, gamma, lambda), compared min-max
  normalised ('both': gamma and lambda fitted) and un-normalised ('neither': alpha too).

Methods: rsm1 (the study's, the default), rsm2, and the least-squares reference before the
closed-form Jacobian (``jac='2-point'`` finite differences, ``restarts='always'``: every one of
the 4 starts, as the reference ran before) and after it (``jac='analytic'``, one start, random
restarts only when it fails). Columns: ``evals`` model evaluations (transduce -> synthesize ->
compare), ``jac`` closed-form Jacobian evaluations (each about one model evaluation), ``time_ms``
best of ``--repeat`` wall times of ``calibrate`` (identifiability check included), and the
relative errors of the fitted parameters against the known ones (clean profiles only; measured by
:func:`afferent.report.measure_calibration`, as ``afferent report`` does).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # measure this checkout's afferent, not whichever one is installed

import afferent  # noqa: E402
from afferent.calibration import calibrate  # noqa: E402
from afferent.profiles import read_observed  # noqa: E402
from afferent.report import CALIBRATION_METHODS, CALIBRATION_TRUTHS, best_time, measure_calibration  # noqa: E402

BLOCK = ROOT / "sample_sed" / "block4"
TRUTHS = CALIBRATION_TRUTHS  # (alpha A, gamma 1/Pa, lambda Pa)
LABELS = {"least_squares (2-point, 4 starts)": "ls before (2-point, 4 starts)", "least_squares": "ls after (analytic, 1 start)"}
METHODS = {LABELS.get(k, k): v for k, v in CALIBRATION_METHODS.items()}
HEADER = (f"{'profile':<18} {'normalise':<9} {'method':<30} {'evals':>5} {'jac':>4} {'time_ms':>8} {'ssd':>10} "
          f"{'status':<9} {'err_alpha':>9} {'err_gamma':>9} {'err_lambda':>10}")


def _err(x):
    return "-" if x is None else f"{x:.1e}"


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3, help="wall time: best of N runs (default 3)")
    args = ap.parse_args(argv)
    print(f"# command: python benchmarks/bench_calibration.py {' '.join(sys.argv[1:] if argv is None else argv)}")
    print(HEADER)
    field = afferent.read_sed(str(BLOCK / "indent_1p32mm.vtu"), length_unit="mm", sed_unit="MPa")
    sed = afferent.sample_sed(field, afferent.read_receptors(BLOCK / "receptors.csv", length_unit="mm"))
    noisy = read_observed(ROOT / "sample_sed" / "observed" / "synthetic_1p32mm_longitudinal.csv", length_unit="mm")
    for label, kwargs in METHODS.items():
        def fit():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return calibrate(sed, noisy, normalise="both", **kwargs)

        t, res = best_time(fit, args.repeat)
        print(f"{'noisy':<18} {'both':<9} {label:<30} {res.n_evaluations:>5} {res.n_jacobian_evaluations:>4} "
              f"{1e3 * t:>8.1f} {res.ssd:>10.3g} {res.status:<9} {'':>9} {'':>9} {'':>10}")
    for truth in TRUTHS:  # noise-free profiles of known parameters: afferent report's measurement
        for r in measure_calibration(sed, (truth,), repeat=args.repeat):
            name = f"clean g{truth[1]:g} l{truth[2]:g}"
            print(f"{name:<18} {r['normalise']:<9} {LABELS.get(r['method'], r['method']):<30} {r['evaluations']:>5} "
                  f"{r['jacobian_evaluations']:>4} {1e3 * r['time_s']:>8.1f} {r['ssd']:>10.3g} {r['status']:<9} "
                  f"{_err(r['err_alpha']):>9} {_err(r['err_gamma']):>9} {_err(r['err_lambda']):>10}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
