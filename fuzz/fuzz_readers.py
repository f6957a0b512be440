"""Coverage-guided fuzzing of everything that reads a user's file (atheris).

Each input's first byte picks a target (an FE export in one of the formats, a receptor table,
an observed profile, a waveform, a scene); the rest is written to a file with that target's
extension and read through the public API with fixed, valid options. The only outcomes
accepted are a result or one of the documented errors (:class:`afferent.exceptions.AfferentError`
and its subclasses, which the CLI turns into one line and exit 2). Anything else - IndexError,
KeyError, a bare ValueError from numpy or pandas, a hang - is a finding: the fuzzer stops and
writes the input as ``crash-<hash>``.

The 'rst' target (ANSYS MAPDL results, the ``ansys`` extra) reads each input in a child
process (about a second each; a native crash of ansys-mapdl-reader must come back as an
error naming the signal); its seeds are the reader's shipped result file and cuts of it.

Run (the seed corpus is built from the test files on first use)::

    .venv/bin/pip install atheris
    .venv/bin/python fuzz/fuzz_readers.py fuzz/corpus -max_total_time=1800 -timeout=20 -rss_limit_mb=4096

With ``AFFERENT_FUZZ_FINDINGS=DIR`` set, a finding does not stop the run: each new kind
(exception type and the afferent line that raised it) is written to DIR as ``<kind>.bin`` (the
input) and ``<kind>.txt`` (target and traceback), and fuzzing goes on; the inputs tried, by
outcome (a result, a documented error, too short, a finding), are written to ``DIR/stats.txt``
every 1,000 inputs.

The path targets (``paths-*``, :mod:`fuzz_paths`) build an export whose side files (steps, pieces,
blocks, heavy data, HDF5 links and external storage) are named and placed as the input chooses,
inside or outside the export's folder, as FIFOs, devices, folders or missing files, and judge the
read: a result must not list a file outside the folder (unless allowed) nor one that is not a
regular file, must not come where the references say it must be refused, and must list every file
its values came from.

Without atheris, ``fuzz_loop.py`` drives the same targets by random mutation, with a supervisor
that records crashes and hangs (see its docstring)::

    nice -n 10 .venv/bin/python fuzz/fuzz_loop.py --seconds 1800 --findings /tmp/findings

Replay one input (prints the exception and the target)::

    .venv/bin/python fuzz/fuzz_readers.py --replay crash-...
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import fuzz_paths  # noqa: E402 - beside this file

#: target name -> (file suffix, reader); readers take the path and use fixed, valid options.
TARGETS: list[tuple[str, str]] = [
    ("csv", ".csv"), ("txt", ".txt"), ("dat", ".dat"), ("rpt", ".rpt"), ("csv.gz", ".csv.gz"),
    ("vtu", ".vtu"), ("vtk", ".vtk"), ("pvd", ".pvd"), ("xdmf", ".xdmf"), ("frd", ".frd"),
    ("receptors", ".csv"), ("observed", ".csv"), ("waveform", ".csv"), ("scene", ".toml"), ("sed_table", ".csv"),
    ("exodus", ".e"),  # appended: existing findings keep their target (their first byte is below 15)
    ("med", ".med"),
    ("rst", ".rst"),  # ANSYS MAPDL results (the 'ansys' extra); read in a child process, ~1 s an input
    # XDMF with its HDF5 heavy data (the collection reader): the fuzzed XDMF beside a valid heavy.h5, and
    # a valid collection XDMF beside the fuzzed heavy.h5
    ("xdmf-text", ".xdmf"), ("xdmf-heavy", ".h5"),
    # long lines: the input's first line repeated 2**(byte % 24) times (up to LONG_LINE_BYTES)
    ("csv-long", ".csv"),
    ("lis", ".lis"),  # ANSYS MAPDL text listings (PRNSOL, NLIST, PRETAB), read by the text-table reader
    # paths and links in every index format (fuzz_paths.py): the input chooses how each file the export points to
    # is named and where it leads; the read is judged by fuzz_paths.check
    *((f"paths-{kind}", "") for kind in fuzz_paths.KINDS),
    ("msh", ".msh"),  # Gmsh MSH 2.2 / 4.1, ASCII and binary (appended: the findings' first bytes are below 34)
]

#: the longest input the csv-long target builds (bytes): a 10 MB line is what a user's broken export can hold
LONG_LINE_BYTES = 10_000_000


def _read(target: str, path: str) -> None:
    import afferent
    from afferent.profiles import read_observed
    from afferent.sampling import read_receptor_sed
    from afferent.scene import load_scene
    from afferent.stimulus import read_waveform

    if target == "receptors":
        afferent.read_receptors(path, length_unit="mm")
    elif target == "observed":
        read_observed(path, length_unit="mm")
    elif target == "waveform":
        read_waveform(path, length_unit="mm")
    elif target == "scene":
        load_scene(path)
    elif target == "sed_table":
        read_receptor_sed(path)
    elif target == "rst":
        from afferent.io import FORMATS

        if "rst" in FORMATS:  # S and EPEL: the exact SED, so that the tensors are read and checked too
            afferent.read_sed(path, length_unit="mm", stress_unit="MPa", sed_from="exact", preset="ansys")
    elif target.startswith("paths-"):
        fuzz_paths.check(path)
    elif target == "xdmf-heavy":
        afferent.read_sed(os.path.join(os.path.dirname(path), "collection.xdmf"), length_unit="mm", sed_unit="MPa")
    else:
        from afferent.io import FORMATS

        if target == "frd" and "frd" not in FORMATS:
            return
        afferent.read_sed(path, length_unit="mm", sed_unit="MPa")


def _long_lines(data: bytes) -> bytes:
    """The csv-long input: the first line of ``data[1:]`` repeated ``2 ** (data[0] % 24)`` times, then the rest."""
    if not data:
        return data
    first, sep, rest = data[1:].partition(b"\n")
    times = min(2 ** (data[0] % 24), LONG_LINE_BYTES // max(len(first), 1))
    return first * max(times, 1) + sep + rest


def prepare(data: bytes, folder: str) -> tuple[str, str]:
    """Write one fuzz input into ``folder`` with the side files its target needs; returns (target, path read)."""
    for name in os.listdir(folder):  # nothing left from the input before: each input sees only its own side files
        p = os.path.join(folder, name)
        shutil.rmtree(p) if os.path.isdir(p) and not os.path.islink(p) else os.remove(p)
    target, suffix = TARGETS[data[0] % len(TARGETS)]
    if target.startswith("paths-"):
        return target, fuzz_paths.build(target[len("paths-"):], data[1:], folder)
    body = _long_lines(data[1:]) if target == "csv-long" else data[1:]
    name = "heavy" if target == "xdmf-heavy" else "input"
    path = os.path.join(folder, name + suffix)
    with open(path, "wb") as fh:
        fh.write(body)
    if target == "pvd":  # a collection needs its steps beside it: one valid step file
        shutil.copy(HERE / "seeds" / "step.vtu", os.path.join(folder, "step.vtu"))
    if target == "xdmf-text":  # the XDMF's heavy data: a valid HDF5 file of DOLFINx's layout
        shutil.copy(HERE / "seeds" / "heavy.h5", os.path.join(folder, "heavy.h5"))
    if target == "xdmf-heavy":  # the fuzzed HDF5 read through a valid temporal collection
        shutil.copy(HERE / "seeds" / "collection.xdmf", os.path.join(folder, "collection.xdmf"))
    return target, path


def run_one(data: bytes, folder: str) -> str:
    """Read one fuzz input; raise on anything but a documented error. Returns the outcome: 'result' (read),
    'error' (a documented error) or 'short' (too short to pick a target)."""
    from afferent.exceptions import AfferentError

    if len(data) < 2:
        return "short"
    target, path = prepare(data, folder)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _read(target, path)
    except (AfferentError, FileNotFoundError):
        return "error"
    return "result"


def _write_stats(findings: str, outcomes: dict) -> None:
    """``DIR/stats.txt``: the inputs tried so far in this process, by outcome (a result, a documented error, too
    short, a finding: an undocumented exception)."""
    Path(findings).mkdir(parents=True, exist_ok=True)
    Path(findings, "stats.txt").write_text(f"inputs tried: {sum(outcomes.values())}\n"
                                           + "".join(f"{k}: {v}\n" for k, v in outcomes.items()))


def _record(findings: str, data: bytes, err: Exception) -> None:
    import traceback

    frames = [f for f in traceback.extract_tb(err.__traceback__) if "/afferent/" in f.filename]
    target = TARGETS[data[0] % len(TARGETS)][0] if data else "none"
    where = f"{Path(frames[-1].filename).stem}_{frames[-1].lineno}" if frames else target
    kind = f"{type(err).__name__}-{where}"
    out = Path(findings)
    out.mkdir(parents=True, exist_ok=True)
    if not (out / f"{kind}.bin").exists():
        (out / f"{kind}.bin").write_bytes(data)
        (out / f"{kind}.txt").write_text(f"target: {target}\n" + "".join(traceback.format_exception(err)))


def _rst_seeds() -> list[tuple[str, bytes]]:
    """Seeds of the 'rst' target: the MAPDL result file ansys-mapdl-reader ships (917 kB, the only
    real one at hand; too large for fuzz/seeds), its headers alone, its first 64 kB, and the file
    with the word that made the reader's compiled code segfault (tests/test_io_rst.py)."""
    try:
        from ansys.mapdl.reader import examples
    except ImportError:
        return []
    data = Path(examples.rstfile).read_bytes()
    crash = bytearray(data)
    crash[4 * 77476:4 * 77477] = (2**31 - 1).to_bytes(4, "little")
    return [("file.rst", data), ("head.rst", data[:4096]), ("cut.rst", data[:65536]), ("crash.rst", bytes(crash))]


def _seed_corpus(corpus: Path) -> None:
    """Prefix each test file with the byte that selects its target."""
    corpus.mkdir(parents=True, exist_ok=True)
    if any(corpus.iterdir()):
        return
    names = [t for t, _ in TARGETS]
    picks = {
        "csv": ROOT / "tests/data/csv", "txt": ROOT / "tests/data/csv", "dat": ROOT / "tests/data/csv",
        "rpt": ROOT / "tests/data/csv", "vtu": HERE / "seeds", "vtk": HERE / "seeds", "pvd": HERE / "seeds",
        "xdmf": HERE / "seeds", "scene": ROOT / "sample_sed/scenes", "receptors": HERE / "seeds",
        "observed": ROOT / "sample_sed/observed", "waveform": HERE / "seeds", "sed_table": HERE / "seeds",
        "frd": ROOT / "tests/data/calculix", "exodus": ROOT / "tests/data/exodus", "med": ROOT / "tests/data/med",
        "xdmf-text": HERE / "seeds", "xdmf-heavy": HERE / "seeds", "csv-long": HERE / "seeds",
        "lis": ROOT / "tests/data/mapdl", "msh": ROOT / "tests/data/gmsh",
    }
    suffixes = {"csv": (".csv",), "txt": (".txt",), "dat": (".dat",), "rpt": (".rpt",), "vtu": (".vtu",),
                "vtk": (".vtk",), "pvd": (".pvd",), "xdmf": (".xdmf",), "scene": (".toml",), "receptors": ("receptors.csv",),
                "observed": (".csv",), "waveform": ("waveform.csv",), "sed_table": ("sed_table.csv",), "frd": (".frd",),
                "exodus": (".e", ".ex2", ".g"), "med": (".med", ".rmed"), "xdmf-text": ("collection.xdmf",),
                "xdmf-heavy": ("heavy.h5",), "csv-long": ("long_row.csv",), "lis": (".lis",),
                "msh": (".msh",)}
    for target, folder in picks.items():
        if not folder.is_dir():
            continue
        for f in sorted(folder.rglob("*")):
            if f.is_file() and f.name.endswith(suffixes[target]) and f.stat().st_size < 200_000:
                (corpus / f"{target}-{f.name}").write_bytes(bytes([names.index(target)]) + f.read_bytes())
    for name, data in _rst_seeds():
        (corpus / f"rst-{name}").write_bytes(bytes([names.index("rst")]) + data)


def main() -> None:
    if len(sys.argv) >= 3 and sys.argv[1] == "--replay":
        import traceback

        data = Path(sys.argv[2]).read_bytes()
        print("target:", TARGETS[data[0] % len(TARGETS)] if data else None)
        with tempfile.TemporaryDirectory() as folder:
            try:
                run_one(data, folder)
                print("accepted (a result or a documented error)")
            except Exception:
                traceback.print_exc()
        return
    import atheris

    corpus = Path(sys.argv[1]) if len(sys.argv) > 1 and not sys.argv[1].startswith("-") else HERE / "corpus"
    _seed_corpus(corpus)
    with atheris.instrument_imports(include=["afferent"]):
        import afferent  # noqa: F401
        import afferent.io._ansys  # noqa: F401
        import afferent.io._assemble  # noqa: F401
        import afferent.io._csv  # noqa: F401
        import afferent.io._exodus  # noqa: F401
        import afferent.io._frd  # noqa: F401
        import afferent.io._med  # noqa: F401
        import afferent.io._meshio  # noqa: F401
        import afferent.io._xdmf  # noqa: F401
        import afferent.io._csv_lines  # noqa: F401
        import afferent.profiles  # noqa: F401
        import afferent.receptors  # noqa: F401
        import afferent.sampling  # noqa: F401
        import afferent.scene  # noqa: F401
        import afferent.stimulus  # noqa: F401
    folder = tempfile.mkdtemp(prefix="afferent-fuzz-")
    findings = os.environ.get("AFFERENT_FUZZ_FINDINGS")
    outcomes = {"result": 0, "error": 0, "short": 0, "finding": 0}

    def one_input(data: bytes) -> None:
        if findings and sum(outcomes.values()) % 1_000 == 0:
            _write_stats(findings, outcomes)
        if not findings:
            outcomes[run_one(data, folder)] += 1
            return
        try:
            outcomes[run_one(data, folder)] += 1
        except Exception as err:  # record and go on
            outcomes["finding"] += 1
            _record(findings, data, err)

    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
