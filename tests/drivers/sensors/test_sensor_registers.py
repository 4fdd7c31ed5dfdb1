"""Register features of the simulated chips that our own drivers do not use, checked against the
datasheets: the ADXL345's DATA_FORMAT (10-bit mode, JUSTIFY), the MPU-9150's self-test and auxiliary
I2C master; and the DLPF noise model (lag-1 correlation, 1 s-mean scatter)."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.clock import VirtualClock
from drivers.sensors import SensorSettings, open_sensor
from drivers.sensors.sim.adxl345 import Adxl345Model
from drivers.sensors.sim.bus import SimulatedI2CBus
from drivers.sensors.sim.error_model import AccelErrorModel, GyroErrorModel, MagErrorModel
from drivers.sensors.sim.faults import SensorFaults
from drivers.sensors.sim.mpu9150 import Mpu9150Model
from drivers.sensors.sim.noise import NoiseConfig
from drivers.sensors.sim.physics import StaticPhysics

F = (0.3, -0.4, 0.866)
QUIET = AccelErrorModel(noise_density_g_per_rthz=[0.0] * 3)

# ADXL345 data sheet rev. E, Table 1 and the DATA_FORMAT description: (FULL_RES, range bits) -> LSB/g,
# output bits (right-justified, sign-extended)
ADXL_TABLE = {(0, 0): (256, 10), (0, 1): (128, 10), (0, 2): (64, 10), (0, 3): (32, 10),
              (1, 0): (256, 10), (1, 1): (256, 11), (1, 2): (256, 12), (1, 3): (256, 13)}


def _adxl(force):
    clock, bus = VirtualClock(), SimulatedI2CBus(1)
    bus.add_device(0x53, Adxl345Model(StaticPhysics(force), QUIET, clock=clock, seed=1))
    bus.write_byte_data(0x53, 0x2D, 0x08)  # Measure
    return bus, clock


@pytest.mark.parametrize("full_res", [0, 1])
@pytest.mark.parametrize("range_bits", [0, 1, 2, 3])
@pytest.mark.parametrize("justify", [0, 1])
@pytest.mark.parametrize("force", [F, (3.0, -9.0, 20.0)])
def test_adxl345_data_format_matches_the_datasheet_table(full_res, range_bits, justify, force):
    bus, clock = _adxl(force)
    bus.write_byte_data(0x53, 0x31, (full_res << 3) | (justify << 2) | range_bits)
    clock.sleep(0.05)
    raw = np.frombuffer(bytes(bus.read_i2c_block_data(0x53, 0x32, 6)), "<i2").astype(int)
    lsb, bits = ADXL_TABLE[(full_res, range_bits)]
    right = np.clip(np.round(np.array(force) * lsb), -(1 << (bits - 1)), (1 << (bits - 1)) - 1)
    expected = right * (1 << (16 - bits)) if justify else right
    np.testing.assert_array_equal(raw, expected)


def test_a_third_party_10_bit_16_g_reading_is_the_datasheets():
    # the case: a 10-bit +-16 g client read (19, -32, 52) where the datasheet gives (10, -16, 26)
    bus, clock = _adxl((0.3125, -0.5, 0.8125))
    bus.write_byte_data(0x53, 0x31, 0x03)
    clock.sleep(0.05)
    assert list(np.frombuffer(bytes(bus.read_i2c_block_data(0x53, 0x32, 6)), "<i2")) == [10, -16, 26]


def _mpu(faults=None, noise=None, physics=None, errors=QUIET, gyro=None, mag=None, seed=1):
    clock, bus = VirtualClock(), SimulatedI2CBus(1)
    chip = Mpu9150Model(physics or StaticPhysics(F, angular_rate_dps=(3.0, -2.0, 1.0)), errors, clock=clock,
                        seed=seed, faults=faults, noise=noise, gyro_errors=gyro, mag_errors=mag)
    chip.attach(bus, 0x68)
    return bus, clock, chip


@pytest.mark.parametrize("noise", ["white", "dlpf"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_mpu9150_self_test_passes_on_a_good_chip(noise, seed):
    bus, clock, _ = _mpu(noise=noise, errors=AccelErrorModel.draw(np.random.default_rng(seed)),
                         gyro=GyroErrorModel.draw(np.random.default_rng(seed)), seed=seed)
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=4, sample_rate_hz=100, gyro_range_dps=500))
    r = s.self_test()
    assert r.passed, r.summary()
    assert len(r.axes) == 6 and all(1 <= a.code <= 31 and abs(a.deviation_pct) < 14 for a in r.axes)
    assert [a.sensor + a.axis for a in r.axes] == ["accelx", "accely", "accelz", "gyrox", "gyroy", "gyroz"]
    assert r.axes[4].factory_trim < 0  # FT[Yg] is negative (register map 4.1)
    assert "passed" in r.summary() and r.to_dict()["passed"]
    # the configured ranges are back, and captures read the physics again
    assert bus.read_byte_data(0x68, 0x1C) == 1 << 3 and bus.read_byte_data(0x68, 0x1B) == 1 << 3


def test_mpu9150_self_test_fails_on_a_failed_chip():
    bus, clock, _ = _mpu(faults=SensorFaults(failed_self_test=True))
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings())
    r = s.self_test()
    assert not r.passed and len(r.failures()) == 6
    assert all(a.deviation_pct == pytest.approx(-55, abs=1) for a in r.axes)
    assert "FAILED" in r.summary() and "accel x" in r.summary()


def test_factory_trim_registers_hold_5_bit_codes_and_follow_the_register_map():
    from drivers.sensors.regs.mpu9150 import accel_factory_trim_lsb, decode_self_test, gyro_factory_trim_lsb
    bus, clock, chip = _mpu()
    regs = bus.read_i2c_block_data(0x68, 0x0D, 4)
    accel, gyro = decode_self_test(regs)
    assert accel == chip.trim.accel_codes and gyro == chip.trim.gyro_codes
    assert regs[3] >> 6 == 0  # SELF_TEST_A bits 7:6 reserved
    bus.write_byte_data(0x68, 0x6B, 0x80)  # a device reset keeps the trim
    assert bus.read_i2c_block_data(0x68, 0x0D, 4) == regs
    assert accel_factory_trim_lsb(1) == pytest.approx(4096 * 0.34) and accel_factory_trim_lsb(0) == 0
    assert gyro_factory_trim_lsb(1, 0) == 25 * 131 and gyro_factory_trim_lsb(1, 1) == -25 * 131


def test_the_trim_draw_leaves_the_existing_random_streams_alone():
    # same seed, with and without reading the self-test: identical samples
    reads = []
    for touch in (False, True):
        bus, clock, _ = _mpu(errors=AccelErrorModel())
        s = open_sensor("MPU-9150", bus, clock=clock)
        s.configure(SensorSettings())
        if touch:
            bus.read_i2c_block_data(0x68, 0x0D, 4)
        s.start()
        clock.sleep(0.5)
        reads.append(s.read().accel_counts)
    np.testing.assert_array_equal(*reads)


def _master_setup(bus, delay_samples=0):
    """What MPU-9150 drivers do: SLV0 reads ST1..ST2 (8 bytes) of the AK8975, SLV1 writes CNTL = 0x01."""
    bus.write_byte_data(0x68, 0x37, 0x00)  # bypass off
    bus.write_byte_data(0x68, 0x24, 0x0D)  # I2C_MST_CTRL: 400 kHz
    bus.write_i2c_block_data(0x68, 0x25, [0x80 | 0x0C, 0x02, 0x80 | 8])  # SLV0: read 8 bytes from ST1
    bus.write_i2c_block_data(0x68, 0x28, [0x0C, 0x0A, 0x80 | 1])  # SLV1: write ...
    bus.write_byte_data(0x68, 0x64, 0x01)  # ... I2C_SLV1_DO = single measurement
    bus.write_byte_data(0x68, 0x34, delay_samples)  # I2C_MST_DLY
    bus.write_byte_data(0x68, 0x67, 0x03 if delay_samples else 0)  # delay SLV0 and SLV1
    bus.write_byte_data(0x68, 0x6A, 0x20)  # USER_CTRL: I2C_MST_EN


@pytest.mark.parametrize("rate,delay", [(100, 0), (1000, 9)])
def test_ak8975_read_through_the_i2c_master_equals_the_bypass_read(rate, delay):
    mag = MagErrorModel(hard_iron_ut=[5.0, -3.0, 12.0], noise_ut=0.0)
    # a magnetometer without noise: no white part and, in the (default) dlpf model, no bias wander either
    # (its 0.1 uT flicker moves the field by an LSB between the two measurements 0.1 s apart)
    still = NoiseConfig(model="dlpf", mag_bias_instability_ut=[0.0] * 3, mag_random_walk_ut_per_rts=[0.0] * 3)
    bus, clock, chip = _mpu(mag=mag, physics=StaticPhysics(F, magnetic_field_ut=(22.0, -7.5, -41.0)), noise=still)
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(sample_rate_hz=rate))
    bus.write_byte_data(0x0C, 0x0A, 0x01)  # bypass read of the same field
    clock.sleep(0.01)
    bypass = bus.read_i2c_block_data(0x0C, 0x02, 8)
    assert bypass[0] & 1
    _master_setup(bus, delay)
    with pytest.raises(OSError):  # with the master on, the bypass no longer shows the AK8975
        bus.read_byte_data(0x0C, 0x00)
    clock.sleep(0.1)
    ext = bus.read_i2c_block_data(0x68, 0x49, 8)  # EXT_SENS_DATA_00..07
    assert ext[0] & 1, "single measurement ready (7.3 ms) before the next master read"
    assert ext[1:7] == bypass[1:7] and ext[7] == 0  # HXL..HZH, ST2
    assert bus.read_byte_data(0x68, 0x36) == 0  # I2C_MST_STATUS: no NACK
    bus.write_byte_data(0x68, 0x6A, 0x00)  # master off, bypass on: the AK8975 is back on the host bus
    bus.write_byte_data(0x68, 0x37, 0x02)
    assert bus.read_byte_data(0x0C, 0x00) == 0x48


def test_the_master_sees_the_single_measurement_timing():
    bus, clock, chip = _mpu(mag=MagErrorModel(noise_ut=0.0))
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(sample_rate_hz=1000))
    _master_setup(bus, 0)  # re-triggering every 1 ms: a 7.3 ms measurement never completes
    clock.sleep(0.1)
    assert bus.read_byte_data(0x68, 0x49) & 1 == 0
    bus.write_byte_data(0x68, 0x25, 0x0B)  # a slave that is not there: NACK flag
    clock.sleep(0.01)
    assert bus.read_byte_data(0x68, 0x36) & 1


def _mpu_1khz_44hz(noise, seconds, poll=0.02):
    bus, clock, chip = _mpu(noise=noise, errors=AccelErrorModel(), gyro=GyroErrorModel())
    s = open_sensor("MPU-9150", bus, clock=clock)
    s.configure(SensorSettings(accel_range_g=2, sample_rate_hz=1000))
    bus.write_byte_data(0x68, 0x1A, 3)  # DLPF_CFG 3: 44 Hz (our driver picks 184 Hz at 1 kHz)
    s.start()
    blocks = []
    for _ in range(int(round(seconds / poll))):
        clock.sleep(poll)
        blocks.append(s.read())
    a = np.concatenate([b.accel_counts for b in blocks]) / s.accel_lsb_per_g
    g = np.concatenate([b.gyro_counts for b in blocks]) / s.gyro_lsb_per_dps
    return a, g


def _lag1(x):
    x = x - x.mean(axis=0)
    return (x[1:] * x[:-1]).sum(axis=0) / (x * x).sum(axis=0)


def test_dlpf_noise_at_1khz_44hz_is_correlated_like_a_first_order_filter():
    a, g = _mpu_1khz_44hz("dlpf", 6.0)
    expected = np.exp(-2 * np.pi * 44 / 1000)  # 0.758
    np.testing.assert_allclose(_lag1(a), expected, atol=0.03)
    np.testing.assert_allclose(_lag1(g), np.exp(-2 * np.pi * 42 / 1000), atol=0.03)  # gyro DLPF: 42 Hz
    np.testing.assert_allclose(a.std(axis=0), 400e-6 * np.sqrt(np.pi * 44 / 2), rtol=0.1)  # 3.3 mg
    # the white model (sim: {noise: white}) keeps independent samples; the default is the dlpf model
    a, _ = _mpu_1khz_44hz("white", 3.0)
    assert np.all(np.abs(_lag1(a)) < 0.06)
    a, _ = _mpu_1khz_44hz(None, 3.0)
    np.testing.assert_allclose(_lag1(a), expected, atol=0.03)


def test_dlpf_noise_1s_means_scatter_like_white_noise_of_the_density():
    """density / sqrt(2 T) = 283 ug for 400 ug/rtHz (the white model gave ~103 ug); Allan deviation
    at 1 s (insensitive to the slow bias terms) and the plain scatter of 1 s means without them."""
    _, _, chip = _mpu(noise="dlpf", errors=AccelErrorModel())
    _, _, white_only = _mpu(noise=NoiseConfig(model="dlpf", accel_bias_instability_g=[0.0] * 3,
                                              accel_random_walk_g_per_rts=[0.0] * 3), errors=AccelErrorModel())
    for c in (chip, white_only):
        c.regs[0x1A], c.regs[0x19] = 3, 0  # 44 Hz, 1 kHz
        c.sampler.restart(1000.0, 44.0)
    means = {}
    for name, c in (("full", chip), ("white", white_only)):
        rows = []
        for _ in range(300):
            c.clock.sleep(1.0)
            rows.append(c.sampler.catch_up(keep_last=2000)["accel_g"].mean(axis=0))
        means[name] = np.array(rows)
    target = 400e-6 / np.sqrt(2)
    np.testing.assert_allclose(means["white"].std(axis=0), target, rtol=0.15)
    adev1 = np.sqrt(0.5 * np.mean(np.diff(means["full"], axis=0) ** 2, axis=0))
    np.testing.assert_allclose(adev1, target, rtol=0.15)


def test_adxl345_dlpf_noise_follows_its_output_rate_bandwidth():
    clock, bus = VirtualClock(), SimulatedI2CBus(1)
    chip = Adxl345Model(StaticPhysics(F), AccelErrorModel(noise_density_g_per_rthz=[550e-6] * 3), clock=clock,
                        seed=4, noise="dlpf")
    assert chip.noise.accel_bias_instability_g == [100e-6] * 3
    bus.add_device(0x53, chip)
    bus.write_byte_data(0x53, 0x2C, 0x0A)  # 100 Hz: bandwidth 50 Hz
    bus.write_byte_data(0x53, 0x2D, 0x08)
    rows = []
    for _ in range(100):
        clock.sleep(1.0)
        rows.append(chip.sampler.catch_up(keep_last=1000)["accel_g"])
    a = np.concatenate(rows)
    np.testing.assert_allclose(a.std(axis=0), 550e-6 * np.sqrt(np.pi * 50 / 2), rtol=0.1)
    np.testing.assert_allclose(_lag1(a), np.exp(-np.pi), atol=0.03)  # exp(-2 pi (rate/2) / rate)
