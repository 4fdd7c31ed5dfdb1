"""A one-hour 100 Hz session (360,000 rows) loads and solves in bounded memory.

:func:`make_thermal_session` writes a synthetic thermal session of any length (36 steps: six faces
at six temperatures) in the session format; ``benchmarks/bench_memory.py`` uses it for the one-hour
and ten-hour figures of ``rig solve``.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from rig.analysis.solve import calibrate_session
from rig.session import SessionWriter, load_session, read_samples

COLUMNS = ("t_s", "step", "ax", "ay", "az", "temp_c", "wx", "wy", "wz", "mx", "my", "mz", "a1_deg", "a2_deg", "a3_deg")
#: one row as ``SessionWriter.append_samples`` formats it (the magnetometer not read: empty cells)
ROW = "%.5f,%d,%d,%d,%d,%.4f,%d,%d,%d,,,,%.5f,%.5f,%.5f"
STEPS = 36
RATE_HZ = 100.0


#: the recorded procedure: the 36 poses (the temperature steps live in the samples' temperatures)
PROCEDURE = ("format: rig-procedure/1\nname: thermal\nsensor: {model: MPU-9150, accel_range_g: 4, sample_rate_hz: 100}\n"
             "dwell: {seconds: 100}\nsteps:\n"
             + "".join(f'  - pose: "{pose}"\n' for pose in ("+X up", "-X up", "+Y up", "-Y up", "+Z up", "-Z up")
                       for _ in range(6))
             + "solve: {model: triangular, thermal: auto}\n")


def _manifest() -> dict:
    faces = _faces()
    return {"procedure": {"name": "thermal", "text": PROCEDURE},
            "software": {"name": "rig", "version": "test"},
            "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": RATE_HZ,
                               "has_temperature": True}},
            "steps": [{"index": i, "name": f"s{i}", "kind": "static", "angles_deg": [0.0, 0.0, 0.0],
                       "f_nominal": faces[i].tolist(), "status": "pending"} for i in range(STEPS)]}


def _faces() -> np.ndarray:
    return np.repeat([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], 6, axis=0).astype(float)


def _step_rows(rng, i: int, n: int, step_s: float) -> dict:
    """Step ``i``'s ``n`` samples: a face, a temperature, white noise of 27 counts."""
    temp = 27.6 + 5.0 * (i % 6)
    accel = np.round(_faces()[i] * 8192 + 300 + 3 * (temp - 27.6) + rng.normal(0, 27, (n, 3))).astype(np.int64)
    return {"t_s": i * step_s + np.arange(n) / RATE_HZ, "accel_counts": accel, "temp_c": np.full(n, temp),
            "gyro_counts": rng.integers(-50, 50, (n, 3)), "angles_deg": np.zeros((n, 3))}


def make_thermal_session(root, name: str = "one-hour", step_s: float = 100.0, *, direct: bool = True,
                         seed: int = 0) -> Path:
    """A complete 36-step thermal session of ``36 * step_s`` seconds at 100 Hz in ``root/name``.

    ``direct``: write samples.csv with one formatted write per step (``ROW``, the format
    ``SessionWriter.append_samples`` writes; a ten-hour session in seconds); otherwise through
    ``append_samples`` itself.
    """
    rng = np.random.default_rng(seed)
    n = int(round(step_s * RATE_HZ))
    w = SessionWriter.create(root, name, _manifest(), columns=COLUMNS)
    for i in range(STEPS):
        r = _step_rows(rng, i, n, step_s)
        if direct:
            table = np.column_stack([r["t_s"], np.full(n, i), r["accel_counts"], r["temp_c"], r["gyro_counts"],
                                     r["angles_deg"]])
            w._append(w._samples, "samples.csv", ("\n".join(ROW % tuple(row) for row in table.tolist()) + "\n").encode())
        else:
            w.append_samples(i, r["t_s"], r["accel_counts"], temp_c=r["temp_c"], gyro_counts=r["gyro_counts"],
                             mag_counts=np.full((n, 3), np.nan), angles_deg=r["angles_deg"])
        w.complete_step(i, {"n_samples": n})
    w.set_status("complete")
    return Path(root) / name


def test_the_direct_generator_writes_what_the_session_writer_writes(tmp_path):
    a = make_thermal_session(tmp_path, "direct", step_s=0.5, direct=True)
    b = make_thermal_session(tmp_path, "writer", step_s=0.5, direct=False)
    assert (a / "samples.csv").read_bytes() == (b / "samples.csv").read_bytes()
    sa, sb = load_session(a), load_session(b)
    for key in sa.samples:
        assert np.array_equal(sa.samples[key], sb.samples[key], equal_nan=True), key


@pytest.fixture(scope="module")
def one_hour(tmp_path_factory):
    return make_thermal_session(tmp_path_factory.mktemp("large"))


def test_samples_are_read_in_little_more_memory_than_their_arrays(one_hour):
    tracemalloc.start()
    try:
        samples, _ = read_samples(one_hour / "samples.csv", n_steps=STEPS)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    arrays = sum(v.nbytes for v in samples.values())
    assert len(samples["t_s"]) == 360_000
    # read at once, the file's text, its parsed columns and the arrays were all held together (2.6x)
    assert peak < 1.6 * arrays, f"peak {peak / 1e6:.0f} MB traced for {arrays / 1e6:.0f} MB of arrays"


def test_a_one_hour_session_solves_under_300_mb(one_hour, tmp_path):
    d = one_hour
    tracemalloc.start()
    try:
        cal = calibrate_session(d)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert cal.accelerometer is not None
    assert peak < 200e6, f"peak {peak / 1e6:.0f} MB traced (the process adds about 100 MB of code and libraries)"
