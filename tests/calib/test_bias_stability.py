"""The reported bias sigma includes how far a session's bias stands off the sensor's long-run bias
(flicker slower than the session, random walk): no averaging inside the session reveals it."""

from __future__ import annotations

import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest

import calib
from calib.numerics.stability import FLICKER_FLOOR, BiasStability
from calib.synthetic import Truth, make_steps, six_faces, triangular_matrix
from drivers.sensors.chips import CHIPS
from drivers.sensors.sim.noise import NoiseProcess, own_stream
from rig.session import adapter

from conftest import REPO

MPU = BiasStability(40e-6, 4e-6, 5000.0)


def test_the_stability_sigma_is_the_scatter_of_the_simulated_chip_s_session_mean():
    """sigma(T) against the simulator's own wander (flicker + random walk, no white noise): the
    spread of T-second means over many fresh sensors, to its statistical precision."""
    t_s, rate_hz, sensors = 40.0, 10.0, 700
    t = np.arange(1, int(t_s * rate_hz) + 1) / rate_hz
    means = np.array([NoiseProcess([40e-6] * 3, [4e-6] * 3, own_stream(seed, 0x5AB), (0.02, 5000.0))
                      .sample(t, [0.0] * 3, None).mean(axis=0) for seed in range(sensors)])
    n = means.size
    tolerance = 4.0 / math.sqrt(2 * n)  # 4 standard errors of a standard deviation from n draws (~4 %)
    assert means.std() / MPU.sigma(t_s) == pytest.approx(1.0, abs=tolerance)
    # the flicker power below 1/T alone (ln(T_c / T), the old formula) falls short by more than that
    only_below = math.sqrt((40e-6 / FLICKER_FLOOR) ** 2 * math.log(5000.0 / t_s) / (2 * math.pi) + 16e-12 * t_s / 3)
    assert means.std() / only_below > 1 + tolerance
    assert BiasStability(0.0, 4e-6, 5000.0).sigma(300.0) == pytest.approx(4e-6 * 10)  # K sqrt(T / 3)


def test_the_solver_weighs_the_steps_with_the_wander_so_the_bias_sigma_holds_the_session_s_stability():
    """Six 10 s faces 15 s apart: the wander is almost common to all steps, so the GLS bias sigma is
    the fit's own with the session's stability in quadrature (what the solver added before it
    weighed the steps with the wander covariance), and the scales gain only what the wander
    between steps adds."""
    truth = Truth(triangular_matrix([8150.0, 8230.0, 8190.0], 0.004, -0.003, 0.002), np.array([120.0, -75.0, 210.0]),
                  np.zeros(3))
    steps = make_steps(truth, six_faces(), rng=np.random.default_rng(3))
    plain = calib.solve(steps, thermal="off")
    wandering = steps.__class__(**{**steps.__dict__, "bias_stability": MPU, "duration_s": np.full(6, 10.0)})
    with_stab = calib.solve(wandering, thermal="off")
    extra = MPU.sigma(float(np.ptp(steps.t_s))) * steps.lsb_per_g
    assert np.allclose(with_stab.sigma["bias_counts"], np.hypot(plain.sigma["bias_counts"], extra), rtol=0.03)
    scale_gain = np.array(with_stab.sigma["scale_counts_per_g"]) / np.array(plain.sigma["scale_counts_per_g"])
    assert np.all((scale_gain > 1.0) & (scale_gain < 1.15)), scale_gain
    assert np.allclose(with_stab.bias_counts, plain.bias_counts, atol=0.5 * np.array(plain.sigma["bias_counts"]))


def test_the_adapter_takes_the_chip_registry_s_figures_and_none_for_unknown_sensors():
    mpu = adapter.bias_stability(SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(
        sensor=SimpleNamespace(model="MPU-9150")))))
    chip = CHIPS["MPU-9150"]
    assert mpu == BiasStability(chip.accel_bias_instability_g, chip.accel_random_walk_g_per_rts,
                                chip.accel_flicker_corner_s, "g")
    assert adapter.bias_stability(SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(
        sensor=SimpleNamespace(model="Xsens MTi"))))) is None


@pytest.mark.slow
def test_on_the_simulator_s_wandering_bias_the_reported_bias_sigma_holds():
    """Step-level Monte Carlo of benchmarks/bench_uncertainty.py (100 Hz, 44 Hz filter, dlpf noise):
    observed scatter of the bias about the long-run truth / median reported sigma near 1 (it is
    1.5-1.8 without the stability term)."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import bench_uncertainty as bench

    r = bench.run_config(100.0, 44.0, n_sessions=100, n_discover=0)
    assert np.all((r["ratio"][:3] > 0.75) & (r["ratio"][:3] < 1.35)), r["ratio"]


def test_the_gyro_and_magnetometer_figures_come_from_the_chip_registry_for_simulator_and_solver():
    """One source: the ChipSpec's figures are the simulator's noise defaults and the solvers' stability."""
    from drivers.sensors.sim.noise import NoiseConfig

    chip = CHIPS["MPU-9150"]
    session = SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(sensor=SimpleNamespace(model="MPU-9150"))))
    for cfg in (NoiseConfig(), NoiseConfig.for_chip("MPU-9150")):
        assert cfg.gyro_bias_instability_dps == [chip.gyro_bias_instability_dps] * 3
        assert cfg.gyro_random_walk_dps_per_rts == [chip.gyro_random_walk_dps_per_rts] * 3
        assert cfg.mag_bias_instability_ut == [chip.mag_bias_instability_ut] * 3
        assert cfg.mag_random_walk_ut_per_rts == [chip.mag_random_walk_ut_per_rts] * 3
        assert cfg.gyro_flicker_band_s[1] == chip.gyro_flicker_corner_s
        assert cfg.mag_flicker_band_s[1] == chip.mag_flicker_corner_s
    gyro, mag = adapter.gyro_bias_stability(session), adapter.mag_bias_stability(session)
    assert (gyro.bias_instability, gyro.random_walk_per_rts, gyro.flicker_corner_s, gyro.unit) == (
        chip.gyro_bias_instability_dps, chip.gyro_random_walk_dps_per_rts, chip.gyro_flicker_corner_s, "deg/s")
    assert (mag.bias_instability, mag.random_walk_per_rts, mag.flicker_corner_s, mag.unit) == (
        chip.mag_bias_instability_ut, chip.mag_random_walk_ut_per_rts, chip.mag_flicker_corner_s, "uT")
    # a chip without a gyroscope or magnetometer has no such figures (and no simulated wander of them)
    adxl = SimpleNamespace(info=SimpleNamespace(rig=SimpleNamespace(sensor=SimpleNamespace(model="ADXL345"))))
    assert adapter.gyro_bias_stability(adxl) is None and adapter.mag_bias_stability(adxl) is None
    assert NoiseConfig.for_chip("ADXL345").gyro_bias_instability_dps == [0.0] * 3
