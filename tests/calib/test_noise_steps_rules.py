"""When a calibration's own steps say more than the family (calib.noise.steps, issue 28 item 5): steps whose longest
averaging time reaches a quarter of the crossing of their white noise and the family's floor are fitted; an answer
within 10 % of the prior on every figure is the prior's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.noise.steps import (NEAR_PRIOR, REACH_OF_CROSSING, fit_with_prior, moved_off, pooled_allan, reach_s,
                               steps_show_wander, white_noise)
from calib.noise.terms import NoiseFigures

RATE_HZ = 100.0
N_WHITE = 340e-6  # an MPU-9150's Allan N through its 44 Hz filter, g/rtHz
PRIOR = NoiseFigures(B=40e-6 / math.sqrt(2), K=4e-6)  # the family's floor and walk
CROSSING_S = (N_WHITE / PRIOR.B) ** 2  # 144.5 s


def _white(seconds: float, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, N_WHITE * math.sqrt(RATE_HZ), int(seconds * RATE_HZ))


def test_the_white_noise_of_a_step_is_read_at_its_first_octave():
    assert white_noise(_white(60.0, 1), RATE_HZ) == pytest.approx(N_WHITE, rel=0.1)
    assert math.isnan(white_noise(_white(1.0, 1), RATE_HZ))  # shorter than four 0.64 s clusters


def test_steps_show_the_wander_from_a_quarter_of_the_crossing_on():
    assert reach_s(16384, RATE_HZ) == pytest.approx(40.96) and reach_s(16383, RATE_HZ) == pytest.approx(20.48)
    assert REACH_OF_CROSSING * CROSSING_S == pytest.approx(36.1, abs=0.1)
    assert not steps_show_wander([_white(10.0, s) for s in range(6)], RATE_HZ, PRIOR)  # the README's 10 s steps
    assert not steps_show_wander([_white(160.0, 2)], RATE_HZ, PRIOR)  # reaches 20.5 s
    assert steps_show_wander([_white(10.0, 3), _white(170.0, 4)], RATE_HZ, PRIOR)  # the longest reaches 41 s
    assert not steps_show_wander([_white(600.0, 5)], RATE_HZ, NoiseFigures(B=0.0, K=4e-6))  # no floor to cross


def test_an_answer_near_the_prior_is_the_priors():
    assert NEAR_PRIOR == 0.10
    assert not moved_off(NoiseFigures(B=1.09 * PRIOR.B, K=0.91 * PRIOR.K), PRIOR)
    assert moved_off(NoiseFigures(B=PRIOR.B, K=1.11 * PRIOR.K), PRIOR)
    assert not moved_off(NoiseFigures(B=PRIOR.B, K=5e-6), NoiseFigures(B=PRIOR.B, K=0.0))  # a walk of 0 stays 0


def test_the_fit_is_the_maximum_of_likelihood_times_prior():
    pooled = pooled_allan([_white(600.0, s) for s in range(6)], RATE_HZ)
    fig = fit_with_prior(pooled, PRIOR)
    assert fig.N == pytest.approx(N_WHITE, rel=0.03)
    assert fig.B < PRIOR.B and fig.K < PRIOR.K  # steps of white noise alone: less wander than the family's
