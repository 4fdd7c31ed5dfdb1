"""ADXL345 driver over an smbus2-compatible bus: identity, init (full resolution), FIFO capture."""

from __future__ import annotations

import numpy as np

from drivers.clock import Clock, MonotonicClock
from drivers.sensors.base import (BusRetry, CaptureStats, SampleBlock, SensorError, SensorIdentity, SensorSettings,
                                  check_identity)
from drivers.sensors.regs.adxl345 import (BW_RATE, DATA_FORMAT, DATAX0, DEFAULT_ADDRESS, DEVID, DEVID_VALUE, FIFO_CTL,
                                          FIFO_DEPTH, FIFO_STATUS, FULL_RES_LSB_PER_G, INT_SOURCE, POWER_CTL,
                                          RANGE_BITS, RATE_CODES)


class Adxl345:
    """One ADXL345 accelerometer in full-resolution mode (256 counts/g at every range).

    Parameters
    ----------
    bus : smbus2.SMBus or SimulatedI2CBus
    address : int
        0x53 (ALT ADDRESS low) or 0x1D.
    clock : Clock
        Timestamps (clock seconds).
    """

    model = "ADXL345"
    has_temperature = False
    has_gyro = False
    gyro_lsb_per_dps = None
    #: entries of the FIFO (stream mode)
    fifo_samples = FIFO_DEPTH

    def __init__(self, bus, address: int = DEFAULT_ADDRESS, *, clock: Clock | None = None) -> None:
        self.bus = bus
        self.address = address
        self.clock = clock or MonotonicClock()
        self.stats = CaptureStats()
        self._io = BusRetry(bus, address, self.model, self.stats)
        self.accel_range_g = 4
        self.sample_rate_hz = 100.0
        self.accel_lsb_per_g = FULL_RES_LSB_PER_G
        self._n = 0
        self._t0 = 0.0

    def identify(self) -> SensorIdentity:
        return check_identity(self.bus, self.address, self.model, DEVID, "DEVID", DEVID_VALUE)

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
        self.accel_lsb_per_g = FULL_RES_LSB_PER_G

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
            lost = max(0, int(round((self.clock.now() - self._t0) * self.sample_rate_hz)) - self._n - FIFO_DEPTH)
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
