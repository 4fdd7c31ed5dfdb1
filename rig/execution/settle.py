"""Settle detection: decide from the accelerometer itself that the table is still.

After a move the sensor rings (worm-gear backlash, cable drag, a springy
mount). Rather than sleeping a fixed time, the runner feeds samples into a
:class:`SettleDetector`, which looks at consecutive windows of samples and
declares the table settled when

* the scatter inside the window is below ``threshold_g`` on every axis, and
* the window mean moved by less than ``mean_tol_sigma`` standard errors
  since the previous window (no slow creep),

for two consecutive windows. The samples of the final still window are
returned so the runner can keep them as the first samples of the capture
(nothing is wasted, and a replay of a recording settles on its first window).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SettleRule:
    """When the table counts as still.

    Attributes
    ----------
    window_s : float
        Length of one window of samples, seconds.
    threshold_g : float
        Largest per-axis sample standard deviation inside a still window, g.
    mean_tol_sigma : float
        Largest change of the window mean between consecutive windows, in
        standard errors of the window mean.
    timeout_s : float
        Give up (the runner flags the step) after this long, seconds.
    min_s : float
        Never settle sooner than this after the move ended, seconds.
    """

    window_s: float = 0.5
    threshold_g: float = 0.01
    mean_tol_sigma: float = 4.0
    timeout_s: float = 30.0
    min_s: float = 0.0


@dataclass
class SettleResult:
    settled: bool
    elapsed_s: float
    noise_g: np.ndarray  # (3,) sample std in the last window, g
    keep_t_s: np.ndarray  # samples of the still window (the start of the capture)
    keep_accel: np.ndarray
    keep_temp_c: np.ndarray
    keep_gyro: np.ndarray | None


class SettleDetector:
    """Incremental stillness test over windows of samples.

    Parameters
    ----------
    rule : SettleRule
    sample_rate_hz : float
    lsb_per_g : float
        Counts per g, to express thresholds in g.

    Call :meth:`start` at the end of each move, then :meth:`feed` samples
    until it returns a :class:`SettleResult`.
    """

    def __init__(self, rule: SettleRule, sample_rate_hz: float, lsb_per_g: float) -> None:
        self.rule = rule
        self.lsb_per_g = float(lsb_per_g)
        self.window_n = max(8, int(round(rule.window_s * sample_rate_hz)))
        self.last_noise_g = np.full(3, np.nan)
        self.start(0.0)

    def start(self, t0_s: float) -> None:
        """Begin watching at clock time ``t0_s`` (the end of the move)."""
        self._start_t = float(t0_s)
        self._pending: list[tuple] = []  # samples not yet cut into windows
        self._run: list[tuple] = []  # consecutive still, mutually consistent windows
        self._last: tuple | None = None  # the last still window judged (even if dropped from the run)

    def feed(self, t_s, accel_counts, temp_c, gyro_counts=None) -> SettleResult | None:
        """Add samples; return a result once two consecutive consistent still windows are seen."""
        if len(t_s) == 0:
            return None
        g = None if gyro_counts is None else np.asarray(gyro_counts, np.int64)
        self._pending.append((np.asarray(t_s, float), np.asarray(accel_counts, np.int64),
                              np.asarray(temp_c, float), g))
        t, a, temp, gyro = _concat(self._pending)
        n = self.window_n
        while len(t) >= n:
            window = (t[:n], a[:n], temp[:n], None if gyro is None else gyro[:n])
            t, a, temp = t[n:], a[n:], temp[n:]
            gyro = None if gyro is None else gyro[n:]
            self._judge(window)
            while self._run and self._run[0][0][0] - self._start_t < self.rule.min_s - 1e-9:
                self._run.pop(0)  # too early to count, however still
            if len(self._run) >= 2:
                rest = (t, a, temp, gyro)
                kt, ka, ktemp, kg = _concat(self._run + [rest])
                elapsed = float(self._run[0][0][0] - self._start_t)
                self.start(self._start_t)
                return SettleResult(True, elapsed, self.last_noise_g.copy(), kt, ka, ktemp, kg)
        self._pending = [(t, a, temp, gyro)]
        return None

    def _judge(self, window: tuple) -> None:
        w = window[1].astype(float) / self.lsb_per_g
        std = w.std(axis=0, ddof=1)
        self.last_noise_g = std
        if not np.all(std <= self.rule.threshold_g):
            self._run = []
            self._last = None
            return
        if self._run or self._last is not None:
            prev = (self._run[-1] if self._run else self._last)[1].astype(float) / self.lsb_per_g
            tol = self.rule.mean_tol_sigma * np.sqrt(_sem2(w, self.lsb_per_g) + _sem2(prev, self.lsb_per_g))
            if np.all(np.abs(w.mean(axis=0) - prev.mean(axis=0)) <= tol):
                self._run.append(window)
                self._last = window
                return
        self._run = [window]
        self._last = window


def _sem2(w: np.ndarray, lsb_per_g: float) -> np.ndarray:
    """Squared standard error of a window mean, floored at one LSB of scatter."""
    std = np.maximum(w.std(axis=0, ddof=1), 1.0 / lsb_per_g)
    return std**2 / len(w)


def _concat(parts: list[tuple]) -> tuple:
    t = np.concatenate([p[0] for p in parts])
    a = np.concatenate([p[1] for p in parts])
    temp = np.concatenate([p[2] for p in parts])
    gyro = None if parts[0][3] is None else np.concatenate([p[3] for p in parts])
    return t, a, temp, gyro
