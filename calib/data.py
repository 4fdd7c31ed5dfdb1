"""Old import path of the accelerometer inputs (used by ``rig``): see :mod:`calib.accel.inputs`."""

from calib.accel.inputs import StepMeans

__all__ = ["StepMeans"]
