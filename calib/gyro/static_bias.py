"""The gyroscope's zero-rate output from rest intervals (static steps), with its sigma.

At rest a gyroscope reads its bias plus the Earth's rotation (at most 15 deg/h = 0.0042 deg/s, projected
on each axis by the pose) plus noise. Each static step k gives a mean ``g_k`` (3,) counts with a standard
error ``s_k`` (from its own scatter, correlated samples accounted for:
:func:`calib.numerics.uncertainty.step_standard_errors`). The bias is their weighted mean per axis,

    b = sum_k g_k / s_k^2 / sum_k 1 / s_k^2,   sigma_b = (sum_k 1 / s_k^2)^-1/2,

and the steps' scatter about it is checked per axis (chi2 over K - 1 degrees of freedom): when the steps
disagree beyond their standard errors (the Earth's rate in different poses, the bias wandering between
steps), sigma_b is scaled by sqrt(chi2/dof) (the one misfit rule of :mod:`calib.numerics.design`), so the
sigma carries what the steps say about each other. One step gives a sigma from its own scatter alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.errors import ObservabilityError
from calib.numerics.design import MISFIT_LEVEL, misfit
from calib.numerics.uncertainty import step_standard_errors

#: a count's quantisation as the floor of a step's sample standard deviation (counts)
QUANTUM_COUNTS = 1.0 / np.sqrt(12.0)


@dataclass(frozen=True)
class StaticGyroBias:
    """Zero-rate output from rest intervals.

    Attributes
    ----------
    bias_counts, sigma_counts : (3,) counts, sensor frame.
    lsb_per_dps : counts per deg/s (the session's nominal sensitivity).
    chi2_per_dof : (3,) the steps' scatter about the bias per axis (nan for one step).
    n_steps : rest intervals used.
    scaled : (3,) bool, whether sigma was scaled by sqrt(chi2/dof) (the steps disagree).
    """

    bias_counts: np.ndarray
    sigma_counts: np.ndarray
    lsb_per_dps: float
    chi2_per_dof: np.ndarray
    n_steps: int
    scaled: np.ndarray

    @property
    def bias_dps(self) -> np.ndarray:
        return self.bias_counts / self.lsb_per_dps

    @property
    def sigma_dps(self) -> np.ndarray:
        return self.sigma_counts / self.lsb_per_dps

    def format_line(self) -> str:
        """``gyroscope zero-rate output (N rest intervals): x b +- s ... counts`` (the unit of the gyro bias in the
        calibration file, the history and the report)."""
        parts = " ".join(f"{'xyz'[i]} {b:+.2f} +- {s:.2f}" for i, (b, s) in enumerate(zip(self.bias_counts,
                                                                                            self.sigma_counts)))
        note = " (sigma scaled: the steps disagree beyond their noise)" if self.scaled.any() else ""
        return f"gyroscope zero-rate output ({self.n_steps} rest intervals): {parts} counts{note}"


def static_gyro_bias(blocks: list, lsb_per_dps: float) -> StaticGyroBias:
    """The zero-rate output from the gyroscope samples of K rest intervals (``blocks``: each (n_k, 3), counts)."""
    blocks = [np.asarray(b, float) for b in blocks if len(b) >= 2]
    if not blocks:
        raise ObservabilityError("the session has no rest interval with gyroscope samples: a static gyro bias "
                                 "needs at least one static step")
    sems, _ = step_standard_errors(blocks, QUANTUM_COUNTS)
    means = np.array([b.mean(axis=0) for b in blocks])
    w = 1.0 / sems**2
    bias = (w * means).sum(axis=0) / w.sum(axis=0)
    sigma = 1.0 / np.sqrt(w.sum(axis=0))
    k = len(blocks)
    chi2 = (w * (means - bias) ** 2).sum(axis=0)
    scaled = np.zeros(3, bool)
    if k > 1:
        for a in range(3):
            scaled[a] = misfit(float(chi2[a]), k - 1, MISFIT_LEVEL)[0]
        sigma = np.where(scaled, sigma * np.sqrt(chi2 / (k - 1)), sigma)
    return StaticGyroBias(bias_counts=bias, sigma_counts=sigma, lsb_per_dps=float(lsb_per_dps),
                          chi2_per_dof=chi2 / (k - 1) if k > 1 else np.full(3, np.nan), n_steps=k, scaled=scaled)
