"""The rig's own errors propagated into a calibration (docs/uncertainty.md, "The rig's errors").

Every error of the turntable's geometry (:mod:`calib.numerics.turntable`) is one parameter with a standard
uncertainty from the rig's classes (or from its characterisation, :attr:`RigErrors.known`): the sensor's
mounting about x, y, z and the stage zeros, the three non-orthogonalities, each stage's periodic and
accumulated angular error and wobble (each a sinusoid of the stage angle: its sine and cosine coefficients,
of random phase), and the lost motion (per pose and stage when poses are reached from either side; a constant
per stage when every pose is approached from one side). Each parameter moves the session's poses through the
same chain the simulated world uses, *correlated* between poses as on the table (a stage zero turns every pose
that stage reaches), and the session is solved again with its nominal specific force moved the other way:
the solve's own sensitivity, whatever its method and model. Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from calib.numerics.budget import RigErrors, rectangular
from calib.numerics.turntable import StageErrors, TableGeometry

STAGES = ("a1", "a2", "a3")
#: finite-difference step, deg (about 1.7e-5 rad: linear, far above the solve's rounding)
EPS_DEG = 1e-3
#: contribution name -> the distribution its parameters have (calib.numerics.budget.DISTRIBUTIONS)
GROUPS = {"rig frame (mounting, stage zeros)": "rectangular", "rig axes (non-orthogonality)": "rectangular",
          "stage angular errors and wobble": "normal", "lost motion": "normal"}


@dataclass(frozen=True)
class RigParameter:
    """One geometry error: its ``name`` (``mounting.x``, ``zero_offset.a3``, ``periodic_sin.a2``,
    ``lost_motion.a3@4``, ...), its contribution ``group``, its standard uncertainty ``u_deg`` and the table
    with it alone at ``EPS_DEG`` (``geometry``) with the arrival directions it needs (``directions``, (K, 3))."""

    name: str
    group: str
    u_deg: float
    geometry: TableGeometry
    directions: np.ndarray | None = None


def _stage(i: int, **errors) -> tuple:
    stages = [StageErrors(), StageErrors(), StageErrors()]
    stages[i] = StageErrors(**errors)
    return tuple(stages)


def _per_stage(t, k: int) -> list[RigParameter]:
    out = []
    sines = (("periodic", t.periodic_deg, "periodic_deg", "periodic_phase_deg"),
             ("accumulated", t.accumulated_deg, "accumulated_deg", "accumulated_phase_deg"),
             ("wobble", t.wobble_deg, "wobble_deg", "wobble_phase_deg"))
    for i, s in enumerate(STAGES):
        out.append(RigParameter(f"zero_offset.{s}", "rig frame (mounting, stage zeros)", rectangular(t.zero_offset_deg),
                                TableGeometry(stages=_stage(i, zero_offset_deg=EPS_DEG))))
        for kind, a, amp, phase in sines:
            for part, ph in (("sin", 0.0), ("cos", 90.0)):  # a sin(x + phi) = a cos(phi) sin x + a sin(phi) cos x
                geometry = TableGeometry(stages=_stage(i, **{amp: EPS_DEG, phase: ph, "period_deg": t.period_deg}))
                out.append(RigParameter(f"{kind}_{part}.{s}", "stage angular errors and wobble", a / math.sqrt(6),
                                        geometry))
    return out


def _lost_motion(t, k: int, one_direction: bool) -> list[RigParameter]:
    """Lost motion: -d L / 2 with L in [0, L_max] (sqrt(E[(L/2)^2]) = L_max / sqrt(12)); per pose and stage of
    unknown direction, or (approached from one side) the same for every pose of a stage."""
    u = t.lost_motion_deg / math.sqrt(12)
    out = []
    for i, s in enumerate(STAGES):
        geometry = TableGeometry(stages=_stage(i, lost_motion_deg=2 * EPS_DEG))
        poses = [None] if one_direction else range(k)
        for j in poses:
            d = np.zeros((k, 3))
            if j is None:
                d[:, i] = -1.0
            else:
                d[j, i] = -1.0
            out.append(RigParameter(f"lost_motion.{s}" + ("" if j is None else f"@{j + 1}"), "lost motion", u,
                                    geometry, d))
    return out


def rig_parameters(rig: RigErrors, k: int) -> list[RigParameter]:
    """Every geometry error of a session of ``k`` poses with its standard uncertainty (a characterised value
    from ``rig.known`` replaces its class)."""
    t = rig.table
    out = [RigParameter(f"mounting.{a}", "rig frame (mounting, stage zeros)", rectangular(t.mounting_deg),
                        TableGeometry(mounting_deg=tuple(EPS_DEG * (a == b) for b in "xyz"))) for a in "xyz"]
    names = ("a1_a2", "a2_a3", "a1_a3")
    out += [RigParameter(f"non_orthogonality.{n}", "rig axes (non-orthogonality)", rectangular(t.non_orthogonality_deg),
                         TableGeometry(non_orthogonality_deg=tuple(EPS_DEG * (n == m) for m in names))) for n in names]
    out += _per_stage(t, k) + _lost_motion(t, k, rig.one_direction)
    return [replace(p, u_deg=rig.known[p.name]) if p.name in rig.known else p for p in out]


def stage_angles_deg(f_nominal: np.ndarray) -> np.ndarray:
    """The stage angles (K, 3), deg, that put each nominal specific force up (a1 = 0: it does not change f;
    angles mod 360 are all the periodic errors see), by the kinematics contract."""
    f = np.asarray(f_nominal, float)
    f = f / np.linalg.norm(f, axis=1, keepdims=True)
    a2 = np.degrees(np.arcsin(np.clip(f[:, 1], -1, 1)))
    a3 = np.degrees(np.arctan2(-f[:, 0], f[:, 2]))
    return np.stack([np.zeros(len(f)), a2, a3], axis=1)


def pose_shift(parameter: RigParameter, angles_deg: np.ndarray) -> np.ndarray:
    """How far (K, 3) the parameter at ``EPS_DEG`` moves each pose's specific force, g0 per deg."""
    k = len(angles_deg)
    d = parameter.directions if parameter.directions is not None else np.zeros((k, 3))
    perfect = TableGeometry().sensor_to_world(np.eye(3), angles_deg, np.zeros((k, 3)))
    moved = parameter.geometry.sensor_to_world(np.eye(3), angles_deg, d)
    up = np.array([0.0, 0.0, 1.0])
    return (np.transpose(moved, (0, 2, 1)) @ up - np.transpose(perfect, (0, 2, 1)) @ up) / EPS_DEG
