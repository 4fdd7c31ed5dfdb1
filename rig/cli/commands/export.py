"""``rig export CALIB --to px4|ardupilot|imucal|json [-o FILE] [--follow]``: a calibration in another tool's format
(docs/exports.md)."""

from __future__ import annotations

import sys

from calib.file import calibration as calfile
from rig.cli import outputs
from rig.cli.common import EXIT_OK
from rig.lab import TARGETS, export_calibration
from rig.lab.export_noise import NOISE_TARGETS, export_profile, noise_summary, read_profile_json


def add_parser(sub) -> None:
    s = sub.add_parser("export", help="export a calibration file to PX4, ArduPilot, imucal or plain JSON")
    s.add_argument("calibration", metavar="CALIB", help="a calibration file, or a unit's noise profile (rig-noise/1 "
                                                         "JSON: exported --to kalibr or json)")
    s.add_argument("--to", required=True, choices=TARGETS + tuple(t for t in NOISE_TARGETS if t not in TARGETS),
                   help="target format")
    s.add_argument("-o", "--output", default=outputs.STDOUT, help="file to write (default -: stdout)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    out = outputs.OutputPolicy(inputs=[args.calibration], follow=args.follow).file(
        args.output, what="the export", stdout=True)
    profile = read_profile_json(args.calibration)
    if profile is not None:
        exp = export_profile(profile, args.to)
        summary = noise_summary(exp)
    else:
        exp = export_calibration(calfile.read(args.calibration), args.to)
        summary = exp.summary()
    outputs.write(out, exp.text)
    if out.stdout:
        print(summary, file=sys.stderr)
        return EXIT_OK
    print(f"export: {args.output}")
    print(summary)
    return EXIT_OK
