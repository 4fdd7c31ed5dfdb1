"""The ``rig`` command. Stable contract (docs/cli.md): exit 0 ok, 2 bad input, 1 failure.

Every error is one line on stderr: what went wrong, where (file, line or field), what was
expected. No tracebacks (set ``RIG_DEBUG=1`` to see them). Each command lives in its own module
(``rig.cli.commands``); this module builds the parser and turns exceptions into exit codes.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

import yaml

import rig.simulation  # noqa: F401 - the composition root: provides the "sim" and "replay" rig kinds
from calib.errors import CalibError
from drivers.sensors.base import SensorError
from drivers.ximc.stage import TurntableError
from rig import __version__
from rig.cli.commands import COMMANDS
from rig.cli.common import EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_OK, UsageError
from rig.config.yamlload import SymlinkLoop
from rig.errors import RigInputError, SessionFormatError
from rig.execution.context import RunAborted, RunError
from rig.execution.operator import OperatorAbsent
from rig.session.lock import SessionLocked


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``rig: ...; see rig --help``), exit 2."""

    def error(self, message: str):
        raise UsageError(f"{message}; see {self.prog} --help")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="rig", description="Calibration rig controller: run procedures on a Standa turntable with "
                "a MEMS sensor, record sessions, solve calibrations.")
    p.add_argument("--version", action="version", version=f"rig {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for module in COMMANDS.values():
        module.add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        print(f"rig: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SystemExit as exc:  # --help, --version
        return EXIT_BAD_INPUT if exc.code else EXIT_OK
    if not args.command:
        print("rig: give a command; see rig --help", file=sys.stderr)
        return EXIT_BAD_INPUT
    held: list[str] = []
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning(args.command, held)
            code = COMMANDS[args.command].run(args)
        for line in held:  # shown once the command succeeded; a refusal stays its one line
            print(line, file=sys.stderr)
        return code
    except BrokenPipeError:  # `rig ... | head -1`: the reader is gone; nothing to say
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK
    except BaseException as exc:  # noqa: BLE001 - the one place errors become exit codes
        code, line = classify(exc)
        if os.environ.get("RIG_DEBUG"):
            raise
        print(f"rig {args.command}: {line}", file=sys.stderr)
        return code


def _one_line_warning(command: str, held: list[str]):
    """numpy/Python warnings as one line each (``rig CMD: warning: ...``), never a raw warning dump;
    held until the command ends (a command that fails says only its one error line)."""
    def show(message, category, filename, lineno, file=None, line=None):
        text = (str(message).strip().splitlines() or [""])[0]
        entry = f"rig {command}: warning: {text} ({category.__name__})"
        if entry not in held:
            held.append(entry)
    return show


#: exception types -> exit code, and how the one line reads (first line of the message by default)
EXIT_CODES: list[tuple[tuple[type, ...], int, object]] = [
    ((KeyboardInterrupt,), EXIT_FAILURE, lambda exc, first: "interrupted"),
    ((RigInputError, SessionFormatError, CalibError, UsageError, OperatorAbsent), EXIT_BAD_INPUT, None),
    ((FileNotFoundError,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: no such file or directory"),
    ((IsADirectoryError,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: is a directory, expected a file"),
    ((SymlinkLoop,), EXIT_BAD_INPUT, lambda exc, first: f"{exc.filename}: {SymlinkLoop.message}, expected a file"),
    ((yaml.YAMLError,), EXIT_BAD_INPUT, lambda exc, first: f"not valid YAML: {first}"),
    ((RunAborted,), EXIT_FAILURE, lambda exc, first: f"aborted: {first}"),
    ((TurntableError, SensorError, RunError, SessionLocked), EXIT_FAILURE, None),
    ((OSError,), EXIT_FAILURE,
     lambda exc, first: f"{exc.strerror or first}" + (f": {exc.filename}" if exc.filename else "")),
]


def classify(exc: BaseException) -> tuple[int, str]:
    """Map an exception to (exit code, one line)."""
    first = (str(exc).strip().splitlines() or [""])[0]
    for types, code, line in EXIT_CODES:
        if isinstance(exc, types):
            return code, line(exc, first) if line else first
    return EXIT_FAILURE, f"internal error ({type(exc).__name__}: {first}); rerun with RIG_DEBUG=1 and report it"


if __name__ == "__main__":
    raise SystemExit(main())
