"""A unit's noise figures from a calibration's own static steps, the family's figures as the prior (issue 28 item 5).

Without a noise profile the recording speaks first: each static step is a short static record, so the
overlapping Allan variances of one axis over all the steps, pooled at octave averaging times up to a quarter
of each step (:func:`pooled_allan`), show the white noise, and on long steps the start of the floor and of the
walk. The figures follow from the likelihood of those variances (chi-squared with their pooled degrees of
freedom: each step is an independent record) times a log-normal prior on the squared floor and walk about the
family's (:func:`fit_with_prior`): where the steps are too short to see the wander the answer stays the family's,
where they are long enough it moves to the unit's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from calib.errors import CalibError
from calib.noise.allan import MAX_TAU_FRACTION, edf_for
from calib.noise.fit import FIT_TAU_MIN_S
from calib.noise.terms import TERMS, NoiseFigures

#: the prior's spread: ln of a unit's figure over the family's, 1 sigma (0.5-2x the family is +-0.87 sigma)
PRIOR_SD_LN = 0.8


@dataclass(frozen=True)
class PooledAllan:
    """Overlapping Allan variances of one axis pooled over several records (steps).

    tau_s : (M,) averaging times, s; avar : (M,) pooled Allan variance, unit^2; terms : (M,) how many
    second differences each pooled; blocks : (M, K) which records reach each averaging time; lengths : (K,)
    the records' sample counts; rate_hz their rate.
    """

    tau_s: np.ndarray
    avar: np.ndarray
    terms: np.ndarray
    blocks: np.ndarray
    lengths: np.ndarray
    rate_hz: float

    def edf(self, alpha: np.ndarray) -> np.ndarray:
        """Equivalent degrees of freedom of each pooled variance: Greenhall's for each record that reaches it,
        summed (the records are independent), for the noise exponents ``alpha`` (M,)."""
        m = np.rint(self.tau_s * self.rate_hz).astype(int)
        alpha = np.asarray(alpha, int)
        total = np.zeros(len(m))
        for k, n in enumerate(self.lengths):
            use = self.blocks[:, k]
            if use.any():
                total[use] += edf_for(alpha[use], m[use], int(n))
        return total


def _avar_terms(y: np.ndarray, m: int) -> tuple[float, int]:
    """Sum of squared second differences of the phase of ``y`` at ``m`` samples, and how many."""
    x = np.concatenate([[0.0], np.cumsum(y)])
    d = x[2 * m:] - 2.0 * x[m:-m] + x[:-2 * m]
    return float(d @ d), len(d)


def pooled_allan(records, rate_hz: float, tau_min_s: float = FIT_TAU_MIN_S) -> PooledAllan:
    """Pooled overlapping Allan variances of ``records`` (a list of (n_i,) arrays of one axis, unit) at octave
    averaging times from ``tau_min_s`` (s) up to a quarter of the longest record; a record contributes where it
    holds at least four averaging times. CalibError for no record of 16 samples or more."""
    ys = [np.asarray(r, float) - np.mean(r) for r in records if len(r) >= 16]
    if not ys:
        raise CalibError("no static step holds 16 samples: the steps' own noise cannot be estimated")
    lengths = np.array([len(y) for y in ys])
    m_max = int(lengths.max() * MAX_TAU_FRACTION)
    ms = [m for m in 2 ** np.arange(int(np.log2(max(m_max, 1))) + 1) if m / rate_hz >= tau_min_s * (1 - 1e-9)]
    tau, avar, count, use = [], [], [], []
    for m in ms:
        s, k, row = 0.0, 0, []
        for y in ys:
            ok = len(y) * MAX_TAU_FRACTION >= m
            row.append(ok)
            if ok:
                ss, kk = _avar_terms(y, int(m))
                s, k = s + ss, k + kk
        if k:
            t = m / rate_hz
            tau.append(t), avar.append(s / (2.0 * k * m**2)), count.append(k), use.append(row)
    return PooledAllan(np.array(tau), np.array(avar), np.array(count), np.array(use, bool), lengths, float(rate_hz))


def fit_with_prior(pooled: PooledAllan, prior: NoiseFigures, sd_ln: float = PRIOR_SD_LN) -> NoiseFigures:
    """The figures N, B (the Allan floor), K that maximise the chi-squared likelihood of ``pooled`` times a
    log-normal prior on B and K about ``prior``'s (``sd_ln`` in ln of the figure; N has none: the steps always
    show it). A prior term at 0 stays 0."""
    tau, avar = pooled.tau_s, pooled.avar
    names = ("N", "B", "K")
    a = np.column_stack([TERMS[t][1](tau) for t in names])
    c0 = np.array([max(float(np.min(avar * tau)), 1e-300), prior.B**2, prior.K**2])
    keep = np.array([True, prior.B > 0, prior.K > 0])
    alpha = np.zeros(len(tau), int)
    x = np.log(c0[keep])
    for _ in range(3):  # degrees of freedom for the noise that dominates the current model
        edf = pooled.edf(alpha)

        def f(z, edf=edf):
            c = np.zeros(3)
            c[keep] = np.exp(z)
            model = a @ c
            r = avar / model
            dev = float(np.sum(0.5 * edf * (r - np.log(r) - 1.0)))
            grad_c = a.T @ (0.5 * edf * (1.0 - r) / model)
            g = (grad_c * c)[keep]
            pen = (z - np.log(c0[keep])) / (2.0 * sd_ln) ** 2  # ln c = 2 ln figure: sd 2 sd_ln
            pen[0] = 0.0  # N: no prior
            return dev + 0.5 * float(np.sum(pen * (z - np.log(c0[keep])))), g + pen

        x = minimize(f, x, jac=True, method="L-BFGS-B").x
        c = np.zeros(3)
        c[keep] = np.exp(x)
        alpha = np.array([TERMS[names[j]][2] for j in np.argmax(a * c[None, :], axis=1)])
    return NoiseFigures(N=math.sqrt(c[0]), B=math.sqrt(c[1]), K=math.sqrt(c[2]))
