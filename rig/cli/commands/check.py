"""``rig check RIG.yaml``: reach every controller and the sensor, one line each, move nothing (docs/cli.md)."""

from __future__ import annotations

from rig.cli.codes import EXIT_BAD_INPUT, EXIT_OK
from rig.cli.terminal import say
from rig.config.rigfile import load_rig_file
from rig.devices.bringup import CHECKS, rig_file_path
from rig.workflow import kinds  # noqa: F401 - registers the "sim" rig kind (the simulator loads when it opens)


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="open every controller and the sensor bus, read who answers; move nothing")
    p.add_argument("rig", help="rig file (docs/rig-file.md), or 'sim' for the embedded simulated rig")


def run(args) -> int:
    rig_file = load_rig_file(rig_file_path(args.rig), sim_hint="'rig check sim'")
    checks = CHECKS[rig_file.kind](rig_file)
    for check in checks:
        print(f"{'ok  ' if check.ok else 'FAIL'}  {check.line}", flush=True)
    failed = [c.part for c in checks if not c.ok]
    if failed:
        say(f"rig check: {rig_file.path}: {len(failed)} of {len(checks)} parts failed ({', '.join(failed)}); "
            "nothing moved")
        return EXIT_BAD_INPUT
    print(f"all {len(checks)} parts answer ({', '.join(c.part for c in checks)}); nothing moved")
    return EXIT_OK
