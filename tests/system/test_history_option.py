"""``rig run`` and ``rig solve`` record into the history ``--history`` names (a file or a database URL), not into
``$RIG_HISTORY``: a lab points one rig's commands at its shared history without changing the environment."""

from __future__ import annotations

import contextlib
import io
import os
import sqlite3

from rig.cli import main

from conftest import PROCEDURES


def _rig(*args) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, err.getvalue()


def _sessions_in(path) -> list[str]:
    if not os.path.exists(path):
        return []
    with contextlib.closing(sqlite3.connect(path)) as db:
        return [r[0] for r in db.execute("SELECT session_id FROM calibrations")]


def test_run_and_solve_record_where_history_says_and_not_in_the_environments(tmp_path):
    environment = os.environ["RIG_HISTORY"]
    before = _sessions_in(environment)
    run_history, solve_history = tmp_path / "run.sqlite", tmp_path / "lab.sqlite"
    code, err = _rig("run", PROCEDURES / "six_position.yaml", "--time-scale", "0", "--seed", "4", "--quiet",
                     "--out", tmp_path / "s", "--history", run_history)
    assert code == 0, err
    (session,) = (tmp_path / "s").iterdir()
    assert _sessions_in(run_history) == [session.name]
    code, err = _rig("solve", session, "-o", tmp_path / "again.yaml", "--history", f"sqlite:///{solve_history}")
    assert code == 0, err
    assert _sessions_in(solve_history) == [session.name]
    assert _sessions_in(environment) == before  # nothing went where the environment points
