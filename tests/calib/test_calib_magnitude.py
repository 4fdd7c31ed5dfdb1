"""Calibration without known poses: the magnitude constraint, on synthetic data and on a real Xsens recording."""

from __future__ import annotations

import numpy as np
import pytest

from calib.errors import ObservabilityError
from calib.numerics.magnitude import fit_magnitude
from calib.numerics.static_detect import detect_static
from calib.synthetic import triangular_matrix


def _directions(n, rng):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_recovers_a_known_triangular_sensor_from_unknown_poses():
    rng = np.random.default_rng(0)
    m = triangular_matrix([8200.0, 8150.0, 8250.0], 0.004, -0.003, 0.002)
    b = np.array([300.0, -200.0, 500.0])
    f = _directions(40, rng)
    sem = np.full((40, 3), 0.3)
    a = f @ m.T + b + rng.normal(size=(40, 3)) * sem
    fit = fit_magnitude(a, sem)
    assert fit.converged
    assert np.all(np.abs(fit.bias - b) < 5 * fit.sigma_bias)
    assert np.all(np.abs(np.diag(fit.matrix) - np.diag(m)) < 5 * np.diag(fit.sigma_matrix))
    assert fit.matrix[0, 1] == pytest.approx(m[0, 1], abs=5 * fit.sigma_matrix[0, 1] + 1e-9)
    assert 0.5 < fit.chi2_per_dof < 2.0


def test_too_few_or_coplanar_intervals_are_refused():
    rng = np.random.default_rng(1)
    with pytest.raises(ObservabilityError, match="at least 10"):
        fit_magnitude(_directions(5, rng) * 8000)
    flat = _directions(30, rng)
    flat[:, 2] = 0
    with pytest.raises(ObservabilityError, match="plane"):
        fit_magnitude(flat * 8000)


def test_real_xsens_recording_matches_the_datasheet_figures(datasets):
    """imu_tk's Xsens MTi recording (hand-held static poses, unknown), ../shared/datasets/imu_tk-xsens.

    The datasets README gives the unit's figures: about 415/413/415 counts per m/s^2 and offsets
    about 33123/33276/32360 counts.
    """
    d = np.loadtxt(datasets / "imu_tk-xsens" / "xsens_acc.txt")
    t, raw = d[:, 0], d[:, 1:4]
    intervals = detect_static(t, raw, init_s=40.0)
    assert len(intervals) >= 20
    means = np.array([raw[s:e].mean(axis=0) for s, e in intervals])
    sems = np.array([raw[s:e].std(axis=0, ddof=1) / np.sqrt(e - s) for s, e in intervals])
    g = 9.81
    fit = fit_magnitude(means, sems, radius=g)  # f in m/s^2
    scale = np.diag(fit.matrix)  # counts per m/s^2
    np.testing.assert_allclose(scale, [415, 413, 415], rtol=0.01)
    np.testing.assert_allclose(fit.bias, [33123, 33276, 32360], atol=40)
    # after calibration every static interval has |f| = g within 0.1 %
    f = (means - fit.bias) @ np.linalg.inv(fit.matrix).T
    assert np.max(np.abs(np.linalg.norm(f, axis=1) / g - 1)) < 1e-3
