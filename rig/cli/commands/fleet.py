"""``rig fleet RESULTS [--by lot|rig|model|month] [--threshold Z] [--json]``: statistics across re-solved units."""

from __future__ import annotations

import dataclasses
import json

from rig.archive.fleet import GROUPS, fleet
from rig.cli.common import EXIT_OK


def add_parser(sub) -> None:
    f = sub.add_parser("fleet", help="statistics across the units of a re-solved archive: spread, units that stand out")
    f.add_argument("results", help="a rig resolve results folder")
    f.add_argument("--by", choices=list(GROUPS), default=None, help="group by lot, rig file, sensor model or month")
    f.add_argument("--threshold", type=float, default=5.0, help="robust z beyond which a unit stands out (default 5)")
    f.add_argument("--json", action="store_true")


def run(args) -> int:
    groups = fleet(args.results, by=args.by, threshold=args.threshold)
    if args.json:
        print(json.dumps({"format": "rig-fleet/1", "by": args.by, "threshold": args.threshold,
                          "groups": [dataclasses.asdict(g) for g in groups]}, indent=2))
        return EXIT_OK
    for g in groups:
        print(f"{args.by or 'fleet'} {g.group}: {g.n} units solved" + (f", {g.failed} failed" if g.failed else ""))
        for name, p in g.parameters.items():
            print(f"  {name:<8} median {p['median']:+10.2f}  spread {p['spread']:8.2f} {p['unit']} (1.4826 MAD)")
        if g.outliers:
            print(f"  standing out (|robust z| > {args.threshold:g}):")
            for o in g.outliers:
                print(f"    {o['session_id']}: {o['parameter']} {o['value']:+.2f} (z {o['z']:+.1f})")
        else:
            print(f"  no unit beyond {args.threshold:g} robust sigmas")
    return EXIT_OK
