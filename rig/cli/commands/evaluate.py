"""``rig evaluate CALIB SESSION [--method poses|magnitude]``: roll/pitch errors in the seed paper's layout, |f| - 1;
or, pose-free, |f| - 1 g in every static step (poses not where the session says, or unknown)."""

from __future__ import annotations

import json
import math
import sys

import numpy as np

import calib
from calib.accel.placement import check_placement
from calib.file import calibration as calfile
from rig.analysis.same_unit import calibration_units, other_unit_note
from rig.cli.common import EXIT_OK, UsageError, json_default, report_warnings
from rig.session import load_session, step_means


def add_parser(sub) -> None:
    e = sub.add_parser("evaluate", help="evaluate a calibration against a session's poses")
    e.add_argument("calibration")
    e.add_argument("session")
    e.add_argument("--json", action="store_true")
    e.add_argument("--method", choices=["poses", "magnitude"], default="poses",
                   help="poses: errors against the nominal poses (default); magnitude: |f| - 1 g in every static "
                        "step, no poses needed (hand-placed or unknown poses)")


def note_other_unit(command: str, cal, calibration_path, session) -> None:
    """One note on stderr when the calibration is of another unit than the session recorded (the evidence
    ``rig compare`` uses, :mod:`rig.analysis.same_unit`); the command goes on, its exit code unchanged."""
    note = other_unit_note(calibration_units(cal, calibration_path, session.info.to_dict(), session.path),
                           calibration_path)
    if note is not None:
        print(f"rig {command}: {note}", file=sys.stderr)


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


#: beyond this |f| - 1 g at rest the calibration is not of this session's data (another sensor, range or file), g
MAX_NORM_ERROR_G = 0.1


def check_calibration_fits(accel, session, calibration_path) -> None:
    """A calibration evaluates only data it describes: with it, the sensor at rest reads 1 g. Counts scaled by
    another range or another sensor's read far from that in every static step, whatever the poses say (the
    angle errors alone would look like a placement)."""
    steps = step_means(session, session.static_step_indices(unknown_pose=True))
    if not len(steps.names):
        return
    f = accel.apply(steps.mean_counts, temp_c=steps.temp_c if accel.temperature is not None else None, t_s=steps.t_s)
    norm = np.linalg.norm(f, axis=1)
    if np.median(np.abs(norm - 1.0)) > MAX_NORM_ERROR_G:
        raise UsageError(f"{session.path}: with {calibration_path} the sensor at rest reads {np.median(norm):.3g} g "
                         f"(median of {len(norm)} static steps; 1 g expected): the calibration does not describe these "
                         "counts (another sensor, range or scale, or edited data)")


def run(args) -> int:
    cal = calfile.read(args.calibration)
    session = load_session(args.session)
    report_warnings("evaluate", session)
    check_same_sensor(cal, session, args.calibration)
    check_calibration_fits(cal.accelerometer, session, args.calibration)
    note_other_unit("evaluate", cal, args.calibration, session)
    if args.method == "magnitude":
        return evaluate_magnitude(cal.accelerometer, session, args.json)
    steps = session.step_means()
    ev = calib.evaluate(cal.accelerometer, steps)
    found = check_placement(cal.accelerometer, steps)
    if args.json:
        print(json.dumps(ev.to_dict(), indent=2, default=json_default))  # the contract as it was; the note on stderr
    else:
        print(ev.format_table())
    if found.beyond.any() and session.info.rig.turntable is None:  # poses placed without a turntable
        print(f"rig evaluate: note: the angle errors of {found.per_step(6)} are beyond the noise "
              f"({float(np.median(found.noise_deg)):.3f} deg): the poses may not be where the session says, and then "
              f"these errors measure the placement, not the calibration: rig evaluate {args.calibration} "
              f"{args.session} --method magnitude", file=sys.stderr)
    return EXIT_OK


def evaluate_magnitude(accel, session, as_json: bool) -> int:
    """|f| - 1 g of the calibrated mean of every static step (known or unknown pose), with its 1-sigma."""
    steps = step_means(session, session.static_step_indices(unknown_pose=True))
    f = accel.apply(steps.mean_counts, temp_c=steps.temp_c if accel.temperature is not None else None,
                    t_s=steps.t_s)
    norm = np.linalg.norm(f, axis=1)
    unit = f / norm[:, None]
    sem_g = steps.sem_counts @ np.abs(np.linalg.inv(np.asarray(accel.matrix_counts_per_g, float))).T
    sigma = np.sqrt(np.sum((unit * sem_g) ** 2, axis=1))
    err = norm - 1.0
    rms = float(np.sqrt(np.mean(err**2)))
    if as_json:
        print(json.dumps({"method": "magnitude", "norm_error_rms_g": rms, "steps": [
            {"name": str(n), "norm_error_g": float(e), "sigma_g": float(s)}
            for n, e, s in zip(steps.names, err, sigma)]}, indent=2, default=json_default))
        return EXIT_OK
    print(f"{'step':<24} {'|f| - 1 (ug)':>13} {'sigma (ug)':>11}")  # ug, as every residual rig prints
    for n, e, s in zip(steps.names, err, sigma):
        print(f"{str(n)[:24]:<24} {e * 1e6:>+13.1f} {s * 1e6:>11.1f}")
    print(f"{len(err)} static steps, |f| - 1 rms {rms * 1e6:.1f} ug (pose-free: the poses are not used)")
    return EXIT_OK
