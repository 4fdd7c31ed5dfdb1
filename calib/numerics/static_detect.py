"""Automatic detection of static intervals in raw samples (the imu_tk approach).

A sample is static when the variance of the signal over a window around it, summed over the three
axes, is below ``threshold_factor`` times the variance seen in the initial static period. Runs of
static samples longer than ``min_s`` become intervals.

:class:`StaticDetector` does it on samples fed in chunks (a recording larger than memory): it keeps the
running sums of the window (a window and a chunk of rows), the variances of the initial period until
their median is known, and the times it still needs; :func:`detect_static` feeds it one array. Both give
the same intervals, to the bit, however the samples are cut into chunks (the running sums are the
whole series' cumulative sums, added in the same order).
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
    t_s : (N,) sample times, s, increasing.  counts : (N, 3) raw samples.
    window_s : variance window.  init_s : the initial period assumed static (noise reference).
    threshold_factor : static when the summed variance < factor x the initial period's.
    min_s : shortest interval kept.  trim_s : trimmed from both ends of every interval.
    """
    t = np.asarray(t_s, float)
    det = StaticDetector(float(np.median(np.diff(t))), float(t[0]), window_s=window_s, init_s=init_s,
                         threshold_factor=threshold_factor, min_s=min_s, trim_s=trim_s)
    det.feed(t, counts)
    return det.finish()


class StaticDetector:
    """:func:`detect_static` on samples fed in chunks of any size (:meth:`feed`, then :meth:`finish`).

    ``dt``: the median sample interval of the whole series (s), ``t0``: its first time; the other
    parameters as :func:`detect_static`'s. Memory: the window and one chunk of rows, plus the variances
    of the initial period (``init_s`` of samples) until the last of them is known.
    """

    def __init__(self, dt: float, t0: float, *, window_s: float = 2.0, init_s: float = 30.0,
                 threshold_factor: float = 6.0, min_s: float = 3.0, trim_s: float = 0.5,
                 reference: float | None = None) -> None:
        self.n = max(3, int(round(window_s / dt)))
        self.half = self.n // 2
        self.trim = int(round(trim_s / dt))
        self.min_s = min_s
        self.threshold_factor = threshold_factor
        self.t_init_end = t0 + init_s
        self.init_n: int | None = None  # samples in the initial period, once a later one is seen
        self.ref: float | None = reference  # given (an adaptive noise floor): no initial period is assumed static
        if reference is not None:
            self.init_n = 0
        self.intervals: list[tuple[int, int]] = []
        self.rejected_short = 0  # static runs shorter than min_s (after the trim)
        self._fed = 0
        self._c1 = np.zeros((1, 3))  # cumulative sums of x and x^2 from index _c_base (C[k]: sum of x[:k])
        self._c2 = np.zeros((1, 3))
        self._c_base = 0
        self._next = 0  # the first sample whose variance is not yet computed
        self._pending: list[np.ndarray] = []  # variances waiting for the reference (initial period)
        self._classified = 0  # the first sample not yet classified static or not
        self._t = np.empty(0)  # times from index _t_base on
        self._t_base = 0
        self._run: int | None = None  # start of the current static run
        self._t_start: float | None = None  # the time at its trimmed start, once fed

    def feed(self, t_s: np.ndarray, counts: np.ndarray) -> None:
        """The next samples: times (increasing) and (n, 3) values."""
        t = np.asarray(t_s, float)
        x = np.asarray(counts, float)
        if len(t) == 0:
            return
        if self.init_n is None and t[-1] > self.t_init_end:
            self.init_n = self._fed + int(np.count_nonzero(t <= self.t_init_end))
        self._t = np.concatenate([self._t, t])
        c1 = np.cumsum(np.vstack([self._c1[-1:], x]), axis=0)[1:]
        c2 = np.cumsum(np.vstack([self._c2[-1:], x * x]), axis=0)[1:]
        self._c1 = np.vstack([self._c1, c1])
        self._c2 = np.vstack([self._c2, c2])
        self._fed += len(t)
        self._catch_t_start()
        self._variances(self._fed - self.half, self._fed)

    def finish(self) -> list[tuple[int, int]]:
        """All samples fed: the static intervals."""
        self._variances(self._fed, self._fed)
        if self.ref is None:
            self.init_n = self._fed if self.init_n is None else self.init_n
            self._take_reference()
        self._close_run(self._fed)
        return self.intervals

    # -- the moving variance -----------------------------------------------------------------------
    def _variances(self, stop: int, n_total: int) -> None:
        """The summed variances of samples ``_next .. stop-1`` (their windows end by ``n_total``)."""
        if stop <= self._next:
            return
        idx = np.arange(self._next, stop)
        lo = np.clip(idx - self.half, 0, n_total)
        hi = np.clip(idx + self.half + 1, 0, n_total)
        cnt = (hi - lo)[:, None]
        c1, c2, b = self._c1, self._c2, self._c_base
        mean = (c1[hi - b] - c1[lo - b]) / cnt
        var = np.maximum((c2[hi - b] - c2[lo - b]) / cnt - mean**2, 0.0).sum(axis=1)
        self._next = stop
        keep = max(0, self._next - self.half) - b  # the sums the next variances need
        if keep > 0:
            self._c1, self._c2, self._c_base = self._c1[keep:], self._c2[keep:], b + keep
        self._pending.append(var)
        if self.ref is None and self.init_n is not None and self._next >= self.init_n:
            self._take_reference()
        elif self.ref is not None:
            self._classify()

    def _take_reference(self) -> None:
        var = np.concatenate(self._pending) if self._pending else np.empty(0)
        self._pending = [var]
        init = var[:self.init_n]
        self.ref = float(np.median(init)) if len(init) else float(np.median(var))
        self._classify()

    # -- runs of static samples --------------------------------------------------------------------
    def _classify(self) -> None:
        var = np.concatenate(self._pending) if len(self._pending) != 1 else self._pending[0]
        self._pending = []
        first = self._classified
        static = var < self.threshold_factor * max(self.ref, 1e-12)
        self._classified += len(var)
        prev = 1 if self._run is not None else 0
        change = np.flatnonzero(np.diff(np.concatenate([[prev], static.astype(np.int8)])))
        for k in change:
            if static[k]:
                self._run, self._t_start = first + int(k), None
                self._catch_t_start()
            else:
                self._close_run(first + int(k))
        drop = max(0, self._classified - self.trim - 1) - self._t_base  # the times a run's end may need
        if self._run is not None and self._t_start is None:
            drop = min(drop, self._run + self.trim - self._t_base)
        if drop > 0:
            self._t, self._t_base = self._t[drop:], self._t_base + drop

    def _catch_t_start(self) -> None:
        if self._run is not None and self._t_start is None:
            s2 = self._run + self.trim
            if s2 < self._fed:
                self._t_start = float(self._t[s2 - self._t_base])

    def _close_run(self, end: int) -> None:
        if self._run is None:
            return
        s2, e2 = self._run + self.trim, end - self.trim
        if e2 > s2 and self._t[e2 - 1 - self._t_base] - self._t_start >= self.min_s:
            self.intervals.append((int(s2), int(e2)))
        else:
            self.rejected_short += 1
        self._run = self._t_start = None


# -- hand-tumbled recordings: an adaptive threshold (the Tedaldi approach) ------------------------------

#: log10 bins of :class:`VarianceFloor`'s histogram (0.01 decade each)
_FLOOR_BINS = np.linspace(-12.0, 12.0, 2401)


class VarianceFloor:
    """The noise floor of a recording: a low percentile of the summed variances of consecutive blocks of
    ``n`` samples (blocks aligned on the whole series, so the result does not depend on how it is fed).

    A hand-tumbled recording has no initial rest to take the noise from; its rests are where the
    variance is lowest, so the ``percentile`` (default 10) of the block variances is the noise of a rest
    as long as a tenth of the recording rests. Fed in chunks (:meth:`feed`), then :meth:`value`.
    """

    def __init__(self, n: int, percentile: float = 10.0) -> None:
        self.n, self.percentile = max(2, int(n)), float(percentile)
        self._rest = np.empty((0, 3))
        self._hist = np.zeros(len(_FLOOR_BINS) - 1, np.int64)

    def feed(self, values: np.ndarray) -> None:
        x = np.concatenate([self._rest, np.asarray(values, float).reshape(-1, 3)])
        k = len(x) // self.n
        if k:
            blocks = x[:k * self.n].reshape(k, self.n, 3)
            var = blocks.var(axis=1).sum(axis=1)
            self._hist += np.histogram(np.log10(np.maximum(var, 1e-12)), _FLOOR_BINS)[0]
        self._rest = x[k * self.n:]

    def value(self) -> float:
        """The percentile's summed variance (units of the values squared); 0 for too few samples."""
        total = int(self._hist.sum())
        if not total:
            return 0.0
        i = int(np.searchsorted(np.cumsum(self._hist), self.percentile / 100.0 * total))
        return float(10 ** (0.5 * (_FLOOR_BINS[i] + _FLOOR_BINS[i + 1])))


def interval_motion(values: np.ndarray, block_n: int) -> float:
    """How much a rest moves inside: the scatter of the means of consecutive blocks of ``block_n`` samples
    over what white noise of the samples' own scatter gives them (rms over the axes of
    ``std(block means) / (std(samples) / sqrt(block_n))``; about 1 at rest, large when the hand drifts).
    NaN with fewer than 3 blocks."""
    x = np.asarray(values, float)
    k = len(x) // max(2, block_n)
    if k < 3:
        return float("nan")
    means = x[:k * block_n].reshape(k, block_n, 3).mean(axis=1)
    # the samples' scatter about their own block means (a slow drift does not inflate it)
    resid = x[:k * block_n].reshape(k, block_n, 3) - means[:, None, :]
    white = np.sqrt(np.maximum((resid**2).sum(axis=(0, 1)) / (k * (block_n - 1)), 1e-30)) / np.sqrt(block_n)
    ratio = means.std(axis=0, ddof=1) / white
    return float(np.sqrt(np.mean(ratio**2)))
