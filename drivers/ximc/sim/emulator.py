"""A virtual 8SMC5-USB controller with an 8MR191 rotation stage, served on a pseudo-terminal.

Any serial program (our ``Stage``, Standa's own libximc via ``xi-com:/dev/pts/N``)
talks to it as to hardware. Motion is a trapezoidal profile computed from the
move settings and the shared :class:`~drivers.clock.Clock`, so it runs in real
time, scaled time or virtual time alike. Faults are injected on demand
(:class:`XimcFaults`). ``python -m drivers.ximc.sim.emulator --count 3`` starts some.
"""

from __future__ import annotations

import argparse
import os
import random
import select
import shutil
import tempfile
import threading
import time
import tty
from dataclasses import dataclass, replace

import numpy as np

from drivers.clock import MonotonicClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.motion import Profile, plan_continuous, plan_move, plan_stop

USTEPS = 256  # FRAC_256
DEG_PER_STEP = 0.01  # 8MR191: 36000 full steps per revolution


@dataclass(frozen=True)
class StageModel:
    """The mechanics behind the controller (8MR191-28 by default)."""

    deg_per_step: float = DEG_PER_STEP
    steps_per_rev: int = 200
    nom_speed_steps_s: int = 4800  # 48 deg/s
    home_position_deg: float = 0.0  # where the home sensor is, in the stage's physical angle


@dataclass
class XimcFaults:
    """Fault injection (all off by default; rates are probabilities per answer).

    Attributes
    ----------
    crc_corrupt_rate : answer with a flipped CRC bit.
    drop_rate : send no answer.
    truncate_rate : send only part of the answer.
    latency_s : delay every answer (wall seconds).
    error_answer_rate, error_answer : answer ``errc``/``errd``/``errv`` instead.
    vanish_at_s, vanish_for_s : at clock time vanish_at_s the port disappears (as if unplugged),
        and a new one appears vanish_for_s wall seconds later (same ``stable_path``).
    stall_at_deg : motion stops dead at this physical angle (deg) with MVCMD_ERROR.
    limit_deg : a limit switch at this angle: stops there with MVCMD_ERROR and an edge flag.
    seed : seeds the random faults.
    """

    crc_corrupt_rate: float = 0.0
    drop_rate: float = 0.0
    truncate_rate: float = 0.0
    latency_s: float = 0.0
    error_answer_rate: float = 0.0
    error_answer: str = "errd"
    vanish_at_s: float | None = None
    vanish_for_s: float = 1.0
    stall_at_deg: float | None = None
    limit_deg: float | None = None
    seed: int = 0


class ControllerEmulator:
    """One emulated controller + stage.

    Parameters
    ----------
    serial_number : int
    clock : Clock (default real time)
    faults : XimcFaults or None
    stage : StageModel
    seed : seeds random faults when ``faults.seed`` is 0
    """

    def __init__(self, serial_number: int, *, clock=None, faults: XimcFaults | None = None,
                 stage: StageModel = StageModel(), seed: int = 0) -> None:
        self.serial_number = int(serial_number)
        self.clock = clock or MonotonicClock()
        self.faults = faults or XimcFaults()
        self.stage = stage
        self._rng = random.Random(self.faults.seed or seed or serial_number)
        self._lock = threading.RLock()
        self.move_settings = P.MoveSettings(Speed=2000, uSpeed=0, Accel=2000, Decel=5000, AntiplaySpeed=2000,
                                            uAntiplaySpeed=0, MoveFlags=0)
        self.engine_settings = P.EngineSettings(NomVoltage=360, NomCurrent=670, NomSpeed=stage.nom_speed_steps_s,
                                                uNomSpeed=0, EngineFlags=P.ENGINE_LIMIT_RPM | P.ENGINE_ACCEL_ON,
                                                Antiplay=1800, MicrostepMode=P.MICROSTEP_MODE_FRAC_256,
                                                StepsPerRev=stage.steps_per_rev, PeakCurrent=0)
        self.home_settings = P.HomeSettings(FastHome=100, uFastHome=0, SlowHome=10, uSlowHome=0, HomeDelta=0,
                                            uHomeDelta=0, HomeFlags=0x170)
        self.firmware = P.FirmwareVersion(4, 3, 8)
        self.device_info = P.DeviceInformation("XIMC", "SM", "8SMC5", 2, 3, 0)
        t = self.clock.now()
        self._profile = Profile.rest(t, 0.0)
        self._offset_usteps = 0.0  # physical microsteps = counter + offset
        self._cmd = P.MVCMD_UKNWN
        self._cmd_error = False
        self._flags = P.STATE_EEPROM_CONNECTED
        self._gpio = 0
        self._error_at = None  # clock time at which the running command ends in error
        self._parser = P.RequestParser()
        self._last_byte = 0.0
        self._master = self._slave = None
        self._thread = None
        self._stop = threading.Event()
        self._vanished_until = None
        self._vanish_done = False
        self._dir = tempfile.mkdtemp(prefix="ximc-emu-")
        self.stable_path = os.path.join(self._dir, f"{self.serial_number:08X}")
        self.path: str | None = None
        self.requests_seen = 0

    # -- physical state (world model) ------------------------------------------------------
    def position_deg_at(self, t_s):
        """True physical angle of the stage at clock time(s) ``t_s``, deg."""
        with self._lock:
            u = self._profile.position(np.asarray(t_s, float)) + self._offset_usteps
        return u / USTEPS * self.stage.deg_per_step

    def speed_deg_s_at(self, t_s):
        """True angular rate of the stage at clock time(s) ``t_s``, deg/s."""
        with self._lock:
            v = self._profile.velocity(np.asarray(t_s, float))
        return v / USTEPS * self.stage.deg_per_step

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> str:
        """Open the pseudo-terminal and serve; returns the device path."""
        self._open_pty()
        self._thread = threading.Thread(target=self._serve, name=f"ximc-emu-{self.serial_number}", daemon=True)
        self._thread.start()
        return self.path

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._close_pty()
        shutil.rmtree(self._dir, ignore_errors=True)

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        self._master, self._slave = master, slave
        self.path = os.ttyname(slave)
        tmp = self.stable_path + ".tmp"
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(self.path, tmp)
        os.replace(tmp, self.stable_path)

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None

    # -- serving -------------------------------------------------------------------------------
    def _serve(self) -> None:
        while not self._stop.is_set():
            self._maybe_vanish()
            if self._master is None:
                time.sleep(0.01)
                continue
            try:
                r, _, _ = select.select([self._master], [], [], 0.02)
            except (OSError, ValueError):
                continue
            if not r:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                continue
            now = time.monotonic()
            if self._parser.buf and now - self._last_byte > 0.4:
                self._parser.clear()  # the controller drops a request after a 400 ms gap
            self._last_byte = now
            for ev in self._parser.feed(data):
                if ev[0] == "zero":
                    self._write(b"\x00")
                elif ev[0] == "unknown":
                    with self._lock:
                        self._flags |= P.STATE_ERRC
                    self._write(b"errc")
                else:
                    self.requests_seen += 1
                    self._answer(ev[1])

    def _maybe_vanish(self) -> None:
        f = self.faults
        if f.vanish_at_s is None or self._vanish_done:
            return
        if self._vanished_until is None and self.clock.now() >= f.vanish_at_s:
            self._close_pty()
            self._vanished_until = time.monotonic() + f.vanish_for_s  # a replug takes wall time
            try:
                os.unlink(self.stable_path)
            except OSError:
                pass
        elif self._vanished_until is not None and time.monotonic() >= self._vanished_until:
            self._open_pty()
            self._parser.clear()
            self._vanish_done = True

    def _write(self, data: bytes) -> None:
        if self._master is None:
            return
        try:
            os.write(self._master, data)
        except OSError:
            pass

    def _answer(self, frame: bytes) -> None:
        try:
            cmd, obj = P.decode_request(frame)
        except P.CrcError:
            with self._lock:
                self._flags |= P.STATE_ERRD
            self._write(b"errd")
            return
        answer = self._handle(cmd, obj)
        f = self.faults
        if f.latency_s > 0:
            time.sleep(f.latency_s)
        if f.drop_rate and self._rng.random() < f.drop_rate:
            return
        if f.error_answer_rate and self._rng.random() < f.error_answer_rate:
            self._write(f.error_answer.encode())
            return
        if f.crc_corrupt_rate and len(answer) > 4 and self._rng.random() < f.crc_corrupt_rate:
            answer = answer[:-1] + bytes([answer[-1] ^ 0x01])
        if f.truncate_rate and self._rng.random() < f.truncate_rate:
            answer = answer[: max(1, len(answer) // 2)]
        self._write(answer)

    # -- command semantics ---------------------------------------------------------------------
    def _limits(self):
        ms = self.move_settings
        speed = ms.Speed + ms.uSpeed / USTEPS
        if self.engine_settings.EngineFlags & P.ENGINE_LIMIT_RPM:
            speed = min(speed, self.engine_settings.NomSpeed)
        return speed * USTEPS, ms.Accel * USTEPS, ms.Decel * USTEPS

    def _state_now(self):
        t = self.clock.now()
        return t, float(self._profile.position(t)), float(self._profile.velocity(t))

    def _set_profile(self, prof: Profile, cmd: int) -> None:
        self._cmd = cmd
        self._cmd_error = False
        self._gpio &= ~(P.STATE_LEFT_EDGE | P.STATE_RIGHT_EDGE)
        self._error_at = None
        f = self.faults
        for where, is_limit in ((f.stall_at_deg, False), (f.limit_deg, True)):
            if where is None:
                continue
            limit_counter = where / self.stage.deg_per_step * USTEPS - self._offset_usteps
            prof2, tc = prof.truncate_at(limit_counter)
            if tc is not None:
                prof = prof2
                self._error_at = tc
                if is_limit:
                    self._gpio |= P.STATE_RIGHT_EDGE if limit_counter >= prof.phases[0].p else P.STATE_LEFT_EDGE
        self._profile = prof

    def _handle(self, cmd: bytes, obj) -> bytes:
        with self._lock:
            t, p, v = self._state_now()
            vmax, acc, dec = self._limits()
            if cmd == b"gets":
                return P.encode_answer(cmd, self._status(t))
            if cmd == b"gpos":
                steps, usteps = _split(p)
                return P.encode_answer(cmd, P.Position(steps, usteps, int(round(p))))
            if cmd in (b"move", b"movr"):
                if self._flags & P.STATE_ALARM:
                    return b"errv"
                usteps_per_step = 1 << (self.engine_settings.MicrostepMode - 1)
                if abs(obj.uPosition) >= usteps_per_step:
                    self._flags |= P.STATE_ERRV
                    return b"errv"
                delta = obj.Position * USTEPS + obj.uPosition * (USTEPS // usteps_per_step)
                if cmd == b"move":
                    target = float(delta)
                else:
                    running_target = self._profile.phases[-1].p if self._running(t) and self._cmd in (
                        P.MVCMD_MOVE, P.MVCMD_MOVR) else p
                    target = running_target + delta
                self._set_profile(plan_move(t, p, v, target, vmax, acc, dec),
                                  P.MVCMD_MOVE if cmd == b"move" else P.MVCMD_MOVR)
                return cmd
            if cmd in (b"left", b"rigt"):
                self._set_profile(plan_continuous(t, p, v, -1.0 if cmd == b"left" else 1.0, vmax, acc, dec),
                                  P.MVCMD_LEFT if cmd == b"left" else P.MVCMD_RIGHT)
                return cmd
            if cmd == b"stop":
                self._profile = Profile.rest(t, p)
                self._cmd, self._cmd_error, self._error_at = P.MVCMD_STOP, False, None
                self._flags &= ~P.STATE_ALARM
                return cmd
            if cmd == b"sstp":
                self._set_profile(plan_stop(t, p, v, dec), P.MVCMD_SSTP)
                return cmd
            if cmd == b"home":
                home_counter = (self.stage.home_position_deg / self.stage.deg_per_step * USTEPS
                                - self._offset_usteps) + (self.home_settings.HomeDelta * USTEPS
                                                          + self.home_settings.uHomeDelta)
                fast = max(self.home_settings.FastHome, 1) * USTEPS
                self._set_profile(plan_move(t, p, v, home_counter, fast, acc, dec), P.MVCMD_HOME)
                self._flags |= P.STATE_IS_HOMED
                return cmd
            if cmd == b"zero":
                # counter := 0; the physical angle and the absolute destination do not move
                self._offset_usteps += p
                self._profile = Profile([replace(ph, p=ph.p - p) for ph in self._profile.phases])
                return cmd
            if cmd == b"spos":
                new_p = p
                if not obj.PosFlags & P.SETPOS_IGNORE_POSITION:
                    new_p = obj.Position * USTEPS + obj.uPosition
                shift = new_p - p
                self._offset_usteps -= shift
                self._profile = Profile([replace(ph, p=ph.p + shift) for ph in self._profile.phases])
                return cmd
            if cmd == b"gmov":
                return P.encode_answer(cmd, self.move_settings)
            if cmd == b"smov":
                if obj.Speed > 100000 or obj.Accel < 1 or obj.Decel < 1:
                    self._flags |= P.STATE_ERRV
                    self.move_settings = replace(obj, Speed=min(obj.Speed, 100000), Accel=max(obj.Accel, 1),
                                                 Decel=max(obj.Decel, 1))
                    return b"errv"
                self.move_settings = obj
                return cmd
            if cmd == b"geng":
                return P.encode_answer(cmd, self.engine_settings)
            if cmd == b"seng":
                if not 1 <= obj.MicrostepMode <= 9:
                    self._flags |= P.STATE_ERRV
                    return b"errv"
                self.engine_settings = obj
                return cmd
            if cmd == b"ghom":
                return P.encode_answer(cmd, self.home_settings)
            if cmd == b"shom":
                self.home_settings = obj
                return cmd
            if cmd == b"gfwv":
                return P.encode_answer(cmd, self.firmware)
            if cmd == b"gser":
                return P.encode_answer(cmd, P.SerialNumber(self.serial_number))
            if cmd == b"geti":
                return P.encode_answer(cmd, self.device_info)
            if cmd in (b"loft", b"pwof", b"save", b"read"):
                return cmd
            return b"errc"

    def _running(self, t: float) -> bool:
        return t < self._profile.end_time

    def _status(self, t: float) -> P.Status:
        p = float(self._profile.position(t))
        v = float(self._profile.velocity(t))
        running = self._running(t)
        if not running and self._error_at is not None and t >= self._error_at:
            self._cmd_error = True
        mv = 0
        if abs(v) > 0:
            mv |= P.MOVE_STATE_MOVING
            vmax = self._limits()[0]
            if abs(abs(v) - vmax) < 1e-6 * vmax:
                mv |= P.MOVE_STATE_TARGET_SPEED
        cmd_sts = self._cmd | (P.MVCMD_RUNNING if running else 0) | (P.MVCMD_ERROR if self._cmd_error else 0)
        steps, usteps = _split(p)
        vs, vus = _split(v)
        return P.Status(MoveSts=mv, MvCmdSts=cmd_sts, PWRSts=P.PWR_STATE_NORM if running else P.PWR_STATE_REDUCT,
                        EncSts=0, WindSts=0x33, CurPosition=steps, uCurPosition=usteps, EncPosition=int(round(p)),
                        CurSpeed=vs, uCurSpeed=vus, Ipwr=300 if running else 150, Upwr=1200, Iusb=0, Uusb=500,
                        CurT=366, Flags=self._flags, GPIOFlags=self._gpio, CmdBufFreeSpace=0)


def _split(usteps: float) -> tuple[int, int]:
    """Microsteps -> (full steps, microsteps) with the microstep part carrying the sign of the remainder."""
    u = int(round(usteps))
    steps = int(u / USTEPS)  # truncates toward zero, like the controller
    return steps, u - steps * USTEPS


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m drivers.ximc.sim.emulator",
                                 description="Start emulated Standa 8SMC5 controllers on pseudo-terminals.")
    ap.add_argument("--count", type=int, default=3)
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--serial-base", type=int, default=0x5A00)
    args = ap.parse_args(argv)
    clock = MonotonicClock(args.time_scale)
    emus = [ControllerEmulator(args.serial_base + i, clock=clock) for i in range(args.count)]
    try:
        for e in emus:
            path = e.start()
            print(f"serial {e.serial_number}  {path}  stable {e.stable_path}  (libximc: xi-com:{path})", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0
    finally:
        for e in emus:
            e.stop()


if __name__ == "__main__":
    raise SystemExit(main())
