"""``rig discover SESSION``: where the model and the data disagree, and which effect is missing."""

from __future__ import annotations

import json

from rig.analysis import discover as dsc
from rig.analysis import twin as twn
from calib.numerics.design import MISFIT_LEVEL
from rig.cli.common import EXIT_OK, check_false_alarm, json_default, report_warnings


def add_parser(sub) -> None:
    dc = sub.add_parser("discover", help="find where the model and the data disagree; name the missing effect")
    dc.add_argument("session")
    dc.add_argument("--json", action="store_true", help="print the rig-discover/4 JSON (docs/discrepancy.md) instead of the report")
    dc.add_argument("--plot", metavar="FILE.png", default=None,
                    help="residuals before/after, by pose and temperature (a directory: written inside it)")
    dc.add_argument("-o", "--output", metavar="CALIB.yaml", default=None,
                    help="write the augmented calibration (effects filled in)")
    dc.add_argument("--twin", metavar="RIG.yaml", default=None,
                    help="write the digital twin: a simulated-rig file whose sensor is the fitted model plus the "
                         "named effects, and the session's procedure beside it (docs/twin.md)")
    dc.add_argument("--false-alarm", type=float, default=MISFIT_LEVEL,
                    help="probability of naming an effect in a session that has none (default 0.01)")


def run(args) -> int:
    check_false_alarm(args.false_alarm)
    session, d = dsc.discover_session(args.session, false_alarm=args.false_alarm)
    report_warnings("discover", session)
    extra = {}
    if args.plot:
        extra["plot"] = str(dsc.write_plot(d, args.plot, session_id=session.id))
    if args.output:
        extra["calibration"] = str(dsc.write_calibration(session, d, args.output))
    if args.twin:
        extra.update(twn.write_for_discovery(session, d, args.twin))
    if args.json:
        print(json.dumps({**d.to_json(), **extra}, indent=2, default=json_default))
    else:
        print(dsc.format_report(session, d))
        for k, v in extra.items():
            print(f"{k}: {v}")
    return EXIT_OK
