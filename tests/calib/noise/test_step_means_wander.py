"""The wander between a calibration's static steps, from their means (calib.noise.steps.StepMeansOfAxis, issue 28
item 5): steps minutes apart differ by a wander no step's own Allan variance reaches, and the residuals of their
means about the calibration's affine model show it, less what the table's pose errors explain. The figures a solve
is weighed with are the posterior means of their squares (calib.noise.steps.posterior_figures), not the mode."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.noise.steps import (PRIOR_SD_LN, _allan_deviance, _design, _noise_exponents, fit_with_prior, pooled_allan,
                               posterior_figures, step_means_of_axis)
from calib.noise.synthetic import noise
from calib.noise.terms import NoiseFigures
from calib.synthetic import six_faces

RATE_HZ = 10.0
FAMILY = NoiseFigures(N=330e-6, B=40e-6 / math.sqrt(2), K=4e-6)  # B: the Allan floor
CORNER_S = 5000.0
DWELL_S, GAP_S = 600.0, 6.0


def _session(truth: NoiseFigures, seed: int, pose_g: float = 0.0, stated_pose_g: float = 0.0):
    """Six 600 s steps of one axis of one continuous record of ``truth``'s noise (g), at the six faces, each face's
    mean moved by a pose error of ``pose_g`` (g, 1 sigma); the steps' samples and their :class:`StepMeansOfAxis`
    with the pose errors stated as ``stated_pose_g`` (g, 1 sigma)."""
    rng = np.random.default_rng(seed)
    drawn = NoiseFigures(N=truth.N, B=truth.B * math.sqrt(2), K=truth.K)  # the generator's B is the registry's
    n, gap = int(DWELL_S * RATE_HZ), int(GAP_S * RATE_HZ)
    y = noise(drawn, 6 * (n + gap), RATE_HZ, rng, CORNER_S)
    f = six_faces()
    steps = [y[i * (n + gap): i * (n + gap) + n] + 0.01 + 1.002 * f[i, 0] + pose_g * rng.standard_normal()
             for i in range(6)]
    start = np.arange(6) * (DWELL_S + GAP_S)
    between = step_means_of_axis([s.mean() for s in steps], f, start, start + DWELL_S, CORNER_S,
                                 np.full(6, stated_pose_g**2))
    return steps, between


def _ln_k_error(truth: NoiseFigures, use_between: bool, seeds=range(12), pose_g: float = 0.0,
                stated_pose_g: float = 0.0) -> float:
    """Median over sessions of ln(fitted K / true K)."""
    out = []
    for seed in seeds:
        steps, between = _session(truth, seed, pose_g, stated_pose_g)
        fit = fit_with_prior(pooled_allan(steps, RATE_HZ), FAMILY, between=between if use_between else None)
        out.append(math.log(fit.K / truth.K))
    return float(np.median(out))


def test_the_step_means_show_a_walk_the_steps_alone_leave_near_the_prior():
    for factor in (0.4, 2.5):  # units whose bias walks 0.4x and 2.5x their family's
        unit = NoiseFigures(N=FAMILY.N, B=FAMILY.B, K=factor * FAMILY.K)
        alone, with_means = _ln_k_error(unit, False), _ln_k_error(unit, True)
        assert abs(with_means) < abs(alone), (factor, alone, with_means)


def test_the_restricted_likelihoods_gradient_is_its_derivative():
    _, between = _session(FAMILY, 1)
    c = np.array([FAMILY.N**2, FAMILY.B**2, FAMILY.K**2])
    value, grad = between.reml(c)
    for j in range(3):
        dc = np.zeros(3)
        dc[j] = 1e-4 * c[j]
        numeric = (between.reml(c + dc)[0] - between.reml(c - dc)[0]) / (2 * dc[j])
        assert numeric == pytest.approx(grad[j], rel=1e-4, abs=1e-6 * abs(value) / c[j])


def test_four_faces_leave_the_affine_model_no_residual_and_are_not_weighed():
    f = six_faces()[[0, 1, 2, 4]]  # +-x, +y, +z: as many steps as the affine model has terms
    assert step_means_of_axis(np.zeros(4), f, np.arange(4) * 10.0, np.arange(4) * 10.0 + 5, CORNER_S) is None
    # a step without a nominal pose, or without a capture time, cannot be placed either
    f6 = six_faces().copy()
    f6[2] = np.nan
    assert step_means_of_axis(np.zeros(6), f6, np.arange(6) * 10.0, np.arange(6) * 10.0 + 5, CORNER_S) is None


def test_the_tables_stated_pose_errors_are_not_taken_for_wander():
    # step means scattered by pose errors of 300 ug (a worm-gear table's class) on a unit of its family's walk:
    # unstated, the scatter is read as a walk far above the family's; stated, K stays near the prior
    pose_g = 300e-6
    unstated = _ln_k_error(FAMILY, True, pose_g=pose_g)
    stated = _ln_k_error(FAMILY, True, pose_g=pose_g, stated_pose_g=pose_g)
    assert unstated > 0.3 and abs(stated) < 0.25 < unstated, (unstated, stated)


def _k2_over_truth(unit: NoiseFigures, fit, seeds=range(12)) -> np.ndarray:
    """Per session, the squared walk ``fit(pooled, prior, between)`` states over the unit's true one."""
    out = []
    for seed in seeds:
        steps, between = _session(unit, seed)
        out.append((fit(pooled_allan(steps, RATE_HZ), FAMILY, between=between).K / unit.K) ** 2)
    return np.array(out)


def test_an_hours_steps_state_the_walk_by_its_posterior_mean_which_lies_nearer_the_truth_than_its_mode():
    # six 600 s steps show a walk at or above the family's to a few degrees of freedom: its mode lies low (a
    # variance known so poorly is skewed), and the mean over what the steps allow is the variance to state
    for factor in (1.0, 2.0):
        unit = NoiseFigures(N=FAMILY.N, B=FAMILY.B, K=factor * FAMILY.K)
        mode, mean = _k2_over_truth(unit, fit_with_prior), _k2_over_truth(unit, posterior_figures)
        assert np.median(mean / mode) > 1.1, (factor, mean / mode)
        assert abs(math.log(np.median(mean))) < abs(math.log(np.median(mode))), (factor, mode, mean)


def test_the_posterior_mean_is_the_posteriors_sum_on_a_fine_grid():
    # the two-pass grid (wide, then the posterior's own extent) against a brute-force sum on 401 x 401 points
    for seed, factor in ((3, 1.0), (5, 0.5)):
        unit = NoiseFigures(N=FAMILY.N, B=FAMILY.B, K=factor * FAMILY.K)
        steps, between = _session(unit, seed)
        pooled = pooled_allan(steps, RATE_HZ)
        mode, mean = fit_with_prior(pooled, FAMILY, between=between), posterior_figures(pooled, FAMILY, between=between)
        c_hat = np.array([mode.N**2, mode.B**2, mode.K**2])
        edf = pooled.edf(_noise_exponents(pooled.tau_s, c_hat))
        z0 = np.log([FAMILY.B**2, FAMILY.K**2])
        zb, zk = np.meshgrid(*(np.linspace(np.log(c) - 9, np.log(c) + 9, 401) for c in c_hat[1:]), indexing="ij")
        c = np.stack([np.full(zb.shape, c_hat[0]), np.exp(zb), np.exp(zk)], axis=-1)
        f = (_allan_deviance(pooled, c @ _design(pooled.tau_s).T, edf)[0] + between.restricted(c)[0]
             + ((zb - z0[0]) ** 2 + (zk - z0[1]) ** 2) / (2 * (2 * PRIOR_SD_LN) ** 2))
        w = np.exp(-(f - f.min()))
        assert mean.K**2 == pytest.approx(np.sum(w * np.exp(zk)) / w.sum(), rel=0.01)
        assert mean.B**2 == pytest.approx(np.sum(w * np.exp(zb)) / w.sum(), rel=0.01)
        assert mean.N == mode.N


def test_a_term_the_prior_holds_at_zero_stays_zero_in_the_mean():
    steps, between = _session(FAMILY, 2)
    no_walk = NoiseFigures(N=FAMILY.N, B=FAMILY.B, K=0.0)
    mean = posterior_figures(pooled_allan(steps, RATE_HZ), no_walk, between=between)
    assert mean.K == 0.0 and mean.B > 0
