"""``Stage``: one turntable axis (Standa 8SMC4/8SMC5 + 8MR191) over pyserial.

Method names follow libximc (``get_status``, ``command_move``,
``command_wait_for_stop``, ...). Degrees at the degree API, full steps +
microsteps on the wire. Every transaction is retried a bounded number of
times with the protocol's zero-byte resynchronisation; after that a
:class:`TurntableError` names the axis, port, command and what came back.
A value is never returned unless its frame decoded with a good CRC.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable

import serial

from drivers.clock import Clock, MonotonicClock
from drivers.ximc import protocol as P


class TurntableError(Exception):
    """A turntable command failed; one line naming axis, port, command and detail."""

    def __init__(self, port: str, command: str, detail: str, name: str = "") -> None:
        self.port, self.command, self.detail, self.name = port, command, detail, name
        axis = f"{name} " if name else ""
        super().__init__(f"{axis}{port}: {command}: {detail}")


@dataclass(frozen=True)
class StageIdentity:
    port: str
    serial_number: int
    firmware: str
    device: dict

    def to_dict(self) -> dict:
        return {"port": self.port, "serial_number": self.serial_number, "firmware": self.firmware,
                "device": dict(self.device)}


RECOVERABLE = (P.CrcError, P.EchoError)


class Stage:
    """One axis over a serial port (a device path or a pyserial URL).

    Parameters
    ----------
    port : str
    clock : Clock used for waiting (default real time).
    deg_per_step : degrees per full motor step at the table (8MR191: 0.01).
    timeout_s : per-read timeout, s (wall time).
    retries : attempts per transaction before giving up.
    name : axis name for messages (a1, a2, a3).
    on_event : callback(kind, detail) for recovered faults (e.g. the session's event log).
    reopen_s : how long to keep trying to reopen a vanished port (wall seconds).
    """

    def __init__(self, port: str, *, clock: Clock | None = None, deg_per_step: float = 0.01,
                 timeout_s: float = 0.3, retries: int = 4, name: str = "",
                 on_event: Callable[[str, dict], None] | None = None, reopen_s: float = 5.0) -> None:
        self.port = port
        self.clock = clock or MonotonicClock()
        self.deg_per_step = float(deg_per_step)
        self.timeout_s = timeout_s
        self.retries = retries
        self.name = name
        self.on_event = on_event
        self.reopen_s = reopen_s
        self._ser: serial.Serial | None = None
        self._microstep_mode = P.MICROSTEP_MODE_FRAC_256
        self.recovered = 0

    # -- port ---------------------------------------------------------------------------------
    def open(self) -> "Stage":
        try:
            self._ser = serial.serial_for_url(self.port, baudrate=115200, bytesize=8, parity="N", stopbits=2,
                                              timeout=self.timeout_s, write_timeout=1.0, rtscts=False, xonxoff=False)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TurntableError(self.port, "open", f"cannot open port ({exc})", self.name) from None
        self._ser.reset_input_buffer()
        try:
            self._microstep_mode = self.get_engine_settings().MicrostepMode
        except TurntableError:
            self.close()
            raise
        return self

    def close(self) -> None:
        if self._ser is not None:
            try:
                self._ser.close()
            except Exception:  # noqa: BLE001
                pass
            self._ser = None

    def __enter__(self) -> "Stage":
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

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

    # -- libximc-style API ----------------------------------------------------------------------
    def get_status(self) -> P.Status:
        return self.transact(b"gets")

    def get_position(self) -> P.Position:
        return self.transact(b"gpos")

    def set_position(self, position: P.SetPosition) -> None:
        self.transact(b"spos", position)

    def command_move(self, position: int, uposition: int = 0) -> None:
        self.transact(b"move", P.Move(int(position), int(uposition)))

    def command_movr(self, delta_position: int, udelta_position: int = 0) -> None:
        self.transact(b"movr", P.Move(int(delta_position), int(udelta_position)))

    def command_stop(self) -> None:
        self.transact(b"stop")

    def command_sstp(self) -> None:
        self.transact(b"sstp")

    def command_home(self) -> None:
        self.transact(b"home")

    def command_zero(self) -> None:
        self.transact(b"zero")

    def command_left(self) -> None:
        self.transact(b"left")

    def command_right(self) -> None:
        self.transact(b"rigt")

    def command_power_off(self) -> None:
        self.transact(b"pwof")

    def get_move_settings(self) -> P.MoveSettings:
        return self.transact(b"gmov")

    def set_move_settings(self, ms: P.MoveSettings) -> None:
        self.transact(b"smov", ms)

    def get_engine_settings(self) -> P.EngineSettings:
        return self.transact(b"geng")

    def set_engine_settings(self, es: P.EngineSettings) -> None:
        self.transact(b"seng", es)
        self._microstep_mode = es.MicrostepMode

    def get_serial_number(self) -> int:
        return self.transact(b"gser").SerialNumber

    def get_firmware_version(self) -> tuple[int, int, int]:
        f = self.transact(b"gfwv")
        return f.Major, f.Minor, f.Release

    def get_device_information(self) -> P.DeviceInformation:
        return self.transact(b"geti")

    def command_wait_for_stop(self, refresh_interval_ms: int = 10, timeout_s: float | None = None) -> P.Status:
        """Poll until the current command is no longer running (MVCMD_RUNNING clear).

        Waits on the stage's clock (instant under a VirtualClock). Raises
        TurntableError when the command ended with MVCMD_ERROR or ``timeout_s`` passed.
        """
        t0 = self.clock.now()
        while True:
            st = self.get_status()
            if not st.running:
                if st.command_error:
                    pos = self._steps_to_deg(st.CurPosition, st.uCurPosition)
                    edge = " at a limit switch" if st.GPIOFlags & (P.STATE_LEFT_EDGE | P.STATE_RIGHT_EDGE) else ""
                    raise TurntableError(self.port, "wait_for_stop",
                                         f"move ended with an error{edge} at {pos:.4f} deg (stalled?)", self.name)
                return st
            if timeout_s is not None and self.clock.now() - t0 > timeout_s:
                raise TurntableError(self.port, "wait_for_stop", f"still moving after {timeout_s:g} s", self.name)
            self.clock.sleep(refresh_interval_ms / 1000.0)

    # -- degrees --------------------------------------------------------------------------------
    @property
    def usteps_per_step(self) -> int:
        return 1 << (self._microstep_mode - 1)

    def _steps_to_deg(self, steps: int, usteps: int) -> float:
        return (steps + usteps / self.usteps_per_step) * self.deg_per_step

    def _deg_to_steps(self, deg: float) -> tuple[int, int]:
        total = round(deg / self.deg_per_step * self.usteps_per_step)
        steps = int(total / self.usteps_per_step)
        return steps, int(total - steps * self.usteps_per_step)

    def get_position_deg(self) -> float:
        p = self.get_position()
        return self._steps_to_deg(p.Position, p.uPosition)

    def move_deg(self, angle_deg: float) -> None:
        if not math.isfinite(angle_deg):
            raise TurntableError(self.port, "move", f"angle {angle_deg!r} is not a finite number", self.name)
        self.command_move(*self._deg_to_steps(angle_deg))

    def movr_deg(self, delta_deg: float) -> None:
        self.command_movr(*self._deg_to_steps(delta_deg))

    def set_speed_deg_s(self, speed_deg_s: float, accel_deg_s2: float | None = None,
                        decel_deg_s2: float | None = None) -> None:
        """Set move speed (and acceleration/deceleration), deg/s and deg/s^2 (read-modify-write)."""
        ms = self.get_move_settings()
        es = self.get_engine_settings()
        max_deg_s = es.NomSpeed * self.deg_per_step
        if not 0 < speed_deg_s <= max_deg_s + 1e-9:
            raise TurntableError(self.port, "smov", f"speed {speed_deg_s:g} deg/s outside 0..{max_deg_s:g} deg/s "
                                 "(the stage's limit)", self.name)
        steps_s = speed_deg_s / self.deg_per_step
        whole = int(steps_s)
        frac = int(round((steps_s - whole) * min(self.usteps_per_step, 256)))
        frac = min(frac, min(self.usteps_per_step, 256) - 1)
        new = replace(ms, Speed=whole, uSpeed=frac)
        if accel_deg_s2 is not None:
            new = replace(new, Accel=max(1, min(65535, int(round(accel_deg_s2 / self.deg_per_step)))))
        if decel_deg_s2 is not None or accel_deg_s2 is not None:
            d = decel_deg_s2 if decel_deg_s2 is not None else accel_deg_s2
            new = replace(new, Decel=max(1, min(65535, int(round(d / self.deg_per_step)))))
        self.set_move_settings(new)

    def rotate_continuous(self, rate_deg_s: float) -> None:
        """Turn continuously at ``rate_deg_s`` (sign gives the direction)."""
        self.set_speed_deg_s(abs(rate_deg_s))
        self.command_right() if rate_deg_s >= 0 else self.command_left()

    def identify(self) -> StageIdentity:
        info = self.get_device_information()
        fw = self.get_firmware_version()
        return StageIdentity(port=self.port, serial_number=self.get_serial_number(),
                             firmware=".".join(map(str, fw)),
                             device={"manufacturer": info.Manufacturer, "manufacturer_id": info.ManufacturerId,
                                     "product": info.ProductDescription,
                                     "hardware": f"{info.Major}.{info.Minor}.{info.Release}"})
