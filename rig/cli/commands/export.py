"""``rig export CALIB --to px4|ardupilot|imucal|json [-o FILE]``: a calibration in another tool's format (docs/exports.md)."""

from __future__ import annotations

import sys

from calib.file import calibration as calfile
from calib.file.calibration import atomic_write_text
from rig.cli.common import EXIT_OK
from rig.lab import TARGETS, export_calibration


def add_parser(sub) -> None:
    s = sub.add_parser("export", help="export a calibration file to PX4, ArduPilot, imucal or plain JSON")
    s.add_argument("calibration", metavar="CALIB")
    s.add_argument("--to", required=True, choices=TARGETS, help="target format")
    s.add_argument("-o", "--output", default=None, help="file to write (default: stdout)")


def run(args) -> int:
    cal = calfile.read(args.calibration)
    exp = export_calibration(cal, args.to)
    if args.output is None:
        sys.stdout.write(exp.text)
        print(exp.summary(), file=sys.stderr)
        return EXIT_OK
    atomic_write_text(args.output, exp.text)
    print(f"export: {args.output}")
    print(exp.summary())
    return EXIT_OK
