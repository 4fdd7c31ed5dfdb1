"""What sealing a session costs (docs/session-format.md, "Seal"): a six-position run and a one-hour 100 Hz session.

    .venv/bin/python benchmarks/bench_seal.py [--repeat 3] [--keep DIR]

Each session is written through :class:`rig.session.SessionWriter` twice, with sealing (the writer hashes the
bytes it writes, :meth:`rig.session.seal.Chains.wrote`, chains each step's at its end, ``Chains.link``, and seals
the record at completion from those hashes, :func:`rig.session.seal.seal_session`) and without (the three replaced
by no-ops), and read back by :func:`rig.session.load_session` with and without the seal's check (samples.csv
checked on the read that parses it, :class:`rig.session.seal.SamplesCheck`, then events.jsonl and the manifest,
:func:`rig.session.seal.verify_on_load`). ``rig verify`` is :func:`rig.session.seal.verify_session` alone, reading
the files itself. Times are the best of ``--repeat`` (seconds).

- six-position: the shipped procedure's shape, 6 steps of 1,000 rows (10 s at 100 Hz), 0.39 MB;
- one hour: the 36-step thermal session of ``tests/rig/session/test_large_session_memory.py`` (six faces at
  six temperatures, 100 s each at 100 Hz: 360,000 rows, every column of an MPU-9150 session), 25.9 MB.

Measured 2026-11-25 (2 cores, load about 1; Python 3.11; best of 3), since the writer hashes as it writes
and the reader checks on its one read (nothing read back for the seal):

    rig run six_position (simulated rig, virtual time, solve and history included): 0.72 s; its hashing
    (as written, 6 links and the seal) 4.9 ms, 0.7 %

    session (rows, samples.csv)       six-position (6,000 rows, 0.39 MB)   one hour (360,000 rows, 25.9 MB)
    recording without sealing              0.049 s                              2.46 s
    hashing as written and links           0.0008 s (0.13 ms a step)            0.037 s (1.0 ms a step)
    the seal at completion                 0.0022 s                             0.0061 s (was 0.023: no re-read)
    recording with sealing                 0.051 s (+4 %)                       2.54 s (+3 %)
    load_session without the check         0.0060 s                             0.264 s
    load_session with the check            0.0067 s (+0.7 ms)                   0.306 s (+42 ms, +16 %)
    rig verify (the check alone)           0.0017 s                             0.046 s

Every cost is O(bytes) and each byte is hashed once where it passes anyway: the writer as it writes, the reader
as it parses (memory: one block). The check's +42 ms on the one-hour session is SHA-256 of 26 MB (about
0.6 GB/s here, with the parse's block handling); before, the check read the file a second time for the same
hashing. The differences of whole recordings carry the noise of a shared machine.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rig.session import SessionWriter, load_session, reader, seal, writer  # noqa: E402

_spec = importlib.util.spec_from_file_location(
    "large_session", REPO / "tests" / "rig" / "session" / "test_large_session_memory.py")
large_session = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(large_session)

SIX_FACES = [[0, 0, 1], [1, 0, 0], [0, 0, -1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
SIX_PROCEDURE = (REPO / "procedures" / "six_position.yaml").read_text()


class Timed:
    """Wraps the writer's sealing calls (hashing what it writes, a step's link, the seal) to add up their time."""

    def __init__(self) -> None:
        self.link_s = self.seal_s = 0.0

    def wrote(self, chains, name, data):
        t0 = time.perf_counter()
        try:
            return _WROTE(chains, name, data)
        finally:
            self.link_s += time.perf_counter() - t0

    def link(self, chains, *args):
        t0 = time.perf_counter()
        try:
            return _LINK(chains, *args)
        finally:
            self.link_s += time.perf_counter() - t0

    def seal(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return seal.seal_session(*args, **kwargs)
        finally:
            self.seal_s += time.perf_counter() - t0


_WROTE, _LINK = seal.Chains.wrote, seal.Chains.link


@contextlib.contextmanager
def sealing(on: bool, timed: Timed | None = None):
    """The writer with its sealing calls timed, or replaced by no-ops."""
    saved = seal.Chains.wrote, seal.Chains.link, writer.seal_session
    if on:
        seal.Chains.wrote = lambda c, name, data: timed.wrote(c, name, data)
        seal.Chains.link = lambda c, *a: timed.link(c, *a)
        writer.seal_session = timed.seal
    else:
        seal.Chains.wrote = lambda c, name, data: None
        seal.Chains.link = lambda c, d, info, i, stats: {**stats, "samples_bytes": [0, (Path(d) / "samples.csv").stat().st_size]}
        writer.seal_session = lambda *a, **k: None
    try:
        yield
    finally:
        seal.Chains.wrote, seal.Chains.link, writer.seal_session = saved


class _NoCheck:
    def __init__(self, *a) -> None:
        pass

    def update(self, chunk) -> None:
        pass


@contextlib.contextmanager
def load_check(on: bool):
    saved = reader.verify_on_load, reader.SamplesCheck
    if not on:
        reader.verify_on_load, reader.SamplesCheck = (lambda *a, **k: []), _NoCheck
    try:
        yield
    finally:
        reader.verify_on_load, reader.SamplesCheck = saved


def six_position(root: Path, name: str) -> Path:
    """The shipped six-position procedure's recording: 6 steps of 1,000 rows, as rig run writes them."""
    manifest = {"procedure": {"name": "six_position", "file": "procedures/six_position.yaml", "text": SIX_PROCEDURE},
                "software": {"name": "rig", "version": "bench"},
                "rig": {"sensor": {"model": "MPU-9150", "address": 104, "accel_lsb_per_g": 8192.0, "accel_range_g": 4,
                                   "sample_rate_hz": 100.0, "has_temperature": True, "gyro_lsb_per_dps": 131.0}},
                "steps": [{"index": i, "name": f"p{i}", "kind": "static", "angles_deg": [0.0, 0.0, 0.0],
                           "f_nominal": f, "status": "pending"} for i, f in enumerate(SIX_FACES)]}
    rng = np.random.default_rng(0)
    w = SessionWriter.create(root, name, manifest,
                             columns=("t_s", "step", "ax", "ay", "az", "temp_c", "wx", "wy", "wz", "a1_deg", "a2_deg",
                                      "a3_deg"))
    for i, f in enumerate(SIX_FACES):
        n = 1000
        w.event("move", step=i, to_deg=[0.0, 90.0 * i, 0.0])
        w.event("settle", step=i, settle_s=0.5)
        w.append_samples(i, i * 15 + np.arange(n) * 0.01,
                         np.round(np.array(f) * 8192 + rng.normal(0, 27, (n, 3))).astype(int),
                         temp_c=np.full(n, 27.6), gyro_counts=rng.integers(-50, 50, (n, 3)),
                         angles_deg=np.zeros((n, 3)))
        w.complete_step(i, {"n_samples": n})
        w.event("capture", step=i, n_samples=n)
    w.set_status("complete")
    return root / name


def one_hour(root: Path, name: str) -> Path:
    return large_session.make_thermal_session(root, name, direct=False)


def simulated_run(root: Path, repeat: int) -> dict:
    """``rig run procedures/six_position.yaml`` on the simulated rig in virtual time (seed 5): the whole run, its
    solve and history record included, with sealing and without."""
    from rig.workflow.run import run_procedure  # the simulated rig: only for this measurement

    best: dict[str, float] = {}
    for k in range(repeat):
        for on in (False, True):
            timed = Timed()
            with sealing(on, timed):
                t0 = time.perf_counter()
                run_procedure(str(REPO / "procedures" / "six_position.yaml"), out_dir=root / f"run-{on}-{k}", seed=5,
                              time_scale=0, history=root / "history.sqlite")
                key = "run_sealed" if on else "run_plain"
                best[key] = min(best.get(key, float("inf")), time.perf_counter() - t0)
            if on:
                best["run_hashing"] = min(best.get("run_hashing", float("inf")), timed.link_s + timed.seal_s)
    return best


def measure(make, root: Path, repeat: int) -> dict:
    best: dict[str, float] = {}

    def keep(key, value):
        best[key] = min(best.get(key, float("inf")), value)

    for k in range(repeat):
        for on in (False, True):
            timed = Timed()
            with sealing(on, timed):
                t0 = time.perf_counter()
                d = make(root, f"{'sealed' if on else 'plain'}-{k}")
                keep("write_sealed" if on else "write_plain", time.perf_counter() - t0)
            if on:
                keep("links", timed.link_s)
                keep("seal", timed.seal_s)
                for check in (False, True):
                    with load_check(check):
                        t0 = time.perf_counter()
                        load_session(d)
                        keep("load_checked" if check else "load_plain", time.perf_counter() - t0)
                t0 = time.perf_counter()
                assert seal.verify_session(d).sealed
                keep("verify", time.perf_counter() - t0)
                best["rows"] = sum(s.stats.n_samples for s in load_session(d).info.steps)
                best["bytes"] = (d / "samples.csv").stat().st_size
                best["steps"] = len(load_session(d).info.steps)
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--keep", default=None, help="write the sessions here (default: a temporary directory, removed)")
    args = ap.parse_args()
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-seal-"))
    root.mkdir(parents=True, exist_ok=True)
    try:
        r = simulated_run(root, args.repeat)
        print("rig run six_position (simulated rig, virtual time; solve and history included)")
        print(f"  without sealing {r['run_plain']:.3f} s, with sealing {r['run_sealed']:.3f} s; hashing "
              f"{1e3 * r['run_hashing']:.1f} ms ({100 * r['run_hashing'] / r['run_plain']:.2f} % of the run)")
        for label, make in (("six-position", six_position), ("one hour at 100 Hz", one_hour)):
            sub = root / label.split()[0]
            sub.mkdir(exist_ok=True)
            r = measure(make, sub, args.repeat)
            steps = int(r["steps"])
            print(f"{label}: {int(r['rows'])} rows, {steps} steps, samples.csv {r['bytes'] / 1e6:.2f} MB")
            print(f"  recording without sealing   {r['write_plain']:.4f} s")
            print(f"  per-step links, all steps   {r['links']:.4f} s ({1e3 * r['links'] / steps:.2f} ms a step)")
            print(f"  the seal at completion      {r['seal']:.4f} s")
            print(f"  recording with sealing      {r['write_sealed']:.4f} s "
                  f"({100 * (r['write_sealed'] / r['write_plain'] - 1):+.0f} %)")
            print(f"  load_session, no check      {r['load_plain']:.4f} s")
            print(f"  load_session, checked       {r['load_checked']:.4f} s "
                  f"({100 * (r['load_checked'] / r['load_plain'] - 1):+.0f} %)")
            print(f"  rig verify (the check)      {r['verify']:.4f} s")
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
