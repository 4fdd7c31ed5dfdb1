"""Calibration mathematics (numpy only): models, solvers, uncertainty, discovery, the calibration file.

Packages:

- :mod:`calib.accel`, :mod:`calib.gyro`, :mod:`calib.mag`: one per sensor, each with ``inputs``
  (step means), ``result`` (a :class:`calib.file.section.CalibrationSection`) and ``solve``; they do
  not import each other.
- :mod:`calib.numerics`: what the sensor packages share (design columns and weighted least squares,
  the affine and magnitude fits, step-mean uncertainty, bias stability and wander, static detection).
- :mod:`calib.discovery`: the discrepancy search and its effect library.
- :mod:`calib.file`: the calibration file (``rig-calibration/1``), its sections, the guarded YAML loader.

Modules: :mod:`calib.errors`, :mod:`calib.frames` (sensor axes), :mod:`calib.acceptance`,
:mod:`calib.evaluation`, :mod:`calib.synthetic` (test data; no runtime module imports it).
Imports nothing from ``rig`` or ``drivers``.

The names below are the package's API (``calib.solve``, ``calib.CalibrationFile``, ...); each is
imported from its module on first use, so ``import calib.errors`` does not load every solver.
"""

from __future__ import annotations

import importlib

#: public name -> the module that defines it
API = {
    "AccelCalibration": "calib.accel.result", "FitSummary": "calib.accel.result", "ThermalModel": "calib.accel.result",
    "StepMeans": "calib.accel.inputs", "solve": "calib.accel.solve", "solve_batch": "calib.accel.solve",
    "CalibrationFile": "calib.file.calibration", "CalibrationSection": "calib.file.section",
    "CalibError": "calib.errors", "CalibrationFileError": "calib.errors", "ObservabilityError": "calib.errors",
    "Evaluation": "calib.evaluation", "evaluate": "calib.evaluation",
    "GyroCalibration": "calib.gyro.result", "RateStepMeans": "calib.gyro.inputs", "solve_gyro": "calib.gyro.solve",
    "MagCalibration": "calib.mag.result", "MagStepMeans": "calib.mag.inputs",
    "Recording": "calib.file.apply", "CalibratedRecording": "calib.file.apply", "RecordingMismatch": "calib.file.apply",
    "solve_mag_ellipsoid": "calib.mag.solve", "solve_mag_positions": "calib.mag.solve",
}
__all__ = sorted(API)


def __getattr__(name: str):
    try:
        module = API[name]
    except KeyError:
        raise AttributeError(f"module 'calib' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(API))
