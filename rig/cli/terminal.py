"""Writing to a terminal that may be gone: what ``rig`` does (the motors, the session, the history)
never depends on its text being read (docs/faults.md). Standard library only: :mod:`rig.cli.main`
imports this before its start-up signal handlers, and ``rig run`` uses it while it stops."""

from __future__ import annotations

import os
import sys


def say_raw(line: str) -> None:
    """One line straight to file descriptor 2, bypassing Python's buffered stderr: safe in a signal
    handler (a buffered write there may interrupt one in progress: "reentrant call"); never fails."""
    try:
        os.write(2, (line + "\n").encode(errors="replace"))
    except OSError:
        pass


def say(line: str, stream=None) -> None:
    """Print one line (to stderr by default) that cannot fail: when the terminal or the pipe is gone
    (EIO, EPIPE, ...) the stream is silenced and the line dropped. What ``rig`` does (the motors, the
    session) never depends on its text being read."""
    stream = sys.stderr if stream is None else stream
    try:
        print(line, file=stream, flush=True)
    except OSError:
        silence(stream)


def silence(stream) -> None:
    """From now on ``stream`` writes to /dev/null: its descriptor is replaced, so what it still buffers
    and everything written later (the interpreter's flush at exit included) succeeds and goes nowhere,
    instead of failing again (a failed flush at exit would make the exit code 120)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, stream.fileno())
        finally:
            os.close(devnull)
        stream.flush()
    except (OSError, ValueError, AttributeError):  # no descriptor (a test's capture): nothing to silence
        pass
