"""The reported bias sigma includes how far a session's bias stands off the sensor's long-run bias
(flicker slower than the session, random walk): no averaging inside the session reveals it."""

from __future__ import annotations

import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import calib
from calib.accel import BiasStability
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix
from drivers.sensors.chips import CHIPS
from rig.session import adapter

from conftest import REPO

MPU = BiasStability(40e-6, 4e-6, 5000.0)


def test_the_stability_sigma_is_the_flicker_power_below_the_session_plus_the_walk():
    t = 96.0
    flicker = (40e-6 / math.sqrt(2 * math.log(2) / math.pi)) ** 2 * math.log(5000.0 / t) / (2 * math.pi)
    assert MPU.sigma_g(t) == pytest.approx(math.sqrt(flicker + (4e-6) ** 2 * t / 3))
    assert MPU.sigma_g(t) == pytest.approx(52.9e-6, rel=0.01)
    assert BiasStability(40e-6, 0.0, 5000.0).sigma_g(6000.0) == 0.0  # longer than the flicker corner
    assert BiasStability(0.0, 4e-6, 5000.0).sigma_g(300.0) == pytest.approx(4e-6 * 10)


def test_the_solvers_add_it_to_the_bias_sigma_in_quadrature_and_nothing_else():
    truth = Truth(triangular_matrix([8150.0, 8230.0, 8190.0], 0.004, -0.003, 0.002), np.array([120.0, -75.0, 210.0]),
                  np.zeros(3))
    steps = make_steps(truth, six_faces(), rng=np.random.default_rng(3))
    plain = calib.solve(steps, thermal="off")
    with_stab = calib.solve(steps.__class__(**{**steps.__dict__, "bias_stability": MPU}), thermal="off")
    extra = MPU.sigma_g(float(np.ptp(steps.t_s))) * steps.lsb_per_g
    assert np.allclose(with_stab.sigma["bias_counts"], np.hypot(plain.sigma["bias_counts"], extra))
    assert with_stab.sigma["scale_counts_per_g"] == plain.sigma["scale_counts_per_g"]
    assert np.allclose(with_stab.bias_counts, plain.bias_counts)


def test_the_adapter_takes_the_chip_registry_s_figures_and_none_for_unknown_sensors():
    mpu = adapter.bias_stability(SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(
        sensor=SimpleNamespace(model="MPU-9150")))))
    chip = CHIPS["MPU-9150"]
    assert mpu == BiasStability(chip.accel_bias_instability_g, chip.accel_random_walk_g_per_rts,
                                chip.accel_flicker_corner_s)
    assert adapter.bias_stability(SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(
        sensor=SimpleNamespace(model="Xsens MTi"))))) is None


def test_on_the_simulator_s_wandering_bias_the_reported_bias_sigma_holds():
    """Step-level Monte Carlo of benchmarks/bench_uncertainty.py (100 Hz, 44 Hz filter, dlpf noise):
    observed scatter of the bias about the long-run truth / median reported sigma near 1 (it is
    1.5-1.8 without the stability term)."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import bench_uncertainty as bench

    r = bench.run_config(100.0, 44.0, n_sessions=100, n_discover=0)
    assert np.all((r["ratio"][:3] > 0.75) & (r["ratio"][:3] < 1.35)), r["ratio"]
