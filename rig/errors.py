"""Errors for bad input: one line naming the file, line, key and what was expected."""

from __future__ import annotations


class RigInputError(ValueError):
    """A procedure, rig file or command-line input does not validate.

    ``str()`` is one line: ``path:line: key: message``.
    """

    def __init__(self, path, line, key, message) -> None:
        self.path, self.line, self.key, self.message = path, line, key, message
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.path:
            where = f"{self.path}:{self.line}: " if self.line else f"{self.path}: "
        key = f"{self.key}: " if self.key else ""
        return f"{where}{key}{self.message}"


class SessionFormatError(RigInputError):
    """A session directory does not follow rig-session/1."""


class RunError(Exception):
    """A run cannot continue; the message is one line for the technician."""


class RunAborted(Exception):
    """The operator interrupted the run (Ctrl-C or 'abort' at a prompt)."""
