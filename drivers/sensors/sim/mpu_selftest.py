"""Factory trim and self-test response of the simulated MPU-9150 (register map rev 4.2, section 4.1).

Each chip gets 5-bit factory-trim codes (SELF_TEST_X/Y/Z/A, 0x0D..0x10), drawn from a random
stream of its own (``[seed, 0x5E1F]``), so no existing draw changes. While a self-test bit of
ACCEL_CONFIG / GYRO_CONFIG (bits 7:5) is set, that axis's output carries the self-test response:
the factory-trim value of its code (FT[Xa] counts at +-8 g, FT[Xg] counts at +-250 deg/s, in g or
deg/s, so it reads right at any range) times (1 + deviation). A good chip's deviation is
normal(0, 3 %) clipped at +-8 %, well inside the register map's 14 % pass band; with
``SensorFaults.failed_self_test`` every response is 45 % of the trim (deviation -55 %: fails).
"""

from __future__ import annotations

import numpy as np

from drivers.sensors.regs.mpu9150 import (ACCEL_LSB_PER_G, GYRO_LSB_PER_DPS, SELF_TEST_ACCEL_RANGE, SELF_TEST_BITS,
                                          SELF_TEST_GYRO_RANGE, accel_factory_trim_lsb, encode_self_test,
                                          gyro_factory_trim_lsb)
from drivers.sensors.sim.noise import own_stream

SELF_TEST_STREAM = 0x5E1F
FAILED_RESPONSE = 0.45  # fraction of the trim a failed chip produces


class SelfTestTrim:
    """Per-chip factory-trim codes and the self-test response they stand for."""

    def __init__(self, seed: int, failed: bool = False) -> None:
        rng = own_stream(seed, SELF_TEST_STREAM)
        self.accel_codes = [int(c) for c in rng.integers(8, 25, 3)]
        self.gyro_codes = [int(c) for c in rng.integers(8, 25, 3)]
        dev_a = np.clip(rng.normal(0, 0.03, 3), -0.08, 0.08)
        dev_g = np.clip(rng.normal(0, 0.03, 3), -0.08, 0.08)
        if failed:
            dev_a = dev_g = np.full(3, FAILED_RESPONSE - 1.0)
        ft_a = np.array([accel_factory_trim_lsb(c) for c in self.accel_codes]) / ACCEL_LSB_PER_G[SELF_TEST_ACCEL_RANGE]
        ft_g = np.array([gyro_factory_trim_lsb(c, i) for i, c in enumerate(self.gyro_codes)]) \
            / GYRO_LSB_PER_DPS[SELF_TEST_GYRO_RANGE]
        self.accel_response_g = ft_a * (1 + dev_a)
        self.gyro_response_dps = ft_g * (1 + dev_g)

    def register_bytes(self) -> bytes:
        """SELF_TEST_X, _Y, _Z, _A (0x0D..0x10)."""
        return encode_self_test(self.accel_codes, self.gyro_codes)

    @staticmethod
    def _mask(config: int) -> np.ndarray:
        return np.array([bool(config & b) for b in SELF_TEST_BITS])

    def accel_offset_g(self, accel_config: int):
        """The response (3,) g added while ACCEL_CONFIG's self-test bits are set; None when none is."""
        return self.accel_response_g * self._mask(accel_config) if accel_config & 0xE0 else None

    def gyro_offset_dps(self, gyro_config: int):
        """The response (3,) deg/s added while GYRO_CONFIG's self-test bits are set; None when none is."""
        return self.gyro_response_dps * self._mask(gyro_config) if gyro_config & 0xE0 else None
