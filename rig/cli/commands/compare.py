"""``rig compare SESSION_A SESSION_B``: two sessions of the same procedure, step by step and axis by axis
(measured vs re-simulated twin, before vs after, sensor A vs sensor B); docs/twin.md."""

from __future__ import annotations

import json

from rig.analysis import compare as cmp
from calib.numerics.design import MISFIT_LEVEL
from rig.cli.common import EXIT_OK, check_false_alarm, json_default, report_warnings


def add_parser(sub) -> None:
    c = sub.add_parser("compare", help="compare two sessions of the same procedure step by step; say where they "
                                       "disagree beyond the noise")
    c.add_argument("session_a")
    c.add_argument("session_b")
    c.add_argument("--json", action="store_true", help="print the rig-compare/2 JSON instead of the report")
    c.add_argument("--details", action="store_true",
                   help="after the verdict, the statistics: every step's difference and z, chi2, where they disagree")
    c.add_argument("--calibrated", action="store_true",
                   help="compare specific force calibrated by each session's own calibration.yaml "
                        "(default: raw counts, which needs the same sensor model and range)")
    c.add_argument("--false-alarm", type=float, default=MISFIT_LEVEL,
                   help="probability of calling two sessions of the same sensor different (default 0.01)")


def run(args) -> int:
    check_false_alarm(args.false_alarm)
    c = cmp.compare_sessions(args.session_a, args.session_b, false_alarm=args.false_alarm,
                             calibrated=args.calibrated)
    for s in (c.a.session, c.b.session):
        report_warnings("compare", s)
    if args.json:
        print(json.dumps(c.to_json(), indent=2, default=json_default))
    else:
        print(cmp.format_report(c, details=args.details))
    return EXIT_OK
