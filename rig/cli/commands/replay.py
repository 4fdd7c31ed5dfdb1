"""``rig replay SESSION``: re-run a recorded session through the replay rig (identical calibration)."""

from __future__ import annotations

from rig.cli.common import EXIT_OK, format_calibration, present
from rig.workflow.replay import replay_session


def add_parser(sub) -> None:
    rp = sub.add_parser("replay", help="re-run a recorded session through the replay rig")
    rp.add_argument("session")
    rp.add_argument("--out", default=None, help="where the replayed session goes (default: beside the original)")


def run(args) -> int:
    result = replay_session(args.session, out_dir=args.out)
    print(f"replayed session: {result.session_dir}")
    if result.conclusion is not None:
        print(f"calibration: {result.calibration_path}")
        print(format_calibration(result.calibration))
        return present("replay", result.conclusion)
    return EXIT_OK
