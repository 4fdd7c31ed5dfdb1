"""How far a sensor's bias wanders, as an Allan-variance characterisation states it (docs/sensors.md,
"Bias stability"), and what that leaves in the mean of a session and between the means of its steps."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError
from calib.numerics.special import EULER_GAMMA, expn
from calib.numerics.wander import FLICKER_FLOOR, PER_DECADE, TAU_MIN_S, wander_cov

#: the units of the sensors' figures: accelerometer, gyroscope, magnetometer
UNITS = ("g", "deg/s", "uT")


@dataclass(frozen=True)
class BiasStability:
    """How far a sensor's bias wanders, as an Allan-variance characterisation states it, in the sensor's
    own ``unit`` (docs/sensors.md, "Bias stability").

    bias_instability : Allan deviation floor B of the bias (flicker), ``unit``.
    random_walk_per_rts : bias random walk K, ``unit``/sqrt(s).
    flicker_corner_s : longest correlation time of the flicker (beyond it the bias no longer wanders
        as flicker), s.
    unit : the unit of the figures (:data:`UNITS`: an accelerometer's "g", a gyroscope's "deg/s", a
        magnetometer's "uT").

    A calibration session of duration T sees one realisation of the slow part of that wander: its
    bias differs from the sensor's long-run bias by :meth:`sigma` (1-sigma), which no amount of
    averaging within the session reveals; between the means of its steps the wander is correlated
    (:meth:`cov`).
    """

    bias_instability: float
    random_walk_per_rts: float
    flicker_corner_s: float
    unit: str = "g"

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise CalibError(f"BiasStability.unit: expected one of {', '.join(UNITS)}, got {self.unit!r}")

    def sigma(self, duration_s: float) -> float:
        """1-sigma of a session's mean bias about the long-run bias, ``unit``: the variance of a T-second
        mean of the flicker, ``(B / 0.664)^2 F(T / T_c) / (2 pi)`` (:func:`flicker_mean_factor`;
        ``ln(T_c / T) + 3/2 - gamma`` for T << T_c: the power below 1/T plus what the components of
        correlation time near T leave in the mean), plus the random walk's mean over the session,
        ``K^2 T / 3``."""
        t = max(float(duration_s), 1.0)
        coeff = self.bias_instability / FLICKER_FLOOR
        flicker = coeff**2 * flicker_mean_factor(t / self.flicker_corner_s) / (2 * math.pi) if coeff > 0 else 0.0
        return math.sqrt(flicker + self.random_walk_per_rts**2 * t / 3.0)

    def cov(self, t_mid_s, duration_s, *, tau_min_s: float = TAU_MIN_S, per_decade: int = PER_DECADE) -> np.ndarray:
        """(K, K) covariance of the wander between the means of K steps centred at ``t_mid_s`` (s) lasting
        ``duration_s`` (s; 0 or None: point values), ``unit`` squared (:func:`calib.numerics.wander.wander_cov`)."""
        return wander_cov(t_mid_s, duration_s, self.bias_instability, self.random_walk_per_rts, self.flicker_corner_s,
                          tau_min_s=tau_min_s, per_decade=per_decade)


@dataclass(frozen=True)
class AxisStability(BiasStability):
    """A sensor whose axes wander each by its own figures (a unit's noise profile, docs/noise.md): ``axes`` one
    :class:`BiasStability` per output axis (x, y, z). The scalar figures are their RMS, what a consumer that weighs
    the three axes with one wander uses (:meth:`sigma`, :meth:`cov`); :meth:`axis_cov` gives each axis its own."""

    axes: tuple = ()

    @classmethod
    def of(cls, axes) -> "AxisStability":
        axes = tuple(axes)
        return cls(_rms([a.bias_instability for a in axes]), _rms([a.random_walk_per_rts for a in axes]),
                   axes[0].flicker_corner_s, axes[0].unit, axes)

    def axis_cov(self, t_mid_s, duration_s, **kw) -> np.ndarray:
        """(A, K, K): :meth:`BiasStability.cov` of each axis."""
        return np.stack([a.cov(t_mid_s, duration_s, **kw) for a in self.axes])


def _rms(values) -> float:
    return math.sqrt(sum(x * x for x in values) / len(values))


def axis_cov(stability: BiasStability, t_mid_s, duration_s, n_axes: int = 3, **kw) -> np.ndarray:
    """(A, K, K) wander covariance per output axis: each axis's own for an :class:`AxisStability`, else the one
    :meth:`BiasStability.cov` for every axis (computed once)."""
    if isinstance(stability, AxisStability) and stability.axes:
        return stability.axis_cov(t_mid_s, duration_s, **kw)
    w = stability.cov(t_mid_s, duration_s, **kw)
    return np.broadcast_to(w, (n_axes, *w.shape))


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
