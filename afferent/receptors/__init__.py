"""Receptor sites (RA-I Meissner corpuscles at dermal-papilla tips, SA-I Merkel cells at the
bases of the intermediate ridges) and their sections.

::

    receptors CSV         --read_receptors--->  ReceptorLayout --sample_sed(field, layout)--> ReceptorSED
    ranges + pitches      --grid_layout------>  ReceptorLayout   (kind: papilla rows or ridge rows)
    FE mesh + layer ids   --interface_sites-->  ReceptorLayout   (kind: tips or bases;
                                                                  sites_from_export: from a file)

Every layout says what its sites are (:attr:`ReceptorLayout.site`: 'RA-I', 'SA-I' or 'file').

All positions are in m.

Axes follow the study: x runs across the fingerprint ridges, z along them, y is the thickness
direction (up, towards the skin surface).
A *longitudinal section* is a line of receptors parallel to the ridges (same x, varying z);
a *cross-section* is a line across them (same z, varying x).

Where the parts live: ``_layout.py`` (:class:`ReceptorLayout`, sections, the receptors file,
:func:`central_line`), ``_grid.py`` (:func:`grid_layout`), ``_tips.py`` (papilla tips and ridge
bases on an FE mesh). Every public name is importable from :mod:`afferent.receptors`.
"""

from __future__ import annotations

from ._grid import PAPILLA_PITCH_M, RIDGE_PITCH_M, grid_layout  # noqa: F401 (constants importable here, as before)
from ._layout import (  # noqa: F401
    SECTION_TOLERANCE_M,
    SITE_KINDS,
    SITE_OF_KIND,
    ReceptorLayout,
    central_line,
    describe_sites,
    group_coordinates,
    read_receptors,
)
from ._tips import (  # noqa: F401
    COORDINATE_NOISE_M,
    MIN_PROMINENCE_M,
    interface_nodes,
    interface_sites,
    interface_tips,
    sites_from_export,
    tips_from_export,
)

__all__ = [
    "ReceptorLayout",
    "central_line",
    "describe_sites",
    "read_receptors",
    "group_coordinates",
    "grid_layout",
    "interface_nodes",
    "interface_sites",
    "interface_tips",
    "sites_from_export",
    "tips_from_export",
]
