"""Write the SYNTHETIC "observed" afferent profiles used by the calibration examples and tests.

These are NOT recordings. They are the model's own longitudinal-section afferent profile on the
bundled FE sample (1.32 mm indenter, block4), computed with known transduction parameters
and perturbed by seeded Gaussian noise, so that a calibration can be checked to recover them:

    TRUE_PARAMS: alpha = 3.0e-8 A, gamma = 8.0e-3 1/Pa, lambda = 250 Pa (the midpoint inside the sample's
    receptor SED at 1.32 mm, 12-572 Pa, as 900 Pa was inside the 20-2400 Pa of the sample before issue 21)
    noise: 2 % of the profile's maximum, numpy default_rng(1321)

Run from the repository root:  python sample_sed/observed/make_observed.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import afferent
from afferent.synthesis import Branching
from afferent.transduction import SigmoidParams

HERE = Path(__file__).resolve().parent
BLOCK = HERE.parent / "block4"
TRUE_PARAMS = SigmoidParams(alpha=3.0e-8, gamma=8.0e-3, lambda_=250.0)
NOISE = 0.02
SEED = 1321


def main():
    field = afferent.read_sed(str(BLOCK / "indent_1p32mm.vtu"), length_unit="mm", sed_unit="MPa")
    layout = afferent.read_receptors(BLOCK / "receptors.csv", length_unit="mm")
    sed = afferent.sample_sed(field, layout, method="linear")
    current = afferent.transduce(sed, TRUE_PARAMS)
    rng = np.random.default_rng(SEED)
    for kind, branching in (("longitudinal", Branching.longitudinal(layout)), ("cross", Branching.cross(layout))):
        aff = afferent.synthesize(current, branching)
        profile = aff.values[-1]
        noisy = profile + NOISE * profile.max() * rng.standard_normal(profile.size)
        axis = "x" if kind == "longitudinal" else "z"
        path = HERE / f"synthetic_1p32mm_{kind}.csv"
        with open(path, "w") as f:
            f.write(f"# SYNTHETIC data, not a recording: afferent current ({kind} sections) along {axis} for the 1.32 mm\n")
            f.write(f"# indenter of sample_sed/block4, alpha={TRUE_PARAMS.alpha} A, gamma={TRUE_PARAMS.gamma} 1/Pa, "
                    f"lambda={TRUE_PARAMS.lambda_} Pa, + {NOISE:.0%} Gaussian noise (seed {SEED}); see make_observed.py.\n")
            f.write("# position in mm, response in nA\n")
            f.write("position,response\n")
            for p, r in zip(aff.positions * 1e3, noisy * 1e9):
                f.write(f"{p:.6g},{r:.6g}\n")
        print(f"wrote {path.relative_to(HERE.parent.parent)}")


if __name__ == "__main__":
    main()
