"""A unit's noise from a calibration's own static steps, the family's figures as the prior (calib.noise.steps,
issue 28 item 5): short steps leave the family's answer, long ones move it to the unit's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.errors import CalibError
from calib.noise.allan import allan_curve
from calib.noise.steps import fit_with_prior, pooled_allan
from calib.noise.synthetic import noise
from calib.noise.terms import NoiseFigures

RATE_HZ = 100.0
FAMILY = NoiseFigures(N=330e-6, B=40e-6 / math.sqrt(2), K=4e-6)  # B: the Allan floor


def _steps(truth: NoiseFigures, n_steps: int, seconds: float, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    drawn = NoiseFigures(N=truth.N, B=truth.B * math.sqrt(2), K=truth.K)  # the generator's B is the registry's
    return [noise(drawn, int(seconds * RATE_HZ), RATE_HZ, rng) for _ in range(n_steps)]


def test_one_record_pools_to_its_own_overlapping_allan_variance():
    (y,) = _steps(FAMILY, 1, 600.0, 1)
    pooled = pooled_allan([y], RATE_HZ, tau_min_s=0.1)
    curve = allan_curve(y, RATE_HZ, tau_min_s=0.1)
    assert np.allclose(pooled.tau_s, curve.tau_s) and np.allclose(pooled.avar, curve.adev**2, rtol=1e-9)


def test_short_steps_leave_the_familys_wander_long_ones_find_the_units():
    unit = NoiseFigures(N=FAMILY.N, B=FAMILY.B, K=2.5 * FAMILY.K)  # a unit whose bias walks 2.5x its family's
    short = fit_with_prior(pooled_allan(_steps(unit, 6, 10.0, 2), RATE_HZ), FAMILY)
    assert abs(math.log(short.K / FAMILY.K)) < 0.2 and abs(math.log(short.B / FAMILY.B)) < 0.2
    assert abs(short.N / unit.N - 1) < 0.05  # the white noise is the steps' own
    long = fit_with_prior(pooled_allan(_steps(unit, 6, 1800.0, 3), RATE_HZ), FAMILY)
    assert abs(math.log(long.K / unit.K)) < abs(math.log(long.K / FAMILY.K)), long


def test_steps_too_short_for_any_allan_variance_are_refused_in_one_line():
    with pytest.raises(CalibError, match="no static step holds 16 samples"):
        pooled_allan([np.zeros(5)], RATE_HZ)
