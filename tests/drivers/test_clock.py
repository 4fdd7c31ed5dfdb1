"""The clocks the drivers and simulators share: the elastic clock waits for a late reader, the strict
one does not (docs/simulated-rig.md, "Clocks")."""

from __future__ import annotations

import time

import numpy as np
import pytest

from drivers.clock import ElasticClock, MonotonicClock
from drivers.sensors import SensorSettings, open_sensor
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics

pytestmark = pytest.mark.realtime  # the elastic and strict clocks are measured against wall time


def test_an_unheld_elastic_clock_keeps_its_time_scale():
    clock = ElasticClock(time_scale=100)
    t0, w0 = clock.now(), time.monotonic()
    time.sleep(0.05)
    assert clock.now() - t0 == pytest.approx((time.monotonic() - w0) * 100, rel=0.2)


def test_a_hold_stops_time_and_lifting_it_resumes_from_there_without_a_jump():
    clock = ElasticClock(time_scale=1000)
    owner = object()
    until = clock.now() + 1.0  # (the clock ran on at 1000x since it was made: a few ms of simulated time)
    clock.hold(owner, until)
    time.sleep(0.05)  # 50 simulated seconds at this scale, were it not held
    held = clock.now()
    assert held == pytest.approx(until, abs=1e-9) and clock.stalled_wall_s > 0.03
    clock.release(owner)
    after = clock.now()
    assert held <= after < held + 5.0  # resumes from the hold, not from where wall time would put it


def test_time_never_runs_backwards_under_a_hold_set_in_the_past():
    clock = ElasticClock(time_scale=1000)
    time.sleep(0.01)
    before = clock.now()
    clock.hold("late", before - 3.0)
    assert clock.now() >= before


def test_the_earliest_hold_wins_and_each_owner_replaces_only_its_own():
    clock = ElasticClock(time_scale=1000)
    clock.hold("a", 0.5)
    clock.hold("b", 2.0)
    time.sleep(0.01)
    assert clock.now() == pytest.approx(0.5)
    clock.hold("a", 1.0)
    time.sleep(0.01)
    assert clock.now() == pytest.approx(1.0)


def test_a_hold_nobody_lifts_is_dropped_so_time_never_stops_for_good():
    clock = ElasticClock(time_scale=1000, max_stall_wall_s=0.05)
    clock.hold("gone", 0.2)
    time.sleep(0.02)
    assert clock.now() == pytest.approx(0.2)
    time.sleep(0.08)
    clock.now()  # the stall is now longer than allowed: the hold goes
    time.sleep(0.02)
    assert clock.now() > 1.0 and clock.dropped_holds == 1


def _sensor(model: str, clock):
    bus = SimulatedI2CBus(1)
    physics = StaticPhysics((0.3, -0.4, 0.866), temp_c=31.0)
    errors = AccelErrorModel(noise_density_g_per_rthz=[0.0] * 3)
    if model == "MPU-9150":
        Mpu9150Model(physics, errors, clock=clock, seed=1).attach(bus, 0x68)
    else:
        bus.add_device(0x53, Adxl345Model(physics, errors, clock=clock, seed=1))
    sensor = open_sensor(model, bus, clock=clock)
    sensor.configure(SensorSettings(accel_range_g=4, sample_rate_hz=1000 if model == "MPU-9150" else 800))
    return sensor


def _late_reader(sensor, clock, reads: int = 6, late_wall_s: float = 0.04):
    """Read the FIFO, but far too late for its size at this time scale (a busy machine)."""
    sensor.start()
    blocks = []
    for _ in range(reads):
        time.sleep(late_wall_s)
        blocks.append(sensor.read())
    sensor.stop()
    return np.concatenate([b.t_s for b in blocks])


@pytest.mark.parametrize("model", ["MPU-9150", "ADXL345"])
def test_an_elastic_clock_waits_for_a_late_reader_and_no_sample_is_lost(model):
    # 40 ms of wall time at 200x is 8 s of sensor time: ~100x what either FIFO holds
    clock = ElasticClock(time_scale=200)
    sensor = _sensor(model, clock)
    t = _late_reader(sensor, clock)
    assert sensor.stats.overflows == 0 and sensor.stats.dropped == 0
    assert len(t) > 30 and np.allclose(np.diff(t), 1.0 / sensor.sample_rate_hz)  # contiguous: no gap
    assert clock.stalled_wall_s > 0.1


@pytest.mark.parametrize("model", ["MPU-9150", "ADXL345"])
def test_a_strict_clock_outruns_the_same_late_reader_and_says_samples_were_lost(model):
    clock = MonotonicClock(time_scale=200)
    sensor = _sensor(model, clock)
    _late_reader(sensor, clock)
    assert sensor.stats.overflows > 0 or sensor.stats.dropped > 0


def test_a_stopped_fifo_holds_nothing():
    clock = ElasticClock(time_scale=1000)
    sensor = _sensor("MPU-9150", clock)
    sensor.start()
    sensor.read()
    sensor.stop()
    t0 = clock.now()
    time.sleep(0.02)
    assert clock.now() - t0 > 10.0  # 20 s of simulated time passed: nothing holds the clock
