"""What a simulated session costs this machine: shipped procedures run in virtual time, in process.

Each procedure runs on ``rigs/sim.yaml`` (``time_scale: 0``, ``noise: dlpf``, the table's own errors on: the
simulator's defaults) through the command line's own entry point (``rig.cli.main``), controllers in process
(``RIG_SIM_TRANSPORT=memory``, as the tests run them), the solve and its report included. Reports the wall and
CPU seconds of each run (the first run of a process also pays the imports: it is reported apart) and a digest of
the session's ``samples.csv``, so that two checkouts can be compared for speed and for sameness of the samples:

    python benchmarks/bench_sim_speed.py [--repo PATH] [--runs 3] [--procedures tumble26.yaml,gyro_rates.yaml]

``--repo`` runs another checkout's code (e.g. a ``git worktree`` of an older commit) with this script.

Measured (2 cores, Python 3.11, seed 5, wall s, median of the runs after the first of 3; the samples' digests
equal between the two commits for every procedure):

| date | commit | tumble26 | gyro_rates | thermal_ramp | six_position | machine |
|---|---|---|---|---|---|---|
| 2026-11-26 14:45 | cb884d3 (the table's errors on by default, before the simulator's cuts) | 5.03 | 10.28 | 4.22 | 0.50 | quiet, load 1-2 |
| 2026-11-26 14:46 | 1e678d4 (a table at rest once per pose, one evaluation of the stages per block, ...) | 2.91 | 8.71 | 2.37 | 0.29 | the same minutes |

What is left of gyro_rates' 8.7 s is the sample path through a move (each block's stage rotations, the dlpf
noise of accelerometer and gyroscope, the error models) and the register traffic of a FIFO read (a hundred thousand
accesses); computing a resting stage's rotation once per block of a rate step was tried and changed nothing
measurable (8.79 s), so it was not kept.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import yaml


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repo", default=str(Path(__file__).resolve().parents[1]), help="the checkout whose code runs")
    ap.add_argument("--runs", type=int, default=3, help="runs of each procedure (the first also pays the imports)")
    ap.add_argument("--procedures", default="tumble26.yaml,gyro_rates.yaml,thermal_ramp.yaml,six_position.yaml")
    ap.add_argument("--seed", type=int, default=5)
    args = ap.parse_args()
    repo = Path(args.repo).resolve()
    os.environ["RIG_SIM_TRANSPORT"] = "memory"
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    tmp = Path(tempfile.mkdtemp(prefix="bench-sim-speed-"))
    os.environ["RIG_HISTORY"] = str(tmp / "history.sqlite")
    sys.path.insert(0, str(repo))
    from rig.cli import main as rig_main  # the checkout's own

    doc = yaml.safe_load((repo / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise"] = "dlpf"
    rig_file = tmp / "rig.yaml"
    rig_file.write_text(yaml.safe_dump(doc))
    print(f"repo {repo}  seed {args.seed}  runs {args.runs}")
    print(f"{'procedure':<20} {'first wall s':>12} {'wall s (median)':>16} {'cpu s (median)':>15}  samples.csv md5")
    for proc in args.procedures.split(","):
        walls, cpus, digests = [], [], set()
        for k in range(args.runs):
            out = tmp / f"{proc}-{k}"
            t, c = time.perf_counter(), time.process_time()
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
                code = rig_main(["run", str(repo / "procedures" / proc), "--rig", str(rig_file), "--out", str(out),
                                 "--seed", str(args.seed), "--quiet"])
            walls.append(time.perf_counter() - t)
            cpus.append(time.process_time() - c)
            if code != 0:
                sys.exit(f"{proc}: rig run exited {code}: {err.getvalue().strip()}")
            session = next(out.iterdir())
            digests.add(hashlib.md5((session / "samples.csv").read_bytes()).hexdigest())
        rest_w, rest_c = walls[1:] or walls, cpus[1:] or cpus
        print(f"{proc:<20} {walls[0]:>12.2f} {statistics.median(rest_w):>16.2f} {statistics.median(rest_c):>15.2f}  "
              f"{','.join(sorted(digests))}")


if __name__ == "__main__":
    main()
