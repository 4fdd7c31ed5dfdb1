"""Re-solves of one session in the history and the report (issue 33, the walkthrough on a fresh clone): an exactly
determined flip solve says so instead of ``residual 0.0 ug  chi2/dof nan``; each re-solve shows how it was
fitted and is not counted as drift (the same data), and a later session is compared like with like. The ``rig``
commands run in this process (``rig.cli.main``) on six-position sessions the simulated rig records in virtual
time (seed 3: one simulated sensor)."""

from __future__ import annotations

import contextlib
import io
import json
import re
import time

import pytest

from calib.file import calibration as calfile
from rig.cli import main

from conftest import PROCEDURES
from html_page import Page

EXACT = "exactly determined (no residual to judge the fit)"


def rig(*args) -> tuple[int, str]:
    """``rig ARGS`` in this process: (exit code, what it printed on stdout)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main([str(a) for a in args])
    return code, out.getvalue()


@pytest.fixture(scope="module")
def resolved(tmp_path_factory) -> dict:
    """A six-position session solved by the run (pinv, triangular), re-solved by flip and with the full model,
    then a second six-position session of the same sensor, all in one history: {"first", "second", "db", "key"}."""
    root = tmp_path_factory.mktemp("resolves")
    db = root / "h.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(db))
        sessions = []
        for name in ("first", "second"):
            assert rig("run", PROCEDURES / "six_position.yaml", "--seed", 3, "--time-scale", 0, "--out", root / name,
                       "--quiet")[0] == 0
            sessions.append(next((root / name).iterdir()))
            if name == "first":
                s = sessions[0]
                assert rig("solve", s, "--method", "flip", "-o", s / "calibration-flip.yaml")[0] == 0
                assert rig("solve", s, "--model", "full", "-o", s / "calibration-full.yaml")[0] == 0
        key = json.loads(rig("history", "--all", "--json")[1])["sensors"][0]["sensor_key"]
    return {"first": sessions[0], "second": sessions[1], "db": db, "key": key}


def _history(resolved, *args) -> str:
    code, out = rig("history", resolved["key"], "--all", "--wide", "--history", resolved["db"], *args)
    assert code == 0
    return out


def test_a_flip_solve_is_said_to_be_exactly_determined_in_the_history_and_the_report(resolved, tmp_path):
    out = _history(resolved)
    (flip,) = [x for x in out.splitlines() if x.startswith("  #2 ")]
    assert EXACT in flip and "chi2/dof nan" not in flip and "chi2/dof" not in flip
    assert rig("report", resolved["first"], "--calibration", resolved["first"] / "calibration-flip.yaml",
               "--history", resolved["db"], "-o", tmp_path / "r.html")[0] == 0
    page = Page((tmp_path / "r.html").read_text())
    assert EXACT in page.text("verdict") and "chi2/dof 0.00" not in page.text("verdict")
    row = next(r for r in page.rows["history-table"] if "this report" in r[0])
    assert row[-2] == EXACT  # the chi2/dof column


def test_re_solves_show_how_they_were_fitted_and_are_not_counted_as_drift(resolved):
    out = _history(resolved)
    heads = {int(m.group(1)): x for x in out.splitlines() if (m := re.match(r"  #(\d) ", x))}
    assert "triangular by pinv" in heads[1] and "diagonal by flip" in heads[2] and "full by pinv" in heads[3]
    for i in (2, 3):
        assert "re-solve of #1's session: not compared for drift" in heads[i]
    assert f"re-solves of session {resolved['first'].name} (#1): #2 diagonal by flip, #3 full by pinv" in out
    doc = json.loads(_history(resolved, "--json"))
    cals = doc["calibrations"]
    for i in (1, 2):  # the re-solves: no change against the data they share
        assert not any("change" in p for p in cals[i]["parameters"].values())


def test_the_next_session_is_compared_with_the_previous_session_fitted_the_same_way(resolved):
    """Session 2 (pinv, triangular) after session 1's three solves: compared with session 1's pinv triangular
    calibration (#1), not with its full-model re-solve (#3), which came last."""
    out = _history(resolved)
    assert "compared like with like (the previous session's calibration fitted the same way): #4 with #1" in out
    doc = json.loads(_history(resolved, "--json"))
    change = doc["calibrations"][3]["parameters"]["accel.alpha_yz"]["change"]
    assert change["compared_with"] == 1 and abs(change["z"]) < 3
    (fourth,) = [x for x in out.splitlines() if x.startswith("  #4 ")]
    assert "re-solve" not in fourth


def test_the_report_of_a_re_solve_says_it_shows_no_change(resolved, tmp_path):
    assert rig("report", resolved["first"], "--calibration", resolved["first"] / "calibration-full.yaml",
               "--history", resolved["db"], "-o", tmp_path / "r.html")[0] == 0
    page = Page((tmp_path / "r.html").read_text())
    assert f"re-solves session {resolved['first'].name} (history #1, triangular by pinv)" in page.text("parameters")
    assert not any(re.fullmatch(r"[+-]\d+\.\dσ( !)?", r[-1]) for r in page.rows["parameter-table"] if len(r) == 5)
    fits = [r[4] for r in page.rows["history-table"][1:]]
    assert fits == ["triangular by pinv", "diagonal by flip (re-solve of #1's session)",
                    "full by pinv (re-solve of #1's session)", "triangular by pinv"]


def test_the_drift_limit_of_a_re_solve_compares_with_the_previous_session_not_with_the_same_data(tmp_path,
                                                                                                 monkeypatch):
    """max_drift_sigma of `rig solve B --model full` compared with B's own run (the history's newest row), the same
    data; it now compares with the previous session's calibration (A's)."""
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    procedure = tmp_path / "six_drift.yaml"
    procedure.write_text((PROCEDURES / "six_position.yaml").read_text() + "\naccept:\n  max_drift_sigma: 5\n")
    runs = []
    for name in ("a", "b"):
        if runs:  # calibrations are stamped to the second: the two must not share one
            time.sleep(1.0 - time.time() % 1.0 + 0.01)
        assert rig("run", procedure, "--seed", 3, "--time-scale", 0, "--out", tmp_path / name, "--quiet")[0] == 0
        runs.append(next((tmp_path / name).iterdir()))
    a_created, b_created = (calfile.read(r / "calibration.yaml").created for r in runs)
    assert a_created != b_created  # the line tells which calibration it compared with by its time
    assert rig("solve", runs[1], "--model", "full", "-o", tmp_path / "full.yaml")[0] in (0, 3)
    (check,) = [c for c in calfile.read(tmp_path / "full.yaml").acceptance["limits"] if c["name"] == "max_drift_sigma"]
    assert check["line"].startswith(f"drift since {a_created}:"), check["line"]
