"""``currents.nc``, the time courses of a run as one NetCDF-4 file (CF-1.10), and ``currents.xdmf``, an
index into it that ParaView opens as a time series (:func:`afferent.export.write_outputs`).

What the field's own tools need (issue 37, each measured):

- every attribute is written as NC_CHAR (a fixed-length HDF5 string, ``np.bytes_`` through h5netcdf),
  never NC_STRING: with NC_STRING attributes ParaView's NetCDF reader (``vtkNetCDFCFReader``) finds no
  time steps ("NetCDF: Not a valid data type or _FillValue type mismatch");
- the dimensions ``receptor`` and ``afferent`` are integers (``ds.sel(receptor=1)``), the ids as text
  are auxiliary coordinates ``receptor_id`` and ``afferent_id``, stored as NC_CHAR arrays (with a
  ``*_strlen`` dimension: CF label variables), never variable-length strings, which cfchecks cannot
  read ("vlen types not supported");
- ``time`` carries ``standard_name`` and ``axis``, and units ``seconds since 1970-01-01 00:00:00``
  (:data:`TIME_ORIGIN` standing for t = 0): with units ``s`` compliance-checker reports a time
  coordinate without a reference date as its high finding. xarray decodes such a time to dates
  unless opened with ``decode_times=False`` (as :func:`afferent.load_results` does);
- ``time`` is the unlimited dimension (chunks of ~1 MB along it): compliance-checker's CF §2.4 check
  otherwise wants ``receptor`` and ``afferent`` left of ``time`` (and ParaView's reader takes the
  first dimension for time). Measured on 595 receptors x 2301 steps (CPU time, the best of 7):
  writing takes 0.12 s where the fixed-size file of NC_STRING attributes took 0.08-0.09 s (an
  unlimited ``time`` costs 15-20 ms of that), and the XDMF index 0.02 s (3.5 MB);
- the file has a global ``history`` (no clock time: two runs of one scene still give the same bytes;
  ``run.json`` beside it records when and how).

Checked (benchmarks/check_outputs.py): compliance-checker 6.1 (CF 1.11) reports nothing, cfchecker 4.1 runs
to its summary (it knows CF up to 1.8), VTK 9.7's ``vtkNetCDFCFReader`` (ParaView's NetCDF reader) finds
every step.

The XDMF index holds no numbers: each step's ``sed_pa`` and ``current_a`` are hyperslabs of the
datasets of ``currents.nc`` (a netCDF-4 file is an HDF5 file), the sites' coordinates its ``x_m``,
``y_m``, ``z_m``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RESULTS_NC", "RESULTS_XDMF", "COORDS", "results_variables", "write_netcdf", "write_xdmf_index",
           "dataset_from_variables", "integer_ids"]

#: the array file of the time courses (output ``currents``)
RESULTS_NC = "currents.nc"
#: the index ParaView opens as a time series of the receptor sites (no numbers of its own)
RESULTS_XDMF = "currents.xdmf"

#: CF's reference date of ``time`` (units ``seconds since ...``): t = 0 of the run, not a date
TIME_ORIGIN = "1970-01-01 00:00:00"

#: the coordinate variables of ``currents.nc`` (the rest are data variables)
COORDS = ("time", "receptor", "receptor_id", "x_m", "y_m", "z_m", "longitudinal", "cross", "afferent", "afferent_id",
          "position_m")


def integer_ids(ids) -> np.ndarray:
    """The ``receptor`` / ``afferent`` dimension: the ids as integers where every id is one written plainly
    (``'0'``, ``'17'``; the receptors of a CSV without an id column: the ``receptor`` column of the tables),
    else each one's 0-based position."""
    text = np.asarray(ids).astype(str)
    plain = all(s.isdigit() and s.isascii() and str(int(s)) == s for s in text.tolist())
    values = np.array([int(s) for s in text.tolist()], dtype=np.int64) if plain else np.arange(text.size)
    return values.astype(np.int32) if values.size == 0 or values.max() < 2**31 else values


def _id_attrs(what: str, label: str) -> dict:
    return {"units": "1", "long_name": f"{what} index: its integer id where every {what} id is an integer, else its 0-based "
                         f"position; the id as written in the tables is {label}"}


def results_variables(sed, current=None, afferent=None) -> tuple[dict, dict]:
    """What ``currents.nc`` holds: name -> (dims, values, CF attributes), and the global attributes; the
    dimension coordinates (``time``, ``receptor``, ``afferent``) are variables of their own name.

    Parameters
    ----------
    sed : ReceptorSED
        SED at the receptors over the run's times (J/m^3 = Pa).
    current : ReceptorCurrent, optional
        Receptor currents (A).
    afferent : AfferentCurrent, optional
        Afferent currents (A).
    """
    from . import __version__

    layout = sed.layout
    pos = np.asarray(layout.positions, dtype=float)
    tr = ("time", "receptor")
    clock = ({"units": "1", "long_name": "step number (the export states no times)", "axis": "T"}
             if getattr(sed, "numbered", False) else
             {"units": f"seconds since {TIME_ORIGIN}", "calendar": "standard", "units_metadata": "leap_seconds: none",
              "standard_name": "time", "axis": "T",
              "long_name": f"time from the start of the run (CF needs a reference date: {TIME_ORIGIN} stands for t = 0)"})
    ids = np.asarray(layout.ids).astype(str)
    out = {"time": (("time",), np.asarray(sed.times, dtype=float), clock),
           "receptor": (("receptor",), integer_ids(ids), _id_attrs("receptor", "receptor_id")),
           "receptor_id": (("receptor",), ids, {"long_name": "receptor id (the tables' receptor column)"})}
    for k, name in enumerate(("x_m", "y_m", "z_m")):
        out[name] = (("receptor",), pos[:, k], {"units": "m", "long_name": f"receptor {name[0]} coordinate"})
    for name in ("longitudinal", "cross"):
        out[name] = (("receptor",), np.asarray(getattr(layout, name)).astype(np.int32),
                     {"units": "1", "long_name": f"{name} section index of the receptor"})
    out["sed_pa"] = (tr, np.asarray(sed.values, dtype=float),
                     {"units": "J m-3", "long_name": "strain-energy density at the receptor (J/m^3 = Pa)"})
    if current is not None:
        out["current_a"] = (tr, np.asarray(current.values, dtype=float), {"units": "A", "long_name": "receptor current"})
    if afferent is not None:
        aids = np.asarray(afferent.afferent_ids).astype(str)
        out["afferent"] = (("afferent",), integer_ids(aids), _id_attrs("afferent", "afferent_id"))
        out["afferent_id"] = (("afferent",), aids, {"long_name": "afferent id (the tables' afferent column)"})
        out["position_m"] = (("afferent",), np.asarray(afferent.positions, dtype=float),
                             {"units": "m", "long_name": f"afferent position along {afferent.axis}"})
        out["afferent_current_a"] = (("time", "afferent"), np.asarray(afferent.values, dtype=float),
                                     {"units": "A", "long_name": "afferent current (sum of its receptors' currents)"})
    attrs = {"Conventions": "CF-1.11", "title": "afferent: time courses at the receptors and afferents",
             "source": f"afferent-skin {__version__}",
             "history": f"written by afferent-skin {__version__} (afferent.export.write_outputs); run.json beside "
                        "this file records when, from which inputs and with which parameters",
             "comment": "run.json beside this file records the run; currents.xdmf beside it opens the receptors' "
                        "time courses in ParaView as a time series"}
    return out, attrs


def _aux(variables: dict, name: str, dims: tuple) -> list[str]:
    """CF: the auxiliary coordinates (positions, ids, section ids) of the data variable ``name``."""
    if name in COORDS:
        return []
    return [c for c in COORDS if c in variables and c not in dims and set(variables[c][0]) <= set(dims)]


def _chars(text) -> tuple[np.ndarray, int]:
    """Strings as a NC_CHAR array (n, strlen) of UTF-8 bytes; strlen at least 1."""
    raw = [s.encode("utf-8") for s in np.asarray(text).astype(str).tolist()]
    width = max([1, *map(len, raw)])
    return np.array(raw, dtype=f"S{width}").reshape(-1, 1).view("S1").reshape(len(raw), width), width


def _attr(value):
    """A netCDF attribute as NC_CHAR (text) or a number; never NC_STRING (see the module docstring)."""
    return np.bytes_(value.encode("utf-8")) if isinstance(value, str) else value


def _chunks(values: np.ndarray, dims: tuple, n_t: int):
    """Chunks along the (unlimited) time axis of about 1 MB that share the steps out evenly (the last one full),
    whole along the other axes; None (contiguous) without a time axis."""
    if "time" not in dims or n_t == 0:
        return None
    row = max(1, int(np.prod(values.shape[1:], dtype=np.int64)) * values.itemsize)
    n_chunks = -(-n_t // max(1, (1 << 20) // row))
    return (-(-n_t // n_chunks), *values.shape[1:])


def write_netcdf(path: str, variables: dict, attrs: dict) -> None:
    """``variables`` (name -> (dims, values, attrs)) as a NetCDF-4 file through h5netcdf (xarray not imported:
    0.4 s less per run); numbers uncompressed (float64), text as NC_CHAR arrays, attributes NC_CHAR.

    Uncompressed because writing must stay within 10 % of a run: on 595 receptors x 2301 steps, zlib
    level 1 with the shuffle filter gave 1.8 MB instead of 22 MB but took the write from 0.085 s to
    0.15 s, 13 % of that 1.1 s run; ``nccopy -d 1 -s`` compresses a file afterwards.
    """
    import h5netcdf

    text = {name: _chars(values) for name, (dims, values, _) in variables.items()
            if np.asarray(values).dtype.kind in "UOS"}
    with h5netcdf.File(path, "w") as f:
        dims = {d: len(values) for name, (dd, values, _) in variables.items() for d in dd[:1] if dd == (name,)}
        dims.update({f"{name}_strlen": width for name, (_, width) in text.items()})
        n_t = dims.pop("time")
        f.dimensions = {"time": None, **dims}  # unlimited, as CF files' time usually is (see the module docstring)
        f.resize_dimension("time", n_t)
        for name, (dims_, values, var_attrs) in variables.items():
            if name in text:
                v = f.create_variable(name, (*dims_, f"{name}_strlen"), "S1", data=text[name][0])
                v.attrs["_Encoding"] = _attr("utf-8")  # read back as text by xarray and netCDF4-python
            else:
                values = np.asarray(values)
                v = f.create_variable(name, dims_, values.dtype, data=values, chunks=_chunks(values, dims_, n_t))
            for key, value in var_attrs.items():
                v.attrs[key] = _attr(value)
            if aux := _aux(variables, name, dims_):
                v.attrs["coordinates"] = _attr(" ".join(aux))
        for key, value in attrs.items():
            f.attrs[key] = _attr(value)


def dataset_from_variables(variables: dict, attrs: dict):
    """The :class:`xarray.Dataset` of ``variables`` (:func:`results_variables`): what ``currents.nc`` reads back
    as; ``to_netcdf`` writes the ids as NC_CHAR again (their encoding says so)."""
    import xarray as xr

    coords = {k: xr.Variable(*v) for k, v in variables.items() if k in COORDS}
    for name in ("receptor_id", "afferent_id"):
        if name in coords:
            coords[name].encoding.update(dtype="S1", char_dim_name=f"{name}_strlen", _Encoding="utf-8")
    return xr.Dataset({k: xr.Variable(*v) for k, v in variables.items() if k not in COORDS}, coords=coords,
                      attrs=attrs)


def write_xdmf_index(path: str, variables: dict, nc_name: str = RESULTS_NC) -> None:
    """``currents.xdmf``: the receptor sites (polyvertex) at every step of ``time``, each step's ``sed_pa`` [and
    ``current_a``] and the section ids read from ``nc_name`` (beside ``path``) by HDF5 path: no number copied.

    XDMF 2 (what ParaView's "XDMF Reader" and VTK's ``vtkXdmfReader`` read; ParaView's Xdmf3 readers too).
    """
    from xml.sax.saxutils import quoteattr

    times = np.asarray(variables["time"][1], dtype=float)
    n = len(variables["receptor"][1])
    n_t = times.size
    src = quoteattr(nc_name)[1:-1]

    def h5(name: str, dims: str, kind: str = "Float", precision: int = 8) -> str:
        return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{precision}" Format="HDF">'
                f"{src}:/{name}</DataItem>")

    fields = [f for f in ("sed_pa", "current_a") if f in variables]
    static = "".join(f'<Attribute Name="{name}" AttributeType="Scalar" Center="Node">{h5(name, str(n), "Int", 4)}'
                     "</Attribute>" for name in ("longitudinal", "cross"))
    head = (f'<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1"/>'
            '<Geometry GeometryType="X_Y_Z">' + "".join(h5(c, str(n)) for c in ("x_m", "y_m", "z_m")) + "</Geometry>")
    lines = ['<?xml version="1.0" ?>', '<Xdmf Version="2.0">', "<Domain>",
             '<Grid Name="receptors" GridType="Collection" CollectionType="Temporal">']
    # ~1.5 kB a step (tried: XPath references to shared items, 14 % smaller, and VTK 9.7's vtkXdmfReader then
    # logs "Dimensions of Attribute not set" at every step); one template filled per step
    slab = "".join(f'<Attribute Name="{name}" AttributeType="Scalar" Center="Node">'
                   f'<DataItem ItemType="HyperSlab" Dimensions="1 {n}" Type="HyperSlab">'
                   f'<DataItem Dimensions="3 2" Format="XML">{{k}} 0 1 1 1 {n}</DataItem>'
                   f"{h5(name, f'{n_t} {n}')}</DataItem></Attribute>" for name in fields)
    step = f'<Grid Name="step {{k}}" GridType="Uniform"><Time Value="{{t!r}}"/>{head}{slab}{static}</Grid>'
    lines += [step.format(k=k, t=t) for k, t in enumerate(times.tolist())]
    lines += ["</Grid>", "</Domain>", "</Xdmf>", ""]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))

