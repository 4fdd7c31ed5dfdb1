"""The main job's numbers.

1. Wall time of the six-position run on the simulated rig at real-time stage speeds (time scale 1),
   and its ratio to the lower bound: moves at the stage's top speed (48 deg/s, same acceleration)
   + the settle minimum (two 0.5 s windows) + the 10 s dwell per pose.
2. Replay: sessions re-solved per second.
3. A one-hour 100 Hz thermal session (360,000 rows) loaded and solved (target under 2 s).

Usage: python benchmarks/bench_rig.py [--skip-realtime]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rig.planning.targets import move_time_s  # noqa: E402
from rig.config.procedure import load_procedure  # noqa: E402
from rig.workflow.run import run_procedure  # noqa: E402
from rig.session import SessionWriter, load_session  # noqa: E402
from calib.file import calibration as calfile  # noqa: E402
from rig.analysis.solve import calibrate_session  # noqa: E402


def lower_bound_s(procedure_path: Path, accel_deg_s2: float = 40.0, settle_s: float = 1.0) -> float:
    proc = load_procedure(procedure_path)
    prev = np.zeros(3)
    total = 0.0
    for s in proc.expanded_steps():
        if s.kind != "static":
            continue
        ang = np.asarray(s.angles_deg)
        total += max(move_time_s(abs(b - a), 48.0, accel_deg_s2) for a, b in zip(prev, ang))
        total += settle_s + s.dwell.seconds
        prev = ang
    return total


def realtime_six_position(tmp: Path) -> Path:
    proc = REPO / "procedures" / "six_position.yaml"
    t0 = time.perf_counter()
    res = run_procedure(str(proc), out_dir=tmp, seed=1, time_scale=1.0)
    wall = time.perf_counter() - t0
    lb = lower_bound_s(proc)
    print(f"six-position run, simulated rig in real time: {wall:.1f} s wall; lower bound {lb:.1f} s "
          f"(48 deg/s moves + 1 s settle + 10 s dwell per pose); ratio {wall / lb:.2f}")
    return res.session_dir


def replay_rate(session_dir: Path, n: int = 20) -> None:
    t0 = time.perf_counter()
    for _ in range(n):
        calfile.write(session_dir / "bench_calibration.yaml", calibrate_session(session_dir))
    dt = (time.perf_counter() - t0) / n
    print(f"re-solve of a recorded six-position session (load + solve + write): {dt * 1e3:.1f} ms "
          f"-> {1 / dt:.1f} sessions/s")


def one_hour_session(tmp: Path) -> None:
    rng = np.random.default_rng(0)
    faces = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    n_steps, per_step = 36, 10000  # 36 steps x 100 s x 100 Hz = 360,000 rows = one hour
    f = np.repeat(faces, 6, axis=0)
    temps = np.tile(27.6 + 5.0 * np.arange(6), 6)
    manifest = {"procedure": {"name": "thermal", "text": (REPO / "procedures" / "thermal.yaml").read_text()},
                "software": {"name": "rig", "version": "bench"},
                "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
                                   "has_temperature": True}},
                "steps": [{"index": i, "name": f"s{i}", "kind": "static", "angles_deg": [0, 0, 0],
                           "f_nominal": f[i].tolist(), "status": "pending"} for i in range(n_steps)]}
    w = SessionWriter.create(tmp, "one-hour", manifest)
    for i in range(n_steps):
        a = np.round(f[i] * 8192 + 300 + 3 * (temps[i] - 27.6) + rng.normal(0, 27, (per_step, 3))).astype(int)
        w.append_samples(i, i * 100 + np.arange(per_step) * 0.01, a, temp_c=np.full(per_step, temps[i]),
                         angles_deg=np.zeros((per_step, 3)))
        w.complete_step(i, {"n_samples": per_step})
    w.set_status("complete")
    d = tmp / "one-hour"
    size_mb = (d / "samples.csv").stat().st_size / 1e6
    t0 = time.perf_counter()
    s = load_session(d)
    t1 = time.perf_counter()
    calfile.write(d / "bench_calibration.yaml", calibrate_session(d, session=s))
    t2 = time.perf_counter()
    print(f"one-hour 100 Hz thermal session ({len(s.samples['t_s'])} rows, {size_mb:.1f} MB): load {t1 - t0:.2f} s, "
          f"solve + write {t2 - t1:.2f} s, total {t2 - t0:.2f} s (target < 2 s)")


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if "--skip-realtime" in sys.argv:
            d = run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=tmp, seed=1,
                              time_scale=0).session_dir
        else:
            d = realtime_six_position(tmp)
        replay_rate(d)
        one_hour_session(tmp)
