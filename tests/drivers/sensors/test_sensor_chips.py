"""The chip registry (drivers.sensors.chips) and the register maps shared by drivers and simulators."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.sensors import SensorError, open_sensor
from drivers.sensors.adxl345 import Adxl345
from drivers.sensors.chips import CHIPS, SENSOR_MODELS, ChipSpec, chip_spec
from drivers.sensors.mpu9150 import Mpu9150
from drivers.sensors.regs import adxl345 as adxl_regs
from drivers.sensors.regs import mpu9150 as mpu_regs
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.physics import StaticPhysics

from conftest import REPO


def test_the_registry_names_every_supported_model_once():
    assert SENSOR_MODELS == ("MPU-9150", "ADXL345")
    assert all(isinstance(spec, ChipSpec) and spec.model == name for name, spec in CHIPS.items())


@pytest.mark.parametrize("model", SENSOR_MODELS)
def test_each_spec_agrees_with_its_driver(model):
    spec = CHIPS[model]
    driver = spec.driver
    assert driver.model == model
    assert (driver.has_temperature, driver.has_gyro) == (spec.has_temperature, spec.has_gyro)
    assert spec.default_address in spec.addresses
    assert driver(SimulatedI2CBus(1), clock=VirtualClock()).address == spec.default_address


def test_chip_facts():
    mpu, adxl = CHIPS["MPU-9150"], CHIPS["ADXL345"]
    assert (mpu.driver, adxl.driver) == (Mpu9150, Adxl345)
    assert mpu.addresses == (0x68, 0x69) and adxl.addresses == (0x53, 0x1D)
    assert (mpu.identity_register, mpu.identity_value) == (0x75, 0x68)
    assert (adxl.identity_register, adxl.identity_value) == (0x00, 0xE5)
    assert mpu.accel_ranges_g == adxl.accel_ranges_g == (2, 4, 8, 16)
    assert mpu.has_magnetometer and not adxl.has_magnetometer
    assert adxl.sample_rates_hz == (6.25, 12.5, 25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0)
    assert mpu.accepts_rate(100.0) and mpu.accepts_rate(1000.0 / 3) and not mpu.accepts_rate(300.0)
    assert adxl.accepts_rate(6.25) and not adxl.accepts_rate(1000.0)


@pytest.mark.parametrize("model", SENSOR_MODELS)
def test_the_simulated_chip_draws_its_noise_density_from_the_registry(model):
    # one source for the simulator's white noise and the targeted preflight's datasheet noise
    drawn = AccelErrorModel.draw(np.random.default_rng(3), model).noise_density_g_per_rthz
    assert tuple(drawn) == CHIPS[model].accel_noise_density_g_rthz
    assert CHIPS["MPU-9150"].accel_noise_density_g_rthz == (400e-6,) * 3  # product spec
    assert CHIPS["ADXL345"].accel_noise_density_g_rthz == (550e-6, 550e-6, 750e-6)  # data sheet: z noisier


def test_unknown_model_is_one_line_naming_the_known_ones():
    with pytest.raises(SensorError, match=r"^unknown sensor model 'BMI160' \(known: MPU-9150, ADXL345\)$"):
        chip_spec("BMI160")
    with pytest.raises(SensorError, match="known: MPU-9150, ADXL345"):
        open_sensor("BMI160", SimulatedI2CBus(1))


@pytest.mark.parametrize("model", SENSOR_MODELS)
def test_open_sensor_identifies_the_simulated_chip_at_the_default_address(model):
    clock, bus = VirtualClock(), SimulatedI2CBus(1)
    chip = {"MPU-9150": Mpu9150Model, "ADXL345": Adxl345Model}[model]
    device = chip(StaticPhysics((0, 0, 1)), AccelErrorModel(), clock=clock)
    bus.add_device(CHIPS[model].default_address, device)
    ident = open_sensor(model, bus, clock=clock).identify()
    assert (ident.model, ident.address) == (model, CHIPS[model].default_address)
    assert (ident.identity_register, ident.identity_value) == (CHIPS[model].identity_register,
                                                               CHIPS[model].identity_value)


def test_simulated_chips_power_up_with_the_register_map_values():
    mpu = Mpu9150Model(StaticPhysics((0, 0, 1)), AccelErrorModel(), clock=VirtualClock())
    adxl = Adxl345Model(StaticPhysics((0, 0, 1)), AccelErrorModel(), clock=VirtualClock())
    assert mpu.regs[mpu_regs.WHO_AM_I] == mpu_regs.WHO_AM_I_VALUE
    assert mpu.accel_lsb_per_g == mpu_regs.ACCEL_LSB_PER_G[0] == 16384.0
    assert adxl.regs[adxl_regs.DEVID] == adxl_regs.DEVID_VALUE


def test_runtime_drivers_load_no_simulator():
    code = ("import sys; import drivers.sensors, drivers.sensors.chips, drivers.sensors.ak8975, drivers.ximc.stage; "
            "print(sorted(m for m in sys.modules if '.sim' in m))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
