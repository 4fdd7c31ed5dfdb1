"""The mechanics behind an emulated controller: the stage model and its motion state.

Positions are kept in counter microsteps (what ``gpos`` reports); the physical angle is
``(counter + offset_usteps) / USTEPS * deg_per_step``, so ``zero`` and ``spos`` renumber the
counter without moving anything. Motion is a :class:`~drivers.ximc.sim.motion.Profile`
evaluated at the injected clock's time, never a timer of its own.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from drivers.ximc import protocol as P
from drivers.ximc.sim.faults import XimcFaults
from drivers.ximc.sim.motion import Profile
from drivers.ximc.stage_spec import MR191

#: microsteps per full step in the emulator's fixed microstep mode (MICROSTEP_MODE_FRAC_256)
USTEPS = 1 << (P.MICROSTEP_MODE_FRAC_256 - 1)
DEG_PER_STEP = MR191.deg_per_step


@dataclass(frozen=True)
class StageModel:
    """The mechanics behind the controller (8MR191-28 by default).

    Attributes
    ----------
    deg_per_step : float
        Table rotation per full step, deg.
    steps_per_rev : int
        Motor full steps per revolution.
    nom_speed_steps_s : int
        Nominal motor speed, full steps/s (4800: 48 deg/s).
    home_position_deg : float
        Where the home sensor is, in the stage's physical angle, deg.
    """

    deg_per_step: float = MR191.deg_per_step
    steps_per_rev: int = MR191.steps_per_rev
    nom_speed_steps_s: int = MR191.nom_speed_steps_s
    home_position_deg: float = 0.0


@dataclass(frozen=True)
class MotionNow:
    """Motion state at one clock time: ``t`` (s), counter position ``p`` (usteps), speed ``v`` (usteps/s)."""

    t: float
    p: float
    v: float


class AxisMotion:
    """Motion state of one emulated motor (not thread-safe: the controller holds the lock).

    Parameters
    ----------
    clock : Clock
    stage : StageModel
    """

    def __init__(self, clock, stage: StageModel) -> None:
        self.clock = clock
        self.stage = stage
        self.profile = Profile.rest(clock.now(), 0.0)
        self.offset_usteps = 0.0  # physical microsteps = counter + offset
        self.cmd = P.MVCMD_UKNWN
        self.cmd_error = False
        self.error_at: float | None = None  # clock time at which the running command ends in error
        self.gpio = 0
        self.direction_before = 1.0  # the direction the motor last turned before the current profile (+1 or -1)
        self._rest_memo: tuple | None = None  # (profile, (offset, direction before), rest pose): rest_pose

    # -- reading ---------------------------------------------------------------------------
    def now(self) -> MotionNow:
        t = self.clock.now()
        return MotionNow(t, float(self.profile.position(t)), float(self.profile.velocity(t)))

    def _deg(self, usteps):
        """Microsteps (of position or speed) in the table's degrees."""
        return usteps / USTEPS * self.stage.deg_per_step

    def position_deg_at(self, t_s):
        """True physical angle at clock time(s) ``t_s``, deg."""
        return self._deg(self.profile.position(np.asarray(t_s, float)) + self.offset_usteps)

    def speed_deg_s_at(self, t_s):
        """True angular rate at clock time(s) ``t_s``, deg/s."""
        return self._deg(self.profile.velocity(np.asarray(t_s, float)))

    def direction_at(self, t_s):
        """The direction (+1 or -1) the motor last turned at clock time(s) ``t_s``: the sign of its speed
        while it turns, else of the current profile's travel so far, else the direction before the profile
        (+1 before any motion). What a gear train's lost motion follows (``rig.simulation.geometry``)."""
        t = np.asarray(t_s, float)
        p, v = self.profile.position_velocity(t)
        return self._direction(t, p, v)

    def _direction(self, t: np.ndarray, p, v):
        travel = p - self.profile.phases[0].p
        started = t >= self.profile.phases[0].t
        d = np.where(np.abs(travel) > 1e-9, np.sign(travel), self.direction_before)
        return np.where(started & (np.abs(v) > 0), np.sign(v), np.where(started, d, self.direction_before))

    def state_at(self, t_s):
        """(:meth:`position_deg_at`, :meth:`speed_deg_s_at`, :meth:`direction_at`) at clock time(s) ``t_s`` from
        one evaluation of the profile (the same numbers as the three calls; the world model asks for all three at
        every block of samples through a move)."""
        t = np.asarray(t_s, float)
        p, v = self.profile.position_velocity(t)
        return self._deg(p + self.offset_usteps), self._deg(v), self._direction(t, p, v)

    def rest_pose(self, t_s: float) -> tuple[float, float] | None:
        """(physical angle deg, last direction +1 or -1) at which the stage stands still from clock time ``t_s``
        on, or None when the current profile still moves at or after ``t_s``. Computed once per profile and
        counter offset: the simulated world asks at every block of samples, and a stage at rest answers without
        evaluating its profile at each sample."""
        if t_s < self.profile.end_time:
            return None
        memo = self._rest_memo
        if memo is None or memo[0] is not self.profile or memo[1] != (self.offset_usteps, self.direction_before):
            end = self.profile.phases[-1].t
            pose = (float(self.position_deg_at(end)), float(self.direction_at(end)))
            memo = self._rest_memo = (self.profile, (self.offset_usteps, self.direction_before), pose)
        return memo[2]

    def counter_of_deg(self, angle_deg: float) -> float:
        """Counter microsteps at which the stage stands at physical ``angle_deg``."""
        return angle_deg / self.stage.deg_per_step * USTEPS - self.offset_usteps

    def running(self, t: float) -> bool:
        return t < self.profile.end_time

    def target(self) -> float:
        """Where the current profile comes to rest, counter microsteps."""
        return self.profile.phases[-1].p

    def command_state(self, t: float) -> int:
        """MvCmdSts at ``t``: the last command, RUNNING while it runs, ERROR once it ended in error."""
        running = self.running(t)
        if not running and self.error_at is not None and t >= self.error_at:
            self.cmd_error = True
        return self.cmd | (P.MVCMD_RUNNING if running else 0) | (P.MVCMD_ERROR if self.cmd_error else 0)

    # -- changing ----------------------------------------------------------------------------
    def start(self, profile: Profile, cmd: int, faults: XimcFaults) -> None:
        """Run ``profile`` as command ``cmd``; a stall or limit switch on the way cuts it short."""
        self.cmd = cmd
        self.cmd_error = False
        self.gpio &= ~(P.STATE_LEFT_EDGE | P.STATE_RIGHT_EDGE)
        self.error_at = None
        self.direction_before = float(self.direction_at(profile.phases[0].t))
        for where, is_limit in ((faults.stall_at_deg, False), (faults.limit_deg, True)):
            if where is None:
                continue
            limit_counter = self.counter_of_deg(where)
            cut, tc = profile.truncate_at(limit_counter)
            if tc is not None:
                profile = cut
                self.error_at = tc
                if is_limit:
                    self.gpio |= P.STATE_RIGHT_EDGE if limit_counter >= profile.phases[0].p else P.STATE_LEFT_EDGE
        self.profile = profile

    def halt(self, now: MotionNow) -> None:
        """Stop dead where the motor is (``stop``)."""
        self.direction_before = float(self.direction_at(now.t))
        self.profile = Profile.rest(now.t, now.p)
        self.cmd, self.cmd_error, self.error_at = P.MVCMD_STOP, False, None

    def shift_counter(self, shift: float) -> None:
        """Add ``shift`` microsteps to the counter; the physical angle and destination stay."""
        self.offset_usteps -= shift
        self.profile = Profile([replace(ph, p=ph.p + shift) for ph in self.profile.phases])
