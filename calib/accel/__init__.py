"""Accelerometer calibration ``a = M f + b(T) + effects``: inputs (:class:`StepMeans`), result
(:class:`AccelCalibration`) and solvers (:func:`solve`, :func:`solve_batch`; docs/methods.md)."""

from calib.accel.inputs import StepMeans
from calib.accel.result import MODELS, AccelCalibration, FitSummary, ThermalModel
from calib.accel.solve import solve, solve_batch

__all__ = ["MODELS", "AccelCalibration", "FitSummary", "StepMeans", "ThermalModel", "solve", "solve_batch"]
