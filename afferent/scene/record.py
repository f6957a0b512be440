"""The run record (``run.json``) and the one-screen summary of a run."""

from __future__ import annotations

from dataclasses import dataclass

from .schema import Scene

from collections.abc import Iterable

import time
import warnings

_QUIET_CATEGORIES = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)



@dataclass(frozen=True)
class SceneResult:
    """What :func:`run_scene` computed and wrote.

    Attributes
    ----------
    scene : Scene
        The resolved scene.
    output : str
        The output folder.
    files : tuple of str
        Files written into it (``run.json`` included).
    record : dict
        The content of ``run.json``.
    stages : dict
        Executed step -> wall time in s (the computing stages of :data:`STAGES` plus
        'hashing', 'receptors', 'cache' and 'writing').
    skipped : dict
        Stage of :data:`STAGES` not executed -> why.
    cache_hit : bool or None
        Whether the sampled SED came from the cache (None: the cache was not used).
    sed : ReceptorSED or None
        SED at the receptors as sampled from the export (J/m^3).
    current, afferent, fit, spikes, waveform
        Receptor currents, afferent currents, profile fit, spike trains and the waveform,
        or None when not computed.
    warnings : tuple of str
        Warnings raised during the run (also re-emitted).
    """

    scene: Scene
    output: str
    files: tuple
    record: dict
    stages: dict
    skipped: dict
    cache_hit: bool | None
    sed: object = None
    current: object = None
    afferent: object = None
    fit: object = None
    spikes: object = None
    waveform: object = None
    warnings: tuple = ()

    def __repr__(self) -> str:
        ran = ", ".join(f"{k} {v:.3g} s" for k, v in self.stages.items())
        skipped = ", ".join(self.skipped) or "nothing"
        return (f"<SceneResult {self.scene.info.name!r} -> {self.output}: ran {ran}; skipped {skipped}"
                f"; cache {'hit' if self.cache_hit else 'miss' if self.cache_hit is False else 'off'}>")


def reemit(caught: Iterable[warnings.WarningMessage]) -> list[str]:
    """Warn again, in the caller's context, what a run caught; returns the messages that count (not deprecations)."""
    messages = []
    for w in caught:
        if not issubclass(w.category, _QUIET_CATEGORIES):
            messages.append(str(w.message))
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return messages


def build_record(scene: Scene, planned: list[str], skipped: dict, seconds: dict, record: dict, inputs: dict, caught: list[warnings.WarningMessage], files: list[str], started: str, t_run: float, extra: dict | None) -> dict:
    """The content of ``run.json``.

    Parameters
    ----------
    scene : Scene
        The resolved scene (recorded whole, keys in SI).
    planned : list of str
        Stages :func:`~afferent.scene.plan.plan` chose.
    skipped : dict
        Stage -> why it did not run.
    seconds : dict
        Executed step -> wall time in s.
    record : dict
        Entries the stages wrote (field, sampling, cache, receptors, transduction, ...).
    inputs : dict
        Input path -> sha256 (None: hashed here).
    caught : list of warnings.WarningMessage
    files : list of str
        Files written (run.json is added).
    started : str
        ISO start time (UTC).
    t_run : float
        ``time.perf_counter()`` at the start, for ``wall_seconds``.
    extra : dict or None
        More entries (the command line).
    """
    from .. import __version__
    from ..export import file_sha256, versions
    from .stages import _hash_all

    full = {
        "afferent_scene": 1,
        "afferent": __version__,
        "started_utc": started,
        "scene_file": None if scene.source is None else {"path": scene.source, "sha256": file_sha256(scene.source)},
        "scene": scene.to_dict(),
        "plan": planned,
        "inputs": _hash_all(inputs),
        "versions": versions(),
        "stages": [{"stage": k, "seconds": v} for k, v in seconds.items()],
        "skipped": [{"stage": k, "reason": v} for k, v in skipped.items()],
    }
    full.update(record)
    full["warnings"] = [{"category": w.category.__name__, "message": " ".join(str(w.message).split())}
                        for w in caught if not issubclass(w.category, _QUIET_CATEGORIES)]
    full["outputs"] = sorted(files + ["run.json"])
    full["wall_seconds"] = time.perf_counter() - t_run
    if extra:
        full.update(extra)
    return full


def _merge_reasons(skipped: dict):
    """Group stages skipped for the same reason: [('a, b', reason), ...]."""
    groups: dict[str, list[str]] = {}
    for stage, why in skipped.items():
        groups.setdefault(why, []).append(stage)
    return [(", ".join(stages), why) for why, stages in groups.items()]


def summary_lines(result: SceneResult) -> list[str]:
    """What ``afferent run`` prints after a run: files written, stages and times, skips, region, spikes,
    transduction range and fit (one line each)."""
    out = [f"afferent run: wrote {result.output}: {', '.join(sorted(result.files))}",
           "  ran: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.stages.items())]
    if result.skipped:
        out.append("  skipped: " + "; ".join(f"{k} ({v})" for k, v in _merge_reasons(result.skipped)))
    rec = result.record.get("receptors", {})
    if result.scene.region.bounded:
        out.append(f"  region: {rec.get('n_receptors_in_region')} of {rec.get('n_receptors_total')} receptors")
    if result.spikes is not None:
        sp = result.record["spikes"]
        out.append(f"  spikes: {sp['n_spikes']} from {sp['n_afferents']} afferents in {sp['duration_s']:g} s "
                   f"({sp['engine']}, {'dt %g ms' % (sp['dt_s'] * 1e3) if sp.get('dt_s') else 'no grid'}, "
                   f"{sp['input']} input{_zones_words(sp)})")
    sat = result.record.get("saturation")
    if sat:
        out.append(f"  transduction: {sat['fraction_sensitive']:.1%} of receptor samples in the sigmoid's sensitive "
                   f"range, currents vary by {sat['modulation']:.3g} of their mean across receptors "
                   f"(gamma x SED range {sat['gamma_sed_range']:.3g})")
    if result.fit is not None:
        out.append(f"  fit: R2(study) {result.fit.r2_study:.3f}, R2 {result.fit.r2:.3f}, ssd {result.fit.ssd:.3g}")
    return out


def _zones_words(sp: dict) -> str:
    """', zones: 28 zones, 4 per afferent' for a zones run's spikes record, '' for the sum model."""
    z = sp.get("zones")
    if not z:
        return ""
    lo, hi = z["zones_per_afferent"]
    return f", zones: {z['n_zones']} zones, {lo if lo == hi else f'{lo}-{hi}'} per afferent"
