"""The calibration history (rig.lab.history, rig.lab.drift): round trip, concurrent writers, a corrupted
or locked database (one-line error, nothing lost), drift flags. Sessions are real `rig run`s of the
simulated rig (the same seed is the same simulated sensor; another seed is another sensor)."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from calib.file import calibration as calfile
from calib.acceptance import largest_drift
from calib.file.parameters import at_common_temperature
from rig.cli import main
from rig.lab import (SCHEMA_VERSION, HistoryCorrupt, HistoryLocked, drift, format_history, list_sensors, open_history,
                     record_calibration, sensor_history, store_calibration)
from rig.lab.drift import CalibrationRecord
from rig.lab.history import MIGRATIONS

from conftest import PROCEDURES, REPO


def run_session(out, seed: int, procedure: str = "six_position.yaml"):
    code = main(["run", str(PROCEDURES / procedure), "--seed", str(seed), "--time-scale", "0", "--out", str(out),
                 "--quiet"])
    assert code == 0
    (session,) = [p for p in out.iterdir() if p.is_dir()]
    return session


@pytest.fixture(scope="module")
def seed3(tmp_path_factory):
    return run_session(tmp_path_factory.mktemp("seed3"), 3)


@pytest.fixture(scope="module")
def seed4(tmp_path_factory):
    return run_session(tmp_path_factory.mktemp("seed4"), 4)


def _record(session, db, **kw):
    warning = record_calibration(session, session / "calibration.yaml", history=db, **kw)
    assert warning is None, warning


def test_calibrations_round_trip(seed3, tmp_path):
    db = tmp_path / "h.sqlite"
    for _ in range(5):  # one calibration recorded five times: one row (a record is idempotent)
        _record(seed3, db)
    _record(seed3, db, verdict="PASS")  # the same numbers with a verdict: a record of its own
    cal = calfile.read(seed3 / "calibration.yaml")
    with open_history(db) as h:
        (sensor,) = list_sensors(h)
        assert sensor["sensor_key"] == "MPU-9150@0x68#0x68/sim-seed-3" and sensor["n"] == 2
        assert h.query("SELECT MAX(version) FROM schema_version")[0][0] == SCHEMA_VERSION
        records = sensor_history(h, sensor["sensor_key"])
    assert len(records) == 2
    r = records[-1]
    a = cal.accelerometer
    for j, x in enumerate("xyz"):
        assert r.parameters[f"accel.bias_{x}"][:2] == (a.bias_counts[j], a.sigma["bias_counts"][j])
        assert r.parameters[f"accel.scale_{x}"][:2] == (a.scale_counts_per_g[j], a.sigma["scale_counts_per_g"][j])
    for k in ("alpha_yz", "alpha_zy", "alpha_zx"):
        assert r.parameters[f"accel.{k}"] == (a.misalignment[k], a.sigma["misalignment"][k], "rad")
    info = r.info
    assert info["session_id"] == seed3.name and info["procedure_name"] == "six_position"
    assert len(info["procedure_sha256"]) == 64
    assert [info["rig"]["axes"][ax]["serial"] for ax in ("a1", "a2", "a3")] == [23040, 23041, 23042]
    assert info["rig"]["axes"]["a1"]["firmware"] == "4.3.8"
    assert info["software_version"] == cal.software["version"]
    assert 20 < info["temp_mean_c"] < 40
    assert info["residual_rms_g"] == a.fit.residual_rms_g and info["chi2_per_dof"] == a.fit.chi2_per_dof
    d = drift(records)  # the second is a re-solve of the first's session (the same data): not compared
    assert all(col == [None, None] for col in d.values())


def test_drift_between_two_sensors_under_one_id_is_flagged(seed3, seed4, tmp_path):
    db = tmp_path / "h.sqlite"
    _record(seed3, db, sensor_id="DUT-7")
    _record(seed4, db, sensor_id="DUT-7")
    with open_history(db) as h:
        records = sensor_history(h, "MPU-9150:DUT-7")
    d = drift(records)
    assert d["accel.bias_x"][1]["flagged"] and abs(d["accel.bias_x"][1]["z"]) > 3
    s0, s1 = records[0].parameters["accel.bias_x"][1], records[1].parameters["accel.bias_x"][1]
    assert d["accel.bias_x"][1]["combined_sigma"] == pytest.approx(np.hypot(s0, s1))
    assert "drift beyond 3 combined sigma: " in format_history("MPU-9150:DUT-7", records)


WRITER = textwrap.dedent("""
    import sys
    from rig.lab import store_calibration
    session, db = sys.argv[1], sys.argv[2]
    for k in range(15):  # 15 different records (a verdict each: the same one twice would be one row)
        store_calibration(session, session + "/calibration.yaml", history=db, sensor_id=sys.argv[3], verdict=f"V{k}")
""")


def test_two_concurrent_writers_lose_nothing(seed3, tmp_path):
    db = tmp_path / "h.sqlite"
    open_history(db).close()
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(seed3), str(db), f"rig-{i}"], cwd=REPO,
                              stderr=subprocess.PIPE, text=True) for i in range(2)]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    with open_history(db) as h:
        counts = {s["sensor_key"]: s["n"] for s in list_sensors(h)}
        assert h.query("SELECT COUNT(*) FROM parameters")[0][0] == 30 * 9
    assert counts == {"MPU-9150:rig-0": 15, "MPU-9150:rig-1": 15}


def test_a_corrupted_database_is_refused_in_one_line_and_left_untouched(seed3, tmp_path):
    db = tmp_path / "h.sqlite"
    db.write_bytes(b"this is not a database\n" * 300)
    before = db.read_bytes()
    with pytest.raises(HistoryCorrupt) as exc:
        open_history(db)
    assert "\n" not in str(exc.value) and str(db) in str(exc.value) and exc.value.exit_code == 2
    warning = record_calibration(seed3, seed3 / "calibration.yaml", history=db)
    assert warning.startswith("history not recorded: ") and "\n" not in warning
    assert db.read_bytes() == before


def test_a_newer_schema_is_refused(tmp_path):
    db = tmp_path / "h.sqlite"
    open_history(db).close()
    with sqlite3.connect(db) as c:
        c.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION + 1,))
    with pytest.raises(HistoryCorrupt, match="newer than this software"):
        open_history(db)


def test_a_locked_database_gives_one_line_and_loses_nothing(seed3, tmp_path):
    db = tmp_path / "h.sqlite"
    _record(seed3, db)
    holder = sqlite3.connect(db, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        with pytest.raises(HistoryLocked) as exc:
            store_calibration(seed3, seed3 / "calibration.yaml", history=db, timeout_s=0.2)
        assert "locked" in str(exc.value) and "\n" not in str(exc.value) and exc.value.exit_code == 1
        warning = record_calibration(seed3, seed3 / "calibration.yaml", history=db, timeout_s=0.2)
        assert warning.startswith("history not recorded: ") and "locked" in warning
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    with open_history(db) as h:
        assert [s["n"] for s in list_sensors(h)] == [1]
    _record(seed3, db, verdict="PASS")
    with open_history(db) as h:
        assert [s["n"] for s in list_sensors(h)] == [2]


def test_record_calibration_never_raises(tmp_path):
    warning = record_calibration(tmp_path / "nope", tmp_path / "nope/calibration.yaml", history=tmp_path / "h.sqlite")
    assert warning.startswith("history not recorded: ")


def test_migrations_are_versioned_and_wal_is_on(tmp_path):
    assert [v for v, _ in MIGRATIONS] == sorted({v for v, _ in MIGRATIONS})
    with open_history(tmp_path / "h.sqlite") as h:
        assert h.query("PRAGMA journal_mode")[0][0] == "wal"
        assert h.query("PRAGMA busy_timeout")[0][0] > 0


def test_lab_never_imports_a_simulator():
    import grimp
    graph = grimp.build_graph("rig", "drivers", "calib")
    for forbidden in ("rig.simulation", "drivers.ximc.sim", "drivers.sensors.sim"):
        assert not graph.chain_exists(importer="rig.lab", imported=forbidden, as_packages=True)


def _thermal_pair():
    """Six-position at 27.6 C (bias at the session's temperature) and a run with a linear bias
    temperature coefficient reporting its bias at t0 = 25.0 C: the same sensor, no ageing."""
    before = CalibrationRecord(1, {"temp_mean_c": 27.6, "calibrated_at": "2026-01-01"},
                               {"accel.bias_x": (396.4, 0.35, "counts"), "accel.scale_x": (8146.3, 0.6, "counts/g")})
    after = CalibrationRecord(2, {"temp_mean_c": 25.3, "calibrated_at": "2026-02-01"},
                              {"accel.bias_x": (396.4 + 4.98 * 2.6, 0.14, "counts"), "accel.t0_c": (25.0, None, "C"),
                               "accel.tempco1_x": (-4.98, 0.025, "counts/C^1"),
                               "accel.scale_x": (8146.0, 0.3, "counts/g")})
    return before, after


def test_biases_are_compared_at_one_temperature_when_a_calibration_has_temperature_terms():
    before, after = _thermal_pair()
    change = drift([before, after])["accel.bias_x"][1]
    assert change["at_temp_c"] == 27.6 and abs(change["delta"]) < 1e-9 and not change["flagged"]
    # the stated bias sigma gains the coefficient's sigma times the 2.6 C it is carried over
    assert change["combined_sigma"] == pytest.approx(np.sqrt(0.35**2 + 0.14**2 + (0.025 * 2.6) ** 2))
    table = format_history("s", [before, after])
    assert "no drift beyond 3 combined sigma" in table and "accelerometer biases at 27.6 C" in table
    assert "#2 from its t0 25.0 C" in table  # the thermal calibration's bias shown where the other one holds
    assert "396.4+-0.15 (+0.0s)" in table


def test_a_real_bias_change_is_still_flagged_across_temperatures():
    before, after = _thermal_pair()
    value, sigma, unit = after.parameters["accel.bias_x"]
    after.parameters["accel.bias_x"] = (value + 5.0, sigma, unit)  # the sensor moved 5 counts
    change = drift([before, after])["accel.bias_x"][1]
    assert change["delta"] == pytest.approx(5.0) and change["flagged"]


def test_acceptance_drift_compares_at_one_temperature_too():
    before, after = _thermal_pair()
    previous, current, common_c = at_common_temperature(before.parameters, 27.6, after.parameters, 25.3)
    d = largest_drift([(n, *v) for n, v in current.items()], previous, "2026-01-01")
    assert common_c == 27.6 and abs(d.z) < 1.0


def test_sensors_are_listed_with_their_numbers_in_order(seed3, tmp_path):
    db = tmp_path / "h.sqlite"
    for sensor_id in ("unit-10", "unit-2", "unit-1"):
        _record(seed3, db, sensor_id=sensor_id)
    with open_history(db) as h:
        keys = [s["sensor_key"] for s in list_sensors(h)]
    assert keys == ["MPU-9150:unit-1", "MPU-9150:unit-2", "MPU-9150:unit-10"], keys  # not 1, 10, 2
