"""The report's text and figures: Markdown tables and one PNG per knob, from the measurements."""

from __future__ import annotations

import os

import numpy as np

from .measure import ReportSize

def _fmt_s(s) -> str:
    if s is None:
        return "-"
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def _fmt_rel(x) -> str:
    if x is None:
        return "-"
    return "0" if x == 0 else f"{x:.2%}" if x >= 1e-3 else f"{x:.1e}"


def _table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def headline(results: dict) -> dict:
    """The report's headline figures (those the README quotes), from :func:`run_report`'s results."""
    samp = {r["method"]: r for r in results["sampling"]}
    spk = {(r["engine"], r["dt_s"]): r for r in results["spiking"] if r.get("wall_s") is not None}
    cal = [r for r in results["calibration"] if r["normalise"] == "both"]
    out = {"linear_err_max": samp["linear"]["err_max"], "nearest_err_max": samp["nearest"]["err_max"],
           "linear_err_median": samp["linear"]["err_median"], "nearest_err_median": samp["nearest"]["err_median"],
           "exact_wall_s": spk["exact", None]["wall_s"]}
    for dt in (1e-3, 1e-4, 1e-5):
        if ("fast", dt) in spk:
            out[f"fast_{dt:g}_rate_err"] = spk["fast", dt]["rate_err_median"]
            out[f"fast_{dt:g}_wall_s"] = spk["fast", dt]["wall_s"]
        if ("brian2", dt) in spk:
            out[f"brian2_{dt:g}_wall_s"] = spk["brian2", dt]["wall_s"]
    for label in ("rsm1", "least_squares"):
        mine = [r for r in cal if r["method"] == label]
        out[f"{label}_evaluations"] = max(r["evaluations"] for r in mine)
        out[f"{label}_err_max"] = max(max(r[f"err_{p}"] or 0 for p in ("alpha", "gamma", "lambda")) for r in mine)
    return out


def _log_axis(ax, values, axis: str = "y") -> None:
    """Log scale on ``axis`` if ``values`` hold a positive finite number (else matplotlib refuses)."""
    v = np.asarray([x for x in values if x is not None], dtype=float)
    if np.any(np.isfinite(v) & (v > 0)):
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def _count_ticks(ax, counts) -> None:
    """x ticks at the measured counts, as plain integers, no minor labels (they collide on a short log axis)."""
    from matplotlib.ticker import NullFormatter

    ax.set_xticks(counts, [f"{c:d}" for c in counts])
    ax.xaxis.set_minor_formatter(NullFormatter())


def _subplots(height: float):
    """A 1 x 2 figure outside pyplot (any backend, nothing left open)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, height), layout="constrained")
    return fig, fig.subplots(1, 2)


def _plot_sampling(results: dict, folder: str) -> str:
    """The sampling figure, saved into ``folder``; returns its path."""
    from ..plotting import legend_beside, save_figure

    rows = results["sampling"]
    fig, (ax_e, ax_t) = _subplots(3.4)
    x = np.arange(len(rows))
    for j, (key, label) in enumerate((("err_median", "median"), ("err_p95", "95th percentile"), ("err_max", "max"))):
        ax_e.bar(x + (j - 1) * 0.27, [r[key] for r in rows], 0.27, label=label)
    ax_e.set_xticks(x, [r["method"] for r in rows])
    _log_axis(ax_e, [r[k] for r in rows for k in ("err_median", "err_p95", "err_max")])
    ax_e.set_ylabel("relative error of the sampled SED")
    legend_beside(ax_e)
    ax_t.bar(x - 0.2, [r["weights_s"] * 1e3 for r in rows], 0.4, label="weights (once)")
    ax_t.bar(x + 0.2, [r["per_step_s"] * 1e3 for r in rows], 0.4, label="per time step")
    ax_t.set_xticks(x, [r["method"] for r in rows])
    _log_axis(ax_t, [r[k] for r in rows for k in ("weights_s", "per_step_s")])
    ax_t.set_ylabel("time (ms)")
    legend_beside(ax_t)
    fig.suptitle("Sampling the SED at receptor sites: error and time per method")
    return save_figure(fig, os.path.join(folder, "sampling.png"))


def _plot_spiking(results: dict, folder: str) -> str:
    """The spiking figure, saved into ``folder``; returns its path."""
    from ..plotting import legend_beside, save_figure

    rows = [r for r in results["spiking"] if r.get("wall_s") is not None]
    exact = rows[0]
    fig, (ax_t, ax_e) = _subplots(3.6)
    for engine, marker in (("fast", "o"), ("brian2", "s")):
        part = [r for r in rows if r["engine"] == engine]
        if part:
            ax_t.loglog([r["dt_s"] * 1e3 for r in part], [r["wall_s"] for r in part], marker + "-", label=engine)
    ax_t.axhline(exact["wall_s"], color="k", ls=":", label="exact (no dt)")
    ax_t.set_xlabel("dt (ms)")
    ax_t.set_ylabel("wall time (s)")
    legend_beside(ax_t)
    fast = [r for r in rows if r["engine"] == "fast"]
    dts = np.array([r["dt_s"] * 1e3 for r in fast])
    ax_s = ax_e.twinx()  # the relative error (dimensionless) left, the time errors (s) right: one unit per axis
    hidden = []
    for ax, key, label, marker in ((ax_e, "rate_err_median", "rate, median relative error (left)", "C0o-"),
                                   (ax_s, "spike_err_median_s", "spike time, median error (s, right)", "C1^--"),
                                   (ax_s, "latency_err_max_s", "first-spike latency, max error (s, right)", "C2s:")):
        vals = np.array([r[key] for r in fast], dtype=float)
        hidden += [f"{label.split(',')[0]} at dt = {d:g} ms" for d, v in zip(dts, vals) if not v > 0]
        ax.loglog(dts, np.where(vals > 0, vals, np.nan), marker, label=label)
    ax_e.set_xlabel("dt of the fast engine (ms); brian2 gives the same spikes")
    ax_e.set_ylabel("relative error of the rate")
    ax_s.set_ylabel("error (s)")
    # a zero error has no place on a log axis: say which points are not drawn
    legend_beside(ax_e, title=("zero, not drawn: " + "; ".join(hidden)) if hidden else None)
    fig.suptitle("Spiking engines: wall time and error against the exact engine, by time step")
    return save_figure(fig, os.path.join(folder, "spiking.png"))


def _plot_receptors(results: dict, folder: str) -> str:
    """The receptors figure, saved into ``folder``; returns its path."""
    from ..plotting import legend_beside, save_figure

    rows = results["receptors"]
    fig, (ax_t, ax_e) = _subplots(3.4)
    n = [r["receptors"] for r in rows]
    ax_t.loglog(n, [r["sampling_s"] * 1e3 for r in rows], "o-", label="sampling (locating + weights)")
    ax_t.loglog(n, [r["transduce_synthesize_s"] * 1e3 for r in rows], "s-", label="transduction + synthesis")
    ax_t.set_xlabel("receptors")
    ax_t.set_ylabel("time (ms)")
    legend_beside(ax_t)
    ax_e.semilogx(n[:-1], [r["profile_error"] for r in rows[:-1]], "o-", label="normalised profile")
    ax_e.semilogx(n[:-1], [r["current_error"] for r in rows[:-1]], "s-", label="mean current per receptor")
    ax_e.set_xlabel("receptors")
    for ax in (ax_t, ax_e):
        _count_ticks(ax, n)
    ax_e.set_ylabel(f"max error vs {rows[-1]['per_papilla']} per papilla")
    legend_beside(ax_e)
    fig.suptitle("Receptor density: time and error against the densest layout")
    return save_figure(fig, os.path.join(folder, "receptors.png"))


def _plot_calibration(results: dict, folder: str) -> str:
    """The calibration figure, saved into ``folder``; returns its path."""
    from ..plotting import save_figure

    rows = results["calibration"]
    fig, (ax_n, ax_e) = _subplots(4.2)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    cases = list(dict.fromkeys((r["truth"], r["normalise"]) for r in rows))
    x = np.arange(len(methods))
    w = 0.8 / len(cases)
    for j, case in enumerate(cases):
        part = [next(r for r in rows if (r["truth"], r["normalise"]) == case and r["method"] == m) for m in methods]
        label = f"{case[0]}, normalise {case[1]}"
        ax_n.bar(x + (j - (len(cases) - 1) / 2) * w, [r["evaluations"] for r in part], w, label=label)
        worst = [max(r[f"err_{p}"] or 0 for p in ("alpha", "gamma", "lambda")) for r in part]
        ax_e.bar(x + (j - (len(cases) - 1) / 2) * w, np.maximum(worst, 1e-16), w, label=label)
    for ax in (ax_n, ax_e):
        ax.set_xticks(x, [m.replace(" (", "\n(") for m in methods], fontsize="small")
        ax.set_yscale("log")  # evaluations >= 1; errors floored at 1e-16 above
    ax_n.set_ylabel("model evaluations")
    ax_e.set_ylabel("largest relative parameter error")
    fig.legend(*ax_n.get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize="small")
    fig.suptitle("Calibration methods: cost and recovered parameters")
    return save_figure(fig, os.path.join(folder, "calibration.png"))


def _plot_series(results: dict, folder: str) -> str:
    """The series figure, saved into ``folder``; returns its path."""
    from ..plotting import legend_beside, save_figure

    rows = results["series"]
    fig, (ax_t, ax_m) = _subplots(3.4)
    for how, marker in (("read_sed + sample_sed", "o-"), ("iter_sed + sample_steps", "s-")):
        part = [r for r in rows if r["how"] == how]
        ax_t.plot([r["steps"] for r in part], [r["wall_s"] for r in part], marker, label=how)
        ax_m.plot([r["steps"] for r in part], [r["peak_mb"] for r in part], marker, label=how)
    ax_t.set_ylabel("wall time (s)")
    ax_m.set_ylabel("peak traced memory (MB)")
    for ax in (ax_t, ax_m):
        ax.set_xlabel(f"time steps ({rows[0]['points']:,}-node mesh)")
        ax.set_ylim(bottom=0)
        legend_beside(ax)
    fig.suptitle("Time series: whole read against streamed read")
    return save_figure(fig, os.path.join(folder, "series.png"))


def _plots(results: dict, folder: str) -> dict:
    """Every knob's figure: ``{knob: PNG file name}``."""
    draw = {"sampling": _plot_sampling, "spiking": _plot_spiking, "receptors": _plot_receptors,
            "calibration": _plot_calibration, "series": _plot_series}
    return {k: os.path.basename(f(results, folder)) for k, f in draw.items()}


#: The report's sections, in order: (key, title).
SECTIONS = (("machine", "Machine and versions"), ("sampling", "Sampling method"),
            ("spiking", "Spiking engine and time step"), ("receptors", "Receptor count"),
            ("calibration", "Calibration method"), ("series", "Reading a time series"), ("headline", "Headline figures"))


def _md_intro(results: dict, size: ReportSize, png: dict, t: dict, command: str) -> list[str]:
    """Title, how the report was made, the machine and versions."""
    m = results["machine"]
    v = m["versions"]
    out = [f"# afferent speed and accuracy report ({size.name})", "",
           f"Written by `{command}` in {results['wall_s']:.0f} s. Every figure below was measured in that run, on this "
           "machine; times are the fastest of the timed runs (wall clock). Each section states the size of its "
           "measurement and how long it took; `afferent report --full` runs the larger sizes of the benchmark "
           "scripts (`benchmarks/*.py` in the source repository).", ""]
    out += ["## Machine and versions", "",
            _table(["what", "value"], [
                ["CPUs", m["cpus"]], ["CPU model", m["cpu_model"] or "not readable"],
                ["RAM", "not readable" if m["ram_gb"] is None else f"{m['ram_gb']:.1f} GB"],
                ["platform", m["platform"]],
                *[[name, ver or "absent"] for name, ver in v.items()]]), ""]
    return out


def _md_sampling(results: dict, size: ReportSize, png: dict, t: dict) -> list[str]:
    """The sampling section."""
    s = {r["method"]: r for r in results["sampling"]}
    return ["## Sampling method", "",
            f"A manufactured SED (a smooth 4 kPa bump, known everywhere) on the mesh of the packaged sample "
            f"(`block4/indent_0p88mm.vtu`, {results['mesh_points']:,} nodes), sampled at {s['linear']['receptors']:,} random "
            f"sites within 0.04 mm (x, z) of the papilla tips and 0.02-0.05 mm below them; errors are relative to the exact value ({_t(t, 'sampling')}).", "",
            _table(["method", "weights (once)", "per time step", "median error", "95th pct", "max error"],
                   [[r["method"], _fmt_s(r["weights_s"]), _fmt_s(r["per_step_s"]), _fmt_rel(r["err_median"]),
                     _fmt_rel(r["err_p95"]), _fmt_rel(r["err_max"])] for r in results["sampling"]]), "",
            f"![sampling]({png['sampling']})", "",
            "`linear` (the default) interpolates in the mesh's own cells; `nearest` takes one node's value. Both "
            "locate every site once; applying the weights per step costs almost nothing either way.", ""]


def _md_spiking(results: dict, size: ReportSize, png: dict, t: dict) -> list[str]:
    """The spiking section."""
    rows = results["spiking"]
    cf = results["closed_form"]
    return ["## Spiking engine and time step", "",
            f"A synthetic ramp-and-hold current (ramp 100 ms, hold 500 ms, release 100 ms; plateaus 30 nA - 16 uA, "
            f"sampled every 1 ms) drives {size.spiking_afferents} afferents for {size.spiking_duration:g} s through the RA "
            "leaky integrate-and-fire preset. Errors are against `engine='exact'` (the default: event-driven, no time "
            f"step, exact spike times), rank-matched spike by spike ({_t(t, 'spiking')}).", "",
            _table(["engine", "backend", "dt", "wall time", "spikes", "rate error (median)", "rate error (max)",
                    "spike time error (median)", "count differs", "first-spike error (max)"],
                   [[r["engine"], r["backend"] or "-", "none" if r["dt_s"] is None else f"{r['dt_s'] * 1e3:g} ms",
                     _fmt_s(r["wall_s"]), r["spikes"] if r["spikes"] is not None else "-",
                     *(["skipped: " + r["skipped"], "", "", "", ""] if "skipped" in r else
                       [_fmt_rel(r["rate_err_median"]), _fmt_rel(r["rate_err_max"]), _fmt_s(r["spike_err_median_s"]),
                        _fmt_rel(r["count_differs"]), _fmt_s(r["latency_err_max_s"])])] for r in rows]), "",
            f"![spiking]({png['spiking']})", "",
            f"Check against the closed form: a constant current of 3 rheobases ({cf['current_a'] * 1e9:.3g} nA) fires at "
            f"{cf['closed_form_hz']:.3f} Hz; the exact engine gives {cf['exact_hz']:.3f} Hz over 1 s (a whole number of "
            "spikes). The grid engines' errors fall about in proportion to dt; `fast` and `brian2` give the same spikes "
            "on the same grid.", ""]


def _md_receptors(results: dict, size: ReportSize, png: dict, t: dict) -> list[str]:
    """The receptors section."""
    rows = results["receptors"]
    return ["## Receptor count", "",
            f"The 1.32 mm indenter (`block4/indent_1p32mm.vtu`), k receptors per papilla tip spread along the ridge "
            f"over +-0.04 mm of the tip (119 tips), longitudinal synthesis with the study's start parameters; errors "
            f"of each longitudinal profile (mean current per receptor) against {rows[-1]['per_papilla']} per papilla "
            f"({_t(t, 'receptors')}).", "",
            _table(["per papilla", "receptors", "sampling", "transduction + synthesis", "normalised profile error",
                    "current error"],
                   [[r["per_papilla"], r["receptors"], _fmt_s(r["sampling_s"]), _fmt_s(r["transduce_synthesize_s"]),
                     _fmt_rel(r["profile_error"]), _fmt_rel(r["current_error"])] for r in rows]), "",
            f"![receptors]({png['receptors']})", ""]


def _md_calibration(results: dict, size: ReportSize, png: dict, t: dict) -> list[str]:
    """The calibration section."""
    rows = results["calibration"]
    return ["## Calibration method", "",
            "Noise-free longitudinal profiles of known parameters (alpha 3e-8 A) on the SED of the 1.32 mm indenter at "
            "the 119 receptors, fitted from the study's start parameters, compared min-max normalised (`both`: gamma "
            f"and lambda fitted) and un-normalised (`neither`: alpha too) ({_t(t, 'calibration')}).", "",
            _table(["profile", "normalise", "method", "evaluations", "Jacobians", "time", "status", "error alpha",
                    "error gamma", "error lambda"],
                   [[r["truth"], r["normalise"], r["method"], r["evaluations"], r["jacobian_evaluations"],
                     _fmt_s(r["time_s"]), r["status"], _fmt_rel(r["err_alpha"]), _fmt_rel(r["err_gamma"]),
                     _fmt_rel(r["err_lambda"])] for r in rows]), "",
            f"![calibration]({png['calibration']})", "",
            "RSM (the study's procedure) stops where its linear or quadratic surface stops improving: its profile "
            "matches closely (small ssd) but gamma and lambda can sit elsewhere on the ridge along which the profile "
            "barely changes. Least squares with the closed-form Jacobian (the default `least_squares`) reaches the known "
            "parameters to rounding in the fewest evaluations; the 2-point, 4-start variant is the same fit without "
            "the Jacobian.", ""]


def _md_series(results: dict, size: ReportSize, png: dict, t: dict) -> list[str]:
    """The series section."""
    rows = results["series"]
    return ["## Reading a time series", "",
            f"A generated series of binary, zlib-compressed VTUs ({rows[0]['points']:,}-node hexahedral block, "
            f"{', '.join(str(n) for n in size.series_steps)} steps) sampled at 150 receptors: read whole then sampled, "
            f"against streamed one step at a time ({_t(t, 'series')}). Memory: peak of Python-level allocations "
            "(tracemalloc).", "",
            _table(["how", "steps", "wall time", "peak memory", "max difference"],
                   [[r["how"], r["steps"], _fmt_s(r["wall_s"]), f"{r['peak_mb']:.1f} MB", f"{r['max_diff_pa']:.2g} Pa"]
                    for r in rows]), "",
            f"![series]({png['series']})", ""]


def _md_headline(results: dict, size: ReportSize) -> list[str]:
    """The headline figures."""
    h = results["headline"]
    lines = [f"- sampling error, max (median): linear {_fmt_rel(h['linear_err_max'])} ({_fmt_rel(h['linear_err_median'])}), "
             f"nearest {_fmt_rel(h['nearest_err_max'])} ({_fmt_rel(h['nearest_err_median'])})",
             f"- spiking, {size.spiking_afferents} afferents x {size.spiking_duration:g} s: exact {_fmt_s(h['exact_wall_s'])}"
             + "".join(f"; fast at {dt:g} ms {_fmt_s(h[f'fast_{dt / 1e3:g}_wall_s'])}, rate error "
                       f"{_fmt_rel(h[f'fast_{dt / 1e3:g}_rate_err'])}" for dt in (1, 0.1, 0.01)
                       if f"fast_{dt / 1e3:g}_wall_s" in h)
             + "".join(f"; brian2 at {dt:g} ms {_fmt_s(h[f'brian2_{dt / 1e3:g}_wall_s'])}" for dt in (1, 0.1)
                       if f"brian2_{dt / 1e3:g}_wall_s" in h),
             f"- calibration (normalised, noise-free): rsm1 up to {h['rsm1_evaluations']} evaluations, parameter error up "
             f"to {_fmt_rel(h['rsm1_err_max'])}; least_squares up to {h['least_squares_evaluations']} evaluations, "
             f"error up to {_fmt_rel(h['least_squares_err_max'])}"]
    ser = {(r["how"], r["steps"]): r for r in results["series"]}
    n = max(size.series_steps)
    lines.append(f"- series of {n} steps: read whole {ser['read_sed + sample_sed', n]['peak_mb']:.0f} MB, streamed "
                 f"{ser['iter_sed + sample_steps', n]['peak_mb']:.0f} MB peak")
    return ["## Headline figures", "", *lines, ""]


def _markdown(results: dict, size: ReportSize, png: dict, command: str) -> str:
    """The whole report.md text."""
    t = results["timings"]
    out = _md_intro(results, size, png, t, command)
    for section in (_md_sampling, _md_spiking, _md_receptors, _md_calibration, _md_series):
        out += section(results, size, png, t)
    out += _md_headline(results, size)
    return "\n".join(out)


def _t(timings: dict, key: str) -> str:
    return f"measured in {timings[key]:.1f} s"
