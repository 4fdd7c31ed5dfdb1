"""Per-step cost of a long procedure: N listed steps at virtual time (issue 34 item 7).

A procedure of N listed steps (two poses alternating, ``dwell: 0.2 s`` at 100 Hz: 20 samples a step) runs
in process on the embedded simulated rig at virtual time (``run_procedure(..., time_scale=0)``, no solve).
Every step's wall time is taken at ``SessionWriter.complete_step``; the table gives the total, the mean
per-step time of the first and of the last 1,000 steps (or tenth, for a smaller N), the time spent recording
steps (``complete_step``: the fsync of the samples and the step's record) and the bytes the step records
wrote (session.yaml rewrites before; steps.jsonl lines after).

Usage: python benchmarks/bench_many_steps.py [--steps N]   (default 10000)

Results (this container: 2 cores shared with other work, load average 3-9 during the runs; controllers in
process, RIG_SIM_TRANSPORT=memory). "ms/step" is the wall time between two steps' ends, "rec" the time inside
``complete_step``, "B/step" the bytes it wrote.

Before (the manifest rewritten, fsynced and renamed after every step); 10,000 steps would take hours, so
measured at 500 and 2,000 steps and extrapolated::

     steps  total s  first k ms/step  last k ms/step     k recording s rec first ms rec last ms B/step first B/step last session.yaml
       500     48.9            78.08          123.54    50        39.6        44.88      107.50        91008      245239       253662
      2000    596.9           204.41          435.87   200       566.6       184.48      421.26       354913      970451      1004645

  The recording cost grows with the manifest, i.e. with the number of steps N (every step rewrites all of
  them): 0.28 s a step on average at N = 2,000, so about 1.4 s at N = 10,000: 10,000 x 1.4 s = 3.9 h of
  manifest rewrites (~33 GB written) for about 4 min of simulated rig work, about 4 h in all (the issue's
  figure). And the 10,000-step manifest (5.0 MB) was then refused by the reader (4 MiB limit): no solve.

After (one fsynced steps.jsonl line per step; the manifest compacted once, at the end)::

     steps  total s  first k ms/step  last k ms/step     k recording s rec first ms rec last ms B/step first B/step last session.yaml
     10000    228.7            28.37           17.92  1000        54.3         7.26        3.35          351         353      5016475

  10,000 steps in under 4 min; the per-step cost is flat (first and last 1,000 steps alike: 351 and 353 bytes
  a step, two fsyncs); the compaction at the end writes the 5.0 MB manifest once (about 2 s), and the reader
  reads it (limit 16 MiB). With the session seal (rig.session.seal, its per-step links) the same run took
  425 s: 6.5 ms of recording a step at the start, 47 ms at the end (its link_step scanned every step's stats
  to find the previous link: O(N) a step; 573-581 B/step).

With the seal hashed as written (2026-11-25: rig.session.seal.Chains, the chain runs from the last link made,
nothing read back; 2 cores, 4 other engineers' work beside it)::

     steps  total s  first k ms/step  last k ms/step     k recording s rec first ms rec last ms B/step first B/step last session.yaml
     10000    216.9            21.64           24.68  1000        28.6         2.41        4.54          573         581      7788734

  Recording a step 2.4-4.5 ms (was 6.5-47 ms), flat within the load's noise; 10,000 steps in 3.6 min.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
# the controllers in process (the same protocol bytes, no pseudo-terminals): the steps' cost without the
# scheduling noise of pty threads on a shared machine (RIG_SIM_TRANSPORT=pty to measure with them)
os.environ.setdefault("RIG_SIM_TRANSPORT", "memory")

from rig.session import writer as session_writer  # noqa: E402
from rig.workflow.run import run_procedure  # noqa: E402

POSES = ("+Z up", "+X up")


def procedure_text(n_steps: int) -> str:
    """A procedure of ``n_steps`` listed steps (no repeat:), two poses alternating, 0.2 s dwell."""
    steps = "".join(f'  - pose: "{POSES[i % 2]}"\n' for i in range(n_steps))
    return ("format: rig-procedure/1\nname: many_steps\nsensor: {accel_range_g: 4, sample_rate_hz: 100}\n"
            "dwell: {seconds: 0.2}\nsettle: {window_s: 0.1, threshold_g: 0.01, timeout_s: 30}\n"
            f"steps:\n{steps}solve: {{model: triangular, method: pinv, thermal: auto}}\n")


def _journal_size(d: Path) -> int:
    journal = d / "steps.jsonl"
    return journal.stat().st_size if journal.exists() else 0


class StepClock:
    """Wraps ``SessionWriter.complete_step``: the wall time at every step's end, the time spent inside and the
    bytes it wrote (the journal's growth, and the manifest whenever the writer rewrote it)."""

    def __init__(self) -> None:
        self.ends: list[float] = []
        self.inside: list[float] = []
        self.written: list[int] = []
        self.manifest_bytes = 0
        self.originals = (session_writer.SessionWriter.complete_step, session_writer.atomic_write_text)

    def install(self) -> None:
        complete_step, atomic_write_text = self.originals

        def counted_write(path, text):
            self.manifest_bytes += len(text.encode() if isinstance(text, str) else text)
            atomic_write_text(path, text)

        def timed(writer, *args, **kwargs):
            journal, manifest = _journal_size(writer.session_dir), self.manifest_bytes
            t0 = time.perf_counter()
            complete_step(writer, *args, **kwargs)
            t1 = time.perf_counter()
            self.inside.append(t1 - t0)
            self.ends.append(t1)
            self.written.append(max(_journal_size(writer.session_dir) - journal, 0) + self.manifest_bytes - manifest)

        session_writer.SessionWriter.complete_step = timed
        session_writer.atomic_write_text = counted_write

    def uninstall(self) -> None:
        session_writer.SessionWriter.complete_step, session_writer.atomic_write_text = self.originals


def run(n_steps: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "many.yaml"
        path.write_text(procedure_text(n_steps))
        clock = StepClock()
        clock.install()
        t0 = time.perf_counter()
        try:
            result = run_procedure(str(path), out_dir=Path(tmp) / "s", seed=1, time_scale=0, solve=False)
        finally:
            clock.uninstall()
        total = time.perf_counter() - t0
        d = result.session_dir
        sizes = {p.name: p.stat().st_size for p in d.iterdir() if p.is_file()}
    per_step = [b - a for a, b in zip([t0] + clock.ends[:-1], clock.ends)]
    k = min(1000, max(1, n_steps // 10))
    return {"n": n_steps, "total_s": total, "first_ms": 1e3 * sum(per_step[:k]) / k,
            "last_ms": 1e3 * sum(per_step[-k:]) / k, "k": k, "record_s": sum(clock.inside),
            "record_first_ms": 1e3 * sum(clock.inside[:k]) / k, "record_last_ms": 1e3 * sum(clock.inside[-k:]) / k,
            "bytes_first": sum(clock.written[:k]) / k, "bytes_last": sum(clock.written[-k:]) / k,
            "manifest_bytes": sizes.get("session.yaml", 0), "status": result.status}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, action="append", help="steps in the procedure (repeatable; default 10000)")
    args = ap.parse_args(argv)
    print(f"{'steps':>6} {'total s':>8} {'first k ms/step':>16} {'last k ms/step':>15} {'k':>5} "
          f"{'recording s':>11} {'rec first ms':>12} {'rec last ms':>11} {'B/step first':>12} {'B/step last':>11} "
          f"{'session.yaml':>12}")
    for n in args.steps or [10000]:
        r = run(n)
        print(f"{r['n']:>6} {r['total_s']:>8.1f} {r['first_ms']:>16.2f} {r['last_ms']:>15.2f} {r['k']:>5} "
              f"{r['record_s']:>11.1f} {r['record_first_ms']:>12.2f} {r['record_last_ms']:>11.2f} "
              f"{r['bytes_first']:>12.0f} {r['bytes_last']:>11.0f} {r['manifest_bytes']:>12}", flush=True)
    print(f"(cpu: {os.cpu_count()} cores)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
