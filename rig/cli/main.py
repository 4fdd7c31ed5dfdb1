"""The ``rig`` command. Stable contract (docs/cli.md): exit 0 ok, 2 bad input, 1 failure.

Every error is one line on stderr: what went wrong, where (file, line or field), what was
expected. No tracebacks (set ``RIG_DEBUG=1`` to see them). Each command lives in its own module
(``rig.cli.commands``); this module builds the parser and turns exceptions into exit codes (by the
table in :mod:`rig.cli.failures`). It imports only the command given: ``rig --help`` and ``rig
--version`` load no command, no numpy (docs/architecture.md, "Deferred imports"). Once a command is
given, :func:`main` calls the composition root (:func:`rig.composition.wire`) before running it.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

from rig import __version__
from rig.cli.codes import EXIT_BAD_INPUT, EXIT_OK, UsageError
from rig.cli.commands import COMMANDS, load


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
        else:
            sub.add_parser(name, help=help_line)
    return p


def command_given(argv: list[str]) -> str | None:
    """The command word of ``argv``: its first argument that is not an option (``rig`` has no option
    that takes a value before the command)."""
    return next((a for a in argv if not a.startswith("-")), None)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(command_given(argv))
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
    from rig.cli import failures  # deferred: the error types of every layer (calib, pandas), not for --help
    from rig.composition import wire  # deferred: the composition root, once a command runs, not for --help
    wire()  # the simulator's providers (rig.composition): every command reads rig files alike
    held: list[str] = []
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning(args.command, held)
            code = load(args.command).run(args)
        for line in held:  # shown once the command succeeded; a refusal stays its one line
            print(line, file=sys.stderr)
        return code
    except BrokenPipeError:  # `rig ... | head -1`: the reader is gone; nothing to say
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK
    except BaseException as exc:  # noqa: BLE001 - the one place errors become exit codes
        code, line = failures.classify(exc)
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


if __name__ == "__main__":
    raise SystemExit(main())
