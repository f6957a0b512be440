"""Planning: the wanted outputs -> the stages that produce them, and why the others are skipped."""

from __future__ import annotations

from .defaults import resolve
from .schema import Scene

#: The computing stages, in order; a run executes the subset :func:`plan` returns.
STAGES = ("reading", "sampling", "stimulus", "transduction", "synthesis", "comparison", "input", "spiking")

_CURRENT_STAGES = ("reading", "sampling", "stimulus", "transduction", "synthesis")
#: output -> stages it needs
NEEDS = {
    "sed_map": ("reading", "sampling"),
    "vtu": ("reading", "sampling"),
    "currents": _CURRENT_STAGES,
    "profiles": _CURRENT_STAGES,
    "fit": _CURRENT_STAGES + ("comparison",),
    "spikes": _CURRENT_STAGES + ("input", "spiking"),
    "plots": (),
    "nwb": _CURRENT_STAGES + ("input", "spiking"),
    "hotspots": ("reading", "sampling"),
    "cycles": ("reading", "sampling", "stimulus"),
}

# ---------------------------------------------------------------------------- planning
def plan(scene: Scene) -> list[str]:
    """The stages (from :data:`STAGES`, in order) that the scene's wanted outputs need.

    ``sed_map`` / ``vtu`` -> reading, sampling; ``currents`` / ``profiles`` -> + stimulus (only
    with a waveform), transduction, synthesis; ``fit`` -> + comparison; ``spikes`` -> + input,
    spiking. At run time a cache hit may skip reading and sampling as well.

    Examples
    --------
    >>> plan(load_scene("sample_sed/scenes/sed_map.toml"))  # doctest: +SKIP
    ['reading', 'sampling']
    """
    scene = resolve(scene)
    need = set()
    for w in scene.outputs.want:
        need.update(NEEDS[w])
    if scene.stimulus.waveform is None:
        need.discard("stimulus")
    return [s for s in STAGES if s in need]


def skip_reasons(scene: Scene) -> dict[str, str]:
    """Why each stage :func:`plan` leaves out is not run (stage -> sentence)."""
    scene = resolve(scene)
    planned = plan(scene)
    want = list(scene.outputs.want)
    out = {}
    for s in STAGES:
        if s in planned:
            continue
        if s == "stimulus" and ("transduction" in planned or "cycles" in want):
            out[s] = "the scene has no [stimulus] waveform: the export's own time steps are used"
            continue
        users = [w for w, stages in NEEDS.items() if s in stages and w not in ("plots", "nwb")]
        which = repr(users[0]) if len(users) == 1 else "any of " + ", ".join(map(repr, users))
        out[s] = f"not needed: the requested outputs {want} do not include {which}"
    return out


