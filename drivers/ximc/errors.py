"""The one exception of the turntable drivers."""

from __future__ import annotations


class TurntableError(Exception):
    """A turntable command failed; one line naming axis, port, command and detail."""

    def __init__(self, port: str, command: str, detail: str, name: str = "") -> None:
        self.port, self.command, self.detail, self.name = port, command, detail, name
        axis = f"{name} " if name else ""
        super().__init__(f"{axis}{port}: {command}: {detail}")
