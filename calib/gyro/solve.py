"""Gyroscope solver: 12-parameter weighted least squares over the rate steps, and the seed's +/- pairs."""

from __future__ import annotations

import numpy as np

from calib.affine import fit_affine, input_coverage
from calib.design import session_rule, solve_wls
from calib.errors import ObservabilityError
from calib.gyro.inputs import RateStepMeans
from calib.gyro.result import AXES, OFF_DIAGONAL, BiasPair, GyroCalibration, param_names


def find_bias_pairs(steps: RateStepMeans, rel_tol: float = 1e-6) -> list[BiasPair]:
    """Zero-rate outputs from every pair of steps with opposite nominal rates.

    Each step is used at most once; steps with zero rate are skipped. For a pair
    ``b = (a_plus + a_minus) / 2`` and ``sigma = sqrt(sem_plus^2 + sem_minus^2) / 2`` (counts).
    """
    w = steps.rate_nominal_dps
    used = np.zeros(len(steps), bool)
    pairs = []
    for i in range(len(steps)):
        ri = float(np.linalg.norm(w[i]))
        if used[i] or ri == 0:
            continue
        for j in range(i + 1, len(steps)):
            if not used[j] and np.linalg.norm(w[i] + w[j]) <= rel_tol * ri:
                used[i] = used[j] = True
                dominant = np.abs(w[i]) / ri
                axis = AXES[int(np.argmax(dominant))] if dominant.max() > 1 - 1e-6 else "xyz"
                bias = 0.5 * (steps.mean_counts[i] + steps.mean_counts[j])
                sig = 0.5 * np.sqrt(steps.sem_counts[i] ** 2 + steps.sem_counts[j] ** 2)
                pairs.append(BiasPair(axis_spun=axis, rate_dps=ri, bias_counts=bias, sigma_counts=sig))
                break
    return pairs


def _check_observable(w: np.ndarray) -> None:
    missing, full = input_coverage(w)
    if missing:
        names = "".join(AXES[j] for j in missing)
        about = " or ".join(AXES[j] for j in missing)
        scales = ", ".join(f"k_{AXES[j]}" for j in missing)
        couplings = ", ".join(f"m_{AXES[i]}{AXES[j]}" for j in missing for i in range(3) if i != j)
        raise ObservabilityError(f"the rate steps never spin about {about}: scale {scales} and couplings "
                                 f"{couplings} undetermined; add rate steps about {names if len(names) == 1 else ' and '.join(names)}")
    if not full:
        raise ObservabilityError(f"the {len(w)} rate steps do not determine the 12 gyro parameters (the rates "
                                 "with a constant column are rank-deficient); spin each axis both ways, e.g. "
                                 "+-25, +-40, +-63 deg/s about x, y and z")


def _sigmas(matrix: np.ndarray, fits: tuple) -> dict:
    """1-sigma of b, k (= M_ii) and m_ij = M_ij / M_ii from each output axis' covariance."""
    sig = {}
    for i in range(3):
        c = fits[i].cov  # parameters [M_i0, M_i1, M_i2, b_i]
        sig[f"b_{AXES[i]}"] = float(np.sqrt(c[3, 3]))
        sig[f"k_{AXES[i]}"] = float(np.sqrt(c[i, i]))
    for i, j in OFF_DIAGONAL:
        c = fits[i].cov
        mii, mij = matrix[i, i], matrix[i, j]
        grad = np.zeros(c.shape[0])
        grad[j] = 1.0 / mii
        grad[i] = -mij / mii**2
        sig[f"m_{AXES[i]}{AXES[j]}"] = float(np.sqrt(max(grad @ c @ grad, 0.0)))
    return {n: sig[n] for n in param_names()}


def solve_gyro(steps: RateStepMeans) -> GyroCalibration:
    """Solve the 12-parameter gyro model ``counts = M w + b`` from rate-step means.

    Parameters
    ----------
    steps : :class:`RateStepMeans` (true rates in the sensor frame, deg/s; means in counts).

    Returns
    -------
    :class:`GyroCalibration` with M and b from weighted least squares over all steps
    (per output axis, columns ``[w_x, w_y, w_z, 1]``, weights 1/sem; covariance
    not rescaled by chi2/dof, see :func:`calib.design.solve_wls`),
    and the + / - pair zero-rate outputs of the seed method for comparison.

    Raises
    ------
    ObservabilityError when the steps do not spin about all three axes, or the
    rates with a constant column are rank-deficient.
    """
    w = steps.rate_nominal_dps
    _check_observable(w)
    g_inputs = g_sensitivity_inputs(steps)
    if g_inputs:
        return _solve_with_g(steps, g_inputs)
    names = [[f"M_{AXES[i]}{a}" for a in AXES] + [f"b_{AXES[i]}"] for i in range(3)]
    fit = fit_affine(w, steps.mean_counts, steps.sem_counts, names)
    m, b = fit.matrix, fit.offset
    res_dps = np.linalg.solve(m, fit.residuals.T).T
    nonorth = {f"m_{AXES[i]}{AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
    return GyroCalibration(
        lsb_per_dps=steps.lsb_per_dps, matrix_counts_per_dps=m, bias_counts=b,
        scale_counts_per_dps=np.diag(m).copy(), nonorthogonality=nonorth, sigma=_sigmas(m, fit.axis_fits),
        bias_pairs=find_bias_pairs(steps), residual_rms_dps=float(np.sqrt(np.mean(res_dps**2))),
        chi2_per_dof=fit.chi2_per_dof, n_steps=len(steps))


#: an input component of the specific force must vary by this much over the rate steps (g) for its
#: column of the g-sensitivity to be determined (e.g. z spins with z up vs x/y spins where gravity turns)
G_SPREAD_MIN = 0.5


def g_sensitivity_inputs(steps: RateStepMeans) -> list[int]:
    """Input axes whose g-sensitivity column the steps determine (empty without ``f_mean_g``)."""
    if steps.f_mean_g is None:
        return []
    return [k for k in range(3) if np.ptp(steps.f_mean_g[:, k]) >= G_SPREAD_MIN]


def _solve_with_g(steps: RateStepMeans, g_inputs: list[int]) -> GyroCalibration:
    """``counts = M w + b + G f``: the 12 parameters plus the determined columns of G (counts per g)."""
    w, f = steps.rate_nominal_dps, steps.f_mean_g
    design = np.column_stack([w, np.ones(len(w))] + [f[:, k] for k in g_inputs])
    fits = []
    for i in range(3):
        nm = [f"M_{AXES[i]}{a}" for a in AXES] + [f"b_{AXES[i]}"] + [f"G_{AXES[i]}{AXES[k]}" for k in g_inputs]
        fits.append(solve_wls(design, steps.mean_counts[:, i], steps.sem_counts[:, i], nm))
    fits = session_rule(fits)
    m = np.array([ft.params[:3] for ft in fits])
    b = np.array([ft.params[3] for ft in fits])
    gm, gs = np.zeros((3, 3)), np.zeros((3, 3))
    for i, ft in enumerate(fits):
        for n, k in enumerate(g_inputs):
            gm[i, k] = ft.params[4 + n]
            gs[i, k] = np.sqrt(ft.cov[4 + n, 4 + n])
    res = np.column_stack([ft.residuals for ft in fits])
    res_dps = np.linalg.solve(m, res.T).T
    chi2 = sum(ft.chi2 for ft in fits)
    dof = sum(ft.dof for ft in fits)
    nonorth = {f"m_{AXES[i]}{AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
    # the +/- pairs, corrected for the g-sensitivity of their own specific force
    pairs = find_bias_pairs(steps)
    return GyroCalibration(
        lsb_per_dps=steps.lsb_per_dps, matrix_counts_per_dps=m, bias_counts=b, scale_counts_per_dps=np.diag(m).copy(),
        nonorthogonality=nonorth, sigma=_sigmas(m, tuple(fits)), bias_pairs=pairs,
        residual_rms_dps=float(np.sqrt(np.mean(res_dps**2))), chi2_per_dof=chi2 / dof if dof > 0 else float("nan"),
        n_steps=len(steps),
        g_sensitivity={"inputs": [AXES[k] for k in g_inputs], "matrix_counts_per_g": gm, "sigma_counts_per_g": gs})
