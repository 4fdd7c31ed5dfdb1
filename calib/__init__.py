"""Calibration math (pure numpy): models, solvers, uncertainty, observability, evaluation, calibration file.

Imports nothing from ``rig`` or ``drivers``.
"""

from calib.calfile import CalibrationFile
from calib.data import StepMeans
from calib.errors import CalibError, CalibrationFileError, ObservabilityError
from calib.evaluation import Evaluation, evaluate
from calib.models import AccelCalibration, FitSummary, ThermalModel
from calib.solvers import solve, solve_batch

__all__ = ["AccelCalibration", "CalibError", "CalibrationFile", "CalibrationFileError", "Evaluation",
           "FitSummary", "ObservabilityError", "StepMeans", "ThermalModel", "evaluate", "solve", "solve_batch"]
