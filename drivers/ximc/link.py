"""``XimcLink``: request/answer transactions with one 8SMC4/8SMC5 controller over pyserial.

Every transaction is retried a bounded number of times with the protocol's zero-byte
resynchronisation (and a reopen of the port if it vanished, e.g. a USB replug); after that a
:class:`TurntableError` names the axis, port, command and what came back. A value is never
returned unless its frame decoded with a good CRC. That policy is the sans-I/O
:class:`~drivers.ximc.transaction.Transaction`; this class is its shell: it owns the pyserial
port and the wall clock and carries out the actions the policy asks for.
:class:`drivers.ximc.stage.Stage` adds the command set and degree units on top.
"""

from __future__ import annotations

import time
from typing import Callable

import serial

from drivers.ximc import protocol as P
from drivers.ximc.errors import TurntableError
from drivers.ximc.transaction import (Close, Done, Failed, Open, Receive, Reconnected, Recovered, Reopen, ResetInput,
                                      Transaction, Wait, Write)

RECOVERABLE = (P.CrcError, P.EchoError)
#: what a port raises when it fails or vanishes
PORT_ERRORS = (serial.SerialException, OSError)


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

    def _serial_for_url(self) -> serial.Serial:
        """The port opened: 115200 8N2, no flow control."""
        return serial.serial_for_url(self.port, baudrate=115200, bytesize=8, parity="N", stopbits=2,
                                     timeout=self.timeout_s, write_timeout=1.0, rtscts=False, xonxoff=False)

    def _open_port(self) -> None:
        """Open the serial port; TurntableError if it cannot be opened."""
        try:
            self._ser = self._serial_for_url()
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
        self._run(Reopen(self.reopen_s), "reconnect")

    def transact(self, cmd: bytes, obj=None):
        """Send one request and return its decoded answer (None for echo-only commands)."""
        if self._ser is None:
            raise TurntableError(self.port, cmd.decode(), "port is not open", self.name)
        policy = Transaction(cmd, obj, microstep_mode=self._microstep_mode, timeout_s=self.timeout_s,
                             retries=self.retries, reopen_s=self.reopen_s)
        return self._run(policy, cmd.decode())

    # -- the shell: the policy's actions on the port and the wall clock ---------------------------
    def _run(self, policy: Transaction | Reopen, command: str):
        """Carry out ``policy``'s actions, telling it what happened, until its outcome."""
        actions = policy.start(time.monotonic())
        while True:
            for action in actions:
                if isinstance(action, Done):
                    return action.result
                if isinstance(action, Failed):
                    raise TurntableError(self.port, command, action.reason, self.name)
                following = self._CARRY_OUT[type(action)](self, policy, action)
                if following is not None:
                    break
            else:
                following = policy.resume(time.monotonic())
            actions = following

    def _on_port(self, policy, effect: Callable[[], object]) -> list | None:
        """Run one port effect; on a port error, the policy's answer to it (the rest of the list is dropped)."""
        try:
            effect()
        except PORT_ERRORS as exc:
            return policy.port_failed(str(exc), time.monotonic())
        return None

    def _write(self, policy, action: Write) -> list | None:
        return self._on_port(policy, lambda: self._ser.write(action.data))

    def _reset_input(self, policy, action: ResetInput) -> list | None:
        return self._on_port(policy, lambda: self._ser.reset_input_buffer())

    def _receive(self, policy, action: Receive) -> list:
        try:
            data = self._ser.read(action.max_bytes)
        except PORT_ERRORS as exc:
            return policy.port_failed(str(exc), time.monotonic())
        now = time.monotonic()
        # a read that returns nothing has waited its timeout (an in-memory port returns at once: nothing is coming)
        return policy.received(data, now if data else max(now, action.until))

    def _wait(self, policy, action: Wait) -> None:
        time.sleep(max(action.until - time.monotonic(), 0.0))

    def _close(self, policy, action: Close) -> None:
        self.close()

    def _open(self, policy, action: Open) -> list | None:
        def reopen() -> None:
            self._ser = self._serial_for_url()
            self._ser.reset_input_buffer()
        return self._on_port(policy, reopen)

    def _note_recovered(self, policy, action: Recovered) -> None:
        self.recovered += 1
        self._event("recovered", {"command": action.command, "attempts": action.attempts, "fault": action.fault})

    def _note_reconnected(self, policy, action: Reconnected) -> None:
        self._event("reconnected", {"port": self.port})

    def _event(self, kind: str, detail: dict) -> None:
        if self.on_event is not None:
            self.on_event(kind, dict(detail, axis=self.name, port=self.port))

    #: action type -> how the shell carries it out (None: go on with the list; a list: the policy's next actions)
    _CARRY_OUT = {
        Write: _write, ResetInput: _reset_input, Receive: _receive, Wait: _wait, Close: _close, Open: _open,
        Recovered: _note_recovered, Reconnected: _note_reconnected,
    }
