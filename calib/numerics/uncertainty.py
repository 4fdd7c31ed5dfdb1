"""Standard errors of step means from correlated samples (docs/methods.md, "Per-step standard errors").

A sensor's samples are not independent: the chip's digital low-pass filter correlates consecutive
samples (at 1 kHz with a 44 Hz filter the lag-1 correlation is about 0.76) and its bias wanders.
The standard error of a step mean is then ``sqrt(VIF) * s / sqrt(n)``, ``s`` the step's sample
standard deviation and ``VIF = 1 + 2 sum_k rho_k`` the variance inflation factor of the noise's
autocorrelation ``rho_k`` (``n / VIF`` is the effective sample size).

The noise structure is a property of the chip and its settings, the same in every step of a
session, so the VIF is estimated once per axis from the autocorrelation pooled over all steps'
mean-removed samples, with Geyer's initial-positive-sequence truncation (the sum stops at the first
pair of lags whose autocovariance sum is not positive, and the pair sums are made non-increasing).
Each step keeps its own sample standard deviation. For white noise the VIF is 1 within a few
per mille, so the standard errors are the classic ``s / sqrt(n)``.

Pure numpy.
"""

from __future__ import annotations

import numpy as np

#: a VIF estimate is never taken below this (only noise of a few lags can push a white VIF below 1)
MIN_VIF = 0.5


def pooled_autocovariance(blocks: list, max_lag: int) -> np.ndarray:
    """Autocovariance at lags 0..max_lag of 1-D sample blocks, each with its own mean removed,
    pooled over the blocks (sum of lagged products / number of products)."""
    num = np.zeros(max_lag + 1)
    den = np.zeros(max_lag + 1)
    for x in blocks:
        x = np.asarray(x, float)
        n = len(x)
        if n < 2:
            continue
        x = x - x.mean()
        size = 1 << int(np.ceil(np.log2(2 * n)))
        f = np.fft.rfft(x, size)
        acov = np.fft.irfft(f * np.conj(f), size)[:min(n, max_lag + 1)]
        num[:len(acov)] += acov
        den[:len(acov)] += n - np.arange(len(acov))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.maximum(den, 1), 0.0)


def geyer_vif(gamma: np.ndarray) -> float:
    """``sigma^2_asymptotic / gamma_0`` by Geyer's (1992) initial monotone positive sequence."""
    if gamma[0] <= 0:
        return 1.0
    m = (len(gamma) - 1) // 2
    pairs = gamma[0:2 * m:2] + gamma[1:2 * m + 1:2]
    if len(pairs) == 0:
        return 1.0
    stop = np.flatnonzero(pairs <= 0)
    pairs = pairs[:stop[0]] if len(stop) else pairs
    if len(pairs) == 0:
        return MIN_VIF
    pairs = np.minimum.accumulate(pairs)
    return float(max((2.0 * np.sum(pairs) - gamma[0]) / gamma[0], MIN_VIF))


def pooled_autocovariances(blocks: list, max_lag: int) -> np.ndarray:
    """:func:`pooled_autocovariance` of every axis at once: blocks (n_i, A) -> (max_lag + 1, A). Blocks of one
    length are transformed together (one FFT call per length, not one per block and axis)."""
    n_axes = blocks[0].shape[1]
    num = np.zeros((max_lag + 1, n_axes))
    den = np.zeros(max_lag + 1)
    by_length: dict[int, list] = {}
    for b in blocks:
        if len(b) >= 2:
            by_length.setdefault(len(b), []).append(b)
    for n, group in by_length.items():
        x = np.stack(group)  # (k, n, A)
        x = x - x.mean(axis=1, keepdims=True)
        size = 1 << int(np.ceil(np.log2(2 * n)))
        f = np.fft.rfft(x, size, axis=1)
        m = min(n, max_lag + 1)
        acov = np.fft.irfft(f * np.conj(f), size, axis=1)[:, :m]
        num[:m] += acov.sum(axis=0)
        den[:m] += len(group) * (n - np.arange(m))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den[:, None] > 0, num / np.maximum(den, 1)[:, None], 0.0)


def pooled_vif(blocks: list, max_lag: int | None = None) -> np.ndarray:
    """Per-axis variance inflation factor of a mean, pooled over sample blocks (each (n_i, A))."""
    blocks = [np.asarray(b, float).reshape(len(b), -1) for b in blocks if len(b) >= 2]
    if not blocks:
        return np.ones(1)
    n_min = min(len(b) for b in blocks)
    lag = max(1, n_min // 2 if max_lag is None else min(int(max_lag), n_min - 1))
    gamma = pooled_autocovariances(blocks, lag)
    return np.array([geyer_vif(gamma[:, j]) for j in range(gamma.shape[1])])


def step_standard_errors(blocks: list, floor: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors (K, A) of the means of K sample blocks (each (n_i, A)) and the pooled VIF (A,).

    ``sqrt(VIF_a) * max(s_ia, floor) / sqrt(n_i)``: the per-step sample standard deviation ``s_ia``
    (never below ``floor``, e.g. the quantisation of one count) and the VIF of axis ``a`` pooled over
    the blocks (:func:`pooled_vif`).
    """
    arrs = [np.asarray(b, float).reshape(len(b), -1) for b in blocks]
    vif = pooled_vif(arrs)
    sems = np.array([np.maximum(a.std(axis=0, ddof=1), floor) / np.sqrt(len(a)) for a in arrs])
    return sems * np.sqrt(vif)[None, :], vif
