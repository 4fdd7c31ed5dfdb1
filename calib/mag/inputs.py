"""Magnetometer inputs: per-step means of the static steps that have magnetometer readings."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.affine import check_array


@dataclass(frozen=True)
class MagStepMeans:
    """One row per static step of a magnetometer calibration.

    Attributes
    ----------
    names : (K,) step names.
    field_nominal_ut : (K, 3) true field in the sensor frame, uT, or None when the poses are unknown.
    mean_ut : (K, 3) mean magnetometer output, uT.
    sem_ut : (K, 3) standard error of each mean (sample std / sqrt(n)), uT, > 0.
    n_samples : (K,) samples per step.
    """

    names: tuple
    field_nominal_ut: np.ndarray | None
    mean_ut: np.ndarray
    sem_ut: np.ndarray
    n_samples: np.ndarray

    def __post_init__(self) -> None:
        k = len(self.names)
        owner = "MagStepMeans"
        if self.field_nominal_ut is not None:
            object.__setattr__(self, "field_nominal_ut",
                               check_array(owner, "field_nominal_ut", self.field_nominal_ut, (k, 3)))
        for name, shape in (("mean_ut", (k, 3)), ("sem_ut", (k, 3)), ("n_samples", (k,))):
            object.__setattr__(self, name, check_array(owner, name, getattr(self, name), shape,
                                                       positive=name in ("sem_ut", "n_samples")))

    def __len__(self) -> int:
        return len(self.names)

