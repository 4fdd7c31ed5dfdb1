"""The ``rig`` command. Stable contract (docs/cli.md): exit 0 ok, 2 bad input, 1 failure.

Every error is one line on stderr: what went wrong, where (file, line or field), what was
expected. No tracebacks (set ``RIG_DEBUG=1`` to see them). Each command lives in its own module
(``rig.cli.commands``); this module builds the parser and turns exceptions into exit codes (by the
table in :mod:`rig.cli.failures`). It imports only the command given: ``rig --help`` and ``rig
--version`` load no command, no numpy (docs/architecture.md, "Deferred imports"). Once a command is
given, :func:`main` calls the composition root (:func:`rig.composition.wire`) before running it.

Signals (docs/cli.md): run as the program (``rig ...``, ``python -m rig.cli ...``), a SIGINT, SIGTERM or
SIGHUP during start-up (imports, parsing, wiring: nothing has been done yet) exits at once with one line,
``rig COMMAND: interrupted``, exit 1, never a traceback; the handlers are installed when this module is
imported, before the command's imports. Once the command runs, Ctrl-C is a KeyboardInterrupt (exit 1,
``interrupted``); ``rig run`` stops the motors on every one of them (:func:`rig.cli.commands.run.stop_on_signals`).
Python itself cannot be guarded before it has imported ``site`` and this module.
"""

from __future__ import annotations

import os
import signal
import sys

from rig.cli.terminal import say, say_raw, silence

#: the signals that stop ``rig`` (Ctrl-C, kill, a closed terminal or a dropped ssh connection)
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: each stop signal's handler before the start-up handlers replaced it (SIG_IGN stays ignored: a
#: background job's SIGINT, ``nohup``'s SIGHUP)
_inherited: dict[int, object] = {}


def exit_on_stop_signals() -> None:
    """Start-up: a stop signal exits at once, ``rig COMMAND: interrupted``, exit 1 (nothing has been done
    yet; a KeyboardInterrupt in the middle of an import would print a traceback instead)."""
    for sig in STOP_SIGNALS:
        current = signal.getsignal(sig)
        if current is _exit_interrupted or current == signal.SIG_IGN:
            continue
        _inherited[sig] = current
        signal.signal(sig, _exit_interrupted)


def _exit_interrupted(signum, frame):
    """Runs before this module's imports are done: it needs nothing but os and sys."""
    try:
        words = [a for a in sys.argv[1:] if not a.startswith("-")]  # command_given(), maybe not defined yet
        say_raw(f"rig {words[0]}: interrupted" if words and words[0].isidentifier() else "rig: interrupted")
    finally:
        os._exit(1)  # EXIT_FAILURE (rig.cli.codes), which may not be imported yet


def launched_as_rig() -> bool:
    """This interpreter was started as the ``rig`` program (the console script, ``python -m rig.cli``),
    not by a program that imports the CLI (tests call ``main(argv)``)."""
    if os.path.basename(sys.argv[0]) == "rig":
        return True
    names = ("rig.cli", "rig.cli.main")
    options = iter(getattr(sys, "orig_argv", [])[1:])  # the interpreter's options, up to what it runs
    for option in options:
        if option in ("-X", "-W"):
            next(options, None)
        elif option == "-m":
            return next(options, None) in names
        elif option.startswith("-m"):
            return option[2:] in names
        elif not option.startswith("-") or option.startswith("-c") or option == "-":
            return False
    return False


#: the BLAS libraries numpy may load, each told to use one thread unless the user's environment says otherwise
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def one_blas_thread() -> None:
    """The program's matrices are small (a calibration's tens of columns), where BLAS threads only cost: on a busy
    2-core machine OpenBLAS's second thread made a 6x6 triangular solve 16 ms instead of 0.02 ms; and ``rig
    archive`` runs one process per core. Set before numpy loads; a variable the user set is kept."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


if __name__ != "__main__" and launched_as_rig():  # first, before any import that takes time
    exit_on_stop_signals()
    one_blas_thread()

import argparse  # noqa: E402 - after the start-up handlers
import warnings  # noqa: E402

from rig import __version__  # noqa: E402
from rig.cli.codes import EXIT_BAD_INPUT, EXIT_OK, UsageError  # noqa: E402
from rig.cli.commands import COMMANDS, load  # noqa: E402


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``rig: ...; see rig --help``), exit 2."""

    def error(self, message: str):
        raise UsageError(f"{message}; see {self.prog} --help")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser: every command as ``rig --help`` lists it, the arguments of ``command`` only (its
    module is imported to add them; the others' are not: docs/architecture.md, "Deferred imports")."""
    p = _Parser(prog="rig", description="Calibration rig controller: run procedures on a Standa turntable with "
                "a MEMS sensor, record sessions, solve calibrations.")
    p.add_argument("--version", action="version", version=f"rig {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, help_line in COMMANDS.items():
        if name == command:
            load(name).add_parser(sub)
        elif command not in COMMANDS:  # rig --help, a mistyped command: every command is listed
            sub.add_parser(name, help=help_line)
    return p


def command_given(argv: list[str]) -> str | None:
    """The command word of ``argv``: its first argument that is not an option (``rig`` has no option
    that takes a value before the command); None when ``--help`` comes first (``rig --help solve``
    lists every command)."""
    for a in argv:
        if a in ("-h", "--help"):
            return None
        if not a.startswith("-"):
            return a
    return None


def main(argv: list[str] | None = None) -> int:
    """``rig ARGV`` (default: the program's own arguments); returns the exit code. Called without
    ``argv`` it is the program: signals during start-up exit at once (see the module's docstring);
    with ``argv`` (tests, scripts) it leaves the caller's signal handlers alone."""
    program = argv is None
    if program:
        exit_on_stop_signals()
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(command_given(argv))
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        say(f"rig: {exc}")
        return EXIT_BAD_INPUT
    except SystemExit as exc:  # --help, --version
        return EXIT_BAD_INPUT if exc.code else EXIT_OK
    if not args.command:
        say("rig: give a command; see rig --help")
        return EXIT_BAD_INPUT
    from rig.cli import failures  # deferred: the error types of every layer (calib, pandas), not for --help
    from rig.composition import wire  # deferred: the composition root, once a command runs, not for --help
    wire()  # the simulator's providers (rig.composition): every command reads rig files alike
    command = load(args.command)
    held: list[str] = []
    try:
        if program:
            interrupt_as_exception()
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning(args.command, held)
            code = command.run(args)
        for line in held:  # shown once the command succeeded; a refusal stays its one line
            say(line)
        return code
    except BrokenPipeError:  # `rig ... | head -1`: the reader is gone; nothing to say
        silence(sys.stdout)
        return EXIT_OK
    except BaseException as exc:
        if program and isinstance(exc, KeyboardInterrupt):
            ignore_stop_signals()  # exiting on the signal's behalf: another one must not cut that short
        code, line = failures.classify(exc)
        if os.environ.get("RIG_DEBUG"):
            raise
        say(f"rig {args.command}: {line}")
        return code


def interrupt_as_exception() -> None:
    """The command runs: the handlers it inherited are back, except that Ctrl-C raises KeyboardInterrupt
    once and is ignored after that (the command's cleanup is not cut short)."""
    for sig, handler in _inherited.items():
        if signal.getsignal(sig) is _exit_interrupted:
            inherited = signal.SIG_DFL if handler is None else handler
            signal.signal(sig, _interrupt_once if sig == signal.SIGINT else inherited)


def ignore_stop_signals() -> None:
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


def _interrupt_once(signum, frame):
    signal.signal(signum, signal.SIG_IGN)
    raise KeyboardInterrupt


def _one_line_warning(command: str, held: list[str]):
    """numpy/Python warnings as one line each (``rig CMD: warning: ...``), never a raw warning dump;
    held until the command ends (a command that fails says only its one error line)."""
    def show(message, category, filename, lineno, file=None, line=None):
        text = (str(message).strip().splitlines() or [""])[0]
        entry = f"rig {command}: warning: {text} ({category.__name__})"
        if entry not in held:
            held.append(entry)
    return show

