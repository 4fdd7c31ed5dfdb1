"""Synthetic recordings of a magnetometer turned by hand without rests, with known truth.

:func:`turning_recording` turns a sensor smoothly through every orientation (a body rate of up to about
120 deg/s about an axis that wanders, like a hand rolling it) in a uniform field of ``FIELD_UT``, for
``seconds`` at ``rate_hz``; the sensor reads ``m = A h_sensor + B + noise`` (white, ``noise_ut`` per axis), A
within 5 % of identity with cross terms up to 3 %, B up to 40 uT.
"""

from __future__ import annotations

import numpy as np

FIELD_WORLD_UT = np.array([20.0, 0.0, -45.0])
FIELD_UT = float(np.linalg.norm(FIELD_WORLD_UT))


def _rotation(axis_angle: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (rad)."""
    angle = float(np.linalg.norm(axis_angle))
    if angle < 1e-15:
        return np.eye(3)
    k = axis_angle / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def truth(rng) -> tuple[np.ndarray, np.ndarray]:
    """A sensor: A (3, 3) and B (3,) uT."""
    a = np.eye(3) + np.diag(rng.uniform(-0.05, 0.05, 3))
    off = ~np.eye(3, dtype=bool)
    a[off] = rng.uniform(-0.03, 0.03, 6)
    return a, rng.uniform(-40, 40, 3)


def turning_recording(seed: int, *, seconds: float = 60.0, rate_hz: float = 100.0, noise_ut: float = 0.4,
                      planar: bool = False) -> dict:
    """``t_s`` (N,), ``m_ut`` (N, 3) and the truth ``a`` (3, 3), ``b`` (3,), ``noise_ut``; ``planar``: turned
    about the sensor's z axis only."""
    rng = np.random.default_rng(seed)
    a, b = truth(rng)
    n = int(seconds * rate_hz)
    t = np.arange(n) / rate_hz
    # a body rate about a wandering axis: three sums of slow sinusoids, rad/s
    freqs, phases = rng.uniform(0.05, 0.4, (3, 3)), rng.uniform(0, 2 * np.pi, (3, 3))
    w = np.radians(70.0) * np.sin(2 * np.pi * freqs[None, :, :] * t[:, None, None] + phases[None]).sum(axis=2) / 1.5
    if planar:
        w[:, :2] = 0.0
    r = np.eye(3)
    m = np.empty((n, 3))
    for k in range(n):
        m[k] = a @ (r.T @ FIELD_WORLD_UT) + b
        r = r @ _rotation(w[k] / rate_hz)
    m += rng.normal(0, noise_ut, (n, 3))
    return {"t_s": t, "m_ut": m, "a": a, "b": b, "noise_ut": noise_ut}


def upper_representative(a: np.ndarray) -> np.ndarray:
    """The upper-triangular representative of ``A R`` (what an ellipsoid fit returns): ``inv(U)`` with U the
    upper Cholesky factor of ``A^-T A^-1``."""
    ai = np.linalg.inv(a)
    u = np.linalg.cholesky(ai.T @ ai).T
    return np.linalg.inv(u)
