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
    """A climate chamber whose setpoint the runner can change.

    The sensor temperature relaxes exponentially to the setpoint from
    wherever it was when the setpoint changed; ``temp_at`` is exact and
    vectorised.
    """

    def __init__(self, clock, config: ChamberConfig = ChamberConfig()) -> None:
        self.clock = clock
        self.config = config
        # segments: (start time s, temperature at start C, setpoint C)
        self._segments: list[tuple[float, float, float]] = [
            (-np.inf, config.initial_c, config.initial_c)]
        self.setpoint_c = config.initial_c

    def set_target_c(self, target_c: float) -> None:
        """Change the chamber setpoint now."""
        t = self.clock.now()
        now_c = float(self.temp_at(np.array([t]))[0])
        self._segments.append((t, now_c, float(target_c)))
        self.setpoint_c = float(target_c)

    def temp_at(self, t_s: np.ndarray) -> np.ndarray:
        """Sensor temperature at clock times ``t_s``, C."""
        t = np.atleast_1d(np.asarray(t_s, float))
        starts = np.array([s[0] for s in self._segments])
        idx = np.searchsorted(starts, t, side="right") - 1
        idx = np.clip(idx, 0, len(self._segments) - 1)
        seg = np.array([(s[0] if np.isfinite(s[0]) else 0.0, s[1], s[2]) for s in self._segments])
        t0, c0, cset = seg[idx, 0], seg[idx, 1], seg[idx, 2]
        dt = np.maximum(t - t0, 0.0)
        out = cset + (c0 - cset) * np.exp(-dt / self.config.tau_s)
        first = ~np.isfinite(starts[idx])
        out[first] = self._segments[0][1]
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


@dataclass
class WorldModel:
    """Physics source for the simulated sensor (a ``PhysicsSource``)."""

    axes: Sequence[AxisLink]
    chamber: SimChamber
    table_tilt_deg: tuple[float, float] = (0.0, 0.0)
    magnetic_field: FieldConfig = dataclasses.field(default_factory=FieldConfig)
    ringing: RingingConfig = dataclasses.field(default_factory=RingingConfig)
    _last_moving_t: float = -np.inf

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

    def tilt_matrix(self) -> np.ndarray:
        tx, ty = np.radians(self.table_tilt_deg)
        return rot_x(np.array([tx]))[0] @ rot_y(np.array([ty]))[0]

    def __call__(self, t_s: np.ndarray) -> PhysicsBatch:
        t = np.atleast_1d(np.asarray(t_s, float))
        ang = np.radians(self.angles_deg_at(t))
        rates = np.radians(self.rates_deg_s_at(t))
        rz, rx, ry = rot_z(ang[:, 0]), rot_x(ang[:, 1]), rot_y(ang[:, 2])
        r = self.tilt_matrix() @ rz @ rx @ ry  # (N,3,3) sensor -> world
        rt = np.transpose(r, (0, 2, 1))
        f = rt @ np.array([0.0, 0.0, 1.0])
        # body angular rate: w = Ry^T Rx^T (a1' e_z) + Ry^T (a2' e_x) + a3' e_y
        ryt = np.transpose(ry, (0, 2, 1))
        rxt = np.transpose(rx, (0, 2, 1))
        w = (ryt @ rxt @ np.array([0.0, 0.0, 1.0])) * rates[:, 0:1]
        w += (ryt @ np.array([1.0, 0.0, 0.0])) * rates[:, 1:2]
        w += np.array([0.0, 1.0, 0.0]) * rates[:, 2:3]
        f = f + self._ringing(t, np.any(np.abs(rates) > 1e-9, axis=1))
        m = rt @ self.magnetic_field.world_vector_ut()
        return PhysicsBatch(specific_force_g=f, angular_rate_dps=np.degrees(w),
                            magnetic_field_ut=m, temp_c=self.chamber.temp_at(t))

    def _ringing(self, t: np.ndarray, moving: np.ndarray) -> np.ndarray:
        out = np.zeros((len(t), 3))
        cfg = self.ringing
        if cfg.amplitude_g <= 0:
            return out
        # time of the most recent moving sample at or before each sample
        last = np.where(moving, t, -np.inf)
        last = np.maximum.accumulate(np.concatenate(([self._last_moving_t], last)))[1:]
        if len(t):
            self._last_moving_t = float(last[-1])
        dt = t - last
        ok = np.isfinite(dt) & ~moving
        amp = np.zeros(len(t))
        amp[ok] = cfg.amplitude_g * np.exp(-dt[ok] / cfg.tau_s) * np.sin(2 * np.pi * cfg.freq_hz * dt[ok])
        out += amp[:, None] * np.array([0.6, 0.6, 0.5])
        return out
