"""A unit whose axes wander each by their own figures (issue 28: a unit's noise profile): the accelerometer's pinv
solve weighs each axis with its own wander; every other consumer sees the RMS over the axes."""

from __future__ import annotations

import numpy as np

import calib
from calib.numerics.stability import AxisStability, BiasStability, axis_cov
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix

FAMILY = BiasStability(40e-6, 4e-6, 5000.0, "g")
TRUTH = Truth(triangular_matrix([8150.0, 8230.0, 8190.0], 0.004, -0.003, 0.002), np.array([120.0, -75.0, 210.0]),
              np.zeros(3))


def _solve(stability):
    steps = make_steps(TRUTH, six_faces(), rng=np.random.default_rng(3))
    steps = steps.__class__(**{**steps.__dict__, "bias_stability": stability, "duration_s": np.full(6, 10.0)})
    return calib.solve(steps, thermal="off")


def test_each_axis_gets_its_own_wander_in_the_bias_sigma():
    axes = (BiasStability(20e-6, 2e-6, 5000.0, "g"), FAMILY, BiasStability(160e-6, 16e-6, 5000.0, "g"))
    own = _solve(AxisStability.of(axes)).sigma["bias_counts"]
    alike = [_solve(a).sigma["bias_counts"][j] for j, a in enumerate(axes)]
    assert np.allclose(own, alike, rtol=1e-9)  # axis j as if the sensor wandered by axis j's figures everywhere
    assert own[0] < own[1] < own[2]


def test_identical_axes_give_the_scalar_figures_result_and_others_see_the_rms():
    same = AxisStability.of((FAMILY,) * 3)
    assert np.allclose(_solve(same).sigma["bias_counts"], _solve(FAMILY).sigma["bias_counts"], rtol=1e-12)
    mixed = AxisStability.of((BiasStability(30e-6, 3e-6, 5000.0, "g"), BiasStability(40e-6, 4e-6, 5000.0, "g"),
                              BiasStability(50e-6, 5e-6, 5000.0, "g")))
    assert np.isclose(mixed.bias_instability, np.sqrt((30e-6**2 + 40e-6**2 + 50e-6**2) / 3))
    t, d = np.arange(6) * 16.0, np.full(6, 10.0)
    assert axis_cov(FAMILY, t, d).shape == (3, 6, 6) and np.allclose(mixed.cov(t, d), BiasStability(
        mixed.bias_instability, mixed.random_walk_per_rts, 5000.0, "g").cov(t, d))
