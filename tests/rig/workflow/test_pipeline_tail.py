"""One way from a session to its calibration file (issue 25): ``rig run`` reads the recording once and
writes the calibration file once, and the Python API (``run_procedure``) gives exactly what the command
line gives: the same calibration, acceptance verdict and history entry."""

from __future__ import annotations

import json
import os
import sys
import textwrap
from collections import Counter
from pathlib import Path

import pytest
import yaml

from calib.file import calibration as calfile
from rig.cli import main
from rig.cli.common import present
from rig.lab import open_history, sensor_history
from rig.session import load_session
from rig.workflow.conclude import conclude
from rig.workflow.run import run_procedure

from conftest import PROCEDURES

SIX = (PROCEDURES / "six_position.yaml").read_text()
ACCEPT = """\
accept:
  ranges: {accel.scale_*: [8000, 8400]}
  max_chi2_per_dof: 5
  max_attitude_error_deg: 0.5
  max_drift_sigma: 6
report: true
"""

#: the files the audit hook watches, and what each event is counted as
WATCHED = ("session.yaml", "samples.csv", "calibration.yaml")
_counting: list[Counter] = []


def _audit(event: str, args: tuple) -> None:
    if not _counting:
        return
    if event == "open" and isinstance(args[0], (str, bytes, os.PathLike)):
        name = Path(os.fsdecode(args[0])).name
        mode = args[1] if isinstance(args[1], str) else ""
        if name in WATCHED:
            writing = mode is not None and any(c in mode for c in "wax+")
            _counting[-1][(name, "write" if writing else "read")] += 1
    elif event == "os.rename" and Path(os.fsdecode(args[1])).name in WATCHED:
        _counting[-1][(Path(os.fsdecode(args[1])).name, "replace")] += 1


sys.addaudithook(_audit)  # hooks cannot be removed: this one counts only while a test asks (_counting)


def _procedure(tmp_path, name="tail") -> Path:
    text = SIX.replace("name: six_position", f"name: {name}").replace("dwell: {seconds: 10}", "dwell: {seconds: 2}")
    p = tmp_path / f"{name}.yaml"
    p.write_text(text + textwrap.dedent(ACCEPT))
    return p


def _only_session(out: Path) -> Path:
    (session,) = [p for p in out.iterdir() if p.is_dir()]
    return session


def test_rig_run_reads_the_recording_once_and_writes_the_calibration_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "history.sqlite"))
    proc = _procedure(tmp_path)
    _counting.append(Counter())
    try:
        code = main(["run", str(proc), "--seed", "5", "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"])
    finally:
        counts = _counting.pop()
    out = capsys.readouterr().out
    session = _only_session(tmp_path / "s")
    assert code == 0 and "acceptance: PASS" in out and (session / "report.html").is_file()
    # read once, to solve and to check the seal on the same read; sealing (docs/session-format.md, "Seal") hashes
    # what the writer writes as it writes it, so recording a step or sealing the session reads nothing back
    assert "seal:" in (session / "session.yaml").read_text()
    assert counts[("samples.csv", "read")] == 1, counts
    assert counts[("session.yaml", "read")] == 1, counts
    assert counts[("calibration.yaml", "replace")] == 1, counts  # written once (atomically: temp file, rename)
    assert counts[("calibration.yaml", "read")] == 0, counts


def _history_rows(db: Path) -> list[dict]:
    with open_history(db) as h:
        records = sensor_history(h, "MPU-9150@0x68#0x68/sim-seed-5")
    volatile = ("recorded_at", "calibrated_at", "session_id", "session_path", "calibration_path", "seal")
    return [({k: v for k, v in r.info.items() if k not in volatile}, r.parameters) for r in records]


def test_run_procedure_gives_what_rig_run_gives(tmp_path, monkeypatch, capsys):
    proc = _procedure(tmp_path)
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "cli.sqlite"))
    assert main(["run", str(proc), "--seed", "5", "--time-scale", "0", "--out", str(tmp_path / "cli"), "--quiet"]) == 0
    capsys.readouterr()
    result = run_procedure(str(proc), seed=5, time_scale=0, out_dir=tmp_path / "api",
                           history=tmp_path / "api.sqlite")

    by_cli = calfile.read(_only_session(tmp_path / "cli") / "calibration.yaml").to_dict()
    by_api = calfile.read(result.calibration_path).to_dict()
    assert result.calibration.to_dict() == by_api  # what the API returns is what it wrote
    for doc in (by_cli, by_api):
        doc.pop("created"), doc.pop("session")
    assert by_api == by_cli
    assert result.conclusion.verdict == "PASS" and by_api["acceptance"]["passed"] is True
    assert result.conclusion.history_warning is None and result.conclusion.report_path.is_file()
    cli_rows, api_rows = _history_rows(tmp_path / "cli.sqlite"), _history_rows(tmp_path / "api.sqlite")
    assert len(api_rows) == 1 and api_rows == cli_rows


def test_the_history_row_of_a_run_holds_the_seal_the_session_got_when_it_completed(tmp_path):
    # the run records its calibration before it marks the session complete, which seals it: the row gets the seal
    result = run_procedure(str(_procedure(tmp_path)), seed=5, time_scale=0, out_dir=tmp_path / "api",
                           history=tmp_path / "api.sqlite")
    sealed = yaml.safe_load((result.session_dir / "session.yaml").read_text())["seal"]
    with open_history(tmp_path / "api.sqlite") as h:
        (record,) = sensor_history(h, "MPU-9150@0x68#0x68/sim-seed-5")
    assert json.loads(record.info["seal"]) == sealed and result.conclusion.history_warning is None


def test_a_failed_limit_reaches_the_api_as_it_reaches_the_command_line(tmp_path):
    proc = tmp_path / "strict.yaml"
    proc.write_text(_procedure(tmp_path).read_text().replace("[8000, 8400]", "[8000, 8001]"))
    result = run_procedure(str(proc), seed=5, time_scale=0, out_dir=tmp_path / "api",
                           history=tmp_path / "api.sqlite")
    assert result.conclusion.verdict == "FAIL" and not result.conclusion.passed
    assert calfile.read(result.calibration_path).acceptance["passed"] is False
    with open_history(tmp_path / "api.sqlite") as h:
        (record,) = sensor_history(h, "MPU-9150@0x68#0x68/sim-seed-5")
    assert record.info["verdict"] == "FAIL"


@pytest.mark.parametrize("asked", [False, True])
def test_the_report_is_written_only_when_the_procedure_asks(tmp_path, asked):
    text = _procedure(tmp_path).read_text()
    proc = tmp_path / "p.yaml"
    proc.write_text(text if asked else text.replace("report: true\n", ""))
    result = run_procedure(str(proc), seed=5, time_scale=0, out_dir=tmp_path / "s", history=tmp_path / "h.sqlite")
    assert (result.session_dir / "report.html").is_file() is asked
    assert (result.conclusion.report_path is not None) is asked


def test_a_report_that_cannot_be_written_leaves_the_calibration_and_its_record_standing(tmp_path, capsys):
    result = run_procedure(str(_procedure(tmp_path)), seed=5, time_scale=0, out_dir=tmp_path / "s",
                           history=tmp_path / "h.sqlite")
    session = result.session_dir
    (session / "report.html").unlink()
    (session / "report.html").mkdir()  # where the report goes, something that is not a file: it cannot be written
    conclusion = conclude(load_session(session), out=tmp_path / "again.yaml", history=tmp_path / "h.sqlite",
                          report=True)
    assert calfile.read(tmp_path / "again.yaml").acceptance["passed"] is True and conclusion.report_path is None
    assert conclusion.report_warning.startswith("report not written (") and f"rig report {session}" in \
        conclusion.report_warning
    with open_history(tmp_path / "h.sqlite") as h:
        assert len(sensor_history(h, "MPU-9150@0x68#0x68/sim-seed-5")) == 1  # the same numbers: one record
    assert present("run", conclusion) == 0  # the run's result stands; the warning is said, once, on stderr
    (line,) = [x for x in capsys.readouterr().err.splitlines() if "report not written" in x]
    assert line.startswith("rig run: warning: report not written (")
