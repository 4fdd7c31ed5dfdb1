"""Calibration math (pure numpy): models, solvers, uncertainty, observability, evaluation, calibration file.

One package per sensor, each with ``inputs`` (step means), ``result`` (a
:class:`calib.section.CalibrationSection`) and ``solve``: :mod:`calib.accel`, :mod:`calib.gyro`,
:mod:`calib.mag`. Imports nothing from ``rig`` or ``drivers``.
"""

from calib.accel import AccelCalibration, FitSummary, StepMeans, ThermalModel, solve, solve_batch
from calib.calfile import CalibrationFile
from calib.errors import CalibError, CalibrationFileError, ObservabilityError
from calib.evaluation import Evaluation, evaluate
from calib.gyro import GyroCalibration, RateStepMeans, solve_gyro
from calib.mag import MagCalibration, MagStepMeans, solve_mag_ellipsoid, solve_mag_positions
from calib.section import CalibrationSection

__all__ = ["AccelCalibration", "CalibError", "CalibrationFile", "CalibrationFileError", "CalibrationSection",
           "Evaluation", "FitSummary", "GyroCalibration", "MagCalibration", "MagStepMeans", "ObservabilityError",
           "RateStepMeans", "StepMeans", "ThermalModel", "evaluate", "solve", "solve_batch", "solve_gyro",
           "solve_mag_ellipsoid", "solve_mag_positions"]
