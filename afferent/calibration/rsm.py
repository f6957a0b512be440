"""The response-surface (RSM) calibration loop: the study's first-order procedure and a second-order variant.

::

    start --[design around the base -> fit a surface -> step downhill -> re-centre]* --> outcome for finish()

``method='rsm1'`` (the default) is the study's procedure: a two-level full factorial + centre
design (9 runs) in coded parameters at 5 % increments, a first-order fit, steepest-descent
steps while the ssd decreases, re-centred on the best point, repeated until an iteration no
longer lowers the ssd by more than ``tol`` (relative). ``method='rsm2'`` fits a second-order
surface (central composite or Box-Behnken design) and steps to its minimum inside the design
region. Both can stall in a curved valley of the ssd before its optimum; the message says so.
"""

from __future__ import annotations

from .design import DesignName
from .objective import Objective
from ..transduction import SigmoidParams

from typing import Literal

import math

import numpy as np

from ..transduction import saturation_report
from .design import PARAMETERS, decode, encode, increments, make_design, params_to_vector, vector_to_params
from .objective import Runs, clip, iter_row
from .surface import NO_EFFECT_RTOL, canonical_analysis, fit_first_order, make_response_surface
from .surface import steepest_descent, surface_minimum

__all__ = ["DEFAULT_TOL", "DEFAULT_MAX_ITER", "DEFAULT_MAX_STEPS", "rsm"]

#: Relative tolerance: an RSM iteration that lowers the best ssd by at most ``tol`` x the
#: ssd it started from ends the loop (converged). 1e-3 = 0.1 %: the study quotes ssd to two
#: significant digits (0.70 -> 0.24), so a smaller gain is invisible in its table, and on
#: noisy data later gains only fit the noise. Relative, so the same default serves
#: normalised profiles (ssd ~ 0.01-1) and ``normalise='neither'`` (ssd in A^2, ~1e-16).
DEFAULT_TOL = 1e-3
#: Iteration budget, not the stopping rule (``tol`` is). The study reports stopping after 3
#: iterations without saying why; a fixed 3 would cut off data that still improve, so the
#: budget is generous and ``success=False`` says when it ran out. On the synthetic data of
#: tests/test_calibration.py the study's procedure stops by itself after 2 iterations (31
#: evaluations); each iteration costs 8 new design runs plus its descent steps.
DEFAULT_MAX_ITER = 50
#: Largest number of steepest-descent steps per iteration. Steps are one coded unit (5 % of
#: the iteration's base value) on the steepest parameter: if that is lambda, moving it from
#: the study's start (300 Pa) to its longitudinal fit (-705 Pa) takes 67 steps.
DEFAULT_MAX_STEPS = 100
#: A design whose ssd spread is at most this fraction of its largest ssd is flat.
FLAT_RTOL = 1e-12
#: The coding step never falls below ``increment x |start| / 10`` (lambda may cross zero).
STEP_FLOOR_FRACTION = 0.1


class _Loop:
    """Mutable state of one RSM run: the base point, the tables, what was clipped or had no effect."""

    def __init__(self, obj, start, method, design_name):
        self.obj, self.method, self.runs = obj, method, Runs()
        self.x0 = params_to_vector(start)
        self.floor = STEP_FLOOR_FRACTION * np.abs(self.x0)
        self.coded = make_design(design_name)
        self.n_fac = self.coded.shape[1]
        self.centre_row = int(np.flatnonzero(np.all(self.coded == 0, axis=1))[0])
        self.radius = float(np.max(np.abs(self.coded)))
        ev, fit, degen = obj(self.x0)
        self.runs.add(0, "start", 0, np.zeros(self.n_fac), self.x0, ev, fit, degen, False)
        self.base, self.base_ssd = self.x0, fit.ssd
        self.iters = [iter_row(0, self.base, self.base_ssd, obj.n_evaluations)]
        self.coef_rows = []
        self.clipped_any = np.zeros(self.n_fac, bool)
        self.no_effect_all = np.ones(self.n_fac, bool)
        self.n_fits = 0
        self.canonical = None
        # With a min-max normalised prediction alpha cancels out of the ssd exactly: it is never
        # moved (its measured coefficient is still reported, as evidence).
        self.frozen = np.array([obj.norm_pred] + [False] * (self.n_fac - 1))

    def add_iteration(self, it):
        self.iters.append(iter_row(it, self.base, self.base_ssd, self.obj.n_evaluations))

    def outcome(self, status, note) -> dict:
        """The loop's outcome for :func:`.result.finish`; ``status`` 'converged', 'flat' or 'max_iter'."""
        import pandas as pd

        measured = self.no_effect_all if self.n_fits else np.zeros(self.n_fac, bool)
        no_effect = tuple(p for p, e, fz in zip(PARAMETERS, measured, self.frozen) if e or fz)
        return dict(base=self.base, iterations=pd.DataFrame(self.iters), runs=self.runs.frame(),
                    coefficients=pd.DataFrame(self.coef_rows), no_effect=no_effect,
                    clipped=tuple(p for p, c in zip(PARAMETERS, self.clipped_any) if c),
                    success=status == "converged", status=status, note=note, canonical=self.canonical)


def rsm(obj: Objective, start: SigmoidParams, inc: float, tol: float, max_iter: int, max_steps: int, method: Literal['rsm1', 'rsm2'], design_name: DesignName, refine: int) -> dict:
    """Run the RSM loop (``method`` 'rsm1' or 'rsm2') from ``start``; the outcome for :func:`.result.finish`.

    Parameters
    ----------
    obj : Objective
    start : SigmoidParams
        alpha (A), gamma (1/Pa), lambda (Pa); each non-zero.
    inc : float
        Coding step as a fraction of the base value (the study: 0.05).
    tol : float
        Relative ssd decrease per iteration that ends the loop.
    max_iter, max_steps : int
        Iteration budget; descent steps per iteration.
    method : {'rsm1', 'rsm2'}
    design_name : {'factorial', 'ccd', 'bbd'}
    refine : int
        Times the increments may be halved when an iteration ends the loop.

    Returns
    -------
    dict
        ``base`` (end point, A, 1/Pa, Pa), ``iterations``, ``runs``, ``coefficients``,
        ``no_effect``, ``clipped``, ``success``, ``status`` ('converged', 'flat' or
        'max_iter'), ``note`` (why it stopped, in words), ``canonical``.
    """
    st = _Loop(obj, start, method, design_name)
    level, inc_it, last_decrease = 0, inc, math.nan
    for it in range(1, max_iter + 1):
        dxi = increments(st.base, inc_it, floor=st.floor)
        pts, chis, ssd, deg = _evaluate_design(st, it, dxi)
        ok = ~deg
        if _is_flat(ssd, ok, st.n_fac):
            st.add_iteration(it)
            return st.outcome("flat", _flat_message(it, ssd, deg, st.base, obj))
        row = {"iteration": it, "increment": inc_it,
               **{f"base_{p}": float(v) for p, v in zip(PARAMETERS, st.base)},
               **{f"dxi_{p}": float(v) for p, v in zip(PARAMETERS, dxi)}}
        fitter = _first_order_direction if method == "rsm1" else _second_order_direction
        fitted = fitter(st, chis, ssd, ok, row)
        if fitted is None:  # no parameter acts on the ssd
            st.add_iteration(it)
            return st.outcome("flat", _flat_message(it, ssd, deg, st.base, obj))
        direction, no_eff, fixed = fitted
        st.n_fits += 1
        st.no_effect_all &= no_eff
        path_ssd, path_vec, n_steps = _descend(st, it, direction, dxi, pts, ssd, deg, max_steps)
        row.update({**{f"step_{p}": float(v) for p, v in zip(PARAMETERS, direction)}, "n_steps": n_steps,
                    "no_effect": ",".join(p for p, e in zip(PARAMETERS, no_eff) if e)})
        st.coef_rows.append(row)
        best_vec, best_ssd = _best_point(st, it, dxi, pts, ssd, ok, path_ssd, path_vec, fixed)
        start_ssd = st.base_ssd
        if best_ssd < st.base_ssd:
            st.base, st.base_ssd = best_vec, best_ssd
        last_decrease = start_ssd - st.base_ssd
        st.add_iteration(it)
        if last_decrease <= tol * abs(start_ssd):
            if level < refine:
                level += 1
                inc_it *= 0.5
                continue
            note = _converged_message(it, last_decrease, tol, start_ssd, inc_it, level,
                                      stall_note=method == "rsm1" and refine == 0 and last_decrease == 0.0)
            return st.outcome("converged", note)
    if level and last_decrease <= tol * abs(st.iters[-2]["ssd"]):
        note = (f"Stopped at max_iter={max_iter} iterations while refining the increments (now {inc_it:.3g} of "
                "the base value); raise max_iter.")
    else:
        note = (
            f"Stopped at max_iter={max_iter} iterations with the ssd still decreasing (by {last_decrease:.3g} in "
            f"the last one, > tol {tol:g} relative); raise max_iter or start closer."
        )
    return st.outcome("max_iter", note)


def _evaluate_design(st, it, dxi):
    """Evaluate the coded design around the base: points (physical), codes as evaluated, ssd, degenerate."""
    pts, low = clip(decode(st.coded, st.base, dxi))
    chis = np.where(low, encode(pts, st.base, dxi), st.coded)  # as evaluated: clipped points re-encoded
    ssd = np.empty(len(pts))
    deg = np.zeros(len(pts), bool)
    for r, (chi, vec, lo) in enumerate(zip(chis, pts, low)):
        ev, f, d = st.obj(vec)
        ssd[r], deg[r] = f.ssd, d
        st.clipped_any |= lo
        st.runs.add(it, "design", r, chi, vec, ev, f, d, lo.any())
    return pts, chis, ssd, deg


def _is_flat(ssd, ok, n_fac) -> bool:
    """Too few usable runs to fit a surface, or all usable runs give the same ssd."""
    spread = float(ssd[ok].max() - ssd[ok].min()) if ok.any() else 0.0
    scale = float(np.max(np.abs(ssd[ok]))) if ok.any() else 0.0
    return bool(ok.sum() < n_fac + 1 or spread <= FLAT_RTOL * max(scale, np.finfo(float).tiny))


def _first_order_direction(st, chis, ssd, ok, row):
    """The study's step: fit ``ssd ~ b0 + b . chi`` and go down its steepest slope. Fills ``row``."""
    pair_none = _pair_no_effect(chis, ssd, ok)
    lin = fit_first_order(chis[ok], ssd[ok])
    # ~0 coefficient relative to the largest, and no pair of runs that differ only in
    # this parameter differs in ssd (a symmetric effect would also give b_k ~ 0).
    no_eff = lin.no_effect & pair_none
    fixed = no_eff | st.frozen
    direction = steepest_descent(lin.coef, no_effect=fixed)
    corners = ok & np.all(np.abs(chis) == 1.0, axis=1)
    # Curvature check: mean of the factorial corners minus the centre run (> 0: a bowl
    # the plane cannot follow; the first-order model is then only a local guide).
    c = st.centre_row
    curv = float(ssd[corners].mean() - ssd[c]) if corners.any() and ok[c] else 0.0
    row.update({"b0": lin.intercept, **{f"b_{p}": float(v) for p, v in zip(PARAMETERS, lin.coef)},
                "fit_r2": lin.r2, "curvature": curv})
    return direction, no_eff, fixed


def _second_order_direction(st, chis, ssd, ok, row):
    """Fit a second-order surface and step to its minimum inside the design region; None if nothing acts."""
    no_eff = _pair_no_effect(chis, ssd, ok)
    fixed = no_eff | st.frozen
    eff = np.flatnonzero(~fixed)
    if eff.size == 0:
        return None
    # The surface is fitted on the parameters that act on the ssd only: a no-effect
    # parameter's quadratic column would soak up lack of fit (fake curvature).
    surface = make_response_surface(2).fit(chis[ok][:, eff], ssd[ok])
    st.canonical = canonical = _embed_canonical(canonical_analysis(surface), eff, st.n_fac)
    names = [PARAMETERS[k] for k in eff]
    terms = surface.named_steps["poly"].get_feature_names_out(names)
    coefs = np.asarray(surface.named_steps["ols"].coef_, dtype=float)
    direction = np.zeros(st.n_fac)
    direction[eff] = surface_minimum(surface, radius=st.radius)
    pred = surface.predict(chis[ok][:, eff])
    ss_tot = float(np.sum((ssd[ok] - ssd[ok].mean()) ** 2))
    all_terms = make_response_surface(2).named_steps["poly"].fit(np.zeros((1, st.n_fac))).get_feature_names_out(
        list(PARAMETERS))
    row.update({"b0": float(canonical.b0), **{_term_name(t): 0.0 for t in all_terms},
                **{_term_name(t): float(c) for t, c in zip(terms, coefs)},
                "fit_r2": 1.0 - float(np.sum((ssd[ok] - pred) ** 2)) / ss_tot if ss_tot > 0 else 1.0,
                "kind": canonical.kind,
                **{f"chi_s_{p}": float(v) for p, v in zip(PARAMETERS, canonical.stationary_point)},
                **{f"eig_{i}": float(v) for i, v in enumerate(canonical.eigenvalues)}})
    return direction, no_eff, fixed


def _descend(st, it, direction, dxi, pts, ssd, deg, max_steps):
    """Steps n x direction, n = 1, 2, ..., while the ssd decreases: (path ssd, path points, steps taken)."""
    c = st.centre_row
    prev = ssd[c] if not deg[c] else math.inf
    prev_vec = pts[c]
    n_steps = 0
    path_ssd, path_vec = [], []
    if not np.any(direction != 0):
        return path_ssd, path_vec, n_steps
    for n in range(1, max_steps + 1):
        vec, lo = clip(decode(n * direction, st.base, dxi))
        if np.array_equal(vec, prev_vec):
            break  # pinned at a bound: no further move
        ev, f, d = st.obj(vec)
        st.clipped_any |= lo
        st.runs.add(it, "path", n, encode(vec, st.base, dxi), vec, ev, f, d, lo.any())
        n_steps = n
        if d or not f.ssd < prev:
            break
        prev, prev_vec = f.ssd, vec
        path_ssd.append(f.ssd)
        path_vec.append(vec)
    return path_ssd, path_vec, n_steps


def _best_point(st, it, dxi, pts, ssd, ok, path_ssd, path_vec, fixed):
    """The best usable point of the iteration (design or path), no-effect parameters held at the base."""
    cand_ssd = list(ssd[ok]) + path_ssd
    cand_vec = list(pts[ok]) + path_vec
    k = int(np.argmin(cand_ssd))  # the first minimum: deterministic
    best_vec, best_ssd = np.asarray(cand_vec[k]), float(cand_ssd[k])
    if fixed.any() and not np.array_equal(best_vec[fixed], st.base[fixed]):
        # A no-effect parameter only changes the ssd by rounding: never let it move the base.
        best_vec = np.where(fixed, st.base, best_vec)
        ev, f, d = st.obj(best_vec)
        st.runs.add(it, "projected", 0, encode(best_vec, st.base, dxi), best_vec, ev, f, d, False)
        best_ssd = math.inf if d else f.ssd
    return best_vec, best_ssd


def _converged_message(it, last_decrease, tol, start_ssd, inc_it, level, *, stall_note) -> str:
    res_txt = f"{inc_it:.3g} of the base value" + (f" after {level} refinement(s)" if level else "")
    status = (
        f"Converged after {it} iteration(s): the last one lowered the ssd by {last_decrease:.3g} "
        f"(<= tol {tol:g} x {start_ssd:.4g}) at increments of {res_txt}."
    )
    if stall_note:
        status += (
            " No design or descent point improved on the centre at this resolution; a first-order model "
            "can stall in a curved valley before the optimum: refine=N (halve the increments up to N "
            "times) or method='rsm2' may go further."
        )
    return status


def _pair_no_effect(chis, ssd, ok) -> np.ndarray:
    """Per factor: True if every pair of usable runs differing only in that factor has the same ssd.

    "The same" is ``|ssd_i - ssd_j| <= NO_EFFECT_RTOL x (max - min ssd over the runs)``.
    A factor without such a pair is False (no evidence of no effect).
    """
    X, y = chis[ok], ssd[ok]
    spread = float(y.max() - y.min()) if y.size else 0.0
    n = X.shape[1]
    out = np.zeros(n, bool)
    for k in range(n):
        others = np.delete(X, k, axis=1)
        worst, found = 0.0, False
        for i in range(len(X)):
            same = np.all(others == others[i], axis=1) & (X[:, k] != X[i, k])
            if same.any():
                found = True
                worst = max(worst, float(np.max(np.abs(y[same] - y[i]))))
        out[k] = found and worst <= NO_EFFECT_RTOL * spread
    return out


def _embed_canonical(can, eff, n):
    """A CanonicalAnalysis of the effective factors, embedded in all n factors (0 along the others)."""
    from .surface import CanonicalAnalysis

    if eff.size == n:
        return can
    xs = np.zeros(n)
    xs[eff] = can.stationary_point
    b = np.zeros(n)
    b[eff] = can.b
    B = np.zeros((n, n))
    B[np.ix_(eff, eff)] = can.B
    vec = np.zeros((n, n))
    rest = np.setdiff1d(np.arange(n), eff)
    vec[np.ix_(eff, np.arange(eff.size))] = can.eigenvectors
    vec[rest, eff.size + np.arange(rest.size)] = 1.0
    vals = np.concatenate([can.eigenvalues, np.zeros(rest.size)])
    return CanonicalAnalysis(xs, can.stationary_value, vals, vec, can.kind, can.b0, b, B)


def _term_name(term: str) -> str:
    """sklearn's 'alpha^2' / 'alpha gamma' -> 'b_alpha^2' / 'b_alpha*gamma'."""
    return "b_" + term.replace(" ", "*")


def _flat_message(it, ssd, deg, base, obj) -> str:
    p = vector_to_params(base)
    sat = saturation_report(obj.sed_row, p)
    n = len(ssd)
    if deg.all():
        what = (f"all {n} design runs give a constant or nearly constant predicted profile, whose min-max "
                "normalised shape is rounding noise")
    elif (~deg).sum() < 4:
        what = (f"{int(deg.sum())} of {n} design runs give a constant or nearly constant predicted profile, "
                "too few remain to fit a surface")
    else:
        vals = ssd[~deg]
        what = f"all {int((~deg).sum())} usable design runs give the same ssd {float(vals[0]):.6g}"
    return (
        f"The objective is flat around {p!r} (iteration {it}): {what}. {sat.message} "
        "No descent direction exists; start where the receptors are in the sigmoid's sensitive range "
        "(a lambda inside the SED range at the receptors, gamma ~ 4 / that range)."
    )
