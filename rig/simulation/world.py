"""The simulated rig's world model: what the sensor physically experiences.

Stage angles (read from the controller emulators as functions of clock time)
give the sensor's attitude through the kinematics contract
(``R = R_tilt Rz(a1) Rx(a2) Ry(a3)``, ``f = R^T e_z``); a chamber model gives
its temperature; the local magnetic field is rotated into the sensor frame;
the body angular rate follows from the stage rates; a small decaying ringing
follows every stop (so settle detection has something to detect).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from drivers.sensors.sim.physics import PhysicsBatch
from rig.planning.kinematics import rot_x, rot_y, rot_z
from rig.simulation.geometry import TableGeometry


@dataclass(frozen=True)
class ChamberConfig:
    """First-order thermal model of the sensor in its chamber.

    Attributes
    ----------
    initial_c : float
        Sensor temperature at the start, C.
    tau_s : float
        Time constant of the sensor following a new chamber setpoint, s.
    """

    initial_c: float = 25.0
    tau_s: float = 120.0


class SimChamber:
    """A climate chamber whose setpoint the runner can change or ramp.

    The sensor temperature follows the setpoint as a first-order lag (time constant ``tau_s``):
    ``dT/dt = (S(t) - T) / tau``. The setpoint is piecewise linear in time: constant after
    :meth:`set_target_c`, moving at a stated rate after :meth:`ramp_to_c` until it reaches the
    ramp's end, then constant again. On a ramp at rate r the sensor settles to lagging the setpoint
    by ``r tau`` and changes at the rate r itself, so the rate a step sees is the chamber's. ``temp_at``
    is exact (closed form per segment) and vectorised.
    """

    def __init__(self, clock, config: ChamberConfig = ChamberConfig()) -> None:
        self.clock = clock
        self.config = config
        # segments: (start time s, temperature at start C, setpoint at start C, setpoint rate C/s)
        self._segments: list[tuple[float, float, float, float]] = [
            (-np.inf, config.initial_c, config.initial_c, 0.0)]
        self._table: tuple[np.ndarray, np.ndarray] | None = None  # (starts, segments) as arrays: :meth:`_seg`

    @property
    def setpoint_c(self) -> float:
        """The setpoint now, C."""
        return float(self.setpoint_at(np.array([self.clock.now()]))[0])

    @property
    def rate_c_per_s(self) -> float:
        """The setpoint's rate now, C/s (0 when holding)."""
        return float(self._segments[self._index(np.array([self.clock.now()]))[0]][3])

    def set_target_c(self, target_c: float) -> None:
        """Change the chamber setpoint now (a step: the sensor relaxes to it)."""
        self._start(float(target_c), 0.0)

    def ramp_to_c(self, to_c: float, rate_c_per_min: float, from_c: float | None = None) -> float:
        """Move the setpoint from ``from_c`` (None: where it is now) towards ``to_c`` at
        ``rate_c_per_min`` (the sign follows the direction), then hold it there; return the ramp's
        duration, s."""
        t = self.clock.now()
        start_c = self.setpoint_c if from_c is None else float(from_c)
        rate = abs(float(rate_c_per_min)) / 60.0 * (1.0 if to_c >= start_c else -1.0)
        duration_s = abs(float(to_c) - start_c) / abs(rate) if rate else 0.0
        self._start(start_c, rate)
        end_t = t + duration_s
        self._segments.append((end_t, float(self.temp_at(np.array([end_t]))[0]), float(to_c), 0.0))
        self._table = None
        return duration_s

    def _start(self, setpoint_c: float, rate_c_per_s: float) -> None:
        t = self.clock.now()
        now_c = float(self.temp_at(np.array([t]))[0])
        self._segments = [s for s in self._segments if s[0] <= t]  # a new command replaces what was planned
        self._segments.append((t, now_c, setpoint_c, rate_c_per_s))
        self._table = None

    def _seg(self) -> np.ndarray:
        """The segments (start s, 0 for the first; temperature C; setpoint C; rate C/s) as an (S, 4) array, built
        again only when the segment list changes (a thermal wait reads the thermometer thousands of times)."""
        if self._table is None:
            self._table = (np.array([s[0] for s in self._segments]),
                           np.array([(s[0] if np.isfinite(s[0]) else 0.0, s[1], s[2], s[3]) for s in self._segments]))
        return self._table[1]

    def _index(self, t: np.ndarray) -> np.ndarray:
        self._seg()
        return np.clip(np.searchsorted(self._table[0], t, side="right") - 1, 0, len(self._segments) - 1)

    def setpoint_at(self, t_s: np.ndarray) -> np.ndarray:
        """The setpoint at clock times ``t_s``, C."""
        t = np.atleast_1d(np.asarray(t_s, float))
        seg = self._seg()
        i = self._index(t)
        return seg[i, 2] + seg[i, 3] * np.maximum(t - seg[i, 0], 0.0)

    def temp_at(self, t_s: np.ndarray) -> np.ndarray:
        """Sensor temperature at clock times ``t_s``, C: per segment, with setpoint ``S0 + r dt``,
        ``T = S0 + r dt - r tau + (T0 - S0 + r tau) exp(-dt / tau)``."""
        t = np.atleast_1d(np.asarray(t_s, float))
        seg = self._seg()
        i = self._index(t)
        t0, c0, s0, r = seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3]
        tau = self.config.tau_s
        dt = np.maximum(t - t0, 0.0)
        out = s0 + r * dt - r * tau + (c0 - s0 + r * tau) * np.exp(-dt / tau)
        out[i == 0] = self._segments[0][1]
        return out


@dataclass(frozen=True)
class RingingConfig:
    """Decaying oscillation of the specific force after a stage stops.

    Attributes
    ----------
    amplitude_g : float
        Initial amplitude, g.
    freq_hz : float
        Oscillation frequency, Hz.
    tau_s : float
        Decay time constant, s.
    """

    amplitude_g: float = 0.02
    freq_hz: float = 7.0
    tau_s: float = 0.25


@dataclass(frozen=True)
class FieldConfig:
    """Local geomagnetic field.

    Attributes
    ----------
    magnitude_ut : float
        Total intensity, uT.
    inclination_deg : float
        Dip below the horizontal (positive down), deg.
    declination_deg : float
        Angle of horizontal field from world +X towards +Y, deg.
    """

    magnitude_ut: float = 50.0
    inclination_deg: float = 65.0
    declination_deg: float = 0.0

    def world_vector_ut(self) -> np.ndarray:
        inc, dec = np.radians(self.inclination_deg), np.radians(self.declination_deg)
        h = self.magnitude_ut * np.cos(inc)
        return np.array([h * np.cos(dec), h * np.sin(dec), -self.magnitude_ut * np.sin(inc)])


@dataclass
class AxisLink:
    """How a kinematic axis angle follows from its stage.

    kinematic angle = sign * (stage angle - home_offset_deg)
    """

    position_deg_at: Callable[[np.ndarray], np.ndarray]
    speed_deg_s_at: Callable[[np.ndarray], np.ndarray]
    sign: float = 1.0
    home_offset_deg: float = 0.0
    direction_at: Callable[[np.ndarray], np.ndarray] | None = None  # the motor's last direction, +1 or -1
    #: (angle deg, last direction) the stage stands still at from a clock time on, None while it moves then; the
    #: world's shortcut for a block at rest (None: the world evaluates the stage at the block's samples)
    rest_pose: Callable[[float], tuple[float, float] | None] | None = None
    #: (angle deg, rate deg/s, last direction) at clock times from one evaluation of the stage's motion (None: the
    #: world asks the three callables above)
    state_at: Callable[[np.ndarray], tuple] | None = None


@dataclass
class WorldModel:
    """Physics source for the simulated sensor (a ``PhysicsSource``)."""

    axes: Sequence[AxisLink]
    chamber: SimChamber
    table_tilt_deg: tuple[float, float] = (0.0, 0.0)
    magnetic_field: FieldConfig = dataclasses.field(default_factory=FieldConfig)
    ringing: RingingConfig = dataclasses.field(default_factory=RingingConfig)
    geometry: TableGeometry | None = None  # the turntable's own errors (None: a perfect table)
    pose_error_deg: float = 0.0  # each pose placed off its nominal one by up to this (the pose_error effect)
    _last_moving_t: float = -np.inf
    _tilt: tuple | None = None  # (table_tilt_deg, its matrix)
    _memo: dict = dataclasses.field(default_factory=dict, repr=False)  # pose key -> its attitude at rest

    def angles_deg_at(self, t_s: np.ndarray) -> np.ndarray:
        """Kinematic angles (a1, a2, a3) at clock times ``t_s``: (N, 3), deg."""
        t = np.atleast_1d(np.asarray(t_s, float))
        cols = []
        for ax in self.axes:
            pos = np.broadcast_to(np.asarray(ax.position_deg_at(t), float), t.shape)
            cols.append(ax.sign * (pos - ax.home_offset_deg))
        return np.stack(cols, axis=1)

    def rates_deg_s_at(self, t_s: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t_s, float))
        cols = [ax.sign * np.broadcast_to(np.asarray(ax.speed_deg_s_at(t), float), t.shape)
                for ax in self.axes]
        return np.stack(cols, axis=1)

    def directions_at(self, t_s: np.ndarray) -> np.ndarray:
        """The direction each kinematic axis last turned (N, 3), +1 or -1 (+1 where the link does not say)."""
        t = np.atleast_1d(np.asarray(t_s, float))
        cols = [ax.sign * (np.broadcast_to(np.asarray(ax.direction_at(t), float), t.shape)
                           if ax.direction_at is not None else np.ones(t.shape)) for ax in self.axes]
        return np.stack(cols, axis=1)

    def tilt_matrix(self) -> np.ndarray:
        key = tuple(self.table_tilt_deg)
        if self._tilt is None or self._tilt[0] != key:
            tx, ty = np.radians(key)
            self._tilt = (key, rot_x(np.array([tx]))[0] @ rot_y(np.array([ty]))[0])
        return self._tilt[1]

    def placement(self, angles_deg: np.ndarray) -> np.ndarray:
        """The ``pose_error`` effect: (N, 3, 3) world rotations that put each pose off its nominal one, as a hand
        placement would, by angles about world x and y of at most :attr:`pose_error_deg`. A smooth function of the
        stage angles: the same pose is placed the same way every time it is visited, poses 90 deg apart differ."""
        a = np.radians(np.asarray(angles_deg, float))
        ex = np.radians(self.pose_error_deg) * np.sin(a @ np.array([1.3, 2.1, 0.7]) + 0.4)
        ey = np.radians(self.pose_error_deg) * np.sin(a @ np.array([0.9, -1.7, 2.3]) + 1.9)
        return rot_x(ex) @ rot_y(ey)

    def _kinematics(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Kinematic angles (N, 3) deg, rates (N, 3) rad/s and last directions (N, 3) at clock times ``t``: each
        stage's motion evaluated once where its link can (``state_at``), else :meth:`angles_deg_at`,
        :meth:`rates_deg_s_at` and (with a geometry; None without) :meth:`directions_at`."""
        if any(ax.state_at is None for ax in self.axes):
            return (self.angles_deg_at(t), np.radians(self.rates_deg_s_at(t)),
                    self.directions_at(t) if self.geometry is not None else None)
        cols = [ax.state_at(t) for ax in self.axes]
        angles = np.stack([ax.sign * (np.broadcast_to(p, t.shape) - ax.home_offset_deg)
                           for ax, (p, _, _) in zip(self.axes, cols)], axis=1)
        rates = np.stack([ax.sign * np.broadcast_to(v, t.shape) for ax, (_, v, _) in zip(self.axes, cols)], axis=1)
        directions = np.stack([ax.sign * np.broadcast_to(d, t.shape) for ax, (_, _, d) in zip(self.axes, cols)],
                              axis=1)
        return angles, np.radians(rates), directions

    def _attitude(self, t: np.ndarray, rates: np.ndarray, angles: np.ndarray | None = None,
                  directions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sensor -> world rotations (N, 3, 3), specific force (N, 3) in g0 and body rate (N, 3) rad/s (the
        kinematic ``angles`` and ``directions`` at ``t`` when the caller has them)."""
        if self.geometry is not None:
            if angles is None or directions is None:
                angles, directions = self.angles_deg_at(t), self.directions_at(t)
            r, w = self.geometry.attitude(self.tilt_matrix(), angles, directions, rates)
            if self.pose_error_deg:
                r = self.placement(angles) @ r
            f = self.geometry.gravity_g0() * (np.transpose(r, (0, 2, 1)) @ np.array([0.0, 0.0, 1.0]))
            return r, f, w
        deg = self.angles_deg_at(t) if angles is None else angles
        ang = np.radians(deg)
        rz, rx, ry = rot_z(ang[:, 0]), rot_x(ang[:, 1]), rot_y(ang[:, 2])
        r = self.tilt_matrix() @ rz @ rx @ ry  # (N,3,3) sensor -> world
        if self.pose_error_deg:
            r = self.placement(deg) @ r
        f = np.transpose(r, (0, 2, 1)) @ np.array([0.0, 0.0, 1.0])
        # body angular rate: w = Ry^T Rx^T (a1' e_z) + Ry^T (a2' e_x) + a3' e_y
        ryt = np.transpose(ry, (0, 2, 1))
        rxt = np.transpose(rx, (0, 2, 1))
        w = (ryt @ rxt @ np.array([0.0, 0.0, 1.0])) * rates[:, 0:1]
        w += (ryt @ np.array([1.0, 0.0, 0.0])) * rates[:, 1:2]
        w += np.array([0.0, 1.0, 0.0]) * rates[:, 2:3]
        return r, f, w

    def temp_c_at(self, t_s: np.ndarray) -> np.ndarray:
        """The sensor's temperature at clock times ``t_s`` (N,), C: the ``temp_c`` of :meth:`__call__` alone."""
        return self.chamber.temp_at(t_s)

    def advance(self, t_s: np.ndarray) -> np.ndarray:
        """Go through clock times ``t_s`` whose samples nobody sees: the ringing's state follows the stages' motion
        there (as in :meth:`__call__`); returns the sensor temperature at those times (N,), C."""
        t = np.atleast_1d(np.asarray(t_s, float))
        self._note_motion(t, np.any(np.abs(np.radians(self.rates_deg_s_at(t))) > 1e-9, axis=1))
        return self.chamber.temp_at(t)

    def _note_motion(self, t: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """The time of the most recent moving sample at or before each of ``t`` (-inf before any), remembered
        for the next call."""
        last = np.where(moving, t, -np.inf)
        last = np.maximum.accumulate(np.concatenate(([self._last_moving_t], last)))[1:]
        if len(t):
            self._last_moving_t = float(last[-1])
        return last

    def _rest_key(self, t: np.ndarray, rates: np.ndarray) -> bytes | None:
        """The table's pose through the block ``t`` when it is at rest there (no stage turning at any of its
        times, the same angles and last directions at its first and last), as a key of the attitude's memo;
        None while it moves. The stages' trapezoidal profiles cannot leave and come back between two samples
        of zero speed, so the block's two ends stand for all of it."""
        if rates.any():
            return None
        ends = t[[0, -1]]
        deg = self.angles_deg_at(ends)
        if not (deg[0] == deg[1]).all():
            return None
        d = self.directions_at(ends) if self.geometry is not None else np.ones((2, 3))
        if not (d[0] == d[1]).all():
            return None
        return self._memo_key(b"angles", np.concatenate([deg[0], d[0]]))

    def _static_attitude(self, key: bytes, t0: np.ndarray, rate0: np.ndarray) -> tuple:
        """(f, w, m) of one sample at rest, remembered by the pose's key: a dwell of many reads evaluates its
        attitude once (the memo is bounded: a long session visits many poses)."""
        memo = self._memo
        entry = memo.get(key)
        if entry is None or entry[0] is not self.geometry or entry[1] is not self.magnetic_field:
            if len(memo) >= 512:
                memo.clear()
            r, f, w = self._attitude(t0, rate0)
            m = np.transpose(r, (0, 2, 1)) @ self.magnetic_field.world_vector_ut()
            entry = memo[key] = (self.geometry, self.magnetic_field, (f, w, m))
        return entry[2]

    def _resting_key(self, t0: float) -> bytes | None:
        """:meth:`_rest_key` from the stages' own word that they stand still from ``t0`` on (each link's
        ``rest_pose``), without evaluating their motion at the block's samples; None when a link cannot say or
        a stage moves."""
        poses = []
        for ax in self.axes:
            pose = None if ax.rest_pose is None else ax.rest_pose(t0)
            if pose is None:
                return None
            poses.append(pose)
        return self._memo_key(b"stages", np.asarray(poses, float))

    def _memo_key(self, kind: bytes, pose: np.ndarray) -> bytes:
        """The attitude memo's key: how the pose was read (``kind``), the pose, the base's tilt and the pose_error
        effect; the geometry and the magnetic field (frozen) are checked by identity (:meth:`_static_attitude`)."""
        return (kind + pose.tobytes() + np.asarray(self.table_tilt_deg, float).tobytes()
                + np.float64(self.pose_error_deg).tobytes())

    def __call__(self, t_s: np.ndarray) -> PhysicsBatch:
        t = np.atleast_1d(np.asarray(t_s, float))
        key = self._resting_key(float(t[0]))
        angles = directions = None
        if key is not None:
            rates = np.zeros((len(t), 3))
        else:
            angles, rates, directions = self._kinematics(t)
            key = self._rest_key(t, rates)
        if key is not None:  # the table at rest: one attitude for the whole block
            f, w, m = (np.repeat(x, len(t), axis=0) for x in self._static_attitude(key, t[:1], rates[:1]))
        else:
            r, f, w = self._attitude(t, rates, angles, directions)
            m = np.transpose(r, (0, 2, 1)) @ self.magnetic_field.world_vector_ut()
        f = f + self._ringing(t, np.any(np.abs(rates) > 1e-9, axis=1))
        return PhysicsBatch(specific_force_g=f, angular_rate_dps=np.degrees(w),
                            magnetic_field_ut=m, temp_c=self.chamber.temp_at(t))

    def _ringing(self, t: np.ndarray, moving: np.ndarray) -> np.ndarray:
        out = np.zeros((len(t), 3))
        cfg = self.ringing
        if cfg.amplitude_g <= 0:
            return out
        last = self._note_motion(t, moving)  # time of the most recent moving sample at or before each sample
        dt = t - last
        ok = np.isfinite(dt) & ~moving
        amp = np.zeros(len(t))
        amp[ok] = cfg.amplitude_g * np.exp(-dt[ok] / cfg.tau_s) * np.sin(2 * np.pi * cfg.freq_hz * dt[ok])
        out += amp[:, None] * np.array([0.6, 0.6, 0.5])
        return out
