"""The I2C sensor drivers against the register-level simulators: identity, configuration, capture, faults,
and drivers nobody here wrote (mpu6050-raspberrypi, Adafruit_ADXL345) reading the simulated chips."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.sensors import SensorError, SensorSettings, open_sensor
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.error_model import AccelErrorModel, matrix_from_triangular
from drivers.sensors.sim.faults import SensorFaults
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.noise import NoiseConfig
from drivers.sensors.sim.physics import StaticPhysics

F = (0.3, -0.4, 0.866)


#: the dlpf noise model (the default) with its bias wander off: with a zero white density, a still chip
STILL = NoiseConfig(model="dlpf", accel_bias_instability_g=[0.0] * 3, accel_random_walk_g_per_rts=[0.0] * 3)


def _bus(model="MPU-9150", errors=None, faults=None, physics=None, clock=None, noise=None):
    clock = clock or VirtualClock()
    bus = SimulatedI2CBus(1)
    physics = physics or StaticPhysics(F, temp_c=31.0)
    errors = errors or AccelErrorModel(noise_density_g_per_rthz=[0.0] * 3)
    if model == "MPU-9150":
        Mpu9150Model(physics, errors, clock=clock, seed=1, faults=faults, noise=noise).attach(bus, 0x68)
    else:
        bus.add_device(0x53, Adxl345Model(physics, errors, clock=clock, seed=1, faults=faults, noise=noise))
    return bus, clock


def _capture(sensor, clock, seconds, poll=0.05):
    sensor.start()
    blocks = []
    for _ in range(int(round(seconds / poll))):
        clock.sleep(poll)
        blocks.append(sensor.read())
    t = np.concatenate([b.t_s for b in blocks])
    a = np.concatenate([b.accel_counts for b in blocks])
    temp = np.concatenate([b.temp_c for b in blocks])
    return t, a, temp


@pytest.mark.parametrize("model,lsb", [("MPU-9150", 8192.0), ("ADXL345", 256.0)])
def test_static_capture_gives_the_physics_back_with_every_sample_once(model, lsb):
    bus, clock = _bus(model)
    s = open_sensor(model, bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=4, sample_rate_hz=100))
    assert s.accel_lsb_per_g == lsb
    t, a, temp = _capture(s, clock, 10.0)
    assert len(t) == 1000 and s.stats.dropped == 0 and s.stats.overflows == 0
    np.testing.assert_allclose(np.diff(t), 0.01, atol=1e-9)
    np.testing.assert_allclose(a.mean(axis=0) / lsb, F, atol=1.0 / lsb)
    if model == "MPU-9150":
        assert temp.mean() == pytest.approx(31.0, abs=0.01)
    else:
        assert np.all(np.isnan(temp)) and not s.has_temperature


def test_range_changes_sensitivity_on_the_chip():
    # a still chip: the half-count tolerance is the quantisation's; the dlpf model's bias wander (some
    # 80 ug over half a second, 1.3 counts at +-2 g) would be noise this test does not measure
    bus, clock = _bus(noise=STILL)
    s = open_sensor("MPU-9150", bus, clock=clock)
    for rng, lsb in ((2, 16384), (8, 4096), (16, 2048)):
        s.configure(SensorSettings(accel_range_g=rng, sample_rate_hz=100))
        _, a, _ = _capture(s, clock, 0.5)
        assert a[:, 2].mean() == pytest.approx(0.866 * lsb, abs=1.0)


def test_one_kilohertz_capture_has_no_drops_or_duplicates():
    bus, clock = _bus()
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=4, sample_rate_hz=1000))
    t, _, _ = _capture(s, clock, 5.0, poll=0.02)
    assert len(t) == 5000 and len(np.unique(t)) == 5000
    assert s.stats.dropped == 0 and s.stats.duplicated == 0


def test_reading_too_slowly_is_detected_as_an_overflow_not_hidden():
    bus, clock = _bus()
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=4, sample_rate_hz=1000))
    s.start()
    clock.sleep(2.0)  # 2000 samples x 14 bytes >> 1024-byte FIFO
    s.read()
    assert s.stats.overflows == 1 and s.stats.dropped > 1000


def test_sleeping_chip_gives_no_data_until_woken():
    bus, clock = _bus()
    assert bus.read_byte_data(0x68, 0x6B) == 0x40  # powers up asleep
    clock.sleep(1.0)
    assert bus.read_i2c_block_data(0x68, 0x3B, 6) == [0] * 6
    assert bus.read_byte_data(0x68, 0x3A) & 1 == 0


def test_ak8975_appears_behind_the_bypass_with_fuse_rom_sensitivity():
    bus, clock = _bus()
    with pytest.raises(OSError):
        bus.read_byte_data(0x0C, 0x00)
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings())
    assert bus.read_byte_data(0x0C, 0x00) == 0x48  # WIA
    bus.write_byte_data(0x0C, 0x0A, 0x0F)  # fuse ROM access
    asa = bus.read_i2c_block_data(0x0C, 0x10, 3)
    bus.write_byte_data(0x0C, 0x0A, 0x00)
    bus.write_byte_data(0x0C, 0x0A, 0x01)  # single measurement
    clock.sleep(0.01)
    assert bus.read_byte_data(0x0C, 0x02) & 1  # DRDY
    raw = np.frombuffer(bytes(bus.read_i2c_block_data(0x0C, 0x03, 6)), "<i2")
    adjusted = raw * ((np.array(asa) - 128) * 0.5 / 128 + 1) * 0.3
    np.testing.assert_allclose(adjusted, (20.0, 0.0, -45.0), atol=1.5)
    assert bus.read_byte_data(0x0C, 0x0A) == 0  # powered down after the measurement


def test_wrong_or_missing_chip_is_a_clear_error():
    bus, clock = _bus("ADXL345")
    with pytest.raises(SensorError, match=r"MPU-9150 at 0x68: no answer"):
        open_sensor("MPU-9150", bus, clock=clock).identify()
    bus.add_device(0x69, bus._devices[0x53])
    with pytest.raises(SensorError, match=r"MPU-9150 at 0x69: WHO_AM_I reads 0x00, expected 0x68 \(wrong chip"):
        open_sensor("MPU-9150", bus, address=0x69, clock=clock).identify()


def test_bad_settings_are_refused():
    bus, clock = _bus()
    s = open_sensor("MPU-9150", bus, clock=clock)
    with pytest.raises(SensorError, match="range 3 g"):
        s.configure(SensorSettings(accel_range_g=3))
    with pytest.raises(SensorError, match="1000/\\(1\\+n\\)"):
        s.configure(SensorSettings(sample_rate_hz=300))


def test_error_model_equation_matches_the_seed_model():
    m = matrix_from_triangular([1.01, 0.99, 1.02], 0.004, -0.003, 0.002)
    k = np.diag(m)
    assert m[0, 1] == pytest.approx(k[0] * 0.004)
    assert m[0, 2] == pytest.approx(-k[0] * (-0.003 - 0.004 * 0.002))
    assert m[1, 2] == pytest.approx(k[1] * 0.002) and m[1, 0] == 0 and m[2, 0] == m[2, 1] == 0


def test_transient_i2c_errors_are_retried_and_counted():
    bus, clock = _bus(faults=SensorFaults(oserror_rate=0.05, seed=3))
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings())
    t, _, _ = _capture(s, clock, 5.0)
    assert len(t) == 500 and s.stats.io_retries > 0


def test_a_dead_chip_raises_instead_of_returning_stale_data():
    bus, clock = _bus(faults=SensorFaults(dead_after_s=1.0))
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings())
    s.start()
    clock.sleep(2.0)
    with pytest.raises(SensorError, match="MPU-9150 at 0x68: I2C .* failed 4 times"):
        s.read()


@pytest.mark.parametrize("fault,check", [
    (SensorFaults(stuck_after_s=0.5), lambda a, t: np.ptp(a[-100:], axis=0).max() == 0),
    (SensorFaults(saturate_after_s=0.5), lambda a, t: np.all(a[-100:] == 32767)),
    (SensorFaults(thermometer_fail_after_s=0.5), lambda a, t: t[-1] < -40),
])
def test_stuck_saturated_and_failed_thermometer_show_in_the_data(fault, check):
    bus, clock = _bus(faults=fault, errors=AccelErrorModel())
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings())
    _, a, temp = _capture(s, clock, 2.0)
    assert check(a, temp)
    from rig.execution.checks import check_step
    assert not check_step(a[-150:], temp[-150:], 150, True).ok


def test_third_party_mpu6050_driver_reads_the_simulated_chip(monkeypatch):
    bus, clock = _bus(physics=StaticPhysics(F, angular_rate_dps=(10.0, -5.0, 2.0), temp_c=31.0))
    fake_smbus = types.ModuleType("smbus")
    fake_smbus.SMBus = lambda n: bus
    monkeypatch.setitem(sys.modules, "smbus", fake_smbus)
    monkeypatch.delitem(sys.modules, "mpu6050", raising=False)
    monkeypatch.delitem(sys.modules, "mpu6050.mpu6050", raising=False)
    from mpu6050 import mpu6050

    dev = mpu6050(0x68)  # writes PWR_MGMT_1 = 0: wakes the chip
    clock.sleep(0.1)
    acc = dev.get_accel_data(g=True)
    assert [acc["x"], acc["y"], acc["z"]] == pytest.approx(list(F), abs=1e-3)
    gyro = dev.get_gyro_data()
    assert [gyro["x"], gyro["y"], gyro["z"]] == pytest.approx([10.0, -5.0, 2.0], abs=0.02)
    # its temperature formula is the MPU-6050's (raw/340 + 36.53); ours is the MPU-9150's (+35)
    assert dev.get_temp() == pytest.approx(31.0 + 1.53, abs=0.08)  # one reading: 0.02 C noise
    dev.set_accel_range(dev.ACCEL_RANGE_8G)
    clock.sleep(0.05)
    assert dev.read_accel_range() == 8
    assert dev.get_accel_data(g=True)["z"] == pytest.approx(0.866, abs=1e-3)


def test_third_party_adafruit_adxl345_driver_reads_the_simulated_chip():
    bus, clock = _bus("ADXL345")
    import Adafruit_ADXL345
    import Adafruit_GPIO.I2C as I2C

    class Iface:
        """Adafruit_GPIO's i2c_interface hook; like its default (Adafruit_PureIO) block reads give bytearrays."""

        def __init__(self, busnum):
            self._bus = bus

        def read_i2c_block_data(self, addr, cmd, length=32):
            return bytearray(bus.read_i2c_block_data(addr, cmd, length))

        def __getattr__(self, name):
            return getattr(self._bus, name)

    class Factory:
        @staticmethod
        def get_i2c_device(address, **kw):
            return I2C.Device(address, 1, i2c_interface=Iface)

    dev = Adafruit_ADXL345.ADXL345(i2c=Factory)  # checks DEVID, sets Measure
    dev.set_range(Adafruit_ADXL345.ADXL345_RANGE_4_G)
    dev.set_data_rate(Adafruit_ADXL345.ADXL345_DATARATE_100_HZ)
    clock.sleep(0.1)
    x, y, z = dev.read()
    # full resolution: 256 LSB/g (3.9 mg/LSB)
    assert np.array([x, y, z]) / 256.0 == pytest.approx(np.array(F), abs=2 / 256)


def test_ak8975_driver_reads_the_field_with_its_sensitivity_adjustment():
    from drivers.sensors.ak8975 import Ak8975

    bus, clock = _bus()
    mag = Ak8975(bus, clock=clock)
    with pytest.raises(SensorError, match="bypass"):
        mag.identify()
    open_sensor("MPU-9150", bus, clock=clock).configure(SensorSettings())
    mag.configure()
    assert np.all(mag.asa_factor != 1.0)
    np.testing.assert_allclose(mag.read_field_ut(), (20.0, 0.0, -45.0), atol=1.5)
