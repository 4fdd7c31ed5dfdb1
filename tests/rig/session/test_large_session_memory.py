"""A one-hour 100 Hz session (360,000 rows) loads and solves in bounded memory."""

from __future__ import annotations

import tracemalloc

import numpy as np

from rig.analysis.solve import solve_session
from rig.session import SessionWriter

COLUMNS = ("t_s", "step", "ax", "ay", "az", "temp_c", "wx", "wy", "wz", "mx", "my", "mz", "a1_deg", "a2_deg", "a3_deg")


def _one_hour(tmp_path):
    rng = np.random.default_rng(0)
    faces = np.repeat([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], 6, axis=0).astype(float)
    temps = np.tile(27.6 + 5.0 * np.arange(6), 6)
    manifest = {"procedure": {"name": "thermal", "text": "solve: {model: triangular, thermal: auto}\n"},
                "software": {"name": "rig", "version": "test"},
                "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
                                   "has_temperature": True}},
                "steps": [{"index": i, "name": f"s{i}", "kind": "static", "angles_deg": [0.0, 0.0, 0.0],
                           "f_nominal": faces[i].tolist(), "status": "pending"} for i in range(36)]}
    w = SessionWriter.create(tmp_path, "one-hour", manifest, columns=COLUMNS)
    n = 10000  # 36 steps x 100 s x 100 Hz = 360,000 rows
    for i in range(36):
        a = np.round(faces[i] * 8192 + 300 + 3 * (temps[i] - 27.6) + rng.normal(0, 27, (n, 3))).astype(int)
        w.append_samples(i, i * 100 + np.arange(n) * 0.01, a, temp_c=np.full(n, temps[i]),
                         gyro_counts=rng.integers(-50, 50, (n, 3)), mag_counts=np.full((n, 3), np.nan),
                         angles_deg=np.zeros((n, 3)))
        w.complete_step(i, {"n_samples": n})
    w.set_status("complete")
    return tmp_path / "one-hour"


def test_a_one_hour_session_solves_under_300_mb(tmp_path):
    d = _one_hour(tmp_path)
    tracemalloc.start()
    try:
        cal, _ = solve_session(d, out=tmp_path / "cal.yaml")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert cal.accelerometer is not None
    assert peak < 200e6, f"peak {peak / 1e6:.0f} MB traced (the process adds about 100 MB of code and libraries)"
