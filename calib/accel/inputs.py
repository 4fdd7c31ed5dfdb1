"""Inputs of the solvers: per-step means of a static calibration session."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from calib.special import expn

from calib.errors import CalibError


#: Allan deviation floor of flicker noise = sqrt(2 ln 2 / pi) * flicker coefficient (IEEE Std 952, annex C)
FLICKER_FLOOR = math.sqrt(2 * math.log(2) / math.pi)
#: the Euler-Mascheroni constant
EULER_GAMMA = 0.5772156649015329


@dataclass(frozen=True)
class BiasStability:
    """How far a sensor's bias wanders, as an Allan-variance characterisation states it.

    bias_instability_g : Allan deviation floor B of the bias (flicker), g.
    random_walk_g_per_rts : bias random walk K, g/sqrt(s).
    flicker_corner_s : longest correlation time of the flicker (beyond it the bias no longer wanders
        as flicker), s.

    A calibration session of duration T sees one realisation of the slow part of that wander: its
    bias differs from the sensor's long-run bias by :meth:`sigma_g` (1-sigma), which no amount of
    averaging within the session reveals (docs/sensors.md, "Bias stability").
    """

    bias_instability_g: float
    random_walk_g_per_rts: float
    flicker_corner_s: float

    def sigma_g(self, duration_s: float) -> float:
        """1-sigma of a session's mean bias about the long-run bias, g: the variance of a T-second
        mean of the flicker, ``(B / 0.664)^2 F(T / T_c) / (2 pi)`` (:func:`flicker_mean_factor`;
        ``ln(T_c / T) + 3/2 - gamma`` for T << T_c: the power below 1/T plus what the components of
        correlation time near T leave in the mean), plus the random walk's mean over the session,
        ``K^2 T / 3``."""
        t = max(float(duration_s), 1.0)
        coeff = self.bias_instability_g / FLICKER_FLOOR
        flicker = coeff**2 * flicker_mean_factor(t / self.flicker_corner_s) / (2 * math.pi) if coeff > 0 else 0.0
        return math.sqrt(flicker + self.random_walk_g_per_rts**2 * t / 3.0)


def flicker_mean_factor(a: float) -> float:
    """``F(a) = integral from a to infinity of 2 (x - 1 + exp(-x)) / x^3 dx``: the variance of a mean over
    T of flicker whose correlation times reach up to T_c (a = T / T_c), per unit ``c^2 / (2 pi)``.

    Each first-order component of correlation time tau leaves ``2 (x - 1 + exp(-x)) / x^2`` (x = T / tau)
    of its variance in the mean; flicker spreads ``c^2 / (2 pi)`` of variance evenly over ln(tau).
    Closed form ``2 / a - 1 / a^2 + 2 E_3(a) / a^2``; ``-ln(a) + 3/2 - gamma`` for small a.
    """
    a = float(a)
    if a < 1e-4:
        return -math.log(max(a, 1e-300)) + 1.5 - EULER_GAMMA
    return 2.0 / a - 1.0 / a**2 + 2.0 * float(expn(3, a)) / a**2


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
        taken as point values in time by the wander covariance, :mod:`calib.wander`).
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
                         duration_s=None if self.duration_s is None else self.duration_s[idx])

    def bias_stability_counts(self) -> float:
        """1-sigma (counts) by which the session's bias stands off the sensor's long-run bias
        (:meth:`BiasStability.sigma_g` over the span of the steps' times); 0 when unknown."""
        if self.bias_stability is None or len(self) == 0:
            return 0.0
        return self.bias_stability.sigma_g(float(np.ptp(self.t_s))) * float(self.lsb_per_g)
