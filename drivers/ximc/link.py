"""``XimcLink``: request/answer transactions with one 8SMC4/8SMC5 controller over pyserial.

Every transaction is retried a bounded number of times with the protocol's zero-byte
resynchronisation (and a reopen of the port if it vanished, e.g. a USB replug); after that a
:class:`TurntableError` names the axis, port, command and what came back. A value is never
returned unless its frame decoded with a good CRC. :class:`drivers.ximc.stage.Stage` adds the
command set and degree units on top.
"""

from __future__ import annotations

import time
from typing import Callable

import serial

from drivers.ximc import protocol as P
from drivers.ximc.errors import TurntableError

RECOVERABLE = (P.CrcError, P.EchoError)


class XimcLink:
    """Transactions with one controller on a serial port (a device path or a pyserial URL).

    Parameters
    ----------
    port : str
    timeout_s : float
        Per-read timeout, s (wall time).
    retries : int
        Attempts per transaction before giving up.
    name : str
        Axis name for messages (a1, a2, a3).
    on_event : callable or None
        ``on_event(kind, detail)`` for recovered faults (e.g. the session's event log).
    reopen_s : float
        How long to keep trying to reopen a vanished port, wall seconds.
    """

    def __init__(self, port: str, *, timeout_s: float = 0.3, retries: int = 4, name: str = "",
                 on_event: Callable[[str, dict], None] | None = None, reopen_s: float = 5.0) -> None:
        self.port = port
        self.timeout_s = timeout_s
        self.retries = retries
        self.name = name
        self.on_event = on_event
        self.reopen_s = reopen_s
        self._ser: serial.Serial | None = None
        self._microstep_mode = P.MICROSTEP_MODE_FRAC_256
        self.recovered = 0

    def _open_port(self) -> None:
        """Open the serial port (115200 8N2, no flow control); TurntableError if it cannot be opened."""
        try:
            self._ser = serial.serial_for_url(self.port, baudrate=115200, bytesize=8, parity="N", stopbits=2,
                                              timeout=self.timeout_s, write_timeout=1.0, rtscts=False, xonxoff=False)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TurntableError(self.port, "open", f"cannot open port ({exc})", self.name) from None
        self._ser.reset_input_buffer()

    def close(self) -> None:
        if self._ser is not None:
            try:
                self._ser.close()
            except Exception:  # noqa: BLE001
                pass
            self._ser = None

    def reconnect(self) -> None:
        """Reopen the port (e.g. after a USB replug), trying for ``reopen_s`` wall seconds."""
        self.close()
        deadline = time.monotonic() + self.reopen_s
        last = None
        while time.monotonic() < deadline:
            try:
                self._ser = serial.serial_for_url(self.port, baudrate=115200, bytesize=8, parity="N", stopbits=2,
                                                  timeout=self.timeout_s, write_timeout=1.0)
                self._ser.reset_input_buffer()
                self._event("reconnected", {"port": self.port})
                return
            except (serial.SerialException, OSError) as exc:
                last = exc
                time.sleep(0.05)
        raise TurntableError(self.port, "reconnect", f"port did not come back within {self.reopen_s:g} s ({last})",
                             self.name)

    # -- transactions -------------------------------------------------------------------------
    def _event(self, kind: str, detail: dict) -> None:
        if self.on_event is not None:
            self.on_event(kind, dict(detail, axis=self.name, port=self.port))

    def _read_answer(self, cmd: bytes) -> bytes:
        parser = P.AnswerParser(cmd)
        deadline = time.monotonic() + max(self.timeout_s * 3, 1.0)
        while True:
            want = max(parser.missing(), 1)
            chunk = self._ser.read(want)
            if chunk:
                done, frame = parser.feed(chunk)
                if done:
                    return frame
            elif time.monotonic() > deadline or not chunk:
                got = bytes(parser.buf)
                raise TimeoutError(f"no complete answer (got {len(got)} bytes: {got[:12].hex(' ')})")

    def _resync(self) -> None:
        """Send zeros until the controller echoes a zero: its input buffer is then empty."""
        try:
            self._ser.reset_input_buffer()
            self._ser.write(b"\x00" * 64)
            deadline = time.monotonic() + 0.5
            while time.monotonic() < deadline:
                b = self._ser.read(64)
                if b and 0 in b:
                    break
            time.sleep(0.005)
            self._ser.reset_input_buffer()
        except (serial.SerialException, OSError):
            pass

    def transact(self, cmd: bytes, obj=None):
        """Send one request and return its decoded answer (None for echo-only commands)."""
        if self._ser is None:
            raise TurntableError(self.port, cmd.decode(), "port is not open", self.name)
        frame = P.encode_request(cmd, obj, self._microstep_mode)
        last = ""
        for attempt in range(1, self.retries + 1):
            try:
                self._ser.write(frame)
                answer = self._read_answer(cmd)
                result = P.decode_answer(cmd, answer)
                if attempt > 1:
                    self.recovered += 1
                    self._event("recovered", {"command": cmd.decode(), "attempts": attempt, "fault": last})
                return result
            except P.ErrorAnswer as exc:
                if exc.code == b"errv":
                    raise TurntableError(self.port, cmd.decode(), f"controller rejected a value ({exc})",
                                         self.name) from None
                last = str(exc)
                self._resync()
            except (P.CrcError, P.EchoError, TimeoutError) as exc:
                last = str(exc)
                self._resync()
            except (serial.SerialException, OSError) as exc:
                last = f"port error ({exc})"
                try:
                    self.reconnect()
                except TurntableError as exc2:
                    raise TurntableError(self.port, cmd.decode(), f"port vanished and did not come back ({exc2.detail})",
                                         self.name) from None
        raise TurntableError(self.port, cmd.decode(), f"no valid answer after {self.retries} tries (last: {last})",
                             self.name)

