"""Gyroscope solver: 12-parameter least squares over the rate steps, and the seed's +/- pairs.

The steps are weighed by their standard errors and, when the gyroscope's bias stability and the
steps' times are known (:meth:`calib.gyro.inputs.RateStepMeans.wander_counts2`), by the covariance of
the zero-rate output's wander between them: generalised least squares, as the accelerometer's solver
(docs/methods.md, "Per-step standard errors"). Rate steps last 100 s and follow one another for half
an hour, so the wander between them is several times a step's own standard error: without it a clean
simulated session had chi2/dof ~ 35, bias sigmas 6 times too small and, Birge-rescaled, scale and
coupling sigmas twice too large."""

from __future__ import annotations

import numpy as np

from calib.numerics.affine import fit_affine, input_coverage, solve_axis
from calib.numerics.design import session_rule
from calib.errors import ObservabilityError
from calib.gyro.inputs import RateStepMeans
from calib.gyro.result import SENSOR_AXES, OFF_DIAGONAL, BiasPair, GyroCalibration, param_names


def find_bias_pairs(steps: RateStepMeans, rel_tol: float = 1e-6) -> list[BiasPair]:
    """Zero-rate outputs from every pair of steps with opposite nominal rates.

    Each step is used at most once; steps with zero rate are skipped. For a pair
    ``b = (a_plus + a_minus) / 2`` and ``sigma = sqrt(sem_plus^2 + sem_minus^2 + W_pp + W_mm + 2 W_pm) / 2``
    (counts; W the bias wander's covariance between the step means, zero when unknown: the sigma is
    then the steps' standard errors alone).
    """
    w = steps.rate_nominal_dps
    wander = steps.wander_counts2()
    used = np.zeros(len(steps), bool)
    pairs = []
    for i in range(len(steps)):
        ri = float(np.linalg.norm(w[i]))
        if used[i] or ri == 0:
            continue
        for j in range(i + 1, len(steps)):
            if not used[j] and np.linalg.norm(w[i] + w[j]) <= rel_tol * ri:
                used[i] = used[j] = True
                pairs.append(_pair(steps, i, j, ri, 0.0 if wander is None else wander[np.ix_([i, j], [i, j])].sum()))
                break
    return pairs


def _pair(steps: RateStepMeans, i: int, j: int, rate_dps: float, wander_counts2: float) -> BiasPair:
    """The zero-rate output of steps ``i`` and ``j`` (opposite rates of magnitude ``rate_dps``, deg/s);
    ``wander_counts2`` the variance (counts^2) the wander adds to the sum of their means."""
    dominant = np.abs(steps.rate_nominal_dps[i]) / rate_dps
    axis = SENSOR_AXES[int(np.argmax(dominant))] if dominant.max() > 1 - 1e-6 else "xyz"
    bias = 0.5 * (steps.mean_counts[i] + steps.mean_counts[j])
    sig = 0.5 * np.sqrt(steps.sem_counts[i] ** 2 + steps.sem_counts[j] ** 2 + wander_counts2)
    return BiasPair(axis_spun=axis, rate_dps=rate_dps, bias_counts=bias, sigma_counts=sig)


def _check_observable(w: np.ndarray) -> None:
    missing, full = input_coverage(w)
    if missing:
        names = "".join(SENSOR_AXES[j] for j in missing)
        about = " or ".join(SENSOR_AXES[j] for j in missing)
        scales = ", ".join(f"k_{SENSOR_AXES[j]}" for j in missing)
        couplings = ", ".join(f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}" for j in missing for i in range(3) if i != j)
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
        sig[f"b_{SENSOR_AXES[i]}"] = float(np.sqrt(c[3, 3]))
        sig[f"k_{SENSOR_AXES[i]}"] = float(np.sqrt(c[i, i]))
    for i, j in OFF_DIAGONAL:
        c = fits[i].cov
        mii, mij = matrix[i, i], matrix[i, j]
        grad = np.zeros(c.shape[0])
        grad[j] = 1.0 / mii
        grad[i] = -mij / mii**2
        sig[f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}"] = float(np.sqrt(max(grad @ c @ grad, 0.0)))
    return {n: sig[n] for n in param_names()}


def solve_gyro(steps: RateStepMeans) -> GyroCalibration:
    """Solve the 12-parameter gyro model ``counts = M w + b`` from rate-step means.

    Parameters
    ----------
    steps : :class:`RateStepMeans` (true rates in the sensor frame, deg/s; means in counts).

    Returns
    -------
    :class:`GyroCalibration` with M and b from least squares over all steps (per output axis,
    columns ``[w_x, w_y, w_z, 1]``; generalised with the bias wander between the steps when
    ``steps.bias_stability`` and ``steps.t_s`` are known, else weights 1/sem; covariance rescaled
    by chi2/dof only on a significant misfit of the session, :func:`calib.numerics.design.session_rule`),
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
    names = [[f"M_{SENSOR_AXES[i]}{a}" for a in SENSOR_AXES] + [f"b_{SENSOR_AXES[i]}"] for i in range(3)]
    fit = fit_affine(w, steps.mean_counts, steps.sem_counts, names, steps.wander_counts2())
    m, b = fit.matrix, fit.offset
    res_dps = np.linalg.solve(m, fit.residuals.T).T
    nonorth = {f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
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
    wander = steps.wander_counts2()
    fits = []
    for i in range(3):
        nm = [f"M_{SENSOR_AXES[i]}{a}" for a in SENSOR_AXES] + [f"b_{SENSOR_AXES[i]}"] + [f"G_{SENSOR_AXES[i]}{SENSOR_AXES[k]}" for k in g_inputs]
        fits.append(solve_axis(design, steps.mean_counts[:, i], steps.sem_counts[:, i], wander, nm))
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
    nonorth = {f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}": float(m[i, j] / m[i, i]) for i, j in OFF_DIAGONAL}
    # the +/- pairs, corrected for the g-sensitivity of their own specific force
    pairs = find_bias_pairs(steps)
    return GyroCalibration(
        lsb_per_dps=steps.lsb_per_dps, matrix_counts_per_dps=m, bias_counts=b, scale_counts_per_dps=np.diag(m).copy(),
        nonorthogonality=nonorth, sigma=_sigmas(m, tuple(fits)), bias_pairs=pairs,
        residual_rms_dps=float(np.sqrt(np.mean(res_dps**2))), chi2_per_dof=chi2 / dof if dof > 0 else float("nan"),
        n_steps=len(steps),
        g_sensitivity={"inputs": [SENSOR_AXES[k] for k in g_inputs], "matrix_counts_per_g": gm, "sigma_counts_per_g": gs})
