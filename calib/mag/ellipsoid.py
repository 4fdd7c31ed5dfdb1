"""The field-ellipsoid fit with the magnetometer's offset wander between the steps.

:func:`calib.numerics.magnitude.fit_magnitude` fits ``|U (m_k - b)| = |h|`` to the step means weighing each
step by its own standard error. The offset of a magnetometer wanders (flicker, random walk:
:class:`calib.numerics.stability.BiasStability`), common to steps close in time and different between
distant ones, so the step means are correlated. Linearised about the fit, the residual
``r_k = |U (m_k - b)| - |h|`` moves by ``g_k . dm_k`` with ``g_k = U^T f_k / |f_k|`` (``f_k = U (m_k - b)``),
and the residuals' covariance is

    V_kl = delta_kl sum_a (g_ka sem_ka)^2 + W_kl (g_k . g_l)     (W: the wander, uT^2, per axis)

:func:`fit_ellipsoid` minimises ``r^T V^-1 r`` (Levenberg-Marquardt on the residuals whitened by V's
Cholesky factor, V evaluated at the weighted fit and once more at the result), the nonlinear
counterpart of :func:`calib.numerics.design.solve_gls`. Parameters and units as ``fit_magnitude``.
"""

from __future__ import annotations

import numpy as np

from calib.numerics.design import misfit
from calib.errors import ObservabilityError
from calib.numerics.magnitude import MISFIT_P, MagnitudeFit, fit_magnitude, matrix_sigma

_IU = np.triu_indices(3)
#: times V is evaluated at the current solution and the whitened fit redone
PASSES = 2


def _unpack(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Offset b (3,) and upper-triangular U (3, 3) from the parameter vector [b, U upper triangle]."""
    u = np.zeros((3, 3))
    u[_IU] = p[3:9]
    return p[:3], u


def _calibrated(p: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``f_k = U (m_k - b)`` (K, 3), uT."""
    b, u = _unpack(p)
    return (m - b) @ u.T


def residual_covariance(p: np.ndarray, m: np.ndarray, sem: np.ndarray, wander: np.ndarray) -> np.ndarray:
    """(K, K) covariance (uT^2) of the residuals ``|U (m_k - b)| - |h|`` at parameters ``p``, from the
    step means' standard errors ``sem`` (K, 3) and the offset wander ``wander`` (K, K), uT^2."""
    _, u = _unpack(p)
    f = _calibrated(p, m)
    g = (f / np.maximum(np.linalg.norm(f, axis=1), 1e-12)[:, None]) @ u  # rows: U^T f / |f|
    return np.diag(np.sum((g * sem) ** 2, axis=1)) + wander * (g @ g.T)


def _whitened_fit(p0: np.ndarray, m: np.ndarray, radius: float, chol: np.ndarray):
    """Levenberg-Marquardt of the residuals whitened by ``chol`` from ``p0``."""
    def whitened(p):
        return np.linalg.solve(chol, np.linalg.norm(_calibrated(p, m), axis=1) - radius)
    from scipy.optimize import least_squares  # deferred: 0.2 s to import; only a magnetometer fit needs it
    return least_squares(whitened, p0, method="lm", x_scale="jac", max_nfev=2000)


def fit_ellipsoid(mean_ut, sem_ut, field_ut: float, wander_ut2: np.ndarray | None = None) -> MagnitudeFit:
    """Fit ``|U (m - b)| = field_ut`` to step means ``mean_ut`` (K, 3), uT, with standard errors
    ``sem_ut`` (K, 3), uT, and the offset wander between the steps ``wander_ut2`` (K, K), uT^2 (None:
    :func:`calib.numerics.magnitude.fit_magnitude`'s weighted fit alone). The sigmas come from the whitened
    Jacobian, rescaled by chi2/dof only when the misfit is significant (as ``fit_magnitude``)."""
    first = fit_magnitude(mean_ut, sem_ut, radius=field_ut)
    if wander_ut2 is None:
        return first
    m, sem = np.asarray(mean_ut, float), np.asarray(sem_ut, float)
    p = np.concatenate([first.bias, np.linalg.inv(first.matrix)[_IU]])
    for _ in range(PASSES):
        chol = np.linalg.cholesky(residual_covariance(p, m, sem, np.asarray(wander_ut2, float)))
        sol = _whitened_fit(p, m, field_ut, chol)
        p = sol.x
    return _result(sol, m, field_ut, first.converged and bool(sol.success))


def _result(sol, m: np.ndarray, radius: float, converged: bool) -> MagnitudeFit:
    """The :class:`calib.numerics.magnitude.MagnitudeFit` of a whitened solution."""
    k, n_par = len(m), len(sol.x)
    chi2, dof = float(np.sum(sol.fun**2)), k - n_par
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac)
    except np.linalg.LinAlgError:
        raise ObservabilityError("the static intervals do not determine the model (singular Jacobian)") from None
    if misfit(chi2, dof, MISFIT_P)[0]:
        cov = cov * chi2 / dof
    b, u = _unpack(sol.x)
    mat = np.linalg.inv(u)
    resid = np.linalg.norm(_calibrated(sol.x, m), axis=1) - radius
    return MagnitudeFit(matrix=mat, bias=b, radius=float(radius), cov=cov,
                        residual_rms=float(np.sqrt(np.mean(resid**2))),
                        chi2_per_dof=chi2 / dof if dof > 0 else float("nan"), n_intervals=k, converged=converged,
                        sigma_bias=np.sqrt(np.diag(cov)[:3]), sigma_matrix=matrix_sigma(mat, cov[3:9, 3:9]))
