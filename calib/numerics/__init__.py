"""Numerics the three sensor packages share: weighted least squares over named design columns
(``design``), the affine fit (``affine``), the magnitude constraint (``magnitude``), standard errors of
correlated step means (``uncertainty``), the bias wander and its covariance (``stability``,
``wander``), static-interval detection (``static_detect``) and the two special functions every solve
needs (``special``). Imports nothing from :mod:`calib.accel`, :mod:`calib.gyro` or :mod:`calib.mag`.
"""
