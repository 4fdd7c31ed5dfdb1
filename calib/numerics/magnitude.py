"""Calibration without known poses: the magnitude constraint (imu_tk / ArduPilot approach).

At rest the specific force has magnitude 1 g whatever the pose, so static
intervals in unknown poses still calibrate the sensor:

    f_i = U (a_i - b),   minimise  sum_i ((|f_i| - r) / sigma_i)^2

with ``U`` upper triangular (6 parameters: scale and the three misalignments
of the seed's triangular model, ``M = U^-1``) and ``b`` the bias (3). ``r`` is
1 g for an accelerometer; for a magnetometer ellipsoid the same code fits with
``r`` the local field magnitude. Levenberg-Marquardt (scipy), sigmas from
the Jacobian at the solution, scaled by chi2/dof when the misfit is significant.
Needs at least 9 static intervals in well-spread directions (ideally 20 or more).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.numerics.design import MISFIT_LEVEL, misfit
from calib.errors import ObservabilityError

MISFIT_P = MISFIT_LEVEL  # a misfit this improbable rescales the sigmas by chi2/dof (the one level)


@dataclass(frozen=True)
class MagnitudeFit:
    """Result of a magnitude-constraint fit (units of the input counts).

    matrix : (3, 3) M with a = M f + b (counts per unit of f).
    bias : (3,) counts.
    radius : the given magnitude of f.
    cov : covariance of the parameter vector [b (3), U upper triangle (6)].
    residual_rms : RMS of |f| - r over the intervals, units of f.
    chi2_per_dof, n_intervals, converged.
    """

    matrix: np.ndarray
    bias: np.ndarray
    radius: float
    cov: np.ndarray
    residual_rms: float
    chi2_per_dof: float
    n_intervals: int
    converged: bool
    sigma_bias: np.ndarray
    sigma_matrix: np.ndarray


_IU = np.triu_indices(3)
#: smallest singular value of the unit directions / sqrt(K): six faces give 0.58, one pose 0
MIN_DIRECTION_COVERAGE = 0.15


def _unpack(p, radius):
    b = p[:3]
    u = np.zeros((3, 3))
    u[_IU] = p[3:9]
    return b, u, radius


def fit_magnitude(mean_counts, sem_counts=None, *, radius: float = 1.0, min_intervals: int = 9) -> MagnitudeFit:
    """Fit ``|U (a - b)| = radius`` to interval means ``a`` (K, 3).

    ``radius`` is 1 (g) for an accelerometer; for a magnetometer the local field magnitude (uT)
    from a reference model, or 1 to get the soft-iron matrix up to scale.
    """
    if not radius > 0:
        raise ValueError("radius must be > 0")
    a = np.asarray(mean_counts, float)
    k = len(a)
    _check_intervals(a, min_intervals)
    sem = np.ones_like(a) if sem_counts is None else np.asarray(sem_counts, float)
    b0 = 0.5 * (a.max(axis=0) + a.min(axis=0))
    half = np.maximum(0.5 * (a.max(axis=0) - a.min(axis=0)), 1e-9)
    u0 = np.diag(radius / half)
    p0 = np.concatenate([b0, u0[_IU]])

    def residuals(p):
        b, u, r = _unpack(p, radius)
        f = (a - b) @ u.T
        norm = np.linalg.norm(f, axis=1)
        # sigma of |f| from the step means' standard errors, propagated along f
        unit = f / np.maximum(norm, 1e-12)[:, None]
        sig = np.sqrt(np.sum(((unit @ u) * sem) ** 2, axis=1))
        return (norm - r) / np.maximum(sig, 1e-15)

    from scipy.optimize import least_squares  # deferred: 0.2 s to import; only the magnitude method fits this way
    sol = least_squares(residuals, p0, method="lm", x_scale="jac", max_nfev=2000)
    p = sol.x
    jac = sol.jac
    keep = list(range(9))
    res = residuals(p)
    dof = k - jac.shape[1]
    chi2 = float(np.sum(res**2))
    try:
        cov_q = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        raise ObservabilityError("the static intervals do not determine the model (singular Jacobian)") from None
    if misfit(chi2, dof, MISFIT_P)[0]:  # Birge ratio only for a significant misfit, as calib.numerics.design
        cov_q = cov_q * chi2 / dof
    cov = np.zeros((len(p), len(p)))
    cov[np.ix_(keep, keep)] = cov_q
    b, u, r = _unpack(p, radius)
    m = np.linalg.inv(u)
    sig_m = matrix_sigma(m, cov[3:9, 3:9])
    f = (a - b) @ u.T
    resid = np.linalg.norm(f, axis=1) - r
    _check_coverage(f)
    return MagnitudeFit(matrix=m, bias=b, radius=float(r), cov=cov, residual_rms=float(np.sqrt(np.mean(resid**2))),
                        chi2_per_dof=chi2 / dof if dof > 0 else float("nan"), n_intervals=k,
                        converged=bool(sol.success), sigma_bias=np.sqrt(np.diag(cov)[:3]), sigma_matrix=sig_m)


def _check_intervals(a: np.ndarray, min_intervals: int) -> None:
    """Enough interval means (K, 3), not all in one plane."""
    k, n_par = len(a), 9
    if k < max(min_intervals, n_par + 1):
        raise ObservabilityError(f"the magnitude method needs at least {max(min_intervals, n_par + 1)} static "
                                 f"intervals in different directions; got {k}")
    spread = np.linalg.svd(a - a.mean(axis=0), compute_uv=False)
    if spread[-1] < 1e-3 * spread[0]:
        raise ObservabilityError("the static intervals lie in a plane: turn the sensor through all three axes")


def matrix_sigma(m: np.ndarray, cov_u: np.ndarray) -> np.ndarray:
    """1-sigma (3, 3) of ``M = U^-1`` by first-order propagation (``dM = -M dU M``) of U's (6, 6) covariance."""
    jm = np.zeros((9, 6))
    for j, (r_, c_) in enumerate(zip(*_IU)):
        du = np.zeros((3, 3))
        du[r_, c_] = 1.0
        jm[:, j] = (-m @ du @ m).ravel()
    return np.sqrt(np.maximum(np.diag(jm @ cov_u @ jm.T), 0)).reshape(3, 3)


def _check_coverage(f: np.ndarray) -> None:
    """The calibrated directions (K, 3) must cover the sphere, or scale and bias trade off freely."""
    k = len(f)
    unit = f / np.maximum(np.linalg.norm(f, axis=1), 1e-12)[:, None]
    coverage = float(np.linalg.svd(unit, compute_uv=False)[-1] / np.sqrt(k))
    if coverage < MIN_DIRECTION_COVERAGE:
        raise ObservabilityError(f"the {k} static intervals do not point in enough different directions (coverage "
                                 f"{coverage:.2f} < {MIN_DIRECTION_COVERAGE}): turn the sensor so each axis points up "
                                 "and down in some of them")
