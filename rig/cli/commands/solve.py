"""``rig solve SESSION``: (re)solve a recorded session into a calibration file."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from calib.errors import CalibError
from calib.accel.redundancy import pair_biases
from calib.mag import MagCalibration
from rig.analysis.solve import (ABSENT_ACCEL, accelerometer_absent, magnetometer_units, refuse_misplaced_poses,
                                solve_present_sensors, static_gyro)
from rig.cli import outputs
from rig.cli.common import (EXIT_OK, HISTORY_HELP, ZRO_NOT_STORED, Stages, UsageError, format_calibration, format_magnetometer, json_default, parse_thermal,
                            present, report_warnings, warn_if_misfit)
from rig.session import load_session
from rig.workflow.conclude import conclude


def add_parser(sub) -> None:
    s = sub.add_parser("solve", help="solve a recorded session into a calibration file")
    s.add_argument("session")
    s.add_argument("-o", "--output", default=None, help="calibration file (default SESSION/calibration.yaml)")
    s.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)
    s.add_argument("--model", choices=["triangular", "full"], default=None)
    s.add_argument("--method", choices=["pinv", "flip", "combinations", "magnitude"], default=None,
                   help="magnitude: |f| = 1 g in every static step, poses not needed (imported recordings)")
    s.add_argument("--thermal", default=None, help="auto | off | ORDER")
    s.add_argument("--json", action="store_true")
    s.add_argument("--trust-poses", action="store_true",
                   help="solve on the nominal poses even when the recorded directions disagree with them beyond the "
                        "noise (sessions without a turntable); the sigmas then carry the misfit, not the pose error")
    s.add_argument("--force", action="store_true",
                   help="replace SESSION/calibration.yaml (otherwise a re-solve is written beside it)")
    s.add_argument("--no-record", action="store_true",
                   help="an exploratory re-solve: write the calibration file, record nothing in the history")
    s.add_argument("--history", default=None, metavar="PATH|URL", help=HISTORY_HELP)


#: a session longer than this many steps, or with more than this many bytes of samples, is solved with its stages
#: said on stderr as they start (docs/cli.md: a 10,000-step import solves in about 4 s, most of it reading)
LONG_STEPS = 1000
LONG_BYTES = 20 * 1024 * 1024

#: option pairs that contradict each other: (option, value, other option, value or None for any, why)
CONFLICTS = [
    ("method", "flip", "model", "full", "the flip method fits biases and scale factors only (no cross-axis terms)"),
    ("method", "magnitude", "thermal", None, "the magnitude method fits no temperature model"),
]


def run(args) -> int:
    thermal = parse_thermal(args.thermal)
    for key, value, other, other_value, why in CONFLICTS:
        given = getattr(args, other)
        if getattr(args, key) == value and given is not None and (other_value is None or given == other_value):
            raise UsageError(f"--{key} {value} cannot be combined with --{other} {given}: {why}")
    out = output(args) if args.output is not None else None  # -o: checked before the session is read
    stages = Stages("solve", args.session, long_steps=LONG_STEPS, long_bytes=LONG_BYTES)
    stages(f"reading the session ({stages.size_mb:.0f} MB of samples)")
    session = load_session(args.session)
    stages.steps(len(session.info.steps))
    if out is None:  # the default, in the session folder: checked once it is known to be a session
        out = output(args)
    report_warnings("solve", session)
    pending = [f"{s.index + 1} ({s.name})" for s in session.info.steps if s.status == "pending"]
    if pending:
        print(f"rig solve: warning: the session is incomplete ({session.info.status}); steps not recorded: "
              f"{', '.join(pending[:10])}{' ...' if len(pending) > 10 else ''}; solving what was recorded",
              file=sys.stderr)
    if accelerometer_absent(session):
        if args.output is not None:  # a file asked for that cannot be written: refused, never exit 0 without it
            raise UsageError(f"-o {args.output}: {session.path} has no accelerometer data, and a calibration file "
                             "(rig-calibration/1) holds an accelerometer section, so none can be written; "
                             f"rig solve {session.path} --json > FILE keeps its magnetometer and gyroscope")
        return solve_without_accelerometer(session, args.json)
    if not args.trust_poses:
        refuse_misplaced_poses(session, model=args.model, method=args.method, thermal=thermal)
    stages(f"solving {len(session.info.steps)} steps")
    with outputs.writing(out):  # an error writing the file names the path given
        conclusion = conclude(session, out=out.path, model=args.model, method=args.method, thermal=thermal,
                              report=False, record=not args.no_record, history=args.history)
    stages("done: calibration written and recorded")
    verdict_code = present("solve", conclusion, quiet=args.json)
    cal, path = conclusion.calibration, conclusion.calibration_path
    if args.json:  # the file's content, the acceptance verdict included when the procedure has limits
        print(json.dumps({"calibration": str(path), **cal.to_dict()}, indent=2, default=json_default))
    else:
        print(f"calibration: {path}")
        print(format_calibration(cal).replace(" uT", f" {magnetometer_units(session)}"))
        gyro = static_gyro(session)
        if gyro is not None:
            print(f"  {gyro.format_line()}{ZRO_NOT_STORED if cal.gyroscope is None else ''}")
        warn_if_misfit(cal, "solve")
        if args.method != "magnitude":
            print_redundancy(session)
    return verdict_code


def solve_without_accelerometer(session, as_json: bool) -> int:
    """A session without an accelerometer: its gyroscope and magnetometer solved alone and printed; no
    calibration file (``rig-calibration/1`` holds an accelerometer section)."""
    res = solve_present_sensors(session)
    unit = magnetometer_units(session)
    print(f"rig solve: note: {ABSENT_ACCEL}; solving the {' and '.join(n for n in ('gyroscope', 'magnetometer') if n not in res.absent)} alone; "
          "no calibration file is written (rig-calibration/1 needs an accelerometer section)", file=sys.stderr)
    for problem in res.problems:
        print(f"rig solve: {problem}", file=sys.stderr)
    if as_json:
        print(json.dumps({"calibration": None, "absent": res.absent, "gyroscope": res.gyroscope,
                          "magnetometer": res.magnetometer, "magnetometer_units": unit,
                          "gyroscope_zero_rate_dps": None if res.gyro_static is None else
                          {"bias": res.gyro_static.bias_dps, "sigma": res.gyro_static.sigma_dps,
                           "n_steps": res.gyro_static.n_steps}}, indent=2, default=json_default))
    else:
        if res.magnetometer is not None:
            print(format_magnetometer(MagCalibration.from_dict(res.magnetometer), unit))
        if res.gyro_static is not None:
            print(f"  {res.gyro_static.format_line()}")
    solved = res.magnetometer is not None or res.gyro_static is not None or res.gyroscope is not None
    if not solved:
        raise CalibError(f"{session.path}: nothing could be solved: {'; '.join(res.problems) or 'no rest intervals'}")
    return EXIT_OK


#: what rig solve may write in the session it solves (docs/cli.md, "Output paths")
OWN = ("calibration*.yaml",)


def output(args) -> outputs.Output:
    """The calibration file (``-o``, else :func:`default_output`), checked by the output policy."""
    policy = outputs.OutputPolicy(inputs=[args.session], session=args.session, follow=args.follow)
    return policy.file(args.output if args.output is not None else default_output(args), what="the calibration",
                       own=OWN, make_parents=True)


def default_output(args) -> Path:
    """SESSION/calibration.yaml, unless one is there already (written by ``rig run``): then a file
    beside it named after the options, so a re-solve never silently replaces the run's result."""
    first = Path(args.session) / "calibration.yaml"
    if args.force or not first.exists():
        return first
    tag = "-".join(str(v) for v in (args.model, args.method, args.thermal and f"thermal-{args.thermal}") if v)
    stem = f"calibration-{tag or 'resolved'}"
    beside = Path(args.session) / f"{stem}.yaml"
    k = 2
    while beside.exists():  # never silently replace an earlier re-solve either
        beside = Path(args.session) / f"{stem}-{k}.yaml"
        k += 1
    print(f"note: {first} exists (the run's calibration); writing {beside.name} beside it "
          "(use --force to replace it, or -o FILE)", file=sys.stderr)
    return beside


def print_redundancy(session) -> None:
    """The six-pose redundancy check, when the session (loaded) has two or more +/- pose pairs."""
    try:
        steps = session.step_means()
        r = pair_biases(steps)
    except (CalibError, Exception):  # noqa: BLE001 - an optional extra; the calibration is already written
        return
    print("  " + r.format_table(steps.lsb_per_g).replace("\n", "\n  "))
