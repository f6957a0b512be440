"""Receptor layouts: :class:`ReceptorLayout`, sections (:func:`group_coordinates`), :func:`read_receptors`, :func:`central_line`.

Documented with the rest of :mod:`afferent.receptors`, which re-exports every public name.
"""

from __future__ import annotations

from .._typing import ArrayLike, NDArray, PathLike

import os
import warnings
from dataclasses import dataclass

import numpy as np

from .._validation import check_finite_array, check_positive
from ..exceptions import AfferentWarning, SEDFormatError
from ..io._columns import canonical
from ..units import length_factor

#: Default tolerance (m) when grouping receptors into sections: coordinates closer than
#: this along the grouping axis fall into one section. 20 um is a tenth of the papilla
#: pitch (0.22 mm) and far above FE coordinate noise.
SECTION_TOLERANCE_M = 20e-6


#: What receptor sites can be (:attr:`ReceptorLayout.site`): dermal-papilla tips (RA-I,
#: Meissner corpuscles), bases of the intermediate ridges (SA-I, Merkel cells), or positions
#: as given (a receptor file or an array). See :ref:`method-receptor-sites`.
SITE_KINDS = ("RA-I", "SA-I", "file")
#: The site kind of each ``kind`` of :func:`interface_sites` and :func:`grid_layout`.
SITE_OF_KIND = {"tips": "RA-I", "bases": "SA-I"}
_SITE_WORDS = {"RA-I": "RA-I sites (dermal-papilla tips, Meissner corpuscles)",
               "SA-I": "SA-I sites (intermediate-ridge bases, Merkel cells)",
               "file": "sites as given (a receptor file: no site rule)"}


def describe_sites(layout: "ReceptorLayout") -> str:
    """One line: how many sites, what they are, where (mm), e.g. for ``afferent info --receptors``."""
    lo, hi = layout.positions.min(axis=0) * 1e3, layout.positions.max(axis=0) * 1e3
    src = f" from {layout.source}" if layout.source else ""
    return (f"receptor sites: {layout.n_receptors} {_SITE_WORDS[layout.site]}{src}; x [{lo[0]:.4g}, {hi[0]:.4g}], "
            f"y [{lo[1]:.4g}, {hi[1]:.4g}], z [{lo[2]:.4g}, {hi[2]:.4g}] mm")


#: Largest section label: labels index arrays of ``max label + 1`` entries
#: (:meth:`ReceptorLayout.section_positions`), and no fingertip has a million ridges.
MAX_SECTION_LABEL = 999_999


def group_coordinates(values: ArrayLike, tol: float = SECTION_TOLERANCE_M) -> tuple[np.ndarray, np.ndarray]:
    """Group 1-D coordinates that lie within ``tol`` of their neighbours (single linkage).

    Parameters
    ----------
    values : array_like of shape (n,)
        Coordinates in m.
    tol : float
        Largest gap in m inside one group.

    Returns
    -------
    labels : ndarray of shape (n,), int
        Group index of each value, numbered in increasing coordinate order from 0.
    centres : ndarray of shape (n_groups,)
        Mean coordinate of each group in m.

    Examples
    --------
    >>> labels, centres = group_coordinates([0.0, 1e-3, 1e-7, 1.0000001e-3])
    >>> labels.tolist()
    [0, 1, 0, 1]
    """
    values = np.asarray(values, dtype=float)
    tol = check_positive("tol", tol, unit="m")
    if values.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    order = np.argsort(values, kind="stable")
    with np.errstate(over="ignore"):  # a gap between -1e308 and 1e308 is inf: still a gap
        gaps = np.diff(values[order]) > tol
    sorted_labels = np.concatenate([[0], np.cumsum(gaps)])
    labels = np.empty_like(sorted_labels)
    labels[order] = sorted_labels
    return labels.astype(np.int64), label_means(labels, values)


def label_means(labels, values, minlength: int = 0) -> np.ndarray:
    """Mean of ``values`` per integer label ``0..max`` (NaN for a label no value carries).

    Each value is divided by its label's count before summing, so means of coordinates near
    the float maximum (1e308 m) do not overflow to inf. Units: those of ``values``.
    """
    labels = np.asarray(labels, dtype=np.int64)
    counts = np.bincount(labels, minlength=minlength)
    sums = np.bincount(labels, weights=np.asarray(values, dtype=float) / counts[labels], minlength=minlength)
    return np.where(counts > 0, sums, np.nan)


@dataclass(frozen=True)
class ReceptorLayout:
    """Positions of receptor sites and the sections they belong to.

    Parameters
    ----------
    positions : ndarray of shape (n_receptors, 3)
        Receptor coordinates in m.
    ids : ndarray of shape (n_receptors,) of str, optional
        Receptor names; default ``'0'``, ``'1'``, ...
    longitudinal : ndarray of shape (n_receptors,), int, optional
        Longitudinal-section index (lines parallel to the ridges, grouped by x); computed
        with :func:`group_coordinates` when not given.
    cross : ndarray of shape (n_receptors,), int, optional
        Cross-section index (lines across the ridges, grouped by z); computed when not given.
    tol : float, default=20e-6
        Grouping tolerance in m used when sections are computed.
    source : str, optional
        The receptor file the sites were read from (named in error messages), or None.
    site : {'file', 'RA-I', 'SA-I'}, default='file'
        What the sites are (``SITE_KINDS``): ``'RA-I'`` dermal-papilla tips (Meissner
        corpuscles; :func:`interface_sites` ``kind='tips'``, :func:`grid_layout` papilla rows),
        ``'SA-I'`` bases of the intermediate ridges (Merkel cells; ``kind='bases'``), ``'file'``
        positions taken as given (a receptor file or an array) with no anatomical rule.
        Recorded in run.json and shown by ``afferent info --receptors``.
    """

    positions: np.ndarray
    ids: np.ndarray | None = None
    longitudinal: np.ndarray | None = None
    cross: np.ndarray | None = None
    tol: float = SECTION_TOLERANCE_M
    source: str | None = None
    site: str = "file"

    def __post_init__(self):
        if self.site not in SITE_KINDS:
            raise ValueError(f"'site' must be one of {', '.join(map(repr, SITE_KINDS))}; got {self.site!r} instead.")
        pos = check_finite_array("positions", self.positions, ndim=2, shape_doc="(n_receptors, 3) in metres")
        if pos.shape[1] != 3:
            raise ValueError(
                f"'positions' must be an array of shape (n_receptors, 3) in metres; got shape {pos.shape} instead."
            )
        n = pos.shape[0]
        ids = np.arange(n).astype(str) if self.ids is None else np.asarray(self.ids).astype(str)
        if ids.shape != (n,):
            raise ValueError(f"'ids' must have one entry per receptor ({n}); got shape {ids.shape} instead.")
        if len(set(ids.tolist())) != n:
            dup = next(i for i in ids.tolist() if (ids == i).sum() > 1)
            raise ValueError(f"Receptor ids must be unique; got {dup!r} more than once.")
        sections = {}
        for name, axis in (("longitudinal", 0), ("cross", 2)):
            given = getattr(self, name)
            if given is None:
                lab, _ = group_coordinates(pos[:, axis], self.tol)
            else:
                lab = np.asarray(given)
                if lab.shape != (n,) or not np.issubdtype(lab.dtype, np.integer):
                    raise ValueError(
                        f"'{name}' must be integer section labels of shape ({n},); got {lab.dtype} of shape {lab.shape} instead."
                    )
                if lab.size and (lab.min() < 0 or lab.max() > MAX_SECTION_LABEL):
                    k = int(np.flatnonzero((lab < 0) | (lab > MAX_SECTION_LABEL))[0])
                    raise ValueError(f"'{name}' section labels must lie from 0 to {MAX_SECTION_LABEL:,}; got "
                                     f"{int(lab[k])} for receptor {k} instead.")
            sections[name] = lab.astype(np.int64)
        for name, arr in (("positions", pos), ("ids", ids), *sections.items()):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_receptors(self) -> int:
        """Number of receptor sites."""
        return self.positions.shape[0]

    def section_positions(self, kind: str) -> np.ndarray:
        """Mean coordinate (m) of each section: x for ``'longitudinal'``, z for ``'cross'``.

        Returns an ndarray of shape (max_label + 1,), indexed by section label; NaN for a
        label no receptor carries (after :meth:`subset`).
        """
        labels = self.longitudinal if kind == "longitudinal" else self.cross
        axis = 0 if kind == "longitudinal" else 2
        n = int(labels.max()) + 1 if labels.size else 0
        return label_means(labels, self.positions[:, axis], n)

    def subset(self, mask: ArrayLike) -> "ReceptorLayout":
        """The layout restricted to ``mask`` (bool array or indices); section labels are kept."""
        idx = np.arange(self.n_receptors)[mask]
        return ReceptorLayout(
            self.positions[idx], self.ids[idx], self.longitudinal[idx], self.cross[idx], tol=self.tol, source=self.source,
            site=self.site,
        )

    def __len__(self) -> int:
        return self.n_receptors

    def __repr__(self) -> str:
        return (
            f"<ReceptorLayout: {self.n_receptors} {self.site} sites, "
            f"{len(np.unique(self.longitudinal))} longitudinal sections, {len(np.unique(self.cross))} cross-sections>"
        )


#: Receptor-id columns, compared after :func:`afferent.io._columns.canonical` (case, spaces,
#: underscores, dots and dashes ignored): ``id``, ``receptor_id``, ``Receptor ID``, ``site``...
_ID_COLUMNS = ("id", "receptor", "receptorid", "receptorname", "receptorlabel", "name", "label", "site", "siteid",
               "rid", "meissner", "meissnerid", "corpuscle", "corpuscleid", "tip", "tipid")
_SECTION_COLUMNS = {"longitudinal": ("longitudinal", "longitudinal_section"), "cross": ("cross", "cross_section")}


def read_receptors(path: PathLike, *, length_unit: str, tol: float = SECTION_TOLERANCE_M) -> ReceptorLayout:
    """Read receptor sites from a CSV with columns x, y, z (optional id and section labels).

    Parameters
    ----------
    path : str or path-like
        CSV file; comma, semicolon, tab or whitespace separated; ``#`` comment lines allowed.
        Column names are case-insensitive: ``x, y, z`` (required), a receptor id (optional:
        ``id``, ``receptor_id``, ``Receptor ID``, ``receptor``, ``name``, ``label``, ``site``,
        ... the first found), ``longitudinal`` / ``cross`` (optional whole-number section labels, 0 to 999,999).
        Any other column is reported with an :class:`~afferent.exceptions.AfferentWarning`.
    length_unit : str
        Unit of x, y, z: ``'m'``, ``'mm'`` or ``'um'``. Required: never guessed.
    tol : float, default=20e-6
        Section-grouping tolerance in m.

    Returns
    -------
    ReceptorLayout

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SEDFormatError
        If the file is empty, lacks x/y/z, holds non-numeric or non-finite coordinates, or
        section labels that are not whole numbers from 0 to 999,999.
    """

    from .._tables import numeric_columns, read_table

    path = os.fspath(path)
    factor = length_factor(length_unit)
    # as text, so that an error quotes a cell as written ('n/a', '')
    df, cols = read_table(path, what="Receptor file", expected="x, y, z (optional id, longitudinal, cross)", as_text=True,
                          frame=False)
    missing = [c for c in ("x", "y", "z") if c not in cols]
    if missing:
        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise SEDFormatError(
            f"Receptor file {path!r} must have columns 'x', 'y', 'z'; missing {', '.join(map(repr, missing))}. "
            f"Found columns {found}."
        )
    if len(df) == 0:
        raise SEDFormatError(f"Receptor file {path!r} has a header but no receptor rows.")
    xyz = numeric_columns(df, [cols["x"], cols["y"], cols["z"]], what="Receptor file", path=path)
    by_canonical = {canonical(c): df_col for c, df_col in cols.items()}
    id_col = next((by_canonical[c] for c in _ID_COLUMNS if c in by_canonical), None)  # first in the order above
    ids = np.array([str(c).strip() for c in df[id_col]], dtype=object) if id_col is not None else None
    sections = {}
    used = {cols["x"], cols["y"], cols["z"], id_col}
    for name, aliases in _SECTION_COLUMNS.items():
        col = next((cols[c] for c in aliases if c in cols), None)
        if col is not None:
            labels = numeric_columns(df, [col], what="Receptor file", path=path)[:, 0]
            bad = (labels != np.round(labels)) | (labels < 0) | (labels > MAX_SECTION_LABEL)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise SEDFormatError(
                    f"Receptor file {path!r}: column {str(col)!r} must hold whole-number section labels from 0 to "
                    f"{MAX_SECTION_LABEL:,}; got {float(labels[k])!r} on data row {k + 1} instead."
                )
            sections[name] = labels.astype(np.int64)
            used.add(col)
    ignored = [str(c) for c in df.columns if c not in used]
    if ignored:
        warnings.warn(
            f"Receptor file {path!r}: column(s) {', '.join(map(repr, ignored))} not used (afferent reads x, y, z, "
            f"a receptor id such as 'id' or 'receptor_id', 'longitudinal' and 'cross'); "
            + (f"receptor ids from {str(id_col)!r}." if id_col is not None else "receptors numbered 0, 1, ..."),
            AfferentWarning, stacklevel=2,
        )
    try:
        return ReceptorLayout(xyz * factor, ids, tol=tol, source=path, **sections)
    except ValueError as err:
        raise SEDFormatError(f"Receptor file {path!r}: {err}") from err


def central_line(layout: ReceptorLayout, axis: str) -> NDArray[np.intp]:
    """The receptors on the section line through the middle of the layout, along ``axis``.

    Along x: the cross section (constant z) whose centre is nearest the middle of the z extent;
    along z: the longitudinal section nearest the middle of the x extent.

    Parameters
    ----------
    layout : ReceptorLayout
        Receptor sites in m, with section labels.
    axis : {'x', 'z'}
        The direction of the line.

    Returns
    -------
    idx : ndarray of int
        Receptor indices on the line, sorted by their coordinate along ``axis``.
    coord : ndarray of float
        Their coordinate along ``axis``, m.
    at : float
        The section's position on the other axis, m.
    """
    other = 2 if axis == "x" else 0
    labels = layout.cross if axis == "x" else layout.longitudinal
    kind = "cross" if axis == "x" else "longitudinal"
    centres = layout.section_positions(kind)
    mid = 0.5 * (layout.positions[:, other].min() + layout.positions[:, other].max())
    best = int(np.nanargmin(np.abs(centres - mid)))
    idx = np.flatnonzero(labels == best)
    coord = layout.positions[idx, 0 if axis == "x" else 2]
    order = np.argsort(coord)
    return idx[order], coord[order], centres[best]
