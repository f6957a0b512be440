"""What each stage needs from a scene: receptor layouts and the region, the mesh crop, sigmoid
parameters, the waveform and the branching. Pure functions of the resolved scene (and the field).
"""

from __future__ import annotations

import json
from dataclasses import replace
import os
import warnings

from .schema import _GRID_DEFAULTS, MESH_GRIDS, ReceptorSpec, RegionSpec, Scene, SceneError


def _in_region(layout, region: RegionSpec):
    import numpy as np

    mask = np.ones(layout.n_receptors, bool)
    for axis, rng in ((0, region.x_range_m), (2, region.z_range_m)):
        if rng is not None:
            c = layout.positions[:, axis]
            mask &= (c >= rng[0] - 1e-9) & (c <= rng[1] + 1e-9)  # 1 nm: float noise of unit conversions
    return mask


def _restrict(layout, scene: Scene, info: dict):
    """The layout inside the region; ``info`` gets the counts."""
    info["n_receptors_total"] = int(layout.n_receptors)
    if not scene.region.bounded:
        info["n_receptors_in_region"] = int(layout.n_receptors)
        return layout
    mask = _in_region(layout, scene.region)
    n = int(mask.sum())
    info["n_receptors_in_region"] = n
    if n == 0:
        lo, hi = layout.positions.min(axis=0) * 1e3, layout.positions.max(axis=0) * 1e3
        raise scene.origin.error("region", None, "[region] must contain at least one receptor; got none of the "
                                 f"{layout.n_receptors} receptors (x [{lo[0]:.4g}, {hi[0]:.4g}] mm, "
                                 f"z [{lo[2]:.4g}, {hi[2]:.4g}] mm) inside it instead.")
    return layout if n == layout.n_receptors else layout.subset(mask)


def _layout_before_reading(scene: Scene):
    """The receptor layout when it does not depend on the export (a file, a regular grid with ranges), else None."""
    rec = scene.receptors
    if rec.file is not None:
        from ..receptors import read_receptors

        return read_receptors(rec.file, length_unit=rec.length_unit)
    if rec.grid == "regular" and rec.x_range_m is not None and rec.z_range_m is not None:
        from ..receptors import grid_layout

        return grid_layout(x_range=rec.x_range_m, z_range=rec.z_range_m, y=rec.y_m, pitch_x=rec.pitch_x_m,
                           pitch_z=rec.pitch_z_m, origin=rec.origin_m, kind=rec.rows or "tips")
    return None


def _beside_scene(scene: Scene):
    """The scene whose ``[receptors]`` are the second hot-spot map's sites (``hotspot_beside[_file]``), or None.

    ``hotspot_beside_file``: a site CSV in ``[receptors] length_unit`` (else ``[export] length_unit``);
    ``hotspot_beside``: 'tips' or 'bases' found on the export with ``[receptors]``' materials and pitches.
    """
    out, rec = scene.outputs, scene.receptors
    if "hotspots" not in (out.want or ()) or (out.hotspot_beside is None and out.hotspot_beside_file is None):
        return None
    if out.hotspot_beside_file is not None:
        new = ReceptorSpec(file=out.hotspot_beside_file, length_unit=rec.length_unit or scene.export.length_unit)
    else:
        keys = {k: getattr(rec, k) if getattr(rec, k) is not None else v for k, v in _GRID_DEFAULTS.items()}
        new = ReceptorSpec(grid=out.hotspot_beside, **keys)
    return replace(scene, receptors=new)


def _given(scene: Scene, name: str) -> str:
    """The [receptors] key as the user wrote it."""
    return scene.origin.given.get("receptors", {}).get(name, name)


def _named_inputs(scene: Scene, planned) -> list:
    """(what, path, where) of every file besides the export that the planned stages read, ``where`` the scene key
    (for a scene file; None for a scene built from options or in Python, whose caller names its own)."""
    ex, out = scene.export, scene.outputs
    entries = [("Coordinates file", ex.coordinates, "export", "coordinates"),
               ("Elastic constants table", ex.materials, "export", "materials"),
               ("Receptor file", scene.receptors.file, "receptors", "file"),
               ("Receptor file", out.hotspot_beside_file, "outputs", "hotspot_beside_file")]
    if "transduction" in planned:
        entries.append(("Calibration result", scene.transduction.calibration, "transduction", "calibration"))
    if "synthesis" in planned and scene.synthesis.kind == "map":
        entries.append(("Branching map file", scene.synthesis.map, "synthesis", "map"))
    if "comparison" in planned:
        entries.append(("Observed profile file", scene.fit.observed, "fit", "observed"))
    if "spiking" in planned and scene.spikes.branching == "zones":
        entries.append(("Zone map file", scene.spikes.zone_map, "spikes", "zone_map"))
    if "stimulus" in planned and scene.stimulus.waveform == "file":
        entries.append(("Waveform file", scene.stimulus.file, "stimulus", "file"))
    return [(what, path, f"[{table}] {key}" if scene.source else None) for what, path, table, key in entries if path]


def _check_before_reading(scene: Scene, planned) -> None:
    """Every file the planned stages read, and the material array of each set of sites found on the export
    (``[receptors] grid``, ``[outputs] hotspot_beside``), checked before the export is read
    (:mod:`afferent._inputs`: the array on the export's header where its format lists the arrays; else
    right after the one read, before the sites are searched)."""
    from .._inputs import check_files, check_material_array
    from ..exceptions import SEDFormatError

    check_files(_named_inputs(scene, planned))
    ex = scene.export
    for sc in (scene, _beside_scene(scene)):
        if sc is None or sc.receptors.grid not in MESH_GRIDS:
            continue
        name = sc.receptors.material_array or _GRID_DEFAULTS["material_array"]
        try:  # a scene built from options: 'material_array', which the command line says as --material-array
            check_material_array(list(ex.files), name, format=ex.format, where=None if scene.source else "'material_array'",
                                 allow_outside_files=bool(ex.allow_outside_files))
        except SEDFormatError as err:
            if not scene.source:
                raise
            raise scene.origin.error("receptors", _given(scene, "material_array"), str(err)) from err


def _layout_from_field(scene: Scene, field, raw):
    """Receptors found on the export: papilla tips or ridge bases, or a regular grid over the export's extent.

    ``raw``: the export as its reader returned it (its first step; :func:`afferent.io.iter_sed`'s
    ``on_first_raw``), on which tips and bases are found: the export is not read a second time.
    """
    rec = scene.receptors
    pitch = dict(pitch_x=rec.pitch_x_m, pitch_z=rec.pitch_z_m)
    if rec.grid in ("tips", "bases"):
        from ..receptors._tips import sites_from_raw

        files = [f for f in field.provenance.files if not f.lower().endswith(".pvd")] or list(field.provenance.files)
        unit = field.provenance.units.get("length")
        # the region is applied afterwards (as interface_tips' own ranges would be: last), to count what it leaves out
        return sites_from_raw(raw, files[0], length_unit=unit, material_array=rec.material_array, upper=rec.upper,
                              lower=rec.lower, kind=rec.grid, **pitch)
    from ..receptors import grid_layout

    lo, hi = field.bounds
    x_range = rec.x_range_m or (lo[0] + rec.pitch_x_m / 2, hi[0] - rec.pitch_x_m / 2)
    z_range = rec.z_range_m or (lo[2] + rec.pitch_z_m / 2, hi[2] - rec.pitch_z_m / 2)
    return grid_layout(x_range=x_range, z_range=z_range, y=rec.y_m, origin=rec.origin_m, kind=rec.rows or "tips", **pitch)


def _crop(field, positions, method: str):
    """The field with only the cells whose bounding box reaches the receptors' box (point location is exact).

    Not done for cell data with 'linear' sampling: averaging cells to nodes needs every cell
    around a node.
    """
    import numpy as np

    from ..field import Cells, SEDField

    if field.cells is None or (field.location == "cell" and method == "linear") or not len(positions):
        return field, None
    lo_f, hi_f = field.bounds
    margin = 1e-3 * float(np.max(hi_f - lo_f))
    lo, hi = positions.min(axis=0) - margin, positions.max(axis=0) + margin
    tet = field.cells.tetra
    # Cohen-Sutherland outcodes: bit 2k (2k+1) set when a node lies below (above) the box on axis k; a
    # tetrahedron misses the box exactly when its four nodes share a bit (all on one side of one face).
    code = np.zeros(field.n_points, np.uint8)
    for ax in range(3):
        code |= (field.points[:, ax] < lo[ax]).astype(np.uint8) << (2 * ax)
        code |= (field.points[:, ax] > hi[ax]).astype(np.uint8) << (2 * ax + 1)
    shared = code[tet[:, 0]] & code[tet[:, 1]] & code[tet[:, 2]] & code[tet[:, 3]]
    keep = shared == 0
    if keep.all():
        return field, None
    cells = Cells(tet[keep], field.cells.parent[keep], field.cells.n_cells, field.cells.cell_types,
                  materials=field.cells.materials, nodes=field.cells.nodes)
    cropped = SEDField(field.points, field.sed, field.times, field.location, cells, field.provenance, field.sides)
    return cropped, {"tetra_total": int(tet.shape[0]), "tetra_searched": int(keep.sum())}


def _params(scene: Scene, inputs: dict):
    """SigmoidParams and where they came from."""
    from ..transduction import STUDY_PARAMS, SigmoidParams

    tr = scene.transduction
    if tr.calibration is not None:
        path = tr.calibration
        if not os.path.isfile(path):
            raise FileNotFoundError(f"Calibration result {path!r} ([transduction] calibration) not found.")
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as err:
            raise SceneError(f"Calibration result {path!r} must be the JSON written by 'afferent calibrate' "
                             f"(CalibrationResult.to_dict()); it could not be read: {err}.") from err
        chosen = None
        if isinstance(data, dict) and "params" not in data and isinstance(data.get("syntheses"), dict):
            chosen = tr.calibration_synthesis or data.get("best_synthesis")
            if chosen not in data["syntheses"]:
                raise SceneError(f"Calibration result {path!r} holds syntheses {', '.join(map(repr, data['syntheses']))}; "
                                 f"[transduction] calibration_synthesis must name one; got {chosen!r} instead.")
            data = data["syntheses"][chosen]
        p = data.get("params") if isinstance(data, dict) else None
        if not isinstance(p, dict) or not all(k in p for k in ("alpha_a", "gamma_per_pa", "lambda_pa")):
            raise SceneError(f"Calibration result {path!r} must hold 'params' with alpha_a, gamma_per_pa and "
                             "lambda_pa (CalibrationResult.to_dict()); it does not.")
        inputs[path] = None
        params = SigmoidParams(p["alpha_a"], p["gamma_per_pa"], p["lambda_pa"])
        return params, {"source": "calibration", "file": path, "synthesis": chosen or data.get("synthesis"),
                        "method": data.get("method"), "ssd": data.get("ssd")}
    explicit = {"alpha": tr.alpha_a, "gamma": tr.gamma_per_pa, "lambda_": tr.lambda_pa}
    if tr.params is not None:
        base = STUDY_PARAMS[tr.params]
        vals = {k: (getattr(base, k) if v is None else v) for k, v in explicit.items()}
        over = [k for k, v in explicit.items() if v is not None]
        src = f"study table 5.2, {tr.params!r} row" + (f", overriding {', '.join(over)}" if over else "")
        return SigmoidParams(**vals), {"source": src}
    return SigmoidParams(**explicit), {"source": "scene"}


def _waveform(scene: Scene):
    from .. import stimulus

    st = scene.stimulus
    if st.waveform == "ramp":
        return stimulus.ramp_and_hold(st.depth_m, st.speed_m_per_s, st.hold_s, release=st.release, dt=st.dt_s,
                                      pre=st.pre_s, post=st.post_s)
    if st.waveform == "sine":
        return stimulus.sinusoid(st.frequency_hz, st.amplitude_m, offset=st.offset_m, duration=st.duration_s,
                                 dt=st.dt_s, on_negative=st.on_negative)
    return stimulus.read_waveform(st.file, length_unit=st.length_unit, time_unit=st.time_unit,
                                  on_negative=st.on_negative)


def _judge_placement(scene: Scene, record, planned) -> None:
    """Receptors away from where the scene's afferent class has them (:func:`afferent._placement.judge_placement`),
    judged when their SED becomes receptor currents (a map of SED alone may sample anywhere)."""
    if "transduction" not in planned:
        return
    from .._placement import judge_placement

    judge_placement(record, scene.afferent.afferent_class, scene.info.accept, stacklevel=4)


def _refuse_step_numbers(scene: Scene, sed, what: str) -> None:
    """``what`` (spiking, the cycles output) on the step numbers 0, 1, ... of an export that states no times
    (``sed.time_unit`` 'step', several steps; not when a waveform's times drive the run): refused unless the
    scene accepts 'step-times'."""
    from .._validation import refuse_unless

    n = sed.values.shape[0]
    if not getattr(sed, "numbered", False):
        return
    refuse_unless("step-times", scene.info.accept, f"The export states no step times: its {n} steps are numbered "
                  f"0 .. {n - 1}, and {what} would read those numbers as seconds (1 s per step, {n - 1} s in all); "
                  "give the steps' times with times=T0,T1,... (in s; [export] times in a scene file)", stacklevel=3)


def _refuse_rate_keys_without_rate(scene: Scene, afferent) -> None:
    """[spikes] gain_s / tau_s given where the input's rate term is 0 (one step, no waveform: a constant
    current): every value gives the same spikes, so the key is refused, named."""
    given = scene.origin.given.get("spikes", {})
    rate = [k for k in ("gain_s", "tau_s") if k in given]
    if not rate or scene.spikes.input == "static" or afferent.n_times > 1:
        return
    key = given[rate[0]]
    where, waveform = (f"[spikes] {key!r}", "[stimulus] waveform") if scene.source else (f"{rate[0]!r}", "waveform=")
    text = (f"{where} has no effect: the export has one step and no waveform drives it, so the current is constant "
            f"and the {scene.spikes.input} input's rate term is 0 (every value of it gives the same spikes); give a "
            f"waveform ({waveform}) or leave {where} out.")
    raise scene.origin.error("spikes", key, text) if scene.source else ValueError(text)


def _trim(waveform, duration: float):
    """The waveform up to ``t0 + duration`` (plus the first sample at or after it); (waveform, trimmed?)."""
    import numpy as np

    from ..stimulus import Waveform

    t_end = waveform.times[0] + duration
    k = int(np.searchsorted(waveform.times, t_end, side="left"))
    n = max(min(k + 1, waveform.n_times), 2)
    if n >= waveform.n_times:
        return waveform, False
    params = dict(waveform.parameters)
    params["trimmed_to_s"] = float(duration)
    notes = tuple(waveform.notes) + (f"trimmed to the simulated {duration:g} s ({n} of {waveform.n_times} samples)",)
    return Waveform(waveform.times[:n], waveform.depth[:n], kind=waveform.kind, parameters=params, notes=notes), True


def _branching(scene: Scene, layout, full_ids):
    """Branching on the region's receptors; a map is restricted to the rows of receptors inside."""
    from ..synthesis import Branching

    sy = scene.synthesis
    if sy.kind == "longitudinal":
        return Branching.longitudinal(layout), {}
    if sy.kind == "cross":
        return Branching.cross(layout), {}
    if sy.kind == "random":
        return Branching.random(layout, sy.receptors_per_afferent, rng=sy.seed), {}
    if full_ids is None or len(full_ids) == layout.n_receptors:
        return Branching.from_map(sy.map, layout), {}
    from .._tables import read_table

    df, cols = read_table(sy.map, what="Branching map file", expected="receptor, afferent[, weight]", as_text=True)
    rcol = cols.get("receptor")
    if rcol is None:
        return Branching.from_map(sy.map, layout), {}  # its own message about the columns
    rec = df[rcol].astype(str).str.strip()
    inside = set(layout.ids.tolist())
    known = set(map(str, full_ids))
    unknown = [r for r in dict.fromkeys(rec.tolist()) if r not in known]
    if unknown:
        return Branching.from_map(sy.map, layout), {}  # reports the unknown ids with the file name
    keep = rec.isin(inside)
    acol = cols.get("afferent")
    cut = 0
    if acol is not None:
        aff = df[acol].astype(str).str.strip()
        partial = aff[keep].unique()
        cut = int(sum(1 for a in partial if not keep[aff == a].all()))
    if cut:
        from ..exceptions import AfferentWarning

        warnings.warn(f"{cut} afferent(s) of the branching map {sy.map!r} have receptors both inside and outside "
                      "[region] (or the SED field); their currents count only the receptors inside.", AfferentWarning, stacklevel=3)
    return Branching.from_map(df[keep].reset_index(drop=True), layout), {
        "map_rows_outside_region": int((~keep).sum()), "afferents_cut_by_region": cut}


def _hash_all(paths: dict) -> dict:
    from ..export import file_sha256

    return {p: (h if h is not None else file_sha256(p)) for p, h in paths.items()}



def _inside_field(scene: Scene, sed, full_ids, *, drop: bool):
    """(SED at the receptors inside the FE field, the run record's ``outside`` entry or None, its warning or None).

    Receptors sampled outside the field (``[sampling] on_outside`` 'nan' or 'warn': NaN SED) keep their NaN in the
    SED tables (``sed_map``, ``receptors.vtu``); with ``drop`` (the run transduces) they are left out of every
    stage from there on (transduction, synthesis, spikes, their tables), as receptors outside ``[region]`` are.
    The entry and the warning name them, and, for the scene's branching built on all the sampled receptors, the
    afferents that lose some of their receptors (their currents sum only the receptors inside: smaller than with
    every receptor) and those left with none (no afferent). A random branching is drawn from the receptors inside.
    """
    import numpy as np

    from ..exceptions import FieldCoverageError
    from ..synthesis import _preview

    out = np.asarray(sed.outside, bool)
    if not out.any():
        return sed, None, None
    layout, n_out = sed.layout, int(out.sum())
    ids = [str(i) for i in layout.ids[out]]
    if not drop:
        return sed, {"n_receptors": n_out, "of": int(layout.n_receptors), "receptors": ids,
                     "how": "NaN in the SED tables; no stage after sampling runs"}, (
            f"{n_out} of {layout.n_receptors} receptors lie outside the SED field ({_preview(ids)}): their SED is NaN "
            "in the SED tables. run.json 'outside' lists them all.")
    if out.all():
        raise FieldCoverageError(f"All {layout.n_receptors} receptors lie outside the SED field (first: {ids[0]!r}); "
                                 "no stage after sampling has a receptor to work on.")
    partly, none = {}, []
    if scene.synthesis.kind != "random":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            w = _branching(scene, layout, full_ids)[0]
        for a, aid in enumerate(w.afferent_ids):
            cols = w.weights.indices[w.weights.indptr[a]:w.weights.indptr[a + 1]]
            k = int(out[cols].sum())
            if k == cols.size and k:
                none.append(str(aid))
            elif k:
                partly[str(aid)] = [k, int(cols.size)]
    record = {"n_receptors": n_out, "of": int(layout.n_receptors), "receptors": ids,
              "afferents_partly_outside": partly, "afferents_all_outside": none,
              "how": "NaN in the SED tables, left out of every stage from transduction on; an afferent sums only its "
                     "receptors inside the field"}
    msg = (f"{n_out} of {layout.n_receptors} receptors lie outside the SED field ({_preview(ids)}): their SED is NaN in "
           "the SED tables, and they are left out of every stage from transduction on.")
    if partly:
        shown = ", ".join(f"{a!r} ({k} of {n} outside)" for a, (k, n) in list(partly.items())[:5])
        msg += (f" {len(partly)} afferent(s) keep only their receptors inside, so their currents sum fewer receptors "
                f"than they have: {shown}{', ...' if len(partly) > 5 else ''}.")
    if none:
        msg += f" {len(none)} afferent(s) have no receptor inside and are left out: {_preview(none)}."
    keep = ~out
    inside = replace(sed, values=sed.values[:, keep], layout=layout.subset(keep), outside=np.zeros(int(keep.sum()), bool))
    return inside, record, msg + " run.json 'outside' lists them all."
