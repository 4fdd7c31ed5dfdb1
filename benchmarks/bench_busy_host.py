"""The README's main job on a busy machine (issue 26): `rig run procedures/six_position.yaml` with
CPU-bound processes running beside it.

For each seed: a quiet run, then the same command with ``--busy`` busy loops (default 6) beside it on
the elastic clock (the default), then the same under load with ``--strict`` (the time scale kept, as on
hardware: what the default did before the elastic clock). Reports exit code, wall time, samples lost
(FIFO overflows in the events), and the largest distance of any calibration parameter from the quiet
run of the same seed in combined sigmas (sqrt(sigma_quiet^2 + sigma_busy^2)).

The runs are real commands (subprocesses): the point is the whole program on a loaded machine.

Usage: python benchmarks/bench_busy_host.py [--busy 6] [--seeds 1 2 3] [--time-scale 10] [--skip-strict]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
RIG = [str(REPO / ".venv" / "bin" / "rig")] if (REPO / ".venv" / "bin" / "rig").exists() else [
    sys.executable, "-m", "rig.cli"]
#: the calibration numbers compared with the quiet run, and where their sigmas are
PARAMS = ("bias_counts", "scale_counts_per_g")


def _spin() -> None:
    while True:
        pass


def run_main_job(out: Path, seed: int, extra: list[str]) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run(RIG + ["run", str(REPO / "procedures" / "six_position.yaml"), "--out", str(out),
                                 "--seed", str(seed), "--quiet"] + extra, capture_output=True, text=True, cwd=REPO)
    wall = time.perf_counter() - t0
    sessions = sorted(out.glob("six_position-*"))
    result = {"exit": proc.returncode, "wall_s": wall, "stderr": proc.stderr.strip().splitlines()[-1:],
              "calibration": None, "lost_events": None}
    if sessions:
        events = (sessions[-1] / "events.jsonl").read_text().splitlines()
        result["lost_events"] = sum("overflow" in e or "samples lost" in e for e in events)
        cal = sessions[-1] / "calibration.yaml"
        if cal.exists():
            result["calibration"] = yaml.safe_load(cal.read_text())["accelerometer"]
    return result


def distance_sigma(quiet: dict, busy: dict) -> float:
    """Largest |busy - quiet| / sqrt(s_quiet^2 + s_busy^2) over biases, scales and misalignments."""
    z = []
    for key in PARAMS:
        a, b = np.asarray(quiet[key]), np.asarray(busy[key])
        z.extend(np.abs(a - b) / np.hypot(quiet["sigma"][key], busy["sigma"][key]))
    mq, mb = quiet["misalignment"], busy["misalignment"]
    sq, sb = quiet["sigma"]["misalignment"], busy["sigma"]["misalignment"]
    z.extend(abs(mq[k] - mb[k]) / np.hypot(sq[k], sb[k]) for k in mq)
    return float(np.nanmax(z))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--busy", type=int, default=6, help="CPU-bound processes beside the run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--time-scale", type=float, default=None, help="default: the rig file's (10)")
    ap.add_argument("--skip-strict", action="store_true")
    args = ap.parse_args()
    scale = [] if args.time_scale is None else ["--time-scale", f"{args.time_scale:g}"]
    print(f"machine: {mp.cpu_count()} cores; {args.busy} busy loops beside each loaded run")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            quiet = run_main_job(Path(tmp) / f"quiet{seed}", seed, scale)
            busy = [mp.Process(target=_spin, daemon=True) for _ in range(args.busy)]
            for p in busy:
                p.start()
            try:
                loaded = run_main_job(Path(tmp) / f"busy{seed}", seed, scale)
                strict = None if args.skip_strict else run_main_job(Path(tmp) / f"strict{seed}", seed,
                                                                    scale + ["--strict"])
            finally:
                for p in busy:
                    p.terminate()
                for p in busy:
                    p.join()
            for name, r in (("quiet", quiet), ("busy, elastic", loaded), ("busy, --strict", strict)):
                if r is None:
                    continue
                z = (distance_sigma(quiet["calibration"], r["calibration"])
                     if quiet["calibration"] and r["calibration"] and r is not quiet else None)
                rows.append({"seed": seed, "run": name, "exit": r["exit"], "wall_s": round(r["wall_s"], 1),
                             "lost_events": r["lost_events"], "calibration": r["calibration"] is not None,
                             "max_dist_sigma": None if z is None else round(z, 2),
                             "last_line": r["stderr"][0] if r["exit"] and r["stderr"] else ""})
    print(f"{'seed':>4}  {'run':<15} {'exit':>4} {'wall s':>7} {'lost':>5} {'calib':>5} {'max |d|/sigma':>13}  note")
    for r in rows:
        print(f"{r['seed']:>4}  {r['run']:<15} {r['exit']:>4} {r['wall_s']:>7} {str(r['lost_events']):>5} "
              f"{str(r['calibration']):>5} {str(r['max_dist_sigma']):>13}  {r['last_line'][:110]}")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
