"""Gyroscope rate-table calibration ``counts = M w + b (+ G f)``: inputs (:class:`RateStepMeans`), result
(:class:`GyroCalibration`) and solver (:func:`solve_gyro`), after Liang, Xu & Cao 2017 (docs/methods.md)."""

from calib.gyro.inputs import RateStepMeans
from calib.gyro.result import SENSOR_AXES, OFF_DIAGONAL, BiasPair, GyroCalibration, param_names
from calib.gyro.solve import G_SPREAD_MIN, find_bias_pairs, g_sensitivity_inputs, solve_gyro

__all__ = ["SENSOR_AXES", "G_SPREAD_MIN", "OFF_DIAGONAL", "BiasPair", "GyroCalibration", "RateStepMeans", "find_bias_pairs",
           "g_sensitivity_inputs", "param_names", "solve_gyro"]
