"""Magnetometer inputs: per-step means of the static steps that have magnetometer readings."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.numerics.affine import check_array, check_times
from calib.numerics.stability import BiasStability


@dataclass(frozen=True)
class MagStepMeans:
    """One row per static step of a magnetometer calibration.

    Attributes
    ----------
    names : (K,) step names.
    field_nominal_ut : (K, 3) true field in the sensor frame, uT, or None when the poses are unknown.
    mean_ut : (K, 3) mean magnetometer output, uT.
    sem_ut : (K, 3) standard error of each mean (from the step's own scatter, correlated samples
        accounted for: :func:`calib.numerics.uncertainty.step_standard_errors`), uT, > 0.
    n_samples : (K,) samples per step.
    t_s : (K,) mid-time of each step's readings, s from session start, or None (unknown).
    duration_s : (K,) how long each step's readings lasted, s, or None (point values in time).
    bias_stability : the magnetometer's :class:`calib.numerics.stability.BiasStability` (uT), or None (unknown: the steps are
        weighed by their standard errors alone). Used only with ``t_s``.
    """

    names: tuple
    field_nominal_ut: np.ndarray | None
    mean_ut: np.ndarray
    sem_ut: np.ndarray
    n_samples: np.ndarray
    t_s: np.ndarray | None = None
    duration_s: np.ndarray | None = None
    bias_stability: BiasStability | None = None

    def __post_init__(self) -> None:
        k = len(self.names)
        owner = "MagStepMeans"
        if self.field_nominal_ut is not None:
            object.__setattr__(self, "field_nominal_ut",
                               check_array(owner, "field_nominal_ut", self.field_nominal_ut, (k, 3)))
        for name, shape in (("mean_ut", (k, 3)), ("sem_ut", (k, 3)), ("n_samples", (k,))):
            object.__setattr__(self, name, check_array(owner, name, getattr(self, name), shape,
                                                       positive=name in ("sem_ut", "n_samples")))
        t, d = check_times(owner, k, self.t_s, self.duration_s)
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "duration_s", d)

    def __len__(self) -> int:
        return len(self.names)

    def wander_ut2(self) -> np.ndarray | None:
        """(K, K) covariance of the offset wander between the step means, uT^2 (the same for every output
        axis), or None when the stability or the step times are unknown."""
        if self.bias_stability is None or self.t_s is None:
            return None
        return self.bias_stability.cov(self.t_s, self.duration_s)
