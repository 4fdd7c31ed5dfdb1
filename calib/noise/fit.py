"""The noise terms fitted to an Allan deviation, with uncertainties and the fit's quality (docs/noise.md).

The Allan variance is linear in the squared figures (:mod:`calib.noise.terms`), ``sigma^2(tau) =
sum_j c_j f_j(tau)``, so the fit is a non-negative weighted linear least squares over the octave-spaced
points. Each point's variance is ``2 sigma^2_model(tau)^2 / edf(tau)``, with Greenhall's degrees of
freedom for the noise that dominates the model there (:func:`calib.noise.allan.with_edf`); the
weights and the degrees of freedom are re-evaluated from the fit until it settles. The covariance of
the ``c_j`` is ``(A^T W A)^-1``, scaled by chi2/dof when the points scatter more than their degrees
of freedom say (Birge): it gives each figure's 1-sigma. The iterated weights make the fit the maximum of
the likelihood that treats each Allan variance as chi-squared with its degrees of freedom (a gamma
variable about the model: weights ``edf / (2 model^2)``), and a figure's 95 % interval is that
likelihood's profile interval (:func:`_profile_interval`), square-rooted. At long averaging times a
point has 4-10 degrees of freedom, so a squared figure's likelihood is skewed: a walk fitted low can be
several times larger, hardly much smaller, which the symmetric interval ``c +- 1.96 sigma`` (used before
2026-11-26) did not say. Both are widened by :data:`CORRELATION_INFLATION`; a term the fit puts at 0 has
an upper bound only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, nnls

from calib.errors import CalibError
from calib.noise.allan import FIT_TAU_MIN_S, AllanCurve, with_edf
from calib.noise.terms import DEFAULT_TERMS, TERMS, NoiseFigures

#: two-sided 95 % normal quantile of the stated intervals
Z95 = 1.959963984540054
#: the profile likelihood's 95 % interval: where twice the log-likelihood falls by chi2(1)'s 95 % quantile
CHI2_1_95 = Z95**2
#: a rate ramp asked "where seen" is kept when its squared figure stands this many sigma above 0
RAMP_SEEN_SIGMA = 3.0
ITERATIONS = 4
#: at most this many Newton steps when the profile likelihood re-fits the other terms
PROFILE_ITERATIONS = 100
#: the likelihood never lets a model fall below this share of the Allan variance measured (a point the model
#: misses by a factor 1e9 counts as missed; the floor keeps the arithmetic finite)
MODEL_FLOOR = 1e-9
#: the fit weighs the octave points as independent; overlapping Allan variances at neighbouring averaging
#: times are correlated, so the covariance of each squared figure is scaled by this factor (the spread of
#: (fitted - true) / stated sigma on synthetic noise of known terms, 60 units with N, B, K drawn 0.5-2x the
#: MPU-9150 accelerometer's, 2 h at 100 Hz, calib.noise.synthetic, seeds 1-3: N 1.29-1.49, B 1.08-1.49, K 1.38-1.61;
#: checked on other seeds in benchmarks/bench_allan.py)
CORRELATION_INFLATION = {"N": 1.5, "B": 1.35, "K": 1.6, "R": 1.6}


@dataclass(frozen=True)
class TermFit:
    """One fitted figure: ``value`` with its 1-sigma ``sigma`` and 95 % interval ``[lo, hi]`` (the axis's unit)."""

    term: str
    value: float
    sigma: float
    lo: float
    hi: float

    def covers(self, truth: float) -> bool:
        return self.lo <= truth <= self.hi

    def to_dict(self) -> dict:
        return {"value": self.value, "sigma": self.sigma, "ci95": [self.lo, self.hi]}


@dataclass(frozen=True)
class NoiseFit:
    """The fit of one axis: its figures, each term's fit, the quality and the curve it was fitted to.

    chi2_dof : chi-squared per degree of freedom of the Allan variances about the model (1 for a good fit).
    max_rel_dev : largest |ADEV / model - 1| over the fitted points.
    tau_floor_s : averaging time of the fitted curve's minimum (the bias instability's correlation time,
        IEEE Std 952: the floor is read there), s; None without a floor.
    """

    figures: NoiseFigures
    terms: dict
    chi2_dof: float
    max_rel_dev: float
    tau_floor_s: float | None
    curve: AllanCurve
    n_fitted: int

    def unresolved(self) -> list[str]:
        """The terms whose 95 % interval reaches 0, fitted above it or at it: the record does not tell them from
        nothing (a floor hidden behind white noise and walk at every averaging time it holds, docs/noise.md)."""
        return [t for t, f in self.terms.items() if f.lo <= 0 < f.hi]

    def to_dict(self) -> dict:
        return {"terms": {t: f.to_dict() for t, f in self.terms.items()}, "chi2_dof": self.chi2_dof,
                "max_rel_dev": self.max_rel_dev, "tau_floor_s": self.tau_floor_s, "points": self.n_fitted}


def _design(tau: np.ndarray, terms) -> np.ndarray:
    return np.column_stack([TERMS[t][1](tau) for t in terms])


def _alpha(tau: np.ndarray, terms, c: np.ndarray) -> np.ndarray:
    """The FM exponent of the term that dominates the model at each tau."""
    parts = _design(tau, terms) * c[None, :]
    return np.array([TERMS[terms[j]][2] for j in np.argmax(parts, axis=1)])


def _solve(curve: AllanCurve, sel: np.ndarray, terms) -> tuple[np.ndarray, np.ndarray, float, AllanCurve]:
    """Iterated weighted NNLS: (c, covariance of c, chi2/dof, curve with the final degrees of freedom)."""
    tau, avar = curve.tau_s[sel], curve.adev[sel] ** 2
    a = _design(tau, terms)
    model = avar.copy()
    c = np.zeros(len(terms))
    for _ in range(ITERATIONS):
        alpha = _alpha(curve.tau_s, terms, c) if c.any() else np.zeros(len(curve.tau_s), int)
        curve = with_edf(curve, alpha)
        sd = np.sqrt(2.0 / curve.edf[sel]) * np.maximum(model, 1e-300)
        c, _ = nnls(a / sd[:, None], avar / sd)
        model = a @ c
    resid = (avar - model) / sd
    dof = max(len(tau) - int(np.count_nonzero(c)), 1)
    chi2_dof = float(resid @ resid / dof)
    free = c > 0
    cov = np.zeros((len(terms), len(terms)))
    if free.any():
        aw = a[:, free] / sd[:, None]
        cov[np.ix_(free, free)] = np.linalg.pinv(aw.T @ aw) * max(chi2_dof, 1.0)
    bound = ~free  # at zero: the 1-sigma of that term alone, for its upper bound
    for j in np.flatnonzero(bound):
        col = a[:, j] / sd
        cov[j, j] = max(chi2_dof, 1.0) / float(col @ col)
    return c, cov, chi2_dof, curve


def _term_fit(term: str, c: float, var: float, lo_c: float, hi_c: float) -> TermFit:
    """The figure sqrt(c), its 1-sigma from var(c) (delta method) and its interval from that of c, [lo_c, hi_c]."""
    s = math.sqrt(max(var, 0.0))
    value = math.sqrt(max(c, 0.0))
    sigma = s / (2 * value) if value > 0 else math.sqrt(s)
    return TermFit(term, value, sigma, math.sqrt(max(min(lo_c, c), 0.0)), math.sqrt(max(hi_c, c, 0.0)))


def _deviance(avar: np.ndarray, model: np.ndarray, edf: np.ndarray) -> float:
    """Minus the log-likelihood, plus a constant that makes it 0 at a perfect fit, of Allan variances ``avar``
    that are chi-squared with ``edf`` degrees of freedom about ``model``: gamma variables of mean ``model``
    and shape ``edf / 2``."""
    r = avar / np.maximum(model, MODEL_FLOOR * avar)
    return float(np.sum(0.5 * edf * (r - np.log(r) - 1.0)))


def _refit(avar: np.ndarray, a: np.ndarray, offset: np.ndarray, edf: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The squared figures (>= 0) of design ``a`` that maximise the chi-squared likelihood of ``avar`` about
    ``offset + a x``, from ``x``: projected Newton steps (the observed information where it is positive
    definite, else the expected one), halved until the deviance falls, variables at 0 that the gradient
    pushes below it held there."""
    scale = np.min(avar[:, None] / np.maximum(a, 1e-300), axis=0)  # each term's size where it first matters
    b = a * scale[None, :]
    u = np.maximum(x / scale, 0.0)
    k = 0.5 * edf

    def dev(u):
        r = avar / np.maximum(offset + b @ u, MODEL_FLOOR * avar)
        return float(np.sum(k * (r - np.log(r) - 1.0)))

    d = dev(u)
    for _ in range(PROFILE_ITERATIONS):
        m = np.maximum(offset + b @ u, MODEL_FLOOR * avar)
        r = avar / m
        g = b.T @ (k * (1.0 - r) / m)
        free = ~((u <= 0.0) & (g > 0.0))
        if not free.any():
            break
        bf = b[:, free]
        h = bf.T @ (bf * (k * (2.0 * r - 1.0) / m**2)[:, None])
        if np.any(np.linalg.eigvalsh(h) <= 0.0):
            h = bf.T @ (bf * (k / m**2)[:, None])
        step = np.zeros_like(u)
        step[free] = -np.linalg.solve(h, g[free])
        for _ in range(40):
            trial = np.maximum(u + step, 0.0)
            d_trial = dev(trial)
            if d_trial <= d:
                break
            step *= 0.5
        else:
            break
        done = d - d_trial <= 1e-10 * (1.0 + d)
        u, d = trial, d_trial
        if done:
            break
    return u * scale


def _profile_interval(avar: np.ndarray, a: np.ndarray, edf: np.ndarray, c: np.ndarray, j: int,
                      threshold: float) -> tuple[float, float]:
    """The interval of the squared figure ``c[j]`` where twice the profile log-likelihood stays within
    ``threshold`` of its maximum (the other squared figures, >= 0, re-fitted at each value of ``c[j]``).

    ``avar`` (M,) the Allan variances, ``a`` (M, J) the design, ``edf`` (M,) their degrees of freedom, ``c``
    (J,) the fitted squared figures.
    """
    others = [k for k in range(a.shape[1]) if k != j]
    c_best = _refit(avar, a, np.zeros(len(avar)), edf, c.copy())
    nll_min = min(_deviance(avar, a @ c_best, edf), _deviance(avar, a @ c, edf))

    def excess(v: float) -> float:
        offset = a[:, j] * v
        x = _refit(avar, a[:, others], offset, edf, c[others].copy()) if others else np.zeros(0)
        return 2.0 * (_deviance(avar, offset + a[:, others] @ x, edf) - nll_min) - threshold

    c_hat = float(c_best[j]) if _deviance(avar, a @ c_best, edf) < _deviance(avar, a @ c, edf) else float(c[j])
    lo = 0.0
    if c_hat > 0 and excess(0.0) > 0:
        lo = brentq(excess, 0.0, c_hat, xtol=1e-6 * c_hat, rtol=1e-6)
    # a step of the size at which the term alone would give the largest Allan variance measured
    step = max(c_hat, float(np.max(avar) / np.max(a[:, j])))
    hi = c_hat + step
    for _ in range(60):
        if excess(hi) > 0:
            break
        step *= 2.0
        hi = c_hat + step
    else:
        return lo, math.inf
    return lo, brentq(excess, c_hat, hi, xtol=1e-6 * (hi - c_hat), rtol=1e-6)  # xtol: c is tiny in SI units


def fit_terms(curve: AllanCurve, terms=DEFAULT_TERMS, ramp: str = "seen", tau_min_s: float = FIT_TAU_MIN_S) -> NoiseFit:
    """Fit ``terms`` (of N, B, K, R) to ``curve`` over its averaging times from ``tau_min_s`` (s).

    ``ramp``: "seen" adds the rate ramp R when the fit finds it above :data:`RAMP_SEEN_SIGMA` sigma, "no"
    never (R in ``terms`` always fits it). CalibError when fewer points than terms remain.
    """
    terms = tuple(t for t in TERMS if t in terms)
    sel = curve.tau_s >= tau_min_s * (1 - 1e-9)
    if int(sel.sum()) < len(terms) + 1:
        raise CalibError(f"the Allan deviation has {int(sel.sum())} points from {tau_min_s:g} s; fitting "
                         f"{', '.join(terms)} needs at least {len(terms) + 1}")
    c, cov, chi2_dof, fitted = _solve(curve, sel, terms)
    if ramp == "seen" and "R" not in terms and int(sel.sum()) >= len(terms) + 2:
        with_r = (*terms, "R")
        c2, cov2, chi2_2, fitted2 = _solve(curve, sel, with_r)
        if c2[-1] > RAMP_SEEN_SIGMA * math.sqrt(cov2[-1, -1]):
            terms, c, cov, chi2_dof, fitted = with_r, c2, cov2, chi2_2, fitted2
    fits = {}
    for j, t in enumerate(terms):
        inflation = CORRELATION_INFLATION[t] ** 2
        lo, hi = _profile_interval(fitted.adev[sel] ** 2, _design(fitted.tau_s[sel], terms), fitted.edf[sel], c,
                                   j, CHI2_1_95 * inflation * max(chi2_dof, 1.0))
        fits[t] = _term_fit(t, c[j], cov[j, j] * inflation, lo, hi)
    figures = NoiseFigures(**{t: f.value for t, f in fits.items()})
    model = np.sqrt(figures.avar(fitted.tau_s[sel]))
    max_rel = float(np.max(np.abs(fitted.adev[sel] / model - 1.0)))
    return NoiseFit(figures, fits, chi2_dof, max_rel, _floor_tau(figures, fitted.tau_s), fitted, int(sel.sum()))


def _floor_tau(figures: NoiseFigures, tau: np.ndarray) -> float | None:
    """The averaging time of the fitted curve's minimum, s (None without a bias instability)."""
    if figures.B <= 0:
        return None
    grid = np.geomspace(tau[0], tau[-1] * 10, 400)
    return float(grid[int(np.argmin(figures.avar(grid)))])
