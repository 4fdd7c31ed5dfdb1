"""The chip registry: one :class:`ChipSpec` per supported sensor, the single list of models.

Everything that needs to know which chips exist (``open_sensor``, rig-file and procedure
validation, ``rig ports``, the simulated rig) reads it here::

    from drivers.sensors.chips import CHIPS, SENSOR_MODELS
    CHIPS["ADXL345"].sample_rates_hz     # (6.25, 12.5, ..., 3200.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from drivers.sensors.adxl345 import Adxl345
from drivers.sensors.base import AccelSensor, SensorError
from drivers.sensors.mpu9150 import Mpu9150
from drivers.sensors.regs import adxl345 as adxl345_regs
from drivers.sensors.regs import mpu9150 as mpu9150_regs


@dataclass(frozen=True)
class ChipSpec:
    """What the rig needs to know about one sensor chip.

    Attributes
    ----------
    model : str
        Name used in rig files, procedures and sessions ("MPU-9150").
    default_address : int
        7-bit I2C address when the rig file gives none.
    addresses : tuple of int
        Every address the chip can be strapped to.
    identity_register, identity_value : int
        Register that identifies the chip and the value it reads (WHO_AM_I = 0x68 ...).
    accel_ranges_g : tuple of int
        Accelerometer full-scale ranges, g.
    sample_rates_hz : tuple of float
        Output rates the chip can be configured to, Hz.
    has_temperature, has_gyro, has_magnetometer : bool
        Thermometer, gyroscope, magnetometer (the MPU-9150's AK8975) on board.
    driver : callable
        ``driver(bus, address, clock=clock) -> AccelSensor``.
    accel_noise_density_g_rthz : tuple of float
        The datasheet's white-noise density of the accelerometer per axis (x, y, z), g/sqrt(Hz): the
        simulator's noise (``drivers.sensors.sim.error_model``) and the optimistic noise of a target's
        preflight (``rig.execution.executors.targeted``).
    accel_bias_instability_g, accel_random_walk_g_per_rts, accel_flicker_corner_s : float
        The accelerometer bias's Allan-variance characterisation (datasheet class; the datasheets
        give only the noise density, so these are typical figures of consumer MEMS parts of the
        family, docs/sensors.md): flicker floor B (g), random walk K (g/sqrt(s)) and the longest
        correlation time of the flicker (s). The simulator's ``dlpf`` noise draws its bias wander
        from them and the solver states how far a session's bias may stand off the long-run bias.
    gyro_bias_instability_dps, gyro_random_walk_dps_per_rts, gyro_flicker_corner_s : float or None
        The same characterisation of the gyroscope's zero-rate output: flicker floor B (deg/s), random
        walk K (deg/s/sqrt(s)), flicker corner (s); None for a chip without a gyroscope.
    mag_bias_instability_ut, mag_random_walk_ut_per_rts, mag_flicker_corner_s : float or None
        The same of the magnetometer's offset: B (uT), K (uT/sqrt(s)), flicker corner (s); None for a
        chip without a magnetometer. Both are typical figures of the families (the datasheets state
        noise only; docs/sensors.md, "Bias stability"): the simulator's ``dlpf`` noise draws the gyro
        and magnetometer wander from them (:meth:`drivers.sensors.sim.noise.NoiseConfig.for_chip`) and
        the gyro and magnetometer solvers weigh the steps with the covariance they imply.
    """

    model: str
    default_address: int
    addresses: tuple[int, ...]
    identity_register: int
    identity_value: int
    accel_ranges_g: tuple[int, ...]
    sample_rates_hz: tuple[float, ...]
    has_temperature: bool
    has_gyro: bool
    has_magnetometer: bool
    driver: Callable[..., AccelSensor]
    accel_noise_density_g_rthz: tuple[float, float, float] = (400e-6, 400e-6, 400e-6)
    accel_bias_instability_g: float = 40e-6
    accel_random_walk_g_per_rts: float = 4e-6
    accel_flicker_corner_s: float = 5000.0
    gyro_bias_instability_dps: float | None = None
    gyro_random_walk_dps_per_rts: float | None = None
    gyro_flicker_corner_s: float | None = None
    mag_bias_instability_ut: float | None = None
    mag_random_walk_ut_per_rts: float | None = None
    mag_flicker_corner_s: float | None = None

    def accepts_rate(self, rate_hz: float) -> bool:
        """Whether the chip can run at ``rate_hz`` (Hz, within 1e-9 relative)."""
        return any(math.isclose(rate_hz, r, rel_tol=1e-9) for r in self.sample_rates_hz)


CHIPS: dict[str, ChipSpec] = {
    "MPU-9150": ChipSpec(
        model="MPU-9150", default_address=mpu9150_regs.DEFAULT_ADDRESS, addresses=mpu9150_regs.ADDRESSES,
        identity_register=mpu9150_regs.WHO_AM_I, identity_value=mpu9150_regs.WHO_AM_I_VALUE,
        accel_ranges_g=tuple(mpu9150_regs.ACCEL_RANGES), sample_rates_hz=mpu9150_regs.SAMPLE_RATES_HZ,
        has_temperature=True, has_gyro=True, has_magnetometer=True, driver=Mpu9150,
        accel_noise_density_g_rthz=(400e-6, 400e-6, 400e-6),  # product spec PS-MPU-9150A: 400 ug/rtHz
        accel_bias_instability_g=40e-6, accel_random_walk_g_per_rts=4e-6, accel_flicker_corner_s=5000.0,
        # MPU-9150 gyro: 7.2 deg/h flicker floor, 0.012 deg/s/sqrt(h) rate random walk (docs/sensors.md)
        gyro_bias_instability_dps=0.002, gyro_random_walk_dps_per_rts=2e-4, gyro_flicker_corner_s=5000.0,
        # AK8975: 0.1 uT flicker floor (a third of its 0.3 uT LSB), 0.6 uT/sqrt(h) walk (docs/sensors.md)
        mag_bias_instability_ut=0.1, mag_random_walk_ut_per_rts=0.01, mag_flicker_corner_s=5000.0),
    "ADXL345": ChipSpec(
        model="ADXL345", default_address=adxl345_regs.DEFAULT_ADDRESS, addresses=adxl345_regs.ADDRESSES,
        identity_register=adxl345_regs.DEVID, identity_value=adxl345_regs.DEVID_VALUE,
        accel_ranges_g=tuple(adxl345_regs.RANGE_BITS), sample_rates_hz=adxl345_regs.SAMPLE_RATES_HZ,
        has_temperature=False, has_gyro=False, has_magnetometer=False, driver=Adxl345,
        accel_noise_density_g_rthz=(550e-6, 550e-6, 750e-6),  # data sheet rev. E: ~1 LSB rms at 100 Hz, z noisier
        accel_bias_instability_g=100e-6, accel_random_walk_g_per_rts=10e-6, accel_flicker_corner_s=5000.0),
}

#: every supported model name, in the registry's order
SENSOR_MODELS: tuple[str, ...] = tuple(CHIPS)


def chip_spec(model: str) -> ChipSpec:
    """The spec of ``model``; SensorError (one line, naming the known models) for an unknown one."""
    try:
        return CHIPS[model]
    except KeyError:
        raise SensorError(f"unknown sensor model {model!r} (known: {', '.join(SENSOR_MODELS)})") from None


def open_sensor(model: str, bus, address: int | None = None, clock=None) -> AccelSensor:
    """A driver for ``model`` on ``bus`` (smbus2.SMBus or SimulatedI2CBus).

    Parameters
    ----------
    model : str
        One of :data:`SENSOR_MODELS`.
    bus : smbus2.SMBus or SimulatedI2CBus
    address : int or None
        I2C address; None for the chip's default.
    clock : Clock or None
        Timestamps (default real time).
    """
    spec = chip_spec(model)
    return spec.driver(bus, address if address is not None else spec.default_address, clock=clock)
