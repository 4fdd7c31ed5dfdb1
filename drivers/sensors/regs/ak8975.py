"""AK8975 magnetometer register map (inside the MPU-9150, behind its I2C bypass).

WIA 0x00 = 0x48; CNTL 0x0A: 0x01 single measurement (the chip powers down after it), 0x0F
fuse-ROM access (ASAX..Z at 0x10..0x12); ST1 0x02 DRDY; HXL..HZH 0x03..0x08 little-endian,
0.3 uT/LSB; ST2 0x09 (bit 3 HOFL: magnetic overflow, bit 2 DERR).
Adjusted = raw * ((ASA - 128) * 0.5 / 128 + 1).
"""

from __future__ import annotations

import numpy as np

DEFAULT_ADDRESS = 0x0C

# -- registers -------------------------------------------------------------------------
WIA, INFO, ST1, HXL, ST2, CNTL, ASAX = 0x00, 0x01, 0x02, 0x03, 0x09, 0x0A, 0x10
WIA_VALUE = 0x48
REGISTER_COUNT = 0x13

# -- bits ------------------------------------------------------------------------------
ST1_DRDY = 0x01
ST2_HOFL, ST2_DERR = 0x08, 0x04
CNTL_POWER_DOWN, CNTL_SINGLE, CNTL_FUSE_ROM = 0x00, 0x01, 0x0F

# -- scales ----------------------------------------------------------------------------
UT_PER_LSB = 0.3  # uT per count
RAW_LIMIT = 4095  # counts, either sign
OVERFLOW_UT = 1229.0  # |field| above this sets HOFL, uT
MEASUREMENT_TIME_S = 0.0073  # single measurement, s


def asa_factor(asa) -> np.ndarray:
    """Sensitivity adjustment factors (3,) from the fuse-ROM bytes ASAX..ASAZ."""
    return (np.asarray(asa, float) - 128.0) * 0.5 / 128.0 + 1.0
