"""A pure-numpy generator of step means from a known truth, for tests and benchmarks.

Noise on each step mean is Gaussian with the standard error a white-noise
sensor of the given noise density would give over the dwell; means are not
quantised (averaging many samples of a noisy signal dithers the LSB away).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.accel.inputs import StepMeans
from calib.numerics.wander import wander_cov_g2


def triangular_matrix(scale_counts_per_g, alpha_yz: float, alpha_zy: float, alpha_zx: float) -> np.ndarray:
    """diag(k) T^-1 with T = [[1, -a_yz, a_zy], [0, 1, -a_zx], [0, 0, 1]] (the seed's model)."""
    t = np.array([[1.0, -alpha_yz, alpha_zy], [0.0, 1.0, -alpha_zx], [0.0, 0.0, 1.0]])
    return np.diag(np.asarray(scale_counts_per_g, float)) @ np.linalg.inv(t)


@dataclass(frozen=True)
class Truth:
    matrix_counts_per_g: np.ndarray
    bias_counts: np.ndarray
    tempco_counts_per_c: np.ndarray  # (3,)
    t_ref_c: float = 25.0


def six_faces() -> np.ndarray:
    return np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def make_steps(truth: Truth, f_g: np.ndarray, *, temp_c=None, rate_hz: float = 100.0, dwell_s: float = 10.0,
               noise_g_per_rthz: float = 400e-6, lsb_per_g: float = 8192.0, rng=None,
               with_temperature: bool = True) -> StepMeans:
    rng = rng or np.random.default_rng()
    f = np.atleast_2d(np.asarray(f_g, float))
    k = len(f)
    n = int(round(rate_hz * dwell_s))
    temps = np.broadcast_to(np.asarray(truth.t_ref_c if temp_c is None else temp_c, float), (k,)).copy()
    sample_sigma = noise_g_per_rthz * np.sqrt(rate_hz / 2.0) * lsb_per_g  # counts
    sample_sigma = np.sqrt(sample_sigma**2 + 1 / 12.0)
    sem = np.full((k, 3), sample_sigma / np.sqrt(n))
    clean = f @ truth.matrix_counts_per_g.T + truth.bias_counts + np.outer(temps - truth.t_ref_c, truth.tempco_counts_per_c)
    means = clean + rng.normal(0.0, 1.0, (k, 3)) * sem
    return StepMeans(names=tuple(f"step{i + 1}" for i in range(k)), f_nominal_g=f, mean_counts=means, sem_counts=sem,
                     n_samples=np.full(k, n), temp_c=temps if with_temperature else None,
                     t_s=np.arange(k) * (dwell_s + 5.0), lsb_per_g=lsb_per_g)


def wander_g(t_s, duration_s, stability, rng, n_axes: int = 3) -> np.ndarray:
    """(K, n_axes) bias wander of the step means (g), drawn from the covariance
    :func:`calib.numerics.wander.wander_cov_g2` implies for steps at ``t_s`` lasting ``duration_s`` (zeros
    when ``stability`` is None); axes independent."""
    cov = wander_cov_g2(t_s, duration_s, stability)
    k = len(cov)
    if not np.any(cov):
        return np.zeros((k, n_axes))
    chol = np.linalg.cholesky(cov + 1e-30 * np.eye(k))
    return chol @ rng.standard_normal((k, n_axes))


def steps_from_output(f_g, out_g, *, temp_c, t_s, sem_g, rng, lsb_per_g: float = 8192.0, stability=None,
                      duration_s=None, names=None) -> StepMeans:
    """Step means (counts) of a sensor whose noise-free output at each step is ``out_g`` (K, 3), g:
    Gaussian noise of standard error ``sem_g`` (g, scalar or (K, 3)) plus the bias wander of
    ``stability`` over steps at ``t_s`` (s) lasting ``duration_s`` (s)."""
    out = np.asarray(out_g, float)
    k = len(out)
    sem = np.broadcast_to(np.asarray(sem_g, float), (k, 3))
    noisy = out + rng.standard_normal((k, 3)) * sem + wander_g(t_s, duration_s, stability, rng)
    return StepMeans(names=tuple(names) if names is not None else tuple(f"step{i + 1}" for i in range(k)),
                     f_nominal_g=np.asarray(f_g, float), mean_counts=noisy * lsb_per_g, sem_counts=sem * lsb_per_g,
                     n_samples=np.full(k, 500), temp_c=None if temp_c is None else np.asarray(temp_c, float),
                     t_s=np.asarray(t_s, float), lsb_per_g=lsb_per_g, bias_stability=stability,
                     duration_s=None if duration_s is None else np.full(k, duration_s, float))
