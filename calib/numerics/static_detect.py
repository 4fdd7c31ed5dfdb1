"""Automatic detection of static intervals in raw samples (the imu_tk approach).

A sample is static when the variance of the signal over a window around it, summed over the three
axes, is below ``threshold_factor`` times the variance seen in the initial static period. Runs of
static samples longer than ``min_s`` become intervals.
"""

from __future__ import annotations

import numpy as np


def moving_variance(x: np.ndarray, n: int) -> np.ndarray:
    """Variance over a centred window of n samples, per column (edges use what exists)."""
    x = np.asarray(x, float)
    c1 = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x]), axis=0)
    c2 = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), x * x]), axis=0)
    idx = np.arange(len(x))
    lo = np.clip(idx - n // 2, 0, len(x))
    hi = np.clip(idx + n // 2 + 1, 0, len(x))
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    return np.maximum((c2[hi] - c2[lo]) / cnt - mean**2, 0.0)


def detect_static(t_s: np.ndarray, counts: np.ndarray, *, window_s: float = 2.0, init_s: float = 30.0,
                  threshold_factor: float = 6.0, min_s: float = 3.0, trim_s: float = 0.5) -> list[tuple[int, int]]:
    """Static intervals as (start, end) sample index pairs (end exclusive).

    Parameters
    ----------
    t_s : (N,) sample times, s.  counts : (N, 3) raw samples.
    window_s : variance window.  init_s : the initial period assumed static (noise reference).
    threshold_factor : static when the summed variance < factor x the initial period's.
    min_s : shortest interval kept.  trim_s : trimmed from both ends of every interval.
    """
    t = np.asarray(t_s, float)
    a = np.asarray(counts, float)
    dt = float(np.median(np.diff(t)))
    n = max(3, int(round(window_s / dt)))
    var = moving_variance(a, n).sum(axis=1)
    init = t <= t[0] + init_s
    ref = float(np.median(var[init])) if init.any() else float(np.median(var))
    static = var < threshold_factor * max(ref, 1e-12)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], static.astype(int), [0]])))
    out = []
    trim = int(round(trim_s / dt))
    for s, e in zip(edges[0::2], edges[1::2]):
        s2, e2 = s + trim, e - trim
        if e2 > s2 and t[e2 - 1] - t[s2] >= min_s:
            out.append((int(s2), int(e2)))
    return out
