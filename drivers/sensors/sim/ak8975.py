"""Register-level model of the AK8975 magnetometer (behind the MPU-9150's I2C bypass).

Register map and scales: :mod:`drivers.sensors.regs.ak8975`. A single measurement
(CNTL = 0x01) is ready ``MEASUREMENT_TIME_S`` clock seconds later; reading ST2 ends it. Transfers
take an optional time ``at`` (clock seconds; default now): the MPU-9150's auxiliary I2C master
reaches the chip at its sample times. Noise: white ``noise_ut`` per measurement, plus (dlpf noise
model) bias instability and random walk (:mod:`drivers.sensors.sim.noise`).
"""

from __future__ import annotations

import numpy as np

from drivers.sensors.regs.ak8975 import (ASAX, CNTL, CNTL_FUSE_ROM, CNTL_POWER_DOWN, CNTL_SINGLE, HXL, INFO,
                                         MEASUREMENT_TIME_S, OVERFLOW_UT, RAW_LIMIT, REGISTER_COUNT, ST1, ST1_DRDY, ST2,
                                         ST2_HOFL, UT_PER_LSB, WIA, WIA_VALUE, asa_factor)
from drivers.sensors.sim.bus import I2CDevice
from drivers.sensors.sim.error_model import MagErrorModel
from drivers.sensors.sim.noise import NoiseConfig, NoiseProcess, own_stream

MAG_NOISE_STREAM = 0xD1F2


class Ak8975Model(I2CDevice):
    """Simulated AK8975: WIA, ST1 DRDY, HXL..HZH little-endian, ST2, CNTL, fuse-ROM ASA.

    Parameters
    ----------
    physics : PhysicsSource
        Supplies ``magnetic_field_ut`` (uT, sensor frame) at clock times.
    errors : MagErrorModel
        Hard and soft iron, noise (uT).
    clock : Clock
    seed : int
        Seeds the noise and the fuse-ROM sensitivity bytes.
    noise : NoiseConfig or None
        The noise model (default white: ``noise_ut`` per measurement from the chip's generator).
    """

    def __init__(self, physics, errors: MagErrorModel, *, clock, seed: int = 0,
                 noise: NoiseConfig | None = None) -> None:
        self.physics = physics
        self.errors = errors
        self.clock = clock
        self.noise = noise or NoiseConfig()
        self.noise_process = NoiseProcess(self.noise.mag_bias_instability_ut, self.noise.mag_random_walk_ut_per_rts,
                                          own_stream(seed, MAG_NOISE_STREAM), self.noise.mag_flicker_band_s)
        self.rng = np.random.default_rng(seed)
        self.asa = bytes(int(x) for x in self.rng.integers(150, 190, 3))
        self.regs = bytearray(REGISTER_COUNT)
        self.regs[WIA] = WIA_VALUE
        self.regs[INFO] = 0x9A
        self.pointer = 0
        self._ready_at: float | None = None

    def _factor(self) -> np.ndarray:
        return asa_factor(list(self.asa))

    def _update(self, now: float) -> None:
        if self._ready_at is not None and now >= self._ready_at:
            t = np.array([self._ready_at])
            m = self.errors.output_ut(self.physics(t).magnetic_field_ut)[0]
            if self.noise.dlpf:
                m = m + self.noise_process.sample(t, [self.errors.noise_ut] * 3, None)[0]
            else:
                m = m + self.rng.normal(0, self.errors.noise_ut, 3)
            raw = np.clip(np.round(m / UT_PER_LSB / self._factor()), -RAW_LIMIT, RAW_LIMIT).astype("<i2")
            self.regs[HXL:ST2] = raw.tobytes()
            self.regs[ST1] = ST1_DRDY
            self.regs[ST2] = ST2_HOFL if np.any(np.abs(m) > OVERFLOW_UT) else 0
            self.regs[CNTL] = CNTL_POWER_DOWN  # powers down after a single measurement
            self._ready_at = None

    def read_registers(self, register: int, length: int, at: float | None = None) -> bytes:
        self._update(self.clock.now() if at is None else at)
        out = bytearray()
        for i in range(length):
            r = register + i
            if ASAX <= r <= ASAX + 2:
                out.append(self.asa[r - ASAX] if self.regs[CNTL] == CNTL_FUSE_ROM else 0)
            elif r < len(self.regs):
                out.append(self.regs[r])
            else:
                out.append(0)
            if r == ST2:
                self.regs[ST1] = 0  # reading ST2 ends the data read
        return bytes(out)

    def write_registers(self, register: int, data: bytes, at: float | None = None) -> None:
        now = self.clock.now() if at is None else at
        for i, v in enumerate(data):
            r = register + i
            if r == CNTL:
                self.regs[CNTL] = v & 0x0F
                if v & 0x0F == CNTL_SINGLE:
                    self._ready_at = now + MEASUREMENT_TIME_S
