"""Per-step checks: saturation, stuck values, temperature out of range and too few samples are caught."""

import numpy as np

from rig.execution.checks import CheckLimits, check_step, longest_constant_run


def _good(n=1000, seed=0):
    rng = np.random.default_rng(seed)
    return np.round(rng.normal([0, 0, 8192], 25, (n, 3))).astype(np.int64), np.full(n, 25.0)


def test_clean_capture_passes():
    a, t = _good()
    assert check_step(a, t, 1000, True).ok


def test_saturation_is_reported_per_axis():
    a, t = _good()
    a[10:20, 2] = 32767
    c = check_step(a, t, 1000, True)
    assert not c.ok and any("saturated on z" in p for p in c.problems)


def test_stuck_axis_is_reported():
    a, t = _good()
    a[100:300, 0] = 123
    c = check_step(a, t, 1000, True)
    assert any("stuck reading on x" in p for p in c.problems)


def test_failed_thermometer_is_reported_only_when_the_sensor_has_one():
    a, t = _good()
    t[:] = -273.0
    assert any("temperature" in p for p in check_step(a, t, 1000, True).problems)
    assert check_step(a, np.full(len(a), np.nan), 1000, False).ok


def test_too_few_samples():
    a, t = _good(900)
    c = check_step(a, t, 1000, True, CheckLimits(min_fraction=0.98))
    assert any("too few samples: 900 of 1000" in p for p in c.problems)


def test_longest_constant_run():
    assert longest_constant_run(np.array([1, 1, 2, 2, 2, 3])) == 3
    assert longest_constant_run(np.array([])) == 0
    assert longest_constant_run(np.array([5])) == 1
