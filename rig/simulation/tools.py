"""``rig sim``: start emulated controllers on pseudo-terminals and show the simulated sensor."""

from __future__ import annotations

import time

import numpy as np

from drivers.sensors import open_sensor
from drivers.sensors.base import SensorSettings
from drivers.sensors.chips import SENSOR_MODELS
from drivers.ximc.sim.emulator import ControllerEmulator
from rig.simulation.simrig import SimSettings, SimulatedRig


def serve_sim(*, count: int = 3, time_scale: float = 1.0, seed: int = 0, sensor_model: str = SENSOR_MODELS[0],
              once: bool = False) -> int:
    """Start ``count`` emulated 8SMC5 controllers (the first three form the simulated table),
    print their device paths and a few sensor readings, and serve until Ctrl-C."""
    settings = SimSettings(time_scale=time_scale)
    sim = SimulatedRig(settings, seed=seed, sensor_model=sensor_model)
    extra = [ControllerEmulator(settings.serial_base + 3 + i, clock=sim.clock) for i in range(max(0, count - 3))]
    try:
        ports = sim.start()
        rows = [(name, sim.emulators[i].serial_number, path) for i, (name, path) in enumerate(ports.items())]
        rows += [(f"extra{i + 1}", e.serial_number, e.start()) for i, e in enumerate(extra)]
        for name, serial, path in rows[:count]:
            print(f"{name}  serial {serial}  {path}  (libximc URI: xi-com:{path})", flush=True)
        sensor = open_sensor(sensor_model, sim.bus, sim.sensor_address, clock=sim.clock)
        ident = sensor.identify()
        sensor.configure(SensorSettings(accel_range_g=4, sample_rate_hz=100))
        sensor.start()
        sim.clock.sleep(0.2)
        blk = sensor.read()
        sensor.stop()
        mean = blk.accel_counts.mean(axis=0) / sensor.accel_lsb_per_g if len(blk.t_s) else np.full(3, np.nan)
        temp = float(np.nanmean(blk.temp_c)) if sensor.has_temperature and len(blk.t_s) else None
        print(f"sensor  {ident.model} at 0x{sim.sensor_address:02x} on a simulated I2C bus: "
              f"{len(blk.t_s)} samples, mean specific force [{mean[0]:+.4f} {mean[1]:+.4f} {mean[2]:+.4f}] g"
              + (f", {temp:.2f} C" if temp is not None else ""), flush=True)
        if once:
            return 0
        print("serving; Ctrl-C to stop", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0
    finally:
        for e in extra:
            e.stop()
        sim.stop()
