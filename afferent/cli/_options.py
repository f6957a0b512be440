"""Options shared by several subcommands, defined once (rasterio's ``rio/options.py`` idea)."""

from __future__ import annotations

import argparse
import math
import sys

from ..io import FORMATS
from ..strain_energy import PRESETS
from ..units import LENGTH_UNITS, SED_UNITS, length_factor, sed_factor, time_factor


def add_input_options(parser: argparse.ArgumentParser) -> None:
    """Options that say how to read an FE export (see :func:`afferent.read_sed`)."""
    g = parser.add_argument_group("reading the export")
    g.add_argument("--length-unit", metavar="U", type=unit_type("length"), help=f"unit of the coordinates ({', '.join(k for k in LENGTH_UNITS if k != 'µm')}); required unless the file states it")
    g.add_argument("--sed-unit", metavar="U", type=unit_type("sed"), help=f"unit of the SED array ({', '.join(SED_UNITS)}); required unless the file states it")
    g.add_argument("--stress-unit", metavar="U", type=unit_type("sed"), help="unit of the stress components when SED is computed from tensors")
    g.add_argument("--sed-from", choices=("field", "exact", "equivalent", "stress"), default="field",
                   help="read an SED array (field), or compute 1/2 sigma:eps (exact) or the study's equivalent SED from "
                        "tensors, or the linear-elastic SED from the stress alone (stress: needs --elastic or --materials)")
    g.add_argument("--poisson", type=float, metavar="NU", help="Poisson's ratio for --sed-from equivalent (the study: 0.48)")
    g.add_argument("--elastic", metavar="E,NU", help="--sed-from stress on a homogeneous model: Young's modulus E (unit "
                                                     "--modulus-unit) and Poisson's ratio NU, e.g. 0.1,0.45")
    g.add_argument("--modulus-unit", metavar="U", type=unit_type("sed"),
                   help="unit of E in --elastic or in --materials (Pa, kPa, MPa, ...); required unless the table's header "
                        "states it, 'E (MPa)'")
    reads(g.add_argument("--materials", metavar="MATERIALS.csv",
                         help="--sed-from stress with constants per material: a CSV with columns material (the id in the "
                              "export's material array, --material-array), E, nu"), what="Elastic constants table")
    g.add_argument("--preset", choices=tuple(PRESETS), help="FE tool whose tensor component order and shear convention apply")
    g.add_argument("--shear", choices=("tensor", "engineering"), help="override the preset's shear-strain convention")
    g.add_argument("--location", choices=("point", "cell"), help="use point data or cell data when the file has both")
    g.add_argument("--sed-column", metavar="NAME", action="append", help="name of the SED array/column (repeat for one column per step)")
    g.add_argument("--stress-columns", metavar="NAMES", help="stress array name, or 6 comma-separated column names xx,yy,zz,xy,yz,xz")
    g.add_argument("--strain-columns", metavar="NAMES", help="strain array name, or 6 comma-separated column names xx,yy,zz,xy,yz,xz")
    g.add_argument("--coord-columns", metavar="X,Y,Z", help="names of the coordinate columns of a CSV")
    reads(g.add_argument("--coordinates", metavar="NODES.csv", help="node/element table id,x,y,z (or an ANSYS NLIST listing, a CalculiX .frd) to join on a table that has only labels"),
          what="Coordinates file")
    g.add_argument("--on-nan", choices=("raise", "drop"), default="raise", help="NaN rows of a point table: error (default) or leave them out")
    g.add_argument("--negative-tolerance", type=float, default=0.25, metavar="R",
                   help="accept negative SED down to -R x the largest SED, summing to at most R x the positive values "
                        "(nodal-extrapolation artefacts of FE tools; set to 0 and reported); default 0.25")
    g.add_argument("--times", metavar="T0,T1,...", help="step times (s unless --time-unit), overriding the file")
    g.add_argument("--time-unit", metavar="U", type=unit_type("time"), help="unit of the step times (s, ms, us)")
    g.add_argument("--format", choices=tuple(FORMATS), help="file format, when the extension does not tell")
    g.add_argument("--allow-outside-files", action="store_true",
                   help="read the files the export points to (a .pvd's steps, XDMF heavy data, HDF5 links and external "
                        "storage, ...) even outside the export's own folder; by default they are refused")


def _names(text: str | None):
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    return parts[0] if len(parts) == 1 else parts


def input_kwargs(args: argparse.Namespace) -> dict:
    """Keyword arguments for :func:`afferent.read_sed` from the parsed options."""
    sed_column = args.sed_column
    if sed_column is not None and len(sed_column) == 1:
        sed_column = sed_column[0]
    times = None
    if args.times is not None:
        try:
            times = [float(t) for t in args.times.split(",")]
        except ValueError as err:
            raise ValueError(f"--times must be comma-separated numbers; got {args.times!r} instead.") from err
    elastic = None
    if args.elastic is not None:
        try:
            elastic = [float(v) for v in args.elastic.split(",")]
        except ValueError:
            elastic = []
        if len(elastic) != 2:
            raise ValueError(f"--elastic must be E,NU (two comma-separated numbers, E in --modulus-unit); got "
                             f"{args.elastic!r} instead.")
    coord = _names(args.coord_columns)
    if coord is not None and (isinstance(coord, str) or len(coord) != 3):
        raise ValueError(f"--coord-columns must name 3 columns as X,Y,Z; got {args.coord_columns!r} instead.")
    return dict(
        length_unit=args.length_unit, sed_unit=args.sed_unit, stress_unit=args.stress_unit, sed_from=args.sed_from,
        poisson=args.poisson, preset=args.preset, shear=args.shear, location=args.location, sed_column=sed_column,
        stress_columns=_names(args.stress_columns), strain_columns=_names(args.strain_columns), coord_columns=coord,
        times=times, time_unit=args.time_unit, coordinates=args.coordinates, on_nan=args.on_nan,
        negative_tolerance=args.negative_tolerance, allow_outside_files=args.allow_outside_files, format=args.format,
        elastic=elastic, modulus_unit=args.modulus_unit, materials=args.materials,
        material_array=getattr(args, "material_array", None), progress=show_progress(args),
    )


def add_side_option(parser: argparse.ArgumentParser) -> None:
    """Which side of a material interface the receptors on it take (see :func:`afferent.sample_sed`)."""
    parser.add_argument("--side", default="average", metavar="SIDE",
                        help="receptors on a material interface: 'average' across the materials (default), or a material "
                             "id to take that material's SED alone (the dermis for Meissner corpuscles)")


def add_output_options(parser: argparse.ArgumentParser, *, what: str, required: bool = True, folder: bool = True,
                       metavar: str = "OUT") -> None:
    """``-o`` (a folder, or a file when not ``folder``) and ``--overwrite``; ``afferent.cli`` checks ``-o`` against
    every path the command reads (:func:`reads`) before the command starts."""
    parser.add_argument("-o", "--output", required=required, metavar=metavar, help=what)
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output (never done silently)")
    parser.set_defaults(_output_what="Output folder" if folder else "Output file")


def reads(action: argparse.Action, paths=None, what: str | None = None) -> argparse.Action:
    """Mark an option or positional as naming files or folders the command reads: ``paths(value)`` gives the paths
    one value names (default: the value itself). :func:`input_paths` gathers them; ``afferent.cli`` checks the
    output against them before the command starts and hands them to every writer
    (``afferent._output.command_inputs``), so that no output is, holds or lies inside one of them. With ``what``
    (the kind of file, 'Receptor file'), each path must be a regular file, checked before the command starts
    (:func:`named_files`, :func:`afferent._inputs.check_files`): no export is read for a command that would fail
    on a missing file after it."""
    action.afferent_reads = paths or (lambda value: (value,))
    action.afferent_what = what
    return action


def named_files(args: argparse.Namespace) -> list:
    """(what, path, flag) of every file the parsed command's options marked ``reads(..., what=...)`` name."""
    out = []
    for action in getattr(args, "_reads", ()):
        what, value = getattr(action, "afferent_what", None), getattr(args, action.dest, None)
        if what is None or value is None:
            continue
        flag = max(action.option_strings, key=len) if action.option_strings else None
        for v in value if isinstance(value, list) else [value]:
            out.extend((what, p, flag) for p in action.afferent_reads(v) if p)
    return out


def after_prefix(prefix: str):
    """``paths`` for :func:`reads`: the file after ``prefix`` (``map:FILE``), nothing for other values."""
    return lambda value: (value[len(prefix):],) if str(value).startswith(prefix) else ()


def input_paths(args: argparse.Namespace) -> list[str]:
    """Every path the parsed command reads (its options and positionals marked with :func:`reads`)."""
    out = []
    for action in getattr(args, "_reads", ()):
        value = getattr(args, action.dest, None)
        for v in value if isinstance(value, list) else [value]:
            if v is not None:
                out.extend(p for p in action.afferent_reads(v) if p)
    return out


def add_run_comparison_options(parser: argparse.ArgumentParser, *, verb: str) -> None:
    """``-o``, ``--overwrite`` and ``--group NAME=PATTERN`` of the commands that compare runs (hotspots, cycles)."""
    add_output_options(parser, what="output folder (created whole, or not at all)")
    parser.add_argument("--group", action="append", metavar="NAME=PATTERN",
                        help=f"{verb} the runs whose label matches PATTERN (fnmatch) as group NAME; repeatable")


def add_accept_option(parser: argparse.ArgumentParser) -> None:
    """``--accept CHECK[,CHECK]``: the checks whose unusual case the user confirms (:data:`afferent._validation.ACCEPTS`;
    a scene's ``[scene] accept``). One option for every such confirmation, each check by name."""
    from .._validation import ACCEPTS

    parser.add_argument("--accept", action="append", metavar="CHECK[,CHECK]",
                        help="confirm the unusual case a check refuses as a likely mistake (repeatable; [scene] accept "
                             f"in a scene file): {'; '.join(f'{k}: {v}' for k, v in ACCEPTS.items())}")


def accepted(args: argparse.Namespace) -> list | None:
    """The checks ``--accept`` names (comma-separated, repeatable), or None."""
    return [c.strip() for a in (getattr(args, "accept", None) or ()) for c in a.split(",") if c.strip()] or None


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """The options every subcommand takes (added by :func:`afferent.cli._main.build_parser`, not by the
    subcommands): ``-q/--quiet``."""
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="nothing on the terminal but errors: no progress bars, summaries or warnings (a run's "
                             "warnings stay in its run.json, a sweep's in its records)")


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars only on a terminal and without --quiet."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def add_receptor_options(parser: argparse.ArgumentParser, *, required: bool = True) -> None:
    """Where the receptors are: a CSV, or a grid generated on the export."""
    g = parser.add_argument_group("receptor sites")
    m = g.add_mutually_exclusive_group(required=required)
    reads(m.add_argument("--receptors", metavar="R.csv", help="receptor sites: columns x, y, z (optional id, longitudinal, "
                                                              "cross)"), what="Receptor file")
    m.add_argument("--grid", metavar="SPEC",
                   help="generate the sites: 'tips' = papilla tips (RA-I) found on the export's epidermis/dermis "
                        "interface (cell array --material-array, ids --upper/--lower); 'bases' = the intermediate-ridge "
                        "bases (SA-I) found there; 'y=H' = a ridge/papilla grid of papilla rows at height H "
                        "(export length unit) over the export's x-z extent")
    g.add_argument("--receptor-unit", metavar="U", type=unit_type("length"), help="length unit of R.csv (default: the export's length unit)")
    g.add_argument("--pitch-x-mm", type=positive_number, help="grid pitch across the ridges, mm (default 0.44)")
    g.add_argument("--pitch-z-mm", type=positive_number, help="grid pitch along the ridges, mm (default 0.22)")
    g.add_argument("--material-array", metavar="NAME",
                   help="cell array of material/layer ids for --grid tips|bases (default 'layer') and for --materials "
                        "(default: the one the export names like a material array)")
    g.add_argument("--upper", type=int, help="material id above the interface (epidermis; default 1)")
    g.add_argument("--lower", type=int, help="material id below the interface (dermis; default 2)")
    add_check(parser, check_receptor_options)


#: the receptor options that apply to generated sites, with their defaults (filled by check_receptor_options)
GRID_OPTIONS = {"pitch_x_mm": ("--pitch-x-mm", 0.44), "pitch_z_mm": ("--pitch-z-mm", 0.22),
                "material_array": ("--material-array", "layer"), "upper": ("--upper", 1), "lower": ("--lower", 2)}


def add_check(parser: argparse.ArgumentParser, check) -> None:
    """Have ``check(args)`` run before the command starts (``afferent.cli._main._guarded``), after every file the
    options name was checked: the combinations of the options an option group adds, in one place for every
    command that adds the group."""
    parser.set_defaults(_checks=(*(parser.get_default("_checks") or ()), check))


def check_receptor_options(args: argparse.Namespace) -> None:
    """Refuse receptor options that would be ignored (their defaults: :func:`grid_option`).

    ``--material-array``, ``--upper``, ``--lower`` apply to ``--grid tips|bases`` (sites found on the
    export's materials); ``--pitch-x-mm``, ``--pitch-z-mm`` to ``--grid``; ``--receptor-unit`` to
    ``--receptors``. Each given where it does not apply is an error naming it, before any file is read.
    With ``--grid tips|bases``, the material array must be one of the export's cell arrays: checked on
    its header where the format lists them (:func:`afferent._inputs.check_material_array`), else right
    after the one read, before the sites are searched.
    """
    grid = (args.grid or "").strip()
    given = [k for k in GRID_OPTIONS if getattr(args, k, None) is not None]
    found = grid in ("tips", "bases")
    for key in given:
        flag = GRID_OPTIONS[key][0]
        if key == "material_array" and (getattr(args, "materials", None) is not None
                                        or getattr(args, "side", "average") != "average"):
            continue  # it names the material ids of the elastic-constants table (--materials) or of --side
        if args.receptors is not None:
            raise ValueError(f"{flag} applies to sites generated with --grid, not to a receptor file (--receptors "
                             f"{args.receptors}); remove {flag}, or use --grid instead of --receptors.")
        if key.startswith("pitch") and not grid:
            raise ValueError(f"{flag} applies to sites generated with --grid tips|bases|y=H; add --grid or remove {flag}.")
        if not key.startswith("pitch") and not found:
            raise ValueError(f"{flag} applies to --grid tips|bases (sites found on the export's materials), not to "
                             f"{'--grid ' + grid if grid else 'a command without --grid'}; remove {flag}.")
    if found and getattr(args, "exports", None):  # on the export's header where its format lists the arrays
        from .._inputs import check_material_array

        check_material_array(args.exports, grid_option(args, "material_array"), format=args.format,
                             allow_outside_files=args.allow_outside_files, where="--material-array")
    if args.receptor_unit is not None and args.receptors is None:
        takes = "--grid y=H takes H in the export's length unit" if grid else "no receptor file is given"
        raise ValueError(f"--receptor-unit is the unit of a receptor file (--receptors R.csv); {takes}; "
                         "remove --receptor-unit.")


def grid_option(args: argparse.Namespace, key: str):
    """The value of a :data:`GRID_OPTIONS` option: as given, else its default."""
    value = getattr(args, key, None)
    return GRID_OPTIONS[key][1] if value is None else value


def unit_type(kind: str):
    """argparse type for a ``kind`` unit flag ('length', 'sed', 'time'): the text as given, checked at once.

    A unit the package does not know is refused by argparse with the flag's own name
    (``argument --receptor-unit: must be a length unit, one of ...; got 'furlong' instead``), before
    any file is read, rather than later under another flag's name.
    """
    factor = {"length": length_factor, "sed": sed_factor, "time": time_factor}[kind]

    def check(text: str) -> str:
        try:
            factor(text, name="the value")
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err).replace("the value must", "must", 1)) from None
        return text

    check.__name__ = f"{kind} unit"
    return check


def positive_number(text: str) -> float:
    """argparse type: a finite number > 0 (``nan``, ``inf``, 0 and negatives refused with the text as given)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0; got {text!r} instead")
    return value


def layout_from_args(args: argparse.Namespace, field, raw):
    """The :class:`ReceptorLayout` the options ask for, in m; ``--grid tips|bases`` found on ``raw``, the export
    as read for ``field`` (:func:`afferent.io.iter_sed`'s ``on_first_raw``): the export is read once."""
    from ..receptors import grid_layout, read_receptors
    from ..receptors._tips import sites_from_raw
    from ..units import length_factor

    unit = field.provenance.units.get("length")
    pitch = dict(pitch_x=grid_option(args, "pitch_x_mm") * 1e-3, pitch_z=grid_option(args, "pitch_z_mm") * 1e-3)
    if args.receptors is not None:
        return read_receptors(args.receptors, length_unit=args.receptor_unit or unit)
    spec = args.grid.strip()
    if spec in ("tips", "bases"):
        source = field.provenance.files[0]
        if source.lower().endswith(".pvd"):
            source = field.provenance.files[1]
        return sites_from_raw(raw, source, length_unit=unit, material_array=grid_option(args, "material_array"),
                              upper=grid_option(args, "upper"), lower=grid_option(args, "lower"), kind=spec, **pitch)
    if spec.startswith("y="):
        try:
            y = float(spec[2:]) * length_factor(unit)
        except ValueError as err:
            raise ValueError(f"--grid y=H needs a number H in the export's length unit; got {spec!r} instead.") from err
        lo, hi = field.bounds
        inset_x, inset_z = pitch["pitch_x"] / 2, pitch["pitch_z"] / 2
        return grid_layout(x_range=(lo[0] + inset_x, hi[0] - inset_x), z_range=(lo[2] + inset_z, hi[2] - inset_z), y=y, **pitch)
    raise ValueError(f"--grid must be 'tips', 'bases' or 'y=H'; got {args.grid!r} instead.")
