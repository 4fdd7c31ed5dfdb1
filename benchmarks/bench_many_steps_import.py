"""Linear cost of an import with many steps (issue 32 item 5): ``rig import``, ``rig solve`` and ``rig discover``
of a generic CSV of N labelled steps.

    .venv/bin/python benchmarks/bench_many_steps_import.py [--steps 1000 10000] [--samples 10] [--discover-timeout 120] [--repeat 3]

The file: N steps of ``--samples`` rows at 100 Hz, labelled with the six faces in turn (``+X up``, ``-X up``,
...: each run of one label is a step with a known pose), counts of a sensor with a bias and 8 counts of noise.
Each command runs as its own process (``python -m rig.cli``) and is timed by the wall clock; ``rig discover``
is stopped after ``--discover-timeout`` seconds and reported as not finished. Targets: import of 10,000 steps
under 10 s, ``rig solve`` under 5 s, ``rig discover`` under 60 s (2-core machine).

Measured (2 cores shared with other engineers' test runs, Python 3.11; 10 samples a step), ``--repeat 3``: the
median wall clock (the median CPU in brackets), before (HEAD ea6b0c3) and after measured back to back at a load
of about 2 (2026-11-26):

| 10,000 steps | import | rig solve | rig discover |
|---|---|---|---|
| before | 18.4 s (CPU 15.5 s) | 8.5 s (CPU 9.2 s) | not finished in 60 s (3 of 3) |
| after | 5.8 s (CPU 6.0 s) | 8.1 s (CPU 9.0 s) | refused in 2.3 s: more than 400 steps (the limit and the reason) |
| + SVD without its unused left factor (load 2.5) | 6.6 s (CPU 6.1 s) | 3.9 s (CPU 3.9 s) | refused in 2.5 s |

At a load of about 6 the import before took 56.8 s (its 20,011 fsyncs wait on the disk), after 7.0 s. Earlier
(2026-11-25): 1,000 steps imported in 6.5 s, solved in 2.7 s, not discovered in 60 s.

Against the targets: import 5.8 s for 10 s (met), discover refused at once beyond 400 steps (met: its time grows
with the square to the cube of the steps and depends on the data: 400 steps 3-6 s, 450 steps 4-31 s, 600 steps 69 s,
1,000 steps over 60 s), solve 8.1 s for 5 s (missed), then 3.9 s (met) once ``_null_names`` computed its SVD
without the unused (K, K) left factor. Where the import's time went (cProfile of 10,000 steps, 63 s
profiled): 20,011 fsyncs (two a step: samples.csv and the steps journal, ``SessionWriter.complete_step``) 22.6 s,
now one per file at the end (the writer's ``durable_steps=False``: the import is renamed into place complete);
re-checking every step's index at each assignment of ``samples_committed_bytes`` (a pydantic model validator,
quadratic) 11.6 s, now a field validator of ``steps``; the manifest's YAML dumped three times and parsed twice
14 s, now dumped once at the end and the seal computed from the mapping just written. ``rig solve`` of 10,000
steps: 70 % is one SVD with full matrices (``calib.numerics.design._null_names``: a 30,000 x 30,000 U never used);
with ``full_matrices=False`` the same solve took 2.2 s (median of 3; not this change's file). Progress: ``rig
import`` prints ``N of M steps written`` on stderr every 5 s beyond 1,000 steps; ``rig solve`` (beyond 1,000 steps
or 20 MB) and ``rig discover`` (beyond 100 static steps) say each stage as it starts (since 2026-11-26).
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
FACES = {"+X up": [1, 0, 0], "-X up": [-1, 0, 0], "+Y up": [0, 1, 0], "-Y up": [0, -1, 0], "+Z up": [0, 0, 1],
         "-Z up": [0, 0, -1]}


def write_csv(path: Path, steps: int, samples: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    names = list(FACES)
    f = np.repeat(np.array([FACES[names[k % 6]] for k in range(steps)], float), samples, axis=0)
    acc = np.rint(f * 16384 + [120, -80, 200] + rng.normal(0, 8, f.shape)).astype(np.int64)
    t = np.arange(len(acc)) / 100.0
    labels = np.repeat([names[k % 6] for k in range(steps)], samples)
    with open(path, "w") as fh:
        fh.write("# units: counts\n# lsb_per_g: 16384\nt_s,ax,ay,az,label\n")
        for lo in range(0, len(acc), 100_000):
            hi = min(len(acc), lo + 100_000)
            fh.write("".join(f"{t[i]:.2f},{acc[i, 0]},{acc[i, 1]},{acc[i, 2]},{labels[i]}\n" for i in range(lo, hi)))


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(args: list[str], timeout: float | None = None) -> tuple[float | None, float, str]:
    """One command as its own process: (wall s or None when stopped at ``timeout``, CPU s, a note: the exit code
    and the first characters of stderr when it failed)."""
    start, cpu = time.perf_counter(), _children_cpu()
    try:
        r = subprocess.run([sys.executable, "-m", "rig.cli", *args], capture_output=True, text=True, timeout=timeout,
                           cwd=REPO)
    except subprocess.TimeoutExpired:
        return None, _children_cpu() - cpu, ""
    took = time.perf_counter() - start
    note = "" if r.returncode == 0 else f" (exit {r.returncode}: {r.stderr.strip()[:160]})"
    return took, _children_cpu() - cpu, note


def median_of(runs: list[tuple[float | None, float, str]], timeout: float | None = None) -> str:
    """``median wall (median CPU)`` of the runs; a run stopped at the timeout counts as longer than any other."""
    walls = [w if w is not None else float("inf") for w, _, _ in runs]
    wall = statistics.median(walls)
    cpu = statistics.median(c for _, c, _ in runs)
    text = f"not finished in {timeout:g} s" if wall == float("inf") else f"{wall:.1f} s"
    return f"{text} (CPU {cpu:.1f} s; runs {', '.join('-' if w == float('inf') else f'{w:.1f}' for w in walls)})" \
        + runs[0][2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--samples", type=int, default=10)
    ap.add_argument("--discover-timeout", type=float, default=120.0)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each command; the median is reported (default 3)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.steps:
            src = Path(tmp) / f"steps{n}.csv"
            write_csv(src, n, args.samples)
            imports, solves, discovers = [], [], []
            for k in range(args.repeat):
                sid = f"s{n}-{k}"
                imports.append(timed(["import", "--from", "csv", str(src), "-o", str(Path(tmp) / "s"), "--id", sid]))
                session = str(Path(tmp) / "s" / sid)
                solves.append(timed(["solve", session, "-o", str(Path(tmp) / f"cal{n}-{k}.yaml")]))
                discovers.append(timed(["discover", session], timeout=args.discover_timeout))
            print(f"{n} steps, median of {args.repeat}: import {median_of(imports)}; rig solve {median_of(solves)}; "
                  f"rig discover {median_of(discovers, args.discover_timeout)}", flush=True)


if __name__ == "__main__":
    main()
