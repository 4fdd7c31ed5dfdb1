"""A history record is idempotent (issue 34 item 9): the same calibration of the same session recorded twice
(``rig history --record`` twice, ``rig solve`` twice, a solve then a record) is one row; a re-solve that differs
is a row of its own, and ``store_calibration`` says which it was. Each on a SQLite file and on PostgreSQL."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from calib.file import calibration as calfile
from rig.cli import main
from rig.lab import list_sensors, open_history, record_calibration, sensor_history, store_calibration

from conftest import PROCEDURES, REPO
from postgres_server import history  # noqa: F401 - a fixture (both backends)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    out = tmp_path_factory.mktemp("idem")
    code = main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "3", "--time-scale", "0", "--out", str(out),
                 "--quiet"])
    assert code == 0
    (s,) = [p for p in out.iterdir() if p.is_dir()]
    return s


def _rows(db) -> int:
    with open_history(db) as h:
        return h.query("SELECT COUNT(*) FROM calibrations")[0][0]


def test_recording_one_calibration_twice_is_one_row(session, tmp_path, history):
    db = history
    first = store_calibration(session, session / "calibration.yaml", history=db)
    again = store_calibration(session, session / "calibration.yaml", history=db)
    assert not first.already and again.already
    assert tuple(again) == tuple(first)  # (row id, sensor key): the row that holds it
    cid, key = again  # still the (row id, sensor key) pair
    assert record_calibration(session, session / "calibration.yaml", history=db) is None
    assert _rows(db) == 1
    with open_history(db) as h:
        assert h.query("SELECT COUNT(*) FROM parameters")[0][0] == 9


def test_a_re_solve_with_the_same_numbers_is_the_same_calibration(session, tmp_path, history):
    """rig solve writes a new ``created`` time: the same numbers of the same session are still one row."""
    db = history
    store_calibration(session, session / "calibration.yaml", history=db)
    cal = calfile.read(session / "calibration.yaml")
    later = cal.model_copy(update={"created": "2099-01-01T00:00:00+00:00"})
    again = store_calibration(session, tmp_path / "elsewhere.yaml", history=db, calibration=later)
    assert again.already and _rows(db) == 1


def test_a_re_solve_that_differs_is_a_new_row_and_history_shows_both(session, tmp_path, history):
    db = history
    store_calibration(session, session / "calibration.yaml", history=db)
    cal = calfile.read(session / "calibration.yaml")
    a = cal.accelerometer
    moved = cal.model_copy(update={"accelerometer": a.model_copy(update={"bias_counts": a.bias_counts + 1.0})})
    other = store_calibration(session, tmp_path / "other.yaml", history=db, calibration=moved)
    assert not other.already
    judged = store_calibration(session, session / "calibration.yaml", history=db, verdict="FAIL")
    assert not judged.already  # the same numbers with another verdict: another record
    assert _rows(db) == 3
    with open_history(db) as h:
        (sensor,) = list_sensors(h)
        assert len(sensor_history(h, sensor["sensor_key"])) == 3


def test_another_sensor_id_is_another_record(session, tmp_path, history):
    db = history
    store_calibration(session, session / "calibration.yaml", history=db)
    assert not store_calibration(session, session / "calibration.yaml", history=db, sensor_id="SN-1").already
    assert _rows(db) == 2


def test_rig_solve_twice_then_history_record_is_one_row(session, tmp_path, monkeypatch, capsys, history):
    db = history
    monkeypatch.setenv("RIG_HISTORY", str(db))
    for name in ("a.yaml", "b.yaml"):
        assert main(["solve", str(session), "-o", str(tmp_path / name)]) == 0
    capsys.readouterr()
    assert main(["history", "--record", str(session), "--calibration", str(tmp_path / "b.yaml")]) == 0
    assert _rows(db) == 1
    assert capsys.readouterr().out.startswith("already recorded: calibration #1 ")  # not "recorded": nothing added
    assert main(["solve", str(session), "-o", str(tmp_path / "full.yaml"), "--model", "full"]) == 0
    capsys.readouterr()
    assert main(["history", "--json", "--all"]) == 0  # records of the simulated rig: listed with --all
    assert '"n": 2' in capsys.readouterr().out


WRITER = textwrap.dedent("""
    import sys
    from rig.lab import store_calibration
    session, db = sys.argv[1], sys.argv[2]
    for _ in range(10):
        store_calibration(session, session + "/calibration.yaml", history=db)
""")


def test_two_writers_recording_the_same_calibration_leave_one_row(session, tmp_path, history):
    db = history
    open_history(db).close()
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(session), str(db)], cwd=REPO,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    assert _rows(db) == 1
