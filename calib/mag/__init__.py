"""Magnetometer calibration ``m = A h + B``: inputs (:class:`MagStepMeans`), result (:class:`MagCalibration`)
and solvers (:func:`solve_mag_positions`, :func:`solve_mag_ellipsoid`)."""

from calib.mag.inputs import MagStepMeans
from calib.mag.result import METHODS, MagCalibration, sigma_names
from calib.mag.solve import solve_mag_ellipsoid, solve_mag_positions

__all__ = ["METHODS", "MagCalibration", "MagStepMeans", "sigma_names", "solve_mag_ellipsoid", "solve_mag_positions"]
