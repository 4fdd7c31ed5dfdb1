"""``rig evaluate CALIB SESSION``: roll/pitch errors in the seed paper's layout, |f| - 1."""

from __future__ import annotations

import json

import calib
from calib import calfile
from rig.cli.common import EXIT_OK, json_default, report_warnings
from rig.session import load_session


def add_parser(sub) -> None:
    e = sub.add_parser("evaluate", help="evaluate a calibration against a session's poses")
    e.add_argument("calibration")
    e.add_argument("session")
    e.add_argument("--json", action="store_true")


def run(args) -> int:
    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    report_warnings("evaluate", session)
    ev = calib.evaluate(cal.accelerometer, session.step_means())
    if args.json:
        print(json.dumps(ev.to_dict(), indent=2, default=json_default))
    else:
        print(ev.format_table())
    return EXIT_OK
