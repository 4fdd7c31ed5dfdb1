"""Attack class: signals. ``rig run procedures/six_position.yaml --time-scale 4`` is signalled in the middle of a
step (kill -9, SIGTERM, SIGINT, SIGHUP, and three SIGINTs within 0.1 s), then ``rig run --resume DIR``: every
step recorded exactly once, every step committed before the signal unchanged, the session complete and its
calibration within 5 sigma of an uninterrupted run of the same simulated sensor.

A trial signals only once the session is mid-step (session.yaml written and a step running: the last step event
of events.jsonl is not its capture), after a chosen time into a chosen step. A run that ended before that
moment, or never reached it, could not be signalled: the trial is ``not tried``, never counted as handled.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path

from . import runner
from .runner import SIX, Case, first_line, start_run
from .workspace import check_session, read_state

FAMILY = "process"
#: how long a run may take to reach the chosen step before the trial gives up (not tried)
REACH_TIMEOUT_S = 180.0


def running_step(d: Path) -> int | None:
    """The index of the step in progress in session folder ``d``: session.yaml exists and the last event that
    names a step is not that step's capture; None otherwise (before the first step, between two, after the last)."""
    if not (d / "session.yaml").exists():
        return None
    try:
        lines = (d / "events.jsonl").read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    for line in reversed(lines):
        try:
            event = json.loads(line)
        except ValueError:
            continue  # the line being written
        if isinstance(event, dict) and "step" in event:
            return None if event.get("kind") == "capture" else int(event["step"])
    return None


def wait_mid_step(p: subprocess.Popen, out: Path, step: int | None, into_s: float) -> tuple[Path | None, str]:
    """Wait until the run ``p`` (recording into ``out``) is ``into_s`` seconds into step index ``step`` (None: the
    first step that runs) and still mid-step; (session folder, "") then, or (None, why not) when the run ended or
    never got there."""
    deadline = time.monotonic() + REACH_TIMEOUT_S
    seen_at = None
    while time.monotonic() < deadline:
        if p.poll() is not None:
            return None, f"the run ended (exit {p.returncode}) before it could be signalled"
        dirs = [d for d in out.iterdir() if d.is_dir()] if out.is_dir() else []
        now = running_step(dirs[0]) if dirs else None
        if seen_at is None and now is not None and (step is None or now >= step):
            seen_at = time.monotonic()
        if seen_at is not None and time.monotonic() - seen_at >= into_s and now is not None:
            return dirs[0], ""
        time.sleep(0.02)
    return None, f"the run did not reach step {'?' if step is None else step + 1} within {REACH_TIMEOUT_S:.0f} s"


def signal_trial(root: Path, k: int, sig: signal.Signals, ref: dict, *, step: int | None = None,
                 into_s: float = 0.0, count: int = 1, within_s: float = 0.0, procedure: Path = SIX) -> Case:
    """Signal a run ``count`` times (spread over ``within_s``) ``into_s`` seconds into step index ``step``, then
    resume it and check the session (:func:`check_session`)."""
    out = root / f"sig{k}"
    what = sig.name if count == 1 else f"{count} x {sig.name} within {within_s:g} s"
    where = "the first step" if step is None else f"step {step + 1}"
    case = Case(FAMILY, f"{what} {into_s:.1f} s into {where}, then --resume",
                ["run", procedure, "--out", out, "--seed", runner.SEED_SENSOR, "--time-scale", "4"], "valid")
    t0 = time.monotonic()
    p = start_run(out, procedure=procedure)
    d, why = wait_mid_step(p, out, step, into_s)
    if d is None:
        p.kill()
        p.communicate()
        case.result.update(category="not tried", why=why, code=p.returncode, first="", seconds=time.monotonic() - t0)
        return case
    at = running_step(d)
    for i in range(count):
        p.send_signal(sig)
        if i + 1 < count:
            time.sleep(within_s / (count - 1))
    case.result["signalled"] = f"step {at + 1}" if at is not None else "between steps"
    try:
        _, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        case.result.update(code=None, first="did not stop within 60 s of the signal", category="timeout",
                           seconds=time.monotonic() - t0)
        return case
    code = p.returncode
    case.result.update(code=code, first=first_line(err))
    if "Traceback" in err or "internal error" in err:
        case.result["category"] = "traceback"
        return case
    expected = -signal.SIGKILL if sig == signal.SIGKILL else 1
    if sig == signal.SIGHUP and signal.getsignal(signal.SIGHUP) == signal.SIG_IGN:
        expected = 0  # the campaign runs under nohup: its runs inherit SIGHUP ignored and are left alone
    if code != expected:
        case.result.update(category="wrong exit code" if code != 0 else "silent wrong result",
                           why=f"{what} in {case.result['signalled']}: exit {code} (expected {expected})")
        return case
    before = read_state(d)
    status = before["manifest"]["status"]
    if sig != signal.SIGKILL and expected == 1 and status != "aborted":
        case.result.update(category="wrong exit code", why=f"session status {status!r} after {what}, not 'aborted'")
        return case
    if status != "complete":
        case.args = ["run", "--resume", d, "--time-scale", "0", "--quiet"]
        code, o, e, _ = runner.rig(*case.args, timeout=180)
        case.result.update(code=code, first=first_line(e))
        if code is None:
            case.result["category"] = "timeout"
            return case
        if "Traceback" in e or "internal error" in e:
            case.result["category"] = "traceback"
            return case
        if code != 0:
            case.result.update(category="wrong exit code", why="the resume failed")
            return case
    cat, why = check_session(d, before, ref)
    kept = len([s for s in before["manifest"]["steps"] if s["status"] == "complete"])
    case.result.update(category=cat, why=why or f"signalled in {case.result['signalled']}, {kept} steps kept",
                       seconds=time.monotonic() - t0)
    return case


def trials(root: Path, ref: dict, n: int, rng, quick: bool) -> list[tuple[str, object]]:
    """The signal trials to run, as (label, thunk): ``n`` single signals (kill -9, SIGTERM, SIGINT, SIGHUP in
    turn) at a seeded step and moment, and three SIGINTs within 0.1 s (one, or two in the full campaign)."""
    sigs = [signal.SIGKILL, signal.SIGTERM, signal.SIGINT, signal.SIGHUP]
    out = []
    for k in range(n):
        sig, step, into = sigs[k % len(sigs)], rng.randrange(6), rng.uniform(0.0, 2.0)
        out.append((sig.name, lambda k=k, sig=sig, step=step, into=into:
                    signal_trial(root, k, sig, ref, step=step, into_s=into)))
    for j in range(1 if quick else 2):
        step, into = rng.randrange(6), rng.uniform(0.0, 2.0)
        out.append(("3 x SIGINT", lambda j=j, step=step, into=into:
                    signal_trial(root, n + j, signal.SIGINT, ref, step=step, into_s=into, count=3, within_s=0.1)))
    return out
