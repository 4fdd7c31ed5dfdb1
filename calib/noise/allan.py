"""The overlapping Allan deviation of one axis, with confidence intervals (allantools; IEEE Std 1139).

:func:`allan_curve` computes the overlapping Allan deviation of rate-like samples (an accelerometer's
g, a gyroscope's deg/s, a magnetometer's uT: allantools' ``data_type="freq"``) at octave-spaced
averaging times, and each point's equivalent degrees of freedom (Greenhall's algorithm,
``allantools.edf_greenhall``) for the noise type that dominates there, from which the chi-squared
confidence interval follows (``allantools.confidence_interval``). allantools is imported when a curve is
computed, not when this module is (docs/architecture.md, "Deferred imports").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.errors import CalibError

#: the averaging times end where fewer than this many independent clusters remain
MAX_TAU_FRACTION = 1.0 / 4.0
#: the averaging times the fit starts at by default, s: shorter ones see the chip's low-pass filter. Its correlation
#: makes an Allan variance fall short of N^2 / tau by a share that shrinks as 1 / tau; from 0.1 s the MPU-9150's
#: 44 Hz filter at 100 Hz pulled the fitted N 0.4-0.5 % low, outside its +-0.65 % interval in 3 of 20 units (two
#: sets of 20 simulated units); from 0.6 s (the first octave point 0.64 s at 100 Hz) the ratio is 1.000, sd 0.004,
#: inside its +-1.35 % interval in 40 of 40 (benchmarks/bench_allan.py)
FIT_TAU_MIN_S = 0.6
#: confidence level of the intervals (1 sigma)
CI_LEVEL = 0.6826894921370859


@dataclass(frozen=True)
class AllanCurve:
    """The overlapping Allan deviation of one axis.

    tau_s : (M,) averaging times, s.
    adev : (M,) Allan deviation, the axis's unit.
    lo, hi : (M,) the 68 % confidence interval of each point (chi-squared with ``edf`` degrees of freedom).
    edf : (M,) equivalent degrees of freedom of each point's Allan variance.
    n_samples : samples the curve was computed from; rate_hz their rate.
    """

    tau_s: np.ndarray
    adev: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    edf: np.ndarray
    n_samples: int
    rate_hz: float

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.rate_hz


def octave_taus(n_samples: int, rate_hz: float, tau_min_s: float = 0.0) -> np.ndarray:
    """Octave-spaced averaging times (s), m = 1, 2, 4, ... samples, from ``tau_min_s`` up to
    :data:`MAX_TAU_FRACTION` of the record."""
    m_max = max(1, int(n_samples * MAX_TAU_FRACTION))
    m = 2 ** np.arange(int(np.log2(m_max)) + 1)
    tau = m / float(rate_hz)
    return tau[tau >= tau_min_s * (1 - 1e-9)]


def edf_for(alpha: np.ndarray, m: np.ndarray, n_samples: int) -> np.ndarray:
    """Greenhall's equivalent degrees of freedom of overlapping Allan variances at ``m`` samples per cluster,
    for frequency-noise exponents ``alpha`` (0 white, -1 flicker, -2 random walk FM)."""
    import allantools  # deferred: only when a characterisation computes a curve

    # allantools counts phase points: n frequency samples integrate to n + 1 phase points
    return np.array([allantools.edf_greenhall(alpha=int(a), d=2, m=int(k), N=n_samples + 1, overlapping=True)
                     for a, k in zip(alpha, m)], float)


def allan_curve(y, rate_hz: float, alpha=None, tau_min_s: float = 0.0) -> AllanCurve:
    """The overlapping Allan deviation of samples ``y`` (N,) taken at ``rate_hz`` (Hz), in ``y``'s unit.

    ``alpha`` (M,) the dominant noise's FM exponent at each averaging time for the degrees of freedom
    (None: white FM, 0, everywhere; :func:`calib.noise.fit.fit_terms` re-evaluates them from its fit).
    CalibError (one line) for fewer than 16 samples or a value that is not finite.
    """
    import allantools  # deferred: only when a characterisation computes a curve

    y = np.asarray(y, float)
    if len(y) < 16:
        raise CalibError(f"an Allan deviation needs at least 16 samples, got {len(y)}")
    if not np.all(np.isfinite(y)):
        raise CalibError(f"sample {int(np.flatnonzero(~np.isfinite(y))[0])} is not a finite number")
    taus = octave_taus(len(y), rate_hz, tau_min_s)
    tau, adev, _, _ = allantools.oadev(y - y.mean(), rate=float(rate_hz), data_type="freq", taus=taus)
    a = np.zeros(len(tau), int) if alpha is None else np.asarray(alpha, int)[:len(tau)]
    return with_edf(AllanCurve(np.asarray(tau, float), np.asarray(adev, float), adev, adev, np.ones(len(tau)),
                               len(y), float(rate_hz)), a)


def with_edf(curve: AllanCurve, alpha: np.ndarray) -> AllanCurve:
    """``curve`` with degrees of freedom and confidence intervals for the noise exponents ``alpha`` (M,)."""
    import allantools  # deferred: only when a characterisation computes a curve

    m = np.rint(curve.tau_s * curve.rate_hz).astype(int)
    edf = edf_for(alpha, m, curve.n_samples)
    lo, hi = np.transpose([allantools.confidence_interval(dev, e, ci=CI_LEVEL) for dev, e in zip(curve.adev, edf)])
    return AllanCurve(curve.tau_s, curve.adev, np.asarray(lo, float), np.asarray(hi, float), edf,
                      curve.n_samples, curve.rate_hz)
