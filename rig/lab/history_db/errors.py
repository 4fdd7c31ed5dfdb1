"""The history's errors: every one prints as one line and carries the exit code docs/cli.md gives it."""

from __future__ import annotations

from rig.errors import RigInputError


class HistoryError(Exception):
    """A history database problem; ``str()`` is one line; ``exit_code`` as in docs/cli.md."""

    exit_code = 1


class HistoryCorrupt(HistoryError, RigInputError):
    """The file is not a history database, is damaged, or is newer than this software (exit 2)."""

    exit_code = 2

    def __init__(self, path, message) -> None:
        RigInputError.__init__(self, str(path), None, None, message)


class HistoryLocked(HistoryError, OSError):
    """Another process held the database longer than the busy timeout, or it cannot be opened (exit 1)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "history database locked"


class HistoryUnreachable(HistoryLocked):
    """The history server did not answer (down, no network, refused the login): exit 1; a record goes to the
    outbox instead (:mod:`rig.lab.history_db.outbox`)."""


def first_line(exc: BaseException) -> str:
    """An exception's message, its first line only (a driver's message can run over several)."""
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]
