"""pyserial URL handler ``ximcsim://NAME``: the real serial driver talking to an in-process
:class:`~drivers.ximc.sim.controller.Controller`, no pseudo-terminal.

The ``Stage`` driver opens ``ximcsim://a1`` like any pyserial URL; bytes it writes go to the
controller registered under ``a1`` (:func:`attach`) and the controller's answer is what it reads.
Tests of the engine use it to run in milliseconds through exactly the code that drives hardware.
pyserial finds this module because :func:`attach` adds ``drivers.ximc.sim`` to
``serial.protocol_handler_packages``.
"""

from __future__ import annotations

import serial
from serial.serialutil import PortNotOpenError, SerialBase

#: name -> controller (anything with receive(bytes) -> bytes and clear_input())
CONTROLLERS: dict[str, object] = {}


def attach(name: str, controller) -> str:
    """Make ``controller`` reachable as ``ximcsim://NAME``; return that URL."""
    if "drivers.ximc.sim" not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append("drivers.ximc.sim")
    CONTROLLERS[name] = controller
    return f"ximcsim://{name}"


def detach(name: str) -> None:
    CONTROLLERS.pop(name, None)


class Serial(SerialBase):
    """A serial port whose other end is an in-process controller (answers arrive at once)."""

    def open(self) -> None:
        name = self.portstr.split("://", 1)[-1]
        if name not in CONTROLLERS:
            raise serial.SerialException(f"no in-process controller named {name!r}")
        self._controller = CONTROLLERS[name]
        self._controller.clear_input()
        self._answer = bytearray()
        self.is_open = True

    def close(self) -> None:
        self.is_open = False

    def _reconfigure_port(self) -> None:
        """Nothing to configure in memory."""

    @property
    def in_waiting(self) -> int:
        return len(self._answer)

    def read(self, size: int = 1) -> bytes:
        if not self.is_open:
            raise PortNotOpenError()
        out = bytes(self._answer[:size])
        del self._answer[:size]
        return out

    def write(self, data) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        self._answer += self._controller.receive(bytes(data))
        return len(data)

    def reset_input_buffer(self) -> None:
        self._answer.clear()

    def reset_output_buffer(self) -> None:
        """Writes are delivered at once: nothing is buffered."""

    def flush(self) -> None:
        """Writes are delivered at once."""
