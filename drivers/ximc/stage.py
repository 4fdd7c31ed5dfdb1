"""``Stage``: one turntable axis (Standa 8SMC4/8SMC5 + 8MR191) over pyserial.

Method names follow libximc (``get_status``, ``command_move``, ``command_wait_for_stop``, ...).
Degrees at the degree API (``move_deg``, ``set_position_deg``, ``get_speed_deg_s``, ...), full
steps + microsteps on the wire. Transactions, retries and resynchronisation are
:class:`~drivers.ximc.link.XimcLink`'s; stage facts (0.01 deg/step, 48 deg/s) are in
:mod:`drivers.ximc.stage_spec`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

from drivers.clock import Clock, MonotonicClock
from drivers.ximc import protocol as P
from drivers.ximc.errors import TurntableError
from drivers.ximc.link import RECOVERABLE, XimcLink
from drivers.ximc.stage_spec import MR191

__all__ = ["RECOVERABLE", "Stage", "StageIdentity", "TurntableError"]


@dataclass(frozen=True)
class StageIdentity:
    """Who answers on a port: serial number, firmware "major.minor.release", device information."""

    port: str
    serial_number: int
    firmware: str
    device: dict

    def to_dict(self) -> dict:
        return {"port": self.port, "serial_number": self.serial_number, "firmware": self.firmware,
                "device": dict(self.device)}


class Stage(XimcLink):
    """One axis over a serial port (a device path or a pyserial URL).

    Parameters
    ----------
    port : str
    clock : Clock
        Used for waiting (default real time).
    deg_per_step : float
        Degrees per full motor step at the table (8MR191: 0.01).
    timeout_s, retries, name, on_event, reopen_s
        As :class:`~drivers.ximc.link.XimcLink` (transactions, retries, reopening the port).
    """

    def __init__(self, port: str, *, clock: Clock | None = None, deg_per_step: float = MR191.deg_per_step,
                 timeout_s: float = 0.3, retries: int = 4, name: str = "",
                 on_event: Callable[[str, dict], None] | None = None, reopen_s: float = 5.0) -> None:
        super().__init__(port, timeout_s=timeout_s, retries=retries, name=name, on_event=on_event,
                         reopen_s=reopen_s)
        self.clock = clock or MonotonicClock()
        self.deg_per_step = float(deg_per_step)

    # -- port ---------------------------------------------------------------------------------
    def open(self) -> "Stage":
        """Open the port and read the controller's microstep mode."""
        self._open_port()
        try:
            self._microstep_mode = self.get_engine_settings().MicrostepMode
        except TurntableError:
            self.close()
            raise
        return self

    def __enter__(self) -> "Stage":
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

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
        """Microsteps per full step in the controller's current microstep mode."""
        return 1 << (self._microstep_mode - 1)

    def _steps_to_deg(self, steps: int, usteps: int) -> float:
        return (steps + usteps / self.usteps_per_step) * self.deg_per_step

    def _deg_to_steps(self, deg: float) -> tuple[int, int]:
        total = round(deg / self.deg_per_step * self.usteps_per_step)
        steps = int(total / self.usteps_per_step)
        return steps, int(total - steps * self.usteps_per_step)

    def get_position_deg(self) -> float:
        """Position counter, deg."""
        p = self.get_position()
        return self._steps_to_deg(p.Position, p.uPosition)

    def set_position_deg(self, angle_deg: float) -> None:
        """Renumber the current position as ``angle_deg`` (deg) without moving (``spos``)."""
        if not math.isfinite(angle_deg):
            raise TurntableError(self.port, "spos", f"angle {angle_deg!r} is not a finite number", self.name)
        self.set_position(P.SetPosition(*self._deg_to_steps(angle_deg)))

    def get_speed_deg_s(self) -> float:
        """Current speed from the status, deg/s (signed: negative turning left)."""
        st = self.get_status()
        return (st.CurSpeed + st.uCurSpeed / self.usteps_per_step) * self.deg_per_step

    def move_deg(self, angle_deg: float) -> None:
        """Move to ``angle_deg`` (deg, absolute); returns at once (see ``command_wait_for_stop``)."""
        if not math.isfinite(angle_deg):
            raise TurntableError(self.port, "move", f"angle {angle_deg!r} is not a finite number", self.name)
        self.command_move(*self._deg_to_steps(angle_deg))

    def movr_deg(self, delta_deg: float) -> None:
        """Move by ``delta_deg`` (deg, relative)."""
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
        """Serial number, firmware and device information of the controller on this port."""
        info = self.get_device_information()
        fw = self.get_firmware_version()
        return StageIdentity(port=self.port, serial_number=self.get_serial_number(),
                             firmware=".".join(map(str, fw)),
                             device={"manufacturer": info.Manufacturer, "manufacturer_id": info.ManufacturerId,
                                     "product": info.ProductDescription,
                                     "hardware": f"{info.Major}.{info.Minor}.{info.Release}"})
