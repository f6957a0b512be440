"""Fuzz targets that generate paths and links in every index format (issue 33), for fuzz_readers.py.

An input's bytes choose, for each file an export points to, how the reference is written and where
it leads: inside the export's folder (relative, in a subfolder, absolute, through ``sub/..``, a
symbolic link inside), outside it (``../``, absolute, a symbolic link to a file or to a folder
outside, ``/dev/zero``, ``/proc/self/environ``), or nowhere sensible (a FIFO, a folder, a missing
file, an empty name, the index itself, a loop of symbolic links, a 5,000-character name, odd
spellings); and whether the read allows files outside the folder. The export is built in the
fuzzer's folder (``exp/`` the export's folder, ``out/`` beside it) in one of the index formats of
:data:`KINDS` - ``.pvd``, JSON ``.series``, ``.pvtu``, ``.vtm``, XDMF Binary and HDF items, HDF5
external storage, external links and virtual datasets, MED and Exodus netCDF-4 files with external
storage or links, and indexes of indexes - sometimes with a few bytes of the index text mutated.

The read (:func:`afferent.io.read_raw`) must end in a result or a documented error; besides the
undocumented exceptions fuzz_readers.py records, :func:`check` raises a finding when:

- ``ReadOutside``: a result lists a file outside the export's folder that was not allowed;
- ``NotRegularRead``: a result lists a file that is not a regular file;
- ``SilentResult``: a result where the references say the read must be refused (a file outside
  the folder not allowed, a FIFO, a device, a folder, a missing file);
- ``LostFile``: a result that does not list a file its values came from (the record of a run
  would miss it).

The oracle computes where each reference leads itself (``os.stat``, ``os.path.realpath``), not
through afferent.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "tests" / "data"
STEP = HERE / "seeds" / "step.vtu"
SED_ONLY = DATA / "dolfinx" / "sed_only"
MED = DATA / "med" / "block_tetra.med"
NETCDF4 = DATA / "exodus" / "layers_sfepy.e"

#: the index formats, one fuzz target each (``paths-<kind>`` in fuzz_readers.TARGETS)
KINDS = ("pvd", "series", "pvtu", "vtm", "xdmf-binary", "xdmf-hdf", "h5-storage", "h5-link", "h5-vds", "med",
         "netcdf", "nested")

#: how a reference is written, and where it leads
REFS = ("inside", "inside-sub", "inside-abs", "inside-dotdot", "link-in", "up", "abs-out", "link-out", "link-dir-out",
        "fifo", "dev-zero", "environ", "folder", "missing", "empty", "self", "loop-link", "long", "weird")
WEIRD = ("~/x.vtu", "file:///etc/passwd", " step.vtu", "step.vtu\n", "%s%n%x", "\\\\server\\share\\x", "ü/ü.vtu", "..", ".",
         "/", "sub/", "./../exp/step.vtu", "//etc//passwd", "exp/../../out/x")


class PathFinding(Exception):
    """A read whose result breaks what the references say (the kinds below)."""


class ReadOutside(PathFinding):
    pass


class NotRegularRead(PathFinding):
    pass


class SilentResult(PathFinding):
    pass


class LostFile(PathFinding):
    pass


class _Draw:
    """Choices drawn from the input's bytes (zeros once they run out)."""

    def __init__(self, data: bytes):
        self.data, self.k = data, 0

    def byte(self) -> int:
        b = self.data[self.k] if self.k < len(self.data) else 0
        self.k += 1
        return b

    def pick(self, seq):
        return seq[self.byte() % len(seq)]

    def rest(self) -> bytes:
        return self.data[self.k:]


# ------------------------------------------------------------------------------------------ member files
def _vtu(path: Path) -> None:
    shutil.copy(STEP, path)


def _sed_values() -> np.ndarray:
    import h5py

    with h5py.File(f"{SED_ONLY}.h5", "r") as f:
        return f["/Function/sed/3"][()]


def _raw_sed(path: Path) -> None:
    _sed_values().astype("<f8").tofile(path)


def _h5_x(path: Path) -> None:
    import h5py

    with h5py.File(path, "w") as f:
        f["x"] = _sed_values()


def _h5_heavy(path: Path) -> None:
    shutil.copy(f"{SED_ONLY}.h5", path)


class _Builder:
    """Places the files references lead to, and remembers each reference for the oracle."""

    def __init__(self, root: Path, draw: _Draw):
        self.exp, self.out, self.draw = root / "exp", root / "out", draw
        for d in (self.exp, self.exp / "sub", self.out):
            d.mkdir(parents=True, exist_ok=True)
        self.refs: list[tuple[str, str, str]] = []  # (referrer, reference, ref kind)
        self.n = 0

    def place(self, referrer: Path, ext: str, make, kinds=REFS) -> str:
        """A reference from ``referrer`` to a new member (``make(path)`` writes it), written as the drawn kind."""
        kind = self.draw.pick(kinds)
        self.n += 1
        name = f"m{self.n}{ext}"
        here, out = referrer.parent, self.out
        ref = name
        if kind == "inside":
            make(here / name)
        elif kind == "inside-sub":
            (here / "sub").mkdir(exist_ok=True)
            make(here / "sub" / name)
            ref = f"sub/{name}"
        elif kind == "inside-abs":
            make(here / name)
            ref = str(here / name)
        elif kind == "inside-dotdot":
            (here / "sub").mkdir(exist_ok=True)
            make(here / name)
            ref = f"sub/../{name}"
        elif kind == "link-in":
            make(here / f"real-{name}")
            (here / name).symlink_to(here / f"real-{name}")
        elif kind == "up":
            make(out / name)
            ref = os.path.relpath(out / name, here)
        elif kind == "abs-out":
            make(out / name)
            ref = str(out / name)
        elif kind == "link-out":
            make(out / f"t-{name}")
            (here / name).symlink_to(out / f"t-{name}")
        elif kind == "link-dir-out":
            make(out / name)
            if not os.path.lexists(here / "d"):
                (here / "d").symlink_to(out, target_is_directory=True)
            ref = f"d/{name}"
        elif kind == "fifo":
            os.mkfifo(here / name)
        elif kind == "dev-zero":
            ref = "/dev/zero"
        elif kind == "environ":
            ref = "/proc/self/environ"
        elif kind == "folder":
            (here / name).mkdir()
        elif kind == "empty":
            ref = ""
        elif kind == "self":
            ref = referrer.name
        elif kind == "loop-link":
            (here / name).symlink_to(here / f"b-{name}")
            (here / f"b-{name}").symlink_to(here / name)
        elif kind == "long":
            ref = "x" * 5000 + ext
        elif kind == "weird":
            ref = self.draw.pick(WEIRD)
        self.refs.append((str(referrer), ref, kind))
        return ref

    def members(self, referrer: Path, ext: str, make, n: int | None = None) -> list[str]:
        return [self.place(referrer, ext, make) for _ in range(n or 1 + self.draw.byte() % 2)]


def _xml_attr(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def _pvd(b: _Builder, path: Path, make=_vtu, ext=".vtu") -> None:
    refs = b.members(path, ext, make)
    path.write_text('<VTKFile type="Collection"><Collection>' + "".join(
        f'<DataSet timestep="{k}" file="{_xml_attr(r)}"/>' for k, r in enumerate(refs)) + "</Collection></VTKFile>")


def _series(b: _Builder, path: Path, make=_vtu, ext=".vtu") -> None:
    refs = b.members(path, ext, make)
    path.write_text(json.dumps({"file-series-version": "1.0", "files": [{"name": r, "time": k} for k, r in enumerate(refs)]}))


def _pvtu(b: _Builder, path: Path) -> None:
    refs = b.members(path, ".vtu", _vtu)
    path.write_text('<VTKFile type="PUnstructuredGrid" version="1.0"><PUnstructuredGrid GhostLevel="0"><PPoints>'
                    '<PDataArray type="Float64" NumberOfComponents="3"/></PPoints>'
                    + "".join(f'<Piece Source="{_xml_attr(r)}"/>' for r in refs) + "</PUnstructuredGrid></VTKFile>")


def _vtm(b: _Builder, path: Path) -> None:
    refs = b.members(path, ".vtu", _vtu)
    path.write_text('<VTKFile type="vtkMultiBlockDataSet" version="1.0"><vtkMultiBlockDataSet>'
                    + "".join(f'<DataSet index="{k}" file="{_xml_attr(r)}"/>' for k, r in enumerate(refs))
                    + "</vtkMultiBlockDataSet></VTKFile>")


def _sed_xdmf(path: Path, item: str) -> None:
    text = Path(f"{SED_ONLY}.xdmf").read_text()
    path.write_text(text.replace('<DataItem Dimensions="32 1" Format="HDF">sed_only.h5:/Function/sed/3</DataItem>', item))


def _xdmf_binary(b: _Builder, path: Path) -> None:
    shutil.copy(f"{SED_ONLY}.h5", path.parent / "sed_only.h5")
    ref = b.place(path, ".bin", _raw_sed)
    _sed_xdmf(path, f'<DataItem Dimensions="32 1" NumberType="Float" Precision="8" Format="Binary">{_xml_text(ref)}</DataItem>')


def _xml_text(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;")


def _xdmf_hdf(b: _Builder, path: Path) -> None:
    shutil.copy(f"{SED_ONLY}.h5", path.parent / "sed_only.h5")
    ref = b.place(path, ".h5", _h5_heavy)
    _sed_xdmf(path, f'<DataItem Dimensions="32 1" Format="HDF">{_xml_text(ref)}:/Function/sed/3</DataItem>')


def _rewrite(h5file: Path, name: str, make) -> None:
    """Dataset ``name`` of an HDF5 file replaced by what ``make(file, name, values)`` creates (attributes kept);
    a reference h5py refuses to write (an empty name) becomes a missing file."""
    import h5py

    with h5py.File(h5file, "a") as f:
        values, attrs = f[name][()], dict(f[name].attrs)
        del f[name]
        try:
            make(f, name, values)
        except (ValueError, TypeError, OSError, UnicodeError, RuntimeError):
            f[name] = h5py.ExternalLink("missing.h5", "/x")
        if isinstance(f.get(name, getlink=True), h5py.HardLink):
            f[name].attrs.update(attrs)


def _storage(ref: str):
    def make(f, name, values):
        f.create_dataset(name, shape=values.shape, dtype=values.dtype, external=[(ref, 0, values.nbytes)])
    return make


def _link(ref: str):
    def make(f, name, values):
        import h5py

        f[name] = h5py.ExternalLink(ref, "/x")
    return make


def _vds(ref: str):
    def make(f, name, values):
        import h5py

        layout = h5py.VirtualLayout(shape=values.shape, dtype=values.dtype)
        layout[...] = h5py.VirtualSource(ref, "x", shape=values.shape)
        f.create_virtual_dataset(name, layout)
    return make


def _h5(kind: str):
    def build(b: _Builder, path: Path) -> None:
        shutil.copy(f"{SED_ONLY}.h5", path.parent / "sed_only.h5")
        shutil.copy(f"{SED_ONLY}.xdmf", path)
        if kind == "storage":
            ref, how = b.place(path.parent / "sed_only.h5", ".bin", _raw_sed), _storage
        else:
            ref, how = b.place(path.parent / "sed_only.h5", ".h5", _h5_x), _link if kind == "link" else _vds
        _rewrite(path.parent / "sed_only.h5", "/Function/sed/3", how(ref))
    return build


def _whole_file(source: Path, dataset: str):
    """A MED or Exodus file whose dataset ``dataset`` (found by its path's end) is stored externally or linked."""
    def build(b: _Builder, path: Path) -> None:
        import h5py

        shutil.copy(source, path)
        found: list[str] = []
        with h5py.File(path, "r") as f:
            f.visit(lambda n: found.append(n) if n.endswith(dataset) else None)
            values = f[found[0]][()]
        if b.draw.byte() % 2:
            ref = b.place(path, ".bin", lambda p: values.tofile(p))
            _rewrite(path, found[0], _storage(ref))
        else:
            def member(p, values=values):
                with h5py.File(p, "w") as f:
                    f["x"] = values
            ref = b.place(path, ".h5", member)
            _rewrite(path, found[0], _link(ref))
    return build


def _single_grid(b: _Builder, path: Path) -> None:
    """meshio's single-grid XDMF (fuzz/seeds/inline.xdmf) with its SED in a Binary data item the input places."""
    import re

    ref = b.place(path, ".bin", lambda p: np.linspace(0, 1e-4, 8).astype("<f8").tofile(p))
    text = (HERE / "seeds" / "inline.xdmf").read_text()
    item = f'<DataItem DataType="Float" Dimensions="8" Format="Binary" Precision="8">{_xml_text(ref)}</DataItem>'
    path.write_text(re.sub(r'(<Attribute Name="SED"[^>]*>)<DataItem[^>]*>[^<]*</DataItem>', lambda m: m.group(1) + item,
                           text, count=1))


def _nested(b: _Builder, path: Path) -> Path | None:
    """An index whose members are indexes: a .pvd or .series of .pvtu, .vtm or single-grid XDMF files, or a .vtm
    of .pvtu records (VTK opens their pieces itself)."""
    inner, ext = b.draw.pick(((_pvtu, ".pvtu"), (_vtm, ".vtm"), (_single_grid, ".xdmf")))
    if b.draw.byte() % 4 == 0:
        path = path.with_name("e.vtm")
        refs = b.members(path, ".pvtu", lambda p: _pvtu(b, Path(p)))
        path.write_text('<VTKFile type="vtkMultiBlockDataSet" version="1.0"><vtkMultiBlockDataSet>'
                        + "".join(f'<DataSet index="{k}" file="{_xml_attr(r)}"/>' for k, r in enumerate(refs))
                        + "</vtkMultiBlockDataSet></VTKFile>")
        return path
    outer = b.draw.pick((_pvd, _series))
    outer(b, path, lambda p: inner(b, Path(p)), ext)


#: kind -> (export file name, builder)
BUILDERS = {
    "pvd": ("e.pvd", _pvd), "series": ("e.vtu.series", _series), "pvtu": ("e.pvtu", _pvtu), "vtm": ("e.vtm", _vtm),
    "xdmf-binary": ("e.xdmf", _xdmf_binary), "xdmf-hdf": ("e.xdmf", _xdmf_hdf), "h5-storage": ("e.xdmf", _h5("storage")),
    "h5-link": ("e.xdmf", _h5("link")), "h5-vds": ("e.xdmf", _h5("vds")), "med": ("e.med", _whole_file(MED, "NOE/COO")),
    "netcdf": ("e.e", _whole_file(NETCDF4, "coord")), "nested": ("e.pvd", _nested),
}


def build(kind: str, data: bytes, folder: str) -> str:
    """Build the export of target ``paths-<kind>`` from ``data`` in ``folder``; returns its path (``folder/case.json``
    says how to judge the read)."""
    root = Path(folder)
    draw = _Draw(data)
    allow = draw.byte() % 4 == 0
    b = _Builder(root, draw)
    name, builder = BUILDERS[kind]
    path = builder(b, b.exp / name) or b.exp / name
    mutated = False
    mutations = draw.byte() % 8
    if mutations >= 6 and path.suffix not in (".med", ".e"):  # a quarter of the indexes get a few bytes changed
        text = bytearray(path.read_bytes())
        for _ in range(mutations - 5):
            if text:
                text[draw.byte() * 7 % len(text)] = draw.byte()
        path.write_bytes(bytes(text))
        mutated = True
    (root / "case.json").write_text(json.dumps({"kind": kind, "allow": allow, "mutated": mutated, "export": str(path),
                                                "refs": b.refs}))
    return str(path)


# ------------------------------------------------------------------------------------------ the oracle
def _inside(path: str, folder: str) -> bool:
    real, base = os.path.realpath(path), os.path.realpath(folder)
    return os.path.commonpath([real, base]) == base


def _lead(referrer: str, ref: str, kind: str, exp: str, allow: bool) -> tuple[str, str | None]:
    """Where a reference leads: ('in' | 'out' | 'bad' | 'any', the file when it is one)."""
    if ref == "." and referrer.endswith(".h5"):
        return "any", None  # a virtual dataset's own file
    if not ref.strip() or "\x00" in ref or len(ref) > 1000:
        return ("any" if referrer.endswith(".vtm") and not ref.strip() else "bad"), None  # VTK skips an empty name
    path = ref if os.path.isabs(ref) else os.path.join(os.path.dirname(referrer), ref)
    if not _inside(path, exp) and not allow:
        return "out", path
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return ("any" if referrer.endswith(".vtm") else "bad"), None  # VTK reads a .vtm's other blocks
    if not stat.S_ISREG(mode):
        return "bad", None
    if kind in ("self", "environ", "weird") or os.path.realpath(path) == os.path.realpath(referrer):
        return "any", path  # a regular file, not a valid member: a result or an error
    return ("in" if _inside(path, exp) else "out"), path


def check(path: str) -> None:
    """Read the export ``path`` built by :func:`build` and judge the result (raises a :class:`PathFinding`);
    documented errors pass through to the caller."""
    from afferent.io import read_raw

    case = json.loads((Path(path).parent.parent / "case.json").read_text())
    exp, allow = str(Path(path).parent), case["allow"]
    raw = read_raw(path, allow_outside_files=allow)
    files = [os.path.realpath(f) for f in raw.files]
    for f in raw.files:
        if not os.path.isfile(f):
            raise NotRegularRead(f"{case['kind']}: the result lists {f!r}, not a regular file")
        if not allow and not _inside(f, exp):
            raise ReadOutside(f"{case['kind']}: the result lists {f!r}, outside {exp!r}, not allowed")
    if case["mutated"]:
        return
    leads = [_lead(r, ref, kind, exp, allow) for r, ref, kind in case["refs"]]
    wanted = {lead for lead, _ in leads}
    if "bad" in wanted or ("out" in wanted and not allow):
        raise SilentResult(f"{case['kind']}: a result where the references {case['refs']} must be refused")
    if "any" in wanted:
        return
    for lead, target in leads:
        if target is not None and os.path.realpath(target) not in files:
            raise LostFile(f"{case['kind']}: {target!r} read but not listed in {raw.files}")
