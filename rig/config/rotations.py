"""Mounting rotations of a fixture slot (docs/fixture.md, "Mounting rotations").

A slot's rotation ``R`` takes a vector in the slot's frame (the sensor's axes as mounted in that slot)
to the turntable's frame: ``v_turntable = R @ v_slot``; its columns are the slot's x, y and z axes
written in turntable axes. The 24 rotations that map axes onto axes (the rotations of a cube) have
names of four characters: where the slot's +x points, then where its +z points, each a turntable
axis and a sign. ``"x+z+"`` is the identity; ``"y+z+"`` turns the slot 90 deg about z (its +x along
the table's +y); ``"x-z-"`` is 180 deg about y (upside down). +y follows (``z × x``), so every name
is a proper rotation. Any other rotation is given as a 3x3 matrix (rows of ``R``), accepted when it
is a proper rotation within :data:`TOLERANCE`.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

#: largest deviation of R R^T from the identity, and of det R from +1, a matrix may have
TOLERANCE = 1e-6
_AXES = {"x": 0, "y": 1, "z": 2}
_SIGNS = {"+": 1.0, "-": -1.0}


def _unit(axis: str, sign: str) -> np.ndarray:
    v = np.zeros(3)
    v[_AXES[axis]] = _SIGNS[sign]
    return v


def _from_name(name: str) -> np.ndarray:
    x, z = _unit(name[0], name[1]), _unit(name[2], name[3])
    return np.column_stack([x, np.cross(z, x), z])


#: the 24 cube rotations by name: "x+z+" (the identity) ... in a fixed order
CUBE_ROTATIONS: dict[str, np.ndarray] = {
    a + s + b + t: _from_name(a + s + b + t)
    for a, s, b, t in itertools.product("xyz", "+-", "xyz", "+-") if a != b}


def is_rotation_name(text) -> bool:
    """Whether ``text`` names one of the 24 cube rotations."""
    return isinstance(text, str) and text in CUBE_ROTATIONS


def rotation_problem(matrix) -> str | None:
    """Why ``matrix`` is not a proper rotation within :data:`TOLERANCE` (None: it is one).

    Parameters
    ----------
    matrix : array_like
        3x3, rows of R (dimensionless).
    """
    try:
        r = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError):
        return "expected a 3x3 list of numbers"
    if r.shape != (3, 3):
        return f"expected a 3x3 list of numbers, got shape {list(r.shape)}"
    if not np.all(np.isfinite(r)):
        return "expected finite numbers (no NaN or infinity)"
    off = float(np.max(np.abs(r @ r.T - np.eye(3))))
    if off > TOLERANCE:
        return (f"expected a rotation: R R^T differs from the identity by {off:.3g} (at most {TOLERANCE:g}; "
                "each row a unit vector, the rows perpendicular)")
    det = float(np.linalg.det(r))
    if abs(det - 1.0) > TOLERANCE:
        return f"expected a proper rotation (det +1), got det {det:+.6g}: a mirror image, not a mounting"
    return None


def name_of(matrix, tol: float = TOLERANCE) -> str | None:
    """The cube-rotation name of ``matrix`` (within ``tol`` per element), or None."""
    r = np.asarray(matrix, dtype=float)
    for name, m in CUBE_ROTATIONS.items():
        if np.max(np.abs(r - m)) <= tol:
            return name
    return None


def angle_deg(matrix) -> float:
    """The rotation angle of ``matrix`` about its axis, deg (0 .. 180)."""
    c = (float(np.trace(np.asarray(matrix, dtype=float))) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


#: axis name -> index, for :func:`about_axis`
AXIS_NAMES = tuple(_AXES)


def about_axis(axis: str, deg: float) -> np.ndarray:
    """The rotation by ``deg`` (right-handed) about the frame's ``axis`` ("x", "y" or "z"): 3x3, its columns the
    turned frame's axes in the unturned frame (as a cube rotation's; entries within 1e-15 of 0 or +-1 rounded)."""
    a = math.radians(float(deg))
    c, s = math.cos(a), math.sin(a)
    i = _AXES[axis]
    j, k = (i + 1) % 3, (i + 2) % 3
    r = np.eye(3)
    r[j, j], r[j, k], r[k, j], r[k, k] = c, -s, s, c
    return np.where(np.abs(r - np.round(r)) < 1e-15, np.round(r), r) + 0.0


def describe(matrix) -> str:
    """A turn in words: ``as placed`` (the identity), ``180 deg about z`` (a turn about a frame axis), else the
    angle and its axis to 3 digits."""
    r = np.asarray(matrix, dtype=float)
    angle = angle_deg(r)
    if angle < 1e-9:
        return "as placed"
    if angle > 180.0 - 1e-9:  # the axis: the column of (R + I) / 2 of largest norm
        axis = (r + np.eye(3))[:, int(np.argmax(np.linalg.norm(r + np.eye(3), axis=0)))]
    else:
        axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    axis = axis / np.linalg.norm(axis)
    for name, i in _AXES.items():
        if abs(abs(axis[i]) - 1.0) < 1e-9:
            sign = "" if axis[i] > 0 or angle > 180.0 - 1e-9 else "-"
            return f"{sign}{angle:.4g} deg about {name}"
    return f"{angle:.4g} deg about [{axis[0]:.3f}, {axis[1]:.3f}, {axis[2]:.3f}]"
