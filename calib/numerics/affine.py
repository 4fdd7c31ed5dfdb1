"""Affine least squares ``y = P x + c`` (3 outputs, 3 inputs), shared by the gyroscope (``counts = M w + b``)
and the magnetometer (``m = A h + B``) solvers, and the array checks of their step-mean inputs.

With the sensor's bias wander between the steps (:mod:`calib.numerics.wander`) the fit is generalised least
squares, ``V = diag(sem^2) + W`` per output axis (axes independent, W common to them), as the
accelerometer's solver (docs/methods.md, "Per-step standard errors")."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from calib.numerics.design import session_rule, solve_gls, solve_wls
from calib.errors import CalibError

def check_array(owner: str, name: str, value: Any, shape: tuple, positive: bool = False) -> np.ndarray:
    """Return ``value`` as a float array of ``shape``; raise :class:`CalibError` otherwise.

    ``owner`` and ``name`` go into the one-line message (``Owner.name: expected ...``).
    """
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise CalibError(f"{owner}.{name}: expected a numeric array of shape {shape}") from None
    if v.shape != shape:
        raise CalibError(f"{owner}.{name}: expected shape {shape}, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise CalibError(f"{owner}.{name}: contains NaN or infinity")
    if positive and not np.all(v > 0):
        raise CalibError(f"{owner}.{name}: every value must be > 0")
    return v


def check_times(owner: str, k: int, t_s: Any, duration_s: Any) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The steps' mid-times ``t_s`` (K,) (s) and capture durations ``duration_s`` (K,) (s, >= 0) as
    float arrays, or None where not given; :class:`CalibError` naming ``owner`` otherwise."""
    t = None if t_s is None else check_array(owner, "t_s", t_s, (k,))
    d = None if duration_s is None else check_array(owner, "duration_s", duration_s, (k,))
    if d is not None and np.any(d < 0):
        raise CalibError(f"{owner}.duration_s: every duration must be >= 0 s")
    return t, d


def step_covariance(sem: np.ndarray, wander: np.ndarray | None) -> np.ndarray:
    """(K, K) covariance of one output axis' step means: ``diag(sem^2)`` plus the wander (K, K) (same
    units squared; None: none)."""
    v = np.diag(np.asarray(sem, float) ** 2)
    return v if wander is None else v + wander


def solve_axis(g: np.ndarray, y: np.ndarray, sem: np.ndarray, wander: np.ndarray | None, names: list[str]):
    """One output axis: weighted least squares (``wander`` None) or generalised least squares with
    :func:`step_covariance` (:func:`calib.numerics.design.solve_gls`)."""
    if wander is None:
        return solve_wls(g, y, sem, names)
    return solve_gls(g, y, step_covariance(sem, wander), names)


@dataclass(frozen=True)
class AffineFit:
    """Weighted least-squares fit of ``y_k = P @ x_k + c`` (3 outputs, 3 inputs).

    Attributes
    ----------
    matrix : (3, 3) P, units of y per unit of x.
    offset : (3,) c, units of y.
    axis_fits : one :class:`calib.numerics.design.AxisFit` per output axis, parameters ``[P_i0, P_i1, P_i2, c_i]``.
    residuals : (K, 3) y - P x - c, units of y.
    chi2_per_dof : total chi-square over total degrees of freedom (nan when dof = 0).
    """

    matrix: np.ndarray
    offset: np.ndarray
    axis_fits: tuple
    residuals: np.ndarray
    chi2_per_dof: float


def affine_design(x: np.ndarray) -> np.ndarray:
    """(K, 4) design ``[x_x, x_y, x_z, 1]`` shared by every output axis."""
    return np.column_stack([np.asarray(x, float), np.ones(len(x))])


def input_coverage(x: np.ndarray, rel_tol: float = 1e-9) -> tuple[list[int], bool]:
    """Which input axes the rows leave undetermined, and whether ``[x, 1]`` has full rank.

    Returns
    -------
    missing : input-axis indices never excited (every |x_j| tiny compared with max |x|).
    full_rank : True when the (K, 4) design ``[x, 1]`` determines all 4 parameters.
    """
    x = np.asarray(x, float)
    scale = float(np.max(np.abs(x))) if x.size else 0.0
    missing = [j for j in range(3) if x.size == 0 or np.max(np.abs(x[:, j])) <= rel_tol * max(scale, 1e-300)]
    g = affine_design(x)
    if g.shape[0] < 4:
        return missing, False
    norm = np.linalg.norm(g, axis=0)
    norm[norm == 0] = 1.0
    sv = np.linalg.svd(g / norm, compute_uv=False)
    return missing, bool(sv[-1] > 1e-10 * sv[0])


def fit_affine(x: np.ndarray, y: np.ndarray, sem: np.ndarray, param_names: list[list[str]],
               wander: np.ndarray | None = None) -> AffineFit:
    """Fit ``y = P x + c`` per output axis, with the Birge rule decided on the session
    (:func:`calib.numerics.design.session_rule`).

    Parameters
    ----------
    x : (K, 3) inputs; y : (K, 3) step means; sem : (K, 3) their standard errors (units of y).
    param_names : per output axis, the names of ``[P_i0, P_i1, P_i2, c_i]``.
    wander : (K, K) covariance of the sensor's bias wander between the step means, units of y
        squared, common to the three output axes (:mod:`calib.numerics.wander`); None: weights 1/sem only.

    The caller checks observability first (:func:`input_coverage`).
    """
    g = affine_design(x)
    fits = session_rule([solve_axis(g, y[:, i], sem[:, i], wander, param_names[i]) for i in range(3)])
    p = np.array([f.params[:3] for f in fits])
    c = np.array([f.params[3] for f in fits])
    chi2 = sum(f.chi2 for f in fits)
    dof = sum(f.dof for f in fits)
    res = np.column_stack([f.residuals for f in fits])
    return AffineFit(p, c, tuple(fits), res, chi2 / dof if dof > 0 else float("nan"))

