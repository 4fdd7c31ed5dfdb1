"""A simulated sample's noise does not depend on how the host's reads split the samples (issue 26): the
same seed gives the same samples whether the FIFO is read every sample or once a second, so a run's
noise does not depend on this machine's pace or the poll interval."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel
from drivers.sensors.sim.noise import NoiseConfig
from drivers.sensors.sim.physics import StaticPhysics
from drivers.sensors.sim.sampler import LazySampler


def _samples(noise: str, reads_s: list[float]) -> dict:
    """Samples of 3 s at 100 Hz, caught up at the given read intervals."""
    clock = VirtualClock()
    rng = np.random.default_rng(7)
    sampler = LazySampler(StaticPhysics(), AccelErrorModel.draw(rng), clock, seed=11,
                          gyro_errors=GyroErrorModel.draw(rng), noise=NoiseConfig(model=noise))
    sampler.restart(100.0, 44.0, delay_s=0.0049, gyro_bandwidth_hz=42.0)
    parts = []
    for dt in reads_s:
        clock.sleep(dt)
        s = sampler.catch_up(keep_last=10_000)
        if s is not None:
            parts.append(s)
    return {k: np.concatenate([p[k] for p in parts]) for k in ("t_s", "accel_g", "gyro_dps", "temp_c")}


@pytest.mark.parametrize("noise", ["dlpf", "white"])
def test_the_noise_of_a_sample_is_the_same_however_the_reads_split_the_samples(noise):
    rng = np.random.default_rng(3)
    uneven = list(rng.choice([0.01, 0.03, 0.05, 0.17, 0.4], size=200))
    every_sample = _samples(noise, [0.01] * 300)
    once_a_second = _samples(noise, [1.0] * 3)
    irregular = _samples(noise, uneven)
    n = len(once_a_second["t_s"])
    assert n == 300 and len(every_sample["t_s"]) == n
    # the same draws; the dlpf filter's arithmetic runs in another order for a long block (a recursive
    # filter) than for a short one (a loop), so equal up to rounding (1e-16 g), not bit for bit
    exact = noise == "white"
    for k in ("t_s", "accel_g", "gyro_dps", "temp_c"):
        for other in (every_sample, irregular):
            if exact:
                np.testing.assert_array_equal(other[k][:n], once_a_second[k][:n], err_msg=k)
            else:
                np.testing.assert_allclose(other[k][:n], once_a_second[k][:n], rtol=0, atol=1e-12, err_msg=k)
    assert np.std(once_a_second["accel_g"][:, 0]) > 0  # there is noise to compare
