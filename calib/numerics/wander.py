"""The covariance between step means that a wandering bias implies.

A MEMS sensor's bias is not constant: an Allan-variance characterisation
(:class:`calib.numerics.stability.BiasStability`) states a flicker floor B (an accelerometer's g)
and a random walk K (g/sqrt(s)). Within one step the wander hardly moves, so the scatter of the step's
own samples (its standard error) does not see it; between steps minutes apart it does,
and a slow common wander of the step means looks like a drift, a jump or a temperature
term to a search that treats the means as independent. This module gives the covariance
of that wander between the means of steps (windows ``[start, end]`` in time), so a
generalised least-squares fit can weigh the step means honestly:

    V = diag(sem^2) + W,   W = W_flicker + W_walk   (per output axis; axes independent)

Flicker
-------
Flicker (1/f) noise of coefficient ``c = B / sqrt(2 ln 2 / pi)`` (IEEE Std 952, annex C:
the Allan deviation floor of S(f) = c^2 / (2 pi f) is B) is a superposition of
first-order Gauss-Markov processes with log-uniformly spread time constants: a
Gauss-Markov process of time constant tau and variance s^2 has the one-sided spectrum
``4 s^2 tau / (1 + (2 pi f tau)^2)``, and

    integral over ln(tau) of 4 tau / (1 + (2 pi f tau)^2) = 4 / (2 pi f) * pi / 2 = 1 / f,

so giving each ln(tau) interval of width D the variance ``s^2 = c^2 D / (2 pi)`` gives
S(f) = c^2 / (2 pi f) for 1 / (2 pi tau_max) << f << 1 / (2 pi tau_min). Beyond the
flicker corner ``tau_max`` the bias no longer wanders as flicker (the band ends there);
``tau_min`` far below a step's duration contributes nothing that the standard error does
not already hold. :func:`flicker_taus_s` gives the nodes (``per_decade`` per decade, the
simulator's discretisation with ``per_decade=2``).

For one Gauss-Markov component (covariance ``s^2 exp(-|u| / tau)``) the covariance of the
means over two windows that do not overlap, of durations d1, d2 and gap g between them, is
exactly

    s^2 exp(-g / tau) * h(d1 / tau) * h(d2 / tau),   h(x) = (1 - exp(-x)) / x,

(the double integral factorises), and the variance of the mean over one window of duration
d is ``s^2 * 2 (x - 1 + exp(-x)) / x^2`` with x = d / tau; both tend to s^2 as d -> 0.

Random walk
-----------
A random walk started at the session origin has covariance ``K^2 min(t, s)``.
With ``min(t, s) = (t + s - |t - s|) / 2`` the covariance of two window means is
``K^2 (m1 + m2 - E|t - s|) / 2`` (m: window midpoints from the origin), where
``E|t - s| = |m1 - m2|`` for windows that do not overlap and ``d / 3`` for one window
with itself. A constant added to every mean (the walk's value at the origin) lies in the
span of any model with a bias, so the choice of origin does not change a fit.

:func:`wander_cov` is in the square of the figures' unit, for any sensor (the gyroscope's deg/s, the
magnetometer's uT; :meth:`calib.numerics.stability.BiasStability.cov`); :func:`wander_cov_g2` is the
accelerometer's, in g^2 (multiply by ``lsb_per_g^2`` for counts^2).
"""

from __future__ import annotations

import math

import numpy as np

from calib.errors import CalibError

#: Allan deviation floor of flicker noise = sqrt(2 ln 2 / pi) * flicker coefficient (IEEE Std 952, annex C)
FLICKER_FLOOR = math.sqrt(2 * math.log(2) / math.pi)
#: shortest flicker time constant modelled, s (faster wander is part of a step's own scatter)
TAU_MIN_S = 0.05
PER_DECADE = 4


def flicker_taus_s(corner_s: float, tau_min_s: float = TAU_MIN_S, per_decade: int = PER_DECADE) -> np.ndarray:
    """Log-spaced time constants (s) from ``tau_min_s`` to the flicker corner, ``per_decade`` per decade."""
    lo, hi = math.log10(tau_min_s), math.log10(max(corner_s, tau_min_s))
    return np.logspace(lo, hi, max(1, int(round((hi - lo) * per_decade)) + 1))


def _h(x: np.ndarray) -> np.ndarray:
    """(1 - exp(-x)) / x, 1 at x = 0."""
    x = np.asarray(x, float)
    safe = np.where(x > 1e-12, x, 1.0)
    return np.where(x > 1e-12, -np.expm1(-safe) / safe, 1.0 - x / 2)


def _self(x: np.ndarray) -> np.ndarray:
    """2 (x - 1 + exp(-x)) / x^2: variance of a window mean per unit process variance; 1 at x = 0."""
    x = np.asarray(x, float)
    safe = np.where(x > 1e-4, x, 1.0)
    exact = 2.0 * (safe + np.expm1(-safe)) / safe**2
    return np.where(x > 1e-4, exact, 1.0 - x / 3.0 + x**2 / 12.0)


def gauss_markov_cov(start_s, end_s, tau_s: float) -> np.ndarray:
    """(K, K) covariance of window means of a unit-variance Gauss-Markov process of time constant
    ``tau_s`` (s); windows ``[start_s[i], end_s[i]]`` (s) must not overlap one another."""
    return gauss_markov_covs(start_s, end_s, np.array([float(tau_s)]))[0]


def gauss_markov_covs(start_s, end_s, taus_s: np.ndarray) -> np.ndarray:
    """(N, K, K): :func:`gauss_markov_cov` for each of the N time constants ``taus_s`` at once (one set of
    array operations for all of them: the flicker's nodes of :func:`wander_cov`)."""
    a, b = np.asarray(start_s, float), np.asarray(end_s, float)
    tau = np.asarray(taus_s, float)[:, None]
    d = (b - a)[None, :] / tau  # (N, K)
    gap = np.maximum(np.maximum(a[None, :] - b[:, None], a[:, None] - b[None, :]), 0.0)
    h = _h(d)
    cov = np.exp(-(gap[None, :, :] / tau[:, :, None])) * h[:, :, None] * h[:, None, :]
    k = len(a)
    cov.reshape(len(tau), k * k)[:, ::k + 1] = _self(d)  # the diagonals
    return cov


def random_walk_cov(start_s, end_s) -> np.ndarray:
    """(K, K) covariance of window means of a unit random walk (1 unit^2 per s) started at the
    earliest window start."""
    a, b = np.asarray(start_s, float), np.asarray(end_s, float)
    m = 0.5 * (a + b) - a.min()
    e_abs = np.abs(m[:, None] - m[None, :])
    np.fill_diagonal(e_abs, (b - a) / 3.0)
    return 0.5 * (m[:, None] + m[None, :] - e_abs)


def wander_cov(t_mid_s, duration_s, bias_instability: float, random_walk_per_rts: float, flicker_corner_s: float,
               *, tau_min_s: float = TAU_MIN_S, per_decade: int = PER_DECADE) -> np.ndarray:
    """(K, K) covariance of the bias wander between the means of K steps centred at ``t_mid_s`` (s)
    lasting ``duration_s`` (s; 0 or None: point values), in the square of the sensor's unit.

    Any sensor: ``bias_instability`` is the Allan deviation floor B (g, deg/s, uT ...),
    ``random_walk_per_rts`` the random walk K (the same unit / sqrt(s)), ``flicker_corner_s`` the
    longest correlation time of the flicker (s).
    """
    t = np.asarray(t_mid_s, float)
    d = np.broadcast_to(np.asarray(0.0 if duration_s is None else duration_s, float), t.shape)
    start, end = t - d / 2, t + d / 2
    out = float(random_walk_per_rts) ** 2 * random_walk_cov(start, end)
    coeff = float(bias_instability) / FLICKER_FLOOR
    if coeff > 0 and flicker_corner_s > 0:
        var = coeff**2 * (math.log(10) / per_decade) / (2 * math.pi)  # per node
        for cov in gauss_markov_covs(start, end, flicker_taus_s(flicker_corner_s, tau_min_s, per_decade)):
            out = out + var * cov  # node by node, in order (the sum as it always was)
    return out


def wander_cov_g2(t_mid_s, duration_s, stability, *, tau_min_s: float = TAU_MIN_S,
                  per_decade: int = PER_DECADE) -> np.ndarray:
    """(K, K) covariance (g^2) of the accelerometer's bias wander between the means of K steps centred
    at ``t_mid_s`` (s) lasting ``duration_s`` (s; 0: point values): :meth:`BiasStability.cov
    <calib.numerics.stability.BiasStability.cov>` of ``stability`` (unit g); zeros when it is None."""
    t = np.asarray(t_mid_s, float)
    if stability is None:
        return np.zeros((len(t), len(t)))
    if stability.unit != "g":
        raise CalibError(f"wander_cov_g2: expected the accelerometer's stability (g), got one in {stability.unit}")
    return stability.cov(t, duration_s, tau_min_s=tau_min_s, per_decade=per_decade)


def wander_rms_g(t_mid_s, duration_s, stability) -> float:
    """RMS (g) of the wander of the step means about their common mean: what the wander adds to the
    scatter of the residuals (0 without a stability; ``stability`` as for :func:`wander_cov_g2`)."""
    w = wander_cov_g2(t_mid_s, duration_s, stability)
    k = len(w)
    if k == 0:
        return 0.0
    c = np.eye(k) - 1.0 / k
    return float(math.sqrt(max(np.trace(c @ w @ c) / k, 0.0)))
