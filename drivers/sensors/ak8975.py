"""AK8975 magnetometer (inside the MPU-9150, on the host bus once the MPU's I2C bypass is on).

WIA 0x00 = 0x48; CNTL 0x0A: 0x01 single measurement (the chip powers down after it), 0x0F fuse-ROM
access (ASAX..Z at 0x10..0x12); ST1 0x02 DRDY; HXL..HZH 0x03..0x08 little-endian, 0.3 uT/LSB;
ST2 0x09 (bit 3 HOFL: magnetic overflow, bit 2 DERR). Adjusted = raw * ((ASA - 128) * 0.5 / 128 + 1).
"""

from __future__ import annotations

import numpy as np

from drivers.clock import Clock, MonotonicClock
from drivers.sensors.base import BusRetry, CaptureStats, SensorError, SensorIdentity, check_identity

UT_PER_LSB = 0.3


class Ak8975:
    model = "AK8975"

    def __init__(self, bus, address: int = 0x0C, *, clock: Clock | None = None) -> None:
        self.bus = bus
        self.address = address
        self.clock = clock or MonotonicClock()
        self.stats = CaptureStats()
        self._io = BusRetry(bus, address, self.model, self.stats)
        self.asa_factor = np.ones(3)

    def identify(self) -> SensorIdentity:
        return check_identity(self.bus, self.address, self.model, 0x00, "WIA", 0x48,
                              hint="is the MPU-9150's I2C bypass enabled?")

    def configure(self) -> None:
        """Identify and read the fuse-ROM sensitivity adjustment."""
        self.identify()
        self._io("write_byte_data", 0x0A, 0x00)
        self._io("write_byte_data", 0x0A, 0x0F)
        asa = np.array(self._io("read_i2c_block_data", 0x10, 3), float)
        self._io("write_byte_data", 0x0A, 0x00)
        self.asa_factor = (asa - 128.0) * 0.5 / 128.0 + 1.0

    def read_field_ut(self, timeout_s: float = 0.05) -> np.ndarray:
        """One single measurement, adjusted, uT (sensor frame of the AK8975)."""
        self._io("write_byte_data", 0x0A, 0x01)
        t0 = self.clock.now()
        while not self._io("read_byte_data", 0x02) & 0x01:
            if self.clock.now() - t0 > timeout_s:
                raise SensorError(f"AK8975 at 0x{self.address:02x}: no data ready after {timeout_s * 1e3:.0f} ms")
            self.clock.sleep(0.001)
        raw = bytes(self._io("read_i2c_block_data", 0x03, 7))  # HXL..HZH, ST2 (ends the read)
        if raw[6] & 0x0C:
            raise SensorError(f"AK8975 at 0x{self.address:02x}: magnetic overflow or data error (ST2 0x{raw[6]:02x})")
        return np.frombuffer(raw[:6], "<i2").astype(float) * self.asa_factor * UT_PER_LSB
