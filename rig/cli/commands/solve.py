"""``rig solve SESSION``: (re)solve a recorded session into a calibration file."""

from __future__ import annotations

import json

from calib.errors import CalibError
from calib.redundancy import pair_biases
from rig.analysis.solve import solve_session
from rig.cli.common import EXIT_OK, format_calibration, json_default, parse_thermal
from rig.session.store import load_session


def add_parser(sub) -> None:
    s = sub.add_parser("solve", help="solve a recorded session into a calibration file")
    s.add_argument("session")
    s.add_argument("-o", "--output", default=None, help="calibration file (default SESSION/calibration.yaml)")
    s.add_argument("--model", choices=["triangular", "full"], default=None)
    s.add_argument("--method", choices=["pinv", "flip", "combinations", "magnitude"], default=None,
                   help="magnitude: |f| = 1 g in every static step, poses not needed (imported recordings)")
    s.add_argument("--thermal", default=None, help="auto | off | ORDER")
    s.add_argument("--json", action="store_true")


def run(args) -> int:
    thermal = parse_thermal(args.thermal)
    cal, path = solve_session(args.session, model=args.model, method=args.method, thermal=thermal,
                              out=args.output)
    if args.json:
        print(json.dumps({"calibration": str(path), **cal.to_dict()}, indent=2, default=json_default))
    else:
        print(f"calibration: {path}")
        print(format_calibration(cal))
        if args.method != "magnitude":
            print_redundancy(args.session)
    return EXIT_OK


def print_redundancy(session_dir) -> None:
    """The six-pose redundancy check, when the session has two or more +/- pose pairs."""
    try:
        steps = load_session(session_dir).step_means()
        r = pair_biases(steps)
    except (CalibError, Exception):  # noqa: BLE001 - an optional extra; the calibration is already written
        return
    print("  " + r.format_table(steps.lsb_per_g).replace("\n", "\n  "))
