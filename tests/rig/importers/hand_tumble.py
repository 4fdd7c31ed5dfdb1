"""Synthetic hand-tumbled accelerometer recordings with known truth (a generic CSV without labels).

:func:`write_hand_tumble` writes ``# units: counts``, ``# lsb_per_g: 16384`` and ``t_s,ax,ay,az`` rows at
100 Hz: ``n_rests`` orientations spread over the sphere (the 26 directions of a cube's faces, edges and
corners, shuffled and each turned by up to 15 deg), each held by hand for 1.5 to 6 s (white noise of
8 counts and a tremor of 0.01 deg), turned to the next in 1 to 3 s with a hand's accelerations (up to
0.3 g) and noise. The sensor's truth: an upper-triangular matrix ``M`` (scale within 3 % of 16384
counts/g, cross terms up to 1 %) and a bias within 400 counts, ``a = M f + b``. ``drift_deg`` turns the
sensor slowly during one rest (a hand that still moves): that rest should be rejected.
``benchmarks/bench_hand_tumble.py`` and ``tests/rig/importers/test_hand_tumble.py`` use it.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

RATE_HZ = 100.0
LSB_PER_G = 16384.0


def truth(rng) -> tuple[np.ndarray, np.ndarray]:
    """A sensor: upper-triangular M (counts/g) and bias b (counts)."""
    m = np.diag(LSB_PER_G * (1 + rng.uniform(-0.03, 0.03, 3)))
    m[np.triu_indices(3, 1)] = LSB_PER_G * rng.uniform(-0.01, 0.01, 3)
    return m, rng.uniform(-400, 400, 3)


def _directions(rng, n: int) -> np.ndarray:
    cube = np.array([p for p in itertools.product((-1, 0, 1), repeat=3) if any(p)], float)
    cube = cube[rng.permutation(len(cube))][:n]
    out = []
    for v in cube / np.linalg.norm(cube, axis=1, keepdims=True):
        out.append(_turn(v, rng.uniform(0, 15), rng))
    return np.array(out)


def _turn(f: np.ndarray, deg: float, rng) -> np.ndarray:
    axis = np.cross(f, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    th = np.radians(deg)
    return f * np.cos(th) + np.cross(axis, f) * np.sin(th)


def write_hand_tumble(path, seed: int, *, n_rests: int = 24, drift_deg: float = 0.0) -> dict:
    """Write one recording to ``path``; return its truth (``matrix``, ``bias``) and the rests' count."""
    rng = np.random.default_rng(seed)
    m, b = truth(rng)
    dirs = _directions(rng, n_rests)
    parts = []
    for k, f in enumerate(dirs):
        n = int(rng.uniform(1.5, 6.0) * RATE_HZ)
        tremor = np.radians(0.01) * rng.normal(size=(n, 3))
        fs = f + np.cross(tremor, f)
        if drift_deg and k == n_rests // 2:  # turned slowly about one axis across f
            axis = np.cross(f, [0.3, -0.5, 0.8])
            axis /= np.linalg.norm(axis)
            th = np.radians(drift_deg) * np.arange(n)[:, None] / n
            fs = f * np.cos(th) + np.cross(axis, f) * np.sin(th)
        parts.append(fs @ m.T + b + rng.normal(0, 8.0, (n, 3)))
        if k + 1 < n_rests:
            nm = int(rng.uniform(1.0, 3.0) * RATE_HZ)
            u = np.linspace(0, 1, nm)[:, None]
            path_f = (1 - u) * f + u * dirs[k + 1]
            path_f /= np.linalg.norm(path_f, axis=1, keepdims=True)
            shake = 0.3 * np.sin(np.pi * u) * rng.normal(size=(1, 3))
            parts.append((path_f + shake) @ m.T + b + rng.normal(0, 8.0, (nm, 3)))
    acc = np.rint(np.vstack(parts)).astype(np.int64)
    t = np.arange(len(acc)) / RATE_HZ
    lines = ["# units: counts", "# lsb_per_g: 16384", "t_s,ax,ay,az"]
    lines += [f"{ti:.2f},{a[0]},{a[1]},{a[2]}" for ti, a in zip(t, acc)]
    Path(path).write_text("\n".join(lines) + "\n")
    return {"matrix": m, "bias": b, "rests": n_rests}
