"""``rig fleet RESULTS [--by lot|rig|model|month] [--threshold Z] [--json]``: statistics across re-solved units."""

from __future__ import annotations

import dataclasses
import json

from rig.archive.fleet import GROUPS, changes, fleet
from rig.cli.common import EXIT_OK


def add_parser(sub) -> None:
    f = sub.add_parser("fleet", help="statistics across the units of a re-solved archive: spread, units that stand out")
    f.add_argument("results", help="a rig resolve results folder")
    f.add_argument("--by", choices=list(GROUPS), default=None, help="group by lot, rig file, sensor model or month")
    f.add_argument("--threshold", type=float, default=None,
                   help="robust z beyond which a unit stands out (default 5); with --against, the change in combined "
                        "sigmas beyond which a session is listed (default 3)")
    f.add_argument("--json", action="store_true")
    f.add_argument("--against", default=None, metavar="OLD_RESULTS",
                   help="the change of every parameter from these results (the same archive solved before)")


def run(args) -> int:
    if args.against is not None:
        return _changes(args)
    threshold = 5.0 if args.threshold is None else args.threshold
    groups = fleet(args.results, by=args.by, threshold=threshold)
    if args.json:
        print(json.dumps({"format": "rig-fleet/1", "by": args.by, "threshold": threshold,
                          "groups": [dataclasses.asdict(g) for g in groups]}, indent=2))
        return EXIT_OK
    for g in groups:
        print(f"{args.by or 'fleet'} {g.group}: {g.n} units solved" + (f", {g.failed} failed" if g.failed else ""))
        for name, p in g.parameters.items():
            print(f"  {name:<8} median {p['median']:+10.2f}  spread {p['spread']:8.2f} {p['unit']} (1.4826 MAD)")
        if g.outliers:
            print(f"  standing out (|robust z| > {threshold:g}):")
            for o in g.outliers:
                print(f"    {o['session_id']}: {o['parameter']} {o['value']:+.2f} (z {o['z']:+.1f})")
        else:
            print(f"  no unit beyond {threshold:g} robust sigmas")
    return EXIT_OK


def _changes(args) -> int:
    """``--against OLD``: each parameter's change from the old results, in its unit and combined sigmas."""
    threshold = 3.0 if args.threshold is None else args.threshold
    found = changes(args.results, args.against, threshold)
    if args.json:
        print(json.dumps({"format": "rig-fleet-change/1", "new": args.results, "old": args.against,
                          "threshold": threshold, "changes": [dataclasses.asdict(c) for c in found]}, indent=2))
        return EXIT_OK
    print(f"change from {args.against} to {args.results} over {found[0].n} sessions solved in both "
          f"(z: the change over the two solves' combined sigma):")
    for c in found:
        print(f"  {c.parameter:<8} mean {c.mean:+10.3f} {c.unit:<8} mean z {c.mean_z:+6.2f}  largest z "
              f"{c.largest_z:+6.2f}" + (f"  {len(c.beyond)} beyond {threshold:g}" if c.beyond else ""))
    return EXIT_OK
