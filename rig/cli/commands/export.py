"""``rig export CALIB --to px4|ardupilot|imucal|json [-o FILE] [--follow]``: a calibration in another tool's format
(docs/exports.md)."""

from __future__ import annotations

import sys

from calib.file import calibration as calfile
from rig.cli import outputs
from rig.cli.common import EXIT_OK
from rig.lab import TARGETS, export_calibration


def add_parser(sub) -> None:
    s = sub.add_parser("export", help="export a calibration file to PX4, ArduPilot, imucal or plain JSON")
    s.add_argument("calibration", metavar="CALIB")
    s.add_argument("--to", required=True, choices=TARGETS, help="target format")
    s.add_argument("-o", "--output", default=outputs.STDOUT, help="file to write (default -: stdout)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    out = outputs.OutputPolicy(inputs=[args.calibration], follow=args.follow).file(
        args.output, what="the export", stdout=True)
    cal = calfile.read(args.calibration)
    exp = export_calibration(cal, args.to)
    outputs.write(out, exp.text)
    if out.stdout:
        print(exp.summary(), file=sys.stderr)
        return EXIT_OK
    print(f"export: {args.output}")
    print(exp.summary())
    return EXIT_OK
