"""The public API is typed (issue 37): every public function and method has its parameters and
return annotated, the annotations resolve, and each option's ``Literal`` type holds exactly the
values its validator accepts.

The public API: the names in ``__all__`` of ``afferent`` and of every public module (no
``_``-prefixed part in its dotted name; a public module without ``__all__``: the public names it
defines), and, of the classes among them, every public method and property plus ``__init__``.

``typing.get_type_hints`` is resolved with the names of :func:`_lazy_names` added: pandas,
matplotlib, scipy, scikit-learn and xarray load on first use, not on import (tests check that), so a
module names their types under ``if TYPE_CHECKING:`` only. So does a module outside
``afferent.spiking`` for that package's types (``SpikeTrains``, ``LIFParams``, ``Engine``,
``DriveMapping``): a SED-only run never imports it (tests/test_scene.py checks). Every other name
must resolve from the module itself.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import typing

import pytest

import afferent


def _lazy_names() -> dict[str, object]:
    import matplotlib.axes
    import matplotlib.figure
    import matplotlib.legend
    import pandas as pd
    import scipy.optimize
    import scipy.sparse as sp
    import sklearn.pipeline
    import xarray as xr

    from afferent import spiking

    return {"DataFrame": pd.DataFrame, "Axes": matplotlib.axes.Axes, "Figure": matplotlib.figure.Figure,
            "Legend": matplotlib.legend.Legend, "sp": sp, "xr": xr, "Pipeline": sklearn.pipeline.Pipeline,
            "OptimizeResult": scipy.optimize.OptimizeResult, "SpikeTrains": spiking.SpikeTrains,
            "LIFParams": spiking.LIFParams, "Engine": spiking.Engine, "DriveMapping": spiking.DriveMapping}


def public_modules() -> list[str]:
    names = [m.name for m in pkgutil.walk_packages(afferent.__path__, "afferent.")
             if not any(part.startswith("_") for part in m.name.split(".")[1:])]
    return ["afferent", *names]


def _members(cls: type) -> list:
    out = []
    for name, value in vars(cls).items():
        if name.startswith("_") and name != "__init__":
            continue
        if isinstance(value, (staticmethod, classmethod)):
            value = value.__func__
        elif isinstance(value, property):
            value = value.fget
        if inspect.isfunction(value):
            out.append(value)
    return out


def public_callables() -> dict[str, object]:
    """Qualified name -> every public function and method (each object once)."""
    found: dict[str, object] = {}
    for modname in public_modules():
        mod = importlib.import_module(modname)
        names = getattr(mod, "__all__", None)
        if names is None:
            names = [n for n, o in vars(mod).items() if not n.startswith("_") and getattr(o, "__module__", None) == modname]
        for name in names:
            obj = getattr(mod, name)
            items = [obj] if inspect.isfunction(obj) else _members(obj) if inspect.isclass(obj) else []
            for f in items:
                found.setdefault(f"{f.__module__}.{f.__qualname__}", f)
    return found


def missing_annotations(f) -> list[str]:
    """The parameters (and ``->``) of ``f`` without an annotation; ``self``/``cls`` need none."""
    sig = inspect.signature(f)
    out = [p.name for i, p in enumerate(sig.parameters.values())
           if p.annotation is inspect.Parameter.empty and not (i == 0 and p.name in ("self", "cls"))]
    if sig.return_annotation is inspect.Signature.empty:
        out.append("->")
    return out


def test_the_public_api_is_large_and_counted():
    # 180 functions and 141 methods/properties when this test was written; the floor guards the walk itself
    assert len(public_callables()) >= 300


def test_missing_annotations_are_found():
    def f(a, *args: int, b: int = 1, **kw) -> None: ...

    def g(self, x: int): ...

    assert missing_annotations(f) == ["a", "kw"]
    assert missing_annotations(g) == ["->"]


def test_every_public_function_and_method_is_fully_annotated():
    missing = {name: m for name, f in public_callables().items() if (m := missing_annotations(f))}
    assert missing == {}, f"{len(missing)} public functions/methods lack annotations: {missing}"


def test_every_public_annotation_resolves():
    lazy = _lazy_names()
    failed = {}
    for name, f in public_callables().items():
        try:
            typing.get_type_hints(f, localns=lazy)
        except Exception as exc:  # noqa: BLE001 (NameError, TypeError: each one named in the message)
            failed[name] = f"{type(exc).__name__}: {exc}"
    assert failed == {}, f"{len(failed)} annotations do not resolve: {failed}"


def _option_cases():
    from afferent import calibration, export, pipeline, profiles, sampling, spiking, stimulus
    from afferent.calibration import design, entry, reference, result
    from afferent.spiking import _drive
    from afferent.stimulus import _adaptation, _waveforms

    # (function, parameter, Literal alias, the tuple its validator checks against)
    return [
        (sampling.sample_sed, "method", sampling.SamplingMethod, sampling.METHODS),
        (sampling.sample_sed, "on_outside", sampling.OnOutside, sampling.ON_OUTSIDE),
        (spiking.simulate_lif, "engine", spiking.Engine, spiking.ENGINES),
        (spiking.simulate_lif, "input_hold", spiking.InputHold, spiking.INPUT_HOLDS),
        (_drive.spike_afferents, "drive", _drive.DriveMapping, _drive.DRIVE_MAPPINGS),
        (_drive.spike_afferents, "input", _drive.InputKind, _drive.INPUTS),
        (stimulus.adapting_input, "mode", _adaptation.AdaptationMode, stimulus.ADAPTATION_MODES),
        (stimulus.adapting_input, "rectify", _adaptation.Rectify, _adaptation.RECTIFY_CHOICES),
        (stimulus.read_waveform, "on_negative", _waveforms.OnNegative, _waveforms.ON_NEGATIVE),
        (stimulus.Waveform.__init__, "kind", _waveforms.WaveformKind, _waveforms.WAVEFORM_KINDS),
        (stimulus.InputCurrent.__init__, "kind", _drive.InputKind, _adaptation.INPUT_KINDS),
        (calibration.calibrate, "method", entry.CalibrationMethod, calibration.METHODS),
        (calibration.calibrate, "normalise", profiles.Normalise, entry._NORMALISE),
        (profiles.compare_profiles, "normalise", profiles.Normalise, profiles._NORMALISE),
        (calibration.calibrate, "jac", reference.Jacobian, reference.JACOBIANS),
        (calibration.calibrate, "restarts", reference.Restarts, reference.RESTARTS),
        (calibration.calibrate, "design", design.DesignName, tuple(design.DESIGNS)),
        (calibration.CalibrationResult.__init__, "status", result.Status, calibration.STATUSES),
        (export.write_outputs, "results_format", export.ResultsFormat, export.RESULTS_FORMATS),
        (pipeline.run_pipeline, "method", sampling.SamplingMethod, sampling.METHODS),
    ]


def _literal_in(hint) -> tuple:
    """The values of the Literal inside ``hint`` (``Literal[...]`` or ``Literal[...] | None``)."""
    if typing.get_origin(hint) is typing.Literal:
        return typing.get_args(hint)
    inner = [a for a in typing.get_args(hint) if typing.get_origin(a) is typing.Literal]
    assert len(inner) == 1, hint
    return typing.get_args(inner[0])


@pytest.mark.parametrize("case", range(20))
def test_each_option_literal_equals_what_its_validator_accepts(case):
    cases = _option_cases()
    assert len(cases) == 20
    f, param, alias, accepted = cases[case]
    assert typing.get_origin(alias) is typing.Literal
    assert typing.get_args(alias) == tuple(accepted)  # the alias and the validator's tuple: one list
    hint = typing.get_type_hints(f, localns=_lazy_names())[param]
    assert _literal_in(hint) == tuple(accepted), f"{f.__qualname__}({param}=...) is annotated {hint}"


def _scene_cases():
    from afferent import profiles, sampling, spiking, stimulus, zones
    from afferent.scene import schema
    from afferent.stimulus import _waveforms

    # (scene section class, key, the Literal alias of the library option the key feeds)
    return [
        (schema.SamplingSpec, "method", sampling.SamplingMethod),
        (schema.SamplingSpec, "on_outside", sampling.OnOutside),
        (schema.StimulusSpec, "on_negative", _waveforms.OnNegative),
        (schema.SpikesSpec, "engine", spiking.Engine),
        (schema.SpikesSpec, "input", stimulus._adaptation.InputKind),
        (schema.SpikesSpec, "drive", spiking._drive.DriveMapping),
        (schema.SpikesSpec, "rectify", stimulus._adaptation.Rectify),
        (schema.SpikesSpec, "branching", zones.BranchingModel),
        (schema.FitSpec, "normalise", profiles.Normalise),
    ]


@pytest.mark.parametrize("case", range(9))
def test_each_scene_choice_equals_the_library_option(case):
    """A scene file's keys spell their choices out (checking a scene loads neither numpy's stage modules
    nor brian2); they must stay the library's."""
    import dataclasses

    cases = _scene_cases()
    assert len(cases) == 9
    section, key, alias = cases[case]
    choices = {f.name: f.metadata["choices"] for f in dataclasses.fields(section)}[key]
    assert tuple(choices) == typing.get_args(alias), f"[{section.__name__}] {key}"
