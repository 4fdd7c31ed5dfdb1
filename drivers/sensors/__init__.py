"""I2C sensor drivers (MPU-9150, ADXL345, AK8975) and the TCA9548A I2C switch (``tca9548a``); their simulators live in ``drivers.sensors.sim``.

Layout: ``base`` (the ``AccelSensor`` interface, errors, sample blocks), ``regs/`` (register maps
and scales, shared with the simulators), one driver module per chip, ``chips`` (the registry:
``CHIPS``, ``SENSOR_MODELS``, ``open_sensor``).
"""

from drivers.sensors.base import (AccelSensor, CaptureStats, SampleBlock, SensorError, SensorIdentity,
                                  SensorSettings)
from drivers.sensors.chips import CHIPS, SENSOR_MODELS, ChipSpec, chip_spec, open_sensor

__all__ = ["AccelSensor", "CaptureStats", "CHIPS", "ChipSpec", "SampleBlock", "SENSOR_MODELS", "SensorError",
           "SensorIdentity", "SensorSettings", "chip_spec", "open_sensor"]
