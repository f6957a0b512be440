"""Every array a file holds is listed by ``afferent info`` (issue 36, item 1), for every mesh test file
under tests/data, each reader.

The arrays each file declares are counted from the file itself, not by afferent's readers:

- legacy ``.vtk``: the ``SCALARS``, ``VECTORS``, ``TENSORS``, ``NORMALS``, ``TEXTURE_COORDINATES``,
  ``COLOR_SCALARS`` section names and the arrays of each ``FIELD`` (its header's count of array
  headers ``name ncomp ntuples type``) under ``POINT_DATA`` / ``CELL_DATA``, keywords in any case
  (FreeFEM writes ``Scalars``); the lines are read as bytes, so binary files' headers count too;
- VTK XML (``.vtu``, ``.pvtu``): the ``Name`` of each ``DataArray`` (``PDataArray``) inside
  ``PointData`` / ``CellData``, found by a regular expression in the text before any appended
  data; a ``.vtm``: the arrays every volume (``.vtu``) block declares (an array missing from one
  block is dropped with a note, by design); a ``.pvd`` or JSON ``.series``: its first entry's;
- XDMF: each ``Attribute``'s ``Name`` and ``Center`` (ElementTree);
- CalculiX ``.frd``: the names on the `` -4`` lines of its result blocks (text also in binary files);
- Exodus II: ``name_nod_var`` and ``name_elem_var`` (scipy's netCDF reader for the classic files,
  h5py for netCDF-4);
- MED: the field names under ``/CHA`` (h5py); afferent lists a code_aster field by the name after
  its 8-character result name (``RESU____DEPL`` -> ``DEPL``);
- FEBio ``.xplt``: the ``<var type=...>`` list of the ``<plotfile>`` of the ``.feb`` input beside it
  (the binary plot file is FEBio's own format: its dictionary is what afferent parses; the input
  says independently what FEBio was asked to write);
- Gmsh ``.msh``: the first string tag (the view's name) of each ``$NodeData``/``$ElementNodeData``
  (point) and ``$ElementData`` (cell) block, text in binary files too; ``.pos``: each ``View "name"``
  (point data, and ``name@cell``).
- VTKHDF: the dataset names under ``/VTKHDF/PointData`` and ``/VTKHDF/CellData`` (h5py);
- EnSight ``.case``: the description of each ``... per node:`` / ``... per element:`` variable line.

Tables (CSV and the text listings of CalculiX, Abaqus, COMSOL, MAPDL) are left out here: their
"arrays" are header columns grouped into tensors by afferent's own name rules, which their own
tests pin (tests/test_csv*.py). Files afferent refuses by design (tests/data/bad, fuzz, Lagrange
cells of degree 3, 2-D meshes: :data:`_REFUSED`) are left out too.
"""

from __future__ import annotations

import glob
import json
import os
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from afferent.cli import main

DATA = os.path.join(os.path.dirname(__file__), "data")
_SKIP_DIRS = ("bad", "fuzz", "golden", "report", "csv", "mapdl")
#: Files afferent refuses by design, and why.
_REFUSED = {"ngsolve/block_order3.vtu": "Lagrange cells of degree 3", "vtk/lagrange_hex64.vtk": "degree 3",
            "mfem/order3/order3.pvd": "degree 3", "mfem/order3/Cycle000003/data.pvtu": "degree 3",
            "mfem/order3/Cycle000003/proc000000.vtu": "degree 3", "ngsolve/plane_2d.vtu": "no volume cells",
            "febio/block_hex8_shell.xplt": "shell elements",
            "exodus/plate_ioss.e": "a 2-D section: its element arrays are on the QUAD4 blocks afferent ignores",
            "gmsh/sed_without_mesh.msh": "a view without its mesh"}
_ENDINGS = (".vtk", ".vtu", ".pvtu", ".vtm", ".pvd", ".series", ".xdmf", ".frd", ".frd.gz", ".e", ".rmed", ".med",
            ".xplt", ".msh", ".pos", ".vtkhdf", ".case")


def _files() -> list[str]:
    out = []
    for path in sorted(glob.glob(os.path.join(DATA, "**", "*"), recursive=True)):
        rel = os.path.relpath(path, DATA)
        if rel.split(os.sep)[0] in _SKIP_DIRS or not path.endswith(_ENDINGS) or rel in _REFUSED:
            continue
        out.append(path)
    return out


# -- the arrays a file declares, from the file --------------------------------------------------------------------

_LEGACY_KINDS = ("SCALARS", "VECTORS", "TENSORS", "NORMALS", "TEXTURE_COORDINATES", "COLOR_SCALARS")
_LEGACY_TYPES = ("bit", "unsigned_char", "char", "unsigned_short", "short", "unsigned_int", "int", "unsigned_long",
                 "long", "float", "double", "vtkidtype", "vtktypeint64", "vtktypeuint64", "string")


_SIZES = {"bit": 1, "unsigned_char": 1, "char": 1, "unsigned_short": 2, "short": 2, "unsigned_int": 4, "int": 4,
          "unsigned_long": 8, "long": 8, "float": 4, "double": 8, "vtkidtype": 8, "vtktypeint64": 8,
          "vtktypeuint64": 8}


def _legacy_vtk(path: str) -> set[tuple[str, str]]:
    """ASCII: the keyword lines (data lines are numbers); binary: the header lines, walked with each
    block's size (a binary block need not end with a newline, so the next keyword can follow it on one line)."""
    with open(path, "rb") as fh:
        text = fh.read()
    binary = text.split(b"\n", 3)[2].strip().upper() == b"BINARY"
    declared, where, n, at, cells = set(), None, 0, 0, []

    def line() -> list[str]:
        nonlocal at
        end = text.index(b"\n", at) if b"\n" in text[at:] else len(text)
        words, at = text[at:end].decode("latin-1").split(), end + 1
        return words

    def skip(count: int, kind: str) -> None:  # binary data: count values of kind
        nonlocal at
        at += count * _SIZES[kind.lower()]
        at += text[at:at + 1] == b"\n"

    if not binary:  # ASCII: keyword lines, data lines are numbers
        field_left = 0
        for raw in text.splitlines():
            words = raw.decode("latin-1").split()
            key = words[0].upper() if words else ""
            if key in ("POINT_DATA", "CELL_DATA") and len(words) == 2:
                where, field_left = key.split("_")[0].lower(), 0
            elif where and key in _LEGACY_KINDS and len(words) >= 2:
                declared.add((words[1], where))
            elif where and key == "FIELD" and len(words) == 3:
                field_left = int(words[2])
            elif field_left and len(words) == 4 and words[3].lower() in _LEGACY_TYPES and words[1].isdigit():
                declared.add((words[0], where))
                field_left -= 1
        return declared
    for _ in range(4):  # title, version, BINARY, DATASET
        line()
    while at < len(text):
        words = line()
        key = words[0].upper() if words else ""
        if key == "POINTS":
            skip(3 * int(words[1]), words[2])
        elif key == "CELLS":
            cells = words
            if b"OFFSETS" not in text[at:at + 20]:
                skip(int(words[2]), "int")
        elif key in ("OFFSETS", "CONNECTIVITY"):  # file version 5.1: CELLS n_offsets n_connectivity
            skip(int(cells[1]) if key == "OFFSETS" else int(cells[2]), words[1])
        elif key == "CELL_TYPES":
            skip(int(words[1]), "int")
        elif key in ("POINT_DATA", "CELL_DATA"):
            where, n = key.split("_")[0].lower(), int(words[1])
        elif key == "SCALARS":
            declared.add((words[1], where))
            if text[at:at + 12].upper() == b"LOOKUP_TABLE":
                line()
            skip(n * (int(words[3]) if len(words) > 3 else 1), words[2])
        elif key in ("VECTORS", "NORMALS", "TENSORS", "TENSORS6"):
            declared.add((words[1], where))
            skip(n * {"TENSORS": 9, "TENSORS6": 6}.get(key, 3), words[2])
        elif key == "TEXTURE_COORDINATES":
            declared.add((words[1], where))
            skip(n * int(words[2]), words[3])
        elif key == "COLOR_SCALARS":
            declared.add((words[1], where))
            skip(n * int(words[2]), "unsigned_char")
        elif key == "LOOKUP_TABLE":  # a table of colours (FreeFEM): its size x RGBA bytes
            skip(4 * int(words[2]), "unsigned_char")
        elif key == "FIELD":
            for _ in range(int(words[2])):
                name, ncomp, ntuples, kind = line()
                if where:
                    declared.add((name, where))
                skip(int(ncomp) * int(ntuples), kind)
                if text[at:at + 8] == b"METADATA":
                    while line():
                        pass
        elif key == "METADATA":
            while line():
                pass
    return declared


def _xml_head(path: str) -> str:
    with open(path, "rb") as fh:
        text = fh.read().decode("latin-1")
    return text.split("<AppendedData", 1)[0]


def _vtk_xml(path: str) -> set[tuple[str, str]]:
    head = _xml_head(path)
    declared = set()
    for where, tag in (("point", "PointData"), ("cell", "CellData")):
        for block in re.findall(rf"<P?{tag}\b[^>]*>(.*?)</P?{tag}>", head, re.S):
            declared |= {(n, where) for n in re.findall(r'<P?DataArray\b[^>]*?\bName="([^"]+)"', block)}
    return declared


def _vtm(path: str) -> set[tuple[str, str]]:
    files = [os.path.join(os.path.dirname(path), e.get("file")) for e in ET.parse(path).iter("DataSet")
             if (e.get("file") or "").endswith(".vtu")]
    sets = [_vtk_xml(f) for f in files if os.path.isfile(f)]
    return set.intersection(*sets) if sets else set()


def _series_first(path: str) -> str:
    if path.endswith(".series"):
        with open(path) as fh:
            name = json.load(fh)["files"][0]["name"]
    else:
        name = next(e.get("file") for e in ET.parse(path).iter("DataSet"))
    return os.path.join(os.path.dirname(path), name)


def _xdmf(path: str) -> set[tuple[str, str]]:
    centre = {"node": "point", "cell": "cell"}
    return {(a.get("Name"), centre[a.get("Center", "Node").lower()]) for a in ET.parse(path).iter("Attribute")}


def _frd(path: str) -> set[tuple[str, str]]:
    import gzip

    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as fh:
        return {(m.decode(), "point") for m in re.findall(rb"\n -4  (\S+)", fh.read())}


def _exodus(path: str) -> set[tuple[str, str]]:
    def names(chars) -> list[str]:
        return ["".join(c.decode() if isinstance(c, bytes) else c for c in row).strip("\x00 ") for row in chars]

    with open(path, "rb") as fh:
        hdf5 = fh.read(4) == b"\x89HDF"
    if hdf5:
        import h5py

        with h5py.File(path) as h:
            got = {v: names(np.asarray(h[v][()]).astype("S1")) for v in ("name_nod_var", "name_elem_var") if v in h}
    else:
        from scipy.io import netcdf_file

        with netcdf_file(path, "r", mmap=False) as nc:
            got = {v: names(nc.variables[v][:].copy()) for v in ("name_nod_var", "name_elem_var") if v in nc.variables}
    return ({(n, "point") for n in got.get("name_nod_var", [])} | {(n, "cell") for n in got.get("name_elem_var", [])})


def _med(path: str) -> set[tuple[str, str]]:
    import h5py

    with h5py.File(path) as h:
        return {(name, "any") for name in h.get("CHA", {})}


def _vtkhdf(path: str) -> set[tuple[str, str]]:
    import h5py

    with h5py.File(path) as h:
        return {(n, where) for group, where in (("PointData", "point"), ("CellData", "cell"))
                for n in h["VTKHDF"].get(group, {})}


def _case(path: str) -> set[tuple[str, str]]:
    out = set()
    with open(path) as fh:
        for line in fh:
            kind, _, rest = line.partition(":")
            if " per node" in kind or " per element" in kind:
                out.add((rest.split()[-2], "point" if " per node" in kind else "cell"))  # description, then file
    return out


def _xplt(path: str) -> set[tuple[str, str]]:
    feb = ET.parse(os.path.splitext(path)[0] + ".feb")
    return {(v.get("type"), "any") for p in feb.iter("plotfile") for v in p.iter("var")}


def _msh(path: str) -> set[tuple[str, str]]:
    with open(path, "rb") as fh:
        text = fh.read()
    where = {b"NodeData": "point", b"ElementNodeData": "point", b"ElementData": "cell"}
    return {(m.group(2).decode(), where[m.group(1)])
            for m in re.finditer(rb'\n\$(NodeData|ElementData|ElementNodeData)\s*\n\s*\d+\s*\n\s*"([^"]*)"', text)}


def _pos(path: str) -> set[tuple[str, str]]:
    with open(path, "rb") as fh:
        names = re.findall(rb'View\s*"([^"]*)"', fh.read())
    return {(n.decode(), "point") for n in names} | {(n.decode() + "@cell", "cell") for n in names}


def declared(path: str) -> set[tuple[str, str]]:
    """(name, 'point' | 'cell' | 'any') of each array ``path`` declares, read from the file itself."""
    if path.endswith((".pvd", ".series")):
        return declared(_series_first(path))
    ext = ".frd" if path.endswith(".frd.gz") else os.path.splitext(path)[1]
    return {".vtk": _legacy_vtk, ".vtu": _vtk_xml, ".pvtu": _vtk_xml, ".vtm": _vtm, ".xdmf": _xdmf, ".frd": _frd,
            ".e": _exodus, ".rmed": _med, ".med": _med, ".xplt": _xplt, ".msh": _msh, ".pos": _pos, ".vtkhdf": _vtkhdf, ".case": _case}[ext](path)


# -- what afferent info lists ---------------------------------------------------------------------------------------

def listed(path: str, capsys) -> set[tuple[str, str]]:
    assert main(["info", path]) == 0
    out = capsys.readouterr().out
    section = out.split("\n  arrays\n", 1)[1]
    return {(m.group(1), m.group(2)) for m in re.finditer(r"^    '(.+?)'\s+(point|cell)\s", section, re.M)}


FILES = _files()


def test_the_mesh_test_files_cover_every_reader():
    kinds = {".frd" if f.endswith(".frd.gz") else os.path.splitext(f)[1] for f in FILES}
    assert kinds >= {".vtk", ".vtu", ".pvtu", ".vtm", ".pvd", ".series", ".xdmf", ".frd", ".e", ".rmed", ".med",
                     ".xplt", ".msh", ".pos", ".vtkhdf", ".case"}
    assert len(FILES) > 40


@pytest.mark.parametrize("path", FILES, ids=[os.path.relpath(f, DATA) for f in FILES])
def test_info_lists_every_array_the_file_declares(path, capsys):
    want = declared(path)
    got = listed(path, capsys)
    missing = set()
    for name, where in want:
        if where != "any" and (name, where) in got:
            continue
        if where == "any" and any(n in (name, name[8:]) for n, _ in got):  # MED: RESU____DEPL -> DEPL
            continue
        missing.add((name, where))
    assert not missing, f"{os.path.relpath(path, DATA)}: declared {sorted(want)}, listed {sorted(got)}"


def test_getfem_second_scalars_and_tensors_sections_are_read_by_both_readers():
    """GetFEM's export_to_vtk writes one section an array; the SED is the second SCALARS section. VTK's
    legacy reader (the binary file: meshio refuses it) kept only the first of each kind before."""
    from afferent.io import read_raw

    for name, reader in (("block_ascii.vtk", "meshio"), ("block_binary.vtk", "VTK")):
        raw = read_raw(os.path.join(DATA, "getfem", name))
        assert raw.reader.startswith(reader)
        assert sorted(raw.arrays) == ["SED", "displacement", "strain", "stress", "von_mises"]
        assert raw.arrays["strain"].values.shape == (1, 75, 9)  # TENSORS: 9 components from either reader
    a = read_raw(os.path.join(DATA, "getfem", "block_ascii.vtk")).arrays
    b = read_raw(os.path.join(DATA, "getfem", "block_binary.vtk")).arrays
    for k in a:
        np.testing.assert_allclose(a[k].values, b[k].values, rtol=0, atol=1e-5 * np.abs(b[k].values).max())  # ASCII digits
