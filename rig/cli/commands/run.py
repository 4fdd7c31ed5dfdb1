"""``rig run PROCEDURE [--rig sim|RIG.yaml] [--seed N] [--resume DIR]``: run, record, solve."""

from __future__ import annotations

import argparse

import math
import shlex
import signal
import sys

from rig.cli.common import (EXIT_FAILURE, EXIT_OK, EXIT_REJECTED, HISTORY_HELP, ZRO_NOT_STORED, UsageError, format_calibration, present,
                            warn_if_misfit)
from rig.analysis.solve import static_gyro
from rig.cli.console import ConsoleUI
from rig.cli.terminal import say, say_raw
from rig.execution.context import RunAborted
from rig.session import SessionManifest
from rig.workflow.batch import GOOD_OUTCOMES, BatchResult, format_batch_table
from rig.workflow.run import run_procedure


def add_parser(sub) -> None:
    r = sub.add_parser("run", help="run a procedure and record a session")
    r.add_argument("procedure", nargs="?", help="procedure YAML (omit with --resume)")
    r.add_argument("--rig", default=None, help="'sim' (default) or a rig file")
    r.add_argument("--out", default="sessions", help="sessions directory (default: sessions/)")
    r.add_argument("--seed", type=int, default=None, help="simulated rig: seed of the hidden sensor parameters")
    r.add_argument("--resume", metavar="DIR", default=None, help="continue an interrupted session, or a fixture batch (its directory)")
    r.add_argument("--time-scale", type=float, default=None,
                   help="simulated rig: clock speed-up (0 = virtual time, as fast as possible)")
    r.add_argument("--strict", action="store_true",
                   help="simulated rig: keep the time scale even when this machine falls behind (samples are "
                        "then lost, as on hardware); default: simulated time waits for the reader")
    r.add_argument("--yes", action="store_true", help="confirm every operator prompt")
    r.add_argument("--quiet", action="store_true", help="print only warnings and the result")
    r.add_argument("--slots", type=_slot_list, default=None, metavar="N,N,...",
                   help="a fixture rig: run only these slots (a re-test of some units; docs/fixture.md)")
    r.add_argument("--history", default=None, metavar="PATH|URL",
                   help=HISTORY_HELP)


def run(args) -> int:
    stop = stop_on_signals()  # first: from here on a signal stops the run, whatever it is doing
    try:
        _check_options(args)
        return _run_and_report(args, stop)
    finally:
        stop.restore()


def _check_options(args) -> None:
    if args.procedure is None and args.resume is None:
        raise UsageError("give a procedure file, or --resume DIR")
    if args.procedure is not None and args.resume is not None:
        raise UsageError("give a procedure file or --resume DIR, not both (a resume runs the session's own "
                         "procedure)")
    if args.seed is not None and not 0 <= args.seed < 2**32:
        raise UsageError(f"--seed: expected an integer from 0 to {2**32 - 1}, got {args.seed}")
    if args.time_scale is not None and not (math.isfinite(args.time_scale) and 0 <= args.time_scale <= 1000):
        raise UsageError(f"--time-scale: expected 0 (virtual time) or a speed-up from 0 to 1000, got {args.time_scale:g}")


def _run_and_report(args, stop: SignalStop) -> int:
    ui = ConsoleUI(assume_yes=args.yes, quiet=args.quiet)
    try:
        result = run_procedure(args.procedure, rig_spec=args.rig, out_dir=args.out, seed=args.seed,
                               resume_dir=args.resume, ui=ui, time_scale=args.time_scale,
                               clock="strict" if args.strict else None, slots=args.slots, history=args.history)
    except RunAborted as exc:
        ui.close()
        where = getattr(exc, "session_dir", None)
        resume = f"rig run --resume {shlex.quote(str(where))}" if where is not None else "rig run --resume <session dir>"
        by = f" ({signal.Signals(stop.signum).name})" if stop.signum not in (None, signal.SIGINT) else ""
        say(f"rig run: aborted: {exc}{by}; motors stopped. Resume with: {resume}")  # a closed terminal: no line, same exit
        return EXIT_FAILURE
    except BaseException:
        ui.close()
        raise
    ui.close(finished=True)
    out = sys.stdout  # the results; nobody reading them (a closed pipe, a hung-up terminal) does not change the exit code
    if isinstance(result, BatchResult):  # a fixture: the table of units, each slot its own session (docs/fixture.md)
        say(format_batch_table(result.slots, result.batch_dir), out)
        say(f"batch record: {result.record_path}", out)
        if result.report_path is not None:
            say(f"batch report: {result.report_path}", out)
        if result.report_warning:
            print(f"rig run: warning: {result.report_warning}", file=sys.stderr)
        return EXIT_OK if all(s.outcome in GOOD_OUTCOMES for s in result.slots) else EXIT_REJECTED
    say(f"session: {result.session_dir}", out)
    recorded = (result.conclusion.session.info if result.conclusion is not None  # the whole session, across resumes
                else SessionManifest.load(result.session_dir)[0])
    flagged = [s for s in recorded.steps if s.status == "flagged"]
    if flagged:
        say("flagged steps (left out of the solve): " + "; ".join(
            f"{s.index + 1} ({s.name}: {'; '.join(map(str, (s.stats.problems if s.stats else None) or ['bad data']))})"
            for s in flagged), out)
    if result.conclusion is None:
        nxt = next_without_solve(recorded, result.session_dir)
        if nxt:
            say(f"next: {nxt}", out)
        return EXIT_OK
    say(f"calibration: {result.calibration_path}", out)
    say(format_calibration(result.calibration), out)
    gyro = static_gyro(result.conclusion.session)  # as rig solve prints it: the gyroscope's zero-rate output
    if gyro is not None:
        say(f"  {gyro.format_line()}{ZRO_NOT_STORED if result.calibration.gyroscope is None else ''}", out)
    warn_if_misfit(result.calibration, "run")
    return present("run", result.conclusion)


def _slot_list(text: str) -> list[int]:
    """``--slots 2,5``: slot numbers (argparse says the option and the text when one is not a number)."""
    try:
        return sorted({int(x) for x in text.split(",") if x.strip()})
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected slot numbers separated by commas (2,5), got {text!r}") from None


def next_without_solve(recorded, session_dir) -> str | None:
    """What to run on a session its procedure does not solve: a reversal (steps in two or more mountings) is
    characterised (``rig characterize-rig``); a long static capture is characterised for its noise (``rig
    characterize``); anything else is solved (``rig solve``)."""
    where = shlex.quote(str(session_dir))
    mounts = {tuple(map(tuple, s.mount.turn)) if getattr(s, "mount", None) is not None and getattr(s.mount, "turn", None)
              is not None else None for s in recorded.steps}
    if len(mounts - {None}) >= 2:
        return f"rig characterize-rig {where} (the turntable's own errors by reversal)"
    static = [s for s in recorded.steps if s.kind == "static"]
    if len(static) == 1:
        return f"rig characterize {where} (the sensor's noise terms)"
    return f"rig solve {where}" if static else None


class SignalStop:
    """The signals that stop a run, while it runs (:func:`stop_on_signals`): ``signum`` is the one
    that stopped it (None while none has)."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.previous: dict[int, object] = {}

    def interrupt(self, signum, frame) -> None:
        if self.signum is not None:
            say_raw("rig run: stopping the motors and closing the session; please wait")
            return
        self.signum = signum
        raise KeyboardInterrupt

    def restore(self) -> None:
        """The run is over: the previous handlers are back, unless a signal stopped the run; then the
        program is exiting on its behalf and further ones are ignored (Python drops its own handlers
        while it exits, and a Ctrl-C then would kill it without its exit code)."""
        for sig, handler in self.previous.items():
            signal.signal(sig, signal.SIG_IGN if self.signum is not None
                          else signal.SIG_DFL if handler is None else handler)


def stop_on_signals() -> SignalStop:
    """Ctrl-C (SIGINT), SIGTERM and SIGHUP (a closed terminal, a dropped ssh connection) stop the motors
    and abort the run, even when the shell that started us ignores SIGINT (a background job does): the
    turntable must stop whoever asks. SIGHUP stays ignored when it was (``nohup rig run ...``: the
    operator asked the run to outlive the terminal). Further signals while the run is stopping only say
    "please wait" (straight to the descriptor: a buffered write in a handler can break the one it
    interrupts, and a closed terminal must not matter); they never cut the cleanup short (motors,
    session status).

    Returns the :class:`SignalStop`; call its ``restore`` once the run is over."""
    stop = SignalStop()
    signals = [signal.SIGINT, signal.SIGTERM]
    if signal.getsignal(signal.SIGHUP) != signal.SIG_IGN:
        signals.append(signal.SIGHUP)
    for sig in signals:
        stop.previous[sig] = signal.getsignal(sig)
        signal.signal(sig, stop.interrupt)
    return stop
