"""Old import path of the magnetometer calibration (used by ``rig``): see :mod:`calib.mag`."""

from calib.mag import METHODS, MagCalibration, MagStepMeans, sigma_names, solve_mag_ellipsoid, solve_mag_positions

__all__ = ["METHODS", "MagCalibration", "MagStepMeans", "sigma_names", "solve_mag_ellipsoid", "solve_mag_positions"]
