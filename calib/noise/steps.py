"""A unit's noise figures from a calibration's own static steps, the family's figures as the prior (issue 28 item 5).

Without a noise profile the recording speaks first: each static step is a short static record, so the
overlapping Allan variances of one axis over all the steps, pooled at octave averaging times up to a quarter
of each step (:func:`pooled_allan`), show the white noise, and on long steps the start of the floor and of the
walk. The figures follow from the likelihood of those variances (chi-squared with their pooled degrees of
freedom: each step is an independent record) times a log-normal prior on the squared floor and walk about the
family's (:func:`fit_with_prior`): where the steps are too short to see the wander the answer stays the family's,
where they are long enough it moves to the unit's. What sets a long session's bias sigma is mostly the wander
between steps minutes apart, which no step reaches on its own: the steps' means about the calibration's affine
model show it (:class:`StepMeansOfAxis`, built by :func:`step_means_of_axis`; a few degrees of freedom, each
worth many of the Allan variances'), and their restricted likelihood joins the fit (``between``). What a solve is
weighed with is :func:`posterior_figures`: N at the posterior's mode, B and K the square roots of the posterior
means of their squares (an hour's steps show one axis's walk to a few degrees of freedom, and the mode of so
skewed a posterior lies below the variance it implies on average).

When that is worth doing is a rule of its own (:func:`steps_show_wander`): the longest averaging time the steps
reach (a quarter of the longest step, on the octave grid) must be at least :data:`REACH_OF_CROSSING` of the
crossing of the steps' white noise and the family's floor, ``(N / B)^2``; shorter steps leave the prior (measured:
on six 10 s steps the posterior is the prior within 1 %). And an answer within :data:`NEAR_PRIOR` of the prior on
every figure is the prior's (:func:`moved_off`). The module needs numpy alone (its own small Newton minimiser, no
scipy), so a solve that asks whether its steps are long enough loads nothing more; Greenhall's degrees of freedom
(allantools) are loaded only when the fit runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from calib.errors import CalibError
from calib.noise.allan import FIT_TAU_MIN_S, MAX_TAU_FRACTION, edf_for
from calib.noise.terms import REGISTRY_B_FLOOR, TERMS, NoiseFigures
from calib.numerics.wander import wander_cov

#: the prior's spread: ln of a unit's figure over the family's, 1 sigma (0.5-2x the family is +-0.43 sigma). Wide
#: on purpose: the answer is the unit's, not the best guess over units; with 0.8 (until 2026-11-26) six 600 s steps
#: left the walk of units 0.5x and 2x their family's 30-50 % of the way to the prior (benchmarks/bench_unit_noise.py
#: --dwell 600: observed scatter / reported sigma 0.69-1.48); with 1.6 and the step means (:class:`StepMeansOfAxis`)
#: the ratios lie 0.05 rms in ln from those of the unit's true figures (0.14 before), with 2.5 0.06
PRIOR_SD_LN = 1.6
#: the longest averaging time of the steps' pooled Allan variance, as a share of each step: a half (the overlapping
#: variance's last octave; a characterisation stops at a quarter, :data:`calib.noise.allan.MAX_TAU_FRACTION`), as
#: six 600 s steps reach 164 s, past the crossing of white noise and floor, instead of 82 s
STEPS_TAU_FRACTION = 0.5
#: the steps are long enough to move the figures off the prior when the longest averaging time they reach is at
#: least this share of the crossing of their white noise and the prior's floor, ``(N / B)^2`` (an MPU-9150 at
#: 100 Hz, N about 340 ug/rtHz through its 44 Hz filter, floor 28 ug: a crossing of about 145 s, so steps of
#: 164 s or more, whose quarter reaches the 41 s octave). Measured on six steps of units 0.5x and 2x their family
#: (8 sessions each): at 60 s steps (reach 0.07 of the crossing) the floor's posterior scatters by 0.55-0.62 in ln
#: about a mean moved by -0.15..+0.38 of ln 2; at 300 s (0.28) it lands at 0.70x and 2.09x the family's (sd 0.31,
#: 0.11); at 600 s (0.57) at 0.57x and 1.92x.
REACH_OF_CROSSING = 0.25
#: an answer within this share of the prior on every figure (B and K) is the prior's: the steps did not move it
NEAR_PRIOR = 0.10


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


def _phase(y: np.ndarray) -> np.ndarray:
    """The phase (running sum, from 0) of rate-like samples ``y``."""
    return np.concatenate([[0.0], np.cumsum(y)])


def _avar_terms(x: np.ndarray, m: int) -> tuple[float, int]:
    """Sum of squared second differences of the phase ``x`` at ``m`` samples, and how many. (``np.einsum``, not
    ``d @ d``: BLAS's threads make a 60,000-sample dot product 12 ms on a busy machine, the sum 0.05 ms.)"""
    d = x[2 * m:] - 2.0 * x[m:-m] + x[:-2 * m]
    return float(np.einsum("i,i->", d, d)), len(d)


def _octaves(n_max: int, rate_hz: float, tau_min_s: float, max_fraction: float = MAX_TAU_FRACTION) -> list[int]:
    """The octave cluster sizes m (samples) from ``tau_min_s`` (s) up to ``max_fraction`` (a quarter) of ``n_max``
    samples."""
    m_max, m, out = max(int(n_max * max_fraction), 1), 1, []
    while m <= m_max:
        if m / rate_hz >= tau_min_s * (1 - 1e-9):
            out.append(m)
        m *= 2
    return out


def pooled_allan(records, rate_hz: float, tau_min_s: float = FIT_TAU_MIN_S,
                 max_fraction: float = MAX_TAU_FRACTION) -> PooledAllan:
    """Pooled overlapping Allan variances of ``records`` (a list of (n_i,) arrays of one axis, unit) at octave
    averaging times from ``tau_min_s`` (s) up to a quarter of the longest record; a record contributes where it
    holds at least four averaging times. CalibError for no record of 16 samples or more."""
    ys = [np.asarray(r, float) - np.mean(r) for r in records if len(r) >= 16]
    if not ys:
        raise CalibError("no static step holds 16 samples: the steps' own noise cannot be estimated")
    lengths = np.array([len(y) for y in ys])
    xs = [_phase(y) for y in ys]
    tau, avar, count, use = [], [], [], []
    for m in _octaves(int(lengths.max()), rate_hz, tau_min_s, max_fraction):
        s, k, row = 0.0, 0, []
        for y, x in zip(ys, xs):
            ok = len(y) * max_fraction >= m
            row.append(ok)
            if ok:
                ss, kk = _avar_terms(x, m)
                s, k = s + ss, k + kk
        if k:
            t = m / rate_hz
            tau.append(t), avar.append(s / (2.0 * k * m**2)), count.append(k), use.append(row)
    return PooledAllan(np.array(tau), np.array(avar), np.array(count), np.array(use, bool), lengths, float(rate_hz))


@dataclass(frozen=True)
class StepMeansOfAxis:
    """The static steps' means of one axis and what the wander makes of them between the steps (:func:`step_means_of_axis`).

    residual : (K,) the means less their least-squares fit by ``design``, unit; design : (K, p) the calibration's
    linear model of the axis at each step (an affine model of the nominal gravity: ``[1, f_x, f_y, f_z]``);
    duration_s : (K,) each mean's capture time, s (its white noise ``N^2 / d``); flicker : (K, K) the covariance
    of the means per unit squared Allan floor (the family's flicker corner); walk : (K, K) per unit K^2 (unit^2 / s);
    pose_var : (K,) each mean's variance from the table's pose errors, unit^2 (0: a perfect table).
    """

    residual: np.ndarray
    design: np.ndarray
    duration_s: np.ndarray
    flicker: np.ndarray
    walk: np.ndarray
    pose_var: np.ndarray

    @property
    def dof(self) -> int:
        """The residuals' degrees of freedom (steps less the design's rank)."""
        return len(self.residual) - int(np.linalg.matrix_rank(self.design))

    @cached_property
    def parts(self) -> np.ndarray:
        """(3, K, K): the means' covariance per unit squared figure (N^2, floor^2, K^2), built once: the fit's
        minimiser evaluates :meth:`reml` many times."""
        return np.stack((np.diag(1.0 / self.duration_s), self.flicker, self.walk))

    def restricted(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The restricted (REML) negative log-likelihood of the residuals for the squared figures ``c`` (..., 3) =
        (N^2, floor^2, K^2), up to a constant, stacked over ``c``'s leading axes: ``0.5 (ln|V| + ln|X'V^-1 X| +
        r'P r)`` with ``V = diag(N^2 / d + pose_var) + floor^2 flicker + K^2 walk``; and ``P`` (..., K, K) and
        ``P r`` (..., K), which :meth:`reml`'s gradient needs."""
        v = np.diag(self.pose_var) + np.einsum("...i,ijk->...jk", np.asarray(c, float), self.parts)
        vi = np.linalg.inv(v)
        x = self.design
        xtvx = x.T @ vi @ x
        p = vi - vi @ x @ np.linalg.solve(xtvx, x.T @ vi)
        pr = p @ self.residual
        value = 0.5 * (np.linalg.slogdet(v)[1] + np.linalg.slogdet(xtvx)[1] + pr @ self.residual)
        return value, p, pr

    def reml(self, c: np.ndarray) -> tuple[float, np.ndarray]:
        """:meth:`restricted` at one ``c`` (3,) and its gradient in ``c``."""
        value, p, pr = self.restricted(c)
        grad = np.array([0.5 * (float(np.sum(p * q)) - float(pr @ q @ pr)) for q in self.parts])
        return float(value), grad


#: the fewest residual degrees of freedom the step means must leave for :func:`fit_with_prior` to weigh them
MIN_BETWEEN_DOF = 1


def step_means_of_axis(means, f_nominal, start_s, end_s, corner_s: float, pose_var=0.0) -> StepMeansOfAxis | None:
    """:class:`StepMeansOfAxis` of the static steps of one axis: their ``means`` (K,), unit, at the nominal gravity
    ``f_nominal`` (K, 3), g, captured over ``[start_s, end_s]`` (K,), s; ``corner_s`` the family's flicker corner
    (s); ``pose_var`` the table's pose variance in the axis's unit squared (scalar or (K,)). None when the affine
    model leaves fewer than :data:`MIN_BETWEEN_DOF` degrees of freedom or a step has no duration."""
    y = np.asarray(means, float)
    x = np.column_stack([np.ones(len(y)), np.asarray(f_nominal, float)])
    a, b = np.asarray(start_s, float), np.asarray(end_s, float)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y)) and np.all(b > a)):
        return None
    if len(y) - int(np.linalg.matrix_rank(x)) < MIN_BETWEEN_DOF:
        return None
    mid, dur = 0.5 * (a + b), b - a
    residual = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
    flicker = wander_cov(mid, dur, 1.0 / REGISTRY_B_FLOOR, 0.0, corner_s)  # an Allan floor of 1 (registry B sqrt 2)
    walk = wander_cov(mid, dur, 0.0, 1.0, corner_s)
    return StepMeansOfAxis(residual, x, dur, flicker, walk, np.broadcast_to(np.asarray(pose_var, float), y.shape).copy())


def _allan_deviance(pooled: PooledAllan, model: np.ndarray, edf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The negative log-likelihood (less its minimum) of ``pooled``'s variances, each chi-squared with ``edf``
    degrees of freedom about ``model`` (..., M), summed over the averaging times (...); and ``avar / model``."""
    r = pooled.avar / model
    return 0.5 * np.sum(edf * (r - np.log(r) - 1.0), axis=-1), r


#: the figures the steps' fit states, in the order of its squared figures ``c``
FIGURES = ("N", "B", "K")


def _design(tau: np.ndarray) -> np.ndarray:
    """(M, 3): the Allan variance at each averaging time ``tau`` (M,) per unit squared figure of :data:`FIGURES`."""
    return np.column_stack([TERMS[t][1](tau) for t in FIGURES])


def _noise_exponents(tau: np.ndarray, c: np.ndarray) -> np.ndarray:
    """At each averaging time ``tau`` (M,), the noise exponent (alpha) of the term that dominates the squared figures
    ``c`` (N^2, floor^2, K^2)."""
    return np.array([TERMS[FIGURES[j]][2] for j in np.argmax(_design(tau) * c[None, :], axis=1)])


def fit_with_prior(pooled: PooledAllan, prior: NoiseFigures, sd_ln: float = PRIOR_SD_LN,
                   between: StepMeansOfAxis | None = None) -> NoiseFigures:
    """The figures N, B (the Allan floor), K that maximise the chi-squared likelihood of ``pooled`` times a
    log-normal prior on B and K about ``prior``'s (``sd_ln`` in ln of the figure; N has none: the steps always
    show it), times, with ``between``, the restricted likelihood of the step means' residuals (the wander between
    steps minutes apart, which no step's own Allan variance reaches: :meth:`StepMeansOfAxis.reml`). A prior term
    at 0 stays 0."""
    tau, avar = pooled.tau_s, pooled.avar
    a = _design(tau)
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
            dev, r = _allan_deviance(pooled, model, edf)
            dev = float(dev)
            grad_c = a.T @ (0.5 * edf * (1.0 - r) / model)
            if between is not None:
                dev_b, grad_b = between.reml(c)
                dev, grad_c = dev + dev_b, grad_c + grad_b
            g = (grad_c * c)[keep]
            pen = (z - np.log(c0[keep])) / (2.0 * sd_ln) ** 2  # ln c = 2 ln figure: sd 2 sd_ln
            pen[0] = 0.0  # N: no prior
            return dev + 0.5 * float(np.sum(pen * (z - np.log(c0[keep])))), g + pen

        x = _minimise(f, x)
        c = np.zeros(3)
        c[keep] = np.exp(x)
        alpha = _noise_exponents(tau, c)
    return NoiseFigures(N=math.sqrt(c[0]), B=math.sqrt(c[1]), K=math.sqrt(c[2]))


#: :func:`posterior_figures` sums the posterior on a grid of this many points per figure, in ln of its square ...
GRID_POINTS = 25
#: ... first over this much about the mode on either side (a factor of 400), then over :data:`GRID_SDS` of the
#: posterior's own sd about its mean (at least :data:`GRID_MIN_HALF_WIDTH_LN`), where the sum is exact to well
#: below 1 % (a normal posterior of sd 0.1 in ln on 25 points over +-6 sd: 0.5 sd apart)
GRID_HALF_WIDTH_LN = 6.0
GRID_SDS = 6.0
GRID_MIN_HALF_WIDTH_LN = 0.05


def posterior_figures(pooled: PooledAllan, prior: NoiseFigures, sd_ln: float = PRIOR_SD_LN,
                      between: StepMeansOfAxis | None = None) -> NoiseFigures:
    """The figures to weigh a solve with: N at the posterior's mode (:func:`fit_with_prior`; the steps always pin
    it), and B and K the square roots of the posterior means of B^2 and K^2, the mean over what the steps leave
    uncertain about them (the same likelihoods and prior, summed on a grid in ln B^2 and ln K^2, N at its mode).

    Why the mean: a parameter whose variance is mostly one axis's walk has variance ``~ K^2``, and the variance to
    state for it is the posterior mean of that (the mean of the error's variance over the figures the data allow),
    not its value at the most probable figure. Steps that show the walk poorly leave a posterior skewed towards
    larger K^2 than its mode; steps that pin it leave the mode. Measured on one-hour six-face sessions (600 s
    steps, units 0.5-2x their family, docs/noise.md "The posterior mean"): the mean's K^2 is 1.04-1.46x the
    mode's per axis at the median over sessions, and 71 of 72 ratios of scatter to sigma lie within 0.8-1.25
    (69 with the mode)."""
    mode = fit_with_prior(pooled, prior, sd_ln, between)
    keep = np.array([prior.B > 0, prior.K > 0])
    if not keep.any():
        return mode
    c_hat = np.array([mode.N**2, mode.B**2, mode.K**2])
    a = _design(pooled.tau_s)
    edf = pooled.edf(_noise_exponents(pooled.tau_s, c_hat))
    z0 = np.log(np.where(keep, [prior.B**2, prior.K**2], 1.0))

    def neg_log_posterior(z: np.ndarray) -> np.ndarray:  # z (..., 2): ln B^2, ln K^2 (-inf: a term at 0)
        c = np.concatenate([np.full(z.shape[:-1] + (1,), c_hat[0]), np.exp(z)], axis=-1)
        value = _allan_deviance(pooled, c @ a.T, edf)[0]
        if between is not None:
            value = value + between.restricted(c)[0]
        return value + 0.5 * np.sum(np.where(keep, (z - z0) ** 2, 0.0), axis=-1) / (2.0 * sd_ln) ** 2

    centre = np.log(np.where(keep, np.maximum(c_hat[1:], 1e-300), 1.0))
    half = np.full(2, GRID_HALF_WIDTH_LN)
    for _ in range(2):  # over the wide grid, then over the posterior's own extent
        axes = [np.linspace(m - h, m + h, GRID_POINTS) if k else np.array([-np.inf])
                for m, h, k in zip(centre, half, keep)]
        z = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
        f = neg_log_posterior(z)
        w = np.exp(-(f - f.min()))
        w /= w.sum()
        zk = np.where(keep, z, 0.0)
        centre = np.einsum("ij,ijd->d", w, zk)
        sd = np.sqrt(np.einsum("ij,ijd->d", w, (zk - centre) ** 2))
        half = np.clip(GRID_SDS * sd, GRID_MIN_HALF_WIDTH_LN, GRID_HALF_WIDTH_LN)
    mean_c = np.einsum("ij,ijd->d", w, np.exp(z))
    return NoiseFigures(N=mode.N, B=math.sqrt(mean_c[0]), K=math.sqrt(mean_c[1]))


#: the longest step of :func:`_minimise` in any parameter (ln of a squared figure: a factor of e^3 = 20)
MAX_STEP = 3.0


def _minimise(f, x0: np.ndarray, iterations: int = 100) -> np.ndarray:
    """The minimum of the smooth ``f(x) -> (value, gradient)`` of a few parameters near ``x0``: Newton's steps on
    the gradient's forward-difference Hessian, damped (Levenberg) until the step, at most :data:`MAX_STEP` in any
    parameter, descends (Armijo) to a finite value. Stops when a step changes ``x`` by less than 1e-9 or the value
    by less than 1e-12 of itself."""
    x = np.array(x0, float)
    fx, g = f(x)
    lam = 0.0
    for _ in range(iterations):
        h = np.empty((len(x), len(x)))
        for j in range(len(x)):
            e = np.zeros(len(x))
            e[j] = 1e-6
            h[:, j] = (f(x + e)[1] - g) / 1e-6
        h = 0.5 * (h + h.T)
        while True:
            try:
                step = -np.linalg.solve(h + lam * np.eye(len(x)), g)
            except np.linalg.LinAlgError:
                step = None
            if step is not None and float(g @ step) < 0:
                step *= min(1.0, MAX_STEP / float(np.max(np.abs(step))))
                with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                    f_new, g_new = f(x + step)
                if np.isfinite(f_new) and np.all(np.isfinite(g_new)) and f_new <= fx + 1e-4 * float(g @ step):
                    break
            lam = max(4.0 * lam, 1e-6 * (1.0 + float(np.abs(np.diag(h)).max())))
            if lam > 1e12:
                return x
        lam *= 0.25
        converged = float(np.max(np.abs(step))) < 1e-9 or fx - f_new <= 1e-12 * max(abs(fx), 1.0)
        x, fx, g = x + step, f_new, g_new
        if converged:
            break
    return x


def white_noise(record, rate_hz: float, tau_min_s: float = FIT_TAU_MIN_S) -> float:
    """N (unit/sqrt(Hz)) of one record (n,), unit: ``sqrt(tau avar(tau))`` at the first octave averaging time from
    ``tau_min_s`` (s), where the white noise dominates; its first 64 such clusters' worth of samples suffice.
    NaN for a record shorter than four such clusters."""
    y = np.asarray(record, float)
    ms = _octaves(len(y), rate_hz, tau_min_s)
    if not ms:
        return math.nan
    y = y[: 64 * ms[0]] - np.mean(y[: 64 * ms[0]])
    s, k = _avar_terms(_phase(y), ms[0])
    return math.sqrt(s / (2.0 * k * ms[0] ** 2) * ms[0] / rate_hz)


def reach_s(longest_samples: int, rate_hz: float, tau_min_s: float = FIT_TAU_MIN_S) -> float:
    """The longest averaging time (s) the pooled Allan variance of steps whose longest holds ``longest_samples``
    samples reaches (the octave at or below a quarter of it); 0 when none."""
    ms = _octaves(int(longest_samples), rate_hz, tau_min_s)
    return ms[-1] / rate_hz if ms else 0.0


def steps_show_wander(records, rate_hz: float, prior: NoiseFigures) -> bool:
    """Whether static steps ``records`` (a list of (n_i,) arrays of one axis) are long enough to move the floor
    off ``prior``'s: the longest averaging time they reach is at least :data:`REACH_OF_CROSSING` of the crossing of
    their own white noise (the longest step's) and the prior's floor. False without a prior floor."""
    if not records or prior.B <= 0:
        return False
    longest = max(records, key=len)
    n = white_noise(longest, rate_hz)
    return math.isfinite(n) and reach_s(len(longest), rate_hz) >= REACH_OF_CROSSING * (n / prior.B) ** 2


def moved_off(figures: NoiseFigures, prior: NoiseFigures, share: float = NEAR_PRIOR) -> bool:
    """Whether ``figures``' B or K lies more than ``share`` away from ``prior``'s (a prior figure of 0 stays 0)."""
    return any(p > 0 and abs(f / p - 1.0) > share for f, p in ((figures.B, prior.B), (figures.K, prior.K)))
