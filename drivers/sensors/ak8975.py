"""AK8975 magnetometer driver (inside the MPU-9150, on the host bus once the MPU's I2C bypass is on).

Register map and scales: :mod:`drivers.sensors.regs.ak8975`.
"""

from __future__ import annotations

import numpy as np

from drivers.clock import Clock, MonotonicClock
from drivers.sensors.base import BusRetry, CaptureStats, SensorError, SensorIdentity, check_identity
from drivers.sensors.regs.ak8975 import (ASAX, CNTL, CNTL_FUSE_ROM, CNTL_POWER_DOWN, CNTL_SINGLE, DEFAULT_ADDRESS, HXL,
                                         ST1, ST1_DRDY, ST2_DERR, ST2_HOFL, UT_PER_LSB, WIA, WIA_VALUE, asa_factor)


class Ak8975:
    """One AK8975 magnetometer: single measurements, adjusted by the fuse-ROM sensitivity, in uT.

    Parameters
    ----------
    bus : smbus2.SMBus or SimulatedI2CBus
    address : int
        0x0C behind the MPU-9150's bypass.
    clock : Clock
        For the data-ready timeout (clock seconds).
    """

    model = "AK8975"

    def __init__(self, bus, address: int = DEFAULT_ADDRESS, *, clock: Clock | None = None) -> None:
        self.bus = bus
        self.address = address
        self.clock = clock or MonotonicClock()
        self.stats = CaptureStats()
        self._io = BusRetry(bus, address, self.model, self.stats)
        self.asa_factor = np.ones(3)

    def identify(self) -> SensorIdentity:
        return check_identity(self.bus, self.address, self.model, WIA, "WIA", WIA_VALUE,
                              hint="is the MPU-9150's I2C bypass enabled?")

    def configure(self) -> None:
        """Identify and read the fuse-ROM sensitivity adjustment."""
        self.identify()
        self._io("write_byte_data", CNTL, CNTL_POWER_DOWN)
        self._io("write_byte_data", CNTL, CNTL_FUSE_ROM)
        asa = self._io("read_i2c_block_data", ASAX, 3)
        self._io("write_byte_data", CNTL, CNTL_POWER_DOWN)
        self.asa_factor = asa_factor(asa)

    def read_field_ut(self, timeout_s: float = 0.05) -> np.ndarray:
        """One single measurement, adjusted, uT (sensor frame of the AK8975)."""
        self._io("write_byte_data", CNTL, CNTL_SINGLE)
        t0 = self.clock.now()
        while not self._io("read_byte_data", ST1) & ST1_DRDY:
            if self.clock.now() - t0 > timeout_s:
                raise SensorError(f"AK8975 at 0x{self.address:02x}: no data ready after {timeout_s * 1e3:.0f} ms")
            self.clock.sleep(0.001)
        raw = bytes(self._io("read_i2c_block_data", HXL, 7))  # HXL..HZH, ST2 (ends the read)
        if raw[6] & (ST2_HOFL | ST2_DERR):
            raise SensorError(f"AK8975 at 0x{self.address:02x}: magnetic overflow or data error (ST2 0x{raw[6]:02x})")
        return np.frombuffer(raw[:6], "<i2").astype(float) * self.asa_factor * UT_PER_LSB
