"""A sans-I/O 8SMC5 controller: request bytes in, answer bytes out.

In the style of h11 and caproto: :class:`Controller` owns no port, thread or timer. Feed it
whatever bytes arrived (``receive``) and send back what it returns. What each command does is
chosen by one table (``Controller.HANDLERS``: command code -> small handler method); motion
state is computed from the injected clock (:mod:`drivers.ximc.sim.axis`). The pseudo-terminal
server around it is :mod:`drivers.ximc.sim.pty`; :class:`~drivers.ximc.sim.emulator.ControllerEmulator`
puts the two together.

Wire behaviour: a resync zero byte is echoed; an unknown command gets ``errc``, a bad data CRC
``errd``, a value out of range ``errv``; a partial request older than ``REQUEST_GAP_S`` (wall
seconds, when arrival times are given) is dropped, as the firmware does.
"""

from __future__ import annotations

import random
import threading
from dataclasses import replace
from typing import Callable

from drivers.clock import Clock, MonotonicClock
from drivers.ximc import protocol as P
from drivers.ximc.sim.axis import USTEPS, AxisMotion, MotionNow, StageModel
from drivers.ximc.sim.faults import XimcFaults, mangle_answer
from drivers.ximc.sim.motion import plan_continuous, plan_move, plan_stop

#: the controller forgets a partial request after this byte gap, wall seconds
REQUEST_GAP_S = 0.4
#: largest Speed a controller accepts in ``smov``, full steps/s
MAX_SPEED_STEPS_S = 100000


def split_usteps(usteps: float) -> tuple[int, int]:
    """Microsteps -> (full steps, microsteps), the microstep part carrying the sign of the remainder."""
    u = int(round(usteps))
    steps = int(u / USTEPS)  # truncates toward zero, like the controller
    return steps, u - steps * USTEPS


class Controller:
    """One emulated 8SMC5 controller with its stage, as a state machine over bytes.

    Parameters
    ----------
    serial_number : int
    clock : Clock
        Motion runs on this clock (default real time).
    faults : XimcFaults or None
        Answer faults (drop, corrupt, truncate, error answers) and mechanical ones (stall, limit).
    stage : StageModel
    seed : int
        Seeds random faults when ``faults.seed`` is 0.
    """

    def __init__(self, serial_number: int, *, clock: Clock | None = None, faults: XimcFaults | None = None,
                 stage: StageModel = StageModel(), seed: int = 0) -> None:
        self.serial_number = int(serial_number)
        self.clock = clock or MonotonicClock()
        self.faults = faults or XimcFaults()
        self.stage = stage
        self.motion = AxisMotion(self.clock, stage)
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
        self.flags = P.STATE_EEPROM_CONNECTED
        self._parser = P.RequestParser()
        self._last_arrival_s = 0.0
        self.requests_seen = 0  # complete request frames received
        self.requests_answered = 0  # of them, the ones that decoded (good CRC) and were handled

    # -- bytes in, bytes out --------------------------------------------------------------------
    def receive(self, data: bytes, *, arrival_s: float | None = None) -> bytes:
        """Feed bytes from the host; return the bytes the controller sends back (may be empty).

        ``arrival_s`` (wall seconds, any monotonic origin) enables the firmware's request-gap
        rule: a partial request is dropped when the next byte comes more than REQUEST_GAP_S later.
        """
        if arrival_s is not None:
            if self._parser.buf and arrival_s - self._last_arrival_s > REQUEST_GAP_S:
                self._parser.clear()
            self._last_arrival_s = arrival_s
        out = bytearray()
        for event in self._parser.feed(data):
            out += self._on_event(event)
        return bytes(out)

    def clear_input(self) -> None:
        """Forget a partially received request (the port was reopened)."""
        self._parser.clear()

    def _on_event(self, event: tuple) -> bytes:
        if event[0] == "zero":
            return b"\x00"
        if event[0] == "unknown":
            with self._lock:
                self.flags |= P.STATE_ERRC
            return b"errc"
        self.requests_seen += 1
        try:
            cmd, request = P.decode_request(event[1])
        except P.CrcError:
            with self._lock:
                self.flags |= P.STATE_ERRD
            return b"errd"
        self.requests_answered += 1
        return mangle_answer(self.handle(cmd, request), self.faults, self._rng)

    def handle(self, cmd: bytes, request) -> bytes:
        """The answer frame to one decoded request (no answer faults applied)."""
        handler = self.HANDLERS.get(cmd)
        if handler is None:
            return b"errc"
        with self._lock:
            return handler(self, cmd, request, self.motion.now())

    # -- physical state (world model) ------------------------------------------------------------
    def position_deg_at(self, t_s):
        """True physical angle of the stage at clock time(s) ``t_s``, deg."""
        with self._lock:
            return self.motion.position_deg_at(t_s)

    def speed_deg_s_at(self, t_s):
        """True angular rate of the stage at clock time(s) ``t_s``, deg/s."""
        with self._lock:
            return self.motion.speed_deg_s_at(t_s)

    def direction_at(self, t_s):
        """The direction (+1 or -1) the motor last turned at clock time(s) ``t_s`` (what lost motion follows)."""
        with self._lock:
            return self.motion.direction_at(t_s)

    def state_at(self, t_s):
        """(angle deg, rate deg/s, last direction) of the stage at clock time(s) ``t_s`` (:meth:`AxisMotion.state_at`)."""
        with self._lock:
            return self.motion.state_at(t_s)

    def rest_pose(self, t_s: float) -> tuple[float, float] | None:
        """(angle deg, last direction) the stage rests at from ``t_s`` on, None while it moves (AxisMotion's)."""
        with self._lock:
            return self.motion.rest_pose(t_s)

    # -- helpers -----------------------------------------------------------------------------------
    def _limits(self) -> tuple[float, float, float]:
        """Top speed (usteps/s), acceleration and deceleration (usteps/s^2) of a move."""
        ms = self.move_settings
        speed = ms.Speed + ms.uSpeed / USTEPS
        if self.engine_settings.EngineFlags & P.ENGINE_LIMIT_RPM:
            speed = min(speed, self.engine_settings.NomSpeed)
        return speed * USTEPS, ms.Accel * USTEPS, ms.Decel * USTEPS

    def _reject(self) -> bytes:
        self.flags |= P.STATE_ERRV
        return b"errv"

    def _status(self, t: float) -> P.Status:
        m = self.motion
        p, v = float(m.profile.position(t)), float(m.profile.velocity(t))
        running = m.running(t)
        cmd_sts = m.command_state(t)
        mv = 0
        if abs(v) > 0:
            mv |= P.MOVE_STATE_MOVING
            vmax = self._limits()[0]
            if abs(abs(v) - vmax) < 1e-6 * vmax:
                mv |= P.MOVE_STATE_TARGET_SPEED
        steps, usteps = split_usteps(p)
        vs, vus = split_usteps(v)
        return P.Status(MoveSts=mv, MvCmdSts=cmd_sts, PWRSts=P.PWR_STATE_NORM if running else P.PWR_STATE_REDUCT,
                        EncSts=0, WindSts=0x33, CurPosition=steps, uCurPosition=usteps, EncPosition=int(round(p)),
                        CurSpeed=vs, uCurSpeed=vus, Ipwr=300 if running else 150, Upwr=1200, Iusb=0, Uusb=500,
                        CurT=366, Flags=self.flags, GPIOFlags=m.gpio, CmdBufFreeSpace=0)

    # -- command handlers: (cmd, decoded request, motion now) -> answer frame ----------------------
    def _get_status(self, cmd: bytes, request, now: MotionNow) -> bytes:
        return P.encode_answer(cmd, self._status(now.t))

    def _get_position(self, cmd: bytes, request, now: MotionNow) -> bytes:
        steps, usteps = split_usteps(now.p)
        return P.encode_answer(cmd, P.Position(steps, usteps, int(round(now.p))))

    def _move(self, cmd: bytes, request: P.Move, now: MotionNow) -> bytes:
        """``move`` (absolute) and ``movr`` (relative to the running move's target, or to here)."""
        if self.flags & P.STATE_ALARM:
            return b"errv"
        usteps_per_step = 1 << (self.engine_settings.MicrostepMode - 1)
        if abs(request.uPosition) >= usteps_per_step:
            return self._reject()
        delta = request.Position * USTEPS + request.uPosition * (USTEPS // usteps_per_step)
        if cmd == b"move":
            target = float(delta)
        else:
            moving = self.motion.running(now.t) and self.motion.cmd in (P.MVCMD_MOVE, P.MVCMD_MOVR)
            target = (self.motion.target() if moving else now.p) + delta
        vmax, acc, dec = self._limits()
        self.motion.start(plan_move(now.t, now.p, now.v, target, vmax, acc, dec),
                          P.MVCMD_MOVE if cmd == b"move" else P.MVCMD_MOVR, self.faults)
        return cmd

    def _turn(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``left`` / ``rigt``: turn continuously at the move speed."""
        vmax, acc, dec = self._limits()
        direction = -1.0 if cmd == b"left" else 1.0
        self.motion.start(plan_continuous(now.t, now.p, now.v, direction, vmax, acc, dec),
                          P.MVCMD_LEFT if cmd == b"left" else P.MVCMD_RIGHT, self.faults)
        return cmd

    def _stop(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``stop``: stop dead and clear the alarm."""
        self.motion.halt(now)
        self.flags &= ~P.STATE_ALARM
        return cmd

    def _soft_stop(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``sstp``: brake at the move deceleration."""
        self.motion.start(plan_stop(now.t, now.p, now.v, self._limits()[2]), P.MVCMD_SSTP, self.faults)
        return cmd

    def _home(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``home``: move at FastHome to the home sensor plus HomeDelta."""
        hs = self.home_settings
        home_counter = self.motion.counter_of_deg(self.stage.home_position_deg) + (hs.HomeDelta * USTEPS
                                                                                  + hs.uHomeDelta)
        _, acc, dec = self._limits()
        self.motion.start(plan_move(now.t, now.p, now.v, home_counter, max(hs.FastHome, 1) * USTEPS, acc, dec),
                          P.MVCMD_HOME, self.faults)
        self.flags |= P.STATE_IS_HOMED
        return cmd

    def _zero(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``zero``: counter := 0; the physical angle and the absolute destination do not move."""
        self.motion.shift_counter(-now.p)
        return cmd

    def _set_position(self, cmd: bytes, request: P.SetPosition, now: MotionNow) -> bytes:
        """``spos``: renumber the counter (unless SETPOS_IGNORE_POSITION)."""
        new_p = now.p
        if not request.PosFlags & P.SETPOS_IGNORE_POSITION:
            new_p = request.Position * USTEPS + request.uPosition
        self.motion.shift_counter(new_p - now.p)
        return cmd

    def _read(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``gmov``, ``geng``, ``ghom``, ``gfwv``, ``gser``, ``geti``: a stored record."""
        record = {b"gmov": self.move_settings, b"geng": self.engine_settings, b"ghom": self.home_settings,
                  b"gfwv": self.firmware, b"gser": P.SerialNumber(self.serial_number),
                  b"geti": self.device_info}[cmd]
        return P.encode_answer(cmd, record)

    def _set_move_settings(self, cmd: bytes, request: P.MoveSettings, now: MotionNow) -> bytes:
        """``smov``: out-of-range values are clamped, stored and answered with ``errv``."""
        if request.Speed > MAX_SPEED_STEPS_S or request.Accel < 1 or request.Decel < 1:
            self.move_settings = replace(request, Speed=min(request.Speed, MAX_SPEED_STEPS_S),
                                         Accel=max(request.Accel, 1), Decel=max(request.Decel, 1))
            return self._reject()
        self.move_settings = request
        return cmd

    def _set_engine_settings(self, cmd: bytes, request: P.EngineSettings, now: MotionNow) -> bytes:
        if not 1 <= request.MicrostepMode <= 9:
            return self._reject()
        self.engine_settings = request
        return cmd

    def _set_home_settings(self, cmd: bytes, request: P.HomeSettings, now: MotionNow) -> bytes:
        self.home_settings = request
        return cmd

    def _accept(self, cmd: bytes, request, now: MotionNow) -> bytes:
        """``loft``, ``pwof``, ``save``, ``read``: acknowledged, no effect on the emulation."""
        return cmd

    #: command code -> handler; a code missing here is answered ``errc``
    HANDLERS: dict[bytes, Callable[..., bytes]] = {
        b"gets": _get_status, b"gpos": _get_position,
        b"move": _move, b"movr": _move, b"left": _turn, b"rigt": _turn,
        b"stop": _stop, b"sstp": _soft_stop, b"home": _home, b"zero": _zero, b"spos": _set_position,
        b"gmov": _read, b"geng": _read, b"ghom": _read, b"gfwv": _read, b"gser": _read, b"geti": _read,
        b"smov": _set_move_settings, b"seng": _set_engine_settings, b"shom": _set_home_settings,
        b"loft": _accept, b"pwof": _accept, b"save": _accept, b"read": _accept,
    }
