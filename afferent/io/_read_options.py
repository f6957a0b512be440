"""What the user declares about an export (:class:`ReadOptions`) and the default tolerances of the checks.

Used by :mod:`afferent.io._assemble`, which re-exports these names.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._validation import check_option
from ..strain_energy import PRESETS

#: Default tolerance for negative SED. FE tools compute SED at integration points and
#: extrapolate/average it to the nodes (CalculiX ENER in the .frd, Abaqus unique-nodal
#: averaging, ANSYS PowerGraphics); near steep gradients the extrapolation overshoots below
#: zero. Measured on real CalculiX 2.20 indentation models (tests/data/calculix and finer
#: versions of them): the most negative nodal ENER is -0.02 x the largest for C3D8 meshes at
#: every resolution tried (the punch edge is a singularity: refining does not remove it) and
#: -0.10 to -0.16 x for quadratic C3D20R/C3D10 meshes; the negative values sum to at most 0.093
#: x the positive ones. A wrong column (a stress or displacement component, a flipped sign)
#: is negative over a large share of the field. So negatives are accepted when both the most
#: negative value and the sum of the negatives are at most this fraction of, respectively, the
#: largest SED and the sum of the positive values; they are then counted, reported and set to 0
#: (SED >= 0 for an elastic solid). Anything else is refused.
NEGATIVE_SED_RTOL = 0.25

SED_FROM = ("field", "exact", "equivalent", "stress")

#: The confirmations (:data:`afferent._validation.ACCEPTS`) that change what a read lets through (``accept=``).
READ_ACCEPTS = ("modulus", "sed-column", "large-strain")

#: Relative L2 difference (at the most loaded step, after the best scale factor) above which
#: the SED computed from an export's tensors and the export's own SED array are said to
#: disagree. They agree to the file's precision only where both are values at the same points
#: (CalculiX .dat integration points: 6e-7; DOLFINx DG0 interpolations and the bundled
#: scikit-fem sample at cell centroids: round-off). Wherever either is an average they cannot:
#: 1/2 sigma:eps of averaged tensors is not the average of 1/2 sigma:eps. Measured on real
#: files: CalculiX nodal ENER vs nodal tensors 8-40 % (tests/data/calculix), SfePy element
#: averages ('el_avg' tensors vs its element-average energy) 9 % (tests/data/sfepy) - as large
#: as what a wrong shear convention does (15-40 %). So this comparison flags only gross errors
#: (a wrong column, a mismatched unit shows in the recorded scale); the shear convention is
#: checked by :func:`shear_consistency`, which averaging does not disturb.
CROSSCHECK_RTOL = {"cell": 0.5, "point": 0.5}

#: An array named like an energy (ELSE, SENE, Kratos' STRAIN_ENERGY) is read as a density when the
#: export's tensors say so: 1/2 sigma:eps agrees with it within :data:`CROSSCHECK_RTOL` under some
#: preset, with a least-squares scale in this band. An element energy is the density times the
#: element volume: its scale is that volume in the file's length unit cubed (1.25e-10 for the 0.5 mm
#: hexahedra of tests/data/kratos written in m), far outside the band unless the elements' volumes
#: are near 1 in the file's unit (then the name decides: refused, and sed_column= confirms).
#: Measured on Kratos 10.4.4 (tests/data/kratos): STRAIN_ENERGY vs its own tensors, point data
#: relative 0.12-0.16 at scale 1.11-1.36, cell data 0.12-0.13 at scale 0.85-1.19.
DENSITY_SCALE_BAND = (0.5, 2.0)

#: Accepted range of the shear-to-normal stiffness ratio of :func:`shear_consistency`: 1 when the
#: strain's shear is read with the right convention, 0.5 when engineering shear is read as
#: tensor shear, 2 for the reverse; the band's edges are the geometric midpoints.
SHEAR_RATIO_BAND = (2 ** -0.5, 2 ** 0.5)

#: Largest strain magnitude |eps| = sqrt(eps:eps) (any row, shear as read) of a step the tensor
#: checks judge when the strain is a finite-strain measure (:data:`afferent.io._columns.FINITE_STRAIN_NAMES`:
#: Green-Lagrange, logarithmic). Both checks rest on linear elasticity; at finite strain the tool
#: pairs Cauchy stress (deformed frame) with a strain of the reference frame and its SED is the
#: hyperelastic W, so the shear/normal stiffness ratio drifts with the strain, a rotation alone
#: moves it, and 1/2 sigma:eps departs from W. Measured on FEBio files (ratio at each step, against
#: the step's largest |eps|): a neo-Hookean block pressed 25 % and slid 20 % (FEBio 4.11) 0.88 at
#: 0.04, 0.82 at 0.11, 0.71 (the band's edge) at 0.26, 0.57 at 0.47; pressed only, 0.92 at 0.05,
#: 0.90 at 0.10, 0.71 at 0.44; a St Venant-Kirchhoff beam bent by a pressure (febio-python's
#: hexbeam, FEBio 3.4) 1.08 at 0.05, 1.14 at 0.10, 1.42 at 0.35. Within 0.1 the drift stays
#: under 20 %, so a right convention stays inside :data:`SHEAR_RATIO_BAND` and a wrong one (x 0.5
#: or x 2) outside it; beyond it a right convention can look wrong. Steps beyond the bound are
#: not judged; a file with no step within it is "not checkable".
SMALL_STRAIN_BOUND = 0.1

#: A scalar read as SED where the export has stress and strain tensors at its location is
#: 1/2 sigma:eps of them up to a unit factor 1000^k: its least-squares scale over 1/2 sigma:eps
#: (:func:`afferent.io._export_checks.tensor_sed_crosscheck`), divided by the nearest power of
#: 1000, lies in this band. Measured on the 14 real exports of tests/data with an SED array beside
#: their tensors (CalculiX nodal ENER, .dat energies, DOLFINx, FEBio, FreeFEM, Kratos, code_aster
#: MED, NGSolve, SfePy): 0.44 (CalculiX C3D20R nodal ENER) .. 1.34. A stress measure (von Mises,
#: a principal stress) is about 1/eps x 1/2 sigma:eps, 10..1000 x at strains of 0.1 %..10 %: refused
#: unless its scale happens to fall near a power of 1000 (then the stiffness check sees it).
SED_SCALE_BAND = (0.2, 5.0)


@dataclass(frozen=True)
class ReadOptions:
    """Everything a user may declare when reading an export (see :func:`afferent.read_sed`)."""

    length_unit: str | None = None
    sed_unit: str | None = None
    stress_unit: str | None = None
    time_unit: str | None = None
    sed_from: str = "field"
    poisson: float | None = None
    preset: str | None = None
    shear: str | None = None
    location: str | None = None
    sed_column: str | tuple[str, ...] | None = None
    stress_columns: str | tuple[str, ...] | None = None
    strain_columns: str | tuple[str, ...] | None = None
    coord_columns: tuple[str, str, str] | None = None
    times: tuple[float, ...] | None = None
    coordinates: str | None = None
    on_nan: str = "raise"
    negative_tolerance: float = NEGATIVE_SED_RTOL
    allow_outside_files: bool = False
    accept: frozenset = frozenset()
    elastic: tuple[float, float] | None = None
    modulus_unit: str | None = None
    materials: str | None = None
    material_array: str | None = None

    def __post_init__(self):
        check_option("sed_from", self.sed_from, SED_FROM)
        if self.preset is not None:
            check_option("preset", self.preset, tuple(PRESETS))
        if self.shear is not None:
            check_option("shear", self.shear, ("tensor", "engineering"))
        if self.location is not None:
            check_option("location", self.location, ("point", "cell"))
        check_option("on_nan", self.on_nan, ("raise", "drop"))
        tol = self.negative_tolerance
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 <= tol < 1):
            raise ValueError(f"'negative_tolerance' must be a number in [0, 1) (a fraction of the largest SED); got {tol!r} instead.")
        if not isinstance(self.allow_outside_files, bool):
            raise ValueError(f"'allow_outside_files' must be True or False; got {self.allow_outside_files!r} instead.")
        if self.sed_from == "equivalent" and self.poisson is None:
            raise ValueError(
                "sed_from='equivalent' needs Poisson's ratio: pass poisson=NU (the study's skin model uses 0.48)."
            )
        if self.poisson is not None and not (-1 < float(self.poisson) <= 0.5):
            raise ValueError(f"'poisson' must be in (-1, 0.5]; got {self.poisson!r} instead.")
        self._check_elastic()

    def _check_elastic(self) -> None:
        """``sed_from='stress'`` takes exactly one of ``elastic`` and ``materials``; neither applies otherwise."""
        given = [k for k in ("elastic", "materials", "modulus_unit") if getattr(self, k) is not None]
        if self.sed_from != "stress":
            if given:
                raise ValueError(f"{given[0]!r} applies to sed_from='stress' (SED from stress alone); got "
                                 f"sed_from={self.sed_from!r}.")
            return
        if (self.elastic is None) == (self.materials is None):
            raise ValueError("sed_from='stress' needs the elastic constants: elastic=(E, NU) with modulus_unit= for a "
                             "homogeneous model, or materials='materials.csv' (columns material, E, nu) - one of them"
                             + ("; got both." if self.elastic is not None else "."))
        if self.elastic is not None:
            pair = self.elastic
            if isinstance(pair, (str, bytes)) or not hasattr(pair, "__len__") or len(pair) != 2 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in pair):
                raise ValueError(f"'elastic' must be a pair (E, nu) of numbers; got {pair!r} instead.")
        if self.poisson is not None:
            raise ValueError("'poisson' applies to sed_from='equivalent'; with sed_from='stress' give nu in elastic= "
                             "or in the materials table.")
