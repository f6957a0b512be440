"""Spike-initiation zones: an afferent's receptors divided into groups, each driving its own LIF.

The study sums the receptor currents of an afferent into one current that drives one
leaky integrate-and-fire neuron (:func:`afferent.synthesis.synthesize`, the ``sum`` branching
model). The SA-I skin-neuron models (Lesniak & Gerling 2009; Lesniak et al. 2014) model an
afferent as several spike-initiation zones (heminodes), each driven by its own group of
receptors; the first zone to reach threshold fires the afferent and resets all its zones.
This module forms the groups (the ``zones`` branching model); the spiking engines run them
(``simulate_lif(..., zones=)``, :ref:`spikes-zones`)::

    Branching (afferents) --split_zones(branching, layout, k)--> Zones
    ReceptorCurrent --synthesize(current, zones.branching)--> zone currents (n_times, n_zones) A
        --simulate_lif(..., zones=zones)--> SpikeTrains per afferent

How zones are formed (:func:`split_zones`): each afferent's receptors, ordered along the
afferent's own length (z for the afferents of a longitudinal, map or random branching,
whose positions are along x; x for cross-sections), are split into ``k`` contiguous groups
of equal size (sizes differ by at most one receptor, the larger groups first). An afferent
with fewer than ``k`` receptors gets one zone per receptor. Every connection of an afferent
(receptor, weight) goes to exactly one of its zones, so the zone currents of an afferent sum
to its ``sum`` current. Or the user names each receptor's zone (:func:`zones_from_map`, a CSV
``receptor, zone``): the zones of an afferent are then the zone labels of its receptors.
"""

from __future__ import annotations

from .receptors._layout import ReceptorLayout
from .synthesis import Branching

from ._typing import PathLike
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

import numbers
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from ._validation import plain as _plain

__all__ = ["Zones", "split_zones", "zones_from_map", "BRANCHING_MODELS", "DEFAULT_ZONES_PER_AFFERENT"]

#: How the receptor currents of an afferent drive its spikes: ``'sum'`` (the study: one current,
#: one LIF) or ``'zones'`` (one LIF per group of receptors, all reset when one fires).
BranchingModel = Literal["sum", "zones"]
BRANCHING_MODELS: tuple[str, ...] = get_args(BranchingModel)

#: Zones per afferent when none is given: the four heminodes of the SA-I model of Lesniak et al.
#: (2014, eLife 3:e01488; Merkel-cell groups of 8, 5, 3 and 1 per heminode in the Gerling
#: lab's model code, see the ``sa1`` LIF preset).
DEFAULT_ZONES_PER_AFFERENT = 4

#: Coordinate an afferent's receptors are ordered along, by the axis of its branching's positions.
_LENGTH_AXIS = {"x": 2, "z": 0}


@dataclass(frozen=True)
class Zones:
    """The spike-initiation zones of every afferent of a branching.

    Build it with :func:`split_zones`.

    Parameters
    ----------
    branching : Branching
        One row per zone (receptor -> zone weights, the afferents' own weights), zones grouped
        by afferent in the afferents' order; ids ``'<afferent>/z<j>'``, ``j`` from 0 along the
        afferent; positions the zones' mean coordinate along the afferents' axis, m.
    afferent : ndarray of shape (n_zones,), int
        Index of each zone's afferent in ``parent`` (non-decreasing).
    parent : Branching
        The afferents (the ``sum`` model's branching).
    rule : str
        How the zones were formed (``'split:K along z'``, ``'map'``), for the record.
    info : dict, optional
        More for the record (a map's rows not used).
    """

    branching: object
    afferent: np.ndarray
    parent: object
    rule: str
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        aff = np.asarray(self.afferent, dtype=np.int64).copy()
        n_aff = self.parent.n_afferents
        if aff.shape != (self.branching.n_afferents,) or (aff.size and (aff.min() < 0 or aff.max() >= n_aff)):
            raise ValueError(f"'afferent' must give each of the {self.branching.n_afferents} zones an afferent index in "
                             f"[0, {n_aff}); got shape {aff.shape} instead.")
        if np.any(np.diff(aff) < 0):
            raise ValueError("'afferent' must be non-decreasing: the zones of an afferent are contiguous.")
        aff.setflags(write=False)
        object.__setattr__(self, "afferent", aff)

    @property
    def n_zones(self) -> int:
        """Number of zones, all afferents together."""
        return int(self.afferent.size)

    @property
    def afferent_ids(self) -> np.ndarray:
        """The afferents' ids (the parent branching's), ndarray of str."""
        return self.parent.afferent_ids

    @property
    def zones_per_afferent(self) -> np.ndarray:
        """Number of zones of each afferent, ndarray of shape (n_afferents,), int."""
        return np.bincount(self.afferent, minlength=self.parent.n_afferents)

    def record(self) -> dict:
        """What ``run.json`` says about the zones: rule, counts, receptors per zone."""
        per = self.zones_per_afferent
        rec = self.branching.receptor_counts
        return {"rule": self.rule, "n_zones": self.n_zones,
                "zones_per_afferent": [int(per.min()), int(per.max())] if per.size else [0, 0],
                "receptors_per_zone": [int(rec.min()), int(rec.max())] if rec.size else [0, 0], **self.info}

    def __repr__(self) -> str:
        per = self.zones_per_afferent
        return (f"<Zones {self.rule!r}: {self.n_zones} zones of {self.parent.n_afferents} afferents "
                f"({per.min() if per.size else 0}-{per.max() if per.size else 0} per afferent)>")


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, numbers.Integral):
        raise TypeError(f"'zones_per_afferent' must be an int; got {_plain(k)!r} instead.")
    if k < 1:
        raise ValueError(f"'zones_per_afferent' must be >= 1; got {_plain(k)!r} instead.")
    return int(k)


def split_zones(branching: Branching, layout: ReceptorLayout, zones_per_afferent: int = DEFAULT_ZONES_PER_AFFERENT) -> Zones:
    """Split each afferent's receptors into ``zones_per_afferent`` contiguous groups along the afferent.

    Parameters
    ----------
    branching : Branching
        The afferents (:class:`afferent.synthesis.Branching`), built from ``layout``.
    layout : ReceptorLayout
        Receptor sites in m (the branching's columns, in order).
    zones_per_afferent : int, default=4
        Zones per afferent, >= 1 (an afferent with fewer receptors gets one zone per receptor;
        ``1`` is the ``sum`` model). Default :data:`DEFAULT_ZONES_PER_AFFERENT`.

    Returns
    -------
    Zones
        Receptors ordered along z (x for a cross-section branching), ties by the other
        coordinate then by column; split into groups whose sizes differ by at most one.

    Raises
    ------
    TypeError
        If ``branching`` is not a Branching or ``zones_per_afferent`` not an int.
    ValueError
        If ``zones_per_afferent < 1`` or the layout does not have the branching's receptors.

    Examples
    --------
    >>> import numpy as np
    >>> from afferent.receptors import ReceptorLayout
    >>> from afferent.synthesis import Branching
    >>> xyz = np.array([[0, 0, z] for z in np.arange(5) * 2.2e-4])
    >>> b = Branching.longitudinal(ReceptorLayout(xyz))
    >>> z = split_zones(b, ReceptorLayout(xyz), 2)
    >>> z.branching.afferent_ids.tolist(), z.branching.receptor_counts.tolist()
    (['L0/z0', 'L0/z1'], [3, 2])
    """
    from .synthesis import Branching

    if not isinstance(branching, Branching):
        raise TypeError(f"'branching' must be a Branching; got {type(branching).__name__} instead.")
    k = _check_k(zones_per_afferent)
    pos = np.asarray(layout.positions, dtype=float)
    if pos.shape != (branching.n_receptors, 3):
        raise ValueError(f"'layout' must have the branching's {branching.n_receptors} receptors; "
                         f"got {pos.shape[0]} instead.")
    along = pos[:, _LENGTH_AXIS[branching.axis]]
    other = pos[:, 2 - _LENGTH_AXIS[branching.axis]]
    w = branching.weights
    rows, cols, data, zone_aff, zone_ids, centres = [], [], [], [], [], []
    for a in range(branching.n_afferents):
        lo, hi = w.indptr[a], w.indptr[a + 1]
        c, d = w.indices[lo:hi], w.data[lo:hi]
        order = np.lexsort((c, other[c], along[c]))
        for j, part in enumerate(np.array_split(order, min(k, c.size)) if c.size else []):
            rows.append(np.full(part.size, len(zone_ids)))
            cols.append(c[part])
            data.append(d[part])
            zone_aff.append(a)
            zone_ids.append(f"{branching.afferent_ids[a]}/z{j}")
            centres.append(float(pos[c[part], 0 if branching.axis == "x" else 2].mean()))
    n_z = len(zone_ids)
    cat = (lambda parts, dt: np.concatenate(parts) if parts else np.zeros(0, dt))
    from scipy import sparse

    zw = sparse.csr_array((cat(data, float), (cat(rows, np.int64), cat(cols, np.int64))),
                          shape=(n_z, branching.n_receptors))
    zb = Branching(zw, np.array(centres), branching.axis, branching.kind, np.array(zone_ids, dtype=str),
                   branching.receptor_ids)
    axis_name = "xyz"[_LENGTH_AXIS[branching.axis]]
    return Zones(zb, np.array(zone_aff, dtype=np.int64), branching, f"split:{k} along {axis_name}")


def _zone_table(source):
    """(receptor ids, zone labels, where) of a receptor -> zone table (CSV path or DataFrame), as text."""
    import os

    import pandas as pd

    if isinstance(source, pd.DataFrame):
        df, where = source, "Zone map"
    else:
        from ._tables import read_table

        where = f"Zone map {os.fspath(source)!r}"
        df, _ = read_table(os.fspath(source), what="Zone map file", expected="receptor, zone", as_text=True)
    cols = {str(c).strip().lower(): c for c in df.columns}
    missing = [c for c in ("receptor", "zone") if c not in cols]
    if missing:
        from .exceptions import SEDFormatError

        found = ", ".join(repr(str(c)) for c in df.columns) or "none"
        raise (ValueError if isinstance(source, pd.DataFrame) else SEDFormatError)(
            f"{where} must have columns 'receptor' and 'zone'; missing {', '.join(map(repr, missing))}. "
            f"Found columns {found}.")
    rec, zone = (df[cols[c]].astype(str).str.strip().where(df[cols[c]].notna(), "").to_numpy()
                 for c in ("receptor", "zone"))
    for name, cells in (("zone", zone), ("receptor", rec)):  # an empty cell is not a label of its own
        empty = np.flatnonzero(cells == "")
        if empty.size:
            k = int(empty[0])
            raise ValueError(f"{where}: {empty.size} row(s) have an empty {name!r} cell (the first on data row {k + 1}"
                             f"{f', receptor {rec[k]!r}' if name == 'zone' else ''}); give every receptor its id and "
                             "a zone label.")
    return rec, zone, where


def zones_from_map(branching: Branching, source: PathLike | DataFrame) -> Zones:
    """Zones named by the user: each receptor's zone label, from a table ``receptor, zone``.

    Parameters
    ----------
    branching : Branching
        The afferents, with ``receptor_ids`` (built from a layout).
    source : str, path-like or pandas.DataFrame
        A CSV file (comma, semicolon, tab or whitespace separated; ``#`` comments) or a DataFrame
        with columns ``receptor`` (ids as in the layout) and ``zone`` (any label); one row per
        receptor. The zones of an afferent are the labels of its receptors, in the order they
        first appear in the table; a receptor shared by several afferents is in the zone of
        that label in each. Rows of receptors the branching does not have (outside a region)
        are not used; the record counts them.

    Returns
    -------
    Zones
        ``rule`` ``'map'``; zone ids ``'<afferent>/<label>'``; positions those of the afferents;
        ``info['map_rows_unused']``, the rows of receptors the branching does not have.

    Raises
    ------
    FileNotFoundError, SEDFormatError
        The file is missing, unreadable or lacks the columns.
    ValueError
        A receptor listed twice, an empty receptor or zone cell (not a zone of its own), or
        receptors of the branching without a zone (the message counts and names them), or a
        branching without receptor ids.
    """
    from .synthesis import Branching, _preview

    if not isinstance(branching, Branching):
        raise TypeError(f"'branching' must be a Branching; got {type(branching).__name__} instead.")
    if branching.receptor_ids is None:
        raise ValueError("'branching' must carry receptor_ids (build it from a ReceptorLayout) to match a zone map.")
    rec, zone, where = _zone_table(source)
    if len(set(rec.tolist())) != rec.size:
        dup = next(r for r in rec.tolist() if (rec == r).sum() > 1)
        raise ValueError(f"{where}: receptor {dup!r} is listed more than once; give each receptor one zone.")
    label = dict(zip(rec.tolist(), zone.tolist()))
    ids = branching.receptor_ids.tolist()
    connected = np.unique(branching.weights.indices)
    lost = [ids[j] for j in connected if ids[j] not in label]
    if lost:
        raise ValueError(f"{where}: {len(lost)} receptor(s) of the branching have no zone: {_preview(lost)}.")
    order = list(dict.fromkeys(zone.tolist()))  # zone labels in the order they first appear
    rank = {z: i for i, z in enumerate(order)}
    w = branching.weights
    rows, cols, data, zone_aff, zone_ids = [], [], [], [], []
    for a in range(branching.n_afferents):
        c, d = w.indices[w.indptr[a]:w.indptr[a + 1]], w.data[w.indptr[a]:w.indptr[a + 1]]
        labs = np.array([rank[label[ids[j]]] for j in c], dtype=np.int64)
        for r in np.unique(labs):
            part = labs == r
            rows.append(np.full(int(part.sum()), len(zone_ids)))
            cols.append(c[part])
            data.append(d[part])
            zone_aff.append(a)
            zone_ids.append(f"{branching.afferent_ids[a]}/{order[r]}")
    aff = np.array(zone_aff, dtype=np.int64)
    cat = (lambda parts, dt: np.concatenate(parts) if parts else np.zeros(0, dt))
    from scipy import sparse

    zb = sparse.csr_array((cat(data, float), (cat(rows, np.int64), cat(cols, np.int64))),
                          shape=(len(zone_ids), branching.n_receptors))
    known = set(ids)
    unused = sum(1 for r in rec.tolist() if r not in known)
    zb = Branching(zb, branching.positions[aff], branching.axis, branching.kind, np.array(zone_ids, dtype=str),
                   branching.receptor_ids)
    return Zones(zb, aff, branching, "map", {"map_rows_unused": int(unused)})


def zone_indicator(zones: Zones):
    """Zone -> afferent sums as a sparse (n_zones, n_afferents) matrix of ones: ``zone_values @ M``
    gives each afferent's summed current (A) from its zones'."""
    n = zones.n_zones
    from scipy import sparse

    return sparse.csr_array((np.ones(n), (np.arange(n), zones.afferent)), shape=(n, zones.parent.n_afferents))
