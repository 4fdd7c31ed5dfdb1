"""Register-level model of the ADXL345 (datasheet rev. E register map).

DEVID 0x00 = 0xE5, OFSX/OFSY/OFSZ 0x1E..0x20 (15.6 mg/LSB, added to the output), BW_RATE 0x2C
(rate = 3200 / 2^(15 - code) Hz), POWER_CTL 0x2D (Measure bit 3; standby at power-up),
INT_SOURCE 0x30 (DATA_READY bit 7, Overrun bit 0), DATA_FORMAT 0x31 (range bits 1:0, JUSTIFY bit 2:
left-justified words with the MSB at bit 15, FULL_RES bit 3: 256 LSB/g at every range with 10..13
bits, else 10 bits at 256/128/64/32 LSB/g), DATAX0..DATAZ1 0x32..0x37 little-endian (reading them pops one FIFO entry),
FIFO_CTL 0x38 (mode bits 7:6: bypass/FIFO/stream), FIFO_STATUS 0x39 (entries bits 5:0). No thermometer.
Addresses and scales: :mod:`drivers.sensors.regs.adxl345`.
"""

from __future__ import annotations

import numpy as np

from drivers.sensors.regs.adxl345 import (BW_RATE, DATA_FORMAT, DATAX0, DEVID, DEVID_VALUE, FIFO_CTL, FIFO_DEPTH,
                                          FIFO_STATUS, INT_SOURCE, OFS_G_PER_LSB, OFSX, POWER_CTL, REGISTER_COUNT,
                                          justify_shift, lsb_per_g, output_bits, rate_hz)
from drivers.sensors.sim.bus import I2CDevice
from drivers.sensors.sim.error_model import AccelErrorModel
from drivers.sensors.sim.faults import FaultInjector, SensorFaults
from drivers.sensors.sim.noise import NoiseConfig, resolve_noise
from drivers.sensors.sim.sampler import LazySampler


class Adxl345Model(I2CDevice):
    """Simulated ADXL345.

    Parameters
    ----------
    physics : PhysicsSource
        Specific force (g, sensor frame) and temperature (C) at clock times.
    accel_errors : AccelErrorModel
    clock : Clock
    seed : int
        Noise seed.
    faults : SensorFaults or None
    noise : NoiseConfig, "white" / "dlpf", a mapping of NoiseConfig fields, or None (the default model);
        with "dlpf" the white density passes a first-order filter of bandwidth rate / 2 (BW_RATE)
    """

    def __init__(self, physics, accel_errors: AccelErrorModel, *, clock, seed: int = 0,
                 faults: SensorFaults | None = None, noise: NoiseConfig | str | dict | None = None) -> None:
        self.clock = clock
        self.noise = resolve_noise(noise, "ADXL345")
        self.sampler = LazySampler(physics, accel_errors, clock, seed, noise=self.noise)
        self.faults = FaultInjector(faults, clock)
        self.pointer = 0
        self.regs = bytearray(REGISTER_COUNT)
        self.regs[DEVID] = DEVID_VALUE
        self.regs[BW_RATE] = 0x0A
        self.regs[INT_SOURCE] = 0x02
        self.fifo: list[np.ndarray] = []
        self.latest = np.zeros(3, np.int64)
        self.overruns = 0
        self._stuck = None

    def check_access(self) -> None:
        self.faults.check_access()

    def rate_hz(self) -> float:
        return rate_hz(self.regs[BW_RATE])

    def _range_counts(self) -> tuple[int, int]:
        """Output word limits (right-justified): 10 bits, or 10..13 bits at full resolution."""
        full = 1 << (output_bits(self.regs[DATA_FORMAT]) - 1)
        return -full, full - 1

    def _word(self, counts: np.ndarray) -> bytes:
        """Little-endian output words, left-justified (MSB at bit 15) when JUSTIFY is set."""
        return (np.asarray(counts, np.int64) << justify_shift(self.regs[DATA_FORMAT])).astype("<i2").tobytes()

    def _catch_up(self) -> None:
        # in bypass mode (no FIFO) only the newest sample is ever seen; the ones before it are only counted
        s = self.sampler.catch_up(keep_last=FIFO_DEPTH + 2 if self.regs[FIFO_CTL] >> 6 else 1)
        if s is None:
            return
        t = s["t_s"]
        ofs = np.frombuffer(bytes(self.regs[OFSX:OFSX + 3]), dtype=np.int8).astype(float) * OFS_G_PER_LSB
        lo, hi = self._range_counts()
        a = np.clip(np.round((s["accel_g"] + ofs) * lsb_per_g(self.regs[DATA_FORMAT])), lo, hi).astype(np.int64)
        f = self.faults.f
        if f.saturate_after_s is not None:
            a[t >= f.saturate_after_s] = hi
        if f.stuck_after_s is not None:
            st = t >= f.stuck_after_s
            if st.any():
                if self._stuck is None:
                    self._stuck = a[int(np.argmax(st))].copy()
                a[st] = self._stuck
        self.latest = a[-1]
        self.regs[INT_SOURCE] |= 0x80
        mode = self.regs[FIFO_CTL] >> 6
        if mode == 0:
            return
        for row in a:
            if len(self.fifo) >= FIFO_DEPTH:
                if mode == 1:  # FIFO mode: stop collecting when full
                    self.regs[INT_SOURCE] |= 0x01
                    self.overruns += 1
                    break
                self.fifo.pop(0)  # stream mode: the oldest is lost
                self.regs[INT_SOURCE] |= 0x01
                self.overruns += 1
            self.fifo.append(row)
        if s["skipped"]:
            self.regs[INT_SOURCE] |= 0x01
            self.overruns += 1

    def read_registers(self, register: int, length: int) -> bytes:
        self.sampler.freeze(self)
        self._catch_up()
        out = bytearray()
        popped = None
        for i in range(length):
            r = register + i
            if DATAX0 <= r <= DATAX0 + 5:
                if popped is None:
                    if self.regs[FIFO_CTL] >> 6 and self.fifo:
                        popped = self.fifo.pop(0)
                    else:
                        popped = self.latest
                    if not self.fifo:
                        self.regs[INT_SOURCE] &= ~0x80 & 0xFF
                out.append(self._word(popped)[r - DATAX0])
            elif r == FIFO_STATUS:
                out.append(min(len(self.fifo), FIFO_DEPTH) & 0x3F)
            elif r == INT_SOURCE:
                out.append(self.regs[INT_SOURCE])
                self.regs[INT_SOURCE] &= ~0x01 & 0xFF  # overrun cleared on read
            elif r < len(self.regs):
                out.append(self.regs[r])
            else:
                out.append(0)
        self._pace()
        return bytes(out)

    def _pace(self) -> None:
        """An elastic clock waits for the host before this FIFO would overflow (:meth:`LazySampler.pace`)."""
        running = self.regs[FIFO_CTL] >> 6
        self.sampler.pace(self, FIFO_DEPTH - len(self.fifo) if running else None)

    def write_registers(self, register: int, data: bytes) -> None:
        self.sampler.freeze(self)
        self._catch_up()
        for i, v in enumerate(data):
            r = register + i
            if r in (DEVID, INT_SOURCE, FIFO_STATUS) or DATAX0 <= r <= DATAX0 + 5:
                continue
            old = self.regs[r]
            self.regs[r] = v
            if r == POWER_CTL:
                if v & 0x08 and not old & 0x08:
                    self.sampler.restart(self.rate_hz(), self.rate_hz() / 2)
                elif not v & 0x08:
                    self.sampler.stop()
            if r == BW_RATE and self.regs[POWER_CTL] & 0x08:
                self.sampler.restart(self.rate_hz(), self.rate_hz() / 2)
            if r == FIFO_CTL and (v >> 6) == 0:
                self.fifo.clear()
        self._pace()
