"""The test suite as CI runs it (issue 26: `bash .ci/run` under 6 minutes on the 2-core machine).

Clones the committed HEAD into a temporary directory (a fresh checkout: no .venv, nothing cached), runs
``bash .ci/run`` there with ``CI=true``, and reports the wall time of the whole run (setup, the package rules,
the tests), the test counts and the slowest tests (pytest's ``--durations``, passed through PYTEST_ADDOPTS so
the command run is exactly .ci/run's).

Usage: python benchmarks/bench_suite.py [--durations 10] [--tests-only]
  --tests-only  run only the README's test command in this checkout (no clone, no setup)

Measured (fresh clone, ``bash .ci/run``, 2 cores, quiet machine, Python 3.11):

| date | HEAD | wall | pytest | tests |
|---|---|---|---|---|
| 2026-11-26 15:23 | 102ed35 (setup.sh: pip also when uv cannot reach the index) | 5 min 03 s | 4 min 47 s | 2292 passed, 20 skipped |
| 2026-11-26 15:12 | e8caed3 (the session's last: the budget's Type A per axis, the recorded stage angles, the hang-up tests' signals) | **4 min 57 s** | 4 min 40 s | 2292 passed, 20 skipped |
| 2026-11-26 15:06 | df51b80, the same run started under nohup: 4 hang-up tests failed (SIGHUP ignored, inherited; fixed in e8caed3) | 5 min 36 s | 5 min 15 s | 4 failed, 2288 passed, 20 skipped |
| 2026-11-26 14:39 | 1e678d4 (uv with bytecode; the simulator's cuts: a table at rest once per pose, one evaluation of the stages per block) | **4 min 59 s** | 4 min 38 s | 2291 passed, 20 skipped |
| 2026-11-26 14:33 | 253b17b (uv without bytecode: two third-party warnings) | 5 min 21 s | 5 min 12 s | 2291 passed, 20 skipped |
| 2026-11-26 13:37 | da5fd51 (a table at rest once per pose) | 6 min 14 s | 5 min 34 s | 2288 passed, 20 skipped |
| 2026-11-26 13:00-13:10 (a session earlier) | cb884d3 (the table's own errors on by default, issue 29) | 7 min 05 s, 7 min 17 s | - | 2307 passed (the 20 dataset tests ran: the datasets were beside that clone) |
| 2026-11-26 09:15, 09:20 | 86a5864.. (BLAS on one thread per test process, the fixture resume tests on 4 slots) | 5 min 14 s, 5 min 10 s | 4 min 42 s, 4 min 38 s | 2273 passed, 20 skipped |
| 2026-11-26 07:00-07:25 (a session earlier) | 28d5248 | 5 min 54 s, 6 min 33 s, 6 min 04 s, 5 min 21 s | 4:49-5:54 | 2238 passed, 20 skipped |
| 2026-11-26 03:58 | f6a5455.. (after the scheduling and simulator changes) | 5 min 06 s | 4 min 33 s | 1969 passed, 20 skipped |
| 2026-11-26 04:21 | 6bb4ab9 | 4 min 48 s | 4 min 17 s | 1978 passed, 20 skipped |
| 2026-11-25 (previous session's end) | fb8bc24 | 6 min 00 s, 6 min 10 s | 5 min 27 s, 5 min 36 s | 1842 passed, 20 skipped |

On 2026-11-26 two OpenBLAS threads in each of the two test processes on two cores made every small BLAS call wait
for the other thread (a 6x6 triangular solve of the discovery search 16 ms instead of 0.02 ms when the machine is
busy): the conftest sets one BLAS thread per process before numpy loads (user CPU of the suite 9:29-10:31 -> 7:55-8:07
with 35 more tests), and ``rig`` itself does the same as a program (docs/cli.md).

The 20 skips are the dataset tests (``../shared/datasets`` is not beside a clone in /tmp). What moved the time:
pytest-xdist 3.8 re-sorts ``--dist loadscope``'s modules by their number of tests unless ``loadscopereorder`` is
off, so the conftest's heavy-modules-first order had never applied (the long simulated modules ran last, one
worker alone at the end); the simulator's per-read cost (a tumble26 run 7.1 -> about 5.0 s); two property tests'
redundant work.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def readme_test_command() -> str:
    """The README's test command (the second newcomer command), without its `bash setup.sh &&` prefix."""
    text = (REPO / "README.md").read_text()
    commands = re.findall(r"```bash\n(.*?)\n```", text, re.S)
    return commands[1].split("&&", 1)[1].strip()


def run_tests(cwd: Path, durations: int) -> tuple[float, str]:
    cmd = shlex.split(readme_test_command()) + [f"--durations={durations}", "-p", "no:cacheprovider"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, env={**os.environ, "CI": "true"})
    return time.perf_counter() - t0, proc.stdout + proc.stderr


def summarise(wall_s: float, output: str, what: str) -> None:
    final = [line for line in output.splitlines() if re.search(r"\d+ (passed|failed)", line)]
    print(f"{what}: {wall_s:.0f} s wall ({wall_s / 60:.1f} min); {final[-1].strip('= ') if final else 'no summary'}")
    timed = re.findall(r"^\s*([0-9.]+)s (setup|call|teardown)\s+(\S+)", output, re.M)
    if timed:
        print("slowest:")
        for seconds, when, test in timed:
            print(f"  {seconds:>7} s {when:<8} {test}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--durations", type=int, default=10)
    ap.add_argument("--tests-only", action="store_true")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f} at start")
    if args.tests_only:
        wall, out = run_tests(REPO, args.durations)
        summarise(wall, out, "README test command")
        return
    with tempfile.TemporaryDirectory() as tmp:
        clone = Path(tmp) / "main"
        subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
        shared = REPO.parent / "shared"
        if shared.is_dir() and not (Path(tmp) / "shared").exists():
            os.symlink(shared, Path(tmp) / "shared")  # CI has ../shared beside the checkout
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", ".ci/run"], cwd=clone, capture_output=True, text=True,
                              env={**os.environ, "CI": "true", "PYTEST_ADDOPTS": f"--durations={args.durations}"})
        wall = time.perf_counter() - t0
        print(f"bash .ci/run exit {proc.returncode}")
        summarise(wall, proc.stdout + proc.stderr, "fresh clone, bash .ci/run (setup, rules, tests)")
        if proc.returncode:
            print(proc.stdout[-3000:] + proc.stderr[-3000:], file=sys.stderr)


if __name__ == "__main__":
    main()
