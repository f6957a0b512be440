"""afferent: from finite-element strain-energy density of skin to tactile afferent signals.

The package's modules are the pipeline's stages (the method they follow: :ref:`method`, docs/method.md)::

    io.read_sed          FE export (CSV/VTU/PVD/XDMF)      -> SEDField        (m, J/m^3, s)
    receptors            receptor CSV / grid               -> ReceptorLayout  (m)
    sampling.sample_sed  SEDField + ReceptorLayout         -> ReceptorSED     (J/m^3)
    transduction         ReceptorSED + SigmoidParams       -> ReceptorCurrent (A)
    synthesis            ReceptorCurrent + Branching       -> AfferentCurrent (A)
    spiking              AfferentCurrent + LIFParams       -> SpikeTrains     (s)

``import afferent`` stays light: stage modules (and their dependencies: pandas, scipy,
meshio, brian2, matplotlib) load on first use of a name below.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

# public name -> module that defines it (PEP 562 lazy loading, as scipy does)
_LAZY = {
    "read_sed": "afferent.io",
    "iter_sed": "afferent.io",
    "SEDField": "afferent.field",
    "Provenance": "afferent.field",
    "ReceptorLayout": "afferent.receptors",
    "read_receptors": "afferent.receptors",
    "sample_sed": "afferent.sampling",
    "sample_steps": "afferent.sampling",
    "ReceptorSED": "afferent.sampling",
    "sed_exact": "afferent.strain_energy",
    "sed_equivalent": "afferent.strain_energy",
    "transduce": "afferent.transduction",
    "SigmoidParams": "afferent.transduction",
    "synthesize": "afferent.synthesis",
    "Branching": "afferent.synthesis",
    "calibrate": "afferent.calibration",
    "CalibrationResult": "afferent.calibration",
    "simulate_lif": "afferent.spiking",
    "LIFParams": "afferent.spiking",
    "sweep": "afferent._sweep",
    "load_results": "afferent.export",
}

__all__ = sorted(_LAZY) + ["__version__"]

#: Stage modules reachable as attributes (``afferent.sampling``), also loaded on first use.
_SUBMODULES = {
    "io", "field", "units", "exceptions", "strain_energy", "receptors", "sampling", "transduction",
    "synthesis", "profiles", "pipeline", "spiking", "plotting", "export", "calibration", "cli",
}


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"afferent.{name}")
    raise AttributeError(f"module 'afferent' has no attribute {name!r}")


def __dir__():
    return __all__ + sorted(_SUBMODULES)
