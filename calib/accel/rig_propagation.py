"""The rig's own errors propagated into a calibration (docs/uncertainty.md, "The rig's errors").

Every error of the turntable's geometry (:mod:`calib.numerics.turntable`) is one parameter with a standard
uncertainty from the rig's classes (or from its characterisation, :attr:`RigErrors.known`): the sensor's
mounting about x, y, z and the stage zeros, the three non-orthogonalities, each stage's periodic and
accumulated angular error and wobble (each a sinusoid of the stage angle: its sine and cosine coefficients,
of random phase), and the lost motion (per stage with the signs of the recorded arrival directions; per pose and
stage, of unknown sign, when they are not recorded; a constant per stage when every pose is approached from one
side). Each parameter moves the session's poses through the
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


def _lost_motion(t, k: int, one_direction: bool, arrival: np.ndarray | None = None) -> list[RigParameter]:
    """Lost motion: -d L / 2 with L in [0, L_max] (sqrt(E[(L/2)^2]) = L_max / sqrt(12)) and d the direction the stage
    arrived in. Approached from one side: a constant per stage (``one_direction``). Arrival directions recorded
    (``arrival``, (K, 3), 0 where unknown): one parameter per stage over the poses of known direction, with the
    recorded signs (the same L at every pose: a reversal moves a pose by L against the poses before it), and one
    over the poses before the stage's first recorded move (one unknown direction). Otherwise one per pose and stage,
    of unknown sign."""
    u = t.lost_motion_deg / math.sqrt(12)
    out = []
    for i, s in enumerate(STAGES):
        geometry = TableGeometry(stages=_stage(i, lost_motion_deg=2 * EPS_DEG))
        if arrival is not None and not one_direction:
            known = np.asarray(arrival, float)[:, i]
            for name, rows, sign in ((f"lost_motion.{s}", known != 0, known),
                                     (f"lost_motion.{s}@start", known == 0, -np.ones(k))):
                if np.any(rows):
                    d = np.zeros((k, 3))
                    d[rows, i] = sign[rows]
                    out.append(RigParameter(name, "lost motion", u, geometry, d))
            continue
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


def needs_arrival(rig: RigErrors) -> bool:
    """Whether a budget of ``rig`` would use a session's arrival directions (:func:`usable_arrival`): poses reached
    from either side on a table with lost motion (a class or a characterised value)."""
    lost = rig.table.lost_motion_deg > 0 or any(v for n, v in rig.known.items() if n.startswith("lost_motion"))
    return lost and not rig.one_direction and not rig.mixed_approach


def usable_arrival(steps, rig: RigErrors) -> np.ndarray | None:
    """The arrival directions the budget may use (:attr:`calib.accel.inputs.StepMeans.arrival_direction`): None
    when the session records none, when every pose is approached from one side (lost motion is then a constant)
    or when only some stages approach so (the recorded directions do not say how those arrived)."""
    arrival = getattr(steps, "arrival_direction", None)
    return None if arrival is None or rig.one_direction or rig.mixed_approach else np.asarray(arrival, float)


def stacked_parameters(steps, rig: RigErrors) -> tuple[list[RigParameter], bool]:
    """The rig's parameters of nonzero uncertainty for one pass of the table's chain over ``steps``' poses, and
    whether lost motion is of unknown sign at every pose (no usable arrival directions, :func:`usable_arrival`;
    poses reached from either side): each stage's lost motion is then one parameter moving every pose at once,
    row j standing for pose j's own independent one (a linear map takes each row apart)."""
    k = len(steps)
    arrival = usable_arrival(steps, rig)
    per_pose = not rig.one_direction and arrival is None
    if per_pose:
        params = [p if p.directions is None else replace(p, directions=np.repeat(p.directions[:1], k, axis=0))
                  for p in rig_parameters(replace(rig, one_direction=True), 1)]
    else:
        params = rig_parameters(rig, k, arrival)
    return [p for p in params if p.u_deg != 0], per_pose


def rig_parameters(rig: RigErrors, k: int, arrival: np.ndarray | None = None) -> list[RigParameter]:
    """Every geometry error of a session of ``k`` poses with its standard uncertainty (a characterised value
    from ``rig.known`` replaces its class); ``arrival``: the poses' recorded arrival directions
    (:attr:`calib.accel.inputs.StepMeans.arrival_direction`), when known."""
    t = rig.table
    out = [RigParameter(f"mounting.{a}", "rig frame (mounting, stage zeros)", rectangular(t.mounting_deg),
                        TableGeometry(mounting_deg=tuple(EPS_DEG * (a == b) for b in "xyz"))) for a in "xyz"]
    names = ("a1_a2", "a2_a3", "a1_a3")
    out += [RigParameter(f"non_orthogonality.{n}", "rig axes (non-orthogonality)", rectangular(t.non_orthogonality_deg),
                         TableGeometry(non_orthogonality_deg=tuple(EPS_DEG * (n == m) for m in names))) for n in names]
    out += _per_stage(t, k) + _lost_motion(t, k, rig.one_direction, arrival)
    return [replace(p, u_deg=rig.known[p.name]) if p.name in rig.known else p for p in out]


def stage_angles_deg(f_nominal: np.ndarray) -> np.ndarray:
    """The stage angles (K, 3), deg, that put each nominal specific force up (a1 = 0: it does not change f;
    angles mod 360 are all the periodic errors see), by the kinematics contract."""
    f = np.asarray(f_nominal, float)
    f = f / np.linalg.norm(f, axis=1, keepdims=True)
    a2 = np.degrees(np.arcsin(np.clip(f[:, 1], -1, 1)))
    a3 = np.degrees(np.arctan2(-f[:, 0], f[:, 2]))
    return np.stack([np.zeros(len(f)), a2, a3], axis=1)


def pose_angles_deg(steps) -> np.ndarray:
    """The stage angles (K, 3), deg, at which the table held each step of ``steps`` (a
    :class:`~calib.accel.inputs.StepMeans`): the recorded ones when the session has them, else
    :func:`stage_angles_deg` of the nominal specific force. The specific force does not say a3 where a2 = +-90 deg
    (a3 then turns about the vertical, as a1 always does): a pose moved off nominal by hundredths of a degree (a
    characterised table's corrected poses, ``Characterisation.corrected``) gets an arbitrary a3 from its f, and the
    table's errors at that a3 are not the ones that moved it."""
    recorded = getattr(steps, "angles_deg", None)
    return np.asarray(recorded, float) if recorded is not None else stage_angles_deg(steps.f_nominal_g)


def pose_shift(parameter: RigParameter, angles_deg: np.ndarray) -> np.ndarray:
    """How far (K, 3) the parameter at ``EPS_DEG`` moves each pose's specific force, g0 per deg (to first order:
    :func:`first_order_shift`; the table's errors are hundredths of a degree)."""
    return pose_shifts([parameter], angles_deg)[0]


def pose_shifts(parameters: list[RigParameter], angles_deg: np.ndarray) -> list[np.ndarray]:
    """:func:`pose_shift` of each parameter, the perfect table's chain at the poses built once."""
    chain = _Chain(angles_deg)
    k = len(chain.theta_deg)
    return [chain.shift(p.geometry, p.directions if p.directions is not None else np.zeros((k, 3))) / EPS_DEG
            for p in parameters]


def first_order_shift(geometry: TableGeometry, angles_deg: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """The specific force's change (K, 3), g0, that ``geometry``'s errors (small: first order) make at the
    commanded stage angles ``angles_deg`` (K, 3) after motion in ``directions`` (K, 3), against a perfect table.

    ``R = S1 S2 S3 M`` and ``f = R^T e_z``: an error that turns the chain by the small rotation vector ``w``
    between ``A`` and ``B`` (``R = A (I + [w]x) B``) moves ``f`` by ``-B^T (w x A^T e_z)``. Each stage's angular
    error turns about its own axis after its stage, its wobble before it (in its parent frame), a bracket
    ``b = I + [beta]x`` on both sides of its stage (``b S b^T``), the mounting after the whole chain. The same
    chain as :meth:`calib.numerics.turntable.TableGeometry.sensor_to_world` (tests/calib/test_rig_shift.py
    checks the two against each other); gravity and a base tilt are not pose errors and are left out."""
    return _Chain(angles_deg).shift(geometry, directions)


class _Chain:
    """The perfect table's chain at the poses: ``P_i = S_1 .. S_i``, ``Q_i = S_{i+1} .. S_3`` and ``a_i = P_i^T e_z``."""

    def __init__(self, angles_deg: np.ndarray) -> None:
        self.theta_deg = np.asarray(angles_deg, float)
        k = len(self.theta_deg)
        stages = TableGeometry().stage_rotations(self.theta_deg, np.zeros((k, 3)))
        prefix = [np.broadcast_to(np.eye(3), (k, 3, 3))]
        for si in stages:
            prefix.append(prefix[-1] @ si)
        suffix = [None, None, None, np.broadcast_to(np.eye(3), (k, 3, 3))]
        for i in (2, 1, 0):
            suffix[i] = stages[i] @ suffix[i + 1]
        self.suffix = suffix
        self.up = [np.transpose(p, (0, 2, 1))[:, :, 2] for p in prefix]

    def moved(self, w: np.ndarray, i: int) -> np.ndarray:
        """``R = P_i (I + [w]x) Q_i``: ``-Q_i^T (w x a_i)`` (K, 3)."""
        return -np.einsum("kji,kj->ki", self.suffix[i], _cross(w, self.up[i]))

    def shift(self, geometry: TableGeometry, directions: np.ndarray) -> np.ndarray:
        k = len(self.theta_deg)
        out = np.zeros((k, 3))
        beta = _bracket_vectors(geometry.non_orthogonality_deg)
        for i, st in enumerate(geometry.stages):
            theta = self.theta_deg[:, i]
            if st.zero_offset_deg or st.periodic_deg or st.accumulated_deg or st.lost_motion_deg:
                axis = np.zeros(3)
                axis[_NOMINAL_AXES[i]] = 1.0
                err = np.radians(st.angle_error_deg(theta, directions[:, i]))
                out += self.moved(err[:, None] * axis[None, :], i + 1)
            if st.wobble_deg:
                _, p, q = _WOBBLE_AXES[i]
                ang = np.radians(theta + st.wobble_phase_deg)
                w = np.zeros((k, 3))
                w[:, p], w[:, q] = np.radians(st.wobble_deg) * np.cos(ang), np.radians(st.wobble_deg) * np.sin(ang)
                out += self.moved(w, i)
            if beta[i] is not None:  # b S b^T = S + [beta]x S - S [beta]x
                b = np.broadcast_to(beta[i], (k, 3))
                out += self.moved(b, i) - self.moved(b, i + 1)
        if any(geometry.mounting_deg):
            m = np.radians(np.asarray(geometry.mounting_deg, float))
            out += self.moved(np.broadcast_to(m, (k, 3)), 3)
        return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (K, 3) arrays (np.cross costs 0.2 ms a call in axis handling)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


#: each stage's nominal axis (a1 z, a2 x, a3 y) and its wobble's two tilt directions (calib.numerics.turntable)
_NOMINAL_AXES = (2, 0, 1)
_WOBBLE_AXES = ((2, 0, 1), (0, 1, 2), (1, 2, 0))


def _bracket_vectors(non_orthogonality_deg) -> list:
    """Each stage's bracket as a small rotation vector, rad (None: none): B2 = rot_y(-d12), B3 = rot_z(-d23) rot_x(d13)."""
    d12, d23, d13 = (float(np.radians(v)) for v in non_orthogonality_deg)
    return [None, np.array([0.0, -d12, 0.0]) if d12 else None, np.array([d13, 0.0, -d23]) if (d13 or d23) else None]
