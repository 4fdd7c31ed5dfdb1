"""The campaign's report: the tally by category (inputs, process trials), by family, every failure (input,
command, exit code, first stderr line) and every attack not tried; and the JSON of every result."""

from __future__ import annotations

import json
from pathlib import Path

from .runner import CATEGORIES, NOT_FAILED, Case

LABELS = {"correct": "handled correctly", "traceback": "tracebacks", "wrong exit code": "wrong exit codes",
          "silent wrong result": "silent wrong results", "bad message": "bad messages (lines/naming)",
          "timeout": "timeouts (hangs, bombs)", "data lost": "data lost", "not tried": "not tried (could not attack)"}


def tally(cases: list[Case]) -> dict:
    t = {c: 0 for c in CATEGORIES}
    for c in cases:
        t[c.result["category"]] += 1
    return t


def failures(cases: list[Case]) -> list[Case]:
    return [c for c in cases if c.result["category"] not in NOT_FAILED]


def print_report(inputs: list[Case], process: list[Case], seconds: float) -> None:
    ti, tp = tally(inputs), tally(process)
    print("\n=== adversarial campaign ===")
    print(f"{'':28s} {'inputs':>7s} {'process':>8s} {'total':>7s}")
    print(f"{'tried':28s} {len(inputs):7d} {len(process):8d} {len(inputs) + len(process):7d}")
    for c in CATEGORIES:
        print(f"{LABELS[c]:28s} {ti[c]:7d} {tp[c]:8d} {ti[c] + tp[c]:7d}")
    fams: dict[str, list[Case]] = {}
    for c in inputs + process:
        fams.setdefault(c.family, []).append(c)
    print("\nby family:")
    for fam, cs in fams.items():
        ok = sum(c.result["category"] == "correct" for c in cs)
        skipped = sum(c.result["category"] == "not tried" for c in cs)
        print(f"  {fam:24s} {ok:4d}/{len(cs):<4d} correct" + (f", {skipped} not tried" if skipped else ""))
    fails = failures(inputs + process)
    print(f"\nfailures ({len(fails)}):")
    for c in sorted(fails, key=lambda c: (c.result["category"], c.family, c.name)):
        _print_case(c)
    skipped = [c for c in inputs + process if c.result["category"] == "not tried"]
    if skipped:
        print(f"\nnot tried ({len(skipped)}):")
        for c in sorted(skipped, key=lambda c: (c.family, c.name)):
            print(f"- {c.family}: {c.name} ({c.result.get('why', '')})")
    print(f"\nrun time: {seconds:.0f} s")


def _print_case(c: Case) -> None:
    why = f" ({c.result['why']})" if c.result.get("why") else ""
    print(f"- [{c.result['category']}] {c.family}: {c.name}{why}\n    $ {c.command()}\n"
          f"    exit {c.result.get('code')}: {c.result.get('first', '')}")


def write_json(path, cases: list[Case]) -> None:
    Path(path).write_text(json.dumps([{"family": c.family, "name": c.name, "command": c.command(),
                                       "expect": c.expect, **c.result} for c in cases], indent=1, default=str))
