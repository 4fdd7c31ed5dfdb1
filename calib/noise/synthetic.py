"""Noise of known terms, for the tests and the benchmarks of the fit (no runtime module imports it).

White noise N (u/sqrt(Hz): samples of sigma ``N sqrt(rate)``), flicker of Allan floor B over the band
``[0.02 s, corner]`` (first-order Gauss-Markov components, two per decade, each of variance
``c^2 D / (2 pi)``, ``c = B / 0.664``: :mod:`calib.numerics.wander`), a random walk K (u/sqrt(s)) and
a rate ramp R (u/s).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from calib.noise.terms import NoiseFigures
from calib.numerics.wander import FLICKER_FLOOR


def flicker(n: int, rate_hz: float, b: float, rng: np.random.Generator, corner_s: float = 5000.0,
            tau_min_s: float = 0.02, per_decade: int = 2) -> np.ndarray:
    """``n`` samples of band-limited flicker whose Allan deviation is flat at ``b`` between the band's ends."""
    lo, hi = math.log10(tau_min_s), math.log10(corner_s)
    k = max(1, int(round((hi - lo) * per_decade)))
    width = (hi - lo) / k
    taus = 10.0 ** (lo + width * (np.arange(k) + 0.5))
    sigma = b / FLICKER_FLOOR * math.sqrt(math.log(10) * width / (2 * math.pi))
    out = np.zeros(n)
    for tau in taus:
        phi = math.exp(-1.0 / (rate_hz * tau))
        e = rng.standard_normal(n) * sigma * math.sqrt(1 - phi**2)
        e[0] = rng.standard_normal() * sigma
        out += lfilter([1.0], [1.0, -phi], e)
    return out


def noise(figures: NoiseFigures, n: int, rate_hz: float, rng: np.random.Generator, corner_s: float = 5000.0) -> np.ndarray:
    """``n`` samples at ``rate_hz`` of white noise, flicker, random walk and ramp of the given ``figures``."""
    y = figures.N * math.sqrt(rate_hz) * rng.standard_normal(n)
    if figures.B > 0:
        y += flicker(n, rate_hz, figures.B, rng, corner_s)
    if figures.K > 0:
        y += np.cumsum(figures.K / math.sqrt(rate_hz) * rng.standard_normal(n))
    if figures.R > 0:
        y += figures.R * np.arange(n) / rate_hz
    return y
