"""A run's figures drawn in a second process, while the run itself reads, samples and writes its tables.

matplotlib's import and the drawing of a run's seven figures take ~1.3 s of one core (docs/performance.md,
"The figures in a second process"); most of it cannot be made shorter in one process. On a machine with two
usable cores :func:`afferent.scene.run_scene` therefore starts one child process as a run that wants
``plots`` begins to read its export: the child imports matplotlib (Agg) and :mod:`afferent.plotting`
while the run reads and samples; at the writing stage the run hands it the small objects the
figures need and it draws them with :func:`afferent.export._figures`, the one figure-drawing
function (the same code draws them in the run's own process otherwise), into the run's temporary
output folder, each PNG written whole through :func:`afferent.plotting.save_figure`. Meanwhile the
run, its tables written, draws :data:`RUN_DRAWS` itself (it would otherwise wait idle: the bench
run's figures 0.92-1.02 s instead of 1.20-1.24 s, docs/performance.md, "On the default install"), then
waits for the child before ``run.json`` and the folder's rename.

What crosses back: the PNGs' names, the warnings raised while drawing (re-emitted in the run, so
they land in ``run.json`` as before) and an error, raised again in the run as the same exception
(an :class:`~afferent.exceptions.OutputWriteError` for a full disk, ...), judged bad input or bug
(:func:`afferent.exceptions.raised_on_purpose`) where it was raised.

Lifetime: the child dies with the run (an error, Ctrl-C or a kill of the run stops it; on Linux the
kernel kills it with its parent), ignores Ctrl-C itself (the run stops it), and exits after its one
drawing. A child that dies before it answers (the out-of-memory killer, a SIGKILL, a crash) fails
nothing: the run draws the figures itself, over what the child left half done (the same PNGs),
warns once and says so in ``run.json``'s ``figures`` (``process`` 'same', ``fallback``: why); so
does a child alive but stuck, killed first: stopped (SIGSTOP, a debugger; Linux ``/proc``) for
:data:`STOPPED_S` s, or silent for :data:`WAIT_S` s. An error the child reports ends the run as it
would in the run's own process.

When (:func:`choose`): only for an export of :data:`MIN_EXPORT_BYTES` or more (its data files: an
index's VTU steps or HDF5 files count, :func:`export_bytes`), read while the child starts, and with
an idle core; a cache hit, a smaller export or a busy machine draws in the run's own process, as
does a machine with one usable core (``os.sched_getaffinity``, else ``os.cpu_count``).
``AFFERENT_FIGURE_PROCESS=0`` draws in the run's own process always, ``1`` in a second process
whatever the export.

multiprocessing's ``spawn`` start (the same on Linux, macOS and Windows) starts the child by
importing the parent's ``__main__`` module again, unless it is a package's ``__main__`` (``python
-m afferent``) or guarded by ``if __name__ == "__main__":`` (the ``afferent`` console script); a
user's unguarded script would run again. So the command line uses the child and the Python API
only when asked (``run_scene(..., figure_process=True)``).
"""

from __future__ import annotations

import contextlib
import glob
import os
import pickle
import threading
import time
import warnings

__all__ = ["ENV", "MIN_EXPORT_BYTES", "export_bytes", "usable_cores", "runnable", "choose", "figure_drawer",
           "FigureProcess", "SameProcess", "die_with_parent"]

#: the environment variable: "0" never a second process, "1" one whatever the export (unset: :func:`choose`)
ENV = "AFFERENT_FIGURE_PROCESS"


#: The figures the run draws itself while the figure process draws the others: the run would otherwise wait idle
#: for it. Balanced by their drawing times on the bench export (benchmarks/bench_run.py): the run's part (raster,
#: rates: ~0.2 s, after matplotlib's import, ~0.35 s) against the child's (SED map, profiles, waveform, PSTH: ~0.6 s).
RUN_DRAWS = frozenset({"raster.png", "rates.png"})


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells it, else ``os.cpu_count()``)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on macOS or Windows
        return os.cpu_count() or 1


#: an export smaller than this (bytes, its data files' sizes summed: :func:`export_bytes`) is read too soon to hide
#: the second process' start-up (~0.9 s of imports): its figures are drawn in the run's own process
MIN_EXPORT_BYTES = 16_000_000


def export_bytes(files, fmt: str | None = None, side=()) -> int:
    """The bytes a run will read from its export (:func:`choose`'s measure): the sizes of its data files summed.

    An index file counts with the files it names (:func:`afferent.io.data_files`: a ``.pvd``'s
    VTU steps, a ``.pvtu``'s pieces, a ``.vtm``'s blocks, an XDMF file's HDF5 files), listed from
    the index alone: a 500 MB series named by a 2 kB ``.pvd`` counts 500 MB. An index that cannot
    be listed counts as the files named (its reader says what is wrong a moment later).

    Parameters
    ----------
    files : sequence of str
        The export's files (``[export] file``), read as ``fmt`` (a format name of
        :data:`afferent.io.FORMATS`; None: by their endings).
    side : sequence of str
        Other files read with it (``[export] coordinates``), counted as they are.
    """
    from .io import data_files

    named = [p for p in files if os.path.isfile(p)]
    try:
        listed = data_files(named, format=fmt) if named else ()
    except (OSError, ValueError, SyntaxError):  # SEDFormatError, an XML ParseError: the reader will say
        listed = named
    return sum(os.path.getsize(p) for p in dict.fromkeys([*listed, *side]) if p and os.path.isfile(p))


def choose(asked: bool, export_bytes: int | None = None) -> tuple[bool, str]:
    """Whether a run draws its figures in a second process, and why (for ``run.json``).

    Parameters
    ----------
    asked : bool
        The caller's wish (``run_scene(figure_process=...)``; the command line asks).
    export_bytes : int, optional
        The size of the export the run is about to read (its files summed, bytes); None: it reads
        none (the sampled SED came from the cache).

    Raises
    ------
    ValueError
        ``AFFERENT_FIGURE_PROCESS`` is set to something other than 0 or 1.

    Notes
    -----
    The second process pays ~0.9 s of CPU to start (Python, numpy, matplotlib, a first figure);
    only a run that reads a large export meanwhile gains: on ``afferent demo``'s eight small
    scenes a process each took 12.3 s of CPU instead of 6.9 s, and the bundled sample scenes
    0.3-0.5 s more CPU each. Nor does a busy machine: with no idle core the child takes its CPU
    from the run (measured at a load average of 4-5 on 2 cores, ``afferent run`` on the 31.5 MB
    bench export took 7.7 s with it, 6.7 s without). ``AFFERENT_FIGURE_PROCESS=1`` uses it
    whatever the export and the load (where asked and with two cores); ``0`` never.
    """
    value = os.environ.get(ENV, "").strip()
    if value not in ("", "0", "1"):
        raise ValueError(f"The environment variable {ENV} must be 0 (draw the figures in the run's own process) or "
                         f"1 (in a second process where there are 2 cores); got {value!r} instead.")
    if value == "0":
        return False, f"{ENV}=0"
    if not asked:
        return False, "not asked (run_scene(figure_process=False), the Python API's default)"
    cores = usable_cores()
    if cores < 2:
        return False, f"{cores} usable core: a second process would only wait for this one"
    if value == "1":
        return True, f"{ENV}=1; {cores} usable cores"
    if export_bytes is None:
        return False, "nothing to read (the sampled SED came from the cache) while a second process starts"
    if export_bytes < MIN_EXPORT_BYTES:
        return False, (f"the export ({export_bytes / 1e6:.3g} MB) is read before a second process could start "
                       f"(under {MIN_EXPORT_BYTES / 1e6:g} MB)")
    busy = runnable()
    if busy is not None and busy >= cores:
        return False, f"no idle core: {busy} processes ready to run on {cores} cores (/proc/loadavg)"
    return True, f"{cores} usable cores; started while the export ({export_bytes / 1e6:.3g} MB) was read"


def runnable() -> int | None:
    """Processes ready to run at this instant, this one included (``/proc/loadavg``'s fourth field; None where
    the system has no such file)."""
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            return int(f.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return None


def figure_drawer(asked: bool, export_bytes: int | None = None):
    """The drawer of a run's figures: a :class:`FigureProcess` where :func:`choose` says so, else a
    :class:`SameProcess` (also when the child cannot be started: why is in its ``record``)."""
    separate, why = choose(asked, export_bytes)
    if separate:
        try:
            return FigureProcess(why)
        except (OSError, RuntimeError) as err:  # no process to spare, or called while a child imports __main__
            return SameProcess(f"the figure process could not start ({type(err).__name__}: {err})")
    return SameProcess(why)


def die_with_parent(parent_pid: int) -> None:
    """Make this (child) process die with the process ``parent_pid`` that started it.

    On Linux the kernel sends it SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``),
    whether the parent ends normally, by SIGTERM or by SIGKILL; elsewhere a daemon thread checks the
    parent's process id every second. A parent already gone by then (``os.getppid()`` changed)
    ends it at once. The sweep's worker processes (:func:`afferent._sweep.engine.worker_init`) and
    the figure process start so.
    """
    import signal

    armed = False
    if hasattr(os, "getppid"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) == 0  # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError, TypeError):  # no libc, or no prctl in it (not Linux)
            armed = False
        if os.getppid() != parent_pid:  # the parent died before the line above took effect
            os._exit(1)
    if not armed:
        def watch():
            while os.getppid() == parent_pid:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, name="afferent-parent-watch", daemon=True).start()


class FigureProcess:
    """The child process that draws one run's figures (module docstring); a context manager that stops it.

    Started at once (``spawn``); :meth:`draw` hands it the figures' objects and returns; :meth:`result`
    waits for the PNGs' names. Leaving the ``with`` block (normally, by an error or by Ctrl-C) stops a
    child still running.

    Attributes
    ----------
    record : dict
        For ``run.json``'s ``figures``: ``process`` ('separate'), ``why``, ``start_s`` (the child's
        start-up: interpreter, imports, a first figure; s), ``seconds`` (drawing, s) and
        ``waited_s`` (how long the run waited for it after writing its tables and drawing its own part,
        :data:`RUN_DRAWS`, in ``here_s``, s).
    """

    def __init__(self, why: str = ""):
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child, os.getpid()), name="afferent-figures", daemon=True)
        self._sender, self._job = None, None
        self.record = {"process": "separate", "why": why}
        with _sigint_held_for_children():
            self._proc.start()
        child.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
        return False

    def draw(self, folder: str, want, objects: dict) -> None:
        """Hand the child the figures to draw into ``folder`` (the run's temporary output folder); returns at once.

        ``objects`` are :func:`afferent.export._figures`' keyword arguments (pickled here, sent by a thread:
        a child still importing does not hold the run up).
        """
        self._job = (os.fspath(folder), set(want), objects)
        data = pickle.dumps((*self._job, RUN_DRAWS), protocol=pickle.HIGHEST_PROTOCOL)
        self._sender = threading.Thread(target=self._send, args=(data,), name="afferent-figures-send", daemon=True)
        self._sender.start()

    def _send(self, data: bytes) -> None:
        try:
            self._conn.send_bytes(data)
        except OSError:  # the child is gone: result() says so
            pass

    def result(self) -> list[str]:
        """Wait for the child; returns the PNG names written, after re-emitting its warnings here.

        A child that ends without an answer (killed by the out-of-memory killer, a SIGKILL, a crash)
        leaves the figures to this process (:meth:`_fall_back`).

        Raises
        ------
        Exception
            The child's error, the same exception the run's own process would have raised.
        """
        t_here = time.perf_counter()
        mine = _figures_into(*self._job, only=RUN_DRAWS)  # the run's part, while the child draws the rest
        t = time.perf_counter()
        self.record["here_s"] = t - t_here
        try:
            reply = self._answer(t)
            if reply[0] == "ready":
                self.record["start_s"] = reply[1]
                reply = self._answer(t)
        except (EOFError, OSError):
            return _in_order(self._fall_back(t) + mine)
        except _Stuck as stuck:
            return _in_order(self._fall_back(t, stuck=str(stuck)) + mine)
        self.record["waited_s"] = time.perf_counter() - t
        _, names, caught, seconds, error = reply
        self.record["seconds"] = seconds
        for message, category, filename, lineno in caught:
            warnings.warn_explicit(message, category, filename, lineno)
        self._proc.join(timeout=5)
        if error is not None:
            _raise(error)
        return _in_order(list(names) + mine)

    def _answer(self, t: float):
        """The child's next message, waited for at most :data:`WAIT_S` s from ``t`` (``time.perf_counter``), and
        not while it is stopped (SIGSTOP, a debugger) for :data:`STOPPED_S` s: then :class:`_Stuck`."""
        stopped = None
        while not self._conn.poll(0.1):
            now = time.perf_counter()
            if _stopped(self._proc.pid):
                stopped = now if stopped is None else stopped
                if now - stopped >= STOPPED_S:
                    raise _Stuck(f"was stopped (state T: SIGSTOP or a debugger) for {STOPPED_S:g} s")
            else:
                stopped = None
            if now - t >= WAIT_S:
                raise _Stuck(f"had not answered after {WAIT_S:g} s")
        return self._conn.recv()

    def _fall_back(self, t: float, stuck: str | None = None) -> list[str]:
        """The child ended without an answer, or is stuck (``stuck``: how; it is killed): draw the figures here,
        over what it left half done; warn once and say so in ``record`` (``process`` 'same', ``fallback``: why;
        ``seconds``: drawing here, s)."""
        from .exceptions import AfferentWarning

        if stuck is not None:
            self._proc.kill()  # SIGKILL ends a stopped process too (SIGTERM would wait until it continues)
        self._proc.join(timeout=5)
        self.stop()  # reaped (or, still running with its end of the pipe closed, killed): no process left behind
        code = self._proc.exitcode
        how = f"was killed by {_signal_name(-code)}" if code is not None and code < 0 else f"ended (exit code {code})"
        said = f"the figure process (pid {self._proc.pid}) {stuck or how} before it had drawn the figures"
        why = " (out of memory?)" if stuck is None else "; it was killed"
        warnings.warn(f"The figures were drawn in the run's own process: {said}{why}.", AfferentWarning, stacklevel=3)
        self.record.update(process="same", fallback=f"{said}; drawn in the run's own process")
        t_draw = time.perf_counter()
        names = _figures_into(*self._job, replace=True, skip=RUN_DRAWS)
        self.record["seconds"] = time.perf_counter() - t_draw
        self.record["waited_s"] = time.perf_counter() - t
        return names

    def stop(self) -> None:
        """Stop the child if it still runs (SIGTERM, then SIGKILL after 2 s) and wait for it; idempotent."""
        if self._proc.exitcode is None and self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(timeout=2)
            if self._proc.exitcode is None:
                self._proc.kill()
                self._proc.join()
        if self._sender is not None:
            self._sender.join(timeout=2)
        self._conn.close()


#: the longest a run waits for its figure process (s, from the end of its own drawing): a child alive but hung
WAIT_S = 600.0
#: how long a run waits for a figure process that is stopped (SIGSTOP, a debugger; Linux /proc), s
STOPPED_S = 5.0


class _Stuck(Exception):
    """The figure process is alive but does not answer (stopped, or hung): the run draws the figures itself."""


def _stopped(pid: int) -> bool:
    """Process ``pid`` is stopped (state T) or stopped by a tracer (t) (Linux /proc; False where unknown)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] in (b"T", b"t")
    except (OSError, IndexError):
        return False


class SameProcess:
    """Draws a run's figures in the run's own process, after its tables (:meth:`result`); :class:`FigureProcess`'s
    interface. ``record``: ``process`` ('same'), ``why``, ``seconds`` (drawing, s)."""

    def __init__(self, why: str = ""):
        self.record = {"process": "same", "why": why}
        self._job = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def draw(self, folder: str, want, objects: dict) -> None:
        """Remember what to draw (drawn by :meth:`result`)."""
        self._job = (folder, want, objects)

    def result(self) -> list[str]:
        """Draw the figures here; returns the PNG names written."""
        t = time.perf_counter()
        names = _figures_into(*self._job)
        self.record["seconds"] = time.perf_counter() - t
        return names

    def stop(self) -> None:
        """Nothing runs elsewhere."""


def _in_order(names: list[str]) -> list[str]:
    """PNG names in the order :func:`afferent.export._figures` draws them (the run's part and the child's merged)."""
    from .export import FIGURE_ORDER

    return sorted(names, key=lambda n: FIGURE_ORDER.index(n) if n in FIGURE_ORDER else len(FIGURE_ORDER))


def _figures_into(folder: str, want, objects: dict, replace: bool = False, *, only=None, skip=frozenset()) -> list[str]:
    """:func:`afferent.export._figures` drawing into ``folder``; returns the PNG names written (in order).

    ``replace``: each figure first removes what a figure process that died drawing into ``folder`` (the run's
    temporary output folder, all written by this package) left of it: the PNG, a temporary ``.NAME.*.part``.
    """
    from .export import _figures

    names: list[str] = []

    def path(name: str) -> str:
        names.append(name)
        target = os.path.join(folder, name)
        if replace:
            for left in [target, *glob.glob(os.path.join(glob.escape(folder), f".{glob.escape(name)}.*.part"))]:
                if os.path.lexists(left):
                    os.remove(left)
        return target

    _figures(path, want, **objects, only=only, skip=skip)
    return names


def _raise(error) -> None:
    """Raise the child's error here: the same exception, its judgement (bad input or bug) kept for the command line."""
    err, on_purpose, text = error
    if err is None:  # it did not survive pickling: its type and words
        err = RuntimeError(text)
        on_purpose = False
    err._afferent_on_purpose = on_purpose
    raise err from _ChildTraceback(text)


def _signal_name(number: int) -> str:
    """'SIGKILL' for 9 (the signal's name where the system knows it, else 'signal N')."""
    import signal

    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class _ChildTraceback(Exception):
    """The traceback of an error raised in the figure process (its text), as the cause of the error raised again."""


@contextlib.contextmanager
def _sigint_held_for_children():
    """Start a child with SIGINT blocked from its first instruction (a blocked signal stays blocked across fork
    and exec; the child ignores it, then unblocks it, in :func:`_serve`). Without it a Ctrl-C while the child's
    interpreter was still starting printed "Fatal Python error: init_import_site" and a traceback beside the
    run's one line (tests/test_figure_process.py's Ctrl-C test). In the run the signal is only held for the
    few ms of the start: it is delivered when unblocked, not lost. Where there is no pthread_sigmask (Windows),
    nothing is changed."""
    import signal

    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()  # started by the child's start otherwise, which unblocks SIGINT on its way
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


# ------------------------------------------------------------------------------ in the child
def _serve(conn, parent_pid: int) -> None:
    """The child's life: prepare (imports, a first figure), draw one run's figures, answer, exit."""
    import signal

    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group: the run stops this one
    if hasattr(signal, "pthread_sigmask"):  # blocked since its start (_sigint_held_for_children): a pending one is dropped
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    t = time.perf_counter()
    try:
        _prepare()
    except Exception:  # noqa: BLE001  (raised again while drawing, where it is caught and sent to the run)
        pass
    try:
        conn.send(("ready", time.perf_counter() - t))
        job = conn.recv_bytes()
        conn.send(_draw(job))
    except (EOFError, OSError):  # the run ended (or failed) before its writing stage: nobody to draw for
        return


def _prepare() -> None:
    """What drawing needs, loaded before the objects arrive: matplotlib (Agg), afferent.plotting, the modules of
    the pickled results, and a first figure drawn to memory (fonts, the Agg renderer). Not pandas (~0.3 s):
    no figure needs it."""
    from . import export, plotting, sampling, spiking, stimulus, synthesis, transduction  # noqa: F401

    plotting._warm_up()


def _draw(job: bytes) -> tuple:
    """Draw the figures of ``job`` (the pickled folder, wanted outputs and :func:`afferent.export._figures`'
    objects) catching warnings and any error, the unpickling's included; the answer to send."""
    t = time.perf_counter()
    error, names = None, []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            folder, want, objects, skip = pickle.loads(job)
            names = _figures_into(folder, want, objects, skip=skip)
        except BaseException as err:  # noqa: BLE001  (sent to the run, raised there)
            error = _portable(err)
    sent = [(str(w.message), w.category if _pickles(w.category) else UserWarning, w.filename, w.lineno)
            for w in caught]
    return "done", names, sent, time.perf_counter() - t, error


def _portable(err: BaseException) -> tuple:
    """(the exception if it survives pickling, else None; raised on purpose?; its traceback as text)."""
    import traceback

    from .exceptions import raised_on_purpose

    text = "".join(traceback.format_exception(err))
    try:
        back = pickle.loads(pickle.dumps(err))
        same = type(back) is type(err) and str(back) == str(err)
    except Exception:  # noqa: BLE001
        same = False
    if not same:
        text = f"{type(err).__name__}: {err}\n\n(in the figure process)\n{text}"
    return (err if same else None), raised_on_purpose(err), text


def _pickles(obj) -> bool:
    try:
        pickle.dumps(obj)
        return True
    except Exception:  # noqa: BLE001
        return False
