"""A fast subset of the adversarial campaign (`benchmarks/adversarial/`, run by `benchmarks/bench_adversarial.py`)
as a regression test.

Forty-one representative bad (and valid-but-odd) inputs across procedures, rig files, sessions, calibration
files, imports, options, output paths, names and damaged discover documents, each classified exactly as the
campaign does (exit 2 with one stderr line naming the input, no traceback, no silent wrong number; exit 0 and the
clean calibration for BOM/CRLF; exit 0 with a warning for a torn line of the step in progress), one of each class
fixed since, plus one kill -9 then
--resume trial and one concurrent-resume trial, each signalled mid-step (a trial that could not signal is "not
tried", and fails here).
Only inputs the campaign handles correctly today are listed; the rest are in the campaign's report.

The campaign runs each input as ``python -m rig.cli ...``; here the inputs, the clean session and the
resumes and solves after a signal run in this process (``rig.cli.main``, as the campaign's subprocess
would: its environment, no standard input, warnings shown as ``PYTHONWARNINGS=default`` shows them in a
fresh interpreter, the campaign's time limit): an interpreter start and the numeric imports per input
cost more than the inputs themselves (issue 26). What only a separate process shows stays one: the
run killed with SIGKILL and the two concurrent resumes (a lock held by another process).
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import signal
import sys
import threading
import time
import traceback
import warnings

import pytest

from rig.cli import main

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from adversarial import campaign, concurrency, runner, signals  # the campaign's package, by path
from adversarial.workspace import Workspace

#: (family, case name) of the campaign's inputs
SMOKE = [
    ("procedure", "billion-laughs alias bomb"),
    ("procedure", "python object tag"),
    ("procedure", "duplicate key dwell"),
    ("procedure", "binary garbage"),
    ("procedure", "settle.window_s = 60"),
    ("procedure", "sensor.model = \"ADXL345\""),
    ("rig file", "faults.ximc.a1.crc_corrupt_rate = 1.5"),
    ("rig file", "turntable.axes.a1.speed_deg_s = 100"),
    ("samples.csv", "step index 1.5 [evaluate]"),
    ("samples.csv", "NaN count in ax [solve]"),
    ("samples.csv", "BOM and CRLF [solve]"),
    ("session.yaml", "format rig-session/2 [solve]"),
    ("calibration", "CRLF line endings [apply]"),
    ("calibration", "bias a word [evaluate]"),
    ("import", "imucal: x_p rows read -1 g (mislabelled part)"),
    ("import", "csv: decreasing time stamps"),
    ("option", "--seed -1"),
    ("option", "--time-scale nan"),
    ("option", "sim --count 0"),
    ("option", "bare rig"),
    ("option", "solve --model full --method flip"),
    # one per class fixed after the campaign's 534/553 run
    ("rig file", 'name = ""'),
    ("rig file", "faults.sensor.oserror_rate = a list of words"),
    ("rig file", "sim.errors.bias_g = [0.1, 0.2]"),
    ("option", "solve --thermal 1 on a 0.0 C span"),
    ("samples.csv", "ax and ay data swapped (header unchanged) [evaluate]"),
    ("session.yaml", "accel_range_g 3 [solve]"),
    ("session.yaml", "f_nominal 5 g [apply]"),
    ("session.yaml", "accel_lsb_per_g 1e300 [replay]"),
    ("session.yaml", "procedure.text a bomb [replay]"),
    ("session dir", "session directory a symlink loop [solve]"),
    ("calibration", "symlink loop [apply]"),
    ("import", "csv: a symlink loop"),
    ("samples.csv", "torn last line inside a finished step (rows lost) [solve]"),
    ("samples.csv", "torn last line in the step in progress (aborted session) [solve]"),
    # one of each attack class added with the package (issue 34 item 9)
    ("procedure", "dwell.seconds = 1.0e9 (exponent form)"),
    ("output path", "solve -o: a FIFO nobody reads"),
    ("output path", "export -o: a symbolic link to a file elsewhere"),
    ("output path", "its own input: apply -o its calibration"),
    ("names", "step names with $ and backticks: rig run (report: true)"),
    ("discover.json", "truncated [report]"),
]


class _TimedOut(BaseException):
    """The campaign's time limit for one input ran out (a hang or a bomb)."""


@contextlib.contextmanager
def _time_limit(seconds: float, on_expiry):
    """Interrupt the command after ``seconds`` (the campaign kills its subprocess then): ``on_expiry()`` is
    called, then ``_TimedOut`` raised in the command. Main thread only (elsewhere: no limit)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum, frame):
        on_expiry()
        raise _TimedOut(f"no answer within {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def _as_the_campaigns_subprocess():
    """The campaign's subprocess conditions in this process: its environment (``runner.rig_env``: its own
    history, no RIG_DEBUG), its working directory, no standard input, and warnings filtered as
    ``PYTHONWARNINGS=default`` filters them in a fresh interpreter (changing the filters resets every
    module's record of warnings already shown, so each input starts as a fresh process would)."""
    env = runner.rig_env()
    saved = {k: os.environ.get(k) for k in ("RIG_HISTORY", "RIG_DEBUG")}
    cwd, stdin = os.getcwd(), sys.stdin
    try:
        os.environ["RIG_HISTORY"] = env["RIG_HISTORY"]
        os.environ.pop("RIG_DEBUG", None)
        os.chdir(REPO)
        with open(os.devnull) as devnull, warnings.catch_warnings():
            sys.stdin = devnull
            warnings.resetwarnings()
            warnings.simplefilter("default")
            yield
    finally:
        sys.stdin = stdin
        os.chdir(cwd)
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def rig_in_process(*args, timeout: float = runner.TIMEOUT_S, stdin=None):
    """``runner.rig`` in this process: (exit code or None when the time limit ran out, stdout, stderr, s).
    An exception that escapes ``main`` is printed as the interpreter would print it (a traceback); a
    command stopped by the time limit keeps the output it had written by then, as a killed process does."""
    out, err = io.StringIO(), io.StringIO()
    cut: list[tuple[int, int]] = []
    t0 = time.monotonic()
    with _as_the_campaigns_subprocess(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            with _time_limit(timeout, lambda: cut.append((out.tell(), err.tell()))):
                code = main([str(a) for a in args])
        except BaseException:  # noqa: BLE001 - what `python -m rig.cli` would die of
            traceback.print_exc(file=err)
            code = 1
    if cut:
        return None, out.getvalue()[:cut[0][0]], err.getvalue()[:cut[0][1]], time.monotonic() - t0
    return code, out.getvalue(), err.getvalue(), time.monotonic() - t0


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """The campaign's workspace (a clean six-position session and its calibration); every ``rig`` command of
    the campaign's code runs in this process (``runner.rig`` replaced for this module), except the runs it
    starts itself with ``runner.start_run`` to signal or to race (subprocesses, as they must be)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runner, "rig", rig_in_process)
        yield Workspace(tmp_path_factory.mktemp("adversarial"))


def _all_cases(ws):
    return campaign.input_cases(ws, random.Random(0), False)


def test_representative_bad_inputs_are_refused_with_one_line(ws):
    by_key = {}
    for c in _all_cases(ws):
        by_key.setdefault((c.family, c.name), c)
    missing = [k for k in SMOKE if k not in by_key]
    assert not missing, f"campaign cases renamed or gone: {missing}"
    results = [runner.run_case(by_key[k]) for k in SMOKE]  # in this process: one at a time
    bad = [f"{c.family}: {c.name}: {c.result['category']} {c.result.get('why', '')} (exit {c.result['code']}: "
           f"{c.result['first']}) $ {c.command()}" for c in results if c.result["category"] != "correct"]
    assert not bad, "\n".join(bad)


@pytest.mark.realtime
def test_kill_9_then_resume_keeps_every_step_exactly_once(ws, tmp_path):
    c = signals.signal_trial(tmp_path, 0, signal.SIGKILL, ws.ref, step=2, into_s=1.0)
    assert c.result["category"] == "correct", (c.result, c.command())


@pytest.mark.realtime
def test_concurrent_resumes_one_proceeds_the_other_names_the_holder(ws, tmp_path):
    # the resumes at 12x (the race is for the lock at their start; the winner's remaining steps only need finishing)
    c = concurrency.concurrent_resume_trial(tmp_path, 0, ws.ref, step=1, into_s=1.0, resume_time_scale="12")
    assert c.result["category"] == "correct", (c.result, c.command())
