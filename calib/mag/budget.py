"""The magnetometer's uncertainty budget on a turntable, positions method (docs/uncertainty.md, "The magnetometer").

The positions method solves ``m = A h + B`` with ``h`` the field each pose should put in the sensor frame. A pose
that lands turned by small angles ``delta`` (sensor frame) puts ``h - delta x h`` there instead, so every step mean
moves by ``-A (delta x h)``, which the solve's linear map ``L`` (generalised least squares per output axis, the
weights of :func:`calib.numerics.affine.fit_affine`) carries into the parameters. Two kinds of ``delta``:

- the **frame**: the sensor's mounting in its fixture and the stages' zeros, the same rotation at every pose (three
  angles of standard uncertainty ``TableClass.frame_u_rad``): mostly the rotation ``A R^T`` the matrix takes in;
- the **poses**: each pose's own error (the stages' periodic and accumulated errors, wobble, the brackets'
  non-orthogonality, lost motion of unknown sign when poses are reached from either side), independent from pose
  to pose (three angles of ``pose_u_rad`` and lost motion's ``lost_motion_u_rad`` each), which moves the hard iron
  too.

First order (hundredths of a degree), the classes as they are on a characterised rig too (the characterisation
corrects the accelerometer's static poses, not the magnetometer's). The ellipsoid method has no poses, and none of
this. Pure.
"""

from __future__ import annotations

import numpy as np

from calib.frames import SENSOR_AXES
from calib.mag.inputs import MagStepMeans
from calib.mag.result import MagCalibration, sigma_names
from calib.numerics.affine import affine_design, step_covariance
from calib.numerics.budget import DEFAULT_K, Contribution, RigErrors, budget_section

FRAME = "rig frame (mounting, stage zeros)"
POSES = "rig poses (stage errors, wobble, non-orthogonality, lost motion)"


def linear_maps(steps: MagStepMeans) -> list[np.ndarray]:
    """Per output axis, the solve's map (4, K) from the step means to ``[a_i x, a_i y, a_i z, hard_iron_i]``."""
    g = affine_design(steps.field_nominal_ut)
    wander = steps.wander_ut2()
    maps = []
    for i in range(len(SENSOR_AXES)):
        w = np.linalg.inv(step_covariance(np.asarray(steps.sem_ut, float)[:, i], wander))
        maps.append(np.linalg.solve(g.T @ w @ g, g.T @ w))
    return maps


def _names(i: int) -> list[str]:
    return [f"a_{SENSOR_AXES[i]}{c}" for c in SENSOR_AXES] + [f"hard_iron_{SENSOR_AXES[i]}"]


def contributions(cal: MagCalibration, steps: MagStepMeans, rig: RigErrors) -> list[Contribution]:
    """Type A (the solve's sigma) and the table's frame and pose terms, in the parameters' units (``a_*`` -,
    ``hard_iron_*`` uT)."""
    h = np.asarray(steps.field_nominal_ut, float)
    a = np.asarray(cal.matrix, float)
    maps = linear_maps(steps)
    table = rig.table
    u_frame = table.frame_u_rad()
    u_pose = float(np.hypot(table.pose_u_rad(), table.lost_motion_u_rad(rig.one_direction)))
    turned = [-np.cross(np.eye(3)[c], h) for c in range(3)]  # (K, 3) uT per rad of a turn about sensor axis c
    frame2 = {n: 0.0 for n in sigma_names()}
    pose2 = dict(frame2)
    for i in range(3):
        names = _names(i)
        for dh in turned:
            r = dh @ a[i]  # (K,) the output axis' step means per rad
            for n, v in zip(names, maps[i] @ r):  # the same turn at every pose
                frame2[n] += (u_frame * v) ** 2
            for n, col in zip(names, maps[i] * r):  # (4, K): each pose's own turn alone
                pose2[n] += float(np.sum((u_pose * col) ** 2))
    return [Contribution("noise and wander", "A", "the solve's sigma (step scatter, offset wander)", dict(cal.sigma)),
            Contribution(FRAME, "B", f"the sensor's mounting and the stages' zeros at their classes: {u_frame:.3g} rad "
                         "about each axis, the same at every pose", {n: float(np.sqrt(v)) for n, v in frame2.items()},
                         "rectangular"),
            Contribution(POSES, "B", f"each pose's own error at the classes: {u_pose:.3g} rad about each axis, "
                         "independent from pose to pose", {n: float(np.sqrt(v)) for n, v in pose2.items()})]


def uncertainty_section(cal: MagCalibration, steps: MagStepMeans, rig: RigErrors, k: float = DEFAULT_K) -> dict:
    """``magnetometer.uncertainty`` of a positions solve: ``U = k u_c`` in ``sigma``'s keys, ``k``, where the rig's
    figures come from, the combined standard uncertainty and the ``budget``."""
    return budget_section(contributions(cal, steps, rig), sigma_names(), k,
                          f"{rig.source} (the table's classes: the positions are not re-placed)")
