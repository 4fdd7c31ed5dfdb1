"""Acceptance limits from the command line: a procedure's ``accept:`` limits are applied after the
solve, PASS or FAIL is printed with one line per failed limit, a failure exits 3 (docs/cli.md), the
verdict is written into the calibration file and recorded in the history."""

from __future__ import annotations

import json
import re
import textwrap

import pytest

from calib.file import calibration as calfile
from rig.cli import main

from conftest import PROCEDURES

SIX = (PROCEDURES / "six_position.yaml").read_text()


def _procedure(tmp_path, accept: str, name="accepted") -> str:
    text = SIX.replace("name: six_position", f"name: {name}").replace("dwell: {seconds: 10}", "dwell: {seconds: 2}")
    p = tmp_path / f"{name}.yaml"
    p.write_text(text + "accept:\n" + textwrap.indent(textwrap.dedent(accept), "  "))
    return str(p)


def _run(tmp_path, proc, seed=3, db=None):
    out = tmp_path / "sessions"
    args = ["run", proc, "--seed", str(seed), "--time-scale", "0", "--out", str(out), "--quiet"]
    return main(args), sorted(out.iterdir(), key=lambda p: p.stat().st_mtime)[-1]


def test_a_failed_limit_exits_3_names_each_failure_and_is_recorded(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    proc = _procedure(tmp_path, """\
        ranges: {accel.bias_x: [-100, 100], accel.scale_*: [8000, 8400]}
        max_chi2_per_dof: 5
    """)
    code, session = _run(tmp_path, proc)
    out = capsys.readouterr().out
    assert code == 3
    assert "acceptance: FAIL (1 of 5 limits)" in out
    assert re.search(r"^  FAIL accel\.bias_x = 39\d(\.\d)? counts: outside \[-100, 100\] counts$", out, re.M), out
    cal = calfile.read(session / "calibration.yaml")
    assert cal.acceptance["passed"] is False and len(cal.acceptance["limits"]) == 5
    assert main(["history", "sim-seed-3", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["calibrations"][-1]["verdict"] == "FAIL"


def test_limits_that_hold_pass_with_exit_0_and_drift_is_judged_against_the_previous_calibration(
        tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    proc = _procedure(tmp_path, """\
        ranges: {accel.bias_*: [-1000, 1000]}
        max_sigma: {accel.bias_*: 3}
        max_attitude_error_deg: 0.1
        max_drift_sigma: 5
    """)
    code, first = _run(tmp_path, proc)
    out = capsys.readouterr().out
    assert code == 0 and "acceptance: PASS (8 limits met)" in out
    assert "first calibration of this sensor" in calfile.read(first / "calibration.yaml").acceptance["limits"][-1]["line"]
    # the same sensor recalibrated: no drift beyond the noise
    assert _run(tmp_path, proc)[0] == 0
    second = sorted((tmp_path / "sessions").iterdir(), key=lambda p: p.stat().st_mtime)[-1]
    drift = calfile.read(second / "calibration.yaml").acceptance["limits"][-1]
    assert drift["name"] == "max_drift_sigma" and drift["passed"] and abs(drift["value"]) < 1e-9


def test_rig_solve_applies_the_recorded_limits_too(tmp_path, capsys):
    proc = _procedure(tmp_path, "ranges: {accel.bias_y: [0, 10]}\n")
    code, session = _run(tmp_path, proc)
    assert code == 3
    capsys.readouterr()
    assert main(["solve", str(session), "-o", str(tmp_path / "again.yaml")]) == 3
    out = capsys.readouterr().out
    again = calfile.read(tmp_path / "again.yaml")
    bias_y = again.accelerometer.bias_counts[1]
    assert not 0 <= bias_y <= 10
    assert "acceptance: FAIL" in out and f"accel.bias_y = {bias_y:.1f}" in out and "outside [0, 10] counts" in out
    assert again.acceptance["passed"] is False


@pytest.mark.parametrize("accept, message", [
    ("ranges: {accel.bias: [-1, 1]}\n", "accept.ranges.accel.bias: unknown parameter 'accel.bias'"),
    ("ranges: {accel.bias_x: [5, 1]}\n", "expected low < high, got [5, 1]"),
    ("ranges: {accel.bias_x: [5]}\n", "expected [low, high]"),
    ("max_chi2_per_dof: -1\n", "accept.max_chi2_per_dof: expected a number > 0"),
    ("max_sigma: {accel.bias_x: nan}\n", "accept.max_sigma.accel.bias_x: expected a number"),
    ("{}\n", "no limits given"),
    ("max_residul_g: 0.1\n", "max_residul_g"),
])
def test_bad_limits_are_refused_before_anything_moves(tmp_path, capsys, accept, message):
    proc = _procedure(tmp_path, accept)
    assert main(["run", proc, "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and f"{proc}:" in err, err
    assert not (tmp_path / "s").exists()


def test_a_misalignment_limit_is_said_in_mrad_as_the_angles_are_printed(tmp_path, capsys, monkeypatch):
    """Issue 33 item 4 (one unit per quantity): the angles print in mrad, and a failed angle limit said
    'accel.alpha_yz = 0.01659 rad: outside [-0.01, 0.01] rad' right under them. The limit is written in the stored
    unit (rad) and the file keeps the values in it; the line a person reads is in mrad."""
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    code, session = _run(tmp_path, _procedure(tmp_path, "ranges: {accel.alpha_*: [-0.0001, 0.0001]}\n"))
    out = capsys.readouterr().out
    assert code == 3
    fails = [x for x in out.splitlines() if x.startswith("  FAIL accel.alpha_")]
    assert fails and all(re.fullmatch(r"  FAIL accel\.alpha_(yz|zy|zx) = -?\d+\.?\d* mrad: outside \[-0\.1, 0\.1\] mrad",
                                      x) for x in fails), fails
    printed = float(re.search(r"alpha_yz (-?\d+\.\d+)", out).group(1))  # the run's own printout of the angle
    cal = calfile.read(session / "calibration.yaml")
    (check,) = [c for c in cal.acceptance["limits"] if c["name"] == "range accel.alpha_yz"]
    assert check["limit"] == "[-0.0001, 0.0001]" and check["value"] * 1e3 == pytest.approx(printed, abs=1e-3)
    # the report's acceptance table too (the re-check: its value and limit columns were in unlabelled rad)
    assert main(["report", str(session), "-o", str(tmp_path / "r.html")]) == 0
    page = (tmp_path / "r.html").read_text()
    table = page[page.index('id="acceptance-table"'):]
    table = table[:table.index("</table>")]
    assert "[-0.1, 0.1] mrad" in table and "[-0.0001, 0.0001]" not in table
