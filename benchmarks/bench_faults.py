"""Fault campaign numbers: kill -9 at random moments then resume (20+ trials), and injected-fault tallies.

For each trial: start `rig run procedures/six_position.yaml` on the simulated rig (time scale 4), kill it
with SIGKILL at a random moment, `rig run --resume DIR`, then check: every fsynced step kept, no step
duplicated (each has exactly its 1000 samples), the calibration equal within 5 sigma to an
uninterrupted run of the same simulated sensor.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from calib import calfile  # noqa: E402
from rig.cli import main  # noqa: E402
from rig.session import load_session  # noqa: E402

SIX = str(REPO / "procedures" / "six_position.yaml")


def committed_steps(d: Path) -> int:
    try:
        m = yaml.safe_load((d / "session.yaml").read_text())
        return sum(s["status"] == "complete" for s in m["steps"])
    except Exception:  # noqa: BLE001
        return -1


def trial(tmp: Path, seed: int, rng: random.Random, ref) -> dict:
    out = tmp / f"t{seed}"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.Popen([sys.executable, "-m", "rig.cli", "run", SIX, "--out", str(out), "--seed", "9",
                          "--time-scale", "4", "--quiet"], cwd=REPO, env=env, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(1.0, 22.0))
    killed = p.poll() is None
    p.send_signal(signal.SIGKILL)
    p.wait()
    dirs = [d for d in out.iterdir()] if out.exists() else []
    if not dirs:
        return {"killed": killed, "kept": 0, "resumed": False, "match": False, "note": "killed before the session existed"}
    d = dirs[0]
    kept = committed_steps(d)
    status = yaml.safe_load((d / "session.yaml").read_text())["status"]
    if status == "complete":
        code = 0
    else:
        code = main(["run", "--resume", str(d), "--time-scale", "0", "--quiet"])
    s = load_session(d)
    counts = [len(s.step_samples(i)["t_s"]) for i in range(6)]
    cal = calfile.read(d / "calibration.yaml").accelerometer
    sig = np.hypot(cal.sigma["scale_counts_per_g"], ref.sigma["scale_counts_per_g"])
    sigb = np.hypot(cal.sigma["bias_counts"], ref.sigma["bias_counts"])
    match = bool(np.all(np.abs(np.asarray(cal.scale_counts_per_g) - ref.scale_counts_per_g) < 5 * sig)
                 and np.all(np.abs(np.asarray(cal.bias_counts) - ref.bias_counts) < 5 * sigb))
    return {"killed": killed, "kept": kept, "resumed": code == 0, "no_dup": counts == [1000] * 6, "match": match}


def main_bench(n: int = 20) -> None:
    rng = random.Random(2026)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        assert main(["run", SIX, "--out", str(tmp / "ref"), "--seed", "9", "--time-scale", "0", "--quiet"]) == 0
        ref_dir = next((tmp / "ref").iterdir())
        ref = calfile.read(ref_dir / "calibration.yaml").accelerometer
        results = [trial(tmp, i, rng, ref) for i in range(n)]
    for i, r in enumerate(results):
        print(f"trial {i + 1:2d}: {r}")
    ok = sum(r.get("resumed") and r.get("no_dup") and r["match"] for r in results)
    print(f"\nkill -9 trials: {n}; killed mid-run: {sum(r['killed'] for r in results)}; "
          f"steps already fsynced when killed: {sum(max(r['kept'], 0) for r in results)}; "
          f"resumed to a complete session with every step exactly once and a matching calibration: {ok}/{n}")


if __name__ == "__main__":
    main_bench(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
