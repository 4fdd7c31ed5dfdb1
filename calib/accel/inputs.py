"""Inputs of the solvers: per-step means of a static calibration session."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError
from calib.numerics.stability import BiasStability


@dataclass(frozen=True)
class StepMeans:
    """One row per static step.

    Attributes
    ----------
    names : step names.
    f_nominal_g : (K, 3) nominal specific force, sensor frame, g; a row of NaN where the pose is unknown.
    mean_counts : (K, 3) mean raw accelerometer counts.
    sem_counts : (K, 3) standard error of each mean (sample std / sqrt(n)), counts.
    n_samples : (K,) samples per step.
    temp_c : (K,) mean temperature per step, C, or None (no thermometer).
    t_s : (K,) mid-time of each step, s from session start.
    lsb_per_g : nominal sensitivity at the recorded range, counts per g.
    bias_stability : the sensor's :class:`BiasStability`, or None (unknown: bias sigmas are then the
        fit's alone).
    temp_rate_c_per_s : (K,) rate of the sensor's temperature over each step (the least-squares slope of
        its thermometer over the step's samples), C/s, or None (steps not captured on a thermal ramp:
        the solvers then fit no thermal-gradient term).
    duration_s : (K,) how long each step's capture lasted, s, or None (unknown: the means are then
        taken as point values in time by the wander covariance, :mod:`calib.numerics.wander`).
    arrival_direction : (K, 3) the direction (+1, -1) each turntable stage a1, a2, a3 last turned in before the
        step's capture, 0 where that is unknown (the stage has not moved since the session began), or None (not
        recorded: a budget then takes each pose's lost motion as of unknown sign, :mod:`calib.accel.rig_propagation`).
    angles_deg : (K, 3) the stage angles a1, a2, a3 each step was commanded to, deg (kinematic, ``docs/kinematics.md``),
        or None (not recorded: a hand-placed or imported session; the table's budget then takes the angles that put
        ``f_nominal_g`` up with a1 = 0, :func:`calib.accel.rig_propagation.pose_angles_deg`).
    """

    names: tuple
    f_nominal_g: np.ndarray
    mean_counts: np.ndarray
    sem_counts: np.ndarray
    n_samples: np.ndarray
    temp_c: np.ndarray | None
    t_s: np.ndarray
    lsb_per_g: float
    bias_stability: BiasStability | None = None
    temp_rate_c_per_s: np.ndarray | None = None
    duration_s: np.ndarray | None = None
    arrival_direction: np.ndarray | None = None
    angles_deg: np.ndarray | None = None

    def __post_init__(self) -> None:
        k = len(self.names)
        for name, shape in (("f_nominal_g", (k, 3)), ("mean_counts", (k, 3)), ("sem_counts", (k, 3)),
                            ("n_samples", (k,)), ("t_s", (k,))):
            v = np.asarray(getattr(self, name))
            if v.shape != shape:
                raise CalibError(f"StepMeans.{name}: expected shape {shape}, got {v.shape}")
            finite = np.isfinite(v)
            if name == "f_nominal_g":  # a step with an unknown pose has a whole row of NaN
                finite = finite.all(axis=1) | np.isnan(v).all(axis=1)
            if not np.all(finite):
                raise CalibError(f"StepMeans.{name}: contains NaN or infinity")
        if self.temp_c is not None:
            t = np.asarray(self.temp_c)
            if t.shape != (k,) or not np.all(np.isfinite(t)):
                raise CalibError("StepMeans.temp_c: expected K finite temperatures, or None")
        if self.temp_rate_c_per_s is not None:
            r = np.asarray(self.temp_rate_c_per_s)
            if r.shape != (k,) or not np.all(np.isfinite(r)):
                raise CalibError("StepMeans.temp_rate_c_per_s: expected K finite temperature rates, or None")
        if self.duration_s is not None:
            d = np.asarray(self.duration_s)
            if d.shape != (k,) or not np.all(np.isfinite(d) & (d >= 0)):
                raise CalibError("StepMeans.duration_s: expected K finite durations >= 0 s, or None")
        if self.angles_deg is not None:
            a = np.asarray(self.angles_deg)
            if a.shape != (k, 3) or not np.all(np.isfinite(a)):
                raise CalibError("StepMeans.angles_deg: expected (K, 3) finite stage angles in deg, or None")
        if self.arrival_direction is not None:
            d = np.asarray(self.arrival_direction)
            if d.shape != (k, 3) or not np.all(np.isin(d, (-1, 0, 1))):
                raise CalibError("StepMeans.arrival_direction: expected (K, 3) of +1, -1 or 0, or None")
        if not np.all(np.asarray(self.sem_counts) > 0):
            raise CalibError("StepMeans.sem_counts: every standard error must be > 0")
        if not self.lsb_per_g > 0:
            raise CalibError("StepMeans.lsb_per_g: must be > 0")

    @property
    def pose_known(self) -> np.ndarray:
        """(K,) True where the step's nominal specific force is known."""
        return np.isfinite(np.asarray(self.f_nominal_g, float)).all(axis=1)

    def __len__(self) -> int:
        return len(self.names)

    def subset(self, idx) -> "StepMeans":
        idx = np.asarray(idx)
        return StepMeans(names=tuple(np.asarray(self.names, dtype=object)[idx]),
                         f_nominal_g=self.f_nominal_g[idx], mean_counts=self.mean_counts[idx],
                         sem_counts=self.sem_counts[idx], n_samples=self.n_samples[idx],
                         temp_c=None if self.temp_c is None else self.temp_c[idx], t_s=self.t_s[idx],
                         lsb_per_g=self.lsb_per_g, bias_stability=self.bias_stability,
                         temp_rate_c_per_s=None if self.temp_rate_c_per_s is None else self.temp_rate_c_per_s[idx],
                         duration_s=None if self.duration_s is None else self.duration_s[idx],
                         arrival_direction=None if self.arrival_direction is None else self.arrival_direction[idx],
                         angles_deg=None if self.angles_deg is None else np.asarray(self.angles_deg)[idx])

    def bias_stability_counts(self) -> float:
        """1-sigma (counts) by which the session's bias stands off the sensor's long-run bias
        (:meth:`BiasStability.sigma` over the span of the steps' times); 0 when unknown."""
        if self.bias_stability is None or len(self) == 0:
            return 0.0
        return self.bias_stability.sigma(float(np.ptp(self.t_s))) * float(self.lsb_per_g)
