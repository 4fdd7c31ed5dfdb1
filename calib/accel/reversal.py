"""Rig characterisation by reversal (docs/uncertainty.md, "Characterisation by reversal").

One sensor recorded at the same table poses in two or more mountings in its fixture (for example turned
180 deg about its z axis between them): the table's errors (the fixture's misalignment, the stage zeros, the
non-orthogonalities) stay where they are, while the sensor's own errors turn with it. One least-squares fit
of every mounting's step means at once,

    counts_{m,i} = M Q_m^T (f_i + sum_j g_j s_ij) + b

(``M``, ``b`` the sensor's full matrix and bias; ``Q_m`` the known turn of mounting m; ``f_i`` the pose's
nominal specific force in the fixture frame; ``g_j`` the table's errors, deg, and ``s_ij`` how each moves
pose i, from the table's geometry chain, :func:`calib.accel.rig_propagation.pose_shift`), separates the two:
Gauss-Newton on the bilinear term, weighted by the step means' standard errors, the covariance scaled by
the Birge ratio when the fit is worse than its noise. The table's errors with their standard uncertainties
then replace their classes in every later budget on that rig (:attr:`RigErrors.known`).

Refused, with the reason: a single mounting (the table's errors and the sensor's are then the same
unknowns), mountings that do not separate them (named: the table errors no combination of the recordings
tells from the sensor's), mountings with different poses. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.accel.inputs import StepMeans
from calib.accel.rig_propagation import EPS_DEG, RigParameter, pose_angles_deg, pose_shifts, rig_parameters
from calib.errors import CalibError
from calib.numerics.budget import RigErrors

#: the table errors a reversal estimates (the others keep their classes: they change from pose to pose). Three
#: are left out because they are exactly others under other names, whatever the poses: a3's zero is the
#: fixture's turn about y (a3 turns about y); a3's axis tilted towards z by d (a1_a3) is a2's zero + d and the
#: fixture turned about x by -d (``Rx(d) Ry Rx(-d)``, a1 never changes f); a1's zero changes nothing. So
#: ``zero_offset.a2`` and ``mounting.x`` hold a1_a3, and ``mounting.y`` holds a3's zero; ``non_orthogonality.a1_a2``
#: holds a tilt of the table's base about y (the same rotation of every pose).
CHARACTERISED = ("mounting.x", "mounting.y", "mounting.z", "zero_offset.a2",
                 "non_orthogonality.a1_a2", "non_orthogonality.a2_a3")
#: the table errors that are characterised parameters under other names (see above): after a characterisation
#: they add nothing of their own to a budget
ALIASES = ("zero_offset.a1", "zero_offset.a3", "non_orthogonality.a1_a3")
#: relative singular value below which a direction of the unknowns counts as not determined
RANK_TOL = 1e-4
ITERATIONS = 4


@dataclass(frozen=True)
class Mounting:
    """One recording: the step means and the sensor's known turn in its fixture (``turn``: 3x3, sensor frame ->
    fixture frame; identity for the reference mounting)."""

    steps: StepMeans
    turn: np.ndarray


@dataclass(frozen=True)
class Characterisation:
    """The table's errors: ``estimate_deg`` and ``u_deg`` per parameter name, the fit's chi2/dof and dof.

    ``u_deg`` is each estimate's standard uncertainty as the table's own error: the fit's (the sensor's noise) and
    what the errors kept as classes put into it (:func:`_aliased`). ``u_correction_deg`` is the fit's alone: how
    well the estimate corrects the poses of a later session, whose budget keeps those classes as terms of their
    own (counted once there); None: as ``u_deg``."""

    estimate_deg: dict
    u_deg: dict
    chi2_per_dof: float
    dof: int
    u_correction_deg: dict | None = None

    def corrected(self, steps: StepMeans, rig: RigErrors) -> StepMeans:
        """``steps`` with their nominal specific force where the characterised table puts it (f + sum g_j s_ij):
        what a later calibration on this rig solves with, so the table's errors leave its estimates."""
        f = np.asarray(steps.f_nominal_g, float)
        angles = pose_angles_deg(steps)
        params = {p.name: p for p in rig_parameters(rig, len(f))}
        names = list(self.estimate_deg)
        shift = sum(self.estimate_deg[n] * s for n, s in zip(names, pose_shifts([params[n] for n in names], angles)))
        fields = {k: getattr(steps, k) for k in steps.__dataclass_fields__}
        return StepMeans(**{**fields, "f_nominal_g": f + shift})

    def rig_errors(self, rig: RigErrors, source: str) -> RigErrors:
        """``rig`` with these parameters' residual standard uncertainties in place of their classes."""
        return RigErrors(table=rig.table, gravity=rig.gravity, one_direction=rig.one_direction,
                         mixed_approach=rig.mixed_approach, thermometer_u_c=rig.thermometer_u_c,
                         known={**rig.known, **dict.fromkeys(ALIASES, 0.0), **(self.u_correction_deg or self.u_deg)},
                         source=source)


def _check(mountings: list[Mounting]) -> np.ndarray:
    if len(mountings) < 2:
        raise CalibError("reversal: one mounting only: the table's errors and the sensor's are the same unknowns; "
                         "record the same poses again with the sensor turned in its fixture (e.g. 180 deg about z)")
    f0 = np.asarray(mountings[0].steps.f_nominal_g, float)
    for i, m in enumerate(mountings[1:], 2):
        if np.shape(m.steps.f_nominal_g) != f0.shape or not np.allclose(m.steps.f_nominal_g, f0, atol=1e-9):
            raise CalibError(f"reversal: mounting {i} was recorded at other poses than mounting 1: every mounting "
                             "needs the same table poses")
    return f0


def _design(mountings, f, shifts, m0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows (3 per step and mounting) of the linearised model in (M row-major 9, b 3, g J), data, weights."""
    rows, y, w = [], [], []
    for mt in mountings:
        q = np.asarray(mt.turn, float)
        x = f @ q  # (K, 3): Q^T f_i as rows
        sx = np.einsum("jkc,cd->jkd", shifts, q)  # (J, K, 3): Q^T s_ij
        for i in range(len(f)):
            for a in range(3):
                row = np.zeros(12 + len(shifts))
                row[3 * a:3 * a + 3] = x[i]
                row[9 + a] = 1.0
                row[12:] = sx[:, i, :] @ m0[a]
                rows.append(row)
                y.append(mt.steps.mean_counts[i, a])
                w.append(1.0 / mt.steps.sem_counts[i, a] ** 2)
    return np.array(rows), np.array(y), np.array(w)


def _undetermined(a: np.ndarray, w: np.ndarray, names: list[str]) -> list[str]:
    """The table errors in the directions the weighted design does not determine."""
    aw = a * np.sqrt(w)[:, None]
    scale = np.linalg.norm(aw, axis=0)
    scale[scale == 0] = 1.0
    _, sv, vt = np.linalg.svd(aw / scale, full_matrices=False)
    weak = vt[sv < RANK_TOL * sv[0]]
    if not len(weak):
        return []
    load = np.max(np.abs(weak[:, 12:]), axis=0)
    return [n for n, v in zip(names, load) if v > 0.1] or ["the sensor's matrix and bias"]


def _aliased(mountings, f, angles, m0, a, w, normal, rig: RigErrors) -> np.ndarray:
    """The covariance the table errors left as classes (periodic, accumulated, wobble, lost motion: the same at a
    pose in every mounting) put into the estimates: each moves the data as a column of the design would, the
    fit takes part of it into the characterised parameters (a2's periodic error at the recorded a2 angles is a
    zero offset of a2 there), by its class's standard uncertainty. Without it a2's zero came out 3.5 u from the
    hidden value on the simulated table."""
    others = [p for p in rig_parameters(rig, len(f)) if p.name not in CHARACTERISED and p.name not in ALIASES
              and p.u_deg > 0]
    if not others:
        return np.zeros_like(normal)
    shifts = np.array(pose_shifts(others, angles))
    columns = _design(mountings, f, shifts, m0)[0][:, 12:]
    gain = np.linalg.solve(normal, (a * w[:, None]).T @ columns) * np.array([p.u_deg for p in others])
    return gain @ gain.T


def characterise(mountings: list[Mounting], rig: RigErrors) -> Characterisation:
    """The table's errors (:data:`CHARACTERISED`) from recordings of one sensor in two or more mountings."""
    f = _check(mountings)
    params: list[RigParameter] = [p for p in rig_parameters(rig, len(f)) if p.name in CHARACTERISED]
    angles = pose_angles_deg(mountings[0].steps)  # every mounting at the same table poses (_check)
    shifts = np.array(pose_shifts(params, angles))  # (J, K, 3) per deg
    names = [p.name for p in params]
    m0 = np.eye(3) * float(np.median(np.abs(mountings[0].steps.mean_counts)))
    x = None
    for _ in range(ITERATIONS):
        a, y, w = _design(mountings, f, shifts, m0)
        missing = _undetermined(a, w, names)
        if missing:
            raise CalibError("reversal: these mountings do not separate the table from the sensor: "
                             f"{', '.join(missing)} undetermined; turn the sensor about another axis between "
                             "mountings (180 deg about z separates the fixture's tilt; add one about x for the rest)")
        sw = np.sqrt(w)
        x, *_ = np.linalg.lstsq(a * sw[:, None], y * sw, rcond=None)
        m0 = x[:9].reshape(3, 3)
    a, y, w = _design(mountings, f, shifts, m0)
    resid = (y - a @ x) * np.sqrt(w)
    dof = len(y) - len(x)
    chi2 = float(resid @ resid / dof) if dof > 0 else float("nan")
    normal = (a * w[:, None]).T @ a
    cov_fit = np.linalg.inv(normal) * (max(chi2, 1.0) if np.isfinite(chi2) else 1.0)
    cov = cov_fit + _aliased(mountings, f, angles, m0, a, w, normal, rig)
    g, u, u_fit = x[12:], np.sqrt(np.diag(cov)[12:]), np.sqrt(np.diag(cov_fit)[12:])
    return Characterisation(estimate_deg=dict(zip(names, map(float, g))), u_deg=dict(zip(names, map(float, u))),
                            chi2_per_dof=chi2, dof=dof, u_correction_deg=dict(zip(names, map(float, u_fit))))


__all__ = ["CHARACTERISED", "Characterisation", "EPS_DEG", "Mounting", "characterise"]
