"""Argument parsing and error handling for the ``afferent`` command (meshio ``_cli`` pattern)."""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys
import traceback
import warnings

import importlib

from .. import __version__
from ..exceptions import AfferentError, raised_on_purpose
from ._options import add_common_options

#: subcommand -> module with add_args(parser) and run(args) -> int (a module, or its name: imported when
#: needed, so that ``afferent run`` does not pay for the imports of ``afferent calibrate``); help comes
#: from the module's docstring.
COMMANDS = {"info": "afferent.cli._info", "sample": "afferent.cli._sample", "run": "afferent.cli._run",
            "calibrate": "afferent.cli._calibrate", "demo": "afferent.cli._demo",
            "report": "afferent.cli._report", "sweep": "afferent.cli._sweep", "hotspots": "afferent.cli._hotspots",
            "cycles": "afferent.cli._cycles"}


def _module(name: str):
    module = COMMANDS[name]
    return importlib.import_module(module) if isinstance(module, str) else module


def _chosen(argv: list[str]) -> str | None:
    """The subcommand named on the command line, or None (also when help or the version is asked first)."""
    for word in argv:
        word = str(word)
        if word in COMMANDS:
            return word
        if word in ("-h", "--help", "--version") or not word.startswith("-"):
            return None
    return None


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own usage errors: one line, exit code 2
        raise _UsageError(message, self.prog)


class _UsageError(Exception):
    """argparse's usage error ``message`` raised by the parser named ``prog`` ('afferent', 'afferent run')."""

    def __init__(self, message: str, prog: str):
        super().__init__(message)
        self.prog = prog

    def line(self, command: str | None) -> str:
        """The text after ``afferent: error: ``: the message under the subcommand's name (``afferent run:
        ...``; the top parser's 'unrecognized arguments' too, when a subcommand was chosen), the
        program's name never twice."""
        prog = self.prog if self.prog != "afferent" or command is None else f"afferent {command}"
        return str(self) if prog == "afferent" else f"{prog}: {self}"


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``afferent`` parser; with ``argv`` naming a subcommand, only that one's module is imported."""
    parser = _Parser(prog="afferent", description="From FE strain-energy density of skin to tactile afferent signals.")
    parser.add_argument("--version", action="version", version=f"afferent {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    chosen = None if argv is None else _chosen(argv)
    for name in COMMANDS:
        if chosen is not None and name != chosen:
            sub.add_parser(name)  # a name among the choices; its options are never parsed in this call
            continue
        module = _module(name)
        doc = module.__doc__ or ""
        p = sub.add_parser(name, help=doc.strip().splitlines()[0], description=doc,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_args(p)
        add_common_options(p)
        p.set_defaults(func=module.run, _reads=tuple(a for a in p._actions if hasattr(a, "afferent_reads")))
    return parser


def _choices_of(parser: argparse.ArgumentParser, argv: list[str] | None) -> dict[str, tuple]:
    """The accepted values of the subcommand's options that have choices: ``{'on_outside': ('raise', ...)}``."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    words = sys.argv[1:] if argv is None else argv
    command = next((w for w in words if sub is not None and w in sub.choices), None)
    if command is None:
        return {}
    return {a.dest: tuple(map(str, a.choices)) for a in sub.choices[command]._actions if a.choices and a.option_strings}


def _flags_of(parser: argparse.ArgumentParser, argv: list[str] | None) -> dict[str, str]:
    """The subcommand's options by keyword: ``{'length_unit': '--length-unit', ...}``."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    words = sys.argv[1:] if argv is None else argv
    command = next((w for w in words if sub is not None and w in sub.choices), None)
    if command is None:
        return {}
    flags = {}
    for action in sub.choices[command]._actions:
        long = [o for o in action.option_strings if o.startswith("--")]
        if not long:
            continue
        flags[action.dest] = long[0]
        if isinstance(action, argparse._StoreTrueAction):
            flags[f"{action.dest}=True"] = long[0]
        if action.dest.endswith("_s"):  # --gain-s, --duration-s: the library's gain=, duration= are in s too
            flags.setdefault(action.dest[:-2], long[0])
    return flags


def speak_cli(message: str, flags: dict[str, str], choices: dict[str, tuple] | None = None) -> str:
    """Rewrite the library's Python keywords as the command's flags.

    ``pass length_unit=`` -> ``pass --length-unit``; ``on_outside='nan'`` -> ``--on-outside nan``;
    ``'sed_unit' is ...`` -> ``--sed-unit is ...``. Only the subcommand's own options are
    rewritten (longest keywords first), so a keyword with no flag stays as it is. A sentence
    offering a value the command's flag does not accept (``choices``: keyword -> accepted
    values, e.g. ``on_outside='drop'`` where ``--on-outside`` takes raise, warn, nan) is left
    out: the command never suggests a remedy it would refuse.
    """
    if choices:
        message = _without_refused_remedies(message, flags, choices)
    for dest in sorted(flags, key=len, reverse=True):
        flag = flags[dest]
        key = re.escape(dest)
        if dest.endswith("=True"):
            message = re.sub(rf"(?<![\w\-.']){key}", flag, message)
            continue
        message = re.sub(rf"(?<![\w\-.']){key}=(?:'([^']*)'|\"([^\"]*)\"|([A-Za-z0-9_+^/\-]+(?:\.[A-Za-z0-9_+^/\-]+)*))",
                         lambda m: f"{flag} {next(g for g in m.groups() if g is not None)}", message)
        message = re.sub(rf"(?<![\w\-.']){key}=(?![\w'\"])(\S?)", lambda m: flag + (" " if m.group(1) and m.group(1) not in ".,;:)" else "") + m.group(1), message)
        message = re.sub(rf"'{key}'", flag, message)
    return message


_REMEDY = re.compile(r"(?<![\w\-.'])(\w+)=(?:'([^']*)'|\"([^\"]*)\"|([A-Za-z0-9_+^/\-]+))")


def _without_refused_remedies(message: str, flags: dict, choices: dict) -> str:
    """``message`` without the sentences that offer a value a flag of the command refuses."""
    def refused(sentence: str) -> bool:
        for m in _REMEDY.finditer(sentence):
            dest, value = m.group(1), next(g for g in m.groups()[1:] if g is not None)
            if dest in flags and choices.get(dest) and value not in choices[dest]:
                return True
        return False

    sentences = re.split(r"(?<=[.;])\s+", message)
    kept = [s for s in sentences if not refused(s)]
    return " ".join(kept) if kept else message


#: the running command's options (keyword -> flag, keyword -> accepted values), for warnings in its words
_WORDS: dict = {"flags": {}, "choices": {}}


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings from the library as one line each, like errors (no source path, no code line), in the
    command's own words (:func:`speak_cli`)."""
    if _WORDS.get("quiet"):  # -q: nothing on the terminal but errors (a run's warnings stay in its run.json)
        return
    text = speak_cli(" ".join(str(message).split()), _WORDS["flags"], _WORDS["choices"])
    print(f"afferent: warning: {text}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 ok, 2 bad input, 1 unexpected failure)."""
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    parser = build_parser(sys.argv[1:] if argv is None else argv)
    flags = _flags_of(parser, argv)
    choices = _choices_of(parser, argv)
    _WORDS.update(flags=flags, choices=choices, quiet=False)
    try:
        args = parser.parse_args(argv)
        _WORDS["quiet"] = bool(getattr(args, "quiet", False))
        args.argv = [str(a) for a in (sys.argv[1:] if argv is None else argv)]  # for the run record
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        with _ended_by_signals():
            return _guarded(args)
    except _UsageError as err:
        print(f"afferent: error: {err.line(_chosen(sys.argv[1:] if argv is None else argv))}", file=sys.stderr)
        return 2
    except (AfferentError, FileNotFoundError, FileExistsError, ValueError, TypeError, PermissionError,
            IsADirectoryError, NotADirectoryError) as err:
        if not raised_on_purpose(err):  # numpy's "cannot reshape ..." on a case nobody checked: a bug
            return _internal_error(err)
        msg = " ".join(str(err).split())  # one line
        if not getattr(err, "key", None) and type(err).__name__ not in ("SceneError", "SceneTypeError"):
            msg = speak_cli(msg, flags, choices)  # in the command's own words; a scene's errors name its TOML keys
        print(f"afferent: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:
        _interrupt_handled()
        from .._output import Terminated

        if isinstance(err, Terminated):  # SIGTERM, SIGHUP: the temporary outputs removed as for Ctrl-C
            print(f"afferent: terminated by {err.name}", file=sys.stderr)
            return 128 + err.signum
        print("afferent: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return _reader_gone()
    except Exception as err:  # a bug: say so, keep the traceback for the report
        if _environment_message(err):  # unless it is the environment (a full or read-only disk, ...): exit 2
            print(f"afferent: error: {_environment_message(err)}", file=sys.stderr)
            return 2
        return _internal_error(err)


def _guarded(args: argparse.Namespace) -> int:
    """Run the command with every path it reads (``_options.reads``) handed to the output guard: its ``-o`` is
    checked against them now, before any work, and every writer checks its output against them too
    (``afferent._output.command_inputs``), whatever the command. Then every file its options name is
    checked (:func:`afferent._inputs.check_files`) and so are the combinations of its options (``args._checks``,
    set by the option groups that add them). A new command inherits this."""
    from .._inputs import check_files
    from .._output import check_place, command_inputs
    from ._options import input_paths, named_files

    inputs = input_paths(args)
    with command_inputs(inputs):
        if getattr(args, "output", None) is not None:
            check_place(args.output, (), getattr(args, "_output_what", "Output"))
        check_files(named_files(args))  # every file an option names, before any export is read (afferent._inputs)
        for check in getattr(args, "_checks", ()):  # the options' combinations (add_receptor_options, ...)
            check(args)
        return args.func(args)


@contextlib.contextmanager
def _ended_by_signals():
    """While the command runs (in the main thread): SIGINT, SIGTERM and SIGHUP go to ``afferent._output.on_signal``
    (KeyboardInterrupt, or :class:`~afferent._output.Terminated`, raised at once or as soon as a writer has made,
    renamed or removed a temporary); the previous handlers are put back after. A signal whose exception some code
    swallowed still ends the command. (A sweep's local workers add their own SIGTERM handler while they run.)"""
    import signal
    import threading

    from .._output import on_signal, signals_seen

    wanted = [getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)]
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signals_seen(reset=True)
    previous = {sig: signal.signal(sig, on_signal) for sig in wanted}
    try:
        yield
        if signals_seen():  # received, raised, and swallowed somewhere (a weakref callback): the command still ends
            on_signal(signals_seen()[0])
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        signals_seen(reset=True)


def _interrupt_handled() -> None:
    """Tell CPython that the KeyboardInterrupt was handled, so the command exits with 130.

    CPython 3.11 notes a KeyboardInterrupt raised inside code it runs from a string (``exec`` of a
    dataclass's generated ``__init__`` while a module is imported, say) as unhandled even when
    Python code catches it, and at exit kills itself with SIGINT instead of returning the exit
    code (seen in tests/test_figure_process.py's Ctrl-C test: 1 run in 25 on a loaded machine,
    exit -2). The flag is reset where the interpreter exports it; elsewhere nothing is done.
    """
    try:
        import ctypes

        ctypes.c_int.in_dll(ctypes.pythonapi, "_Py_UnhandledKeyboardInterrupt").value = 0
    except (ImportError, AttributeError, ValueError, OSError):
        pass


def _environment_message(err: BaseException) -> str | None:
    """One line for an OSError of the environment (afferent._output.describe_os_error), else None."""
    from .._output import describe_os_error

    return describe_os_error(err) if isinstance(err, OSError) else None


def _reader_gone() -> int:
    """The reader of stdout went away (``afferent info ... | head``): stop quietly, as ``cat`` would.

    What is left in Python's stdout buffer is sent to /dev/null so that the interpreter's final
    flush does not fail again; the exit status is 141 (128 + SIGPIPE), a shell's status for a
    writer stopped by a closed pipe. Not an error of the input, not a bug: no message.
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout without a file descriptor (captured in tests)
        pass
    return 141


def _internal_error(err: BaseException) -> int:
    print(f"afferent: internal error (please report): {type(err).__name__}: {err}", file=sys.stderr)
    if os.environ.get("AFFERENT_DEBUG"):
        traceback.print_exc()
    return 1


