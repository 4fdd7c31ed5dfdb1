"""``rig ARGS`` run in this process, as the command-line tests run it: the exit code and what it printed."""

from __future__ import annotations

import contextlib
import io

from rig.cli import main


def rig_in_process(*args) -> tuple[int, str, str]:
    """``rig ARGS`` in this process (every argument turned into a string): (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()
