"""A session of more steps than a dense wander covariance affords (calib.accel.solve.MAX_WANDER_STEPS) is solved
in bounded memory: the steps weighed by their own errors, the bias sigma with the chip's bias-stability term
(a 10,000-step run's solve had reached 24 GB and was killed)."""

from __future__ import annotations

import tracemalloc

import numpy as np

import calib
from calib.accel.solve import MAX_WANDER_STEPS
from calib.accel.inputs import StepMeans
from calib.numerics.stability import BiasStability

FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _steps(k: int) -> StepMeans:
    rng = np.random.default_rng(4)
    f = FACES[np.arange(k) % 6]
    counts = f * 8192 + [30, -20, 50] + rng.normal(0, 0.3, (k, 3))
    return StepMeans(names=tuple(f"s{i}" for i in range(k)), f_nominal_g=f, mean_counts=counts,
                     sem_counts=np.full((k, 3), 0.3), n_samples=np.full(k, 100), temp_c=None, t_s=np.arange(k) * 2.0,
                     lsb_per_g=8192.0, duration_s=np.full(k, 1.0),
                     bias_stability=BiasStability(40e-6, 4e-6, 5000.0, "g"))


def test_more_steps_than_the_limit_solve_in_bounded_memory_with_the_stability_term():
    k = MAX_WANDER_STEPS + 1
    tracemalloc.start()
    try:
        cal = calib.solve(_steps(k), model="triangular", method="pinv", thermal="off")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 200e6, peak  # a dense (K, K) wander covariance per axis alone would be 3 x 32 MB, its solve more
    assert np.allclose(cal.bias_counts, [30, -20, 50], atol=0.1)
    floor = _steps(k).bias_stability_counts()
    assert np.all(np.asarray(cal.sigma["bias_counts"]) >= floor)  # the chip's stability is in the bias sigma


def test_up_to_the_limit_the_wander_is_weighed_as_before():
    small = _steps(60)
    cal = calib.solve(small, model="triangular", method="pinv", thermal="off")
    assert np.all(np.isfinite(cal.sigma["bias_counts"]))
