"""Register-level simulators of the I2C sensors.

``bus`` (``SimulatedI2CBus``), ``mpu9150`` / ``adxl345`` / ``ak8975`` (chip models, register maps
from ``drivers.sensors.regs``), ``sampler`` (lazy sample generation), ``error_model``, ``physics``,
``faults`` (``SensorFaults``).
"""
