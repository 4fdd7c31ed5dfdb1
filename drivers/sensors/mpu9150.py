"""MPU-9150 driver over an smbus2-compatible bus: identity, init, FIFO capture with timestamps.

Capture goes through the 1024-byte FIFO (accelerometer, temperature and
gyroscope: 14 bytes per sample); sample times come from the sample counter
(t0 + n / rate), so they have no jitter. A FIFO overflow is detected
(INT_STATUS FIFO_OFLOW), counted in ``stats`` and the FIFO restarted, never
silently glossed over.
"""

from __future__ import annotations

import numpy as np

from drivers.clock import Clock, MonotonicClock
from drivers.sensors.base import (BusRetry, CaptureStats, SampleBlock, SelfTestAxis, SelfTestResult, SensorError,
                                  SensorIdentity, SensorSettings, check_identity)
from drivers.sensors.regs.mpu9150 import (ACCEL_CONFIG, ACCEL_LSB_PER_G, ACCEL_RANGES, ACCEL_XOUT_H, CONFIG,
                                          DEFAULT_ADDRESS, FIFO_COUNTH, FIFO_EN, FIFO_EN_ALL, FIFO_R_W, FIFO_SIZE, GYRO_CONFIG,
                                          GYRO_LSB_PER_DPS, GYRO_RANGES, INT_ENABLE, INT_FIFO_OFLOW, INT_PIN_CFG,
                                          INT_STATUS, PWR_MGMT_1, SELF_TEST_ACCEL_RANGE, SELF_TEST_GYRO_RANGE,
                                          SELF_TEST_TOLERANCE, SELF_TEST_X, SMPLRT_DIV, TEMP_LSB_PER_C,
                                          TEMP_OFFSET_C, TEMP_OUT_H, USER_CTRL, WHO_AM_I, WHO_AM_I_VALUE,
                                          accel_factory_trim_lsb, decode_self_test, gyro_factory_trim_lsb)

SAMPLE_BYTES = 14  # accel (6) + temp (2) + gyro (6), in register order
SELF_TEST_SETTLE_S = 0.05  # after switching the self-test on or off (several DLPF delays)


def evaluate_self_test(model: str, address: int, codes: tuple, off: np.ndarray, on: np.ndarray) -> SelfTestResult:
    """Register map rev 4.2, section 4.1: response = output with self-test - output without (counts at
    +-8 g / +-250 deg/s, ``off`` / ``on`` = mean (accel x y z, gyro x y z)); passes within 14 % of the
    factory trim FT computed from the 5-bit codes (an axis with code 0 has no trim and fails)."""
    accel_codes, gyro_codes = codes
    trims = [accel_factory_trim_lsb(c) for c in accel_codes] + [gyro_factory_trim_lsb(c, i)
                                                                  for i, c in enumerate(gyro_codes)]
    axes = []
    for j, (code, ft) in enumerate(zip(list(accel_codes) + list(gyro_codes), trims)):
        response = float(on[j] - off[j])
        dev = 100.0 * (response - ft) / ft if ft else float("inf")
        axes.append(SelfTestAxis("accel" if j < 3 else "gyro", "xyz"[j % 3], int(code), float(ft), response,
                                 dev, abs(dev) <= 100 * SELF_TEST_TOLERANCE))
    return SelfTestResult(model, address, tuple(axes), 100 * SELF_TEST_TOLERANCE)


class Mpu9150:
    """One MPU-9150 (accelerometer, gyroscope, thermometer).

    Parameters
    ----------
    bus : smbus2.SMBus or SimulatedI2CBus
    address : int
        0x68 (AD0 low) or 0x69.
    clock : Clock
        Timestamps (clock seconds).
    """

    model = "MPU-9150"
    has_temperature = True
    has_gyro = True

    #: whole samples (accel, temperature, gyro) in the 1024-byte FIFO
    fifo_samples = FIFO_SIZE // SAMPLE_BYTES

    def __init__(self, bus, address: int = DEFAULT_ADDRESS, *, clock: Clock | None = None) -> None:
        self.bus = bus
        self.address = address
        self.clock = clock or MonotonicClock()
        self.stats = CaptureStats()
        self._io = BusRetry(bus, address, self.model, self.stats)
        self.accel_range_g = 4
        self.gyro_range_dps = 250
        self.sample_rate_hz = 100.0
        self.accel_lsb_per_g = ACCEL_LSB_PER_G[1]
        self.gyro_lsb_per_dps = GYRO_LSB_PER_DPS[0]
        self._n = 0
        self._t0 = 0.0
        self._pending = bytearray()
        self._configured = False

    def identify(self) -> SensorIdentity:
        return check_identity(self.bus, self.address, self.model, WHO_AM_I, "WHO_AM_I", WHO_AM_I_VALUE)

    def configure(self, settings: SensorSettings = SensorSettings()) -> None:
        """Wake, set ranges, output rate (SMPLRT_DIV with DLPF on: 1 kHz base) and low-pass."""
        if settings.accel_range_g not in ACCEL_RANGES:
            raise SensorError(f"{self.model}: accelerometer range {settings.accel_range_g} g not in 2/4/8/16")
        if settings.gyro_range_dps not in GYRO_RANGES:
            raise SensorError(f"{self.model}: gyro range {settings.gyro_range_dps} deg/s not in 250/500/1000/2000")
        div = 1000.0 / settings.sample_rate_hz - 1
        if not (0 <= div <= 255 and abs(div - round(div)) < 1e-9):
            raise SensorError(f"{self.model}: sample rate {settings.sample_rate_hz:g} Hz is not 1000/(1+n), n = 0..255")
        self.identify()
        self._io("write_byte_data", PWR_MGMT_1, 0x80)  # reset
        self._io("write_byte_data", PWR_MGMT_1, 0x01)  # wake, PLL with X gyro
        dlpf = 3 if settings.sample_rate_hz <= 200 else 1  # 44 Hz / 184 Hz bandwidth
        self._io("write_byte_data", CONFIG, dlpf)
        self._io("write_byte_data", SMPLRT_DIV, int(round(div)))
        self._io("write_byte_data", GYRO_CONFIG, GYRO_RANGES[settings.gyro_range_dps] << 3)
        self._io("write_byte_data", ACCEL_CONFIG, ACCEL_RANGES[settings.accel_range_g] << 3)
        self._io("write_byte_data", INT_ENABLE, 0x01)  # data ready
        self._io("write_byte_data", INT_PIN_CFG, 0x02)  # bypass: the AK8975 appears on the bus
        check = self._io("read_byte_data", ACCEL_CONFIG)
        if (check >> 3) & 3 != ACCEL_RANGES[settings.accel_range_g]:
            raise SensorError(f"{self.model} at 0x{self.address:02x}: ACCEL_CONFIG did not take the new range")
        self.accel_range_g = settings.accel_range_g
        self.gyro_range_dps = settings.gyro_range_dps
        self.sample_rate_hz = float(settings.sample_rate_hz)
        self.accel_lsb_per_g = ACCEL_LSB_PER_G[ACCEL_RANGES[settings.accel_range_g]]
        self.gyro_lsb_per_dps = GYRO_LSB_PER_DPS[GYRO_RANGES[settings.gyro_range_dps]]
        self._configured = True

    def self_test(self, samples: int = 20) -> SelfTestResult:
        """The chip's self-test (register map rev 4.2, section 4.1), outside a capture.

        Switches to +-8 g / +-250 deg/s, averages ``samples`` outputs without and with the
        self-test bits of ACCEL_CONFIG / GYRO_CONFIG set, reads the factory-trim codes
        (SELF_TEST_X/Y/Z/A) and compares each axis's response with its trim (pass: within 14 %).
        Restores the configured ranges. Configures the chip with default settings first if
        ``configure`` was not called. Never raises for a failing chip: check ``result.passed``.
        """
        if not self._configured:
            self.configure(SensorSettings())
        accel_cfg, gyro_cfg = SELF_TEST_ACCEL_RANGE << 3, SELF_TEST_GYRO_RANGE << 3
        means = []
        for st in (0x00, 0xE0):
            self._io("write_byte_data", ACCEL_CONFIG, st | accel_cfg)
            self._io("write_byte_data", GYRO_CONFIG, st | gyro_cfg)
            self.clock.sleep(SELF_TEST_SETTLE_S)
            means.append(self._mean_outputs(samples))
        self._io("write_byte_data", ACCEL_CONFIG, ACCEL_RANGES[self.accel_range_g] << 3)
        self._io("write_byte_data", GYRO_CONFIG, GYRO_RANGES[self.gyro_range_dps] << 3)
        self.clock.sleep(SELF_TEST_SETTLE_S)
        codes = decode_self_test(self._io("read_i2c_block_data", SELF_TEST_X, 4))
        return evaluate_self_test(self.model, self.address, codes, means[0], means[1])

    def _mean_outputs(self, samples: int) -> np.ndarray:
        """Mean of ``samples`` fresh data-register readings: accel x y z, gyro x y z (counts)."""
        rows = []
        for _ in range(samples):
            self.clock.sleep(1.0 / self.sample_rate_hz)
            raw = bytes(self._io("read_i2c_block_data", ACCEL_XOUT_H, 14))
            w = np.frombuffer(raw, ">i2").astype(float)
            rows.append(np.concatenate([w[0:3], w[4:7]]))
        return np.mean(rows, axis=0)

    def read_temperature_c(self) -> float:
        """One thermometer reading (TEMP_OUT_H/L), C."""
        hi, lo = self._io("read_i2c_block_data", TEMP_OUT_H, 2)
        raw = (hi << 8) | lo
        raw = raw - 65536 if raw & 0x8000 else raw
        return raw / TEMP_LSB_PER_C + TEMP_OFFSET_C

    def start(self) -> None:
        """Reset and enable the FIFO; samples from now on are captured."""
        self._io("write_byte_data", FIFO_EN, 0)
        self._io("write_byte_data", USER_CTRL, 0x04)  # FIFO reset
        self._io("read_byte_data", INT_STATUS)  # clear flags
        self._io("write_byte_data", FIFO_EN, FIFO_EN_ALL)
        self._io("write_byte_data", USER_CTRL, 0x40)
        self._t0 = self.clock.now() + 0.5 / self.sample_rate_hz
        self._n = 0
        self._pending.clear()

    def stop(self) -> None:
        self._io("write_byte_data", USER_CTRL, 0x00)
        self._io("write_byte_data", FIFO_EN, 0)

    def read(self) -> SampleBlock:
        """Every sample produced since the last read."""
        status = self._io("read_byte_data", INT_STATUS)
        if status & INT_FIFO_OFLOW:
            # FIFO overflowed: data was lost and the byte stream may be misaligned; restart it
            self.stats.overflows += 1
            lost = max(0, int(round((self.clock.now() - self._t0) * self.sample_rate_hz)) - self._n)
            self.stats.dropped += lost
            self.start()
            return _empty()
        hi_lo = self._io("read_i2c_block_data", FIFO_COUNTH, 2)
        count = (hi_lo[0] << 8) | hi_lo[1]
        n_bytes = (count // SAMPLE_BYTES) * SAMPLE_BYTES
        data = bytearray()
        while len(data) < n_bytes:
            chunk = min(28, n_bytes - len(data))  # two whole samples per block read (<= 32 bytes)
            data.extend(self._io("read_i2c_block_data", FIFO_R_W, chunk))
        if not data:
            return _empty()
        words = np.frombuffer(bytes(data), dtype=">i2").astype(np.int64).reshape(-1, 7)
        n = len(words)
        t = self._t0 + (self._n + np.arange(n)) / self.sample_rate_hz
        self._n += n
        self.stats.received += n
        return SampleBlock(t_s=t, accel_counts=words[:, 0:3], temp_c=words[:, 3] / TEMP_LSB_PER_C + TEMP_OFFSET_C,
                           gyro_counts=words[:, 4:7])


def _empty() -> SampleBlock:
    return SampleBlock(np.empty(0), np.empty((0, 3), np.int64), np.empty(0), np.empty((0, 3), np.int64))
