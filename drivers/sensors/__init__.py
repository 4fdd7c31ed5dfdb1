"""I2C sensor drivers (MPU-9150, ADXL345) and their register-level simulators."""

from drivers.sensors.base import (AccelSensor, CaptureStats, SampleBlock, SensorError, SensorIdentity,
                                  SensorSettings)


def open_sensor(model: str, bus, address: int | None = None, clock=None):
    """A driver for ``model`` ("MPU-9150" or "ADXL345") on ``bus`` (smbus2.SMBus or SimulatedI2CBus)."""
    if model == "MPU-9150":
        from drivers.sensors.mpu9150 import Mpu9150
        return Mpu9150(bus, address if address is not None else 0x68, clock=clock)
    if model == "ADXL345":
        from drivers.sensors.adxl345 import Adxl345
        return Adxl345(bus, address if address is not None else 0x53, clock=clock)
    raise SensorError(f"unknown sensor model {model!r} (known: MPU-9150, ADXL345)")


__all__ = ["AccelSensor", "CaptureStats", "SampleBlock", "SensorError", "SensorIdentity", "SensorSettings",
           "open_sensor"]
