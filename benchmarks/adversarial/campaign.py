"""The campaign: every attack class's inputs, run ``--jobs`` at a time, then the process trials one at a time, then
the report (``python benchmarks/bench_adversarial.py --help``, or ``python -m benchmarks.adversarial``)."""

from __future__ import annotations

import argparse
import os
import random
import shutil
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from . import __doc__ as CAMPAIGN_DOC
from . import (calibrations, concurrency, imports, names, options, outputs, procedures, report, rigfiles, sessions,
               signals)
from .runner import Case, run_case
from .workspace import Workspace

#: the attack classes of files and commands, in the report's order (each: ``cases(ws, rng, quick)``)
INPUT_CLASSES = (procedures, rigfiles, sessions, calibrations, imports, options, outputs, names)


def input_cases(ws: Workspace, rng: random.Random, quick: bool) -> list[Case]:
    """Every input case of every attack class (files written, nothing run yet)."""
    out: list[Case] = []
    for module in INPUT_CLASSES:
        out += module.cases(ws, rng, quick)
    return out


def quick_sample(cases: list[Case], seed: int) -> list[Case]:
    """A fixed-seed sample that keeps every family: its first control, and at least four others (heavy ones left
    out)."""
    fams: dict[str, list[Case]] = {}
    light = [c for c in cases if not c.heavy]
    for c in light:
        fams.setdefault(c.family, []).append(c)
    picked = []
    for fam, cs in fams.items():
        controls = [c for c in cs if c.expect == "valid"][:1]
        rest = [c for c in cs if c not in controls]
        picked += controls + random.Random(seed).sample(rest, min(len(rest), max(4, 60 * len(cs) // len(light))))
    return picked


def run_inputs(cases: list[Case], jobs: int, t0: float) -> list[Case]:
    done = 0

    def one(c: Case) -> Case:
        nonlocal done
        r = run_case(c)
        done += 1
        if done % 25 == 0:
            print(f"  {done}/{len(cases)} ({time.monotonic() - t0:.0f} s)", file=sys.stderr)
        return r

    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(one, cases))


def run_process_trials(root: Path, ws: Workspace, args) -> list[Case]:
    n = args.trials if args.trials is not None else (4 if args.quick else 21)
    prng = random.Random(args.seed + 1)
    planned = signals.trials(root / "proc", ws.ref, n, prng, args.quick) + \
        concurrency.trials(root / "proc", ws.ref, prng, args.quick)
    out = []
    for k, (_, trial) in enumerate(planned):
        c = trial()
        print(f"  trial {k + 1}/{len(planned)}: {c.name}: {c.result['category']} {c.result.get('why', '')}",
              file=sys.stderr)
        out.append(c)
    return out


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=CAMPAIGN_DOC.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="~60 inputs and a few process trials (< 4 min)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--jobs", type=int, default=max(1, min(4, os.cpu_count() or 1)))
    ap.add_argument("--trials", type=int, default=None,
                    help="single-signal trials (kill -9, SIGTERM, SIGINT, SIGHUP in turn; default 21, quick 4)")
    ap.add_argument("--filter", default=None, help="only inputs whose family or name contains this")
    ap.add_argument("--no-process", action="store_true", help="skip the process-fault trials")
    ap.add_argument("--json", default=None, help="also write every result to this JSON file")
    ap.add_argument("--keep", action="store_true", help="keep the work directory")
    return ap


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    t0 = time.monotonic()
    rng = random.Random(args.seed)
    root = Path(tempfile.mkdtemp(prefix="rig-adversarial-"))
    try:
        ws = Workspace(root)
        print(f"clean session {ws.session.name} ({time.monotonic() - t0:.0f} s); generating inputs", file=sys.stderr)
        cases = input_cases(ws, rng, args.quick)
        if args.quick:
            cases = quick_sample(cases, args.seed)
        if args.filter:
            cases = [c for c in cases if args.filter.lower() in (c.family + " " + c.name).lower()]
        print(f"{len(cases)} inputs, {args.jobs} at a time", file=sys.stderr)
        inputs = run_inputs(cases, args.jobs, t0)
        process = [] if args.no_process else run_process_trials(root, ws, args)
        report.print_report(inputs, process, time.monotonic() - t0)
        if args.json:
            report.write_json(args.json, inputs + process)
        return 1 if report.failures(inputs + process) else 0
    finally:
        if args.keep:
            print(f"work directory kept: {root}", file=sys.stderr)
        else:
            shutil.rmtree(root, ignore_errors=True)
