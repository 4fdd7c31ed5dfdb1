"""The turntable's geometry: three stacked stages with their own errors, and the sensor in its fixture.

Each stage ``i`` (a1 outer and vertical, a2 middle about x, a3 inner about y, ``docs/kinematics.md``)
turns the platform it carries by its *true* angle

    theta_true = theta + zero_offset + P sin(2 pi theta / period + phi_p) + A sin(theta + phi_a) - d L / 2

(``theta`` the commanded angle, P the worm-gear periodic error of one worm turn, A the accumulated error of
the wheel's once-per-revolution eccentricity, ``d`` = +1 or -1 the direction the motor last turned and ``L``
the lost motion on reversal), about an axis that is a little off nominal: the brackets that stack the
stages leave a2's axis tilted towards z by ``delta_12`` and a3's towards x by ``delta_23`` and towards z by
``delta_13`` (the three inter-axis non-orthogonalities), and each axis wobbles (a tilt of magnitude ``w``
whose direction turns once per revolution). The sensor sits on a3's platform rotated by its mounting angles
(about its x, y, z), and gravity is the site's, not 1 g0:

    R = R_tilt S1 S2 S3 M          sensor -> world,   f = (g / g0) R^T e_z   (g0 units)

with ``S_i = W_i(theta) B_i Rot_axis_i(theta_true) B_i^T``. The simulated rig's world model evaluates it
(``rig.simulation.geometry``), and the uncertainty budget propagates the table's error classes through it
(``calib.accel.budget``). Pure numpy.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from functools import cached_property

import numpy as np

from calib.numerics.gravity import G0_M_S2


def _rot(axis: int, angle_rad) -> np.ndarray:
    """Rotation matrices (N, 3, 3) about the coordinate axis ``axis`` (0 x, 1 y, 2 z) by angles in rad."""
    a = np.atleast_1d(np.asarray(angle_rad, float))
    c, s = np.cos(a), np.sin(a)
    out = np.zeros((len(a), 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[:, axis, axis] = 1.0
    out[:, i, i], out[:, j, j], out[:, i, j], out[:, j, i] = c, c, -s, s
    return out


def rot_x(angle_rad):
    return _rot(0, angle_rad)


def rot_y(angle_rad):
    return _rot(1, angle_rad)


def rot_z(angle_rad):
    return _rot(2, angle_rad)


#: each stage's nominal axis in its parent frame (a1 z, a2 x, a3 y) and two unit vectors perpendicular to it
#: (the wobble's tilt directions)
_AXES = ((2, 0, 1), (0, 1, 2), (1, 2, 0))
_ROT = (rot_z, rot_x, rot_y)


def small_rotation(rv: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors ``rv`` (N, 3), rad (Rodrigues)."""
    rv = np.atleast_2d(np.asarray(rv, float))
    th = np.sqrt(np.einsum("ij,ij->i", rv, rv))
    k = np.divide(rv, th[:, None], out=np.zeros_like(rv), where=th[:, None] > 0)
    s, c = np.sin(th), np.cos(th)
    # R = c I + s [k]x + (1 - c) k k^T (Rodrigues; [k]x [k]x = k k^T - I)
    out = (1 - c)[:, None, None] * k[:, :, None] * k[:, None, :]
    sk = s[:, None] * k
    out[:, 0, 1] -= sk[:, 2]
    out[:, 0, 2] += sk[:, 1]
    out[:, 1, 2] -= sk[:, 0]
    out[:, 1, 0] += sk[:, 2]
    out[:, 2, 0] -= sk[:, 1]
    out[:, 2, 1] += sk[:, 0]
    for i in range(3):
        out[:, i, i] += c
    return out


@dataclass(frozen=True)
class StageErrors:
    """One stage's angular error, lost motion and wobble (deg; phases deg).

    Attributes
    ----------
    zero_offset_deg : the stage's zero against the kinematic zero (home sensor repeatability).
    periodic_deg, periodic_phase_deg, period_deg : worm-gear periodic error, amplitude and phase, of one worm
        turn (8MR191: 360 / 180 = 2 deg of table).
    accumulated_deg, accumulated_phase_deg : the wheel's once-per-revolution error (its eccentricity), amplitude.
    lost_motion_deg : the full lost motion on reversal: the table stands L/2 behind the motor in the direction
        the motor last turned.
    wobble_deg, wobble_phase_deg : tilt of the axis, turning once per revolution.
    """

    zero_offset_deg: float = 0.0
    periodic_deg: float = 0.0
    periodic_phase_deg: float = 0.0
    period_deg: float = 2.0
    accumulated_deg: float = 0.0
    accumulated_phase_deg: float = 0.0
    lost_motion_deg: float = 0.0
    wobble_deg: float = 0.0
    wobble_phase_deg: float = 0.0

    def angle_error_deg(self, theta_deg: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """True minus commanded stage angle (deg) at motor angles ``theta_deg`` after motion in ``direction``
        (+1 or -1)."""
        th = np.radians(theta_deg)
        return (self.zero_offset_deg
                + self.periodic_deg * np.sin(2 * np.pi * theta_deg / self.period_deg + np.radians(self.periodic_phase_deg))
                + self.accumulated_deg * np.sin(th + np.radians(self.accumulated_phase_deg))
                - 0.5 * self.lost_motion_deg * np.asarray(direction, float))

    def wobble(self, axis: int, theta_deg: np.ndarray) -> np.ndarray:
        """The wobble's rotation matrices (N, 3, 3) at stage angles ``theta_deg`` (N,) for stage ``axis``."""
        _, p, q = _AXES[axis]
        ang = np.radians(theta_deg + self.wobble_phase_deg)
        rv = np.zeros((len(ang), 3))
        w = np.radians(self.wobble_deg)
        rv[:, p], rv[:, q] = w * np.cos(ang), w * np.sin(ang)
        return small_rotation(rv)


@dataclass(frozen=True)
class TableGeometry:
    """The hidden geometry of the simulated turntable and the sensor's mounting (see the module docstring).

    Attributes
    ----------
    stages : the three stages' :class:`StageErrors`, a1..a3.
    non_orthogonality_deg : (delta_12, delta_23, delta_13): a2's axis tilted towards z; a3's towards x; a3's
        towards z (deg).
    mounting_deg : the sensor's rotation in its fixture about its x, y, z, deg.
    gravity_m_s2 : local gravity at the simulated site, m/s^2.
    """

    stages: tuple[StageErrors, StageErrors, StageErrors] = field(
        default_factory=lambda: (StageErrors(), StageErrors(), StageErrors()))
    non_orthogonality_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mounting_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gravity_m_s2: float = G0_M_S2

    # -- the constant matrices -------------------------------------------------------------------
    def brackets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """B1, B2, B3: each stage's nominal axis turned onto its true axis (in its parent frame)."""
        return self._brackets

    @cached_property
    def _brackets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # the simulated world asks at every block of samples: made once per geometry (a frozen dataclass)
        d12, d23, d13 = np.radians(self.non_orthogonality_deg)
        b2 = rot_y(-d12)[0]  # e_x -> (cos, 0, sin): towards +z
        b3 = rot_z(-d23)[0] @ rot_x(d13)[0]  # e_y -> towards +x and +z
        return np.eye(3), b2, b3

    def axes_in_parent(self) -> list[np.ndarray]:
        """Each stage's true unit axis in its parent frame."""
        return [b[:, _AXES[i][0]] for i, b in enumerate(self.brackets())]

    def mounting(self) -> np.ndarray:
        """M: sensor frame -> a3's platform frame."""
        return self._mounting

    @cached_property
    def _mounting(self) -> np.ndarray:
        mx, my, mz = np.radians(self.mounting_deg)
        return rot_x(mx)[0] @ rot_y(my)[0] @ rot_z(mz)[0]

    def gravity_g0(self) -> float:
        """Local gravity in g0."""
        return self.gravity_m_s2 / G0_M_S2

    # -- the world ---------------------------------------------------------------------------------
    def true_angles_deg(self, angles_deg: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """True kinematic angles (N, 3), deg, of commanded ones (N, 3) after motion in ``directions`` (N, 3)."""
        return np.stack([angles_deg[:, i] + s.angle_error_deg(angles_deg[:, i], directions[:, i])
                         for i, s in enumerate(self.stages)], axis=1)

    def stage_rotations(self, angles_deg: np.ndarray, directions: np.ndarray) -> list[np.ndarray]:
        """S1, S2, S3 (each (N, 3, 3)) at commanded angles (N, 3) after motion in ``directions`` (N, 3)."""
        true = np.radians(self.true_angles_deg(angles_deg, directions))
        out = []
        for i, (b, rot) in enumerate(zip(self.brackets(), _ROT)):
            turn = rot(true[:, i]) if i == 0 else b @ rot(true[:, i]) @ b.T  # B1 is the identity (brackets)
            stage = self.stages[i]
            out.append(stage.wobble(i, angles_deg[:, i]) @ turn if stage.wobble_deg else turn)
        return out

    def sensor_to_world(self, tilt: np.ndarray, angles_deg: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """R (N, 3, 3): sensor frame -> world, with the base ``tilt`` (3, 3)."""
        return self.attitude(tilt, angles_deg, directions, None)[0]

    def attitude(self, tilt: np.ndarray, angles_deg: np.ndarray, directions: np.ndarray,
                 rates: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`sensor_to_world` and :meth:`body_rate` (None without ``rates``) from one evaluation of the stages'
        rotations (the simulated world asks for both at every block of samples)."""
        s1, s2, s3 = self.stage_rotations(angles_deg, directions)
        r = tilt @ s1 @ s2 @ s3 @ self.mounting()
        return r, (None if rates is None else self._body_rate(s2, s3, rates))

    def body_rate(self, angles_deg: np.ndarray, directions: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """Angular rate (N, 3) in the sensor frame for stage rates ``rates`` (N, 3), in their unit (about the
        true axes; the wobble's and the angular errors' own rates neglected: below 1e-3 of the rate)."""
        _, s2, s3 = self.stage_rotations(angles_deg, directions)
        return self._body_rate(s2, s3, rates)

    def _body_rate(self, s2: np.ndarray, s3: np.ndarray, rates: np.ndarray) -> np.ndarray:
        u1, u2, u3 = self.axes_in_parent()
        s3t, s2t = np.transpose(s3, (0, 2, 1)), np.transpose(s2, (0, 2, 1))
        w = (s3t @ s2t @ u1) * rates[:, 0:1] + (s3t @ u2) * rates[:, 1:2] + u3[None, :] * rates[:, 2:3]
        return w @ self.mounting()  # rows: (M^T w)^T = w^T M

    def truth(self) -> dict:
        """Every hidden value, for ``sim_truth.yaml``."""
        d = asdict(self)
        d["stages"] = {name: s for name, s in zip(("a1", "a2", "a3"), d["stages"])}
        d["non_orthogonality_deg"] = dict(zip(("a1_a2", "a2_a3", "a1_a3"), self.non_orthogonality_deg))
        d["mounting_deg"] = dict(zip("xyz", self.mounting_deg))
        return d
