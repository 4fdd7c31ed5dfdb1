"""The two special functions the solvers need on every solve, without importing :mod:`scipy.special`.

``scipy.special`` costs 0.15-0.2 s to import (its array-API layer imports ``numpy.testing`` and
``numpy.f2py``), more than the whole six-position solve; a command that solves one session pays it
on every start (issue 26: ``rig solve`` as fast as a peer script). These are the textbook series and
continued fractions (Press et al., *Numerical Recipes*, 3rd ed., sections 6.2 and 6.3), accurate to
a few units in the 15th digit; ``tests/calib/test_special.py`` holds them to scipy's values over the
ranges the solvers use.
"""

from __future__ import annotations

import math

import numpy as np

EULER_GAMMA = 0.5772156649015329
_EPS = 1e-16
_TINY = 1e-300


def _gamma_q_scalar(a: float, x: float) -> float:
    """Regularised upper incomplete gamma ``Q(a, x) = Gamma(a, x) / Gamma(a)``, a > 0, x >= 0."""
    if not (a > 0.0) or not (x >= 0.0):
        return math.nan
    if x == 0.0:
        return 1.0
    if math.isinf(x):
        return 0.0
    log_prefactor = a * math.log(x) - x - math.lgamma(a)
    if x < a + 1.0:
        # series for P(a, x); Q = 1 - P is not small here, so no digits are lost
        term = total = 1.0 / a
        ap = a
        for _ in range(1_000_000):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * _EPS:
                break
        return max(0.0, 1.0 - total * math.exp(log_prefactor))
    # continued fraction for Q (modified Lentz)
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, 1_000_000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        if abs(d) < _TINY:
            d = _TINY
        c = b + an / c
        if abs(c) < _TINY:
            c = _TINY
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return math.exp(log_prefactor) * h


def chi2_sf(chi2, dof):
    """Upper-tail probability of the chi-square distribution, ``P(X > chi2)`` on ``dof`` degrees of
    freedom (what ``scipy.stats.chi2.sf(chi2, dof)`` and ``scipy.special.chdtrc(dof, chi2)`` give).

    Parameters
    ----------
    chi2 : float or array_like
        Chi-square value(s), dimensionless.
    dof : float or array_like
        Degrees of freedom (> 0); broadcast against ``chi2``.

    Returns
    -------
    float or numpy.ndarray
        A float for scalar inputs, else an array of the broadcast shape. NaN where ``dof <= 0``.
    """
    c, k = np.broadcast_arrays(np.asarray(chi2, dtype=float), np.asarray(dof, dtype=float))
    out = np.array([_gamma_q_scalar(0.5 * kk, 0.5 * max(cc, 0.0)) if not math.isnan(cc) else math.nan
                    for cc, kk in zip(c.ravel(), k.ravel())]).reshape(c.shape)
    return float(out) if out.ndim == 0 else out


def expn(n: int, x: float) -> float:
    """Generalised exponential integral ``E_n(x) = integral from 1 to infinity of exp(-x t) / t^n dt``
    (``scipy.special.expn``), for integer n >= 0 and x > 0 (x = 0 allowed for n >= 2)."""
    n = int(n)
    x = float(x)
    if n < 0 or x < 0.0 or (x == 0.0 and n <= 1):
        return math.nan
    if n == 0:
        return math.exp(-x) / x
    if x == 0.0:
        return 1.0 / (n - 1)
    if x > 1.0:
        # continued fraction (modified Lentz)
        b = x + n
        c = 1.0 / _TINY
        d = 1.0 / b
        h = d
        for i in range(1, 100_000):
            an = -i * (n - 1 + i)
            b += 2.0
            d = 1.0 / (an * d + b)
            c = b + an / c
            delta = c * d
            h *= delta
            if abs(delta - 1.0) < _EPS:
                break
        return h * math.exp(-x)
    # power series around 0, with the digamma term at k = n - 1
    total = 1.0 / (n - 1) if n != 1 else -math.log(x) - EULER_GAMMA
    fact = 1.0
    for i in range(1, 100_000):
        fact *= -x / i
        if i != n - 1:
            delta = -fact / (i - n + 1)
        else:
            psi = -EULER_GAMMA + sum(1.0 / k for k in range(1, n))
            delta = fact * (-math.log(x) + psi)
        total += delta
        if abs(delta) < abs(total) * _EPS:
            break
    return total
