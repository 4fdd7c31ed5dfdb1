"""``rig jog RIG.yaml AXIS DEG``: one small confirmed move of one axis; Ctrl-C stops the motor (docs/cli.md)."""

from __future__ import annotations

import signal
import sys
from contextlib import contextmanager

from rig.cli.codes import EXIT_FAILURE, EXIT_OK
from rig.cli.terminal import say
from rig.config.rigfile import load_rig_file
from rig.devices.bringup import open_axis, rig_file_path
from rig.devices.jog import MAX_JOG_DEG, check_step, jog, plan_jog
from rig.execution.operator import OperatorAbsent
from rig.planning.kinematics import STAGE_AXES
from rig.workflow import kinds  # noqa: F401 - registers the "sim" rig kind (the simulator loads when it opens)


def add_parser(sub) -> None:
    p = sub.add_parser("jog", help="turn one axis by a few degrees (confirmed; Ctrl-C stops it)")
    p.add_argument("rig", help="rig file (docs/rig-file.md), or 'sim' for the embedded simulated rig")
    p.add_argument("axis", choices=STAGE_AXES, help="the axis to turn")
    p.add_argument("deg", type=float, help=f"kinematic degrees, at most {MAX_JOG_DEG:g} either way (e.g. 5 or -2.5)")
    p.add_argument("--yes", action="store_true", help="move without asking")


def run(args) -> int:
    check_step(args.deg)  # before anything is opened
    rig_file = load_rig_file(rig_file_path(args.rig), sim_hint=f"'rig jog sim {args.axis} {args.deg:g}'")
    config = rig_file.axes[args.axis]
    stage, close = open_axis(rig_file, args.axis)
    try:
        plan = plan_jog(args.axis, config, stage, args.deg)
        if not (args.yes or _confirmed(plan.question())):
            say("rig jog: not moved")
            return EXIT_FAILURE
        with _signals_interrupt():
            result = jog(plan, config, stage, on_start=lambda: say(f"rig jog: moving {plan.axis} by "
                                                                   f"{plan.delta_deg:+g} deg (Ctrl-C stops it)"))
    finally:
        close()
    kinematic = config.sign * (result.at_deg - config.home_offset_deg)
    where = f"{plan.axis} at {result.at_deg:.3f} deg on the controller (kinematic {kinematic:.3f} deg)"
    if result.interrupted:
        say(f"rig jog: interrupted by the operator; motor stopped: {where}")
        return EXIT_FAILURE
    print(f"moved {plan.axis} by {plan.delta_deg:+g} deg: {where}")
    return EXIT_OK


def _confirmed(question: str) -> bool:
    """The operator's answer on the terminal; OperatorAbsent (exit 2) without one."""
    if not sys.stdin.isatty():
        raise OperatorAbsent(f"{question} needs a confirmation: run it on a terminal or add --yes")
    try:
        return input(f"{question} [y/N] ").strip().lower() in ("y", "yes")
    except EOFError:
        return False


@contextmanager
def _signals_interrupt():
    """While the motor turns, SIGTERM and SIGHUP stop it as Ctrl-C does: a KeyboardInterrupt, once (more
    signals are ignored until the motor stands); SIGHUP stays ignored under nohup."""
    def interrupt(signum, frame):
        for sig in previous:
            signal.signal(sig, signal.SIG_IGN)
        raise KeyboardInterrupt

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) != signal.SIG_IGN:
            previous[sig] = signal.signal(sig, interrupt)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
