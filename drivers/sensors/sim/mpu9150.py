"""Register-level model of the MPU-9150 (MPU-6050 register map) with the AK8975 behind its bypass.

Registers honoured (addresses in :mod:`drivers.sensors.regs.mpu9150`, from the MPU-6000/6050
register map, rev 4.2):
SMPLRT_DIV 0x19, CONFIG 0x1A (DLPF_CFG), GYRO_CONFIG 0x1B, ACCEL_CONFIG 0x1C, FIFO_EN 0x23,
INT_PIN_CFG 0x37 (I2C_BYPASS_EN exposes the AK8975 at 0x0C), INT_ENABLE 0x38, INT_STATUS 0x3A
(DATA_RDY bit 0, FIFO_OFLOW bit 4, cleared on read), data 0x3B..0x48 big-endian, USER_CTRL 0x6A
(FIFO_EN bit 6, FIFO_RESET bit 2), PWR_MGMT_1 0x6B (DEVICE_RESET bit 7, SLEEP bit 6, reset 0x40),
FIFO_COUNTH/L 0x72/0x73, FIFO_R_W 0x74, WHO_AM_I 0x75 = 0x68.
Self-test: SELF_TEST_X/Y/Z/A 0x0D..0x10 hold per-chip factory-trim codes, ACCEL_CONFIG / GYRO_CONFIG
bits 7:5 add the self-test response (:mod:`drivers.sensors.sim.mpu_selftest`). Auxiliary I2C master:
USER_CTRL.I2C_MST_EN (bit 5), I2C_SLV0..3, I2C_MST_DELAY_CTRL, EXT_SENS_DATA_00..23
(:mod:`drivers.sensors.sim.i2c_master`); while it is on, the bypass no longer shows the AK8975.
Noise: the DLPF model (the default, ``noise="dlpf"``, :mod:`drivers.sensors.sim.noise`) with the
bandwidths and delays of CONFIG.DLPF_CFG.
"""

from __future__ import annotations

import numpy as np

from drivers.sensors.regs.mpu9150 import (ACCEL_CONFIG, ACCEL_LSB_PER_G, ACCEL_XOUT_H, AK8975_ADDRESS, CONFIG,
                                          DATA_LAST, DEFAULT_ADDRESS, DLPF_ACCEL, DLPF_BW_HZ, DLPF_GYRO, FIFO_COUNTH,
                                          FIFO_COUNTL, FIFO_EN, FIFO_R_W, FIFO_SIZE, GYRO_CONFIG, GYRO_LSB_PER_DPS,
                                          INT_PIN_CFG, INT_STATUS, PWR_MGMT_1, SELF_TEST_X, SMPLRT_DIV,
                                          TEMP_LSB_PER_C, TEMP_OFFSET_C, USER_CTRL, USER_CTRL_I2C_MST_EN, WHO_AM_I,
                                          WHO_AM_I_VALUE)
from drivers.sensors.sim.ak8975 import Ak8975Model
from drivers.sensors.sim.bus import I2CDevice
from drivers.sensors.sim.error_model import AccelErrorModel, MagErrorModel
from drivers.sensors.sim.faults import FaultInjector, SensorFaults
from drivers.sensors.sim.i2c_master import AuxI2CMaster
from drivers.sensors.sim.mpu_selftest import SelfTestTrim
from drivers.sensors.sim.noise import NoiseConfig, resolve_noise
from drivers.sensors.sim.sampler import LazySampler


def _i16(x: np.ndarray) -> np.ndarray:
    return np.clip(np.round(x), -32768, 32767).astype(np.int64)


class Mpu9150Model(I2CDevice):
    """Simulated MPU-9150.

    Parameters
    ----------
    physics : PhysicsSource (specific force, rate, field, temperature vs time)
    accel_errors : AccelErrorModel
    clock : Clock
    seed : noise seed
    gyro_errors, mag_errors : optional error models
    faults : SensorFaults
    noise : NoiseConfig, "white" / "dlpf", a mapping of NoiseConfig fields, or None (the default model,
        ``drivers.sensors.sim.noise.DEFAULT_NOISE_MODEL``)
    """

    def __init__(self, physics, accel_errors: AccelErrorModel, *, clock, seed: int = 0, gyro_errors=None,
                 mag_errors: MagErrorModel | None = None, faults: SensorFaults | None = None,
                 noise: NoiseConfig | str | dict | None = None, unit_seed: int | None = None) -> None:
        self.clock = clock
        self.noise = resolve_noise(noise, "MPU-9150")
        self.sampler = LazySampler(physics, accel_errors, clock, seed, gyro_errors, noise=self.noise)
        self.faults = FaultInjector(faults, clock)
        # the factory self-test trim is the unit's own: ``unit_seed`` (default ``seed``) when the noise is drawn anew
        self.trim = SelfTestTrim(seed if unit_seed is None else unit_seed, failed=self.faults.f.failed_self_test)
        self.mag = Ak8975Model(physics, mag_errors or MagErrorModel(), clock=clock, seed=seed + 1, noise=self.noise)
        self.master = AuxI2CMaster(self, {AK8975_ADDRESS: self.mag})
        self._bus = None
        self.pointer = 0
        self.fifo_overflows = 0
        self._reset()

    def attach(self, bus, address: int = DEFAULT_ADDRESS) -> None:
        """Plug into a SimulatedI2CBus (the AK8975 appears when the bypass is enabled)."""
        self._bus = bus
        bus.add_device(address, self)

    def _reset(self) -> None:
        self.regs = bytearray(128)
        self.regs[PWR_MGMT_1] = 0x40
        self.regs[WHO_AM_I] = WHO_AM_I_VALUE
        self.regs[SELF_TEST_X:SELF_TEST_X + 4] = self.trim.register_bytes()
        self.fifo = bytearray()
        self.sampler.stop()
        self._last = {"a": np.zeros(3, np.int64), "t": 0, "g": np.zeros(3, np.int64)}
        self._stuck: dict | None = None

    # -- I2CDevice -----------------------------------------------------------------------------
    def check_access(self) -> None:
        self.faults.check_access()

    def read_registers(self, register: int, length: int) -> bytes:
        self.sampler.freeze(self)
        self._catch_up()
        out = bytearray()
        reg = register
        for i in range(length):
            if reg == FIFO_R_W:  # FIFO_R_W does not auto-increment: the rest of the read is the FIFO's, zeros once empty
                n = length - i
                out += self.fifo[:n]
                del self.fifo[:n]
                out += bytes(length - len(out))
                break
            if reg == INT_STATUS:
                out.append(self.regs[INT_STATUS])
                self.regs[INT_STATUS] = 0  # cleared on read
            elif reg in (FIFO_COUNTH, FIFO_COUNTL):
                n = len(self.fifo)
                out.append((n >> 8) & 0xFF if reg == FIFO_COUNTH else n & 0xFF)
            else:
                out.append(self.regs[reg & 0x7F])
            reg += 1
        self._pace()
        return bytes(out)

    def write_registers(self, register: int, data: bytes) -> None:
        self.sampler.freeze(self)
        self._catch_up()
        for i, v in enumerate(data):
            self._write(register + i, v)
        self._pace()

    def _pace(self) -> None:
        """An elastic clock waits for the host before this FIFO would overflow (:meth:`LazySampler.pace`)."""
        size = self._sample_bytes()
        running = self.regs[USER_CTRL] & 0x40 and size
        self.sampler.pace(self, (FIFO_SIZE - len(self.fifo)) // size if running else None)

    def _write(self, reg: int, v: int) -> None:
        if reg == PWR_MGMT_1:
            if v & 0x80:
                self._reset()
                return
            was_asleep = bool(self.regs[PWR_MGMT_1] & 0x40)
            self.regs[reg] = v & 0x7F
            if v & 0x40:
                self.sampler.stop()
            elif was_asleep:
                self._restart_grid()
            return
        if reg == USER_CTRL:
            if v & 0x04:
                self.fifo.clear()
            self.regs[reg] = v & ~0x04 & 0xFF
            self._route_aux_bus()
            return
        if reg == FIFO_R_W:
            return
        if reg in (WHO_AM_I, INT_STATUS) or ACCEL_XOUT_H <= reg <= DATA_LAST:
            return  # read-only
        self.regs[reg & 0x7F] = v
        if reg in (SMPLRT_DIV, CONFIG) and not self.regs[PWR_MGMT_1] & 0x40:
            self._restart_grid()
        if reg == INT_PIN_CFG:
            self._route_aux_bus()

    def _route_aux_bus(self) -> None:
        """The AK8975 is on the host bus while the bypass is on and the I2C master is off."""
        if self._bus is None:
            return
        if self.regs[INT_PIN_CFG] & 0x02 and not self.regs[USER_CTRL] & USER_CTRL_I2C_MST_EN:
            self._bus.add_device(AK8975_ADDRESS, self.mag)
        else:
            self._bus.remove_device(AK8975_ADDRESS)

    # -- sampling ------------------------------------------------------------------------------
    @property
    def accel_lsb_per_g(self) -> float:
        return ACCEL_LSB_PER_G[(self.regs[ACCEL_CONFIG] >> 3) & 3]

    @property
    def gyro_lsb_per_dps(self) -> float:
        return GYRO_LSB_PER_DPS[(self.regs[GYRO_CONFIG] >> 3) & 3]

    def output_rate_hz(self) -> float:
        dlpf = self.regs[CONFIG] & 7
        base = 8000.0 if dlpf in (0, 7) else 1000.0
        return base / (1 + self.regs[SMPLRT_DIV])

    def _restart_grid(self) -> None:
        cfg = self.regs[CONFIG] & 7
        self.sampler.restart(self.output_rate_hz(), DLPF_BW_HZ[cfg], delay_s=DLPF_ACCEL[cfg][1] / 1e3,
                             gyro_bandwidth_hz=DLPF_GYRO[cfg][0])

    @staticmethod
    def _with_self_test(x, offset):
        return x if offset is None else x + offset

    def _sample_bytes(self) -> int:
        en = self.regs[FIFO_EN]
        return (6 if en & 0x08 else 0) + (2 if en & 0x80 else 0) + 2 * bin(en & 0x70).count("1")

    def _catch_up(self) -> None:
        """Produce the samples due by now: data registers, INT_STATUS, FIFO (with overflow)."""
        if not self.sampler.due():
            return
        size = max(self._sample_bytes(), 1)
        # with neither the FIFO nor the I2C master running, only the data registers show a sample: the
        # newest; the ones before it are only counted (a thermal wait polls the thermometer for hours of
        # virtual time: producing 100 unseen samples a poll cost 40 % of a thermal run's simulation)
        collecting = (self.regs[USER_CTRL] & 0x40 and self._sample_bytes()) or self.regs[USER_CTRL] & USER_CTRL_I2C_MST_EN
        s = self.sampler.catch_up(keep_last=FIFO_SIZE // size + 2 if collecting else 1)
        if s is None:
            return
        t = s["t_s"]
        a = _i16(self._with_self_test(s["accel_g"], self.trim.accel_offset_g(self.regs[ACCEL_CONFIG]))
                 * self.accel_lsb_per_g)
        temp = _i16((s["temp_c"] - TEMP_OFFSET_C) * TEMP_LSB_PER_C)
        g = _i16(self._with_self_test(s["gyro_dps"], self.trim.gyro_offset_dps(self.regs[GYRO_CONFIG]))
                 * self.gyro_lsb_per_dps) if s["gyro_dps"] is not None else np.zeros_like(a)
        if self.regs[USER_CTRL] & USER_CTRL_I2C_MST_EN:
            for ti in t:
                self.master.run(int(round((ti - self.sampler.t_start) * self.sampler.rate_hz)), float(ti))
        f = self.faults
        if f.f.saturate_after_s is not None:
            sat = t >= f.f.saturate_after_s
            a[sat] = 32767
        if f.f.thermometer_fail_after_s is not None:
            temp[t >= f.f.thermometer_fail_after_s] = -32768
        if f.f.stuck_after_s is not None:
            st = t >= f.f.stuck_after_s
            if st.any():
                if self._stuck is None:
                    first = int(np.argmax(st))
                    self._stuck = {"a": a[first].copy(), "t": temp[first], "g": g[first].copy()}
                a[st], temp[st], g[st] = self._stuck["a"], self._stuck["t"], self._stuck["g"]
        # data registers hold the newest sample
        data = np.concatenate([a[-1], [temp[-1]], g[-1]]).astype(">i2").tobytes()
        self.regs[ACCEL_XOUT_H:ACCEL_XOUT_H + 14] = data
        self.regs[INT_STATUS] |= 0x01
        if s["skipped"]:
            self.regs[INT_STATUS] |= 0x10 if self.regs[USER_CTRL] & 0x40 else 0
            if self.regs[USER_CTRL] & 0x40:
                self.fifo_overflows += 1
        if self.regs[USER_CTRL] & 0x40 and self._sample_bytes():
            en = self.regs[FIFO_EN]
            cols = []
            if en & 0x08:
                cols.append(a)
            if en & 0x80:
                cols.append(temp[:, None])
            for bit, j in ((0x40, 0), (0x20, 1), (0x10, 2)):
                if en & bit:
                    cols.append(g[:, j:j + 1])
            block = np.concatenate(cols, axis=1).astype(">i2").tobytes()
            self.fifo.extend(block)
            excess = len(self.fifo) - FIFO_SIZE
            if excess > 0:
                drop = -(-excess // size) * size  # whole samples
                del self.fifo[:drop]
                self.regs[INT_STATUS] |= 0x10
                self.fifo_overflows += 1
