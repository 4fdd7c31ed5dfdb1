"""Affine least squares ``y = P x + c`` (3 outputs, 3 inputs), shared by the gyroscope (``counts = M w + b``)
and the magnetometer (``m = A h + B``) solvers, and the array check of their step-mean inputs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from calib.design import session_rule, solve_wls
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


@dataclass(frozen=True)
class AffineFit:
    """Weighted least-squares fit of ``y_k = P @ x_k + c`` (3 outputs, 3 inputs).

    Attributes
    ----------
    matrix : (3, 3) P, units of y per unit of x.
    offset : (3,) c, units of y.
    axis_fits : one :class:`calib.design.AxisFit` per output axis, parameters ``[P_i0, P_i1, P_i2, c_i]``.
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


def fit_affine(x: np.ndarray, y: np.ndarray, sem: np.ndarray, param_names: list[list[str]]) -> AffineFit:
    """Fit ``y = P x + c`` per output axis with :func:`calib.design.solve_wls` (weights 1/sem).

    The caller checks observability first (:func:`input_coverage`).
    """
    g = affine_design(x)
    fits = session_rule([solve_wls(g, y[:, i], sem[:, i], param_names[i]) for i in range(3)])
    p = np.array([f.params[:3] for f in fits])
    c = np.array([f.params[3] for f in fits])
    chi2 = sum(f.chi2 for f in fits)
    dof = sum(f.dof for f in fits)
    res = np.column_stack([f.residuals for f in fits])
    return AffineFit(p, c, tuple(fits), res, chi2 / dof if dof > 0 else float("nan"))

