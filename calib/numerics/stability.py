"""How far a sensor's bias wanders, as an Allan-variance characterisation states it (docs/sensors.md,
"Bias stability"), and what that leaves in the mean of a session."""

from __future__ import annotations

import math
from dataclasses import dataclass

from calib.numerics.special import expn

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
