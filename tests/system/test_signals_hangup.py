"""Signals to a real ``rig run`` process (issue 34, item 3): a closed terminal, closed pipes, signals during start-up.

Every case needs real signals to a real process, so each runs ``python -m rig.cli run`` in a subprocess, on the
simulated rig at ``--time-scale 1`` (a step of six_position.yaml takes about 13 s: the signal lands mid-step).

- SIGHUP (an ssh drop, a closed terminal window) stops the run as Ctrl-C does: motors soft-stopped (the
  engine's interrupt path: the session's last event is the operator-interrupt abort), session ``aborted``,
  exit 1, one line whose resume command (quoted for a shell: the sessions directory has a space) resumes it.
- The same when nobody reads the output any more: stdout and stderr closed pipes (EPIPE), or the controlling
  terminal hung up (the kernel's SIGHUP, then EIO on every write): a write that fails is dropped, never a
  crash, and the exit code stays 1 (not 120, Python's code for a failed flush at exit).
- ``nohup`` (SIGHUP ignored) is the operator asking the run to outlive the terminal: it goes on.
- Signals during start-up (imports, parsing, the rig opening): one line, ``interrupted``, exit 1, never a
  traceback, however many arrive (three in 0.1 s).
"""

from __future__ import annotations

import fcntl
import json
import os
import pty
import shlex
import signal
import subprocess
import sys
import termios
import threading
import time
from pathlib import Path

import pytest
import yaml

from rig.cli import main

from conftest import PROCEDURES, REPO

SIX = str(PROCEDURES / "six_position.yaml")


def _spawn(out: Path, *extra: str, ignore: tuple[int, ...] = (), **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    env.pop("RIG_DEBUG", None)
    given = kw.pop("preexec_fn", None)

    def preexec():  # the signals as a shell starts a program, whatever this test run inherited (pytest started under
        # nohup ignores SIGHUP, and an ignored signal is inherited), ignored where asked (as nohup starts one)
        for s in (signal.SIGHUP, signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN if s in ignore else signal.SIG_DFL)
        if given is not None:
            given()
    kw["preexec_fn"] = preexec
    kw.setdefault("stdout", subprocess.PIPE)
    kw.setdefault("stderr", subprocess.PIPE)
    return subprocess.Popen([sys.executable, "-X", "faulthandler", "-m", "rig.cli", "run", SIX, "--out", str(out),
                             "--seed", "5", "--time-scale", "1", *extra], cwd=REPO, env=env, **kw)


def _finish(proc: subprocess.Popen, timeout_s: float = 20) -> tuple:
    """``proc.communicate()``; a program still running after ``timeout_s`` is made to dump where each of its threads
    is (SIGABRT: it runs with ``-X faulthandler``) and the test fails with that, not with a bare timeout."""
    try:
        return proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        _, err = proc.communicate()
        text = err if isinstance(err, str) else err.decode(errors="replace")
        raise AssertionError(f"still running after {timeout_s} s; where it was:\n{text[-6000:]}") from None


def _events(d: Path) -> list[dict]:
    return [json.loads(line) for line in (d / "events.jsonl").read_text().splitlines() if line.strip()]


def _status(d: Path) -> str:
    return yaml.safe_load((d / "session.yaml").read_text())["status"]


def _wait_mid_step(out: Path, proc: subprocess.Popen, timeout_s: float = 30) -> Path:
    """The session directory once the first step runs (the axes are zeroed, the step's settle or
    capture is under way)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for d in (out.iterdir() if out.exists() else ()):
            try:
                if sum(e["kind"] == "zero" for e in _events(d)) == 3 and _status(d) == "running":
                    time.sleep(0.4)  # into the step
                    return d
            except (OSError, ValueError, TypeError, KeyError, yaml.YAMLError):
                pass
        assert proc.poll() is None, f"the run ended before its first step (exit {proc.returncode})"
        time.sleep(0.02)
    raise AssertionError("the run did not reach its first step")


def _wait(proc: subprocess.Popen, timeout_s: float = 20) -> None:
    try:
        proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("rig run did not stop") from None


def _assert_aborted_by_the_signal_and_resumes(d: Path, resume: list[str] | None = None) -> None:
    """Session aborted through the engine's interrupt path (soft stop of every axis, then the abort),
    and ``rig run --resume`` (the printed command when given) finishes it."""
    assert _status(d) == "aborted"
    last = _events(d)[-1]
    assert last["kind"] == "abort" and last["reason"] == "RunAborted: interrupted by the operator", last
    args = (resume or ["rig", "run", "--resume", str(d)])[1:]
    assert main([*args, "--time-scale", "0", "--quiet"]) == 0
    assert _status(d) == "complete"


@pytest.mark.realtime
@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGINT], ids=lambda s: signal.Signals(s).name)
def test_sighup_stops_the_motors_marks_the_session_aborted_and_prints_a_resume_command_that_works(tmp_path, sig):
    """SIGHUP as Ctrl-C (SIGINT: the same path, here for the quoted resume command)."""
    out = tmp_path / "my sessions"  # a space: the printed command must be quoted for a shell
    proc = _spawn(out, "--quiet", text=True)
    d = _wait_mid_step(out, proc)
    proc.send_signal(sig)
    _, err = _finish(proc)
    assert proc.returncode == 1, (proc.returncode, err[-3000:])
    last = err.strip().splitlines()[-1]
    by = " (SIGHUP)" if sig == signal.SIGHUP else ""
    assert last.startswith(f"rig run: aborted: interrupted by the operator{by}; motors stopped. Resume with: "), last
    command = shlex.split(last.split("Resume with: ", 1)[1])
    assert command == ["rig", "run", "--resume", str(d)]
    _assert_aborted_by_the_signal_and_resumes(d, command)


@pytest.mark.realtime
def test_sighup_with_stdout_and_stderr_closed_pipes_still_stops_cleanly(tmp_path):
    """The reader of both pipes is gone (EPIPE on every write): progress lines written before the signal
    do not abort the run (the console falls silent), the stop is not turned into a crash by its own
    message, and the exit code is 1."""
    out = tmp_path / "s"
    proc = _spawn(out)  # not --quiet: a progress line per phase change goes to the closed stderr
    d = _wait_mid_step(out, proc)
    proc.stdout.close()
    proc.stderr.close()
    time.sleep(1.2)  # the capture starts: its progress line meets the closed pipe
    assert proc.poll() is None, "a progress line to a closed pipe stopped the run"
    proc.send_signal(signal.SIGHUP)
    _wait(proc)
    assert proc.returncode == 1
    _assert_aborted_by_the_signal_and_resumes(d)


@pytest.mark.realtime
@pytest.mark.pty
def test_a_hung_up_controlling_terminal_stops_the_run(tmp_path):
    """``rig run`` on a terminal (the live progress bar) whose other end closes, as when an ssh connection
    drops: the kernel sends SIGHUP and every later write fails with EIO."""
    out = tmp_path / "s"
    master, slave = pty.openpty()

    def controlling_terminal():  # a session of its own, the pty as its controlling terminal
        fcntl.ioctl(0, termios.TIOCSCTTY, 0)

    proc = _spawn(out, stdin=slave, stdout=slave, stderr=slave, start_new_session=True,
                  preexec_fn=controlling_terminal)
    os.close(slave)
    seen = bytearray()

    def drain():  # the terminal's reader, until it hangs up
        try:
            while chunk := os.read(master, 4096):
                seen.extend(chunk)
        except OSError:
            pass

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    try:
        d = _wait_mid_step(out, proc)
        assert b"+Z up" in seen, bytes(seen[-500:])  # the live bar was on the terminal
    finally:
        os.close(master)  # the terminal goes away: SIGHUP to its session leader, then EIO
    _wait(proc)
    assert proc.returncode == 1
    _assert_aborted_by_the_signal_and_resumes(d)


@pytest.mark.realtime
def test_under_nohup_a_hangup_does_not_stop_the_run(tmp_path):
    """SIGHUP ignored (``nohup rig run ...``) is the operator asking the run to outlive the terminal;
    Ctrl-C still stops it."""
    out = tmp_path / "s"
    proc = _spawn(out, "--quiet", ignore=(signal.SIGHUP,), text=True)
    d = _wait_mid_step(out, proc)
    proc.send_signal(signal.SIGHUP)
    time.sleep(0.5)
    assert proc.poll() is None and _status(d) == "running"
    proc.send_signal(signal.SIGINT)
    _, err = _finish(proc)
    assert proc.returncode == 1 and err.strip().splitlines()[-1].startswith("rig run: aborted"), err[-2000:]


def _catches(pid: int, sig: int) -> bool:
    """Whether the process has a handler for ``sig`` (/proc/PID/status, SigCgt)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(mask >> (sig - 1) & 1)


@pytest.mark.realtime
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP], ids=lambda s: signal.Signals(s).name)
def test_signals_during_start_up_exit_with_one_line_never_a_traceback(tmp_path, sig):
    """From rig's first line of code on (it catches SIGTERM from then: before that the interpreter imports
    ``site``, where no program can catch anything), three signals in 0.1 s at any moment of start-up (the
    imports of numpy, scipy, the simulator, the parsing, the rig opening) end it with one line,
    ``rig run: interrupted`` (or, once the run has started, the abort line), exit 1; never a traceback,
    never a death by the signal."""
    for i, delay in enumerate((0.0, 0.03, 0.1, 0.2, 0.35, 0.5, 0.7) if sig == signal.SIGINT else (0.0, 0.2, 0.5)):
        out = tmp_path / f"s{i}"
        proc = _spawn(out, "--quiet", text=True)
        deadline = time.monotonic() + 0.5  # today's code never catches it before the run: signal anyway
        while not _catches(proc.pid, signal.SIGTERM) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.001)
        time.sleep(delay)
        for _ in range(3):
            if proc.poll() is None:
                proc.send_signal(sig)
            time.sleep(0.033)
        _, err = _finish(proc)
        lines = err.strip().splitlines()
        assert "Traceback" not in err and proc.returncode == 1, (delay, proc.returncode, err[-3000:])
        assert lines and (lines[-1] == "rig run: interrupted" or lines[-1].startswith("rig run: aborted")), (delay, lines)
