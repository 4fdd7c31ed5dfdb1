"""``rig evaluate CALIB SESSION``: roll/pitch errors in the seed paper's layout, |f| - 1."""

from __future__ import annotations

import json
import math

import calib
from calib.file import calibration as calfile
from rig.cli.common import EXIT_OK, UsageError, json_default, report_warnings
from rig.session import load_session


def add_parser(sub) -> None:
    e = sub.add_parser("evaluate", help="evaluate a calibration against a session's poses")
    e.add_argument("calibration")
    e.add_argument("session")
    e.add_argument("--json", action="store_true")


def check_same_sensor(cal, session, path) -> None:
    """A calibration evaluates only sessions of its sensor model at its range (counts per g)."""
    recorded = session.info.rig.sensor
    model = getattr(cal.sensor, "model", None) if not isinstance(cal.sensor, dict) else cal.sensor.get("model")
    if model and recorded.model and model != recorded.model:
        raise UsageError(f"{path}: the calibration is of a {model}, the session recorded a {recorded.model}")
    lsb = float(cal.accelerometer.lsb_per_g)
    if not math.isclose(lsb, float(recorded.accel_lsb_per_g), rel_tol=1e-9):
        raise UsageError(f"{path}: the calibration is for {lsb:g} counts/g, the session recorded "
                         f"{float(recorded.accel_lsb_per_g):g} counts/g (another range): calibrate at that range")


def run(args) -> int:
    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    report_warnings("evaluate", session)
    check_same_sensor(cal, session, args.calibration)
    ev = calib.evaluate(cal.accelerometer, session.step_means())
    if args.json:
        print(json.dumps(ev.to_dict(), indent=2, default=json_default))
    else:
        print(ev.format_table())
    return EXIT_OK
