"""Peak memory of ``rig solve`` on long sessions: one hour and ten hours at 100 Hz.

    .venv/bin/python benchmarks/bench_memory.py [--hours 1 10] [--keep DIR]

Each session is the synthetic 36-step thermal session of ``tests/rig/session/test_large_session_memory.py``
(six faces at six temperatures, 100 Hz, every column of an MPU-9150 session), written straight in the
session format into a temporary directory. ``rig solve`` runs on it in a subprocess of its own; its
peak resident set size comes from ``os.wait4`` (the child's ``ru_maxrss``), so nothing of this
process is counted. The table: duration, rows, samples.csv size, peak RSS (MB), wall time (s).

Measured (2 cores, Python 3.11; ``rig solve`` of a tiny session peaks at 161 MB: interpreter and
libraries):

    reader                                   1 h (360,000 rows)   10 h (3.6 M rows)   growth
    whole file read at once (before)              318 MB              1698 MB         153 MB/h
    samples.csv in blocks into arrays             264 MB              1136 MB          97 MB/h
      ... and rig solve loading it once*          220 MB               724 MB          56 MB/h

Memory grows linearly with the rows. Read at once, the file's bytes, a copy of its body, the parsed
columns and the session's arrays were all held together (about 430 bytes a row); read in blocks it
is the session's arrays (120 bytes a row for the columns of an MPU-9150 session) and one block.
*``rig solve`` loads the session a second time for its redundancy table while the first is still
held (``rig/cli/commands/solve.py``: ``print_redundancy`` reloads it); the last row is measured with
that second load served from the first.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

_spec = importlib.util.spec_from_file_location(
    "large_session", REPO / "tests" / "rig" / "session" / "test_large_session_memory.py")
large_session = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(large_session)


def solve_peak(session_dir: Path, history: Path) -> tuple[float, float, int]:
    """Run ``rig solve SESSION`` in a fresh interpreter: (peak RSS in MB, wall s, exit code)."""
    env = dict(os.environ, RIG_HISTORY=str(history))
    cmd = [sys.executable, "-m", "rig.cli", "solve", str(session_dir), "--force"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace").strip()
    proc.stderr.close()
    if proc.returncode != 0:
        print(f"rig solve failed ({proc.returncode}): {err}", file=sys.stderr)
    return usage.ru_maxrss / 1024.0, wall, proc.returncode  # Linux: ru_maxrss in KiB


def measure(root: Path, hours: float) -> dict:
    step_s = hours * 3600.0 / large_session.STEPS
    t0 = time.perf_counter()
    d = large_session.make_thermal_session(root, f"h{hours:g}", step_s=step_s)
    made_s = time.perf_counter() - t0
    csv = d / "samples.csv"
    rows = large_session.STEPS * int(round(step_s * large_session.RATE_HZ))
    peak_mb, wall_s, code = solve_peak(d, root / "history.sqlite")
    return {"hours": hours, "rows": rows, "file_mb": csv.stat().st_size / 1e6, "peak_mb": peak_mb,
            "wall_s": wall_s, "made_s": made_s, "ok": code == 0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--keep", default=None, help="write the sessions here and keep them (default: a temp dir)")
    args = ap.parse_args(argv)
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores")
    print(f"{'duration':>9} {'rows':>10} {'samples.csv':>12} {'peak RSS':>10} {'wall':>7}  ok")
    ok = True
    with tempfile.TemporaryDirectory(prefix="bench-memory-") as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        for hours in args.hours:
            r = measure(root, hours)
            ok &= r["ok"]
            print(f"{r['hours']:>7g} h {r['rows']:>10,} {r['file_mb']:>9.0f} MB {r['peak_mb']:>7.0f} MB "
                  f"{r['wall_s']:>6.1f}s  {'yes' if r['ok'] else 'NO'}", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
