"""Gyroscope inputs: per-step means of the constant-rate steps of a rate-table session."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.numerics.affine import check_array, check_times
from calib.errors import CalibError
from calib.numerics.stability import BiasStability


@dataclass(frozen=True)
class RateStepMeans:
    """One row per constant-rate step of a gyroscope calibration.

    Attributes
    ----------
    names : (K,) step names.
    rate_nominal_dps : (K, 3) true angular rate of the step in the sensor frame, deg/s.
    mean_counts : (K, 3) mean raw gyroscope output, counts.
    sem_counts : (K, 3) standard error of each mean (from the step's own scatter, correlated samples
        accounted for: :func:`calib.numerics.uncertainty.step_standard_errors`), counts, > 0.
    n_samples : (K,) samples per step.
    lsb_per_dps : nominal sensitivity at the recorded range, counts per deg/s, > 0.
    f_mean_g : (K, 3) mean specific force during each step, sensor frame, g, or None.
    t_s : (K,) mid-time of each step's capture, s from session start, or None (unknown).
    duration_s : (K,) how long each step's capture lasted, s, or None (point values in time).
    bias_stability : the gyroscope's :class:`calib.numerics.stability.BiasStability` (deg/s), or None (unknown: the steps are
        weighed by their standard errors alone). Used only with ``t_s``.
    """

    names: tuple
    rate_nominal_dps: np.ndarray
    mean_counts: np.ndarray
    sem_counts: np.ndarray
    n_samples: np.ndarray
    lsb_per_dps: float
    f_mean_g: np.ndarray | None = None
    t_s: np.ndarray | None = None
    duration_s: np.ndarray | None = None
    bias_stability: BiasStability | None = None

    def __post_init__(self) -> None:
        k = len(self.names)
        owner = "RateStepMeans"
        if self.f_mean_g is not None:
            object.__setattr__(self, "f_mean_g", check_array(owner, "f_mean_g", self.f_mean_g, (k, 3)))
        for name, shape in (("rate_nominal_dps", (k, 3)), ("mean_counts", (k, 3)), ("sem_counts", (k, 3)),
                            ("n_samples", (k,))):
            object.__setattr__(self, name, check_array(owner, name, getattr(self, name), shape,
                                                       positive=name in ("sem_counts", "n_samples")))
        t, d = check_times(owner, k, self.t_s, self.duration_s)
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "duration_s", d)
        try:
            lsb = float(self.lsb_per_dps)
        except (TypeError, ValueError):
            raise CalibError(f"{owner}.lsb_per_dps: expected a number > 0, got {self.lsb_per_dps!r}") from None
        if not (np.isfinite(lsb) and lsb > 0):
            raise CalibError(f"{owner}.lsb_per_dps: expected a finite number > 0, got {self.lsb_per_dps!r}")
        object.__setattr__(self, "lsb_per_dps", lsb)

    def __len__(self) -> int:
        return len(self.names)

    def wander_counts2(self) -> np.ndarray | None:
        """(K, K) covariance of the bias wander between the step means, counts^2 (the same for every
        output axis), or None when the stability or the step times are unknown."""
        if self.bias_stability is None or self.t_s is None:
            return None
        return self.lsb_per_dps**2 * self.bias_stability.cov(self.t_s, self.duration_s)
