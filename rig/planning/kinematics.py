"""Kinematics contract of the three-axis turntable (docs/kinematics.md).

Stages a1 (outer, vertical), a2 (middle), a3 (inner, carries the sensor).
``R = Rz(a1) Rx(a2) Ry(a3)`` maps sensor-frame vectors to the world frame
(Z up). The nominal specific force at rest is ``f = R^T e_z`` in g:
``f = (-sin a3 cos a2, sin a2, cos a3 cos a2)``; the seed's roll is a3 and
its pitch is a2.
"""

from __future__ import annotations

import numpy as np

#: The turntable's axes, outer to inner (the one definition; everything else imports it).
STAGE_AXES: tuple[str, str, str] = ("a1", "a2", "a3")


#: (row, column) of cos, -sin, sin and 1 in a rotation about each axis
_LAYOUT = {"x": ((1, 1), (2, 2), (1, 2), (2, 1), (0, 0)),
           "y": ((0, 0), (2, 2), (2, 0), (0, 2), (1, 1)),
           "z": ((0, 0), (1, 1), (0, 1), (1, 0), (2, 2))}


def _stack(c, s, kind):
    c = np.atleast_1d(np.asarray(c, float))
    s = np.atleast_1d(np.asarray(s, float))
    (c1, c2, neg, pos, one) = _LAYOUT[kind]
    out = np.zeros(c.shape + (3, 3))
    out[..., c1[0], c1[1]] = c
    out[..., c2[0], c2[1]] = c
    out[..., neg[0], neg[1]] = -s
    out[..., pos[0], pos[1]] = s
    out[..., one[0], one[1]] = 1.0
    return out


def rot_x(angle_rad):
    """Rotation matrices about x for angles in radians: (N, 3, 3)."""
    return _stack(np.cos(angle_rad), np.sin(angle_rad), "x")


def rot_y(angle_rad):
    """Rotation matrices about y for angles in radians: (N, 3, 3)."""
    return _stack(np.cos(angle_rad), np.sin(angle_rad), "y")


def rot_z(angle_rad):
    """Rotation matrices about z for angles in radians: (N, 3, 3)."""
    return _stack(np.cos(angle_rad), np.sin(angle_rad), "z")


def sensor_to_world(angles_deg) -> np.ndarray:
    """R = Rz(a1) Rx(a2) Ry(a3) for angles (N, 3) or (3,), deg; returns (N, 3, 3)."""
    a = np.radians(np.atleast_2d(np.asarray(angles_deg, float)))
    return rot_z(a[:, 0]) @ rot_x(a[:, 1]) @ rot_y(a[:, 2])


def f_nominal(angles_deg) -> np.ndarray:
    """Nominal specific force at rest in the sensor frame, g.

    Parameters
    ----------
    angles_deg : array (3,) or (N, 3)
        Kinematic angles a1, a2, a3, deg.

    Returns
    -------
    array (3,) or (N, 3)
    """
    arr = np.asarray(angles_deg, float)
    a = np.radians(np.atleast_2d(arr))
    a2, a3 = a[:, 1], a[:, 2]
    f = np.stack([-np.sin(a3) * np.cos(a2), np.sin(a2), np.cos(a3) * np.cos(a2)], axis=1)
    f[np.abs(f) < 1e-15] = 0.0
    return f[0] if arr.ndim == 1 else f


def angles_for_direction(f_dir, a1_deg: float = 0.0) -> np.ndarray:
    """Angles (a1, a2, a3), deg, that put the specific force along ``f_dir`` (sensor frame).

    a1 is free (it turns about the vertical and does not change f); a2 in
    [-90, 90], a3 in (-180, 180].
    """
    d = np.asarray(f_dir, float)
    n = np.linalg.norm(d)
    if not n > 0:
        raise ValueError("direction must be non-zero")
    d = d / n
    a2 = np.degrees(np.arcsin(np.clip(d[1], -1.0, 1.0)))
    a3 = np.degrees(np.arctan2(-d[0], d[2])) if np.hypot(d[0], d[2]) > 1e-12 else 0.0
    return np.array([float(a1_deg), a2 + 0.0, a3 + 0.0])


def roll_pitch_deg(f) -> tuple[np.ndarray, np.ndarray]:
    """The seed's Euler-Krylov roll (psi) and pitch (theta) from specific force, deg.

    psi = -atan(gx/gz), theta = atan(gy / (gz cos psi - gx sin psi)), quadrant-safe.
    """
    f = np.atleast_2d(np.asarray(f, float))
    gx, gy, gz = f[:, 0], f[:, 1], f[:, 2]
    psi = np.arctan2(-gx, gz)
    theta = np.arctan2(gy, gz * np.cos(psi) - gx * np.sin(psi))
    return np.degrees(psi), np.degrees(theta)
