"""Afferent classes: named presets of the chain (sites, transduction, input, LIF, drive, branching).

A class fills what a scene leaves unsaid in ``[spikes]``; a key the scene gives wins and is
recorded as an override. Scenes select one with ``[afferent] class = "SA-I"``, the command line
with ``afferent run --class SA-I``, sweeps with ``afferent.class = ["RA-I", "SA-I"]``; every
run.json records the class, what it set and its sources (``afferent_class``).

``'RA-I'`` (the default) is the study's chain unchanged: receptors at the papilla tips, the
sigmoid of SED as a static input, the ``'ra'`` LIF through its resistance. ``'SA-I'`` follows
the skin-neuron models of Gerling's group: the sigmoid of SED (Lesniak & Gerling 2009), a
static plus rate-dependent input (:func:`afferent.stimulus.adapting_input`, mode
``'static-plus-rate'``), the ``'sa1'`` LIF, currents mapped to it by the rheobase. Every
equation and number, with its source, is tabulated on the Afferent classes page of the
documentation (docs/classes.md).
"""

from __future__ import annotations

from collections.abc import Iterable

from dataclasses import dataclass

from ._validation import check_option


@dataclass(frozen=True)
class AfferentClass:
    """One afferent class: where its receptors sit and how their SED becomes spikes (SI units).

    Parameters
    ----------
    name : str
        ``'RA-I'`` or ``'SA-I'``.
    sites : str
        Where the class's receptors sit, in words (the scene's ``[receptors]`` places them).
    transduction : str
        SED -> receptor current (``'sigmoid'``: :func:`afferent.transduction.sigmoid`).
    input : str
        The LIF input (``[spikes] input``): ``'static'``, ``'rate-sensitive'`` or
        ``'slowly-adapting'``.
    gain_s, tau_s : float or None
        Gain ``k_d`` of the rate term in s and its time constant in s.
    static_gain : float or None
        Dimensionless gain ``k_s`` on the static current (``'slowly-adapting'``).
    lif_preset : str
        A key of :data:`afferent.spiking.LIF_PRESETS`.
    drive : str
        ``'resistance'`` or ``'rheobase'`` (:data:`afferent.spiking.DRIVE_MAPPINGS`).
    rheobase_multiple : float or None
        With ``drive='rheobase'``: the largest input current's multiple of the rheobase.
    branching : str
        How receptor currents make spikes (``[spikes] branching``): ``'sum'`` (the study's) or
        ``'zones'`` (:mod:`afferent.zones`).
    sources : tuple of str
        Where each choice comes from (short references; docs/classes.md has the table).
    """

    name: str
    sites: str
    transduction: str
    input: str
    gain_s: float | None
    tau_s: float | None
    static_gain: float | None
    lif_preset: str
    drive: str
    rheobase_multiple: float | None
    branching: str
    sources: tuple = ()

    def spikes_defaults(self) -> dict:
        """``[spikes]`` field -> value this class sets (SI keys; fields it leaves alone are absent)."""
        keys = ("input", "gain_s", "tau_s", "static_gain", "lif_preset", "drive", "rheobase_multiple", "branching")
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}

    def record(self, overridden: Iterable[str]=()) -> dict:
        """The class as run.json records it; ``overridden``: the [spikes] keys whose value in the run is not the class's."""
        return {"name": self.name, "sites": self.sites, "transduction": self.transduction,
                "spikes": self.spikes_defaults(), "sources": list(self.sources), "overridden": sorted(overridden)}

    def sites_warning(self, site: str | None) -> str | None:
        """A sentence when the receptors' ``site`` (:attr:`afferent.receptors.ReceptorLayout.site`: 'RA-I'
        papilla tips, 'SA-I' ridge bases, 'file' or None: unknown) is another class's, else None."""
        if site not in AFFERENT_CLASSES or site == self.name:
            return None
        return (f"[afferent] class = {self.name!r} with receptors at the {site} sites ({AFFERENT_CLASSES[site].sites}), "
                f"not at this class's ({self.sites}); give [afferent] class = {site!r}, or place the receptors at the "
                f"{self.name} sites.")


#: The class every scene gets unless it names one.
DEFAULT_CLASS = "RA-I"

#: The named classes (documented on the Afferent classes page, docs/classes.md).
AFFERENT_CLASSES: dict[str, AfferentClass] = {
    "RA-I": AfferentClass(
        name="RA-I", sites="papilla tips of the epidermis-dermis interface",
        transduction="sigmoid", input="static", gain_s=None, tau_s=None, static_gain=None, lif_preset="ra",
        drive="resistance", rheobase_multiple=None, branching="sum",
        sources=("the study (docs/method.md): sigmoid of SED, summed per afferent, static LIF input",
                 "LIF 'ra': TouchSim, Saal et al. 2017 PNAS 114:E5693 (afferent.spiking)")),
    "SA-I": AfferentClass(
        name="SA-I", sites="bases of the intermediate ridges",
        transduction="sigmoid", input="slowly-adapting", gain_s=0.2, tau_s=8e-3, static_gain=1.0, lif_preset="sa1",
        drive="rheobase", rheobase_multiple=10.0, branching="sum",
        sources=("sigmoid of SED: Lesniak & Gerling 2009 Math Biosci 220:15",
                 "static + rate input, tau 8 ms, k_d / (tau k_s) = 25: generator function of Gerling et al. 2018 "
                 "PLoS Comput Biol 14:e1006264 (fit code yw5aj/PlosCompBiol, fit_model.py start values)",
                 "LIF 'sa1': 30 mV, 30 pF, 5 GOhm, 1 ms (Gerling-lab model code; afferent.spiking)",
                 "drive 'rheobase' x 10 and branching 'sum' (not the published heminode 'zones'): this package's "
                 "choices (docs/classes.md)")),
}


def afferent_class(name: str) -> AfferentClass:
    """The class called ``name`` (``'RA-I'``, ``'SA-I'``); ``ValueError`` naming the choices otherwise."""
    check_option("class", name, tuple(AFFERENT_CLASSES))
    return AFFERENT_CLASSES[name]
