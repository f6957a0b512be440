"""Hot-spot maps (the study's chapter 4) and how well two maps tell their indenters apart.

A hot-spot map is the SED at a table of receptor sites (RA-I papilla tips or SA-I
intermediate-ridge bases), min-max normalised over the table to 0..1, with the sites at or
above a threshold (the study: 0.6) shown as hot spots (docs/method.md, "Chapter 4").

Two maps of the same sites under two indenters are told apart by the **map distance**
``1 - r``, r the Pearson correlation of the two normalised maps over the sites: 0 for maps
equal up to a positive scale and offset, 1 for uncorrelated maps, 2 for maps that are each
other's negative. It is computed on the whole normalised maps (every site, not only the hot
ones), so a site just below the threshold counts as much as one just above it.

The **nearest-centroid accuracy** asks the same with noise: each map of a group (say the four
indenters on one model) is a class template; noisy copies (template + Gaussian noise of
standard deviation ``noise``, in normalised units, at every site) are assigned to the nearest
template (Euclidean); the accuracy is the fraction assigned to their own class. For two
templates at Euclidean distance D the expected accuracy is Phi(D / (2 noise)).

Everything here is a pure function of arrays; :mod:`afferent.export` writes ``hotspots.csv``
and ``hotspots.png`` from it and ``afferent hotspots`` tabulates runs.
"""

from __future__ import annotations

from .sampling import ReceptorSED

from ._typing import ArrayLike, PathLike
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: these load on first use
    from pandas import DataFrame

import os

import numpy as np

__all__ = ["DEFAULT_THRESHOLD", "normalise_map", "hotspot_table", "map_distance", "distance_table",
           "nearest_centroid_accuracy", "receptor_hotspots", "hotspot_maps", "write_hotspots",
           "read_hotspot_runs", "read_run_tables", "group_runs", "compare_runs", "HOTSPOT_COLUMNS"]

#: The study's hot-spot threshold on the min-max normalised SED (fig. 4-9).
DEFAULT_THRESHOLD = 0.6


def normalise_map(values: ArrayLike, *, name: str = "map") -> np.ndarray:
    """Min-max normalised copy of ``values`` (any unit): 0 at the smallest, 1 at the largest.

    Raises ``ValueError`` (naming ``name``) for an empty map, a non-finite value, or a constant
    map, whose normalisation is undefined.
    """
    v = np.asarray(values, dtype=float).ravel()
    if v.size == 0:
        raise ValueError(f"{name}: a hot-spot map needs at least one site; got none.")
    if not np.all(np.isfinite(v)):
        bad = int(np.flatnonzero(~np.isfinite(v))[0])
        raise ValueError(f"{name}: every site needs a finite SED; site {bad} has {float(v[bad])!r}.")
    lo, hi = float(v.min()), float(v.max())
    if hi <= lo:
        raise ValueError(f"{name}: every site has the same SED ({float(lo)!r}); a min-max normalised map is undefined.")
    return (v - lo) / (hi - lo)


def hotspot_table(ids: Sequence[str], positions_m: ArrayLike, sed_pa: ArrayLike, *, threshold: float = DEFAULT_THRESHOLD, site: str = "file",
                  name: str = "map") -> DataFrame:
    """One row per site: ``site_kind, site, x_m, z_m, sed_pa, normalised, hot`` (a pandas DataFrame).

    Parameters
    ----------
    ids : sequence of str
        Site ids.
    positions_m : array (n, 3)
        Site coordinates in m (x across the ridges, z along them).
    sed_pa : array (n,)
        SED at the sites in Pa (J/m^3).
    threshold : float, default 0.6
        Hot spots: normalised SED >= threshold (0 <= threshold <= 1).
    site : str
        The site kind written in ``site_kind`` ('RA-I', 'SA-I' or 'file').
    name : str
        Named in errors.
    """
    import pandas as pd

    if not 0.0 <= float(threshold) <= 1.0:
        raise ValueError(f"hot-spot threshold must be within 0..1 (normalised SED); got {threshold!r}.")
    pos = np.asarray(positions_m, dtype=float)
    norm = normalise_map(sed_pa, name=name)
    return pd.DataFrame({"site_kind": site, "site": np.asarray(ids).astype(str), "x_m": pos[:, 0], "z_m": pos[:, 2],
                         "sed_pa": np.asarray(sed_pa, dtype=float).ravel(), "normalised": norm,
                         "hot": norm >= float(threshold)})


def map_distance(a: ArrayLike, b: ArrayLike) -> float:
    """1 - Pearson correlation of two maps over the same sites (0 same pattern, 1 unrelated, 2 opposite).

    Min-max normalisation does not change r (it is a positive affine map), so raw or
    normalised SED give the same distance. Raises ``ValueError`` for maps of different
    length or a constant map (r undefined).
    """
    x = normalise_map(a, name="first map")
    y = normalise_map(b, name="second map")
    if x.size != y.size:
        raise ValueError(f"maps over different sites: {x.size} and {y.size} values.")
    x, y = x - x.mean(), y - y.mean()
    r = float(np.dot(x, y) / np.sqrt(np.dot(x, x) * np.dot(y, y)))
    return 1.0 - max(-1.0, min(1.0, r))


def distance_table(maps: dict) -> DataFrame:
    """``map_distance`` of every pair of ``maps`` ({label: values}): a square pandas DataFrame (labels x labels)."""
    import pandas as pd

    labels = list(maps)
    d = np.zeros((len(labels), len(labels)))
    for i, a in enumerate(labels):
        for j in range(i + 1, len(labels)):
            d[i, j] = d[j, i] = map_distance(maps[a], maps[labels[j]])
    return pd.DataFrame(d, index=labels, columns=labels)


def nearest_centroid_accuracy(maps: dict, *, noise: float, trials: int = 2000, seed: int = 0) -> float:
    """Fraction of noisy copies of each normalised map assigned to their own map (nearest template).

    ``maps``: {label: values at the same sites} (at least two); ``noise``: standard deviation of
    the Gaussian noise added at every site, in normalised units (> 0); ``trials`` copies per map;
    ``seed``: the numpy Generator seed (the result is reproducible). Chance level is 1 / len(maps).
    """
    if len(maps) < 2:
        raise ValueError(f"a classifier needs at least two maps; got {len(maps)}.")
    if not noise > 0:
        raise ValueError(f"noise must be > 0 (normalised units); got {noise!r}.")
    templates = np.stack([normalise_map(v, name=str(k)) for k, v in maps.items()])
    rng = np.random.default_rng(seed)
    correct = 0
    for k, t in enumerate(templates):
        copies = t[None, :] + rng.normal(0.0, noise, size=(int(trials), t.size))
        # squared distances to every template: |c|^2 - 2 c.t + |t|^2 (|c|^2 is common to all)
        score = -2.0 * copies @ templates.T + np.sum(templates ** 2, axis=1)[None, :]
        correct += int(np.sum(np.argmin(score, axis=1) == k))
    return correct / (len(templates) * int(trials))


def receptor_hotspots(sed: ReceptorSED, *, threshold: float = DEFAULT_THRESHOLD, time_index: int | None = None) -> tuple[DataFrame, int]:
    """:func:`hotspot_table` of a ReceptorSED (J/m^3) at one step, with ``time_s`` (``step`` for step numbers)
    and ``map`` columns.

    ``map`` names the site set: its kind ('RA-I', 'SA-I'), or for sites read from a file, the file's name.

    ``time_index`` None: the step of the largest total SED (the export's deepest step).
    Returns (table, time_index).
    """
    v = np.asarray(sed.values, dtype=float)
    k = int(np.argmax(np.nansum(v, axis=1))) if time_index is None else int(time_index)
    table = hotspot_table(sed.layout.ids, sed.layout.positions, v[k], threshold=threshold, site=sed.layout.site,
                          name=f"hot-spot map of the {sed.layout.n_receptors} {sed.layout.site} sites")
    table.insert(4, "step" if getattr(sed, "numbered", False) else "time_s", float(sed.times[k]))
    source = getattr(sed.layout, "source", None)
    table.insert(0, "map", sed.layout.site if sed.layout.site != "file" or not source else os.path.basename(str(source)))
    return table, k


def hotspot_maps(sed_static: ReceptorSED, sed_beside: ReceptorSED | None=None, *, threshold: float = DEFAULT_THRESHOLD) -> list[DataFrame]:
    """The tables of the ``hotspots`` output: the scene's sites, then (if given) the second site set.

    Both at the step of the largest total SED of ``sed_static``. Returns a list of DataFrames
    (:func:`receptor_hotspots`); ``hotspots.csv`` is their concatenation.
    """
    first, k = receptor_hotspots(sed_static, threshold=threshold)
    if sed_beside is None:
        return [first]
    return [first, receptor_hotspots(sed_beside, threshold=threshold, time_index=k)[0]]


def write_hotspots(path: Callable[[str], str], sed_static: ReceptorSED, sed_beside: ReceptorSED | None=None, *, threshold: float = DEFAULT_THRESHOLD, plots: bool = True) -> None:
    """The ``hotspots`` output of :func:`afferent.export.write_outputs`: ``hotspots.csv`` (the tables of
    :func:`hotspot_maps`, one row per site) and, with ``plots``, ``hotspots.png``.

    ``path(name)`` gives the file path of ``name`` in the (temporary) output folder and records it as written.
    """
    import pandas as pd

    tables = hotspot_maps(sed_static, sed_beside, threshold=threshold)
    pd.concat(tables, ignore_index=True).to_csv(path("hotspots.csv"), index=False)
    write_hotspot_vtu(path("hotspots.vtu"), tables, [s.layout for s in (sed_static, sed_beside) if s is not None])
    if plots:
        from .plotting import plot_hotspot_maps, save_figure

        save_figure(plot_hotspot_maps(tables, threshold=threshold), path("hotspots.png"))


def write_hotspot_vtu(path: str, tables, layouts) -> None:
    """``hotspots.vtu``: the sites of every map as VTK vertices (ParaView), at their positions (m), with the
    values of ``hotspots.csv`` at each: ``sed_pa`` (J/m^3), ``normalised`` (0..1), ``hot`` (1 = a hot spot),
    ``map`` (0: the scene's sites, 1: the second site set) and the section ids, as ``receptors.vtu`` does.

    Parameters
    ----------
    path : str
    tables : list of DataFrame
        :func:`hotspot_maps`' tables, one per site set, rows in the order of its layout's sites.
    layouts : list of ReceptorLayout
        The site sets of ``tables``, in the same order.
    """
    import meshio

    pos = np.concatenate([np.asarray(lay.positions, dtype=float) for lay in layouts])
    data = {"sed_pa": np.concatenate([t["sed_pa"].to_numpy(float) for t in tables]),
            "normalised": np.concatenate([t["normalised"].to_numpy(float) for t in tables]),
            "hot": np.concatenate([t["hot"].to_numpy(bool) for t in tables]).astype(np.int32),
            "map": np.concatenate([np.full(len(t), k, dtype=np.int32) for k, t in enumerate(tables)]),
            "longitudinal": np.concatenate([lay.longitudinal for lay in layouts]).astype(np.int32),
            "cross": np.concatenate([lay.cross for lay in layouts]).astype(np.int32)}
    meshio.write(path, meshio.Mesh(pos, [("vertex", np.arange(len(pos)).reshape(-1, 1))], point_data=data),
                 file_format="vtu")


#: What a ``hotspots.csv`` read back must hold (``afferent._run_folder.check_table``): a row per site.
HOTSPOT_COLUMNS = {"finite": ("x_m", "z_m", "sed_pa"), "columns": ("map",)}


def read_hotspot_runs(folders: Sequence[PathLike]) -> dict:
    """{run label: hotspots.csv table} of ``afferent run`` output folders (:func:`read_run_tables`)."""
    return read_run_tables(folders, "hotspots.csv", "hotspots", HOTSPOT_COLUMNS)


def read_run_tables(folders: Sequence[PathLike], filename: str, want: str, checks: dict) -> dict:
    """{run label: the table ``filename``} of ``afferent run`` output folders whose scenes want ``want`` (the label:
    run.json's scene name, else the folder's name); ``afferent hotspots`` and ``afferent cycles`` read runs so.
    Each table is read by ``afferent._run_folder.read_run_table`` with ``checks`` (its ``finite``, ``numbers``,
    ``columns``) and must have rows. A folder without the table, a damaged table or run.json, or two runs of one
    label are errors naming them."""
    from ._run_folder import read_run_table, run_label

    runs = {}
    for folder in folders:
        csv = os.path.join(folder, filename)
        if not os.path.isfile(csv):
            raise FileNotFoundError(f"{folder!r}: no {filename}; expected the output folder of a run whose scene "
                                    f"wants {want!r}.")
        label = run_label(folder)
        if label in runs:
            raise ValueError(f"{folder!r}: a second run named {label!r}; give runs of distinct scene names.")
        runs[label] = read_run_table(csv, what=f"the {want!r} output of a run ({filename})", **checks)
    return runs


def group_runs(labels: Iterable[str], groups: dict | None) -> dict:
    """{group: [labels]} from ``groups`` ({name: fnmatch pattern on the label}); None: one group 'all'.

    A pattern matching no run is an error naming it.
    """
    from fnmatch import fnmatchcase

    if not groups:
        return {"all": list(labels)}
    out = {}
    for name, pattern in groups.items():
        out[name] = [lb for lb in labels if fnmatchcase(lb, pattern)]
        if not out[name]:
            raise ValueError(f"group {name!r}: pattern {pattern!r} matches none of the runs {list(labels)!r}.")
    return out


def compare_runs(runs: dict, groups: dict | None = None, *, noise: float = 0.1, trials: int = 2000, seed: int = 0) -> tuple[DataFrame, DataFrame]:
    """Map distances and classifier accuracy of the runs of each group, per site set (``map`` column).

    Returns (distances, accuracy) DataFrames: ``group, map, a, b, distance`` for every pair of runs
    of a group (:func:`map_distance` of their normalised SED), and ``group, map, n_maps, noise, trials,
    accuracy, chance`` (:func:`nearest_centroid_accuracy`). Runs of a group must map the same sites; a run of the
    group without a map the others have is left out of that map's rows with an :class:`AfferentWarning`.
    """
    import pandas as pd

    dist, acc = [], []
    for g, labels in group_runs(list(runs), groups).items():
        kinds = list(dict.fromkeys(k for lb in labels for k in runs[lb]["map"]))
        for kind in kinds:
            maps = {lb: runs[lb][runs[lb]["map"] == kind] for lb in labels if kind in set(runs[lb]["map"])}
            if len(maps) < len(labels):  # said, not silently left out of the distances and the chance level
                import warnings

                from .exceptions import AfferentWarning

                warnings.warn(f"group {g!r}, map {kind!r}: run(s) {[lb for lb in labels if lb not in maps]} have no "
                              f"sites of that map; compared without them ({len(maps)} of {len(labels)} runs).",
                              AfferentWarning, stacklevel=2)
            ref = next(iter(maps.values()))[["x_m", "z_m"]].to_numpy()
            for lb, t in maps.items():
                if len(t) != len(ref) or not np.allclose(t[["x_m", "z_m"]].to_numpy(), ref, atol=1e-9):
                    raise ValueError(f"group {g!r}, map {kind!r}: run {lb!r} maps other sites than "
                                     f"{next(iter(maps))!r}; a distance needs the same sites.")
            vals = {lb: t["sed_pa"].to_numpy() for lb, t in maps.items()}
            names = list(vals)
            dist += [{"group": g, "map": kind, "a": a, "b": b, "distance": map_distance(vals[a], vals[b])}
                     for i, a in enumerate(names) for b in names[i + 1:]]
            if len(vals) >= 2:
                acc.append({"group": g, "map": kind, "n_maps": len(vals), "noise": noise, "trials": trials,
                            "accuracy": nearest_centroid_accuracy(vals, noise=noise, trials=trials, seed=seed),
                            "chance": 1.0 / len(vals)})
    return pd.DataFrame(dist, columns=["group", "map", "a", "b", "distance"]), pd.DataFrame(acc)
