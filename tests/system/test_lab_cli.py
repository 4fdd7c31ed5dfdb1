"""`rig history` and `rig export` from the command line on a session of the simulated rig."""

from __future__ import annotations

import json
import sqlite3
from contextlib import closing

import pytest

from rig.cli import main

from conftest import PROCEDURES


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A six-position session (seed 3, virtual time) and the calibration history its run recorded into
    (``history``: that run's entry only). Read only: copy them to change them."""
    out = tmp_path_factory.mktemp("lab")
    db = out / "run-history.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(db))
        assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "3", "--time-scale", "0", "--out",
                     str(out / "sessions"), "--quiet"]) == 0
    (s,) = list((out / "sessions").iterdir())
    return {"session": s, "history": db}


@pytest.fixture
def session(recorded):
    return recorded["session"]


def test_history_record_list_show_json_plot(session, tmp_path, capsys, monkeypatch):
    db = tmp_path / "h.sqlite"
    monkeypatch.setenv("RIG_HISTORY", str(db))
    for _ in range(3):  # one calibration recorded three times: one row
        assert main(["history", "--record", str(session)]) == 0
    alt = tmp_path / "full.yaml"  # a re-solve that differs (recorded by rig solve): a row of its own
    assert main(["solve", str(session), "-o", str(alt), "--model", "full"]) == 0
    assert main(["history", "--record", str(session), "--calibration", str(alt)]) == 0  # recorded already
    assert main(["history", "--record", str(session), "--sensor-id", "SN-42"]) == 0
    capsys.readouterr()
    assert main(["history"]) == 0  # every record is of the simulated rig: none in the default list
    listing = capsys.readouterr().out
    assert "MPU-9150@0x68#0x68/sim-seed-3" not in listing and "2 sensor(s) calibrated only on the simulated" in listing
    assert main(["history", "--all"]) == 0
    listing = capsys.readouterr().out
    assert "MPU-9150@0x68#0x68/sim-seed-3" in listing and "MPU-9150:SN-42" in listing
    assert main(["history", "sim-seed-3", "--plot", str(tmp_path / "h.png")]) == 0
    table = capsys.readouterr().out
    assert "2 calibration(s)" in table and "accel.bias_x (counts)" in table
    assert "full by pinv" in table and "(a re-solve of #1's session: not compared for drift)" in table  # same data
    assert (tmp_path / "h.png").stat().st_size > 10_000
    assert main(["history", "SN-42", "--json", "--history", str(db)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "rig-history/1" and len(doc["calibrations"]) == 1 and doc["flagged"] == []


def test_history_errors_are_one_line(session, tmp_path, capsys):
    bad = tmp_path / "bad.sqlite"
    bad.write_text("garbage\n" * 100)
    assert main(["history", "--history", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig history: ") and err.count("\n") == 1 and "untouched" in err
    db = tmp_path / "h.sqlite"
    assert main(["history", "--record", str(session), "--history", str(db)]) == 0
    assert main(["history", "no-such-sensor", "--history", str(db)]) == 2
    assert main(["history", "--record", str(session), "--sensor-id", "SN-43", "--history", str(db)]) == 0
    capsys.readouterr()
    assert main(["history", "MPU-9150", "--history", str(db)]) == 2  # two sensors match: the simulated one hidden
    err = capsys.readouterr().err
    assert "matches several sensors" in err and "rig history --all lists them" in err, err
    assert main(["history", "--history", str(tmp_path / "missing.sqlite")]) == 2
    assert main(["history", "--plot", "x.png", "--history", str(db)]) == 2


@pytest.mark.parametrize("target", ["px4", "ardupilot", "imucal", "json"])
def test_export_writes_the_file_and_one_line(session, tmp_path, capsys, target):
    out = tmp_path / f"cal.{target}"
    assert main(["export", str(session / "calibration.yaml"), "--to", target, "-o", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"export: {out}" and lines[1].startswith(f"{target}: ") and len(lines) == 2
    assert out.stat().st_size > 100


def test_export_bad_input(tmp_path, capsys):
    assert main(["export", str(tmp_path / "none.yaml"), "--to", "px4"]) == 2
    assert main(["export", str(tmp_path / "none.yaml"), "--to", "nope"]) == 2


def test_every_run_and_solve_is_recorded_in_the_history(recorded, tmp_path, monkeypatch, capsys):
    db = tmp_path / "h.sqlite"
    with closing(sqlite3.connect(recorded["history"])) as src, closing(sqlite3.connect(db)) as dst:
        src.backup(dst)  # what the module's run recorded (its write-ahead log included)
    monkeypatch.setenv("RIG_HISTORY", str(db))
    assert main(["solve", str(recorded["session"]), "-o", str(tmp_path / "again.yaml")]) == 0
    capsys.readouterr()
    assert main(["history", "--json", "--all"]) == 0  # a simulated run's records: listed with --all
    listing = json.loads(capsys.readouterr().out)
    assert [s["n"] for s in listing["sensors"]] == [1]  # the same calibration of the same session: one row
    assert main(["solve", str(recorded["session"]), "-o", str(tmp_path / "full.yaml"), "--model", "full"]) == 0
    capsys.readouterr()
    assert main(["history", "--json", "--all"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert [s["n"] for s in listing["sensors"]] == [2]  # a re-solve that differs: both


def test_an_exploratory_re_solve_with_no_record_writes_its_file_and_leaves_the_history_alone(recorded, tmp_path,
                                                                                            monkeypatch, capsys):
    db = tmp_path / "h.sqlite"
    with closing(sqlite3.connect(recorded["history"])) as src, closing(sqlite3.connect(db)) as dst:
        src.backup(dst)
    monkeypatch.setenv("RIG_HISTORY", str(db))
    assert main(["solve", str(recorded["session"]), "-o", str(tmp_path / "full.yaml"), "--model", "full",
                 "--no-record"]) == 0
    assert (tmp_path / "full.yaml").is_file()
    capsys.readouterr()
    assert main(["history", "--json", "--all"]) == 0
    assert [s["n"] for s in json.loads(capsys.readouterr().out)["sensors"]] == [1]  # only the run's own record
