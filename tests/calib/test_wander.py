"""The wander covariance between step means (calib.numerics.wander) against the simulator's own bias wander
(drivers.sensors.sim.noise.NoiseProcess: flicker as Gauss-Markov processes + a random walk)."""

from __future__ import annotations

import numpy as np
import pytest

from calib.errors import CalibError
from calib.numerics.stability import BiasStability
from calib.numerics.wander import gauss_markov_cov, random_walk_cov, wander_cov, wander_cov_g2, wander_rms_g
from drivers.sensors.sim.noise import NoiseProcess

MPU = BiasStability(40e-6, 4e-6, 5000.0)
STARTS_S = np.array([0.0, 10.0, 300.0, 900.0, 2000.0, 2010.0])
DURATIONS_S = np.array([5.0, 5.0, 20.0, 5.0, 5.0, 5.0])
PER_WINDOW = 11


def _simulated_window_means(stability: BiasStability, runs: int) -> np.ndarray:
    """(3 runs, K) means over the windows of the simulator's wander (no white noise), g."""
    times = np.concatenate([np.linspace(a, a + d, PER_WINDOW) for a, d in zip(STARTS_S, DURATIONS_S)])
    out = []
    for r in range(runs):
        p = NoiseProcess([stability.bias_instability] * 3, [stability.random_walk_per_rts] * 3,
                         np.random.default_rng(r), flicker_band_s=(0.02, stability.flicker_corner_s))
        x = p.sample(times, np.zeros(3), None)
        out.append(x.reshape(len(STARTS_S), PER_WINDOW, 3).mean(axis=1).T)
    return np.concatenate(out)


def _centred(c: np.ndarray) -> np.ndarray:
    """Covariance of the means about their common mean (what a model with a bias sees)."""
    k = len(c)
    p = np.eye(k) - 1.0 / k
    return p @ c @ p


@pytest.mark.parametrize("stability", [MPU, BiasStability(40e-6, 0.0, 5000.0), BiasStability(0.0, 4e-6, 5000.0)],
                         ids=["flicker+walk", "flicker", "walk"])
def test_the_covariance_matches_the_simulated_wander_of_window_means(stability):
    runs = 1200
    emp = _centred(np.cov(_simulated_window_means(stability, runs).T))
    model = _centred(wander_cov_g2(STARTS_S + DURATIONS_S / 2, DURATIONS_S, stability))
    sd = np.sqrt(np.outer(np.diag(model), np.diag(model)))
    # sampling error of a covariance over 3 * runs realisations: ~ sd * sqrt(2 / n); 5 of them
    assert np.all(np.abs(emp - model) < 5 * sd * np.sqrt(2.0 / (3 * runs)) + 0.02 * sd), (emp / sd, model / sd)


def test_window_means_reduce_to_point_values_as_the_windows_shrink():
    t = np.array([0.0, 100.0, 400.0])
    point = np.exp(-np.abs(t[:, None] - t[None, :]) / 300.0)
    assert np.allclose(gauss_markov_cov(t, t + 1e-9, 300.0), point, atol=1e-9)
    # a window much longer than tau averages the process down to 2 tau / d
    assert gauss_markov_cov([0.0], [1000.0], 1.0)[0, 0] == pytest.approx(2e-3, rel=1e-2)
    # the random walk: one window with itself has E|t - s| = d / 3
    assert random_walk_cov([0.0, 10.0], [10.0, 20.0])[0, 0] == pytest.approx((10.0 - 10.0 / 3) / 2)


def test_no_stability_means_no_wander():
    assert not np.any(wander_cov_g2([0.0, 10.0], 5.0, None))
    assert wander_rms_g([0.0, 10.0], 5.0, None) == 0.0
    assert wander_rms_g(np.arange(50) * 60.0, 5.0, MPU) > 50e-6  # an hour of MPU-9150 wanders by ~0.1 mg


def test_one_stability_type_for_every_sensor_in_its_own_unit():
    """BiasStability carries its unit: the accelerometer's covariance is wander_cov_g2's, a gyroscope's is
    wander_cov of its own figures (deg/s), and the g^2 function refuses a stability in another unit."""
    t, d = STARTS_S + DURATIONS_S / 2, DURATIONS_S
    gyro = BiasStability(0.002, 2e-4, 5000.0, "deg/s")
    assert MPU.unit == "g" and np.array_equal(MPU.cov(t, d), wander_cov_g2(t, d, MPU))
    assert np.array_equal(gyro.cov(t, d), wander_cov(t, d, 0.002, 2e-4, 5000.0))
    with pytest.raises(CalibError, match="deg/s"):
        wander_cov_g2(t, d, gyro)
    with pytest.raises(CalibError, match="unit"):
        BiasStability(1e-5, 1e-6, 100.0, "m/s^2")
