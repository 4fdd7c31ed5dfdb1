"""Settle detection: the table counts as still when the accelerometer says so, not after a fixed sleep."""

import numpy as np
import pytest

from rig.execution.settle import SettleDetector, SettleRule

RATE = 100.0
LSB = 8192.0


def _samples(t, f_g, rng, noise_g=0.003):
    a = np.round((f_g + rng.normal(0, noise_g, (len(t), 3))) * LSB).astype(np.int64)
    return a


def _feed_all(det, t, a, chunk=7):
    for i in range(0, len(t), chunk):
        r = det.feed(t[i:i + chunk], a[i:i + chunk], np.full(len(t[i:i + chunk]), 25.0))
        if r is not None:
            return r
    return None


def test_quiet_signal_settles_after_two_windows_and_keeps_them():
    rng = np.random.default_rng(1)
    t = np.arange(0, 3, 1 / RATE)
    a = _samples(t, np.array([0, 0, 1.0]), rng)
    det = SettleDetector(SettleRule(window_s=0.5), RATE, LSB)
    det.start(0.0)
    r = _feed_all(det, t, a)
    assert r is not None and r.settled
    assert r.elapsed_s == pytest.approx(0.0)
    # the still windows are kept as the start of the capture: nothing before them is lost
    assert r.keep_t_s[0] == pytest.approx(0.0)
    assert len(r.keep_t_s) >= 2 * det.window_n


def test_ringing_after_a_stop_delays_settling_until_it_decays():
    rng = np.random.default_rng(2)
    t = np.arange(0, 4, 1 / RATE)
    ring = 0.05 * np.exp(-t / 0.3) * np.sin(2 * np.pi * 7 * t)
    f = np.array([0, 0, 1.0]) + ring[:, None] * np.array([1, 1, 0.5])
    a = _samples(t, f, rng)
    det = SettleDetector(SettleRule(window_s=0.5, threshold_g=0.01), RATE, LSB)
    det.start(0.0)
    r = _feed_all(det, t, a)
    assert r is not None
    # amplitude falls below ~0.01 g only after ~0.5 s: the first kept sample is after that
    assert r.keep_t_s[0] >= 0.5
    assert r.elapsed_s == pytest.approx(r.keep_t_s[0])


def test_slow_creep_is_not_still():
    rng = np.random.default_rng(3)
    t = np.arange(0, 3, 1 / RATE)
    f = np.array([0, 0, 1.0]) + (0.004 * t)[:, None] * np.array([1, 0, 0])  # 4 mg/s creep on x
    a = _samples(t, f, rng, noise_g=0.001)
    det = SettleDetector(SettleRule(window_s=0.5), RATE, LSB)
    det.start(0.0)
    assert _feed_all(det, t, a) is None


def test_min_s_holds_off_settling():
    rng = np.random.default_rng(4)
    t = np.arange(0, 3, 1 / RATE)
    a = _samples(t, np.array([0, 0, 1.0]), rng)
    det = SettleDetector(SettleRule(window_s=0.5, min_s=1.2), RATE, LSB)
    det.start(0.0)
    r = _feed_all(det, t, a)
    assert r is not None and r.keep_t_s[0] >= 1.2
