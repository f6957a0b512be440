"""Checks of what an FE export holds: finite values, duplicate points, negative SED,
SED from the tensors against the export's own SED, shear convention of the tensors.

Used by :mod:`afferent.io._assemble`, which re-exports the public names.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..exceptions import SEDFormatError
from ..strain_energy import PRESETS, sed_exact
from ._columns import FINITE_STRAIN_NAMES, canonical
from ._find_arrays import _convention, _where, find_sed_array, find_tensors
from ._raw import RawExport
from ._read_options import (CROSSCHECK_RTOL, DENSITY_SCALE_BAND, NEGATIVE_SED_RTOL, SHEAR_RATIO_BAND,
                            SMALL_STRAIN_BOUND, ReadOptions)


def _check_values(raw: RawExport, values: np.ndarray, what: str) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        t, i = np.argwhere(bad.reshape(values.shape[0], values.shape[1], -1).any(-1))[0]
        kind = "NaN" if np.isnan(values[t, i]).any() else "infinite"
        said = [n for n in raw.notes if " NaN on " in n and any(f"{a.name!r}" in n and a.name in what
                                                                 for a in raw.arrays.values())]
        raise SEDFormatError(
            f"SED file {_where(raw)!r}: {what} must be finite; got {int(bad.sum())} non-finite value(s) "
            f"(first: {kind} at row {int(i)}{f', step {int(t)}' if values.shape[0] > 1 else ''}) instead."
            + (" Pass on_nan='drop' to leave such rows out." if raw.cells is None else "")
            + "".join(f" The file's {n[0].lower()}{n[1:]}" for n in said)
        )


def _merge_duplicate_points(raw: RawExport, xyz: np.ndarray, sed: np.ndarray):
    """A point table listing a point twice: merged if the values agree, refused if not.

    Tables written per element (element-nodal values) repeat shared nodes; where the values
    agree the copies carry nothing, where they differ the table holds unaveraged element-nodal
    values and no single SED belongs to the point.
    """
    _, first, inverse, counts = np.unique(xyz, axis=0, return_index=True, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    if counts.max(initial=1) == 1:
        return xyz, sed, 0
    ref = sed[:, first[inverse]]  # each row's group's first value
    scale = float(np.max(np.abs(sed))) or 1.0
    differ = np.abs(sed - ref).max(axis=0) > 1e-12 * scale
    if differ.any():
        j = int(np.flatnonzero(differ)[0])
        i = int(first[inverse[j]])
        t = int(np.argmax(np.abs(sed[:, j] - sed[:, i])))
        raise SEDFormatError(
            f"SED file {_where(raw)!r} lists the point ({', '.join(f'{v:g}' for v in xyz[j])}) more than once with "
            f"different SED (rows {i} and {j}: {sed[t, i]:.6g} and {sed[t, j]:.6g} J/m^3); {int(np.sum(counts > 1))} point(s) "
            "repeat. These look like unaveraged element-nodal values: export one value per node (averaged, 'unique "
            "nodal') or per element (centroid)."
        )
    keep = np.sort(first)
    return xyz[keep], sed[:, keep], int(xyz.shape[0] - keep.size)


def _scaled_difference(ref: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """(relative L2 difference of ``ref`` and ``scale * u``, scale) for the least-squares scale."""
    ok = np.isfinite(ref) & np.isfinite(u)
    ref, u = ref[ok], u[ok]
    nref, uu = float(np.linalg.norm(ref)), float(u @ u)
    if nref == 0.0:
        return (0.0 if uu == 0.0 else float("inf")), 1.0
    if uu == 0.0:
        return float("inf"), float("nan")
    scale = float(ref @ u) / uu
    return float(np.linalg.norm(ref - scale * u)) / nref, scale


def _percent(rel: float) -> str:
    return f"{100 * rel:.3g} %" if rel > 1e-9 else "< 1e-7 % (round-off)"


def _presets_like(check: dict, name: str) -> str:
    """The presets whose difference equals that of ``name`` up to round-off, as 'preset(s) ...'."""
    ref = check["by_preset"][name]
    same = [p for p, r in check["by_preset"].items() if abs(r - ref) <= 1e-9 + 1e-6 * ref]
    return ("presets " if len(same) > 1 else "preset ") + ", ".join(map(repr, same)) + (" give" if len(same) > 1 else " gives")


def strain_magnitude(strain) -> np.ndarray:
    """|eps| = sqrt(eps:eps) of each row of canonical strain components (..., 6), shear as given (dimensionless)."""
    e = np.asarray(strain, dtype=float)
    return np.sqrt(np.sum(e[..., :3] ** 2, axis=-1) + 2.0 * np.sum(e[..., 3:] ** 2, axis=-1))


def _step_peaks(strain) -> np.ndarray:
    """The largest |eps| of each step of strain (n_steps, n, 6) or (n, 6) (one step); rows not finite left out."""
    e = np.asarray(strain, dtype=float)
    mag = strain_magnitude(e.reshape(1 if e.ndim < 3 else e.shape[0], -1, 6))
    return np.where(np.isfinite(mag), mag, 0.0).max(axis=1, initial=0.0)


def is_finite_strain(name: str) -> bool:
    """Is the strain array ``name`` a finite-strain measure (:data:`afferent.io._columns.FINITE_STRAIN_NAMES`)?"""
    return canonical(name) in FINITE_STRAIN_NAMES


def _beyond_bound(peak: float, finite: bool) -> str:
    """The sentence for data whose strains exceed :data:`SMALL_STRAIN_BOUND`."""
    if finite:
        return (f"not checkable: strains up to {peak:.3g} exceed the small-strain bound {SMALL_STRAIN_BOUND:g} at every "
                "loaded step (a finite-strain analysis: there Cauchy stress and the reference-frame strain leave linear "
                "elasticity, and the check would give a false verdict)")
    return (f"strains up to {peak:.3g} exceed the small-strain bound {SMALL_STRAIN_BOUND:g}: judged as a linear "
            "(small-strain) analysis; in a geometrically nonlinear one large deformation alone moves this check")


def tensor_sed_crosscheck(raw: RawExport, opts: ReadOptions) -> dict | None:
    """Compare SED computed from the export's tensors with the export's own SED array.

    Many tools write an SED array beside stress and strain. For linear elasticity the two
    agree when the component order and shear convention are right, whatever the units (a
    least-squares scale factor absorbs a unit difference and is reported). The comparison is
    made at the step with the largest total SED among the steps whose strains stay within
    :data:`SMALL_STRAIN_BOUND` (any step when none does and the strain is not a finite-strain
    measure: then a ``note`` says so), under the convention in use and under every preset of
    :data:`afferent.strain_energy.PRESETS`. At finite strain the file's SED is the hyperelastic
    W (FEBio's neo-Hookean W: 1.27 x 1/2 sigma:E at |E| 0.066, 2.2 x at 0.47), not 1/2 sigma:eps: a finite-strain
    file (:func:`is_finite_strain`) with no step within the bound is not checkable.

    What it can tell: the shear convention (engineering shear read as tensor shear doubles the
    shear terms). What it cannot: the order of the shear components, since relabelling yz and
    xz in both tensors leaves 1/2 sigma:eps unchanged - and the 'equivalent' SED too (its von
    Mises forms depend on the sum of the squared shear components). So a mix-up among the shear
    components cannot change any SED afferent computes; the order comes from the component
    names or the preset.

    Returns
    -------
    dict or None
        None when the export lacks an SED array or tensors at the same location. Otherwise
        ``sed_array``, ``checkable``, ``max_strain`` (the largest |eps| of the step compared; of
        the file when not checkable), ``small_strain_bound``; when not checkable ``agree`` None
        and ``note`` ("not checkable: ..."); else ``step``, ``convention`` (the preset or shear in use),
        ``relative_difference`` and ``scale`` (SED array ~ scale x SED from the tensors, both in the
        file's units: 1 when the SED array is in the stress unit; for the best preset when no
        convention is declared), ``by_preset`` (relative difference per preset), ``best_preset``,
        ``tolerance`` (:data:`CROSSCHECK_RTOL`), ``agree`` (bool) and, for strains beyond the bound,
        ``note``.
    """
    try:
        (_, _, tloc), (e_name, strain, _) = find_tensors(raw, replace(opts, sed_from="exact"), need_convention=False)
        arr = find_sed_array(raw, ReadOptions(location=tloc, sed_column=opts.sed_column))[0]
    except (SEDFormatError, ValueError):
        return None
    if arr.location != tloc or (arr.ndim == 3 and arr.shape[2] != 1):
        return None
    ref = arr.values.reshape(arr.values.shape[0], -1)
    try:  # the strain's size under the convention in use; when none is known yet, the smaller (engineering) reading
        halve = _convention(opts, raw).shear == "engineering"
    except (SEDFormatError, ValueError):
        halve = True
    total, peaks = np.nansum(np.abs(ref), axis=1), _step_peaks(strain * np.repeat([1.0, 0.5 if halve else 1.0], 3))
    small = peaks <= SMALL_STRAIN_BOUND
    within = small & (total > 0)
    bound = {"sed_array": arr.name, "small_strain_bound": SMALL_STRAIN_BOUND}
    if not within.any() and not small.all() and is_finite_strain(e_name):
        return {**bound, "checkable": False, "max_strain": float(peaks.max()), "agree": None,
                "note": _beyond_bound(float(peaks.max()), True)}
    step = int(np.flatnonzero(within)[np.argmax(total[within])] if within.any() else np.argmax(total))
    one = replace(raw, arrays={k: a.then(lambda v: v[step:step + 1], (1,) + a.shape[1:]) for k, a in raw.arrays.items()},
                  times=None)
    columns = dict(location=tloc, stress_columns=opts.stress_columns, strain_columns=opts.strain_columns)

    def difference(raw_k, options):
        (_, s, _), (_, e, _) = find_tensors(raw_k, options)
        return _scaled_difference(ref[step], sed_exact(s, e)[0])

    free = replace(one, preset=None)
    by_preset, scales = {}, {}
    for name in PRESETS:
        by_preset[name], scales[name] = difference(free, ReadOptions(sed_from="exact", preset=name, **columns))
    best = min(by_preset, key=by_preset.get)
    in_use = opts.preset or raw.preset
    if in_use or opts.shear:
        rel, scale = difference(one, ReadOptions(sed_from="exact", preset=opts.preset, shear=opts.shear, **columns))
    else:  # no convention declared (afferent info): report the presets only
        rel, scale = by_preset[best], scales[best]
    return {
        **bound, "checkable": True, "max_strain": float(peaks[step]), "step": step,
        "convention": (f"preset={in_use!r}" if in_use else "") + (f" shear={opts.shear!r}" if opts.shear else ""),
        "relative_difference": rel, "scale": scale, "by_preset": by_preset, "best_preset": best,
        "location": tloc, "tolerance": CROSSCHECK_RTOL[tloc], "agree": bool(rel <= CROSSCHECK_RTOL[tloc]),
        **({} if within.any() or small.all() else {"note": _beyond_bound(float(peaks[step]), False)}),
    }


def density_by_values(raw: RawExport, arr) -> dict | None:
    """Is an array named like an energy (ELSE, SENE, Kratos' STRAIN_ENERGY) a density? The values decide.

    Compares it with 1/2 sigma:eps of the export's stress and strain tensors (at the array's
    location) under every preset (:func:`tensor_sed_crosscheck`): it is a density when the best
    preset agrees within :data:`CROSSCHECK_RTOL` with a least-squares scale inside
    :data:`DENSITY_SCALE_BAND` (an element energy is the density x the element volume).

    Returns
    -------
    dict or None
        None when the export has no tensors at that location, or when the comparison is not
        checkable (finite strains beyond :data:`SMALL_STRAIN_BOUND` at every step); else the
        cross-check's ``relative_difference``, ``scale`` and ``best_preset`` for the best preset,
        ``density`` (bool) and ``note`` (a sentence for the provenance).
    """
    check = tensor_sed_crosscheck(raw, ReadOptions(sed_column=arr.name, location=arr.location))
    if check is None or not check["checkable"] or check["sed_array"] != arr.name:
        return None
    best = check["best_preset"]
    rel, scale = check["by_preset"][best], check["scale"]
    density = bool(rel <= check["tolerance"] and DENSITY_SCALE_BAND[0] <= scale <= DENSITY_SCALE_BAND[1])
    note = (f"{arr.name!r} ({arr.location} data) is named like an energy, but its values are a density: "
            f"{scale:.3g} x 1/2 sigma:eps of the file's tensors (relative difference {rel:.2g} for the best preset; a "
            f"density has a scale in {DENSITY_SCALE_BAND}, an element energy the element volume).")
    return {"relative_difference": rel, "scale": scale, "best_preset": best, "density": density, "note": note}


def _stiffness_ratio(s: np.ndarray, e: np.ndarray) -> dict | None:
    """k_shear / k_normal of the rows (..., 6) (see :func:`shear_consistency`); None when too little to tell."""
    s, e = s.reshape(-1, 6), e.reshape(-1, 6)
    ok = np.isfinite(s).all(axis=1) & np.isfinite(e).all(axis=1)
    s, e = s[ok], e[ok]
    sd = s[:, :3] - s[:, :3].mean(axis=1, keepdims=True)
    ed = e[:, :3] - e[:, :3].mean(axis=1, keepdims=True)
    en, es = float(np.sum(ed * ed)), float(np.sum(e[:, 3:] ** 2))
    if en == 0.0 or es <= 1e-6 * en or es == 0.0:
        return None
    k_n, k_s = float(np.sum(sd * ed)) / en, float(np.sum(s[:, 3:] * e[:, 3:])) / es
    if k_n <= 0.0:
        return None
    ratio = k_s / k_n
    return {"ratio": ratio, "k_normal": k_n, "k_shear": k_s, "band": list(SHEAR_RATIO_BAND),
            "consistent": bool(SHEAR_RATIO_BAND[0] <= ratio <= SHEAR_RATIO_BAND[1])}


def shear_consistency(stress, strain, finite: bool = False) -> dict | None:
    """Is the strain's shear convention right? A check that needs no material data.

    For an isotropic linear-elastic solid the deviatoric stress is 2G times the deviatoric
    strain, for the normal (xx - mean) and the shear (xy, yz, xz) components alike. Fitting
    ``sigma_dev = k_n eps_dev`` on the normal components and ``sigma_ij = k_s eps_ij`` on the
    shear components over all points and steps gives ``k_s / k_n = 1`` when the shear strain is
    read with the right convention, 0.5 when engineering shear is read as tensor shear and 2 for
    the reverse. Averaging to the nodes is linear, so nodal data obey it too (CalculiX nodal
    STRESS/TOSTRAIN: to 3e-6); several materials or mild nonlinearity move it a little, never
    by a factor 2.

    Large deformation moves it by itself (:data:`SMALL_STRAIN_BOUND`), so only the steps whose
    strains stay within the bound are judged. When none does: for a finite-strain measure
    (``finite``, :func:`is_finite_strain`) the data are not checkable; otherwise every step is
    judged as a linear (small-strain) analysis, and a ``note`` says so.

    Parameters
    ----------
    stress, strain : ndarray of shape (n_steps, n, 6) or (n, 6) (one step)
        Canonical components (xx yy zz xy yz xz); strain with the shear as read (tensor).
    finite : bool
        The strain is a finite-strain measure (Green-Lagrange, logarithmic).

    Returns
    -------
    dict or None
        ``ratio`` (k_s / k_n), ``k_normal``, ``k_shear`` (Pa per unit strain, 2G for an
        isotropic solid), ``band``, ``consistent``, ``checkable`` (True), ``steps_judged`` (of
        ``n_steps``), ``max_strain`` (largest |eps| judged), ``small_strain_bound`` and, where
        steps were left out or the strains exceed the bound, ``note``. Not checkable:
        ``checkable`` False, ``consistent`` None, ``max_strain``, ``small_strain_bound`` and ``note``
        ("not checkable: ..."). None when the data hold too little shear or deviatoric strain to tell.
    """
    s, e = np.asarray(stress, dtype=float), np.asarray(strain, dtype=float)
    s, e = (s, e) if s.ndim >= 3 else (s.reshape(1, -1, 6), e.reshape(1, -1, 6))
    peaks = _step_peaks(e)
    within = peaks <= SMALL_STRAIN_BOUND
    fit = _stiffness_ratio(s[within], e[within]) if within.any() else None
    record = {"n_steps": int(peaks.size), "small_strain_bound": SMALL_STRAIN_BOUND}
    if fit is not None:
        left = int(peaks.size - within.sum())
        note = (f"{left} step(s) with strains beyond the small-strain bound {SMALL_STRAIN_BOUND:g} (up to "
                f"{peaks.max():.3g}) not judged" if left else None)
        return {**fit, **record, "checkable": True, "steps_judged": int(within.sum()),
                "max_strain": float(peaks[within].max()), **({"note": note} if note else {})}
    if within.all() or _stiffness_ratio(s, e) is None:
        return None
    if finite:
        return {**record, "checkable": False, "consistent": None, "max_strain": float(peaks.max()),
                "note": _beyond_bound(float(peaks.max()), True)}
    return {**_stiffness_ratio(s, e), **record, "checkable": True, "steps_judged": int(peaks.size),
            "max_strain": float(peaks.max()), "note": _beyond_bound(float(peaks.max()), False)}


def _caveat(check: dict) -> str:
    """' (Note.)' for a check's ``note``, '' without one."""
    note = check.get("note", "")
    return f" ({note[0].upper()}{note[1:]}.)" if note else ""


def _shear_said(raw: RawExport, shear: dict, conv, in_use: str) -> str:
    """What the shear/normal stiffness ratio says about the convention in use (the start of its messages)."""
    return (f"SED file {_where(raw)!r}: with the shear strain read as {conv.shear} ({in_use.strip()}), the shear "
            f"components of stress and strain are {shear['ratio']:.3g} x as stiff as the normal ones (1 for an "
            "isotropic solid)")


def _shear_message(raw: RawExport, shear: dict, conv, in_use: str) -> str:
    """The warning for a shear/normal stiffness ratio outside the band: which convention would fit, if any."""
    factor = 2.0 if conv.shear == "tensor" else 0.5  # reading the shear as the other convention scales the ratio so
    other = "engineering" if conv.shear == "tensor" else "tensor"
    said = _shear_said(raw, shear, conv, in_use)
    caveat = _caveat(shear) if shear["max_strain"] > SMALL_STRAIN_BOUND else ""
    if SHEAR_RATIO_BAND[0] <= factor * shear["ratio"] <= SHEAR_RATIO_BAND[1]:
        return f"{said}: the file's shear strain looks {other}. Check the preset or pass shear={other!r}.{caveat}"
    return (f"{said}, and {factor * shear['ratio']:.3g} x with the shear read as {other}: no shear convention explains "
            f"it. Check the stress and strain columns (an anisotropic material also does this).{caveat}")


def _refuse_convention(raw: RawExport, said: str, conv, fits: str, caveat: str) -> SEDFormatError:
    """The error for a shear convention the data contradict while another fits (the user did not confirm it
    with ``shear=``): ``said`` what the check found, ``fits`` the presets that fit."""
    other = "engineering" if conv.shear == "tensor" else "tensor"
    return SEDFormatError(
        f"{said}: the file's shear strain looks {other}, and read as {conv.shear} the SED from its tensors is wrong "
        f"(its shear terms {'doubled' if conv.shear == 'tensor' else 'halved'}), the likely cause the preset of "
        f"another tool; give the preset of the tool that wrote it, {fits}, or confirm the {conv.shear} convention "
        f"with shear={conv.shear!r}.{caveat}")


def _tensor_checks(raw: RawExport, opts: ReadOptions, s: np.ndarray, e: np.ndarray, location: str, checks: dict,
                   strain_name: str = ""):
    """Run the tensor cross-checks, record them in ``checks``; return the warning texts.

    ``strain_name``: the strain array's name (a finite-strain measure is judged within the small-strain bound only).

    Raises :class:`SEDFormatError` when the data contradict the shear convention in use and the other one fits
    (a preset of another tool: the SED would be off by tens of %), unless ``shear=`` confirms the convention.
    """
    messages = []
    conv = _convention(opts, raw)
    in_use = (f"preset={opts.preset or raw.preset!r}" if (opts.preset or raw.preset) else "") + (
        f" shear={opts.shear!r}" if opts.shear else "")
    other = "engineering" if conv.shear == "tensor" else "tensor"
    shear = shear_consistency(s, e, finite=is_finite_strain(strain_name))
    check = tensor_sed_crosscheck(raw, opts)
    if shear is not None:
        checks["shear_convention"] = shear
        if shear["checkable"] and not shear["consistent"]:
            msg = _shear_message(raw, shear, conv, in_use)
            factor = 2.0 if conv.shear == "tensor" else 0.5
            if opts.shear is None and SHEAR_RATIO_BAND[0] <= factor * shear["ratio"] <= SHEAR_RATIO_BAND[1]:
                fits = [p for p, c in PRESETS.items() if c.shear == other]
                if check is not None and check.get("checkable") and check["by_preset"][check["best_preset"]] <= \
                        check["tolerance"]:
                    fits = [p for p in fits if abs(check["by_preset"][p] - check["by_preset"][check["best_preset"]])
                            <= 1e-9 + 1e-6 * check["by_preset"][check["best_preset"]]] or fits
                raise _refuse_convention(raw, _shear_said(raw, shear, conv, in_use), conv,
                                         f"one of {', '.join(map(repr, fits))} ({other} shear)",
                                         _caveat(shear) if shear["max_strain"] > SMALL_STRAIN_BOUND else "")
            messages.append(msg)
    if check is not None:
        checks["tensor_sed_vs_export_sed"] = check
        if check["checkable"] and not check["agree"]:
            best = check["best_preset"]
            said = (f"SED file {_where(raw)!r}: 1/2 sigma:eps from the tensors ({check['convention'].strip()}) differs "
                    f"from the file's own SED array {check['sed_array']!r} by {_percent(check['relative_difference'])} "
                    f"(relative L2 at step {check['step']}, after a scale of {check['scale']:.4g}; expected below "
                    f"{_percent(check['tolerance'])} for {check['location']} data); {_presets_like(check, best)} "
                    f"{_percent(check['by_preset'][best])}")
            if opts.shear is None and check["by_preset"][best] <= check["tolerance"] and PRESETS[best].shear != conv.shear:
                raise _refuse_convention(raw, said, conv, _presets_like(check, best).split(" give")[0].replace(
                    "presets ", "one of ").replace("preset ", ""), _caveat(check))
            messages.append(f"{said}. Check the preset and the columns.{_caveat(check)}")
    return messages


def negative_sed_report(sed: np.ndarray, tolerance: float = NEGATIVE_SED_RTOL) -> dict | None:
    """Count and size the negative values of an SED array; None when there are none.

    Parameters
    ----------
    sed : ndarray of shape (n_times, n_values)
        SED in any unit (the report's ``min_pa`` is in the same unit).
    tolerance : float
        Accepted size of the negatives: the most negative value at most ``tolerance`` x the
        largest SED, and the negatives' sum at most ``tolerance`` x the positives' sum.

    Returns
    -------
    dict or None
        ``count``, ``n_values``, ``min_pa`` (most negative value), ``min_relative`` (that value
        over the largest SED; -inf when no value is positive), ``negative_share`` (sum of the
        negatives' magnitudes over the sum of the positive values), ``tolerance``,
        ``within_tolerance``, ``action`` ('set to 0' or 'refused'), ``first_step``, ``first_row``.
    """
    neg = sed < 0
    if not neg.any():
        return None
    smax = float(np.max(sed))
    smin = float(np.min(sed))
    pos_sum = float(np.sum(sed[sed > 0]))
    rel = smin / smax if smax > 0 else -np.inf
    share = float(-np.sum(sed[neg])) / pos_sum if pos_sum > 0 else np.inf
    ok = bool(-rel <= tolerance and share <= tolerance)
    t, i = np.argwhere(neg)[0]
    return {
        "count": int(neg.sum()), "n_values": int(sed.size), "min_pa": smin, "min_relative": rel,
        "negative_share": share, "tolerance": float(tolerance), "within_tolerance": ok,
        "action": "set to 0" if ok else "refused", "first_step": int(t), "first_row": int(i),
    }
