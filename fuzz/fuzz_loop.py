"""fuzz_readers.py's targets driven by a plain random-mutation loop, where atheris is not installed.

Half the inputs go to the path targets (``paths-*``, :mod:`fuzz_paths`: random bytes choose how each
file an export points to is named and where it leads), half are seeds of the corpus
(fuzz_readers.py builds it from the test files) with 1 to 8 random mutations: bits flipped, bytes
set, inserted, deleted or repeated, a splice of another seed, tokens that name files (``../``,
``/proc/self/environ``, ``/dev/zero``, ``file=``) or odd numbers. No coverage guidance.

A supervisor runs one worker process and watches it: a worker that dies (a native crash, the
kernel's OOM killer) or spends more than ``--hang`` seconds of CPU on one input (:data:`WALL_FACTOR` x that in
wall time) is recorded as a crash
or a hang with the input (``crash-<hash>.bin``, ``hang-<hash>.bin`` and a ``.txt``) and replaced.
Every other finding is recorded as fuzz_readers.py does (``<kind>.bin``/``.txt``, the first input
of each kind). At the end ``DIR/summary.json`` holds the counts: inputs tried, results, clean
(documented) errors, internal errors (undocumented exceptions), crashes, hangs, silent results,
lost files, files read outside the export's folder, files read that are not regular files.

Run::

    nice -n 10 .venv/bin/python fuzz/fuzz_loop.py --seconds 1800 --findings /tmp/findings

Replay a finding: ``fuzz_readers.py --replay DIR/<kind>.bin``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

#: tokens inserted by the mutator: names that lead outside, and numbers that break sizes
TOKENS = (b"../", b"../../", b"/proc/self/environ", b"/dev/zero", b"/etc/passwd", b"file=\"", b"Source=\"", b".h5:/",
          b"Format=\"Binary\"", b"-1", b"0", b"1e308", b"nan", b"\x00", b"99999999999", b"\xff\xff\xff\x7f", b"%s%n")

#: outcome -> the summary's name for it
FINDING_NAMES = {"SilentResult": "silent_results", "LostFile": "lost_files", "ReadOutside": "read_outside",
                 "NotRegularRead": "not_regular_read"}


def mutate(data: bytes, rng: random.Random, corpus: list[bytes]) -> bytes:
    """``data`` with 1 to 8 random mutations, its first byte (the target) kept."""
    head, body = data[:1], bytearray(data[1:])
    for _ in range(rng.randint(1, 8)):
        op = rng.randrange(7)
        k = rng.randrange(len(body) + 1)
        if op == 0 and body:
            body[min(k, len(body) - 1)] ^= 1 << rng.randrange(8)
        elif op == 1 and body:
            body[min(k, len(body) - 1)] = rng.randrange(256)
        elif op == 2:
            body[k:k] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        elif op == 3 and body:
            del body[k:k + rng.randint(1, 64)]
        elif op == 4 and body:
            body[k:k] = body[k:k + rng.randint(1, 256)] * rng.randint(1, 8)
        elif op == 5:
            other = rng.choice(corpus)[1:]
            if other:
                j = rng.randrange(len(other))
                body[k:] = other[j:j + rng.randint(1, 4096)]
        else:
            body[k:k] = rng.choice(TOKENS)
    return head + bytes(body[:1_000_000])


def _corpus(folder: Path) -> tuple[list[bytes], list[int]]:
    """The seed corpus (the byte targets' seeds) and the path targets' indexes."""
    import fuzz_readers

    fuzz_readers._seed_corpus(folder)
    paths = [k for k, (t, _) in enumerate(fuzz_readers.TARGETS) if t.startswith("paths-")]
    seeds = [f.read_bytes() for f in sorted(folder.iterdir()) if f.is_file()]
    return [s for s in seeds if len(s) > 1 and s[0] not in paths], paths


def worker(findings: Path, corpus_dir: Path, deadline: float, seed: int) -> None:
    """Read inputs until ``deadline``; each input is written to ``findings/current.bin`` first (for the
    supervisor), the outcomes counted in ``findings/stats-<pid>.json``."""
    import warnings

    import fuzz_readers
    import fuzz_paths

    warnings.simplefilter("ignore")
    rng = random.Random(seed)
    corpus, paths = _corpus(corpus_dir)
    folder = tempfile.mkdtemp(prefix=f"work-{os.getpid()}-", dir=findings)
    counts: dict[str, int] = {}
    stats = findings / f"stats-{os.getpid()}.json"
    current = findings / "current.bin"
    n = 0
    while time.time() < deadline:
        if rng.random() < 0.5 or not corpus:
            data = bytes([rng.choice(paths)]) + bytes(rng.randrange(256) for _ in range(rng.randint(8, 64)))
        else:
            data = mutate(rng.choice(corpus), rng, corpus)
        current.write_bytes(data)
        try:
            outcome = fuzz_readers.run_one(data, folder)
        except fuzz_paths.PathFinding as err:
            outcome = FINDING_NAMES[type(err).__name__]
            fuzz_readers._record(str(findings), data, err)
        except Exception as err:  # noqa: BLE001 - an undocumented exception: a finding
            outcome = "internal_errors"
            fuzz_readers._record(str(findings), data, err)
        counts[outcome] = counts.get(outcome, 0) + 1
        n += 1
        if n % 100 == 0:
            stats.write_text(json.dumps(counts))
    stats.write_text(json.dumps(counts))
    shutil.rmtree(folder, ignore_errors=True)


def _keep(findings: Path, what: str, detail: str) -> None:
    """The input being read when the worker crashed or hung, as ``<what>-<hash>.bin`` with a ``.txt``."""
    data = (findings / "current.bin").read_bytes() if (findings / "current.bin").exists() else b""
    import fuzz_readers

    name = f"{what}-{hashlib.sha256(data).hexdigest()[:12]}"
    (findings / f"{name}.bin").write_bytes(data)
    target = fuzz_readers.TARGETS[data[0] % len(fuzz_readers.TARGETS)] if data else None
    (findings / f"{name}.txt").write_text(f"target: {target}\n{detail}\n")


#: an input is a hang when its worker (with the reader processes it started) spends more than ``--hang`` seconds of
#: CPU on it, or waits this many times as long (a blocked read uses no CPU). CPU, not wall time: on a loaded machine
#: (session 9: load average 7-8 on 2 cores) ANSYS's reader alone took > 30 s of wall time to import, 5 s of CPU.
WALL_FACTOR = 4


def _group_cpu_seconds(pgid: int) -> float:
    """CPU seconds (user + system, and of waited-for children) of every process in the group ``pgid`` (Linux
    ``/proc``; elsewhere 0, and the wall-time bound alone decides)."""
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    total = 0
    try:
        pids = [d for d in os.listdir("/proc") if d.isdigit()]
    except OSError:
        return 0.0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[2]) == pgid:  # after the name: state, ppid, pgrp, ..., utime stime cutime cstime at 11-14
            total += sum(int(x) for x in fields[11:15])
    return total / tick


def supervise(seconds: float, findings: Path, corpus: Path, hang: float, seed: int) -> dict:
    """Run workers for ``seconds``; returns the summary (also written to ``findings/summary.json``)."""
    findings.mkdir(parents=True, exist_ok=True)
    deadline = time.time() + seconds
    extra = {"crashes": 0, "hangs": 0}
    k = 0
    while time.time() < deadline - 1:
        (findings / "current.bin").unlink(missing_ok=True)
        proc = subprocess.Popen([sys.executable, __file__, "--worker", str(findings), str(corpus), str(deadline),
                                 str(seed + k)], start_new_session=True)  # its own group: the readers' children too
        k += 1
        started, cpu0 = None, 0.0
        while proc.poll() is None:
            time.sleep(1)
            current = findings / "current.bin"
            if not current.exists():
                continue
            mtime = current.stat().st_mtime
            if mtime != started:  # a new input: its CPU time counts from here
                started, cpu0 = mtime, _group_cpu_seconds(proc.pid)
            cpu, wall = _group_cpu_seconds(proc.pid) - cpu0, time.time() - mtime
            if cpu > hang or wall > WALL_FACTOR * hang:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                extra["hangs"] += 1
                _keep(findings, "hang", f"still reading after {cpu:.0f} s of CPU ({wall:.0f} s wall): killed")
                break
        else:
            if proc.returncode != 0:
                extra["crashes"] += 1
                _keep(findings, "crash", f"the worker ended with code {proc.returncode}")
    return summarize(findings, extra)


def summarize(findings: Path, extra: dict) -> dict:
    counts: dict[str, int] = dict(extra)
    for f in findings.glob("stats-*.json"):
        for key, v in json.loads(f.read_text()).items():
            counts[key] = counts.get(key, 0) + v
    summary = {
        "inputs_tried": sum(counts.values()),
        "results": counts.get("result", 0),
        "clean_errors": counts.get("error", 0),
        "too_short": counts.get("short", 0),
        "internal_errors": counts.get("internal_errors", 0),
        "crashes": counts.get("crashes", 0),
        "hangs": counts.get("hangs", 0),
        **{name: counts.get(name, 0) for name in FINDING_NAMES.values()},
        "kinds": sorted(p.stem for p in findings.glob("*.bin") if p.name != "current.bin"),
    }
    (findings / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary


def main() -> None:
    if len(sys.argv) >= 2 and sys.argv[1] == "--worker":
        findings, corpus, deadline, seed = sys.argv[2:6]
        worker(Path(findings), Path(corpus), float(deadline), int(seed))
        return
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seconds", type=float, default=1800)
    p.add_argument("--findings", type=Path, required=True)
    p.add_argument("--corpus", type=Path, default=HERE / "corpus")
    p.add_argument("--hang", type=float, default=30, help="seconds on one input that make it a hang")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    print(json.dumps(supervise(args.seconds, args.findings, args.corpus, args.hang, args.seed), indent=1))


if __name__ == "__main__":
    main()
