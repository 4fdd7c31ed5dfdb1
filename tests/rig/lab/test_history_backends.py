"""The calibration history on both backends (docs/history.md): a SQLite file and a PostgreSQL database (a real
server: tests/rig/lab/postgres_server.py). The same records, the same idempotence, two concurrent writers losing
nothing, a locked or a foreign database in one line with its exit code, a server that cannot be reached leaving
the record in the outbox until the next connection sends it, once."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from rig.cli import main
from rig.lab import HistoryCorrupt, HistoryLocked, SCHEMA_VERSION, list_sensors, open_history, sensor_history
from rig.lab.history import MIGRATIONS, calibration_row, record_calibration, store_calibration, store_row
from rig.lab.history_db import outbox
from rig.lab.history_db.location import outbox_path
from rig.lab.history_db.server import WRITER_LOCK

from conftest import PROCEDURES, REPO
from postgres_server import fresh_database, history, require_server  # noqa: F401 - history: a fixture


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed3")
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "3", "--time-scale", "0", "--out", str(out),
                 "--quiet"]) == 0
    (s,) = [p for p in out.iterdir() if p.is_dir()]
    return s


def _record(session, history, **kw):
    warning = record_calibration(session, session / "calibration.yaml", history=history, **kw)
    assert warning is None, warning


def _counts(history) -> dict:
    with open_history(history, create=False) as h:
        return {s["sensor_key"]: s["n"] for s in list_sensors(h)}


def test_a_calibration_round_trips_and_is_recorded_once(session, history):
    for _ in range(3):
        _record(session, history)
    _record(session, history, verdict="PASS")  # another verdict: a record of its own
    row = calibration_row(session, session / "calibration.yaml")
    with open_history(history) as h:
        assert h.query("SELECT MAX(version) FROM schema_version")[0][0] == SCHEMA_VERSION
        (sensor,) = list_sensors(h)
        records = sensor_history(h, sensor["sensor_key"])
    assert sensor["n"] == 2 and sensor["simulated"] == 2
    assert [r.info["verdict"] for r in records] == [None, "PASS"]
    assert {n: (v, s, u) for n, v, s, u in row["parameters"]} == records[0].parameters  # doubles, in order
    assert list(records[0].parameters) == [p[0] for p in row["parameters"]]
    assert records[0].info["rig"] == json.loads(row["calibration"]["rig"])
    assert records[0].info["seal"] is not None  # rig run sealed the session; the seal was copied


def test_a_file_named_by_url_goes_through_sqlalchemy_and_reads_back_by_path(session, tmp_path):
    db = tmp_path / "h.sqlite"
    _record(session, f"sqlite:///{db}")
    _record(session, db)  # the same calibration, by path (sqlite3): the same row
    with open_history(f"sqlite:///{db}") as h:
        assert type(h.db).__name__ == "Server" and h.query("PRAGMA journal_mode")[0][0] == "wal"
        assert [s["n"] for s in list_sensors(h)] == [1]


WRITER = textwrap.dedent("""
    import sys
    from rig.lab import store_calibration
    session, db, me = sys.argv[1], sys.argv[2], sys.argv[3]
    for k in range(10):  # records of its own, and five both writers make (each stored once)
        store_calibration(session, session + "/calibration.yaml", history=db, sensor_id=me, verdict=f"V{k}")
        if k % 2:
            store_calibration(session, session + "/calibration.yaml", history=db, sensor_id="shared",
                              verdict=f"S{k // 2}")
""")


def test_two_concurrent_writers_lose_nothing_and_store_a_shared_record_once(session, history):
    """Both start on an empty database: they race to create the schema too (one migrates, the other waits)."""
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(session), history, f"rig-{i}"], cwd=REPO,
                              stderr=subprocess.PIPE, text=True) for i in range(2)]
    for p in procs:
        _, err = p.communicate(timeout=180)
        assert p.returncode == 0, err
    assert _counts(history) == {"MPU-9150:rig-0": 10, "MPU-9150:rig-1": 10, "MPU-9150:shared": 5}
    with open_history(history) as h:
        assert h.query("SELECT COUNT(*) FROM parameters")[0][0] == 25 * 9


def _hold_writers(history):
    """Another writer holding the history: SQLite ``BEGIN EXCLUSIVE``; PostgreSQL the writers' advisory lock."""
    if not history.startswith("postgresql"):
        import sqlite3

        conn = sqlite3.connect(history, isolation_level=None)
        conn.execute("BEGIN EXCLUSIVE")
        return conn, lambda: (conn.execute("ROLLBACK"), conn.close())
    import sqlalchemy as sa

    eng = sa.create_engine(history)
    conn = eng.connect()
    conn.exec_driver_sql(f"SELECT pg_advisory_lock({WRITER_LOCK})")
    return conn, lambda: (conn.close(), eng.dispose())


def test_a_locked_history_gives_one_line_and_loses_nothing(session, history):
    _record(session, history)
    _, release = _hold_writers(history)
    try:
        with pytest.raises(HistoryLocked) as exc:
            store_calibration(session, session / "calibration.yaml", history=history, timeout_s=0.3)
        assert "locked" in str(exc.value) and "\n" not in str(exc.value) and exc.value.exit_code == 1
        warning = record_calibration(session, session / "calibration.yaml", history=history, timeout_s=0.3,
                                     verdict="PASS")
    finally:
        release()
    assert "\n" not in warning and "locked" in warning
    if history.startswith("postgresql"):  # a server's record waits in the outbox, sent at the next opening
        assert warning.startswith("history server not reached: ") and "outbox" in warning
        assert _counts(history) == {"MPU-9150@0x68#0x68/sim-seed-3": 2}
    else:
        assert warning.startswith("history not recorded: ")
        assert _counts(history) == {"MPU-9150@0x68#0x68/sim-seed-3": 1}


def _foreign(history):
    """A database that is not a rig history: a file of text; a PostgreSQL database whose tables are another's."""
    if not history.startswith("postgresql"):
        with open(history, "wb") as fh:
            fh.write(b"this is not a database\n" * 300)
        return
    import sqlalchemy as sa

    with sa.create_engine(history).begin() as c:
        c.exec_driver_sql("CREATE TABLE schema_version (version INTEGER NOT NULL)")
        c.exec_driver_sql(f"INSERT INTO schema_version VALUES ({SCHEMA_VERSION})")
        c.exec_driver_sql("CREATE TABLE sensors (something_else INTEGER)")


def test_a_foreign_database_is_refused_in_one_line_and_left_untouched(session, history):
    _foreign(history)
    with pytest.raises(HistoryCorrupt) as exc:
        store_calibration(session, session / "calibration.yaml", history=history)
    assert "\n" not in str(exc.value) and exc.value.exit_code == 2
    warning = record_calibration(session, session / "calibration.yaml", history=history)
    assert warning.startswith("history not recorded: ") and "\n" not in warning
    assert main(["history", "--history", history]) == 2


def test_a_newer_schema_is_refused(history):
    open_history(history).close()
    with open_history(history) as h:
        h.write(lambda tx: tx.execute(f"INSERT INTO schema_version (version) VALUES ({SCHEMA_VERSION + 1})"))
    with pytest.raises(HistoryCorrupt, match="newer than this software"):
        open_history(history)


def test_the_cli_records_and_lists_on_either_backend(session, history, capsys, monkeypatch):
    assert main(["history", "--record", str(session), "--history", history]) == 0
    assert "recorded: calibration #1" in capsys.readouterr().out
    assert "password" not in history
    monkeypatch.setenv("RIG_HISTORY", history)  # $RIG_HISTORY names it as --history does
    assert main(["history", "--all", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [s["n"] for s in doc["sensors"]] == [1]
    assert main(["history", "sim-seed-3", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["calibrations"]) == 1


def test_record_calibration_never_raises_for_a_server(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY_OUTBOX", str(tmp_path / "outbox"))
    url = f"postgresql+psycopg://nobody:secret@127.0.0.1:{_free_port()}/none"
    warning = record_calibration(tmp_path / "nope", tmp_path / "nope/calibration.yaml", history=url)
    assert warning.startswith("history not recorded: ") and "secret" not in warning
    with pytest.raises(HistoryLocked) as exc:
        open_history(url)
    assert "cannot reach the history server" in str(exc.value) and "secret" not in str(exc.value)


def test_a_server_that_does_not_answer_is_waited_for_once(session, tmp_path, monkeypatch):
    """A host that takes the connection and never answers (a server hung, a firewall dropping): the connect timeout
    once, then the record, its seal and every other use in the same process go to the outbox at once."""
    monkeypatch.setenv("RIG_HISTORY_OUTBOX", str(tmp_path / "outbox"))
    with socket.create_server(("127.0.0.1", 0)) as silent:
        url = f"postgresql+psycopg://rig@127.0.0.1:{silent.getsockname()[1]}/rig"
        started = time.monotonic()
        warning = record_calibration(session, session / "calibration.yaml", history=url, timeout_s=2)
        took = time.monotonic() - started
        assert "history server not reached" in warning and "timeout" in warning and outbox.pending(url) == 1
        started = time.monotonic()
        assert "outbox" in record_calibration(session, session / "calibration.yaml", history=url, verdict="PASS")
        assert time.monotonic() - started < 1.0 < took


# ---------------------------------------------------------------------------------------------- the outbox

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Forwarder:
    """The server as a rig sees it across a network: a TCP port forwarded to the real server while it runs;
    before :meth:`start` and after :meth:`stop` the port refuses connections (the server cannot be reached)."""

    def __init__(self, target_port: int) -> None:
        self.port, self.target = _free_port(), target_port
        self.sock = None

    def start(self) -> None:
        self.sock = socket.create_server(("127.0.0.1", self.port))
        threading.Thread(target=self._accept, daemon=True).start()

    def stop(self) -> None:
        self.sock.close()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.sock.accept()
            except OSError:
                return
            upstream = socket.create_connection(("127.0.0.1", self.target))
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    @staticmethod
    def _pump(src, dst) -> None:
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        finally:
            dst.close()


def test_a_rig_that_cannot_reach_the_server_keeps_recording_and_syncs_once(session, tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_HISTORY_OUTBOX", str(tmp_path / "outbox"))
    with fresh_database(require_server()) as real:
        host_port, name = real.split("@", 1)[1].split("/")
        forward = Forwarder(int(host_port.rsplit(":", 1)[1]))
        url = real.replace(host_port, f"127.0.0.1:{forward.port}")
        warning = record_calibration(session, session / "calibration.yaml", history=url)  # the server is away
        assert warning.startswith("history server not reached: ") and str(outbox_path(url)) in warning
        warning = record_calibration(session, session / "calibration.yaml", history=url, verdict="PASS")
        assert "outbox" in warning and outbox.pending(url) == 2
        forward.start()
        try:
            assert _counts(url) == {"MPU-9150@0x68#0x68/sim-seed-3": 2}  # opening it sent the outbox
            assert outbox.pending(url) == 0
            with open_history(url) as h:
                records = sensor_history(h, "MPU-9150@0x68#0x68/sim-seed-3")
                assert all(r.info["seal"] for r in records)  # the seal rig recorded into the outbox came along
                row = calibration_row(session, session / "calibration.yaml", verdict="PASS")
                outbox.keep(url, row)  # as if a sync had stored it on the server and died before removing it
                assert outbox.sync(h) == 1
            assert _counts(url) == {"MPU-9150@0x68#0x68/sim-seed-3": 2} and outbox.pending(url) == 0
            _record(session, url, verdict="FAIL")  # and the rig records straight to the server again
            assert _counts(url) == {"MPU-9150@0x68#0x68/sim-seed-3": 3}
        finally:
            forward.stop()


# ---------------------------------------------------------------------------------------------- migration

def test_a_history_written_before_alembic_opens_and_migrates(tmp_path, session):
    import sqlite3

    db = tmp_path / "old.sqlite"
    with sqlite3.connect(db) as conn:  # a version-1 file, as rig wrote it before there was Alembic
        conn.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
        for sql in MIGRATIONS[0][1]:
            conn.execute(sql)
        conn.execute("INSERT INTO schema_version VALUES (1)")
    row = calibration_row(session, session / "calibration.yaml")
    with sqlite3.connect(db) as conn:
        c = {k: v for k, v in row["calibration"].items() if k not in ("seal", "simulated")}
        conn.execute("INSERT INTO sensors VALUES (?, ?, ?, ?, ?, 'x')", tuple(row["sensor"][k] for k in
                                                                             ("key", "model", "address", "identity",
                                                                              "serial")))
        conn.execute(f"INSERT INTO calibrations (sensor_key, {', '.join(c)}) VALUES ({', '.join('?' * (len(c) + 1))})",
                     (row["sensor"]["key"], *c.values()))
    with open_history(db) as h:
        assert h.query("SELECT MAX(version) FROM schema_version")[0][0] == SCHEMA_VERSION
        assert h.query("SELECT version_num FROM alembic_version")[0][0] == f"{SCHEMA_VERSION:04d}"
        assert h.query("SELECT simulated FROM calibrations")[0][0] == 1  # version 3 marked the simulated row
    assert store_row(row, history=db)[0] == 2  # a row of its own: the old one has no seal, no parameters


def test_recording_into_a_file_starts_without_sqlalchemy(session, tmp_path):
    """``rig solve`` records into the SQLite history: SQLAlchemy and Alembic (0.2-0.5 s to import) stay out, also
    when the record creates the file (issue 26)."""
    code = textwrap.dedent(f"""
        import sys
        from rig.lab.history import record_calibration
        assert record_calibration({str(session)!r}, {str(session / 'calibration.yaml')!r},
                                  history={str(tmp_path / 'new' / 'h.sqlite')!r}) is None
        print(sorted({{m.split(".")[0] for m in sys.modules}} & {{"sqlalchemy", "alembic", "psycopg"}}))
    """)
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_a_new_file_is_the_schema_alembic_makes(tmp_path):
    """A new file gets the migration steps and the stamp without Alembic; Alembic, run on an empty file, makes the
    same tables, versions and revision."""
    import re
    import sqlite3

    from rig.lab.history_db import migrate
    from rig.lab.history_db.sqlite_file import SqliteFile

    open_history(tmp_path / "new.sqlite").close()
    empty = SqliteFile(tmp_path / "alembic.sqlite", 5.0)
    migrate.upgrade(empty, 5.0)
    empty.close()

    def schema(path):
        with sqlite3.connect(path) as c:
            tables = sorted((kind, name, re.sub(r"\s*([(),])\s*", r"\1", " ".join(sql.split())) if sql else sql)
                            for kind, name, sql in c.execute("SELECT type, name, sql FROM sqlite_master"))
            return (tables, c.execute("SELECT version FROM schema_version").fetchall(),
                    c.execute("SELECT version_num FROM alembic_version").fetchall())

    assert schema(tmp_path / "new.sqlite") == schema(tmp_path / "alembic.sqlite")
    assert schema(tmp_path / "new.sqlite")[2] == [(f"{SCHEMA_VERSION:04d}",)]
