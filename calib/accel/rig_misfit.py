"""Is a turntable session's misfit more than its rig's own errors explain? (docs/uncertainty.md, "Misfit and the rig")

A turntable does not put the sensor exactly at its nominal poses: its stages' angular errors, lost motion, wobble,
the brackets' non-orthogonality and the sensor's mounting move every pose by a few hundredths of a degree, which
at 8,000 counts/g is a few counts, several times a six-position step's noise. The solve's chi-square judges the
residuals against the noise alone (:meth:`calib.accel.result.AccelCalibration.misfit`), so on such a rig it says
"misfit" for every session, and a real missing effect is no longer told apart from the table.

Here the same residuals are judged against the noise *and* the rig's errors at their standard uncertainties (the
classes, or a characterisation's estimates: :class:`calib.numerics.budget.RigErrors`, the parameters of
:func:`calib.accel.rig_propagation.rig_parameters`). The solve is a linear map of the step means (pinv and
combinations: :class:`calib.accel.budget.LinearSolve`), so its residuals are ``r = (I - H) y`` with ``H`` the
hat matrix of each axis, and for step means of covariance ``C = C_noise + J U^2 J^T`` (``J``: the step means'
response to each rig parameter, counts per deg, ``U``: its standard uncertainty) the residuals have covariance
``S = (I - H) C (I - H)^T`` of rank ``dof``. ``r^T S^+ r`` is chi-square on ``dof`` when the model is right and the
rig's errors are what its budget says (normal errors; the classes' rectangular ones are close enough for a tail
test). With the rig's errors at zero this is the solve's own chi-square (the same residuals and covariance).

The rig's errors are systematic (the same table gives the same errors every run), so a table much worse than its
classes still shows as a misfit here: what it should.

Pure numpy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from calib.accel.inputs import StepMeans
from calib.accel.rig_propagation import pose_angles_deg, pose_shifts, stacked_parameters
from calib.accel.solve import axis_wander_counts2, wander_covariance, weighs_wander
from calib.numerics.budget import RigErrors
from calib.numerics.design import MISFIT_LEVEL, SENSOR_AXES, misfit

#: the most steps judged so (a dense (3K, 3K) covariance and its eigendecomposition: 0.1 s at 200 steps, minutes at
#: 1,500); a longer session's calibration file has no ``misfit_with_rig`` and its misfit is judged against the noise
MAX_STEPS = 200
#: eigenvalues of the residual covariance below this fraction of the largest are its null space (the fitted
#: directions: exactly zero in exact arithmetic)
RANK_TOLERANCE = 1e-10


@dataclass(frozen=True)
class RigMisfit:
    """The fit judged against the noise and the rig's errors: ``chi2`` on ``dof``, its upper-tail probability
    ``p``, and whether that is a misfit at the solvers' level (``significant``)."""

    chi2: float
    dof: int
    p: float
    significant: bool

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else float("nan")

    def as_dict(self) -> dict:
        """The calibration file's ``accelerometer.uncertainty.misfit_with_rig``."""
        return {"chi2_per_dof": float(self.chi2_per_dof), "dof": int(self.dof), "p": float(self.p),
                "significant": bool(self.significant)}


def has_pose_errors(rig: RigErrors) -> bool:
    """Whether the rig moves any pose: a class or a characterised value other than zero (the period is no error)."""
    table = dataclasses.asdict(rig.table)
    return any(v for name, v in table.items() if name != "period_deg") or any(rig.known.values())


def noise_covariances(steps: StepMeans) -> list[np.ndarray]:
    """Each output axis' covariance (K, K) of the step means, counts^2, as the solve weighed them: the steps'
    standard errors, and the bias wander between their windows where the solve took it (at most
    :data:`~calib.accel.solve.MAX_WANDER_STEPS` steps, a bias stability known)."""
    sem = np.asarray(steps.sem_counts, float)
    wander = weighs_wander(steps)
    w_axes = axis_wander_counts2(steps) if wander else None
    return [wander_covariance(steps, sem[:, j], w_axes[j]) if wander else np.diag(sem[:, j] ** 2)
            for j in range(len(SENSOR_AXES))]


def rig_step_covariance(steps: StepMeans, rig: RigErrors, matrix_counts_per_g) -> np.ndarray:
    """Covariance (3K, 3K) of the step means (axis-major: x of every step, then y, then z), counts^2, from the
    rig's errors at their standard uncertainties: ``sum_p u_p^2 j_p j_p^T``, ``j_p`` the step means' response to
    parameter ``p`` per deg (the sensitivity ``matrix_counts_per_g`` times the pose's shift)."""
    k = len(steps)
    angles = pose_angles_deg(steps)
    m = np.asarray(matrix_counts_per_g, float)
    params, per_pose = stacked_parameters(steps, rig)  # lost motion of unknown sign: a column per pose and stage
    cols = []
    for p, shift in zip(params, pose_shifts(params, angles)):  # shift: (K, 3) g per deg
        counts = shift @ m.T * p.u_deg  # (K, 3) counts at one standard uncertainty
        if per_pose and p.name.startswith("lost_motion."):
            for j in range(k):  # pose j's own lost motion moves pose j alone
                alone = np.zeros_like(counts)
                alone[j] = counts[j]
                cols.append(alone.T.reshape(-1))
        else:
            cols.append(counts.T.reshape(-1))  # (3K,) axis-major
    if not cols:
        return np.zeros((3 * k, 3 * k))
    j = np.stack(cols, axis=1)
    return j @ j.T


def rig_misfit(linear, steps: StepMeans, rig: RigErrors, matrix_counts_per_g,
               level: float = MISFIT_LEVEL) -> RigMisfit | None:
    """The residuals of ``linear``'s solve (:class:`calib.accel.budget.LinearSolve`, of ``steps``) judged against
    the step means' noise and the rig's errors (:func:`rig_step_covariance`); None beyond :data:`MAX_STEPS`."""
    k = len(steps)
    if k > MAX_STEPS:
        return None
    y = np.asarray(steps.mean_counts, float)
    blocks, residuals = [], []
    for j, a in enumerate(SENSOR_AXES):
        d = linear.designs[a]
        hat = d @ linear.maps[a]  # (K, K): the fitted step means from the step means
        blocks.append(np.eye(k) - hat)
        residuals.append(y[:, j] - d @ linear.params[a])
    proj = np.zeros((3 * k, 3 * k))
    for j, b in enumerate(blocks):
        proj[j * k:(j + 1) * k, j * k:(j + 1) * k] = b
    cov = rig_step_covariance(steps, rig, matrix_counts_per_g)
    for j, c in enumerate(noise_covariances(steps)):
        cov[j * k:(j + 1) * k, j * k:(j + 1) * k] += c
    s = proj @ cov @ proj.T
    values, vectors = np.linalg.eigh(0.5 * (s + s.T))
    keep = values > RANK_TOLERANCE * max(float(values[-1]), 1e-300)
    dof = int(np.count_nonzero(keep))
    r = np.concatenate(residuals)
    chi2 = float(np.sum((vectors[:, keep].T @ r) ** 2 / values[keep]))
    significant, p = misfit(chi2, dof, level)
    return RigMisfit(chi2, dof, p, significant)
