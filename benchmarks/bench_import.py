"""Time and peak memory of ``rig import --from csv`` on generic CSVs of 20 MB, 200 MB and 1 GB.

    .venv/bin/python benchmarks/bench_import.py [--sizes-mb 20 200 1000] [--keep DIR]

Each file is a tumble with static intervals (``tests/rig/importers/tumble_csv.py``: ``t_s,ax,ay,az,temp_c``
at 200 Hz, 26 orientations held still and turned between, no label column, so the importer finds the
steps by static detection), written into a temporary directory. ``rig import`` runs on it in a
subprocess of its own, started by a small measuring process (:data:`MEASURE`) that prints
``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` after it: the import's peak resident set size and
nothing of this process's (a child started straight from here would carry this process's own high-water
mark, the generator's, through exec into its ``ru_maxrss``: 380 MB instead of 200 at 200 MB).
A size is skipped when the disk lacks about four times its size (the source, the spool and the session).
The table: size, rows, wall time, peak RSS, seconds per MB, steps found.

Measured (2 cores, Python 3.11, numpy 2.4, pandas 3.0; ``rig import`` of a tiny file peaks at about
150 MB: interpreter, numpy, pandas; 50 MB measured by hand the same way):

    file      rows      before: wall   peak RSS     after: wall   peak RSS   s/MB   steps
    20 MB     0.64 M          16.0 s     619 MB           14.2 s     190 MB   0.68     26
    50 MB     1.6 M           49.1 s    1386 MB           23.9 s     199 MB   0.46     26
    200 MB    6.5 M          200.7 s    5287 MB           87.0 s     204 MB   0.41     26
    1 GB      32 M      not run (about 27 GB)            264.4 s     206 MB   0.24     26

Issue 32 (the generic CSV's quasi-static detector with its adaptive threshold: one more pass over the spool
for the noise floor, one per rest for its motion): 20 MB in 4.3 s, peak 191 MB, the same 26 steps (a quieter
machine than the table's; 2026-11-25).

The machine was shared (load 6 to 9 on 2 cores): times vary by a factor of two from run to run; the
memory does not. Before, 1 GB was not run: 26 times the file, more than the machine's 24 GB.

Before: the whole file read at once (its text, a list of rows, the parsed arrays, the session's rows as
text: about 800 bytes a row), then the whole session loaded again to try the follow-up commands. After:
the file is read in blocks of 4 MiB into a binary spool, the session written from it in chunks of 65,536
rows; memory stays flat whatever the size, and the time grows with the size. Most of the time is the
session writer formatting samples.csv (``SessionWriter.append_samples``: numpy's ``char.mod``, about 9 us
a row); reading and parsing the source is about a fifth of it.
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _generator():
    spec = importlib.util.spec_from_file_location("tumble_csv", REPO / "tests" / "rig" / "importers" / "tumble_csv.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: a small process that runs the command given and prints its children's peak RSS (kB) as its last line: the
#: import is started from it, not from this process, whose own peak a child's ru_maxrss would include (a
#: child started by vfork, as subprocess does, takes its parent's high-water mark with it through exec)
MEASURE = ("import resource, subprocess, sys\n"
           "code = subprocess.call(sys.argv[1:])\n"
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
           "sys.exit(code)\n")


def run_import(src: Path, out: Path) -> tuple[float, float, str]:
    """``rig import --from csv SRC -o OUT`` in a subprocess: wall time (s), peak RSS (MB), its output."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", MEASURE, sys.executable, "-m", "rig.cli", "import", "--from", "csv",
                           str(src), "-o", str(out)], cwd=REPO, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"rig import failed ({proc.returncode}):\n{proc.stdout}{proc.stderr}")
    text, peak_kb = proc.stdout.rstrip("\n").rsplit("\n", 1)
    return wall, int(peak_kb) / 1024.0, text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes-mb", type=float, nargs="+", default=[20, 200, 1000])
    ap.add_argument("--keep", type=Path, default=None, help="work in this directory and keep its files")
    args = ap.parse_args(argv)
    gen = _generator()
    work = args.keep or Path(tempfile.mkdtemp(prefix="bench_import_"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"{'file':>8} {'rows':>10} {'wall s':>8} {'peak MB':>8} {'s/MB':>6} {'steps':>6}")
    try:
        for mb in args.sizes_mb:
            free = shutil.disk_usage(work).free
            if free < 4 * mb * 1e6:
                print(f"{mb:>6g}MB skipped: {free / 1e9:.1f} GB free in {work}, about {4 * mb / 1e3:.1f} GB needed")
                continue
            src = work / f"tumble_{mb:g}mb.csv"
            info = gen.write_tumble_csv(src, mb * 1e6)
            out = work / f"sessions_{mb:g}mb"
            wall, rss, text = run_import(src, out)
            steps = next((line.split(" steps")[0].rsplit(", ", 1)[-1] for line in text.splitlines()
                          if " steps (" in line), "?")
            size_mb = info["bytes"] / 1e6
            print(f"{size_mb:>6.0f}MB {info['rows']:>10d} {wall:>8.1f} {rss:>8.0f} {wall / size_mb:>6.2f} {steps:>6}",
                  flush=True)
            if args.keep is None:
                src.unlink()
                shutil.rmtree(out)
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
