"""ADXL345 driver over an smbus2-compatible bus: identity, init (full resolution), FIFO capture."""

from __future__ import annotations

import numpy as np

from drivers.clock import Clock, MonotonicClock
from drivers.sensors.sim.adxl345 import BW_RATE, DATA_FORMAT, DATAX0, DEVID, FIFO_CTL, FIFO_STATUS, INT_SOURCE, POWER_CTL
from drivers.sensors.base import BusRetry, check_identity, CaptureStats, SampleBlock, SensorError, SensorIdentity, SensorSettings

RANGE_BITS = {2: 0, 4: 1, 8: 2, 16: 3}
RATE_CODES = {3200 / 2 ** (15 - c): c for c in range(6, 16)}  # 6.25 .. 3200 Hz


class Adxl345:
    model = "ADXL345"
    has_temperature = False
    has_gyro = False
    gyro_lsb_per_dps = None

    def __init__(self, bus, address: int = 0x53, *, clock: Clock | None = None) -> None:
        self.bus = bus
        self.address = address
        self.clock = clock or MonotonicClock()
        self.stats = CaptureStats()
        self._io = BusRetry(bus, address, self.model, self.stats)
        self.accel_range_g = 4
        self.sample_rate_hz = 100.0
        self.accel_lsb_per_g = 256.0
        self._n = 0
        self._t0 = 0.0

    def identify(self) -> SensorIdentity:
        return check_identity(self.bus, self.address, self.model, DEVID, "DEVID", 0xE5)

    def configure(self, settings: SensorSettings = SensorSettings()) -> None:
        if settings.accel_range_g not in RANGE_BITS:
            raise SensorError(f"{self.model}: range {settings.accel_range_g} g not in 2/4/8/16")
        code = RATE_CODES.get(float(settings.sample_rate_hz))
        if code is None:
            raise SensorError(f"{self.model}: sample rate {settings.sample_rate_hz:g} Hz not one of "
                              + ", ".join(f"{r:g}" for r in sorted(RATE_CODES)))
        self.identify()
        self._io("write_byte_data", POWER_CTL, 0x00)  # standby while configuring
        self._io("write_byte_data", DATA_FORMAT, 0x08 | RANGE_BITS[settings.accel_range_g])  # FULL_RES
        self._io("write_byte_data", BW_RATE, code)
        self._io("write_byte_data", FIFO_CTL, 0x00)
        self._io("write_byte_data", POWER_CTL, 0x08)  # measure
        if self._io("read_byte_data", DATA_FORMAT) != 0x08 | RANGE_BITS[settings.accel_range_g]:
            raise SensorError(f"{self.model} at 0x{self.address:02x}: DATA_FORMAT did not take the new range")
        self.accel_range_g = settings.accel_range_g
        self.sample_rate_hz = float(settings.sample_rate_hz)
        self.accel_lsb_per_g = 256.0

    def start(self) -> None:
        self._io("write_byte_data", FIFO_CTL, 0x00)  # bypass clears the FIFO
        self._io("read_byte_data", INT_SOURCE)
        self._io("write_byte_data", FIFO_CTL, 0x80)  # stream mode
        self._t0 = self.clock.now() + 0.5 / self.sample_rate_hz
        self._n = 0

    def stop(self) -> None:
        self._io("write_byte_data", FIFO_CTL, 0x00)

    def read(self) -> SampleBlock:
        src = self._io("read_byte_data", INT_SOURCE)
        if src & 0x01:
            self.stats.overflows += 1
            lost = max(0, int(round((self.clock.now() - self._t0) * self.sample_rate_hz)) - self._n - 32)
            self.stats.dropped += lost
            self.start()
            return SampleBlock(np.empty(0), np.empty((0, 3), np.int64), np.empty(0))
        entries = self._io("read_byte_data", FIFO_STATUS) & 0x3F
        rows = []
        for _ in range(entries):
            b = bytes(self._io("read_i2c_block_data", DATAX0, 6))
            rows.append(np.frombuffer(b, dtype="<i2").astype(np.int64))
        if not rows:
            return SampleBlock(np.empty(0), np.empty((0, 3), np.int64), np.empty(0))
        a = np.array(rows)
        n = len(a)
        t = self._t0 + (self._n + np.arange(n)) / self.sample_rate_hz
        self._n += n
        self.stats.received += n
        return SampleBlock(t_s=t, accel_counts=a, temp_c=np.full(n, np.nan))
