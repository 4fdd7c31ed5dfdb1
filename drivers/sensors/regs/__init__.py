"""Register maps and scale tables of the supported chips, one module per chip.

Shared by the runtime drivers (``drivers.sensors.mpu9150`` ...) and the register-level
simulators (``drivers.sensors.sim``), so neither depends on the other.
"""
