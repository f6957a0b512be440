"""Benchmark: model evaluations and wall time of each calibration method on the bundled FE sample.

Run from the repository root:  python benchmarks/bench_calibration.py [--repeat 3]

Data: SED at the 119 receptors of sample_sed/block4 (1.32 mm indenter; 22-2374 Pa), longitudinal
sections (7 afferents), from the study's start (2.46e-8 A, 4.6e-3 1/Pa, 300 Pa). Profiles:

* ``noisy``: sample_sed/observed/synthetic_1p32mm_longitudinal.csv (the model's own profile for
  alpha 3e-8 A, gamma 2e-3 1/Pa, lambda 900 Pa plus 2 % noise; it leaves gamma and lambda on a
  ridge, so the reference slides along it);
* ``clean g.. l..``: noise-free profiles of known (3e-8 A, gamma, lambda), compared min-max
  normalised ('both': gamma and lambda fitted) and un-normalised ('neither': alpha too).

Methods: rsm1 (the study's, the default), rsm2, and the least-squares reference before the
closed-form Jacobian (``jac='2-point'`` finite differences, ``restarts='always'``: every one of
the 4 starts, as the reference ran before) and after it (``jac='analytic'``, one start, random
restarts only when it fails). Columns: ``evals`` model evaluations (transduce -> synthesize ->
compare), ``jac`` closed-form Jacobian evaluations (each about one model evaluation), ``time_ms``
best of ``--repeat`` wall times of ``calibrate`` (identifiability check included), and the
relative errors of the fitted parameters against the known ones (clean profiles only).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # measure this checkout's afferent, not whichever one is installed

import afferent  # noqa: E402
from afferent.calibration import calibrate  # noqa: E402
from afferent.profiles import ObservedProfile, read_observed  # noqa: E402
from afferent.synthesis import Branching  # noqa: E402
from afferent.transduction import SigmoidParams  # noqa: E402

BLOCK = ROOT / "sample_sed" / "block4"
TRUTHS = (SigmoidParams(3e-8, 2e-3, 900.0), SigmoidParams(3e-8, 5e-3, 600.0))
METHODS = {
    "rsm1": dict(method="rsm1"),
    "rsm2": dict(method="rsm2"),
    "ls before (2-point, 4 starts)": dict(method="least_squares", jac="2-point", restarts="always"),
    "ls after (analytic, 1 start)": dict(method="least_squares"),
}


def cases():
    field = afferent.read_sed(str(BLOCK / "indent_1p32mm.vtu"), length_unit="mm", sed_unit="MPa")
    sed = afferent.sample_sed(field, afferent.read_receptors(BLOCK / "receptors.csv", length_unit="mm"))
    noisy = read_observed(ROOT / "sample_sed" / "observed" / "synthetic_1p32mm_longitudinal.csv", length_unit="mm")
    yield "noisy", "both", sed, noisy, None
    for truth in TRUTHS:
        aff = afferent.synthesize(afferent.transduce(sed, truth), Branching.longitudinal(sed.layout))
        clean = ObservedProfile(aff.positions, aff.values[-1])
        for normalise in ("both", "neither"):
            yield f"clean g{truth.gamma:g} l{truth.lambda_:g}", normalise, sed, clean, truth


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3, help="wall time: best of N runs (default 3)")
    args = ap.parse_args(argv)
    print(f"# command: python benchmarks/bench_calibration.py {' '.join(sys.argv[1:] if argv is None else argv)}")
    print(f"{'profile':<18} {'normalise':<9} {'method':<30} {'evals':>5} {'jac':>4} {'time_ms':>8} {'ssd':>10} "
          f"{'status':<9} {'err_alpha':>9} {'err_gamma':>9} {'err_lambda':>10}")
    for name, normalise, sed, observed, truth in cases():
        for label, kwargs in METHODS.items():
            times = []
            for _ in range(args.repeat):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    t = time.perf_counter()
                    res = calibrate(sed, observed, normalise=normalise, **kwargs)
                    times.append(time.perf_counter() - t)
            errs = ["", "", ""]
            if truth is not None:
                fitted = (res.params.alpha, res.params.gamma, res.params.lambda_)
                known = (truth.alpha, truth.gamma, truth.lambda_)
                errs = [f"{abs(f / k - 1):.1e}" if p not in res.no_effect else "-"
                        for p, f, k in zip(("alpha", "gamma", "lambda"), fitted, known)]
            print(f"{name:<18} {normalise:<9} {label:<30} {res.n_evaluations:>5} {res.n_jacobian_evaluations:>4} "
                  f"{1e3 * min(times):>8.1f} {res.ssd:>10.3g} {res.status:<9} {errs[0]:>9} {errs[1]:>9} {errs[2]:>10}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
