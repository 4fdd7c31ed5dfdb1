"""60 s of simulated capture: samples expected, received, dropped, duplicated (targets 0 and 0)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.clock import VirtualClock
from drivers.sensors import SensorSettings, open_sensor
from drivers.sensors.chips import CHIPS
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics


def run(model: str, rate_hz: float, seconds: float = 60.0, poll_s: float = 0.02) -> None:
    clock = VirtualClock()
    bus = SimulatedI2CBus(1)
    errors = AccelErrorModel.draw(np.random.default_rng(0), model)
    if model == "MPU-9150":
        Mpu9150Model(StaticPhysics(), errors, clock=clock, seed=1).attach(bus)
    else:
        bus.add_device(CHIPS[model].default_address, Adxl345Model(StaticPhysics(), errors, clock=clock, seed=1))
    s = open_sensor(model, bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=4, sample_rate_hz=rate_hz))
    s.start()
    t_wall = time.perf_counter()
    ts = []
    for _ in range(int(round(seconds / poll_s))):
        clock.sleep(poll_s)
        ts.append(s.read().t_s)
    wall = time.perf_counter() - t_wall
    t = np.concatenate(ts)
    expected = int(round(seconds * rate_hz))
    dup = len(t) - len(np.unique(np.round((t - t[0]) * rate_hz)))
    gaps = int(np.sum(np.round(np.diff(t) * rate_hz) > 1))
    print(f"{model:8s} {rate_hz:6g} Hz  {seconds:g} s: expected {expected}, received {len(t)}, "
          f"dropped {s.stats.dropped} (gaps {gaps}, FIFO overflows {s.stats.overflows}), duplicated {dup}, "
          f"I2C transfers {bus.transfers}, wall {wall:.2f} s")


if __name__ == "__main__":
    run("MPU-9150", 1000.0)
    run("MPU-9150", 100.0)
    run("ADXL345", 800.0, poll_s=0.02)
    run("ADXL345", 1600.0, poll_s=0.01)
