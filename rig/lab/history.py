"""The calibration history: one embedded SQLite database of every calibration, per sensor (docs/history.md).

Where: ``--history PATH``, else ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``
(:func:`default_path`). The schema is versioned (table ``schema_version``) and migrated by the
table :data:`MIGRATIONS` of SQL steps, each applied once inside one ``BEGIN IMMEDIATE`` transaction.
WAL journal and a busy timeout: two writers (two rigs on one machine) wait for each other instead
of failing; every write is one transaction, so a crash or a refused write leaves what was stored.

:func:`record_calibration` is the one call the workflows make after a solve: it never raises for a
database problem (it returns a one-line warning instead). :func:`open_history` and the readers raise
:class:`HistoryCorrupt` (exit 2: not a database / damaged) or :class:`HistoryLocked` (exit 1).
"""

from __future__ import annotations

import json
import os
import sqlite3
from datetime import datetime, timezone
from pathlib import Path

from calib.file import calibration as calfile
from calib.file.parameters import finite_or_none as _fnum
from calib.file.parameters import sensor_parameters
from rig import __version__
from rig.errors import RigInputError
from rig.lab.identity import rig_identity, sensor_identity, temperatures
from rig.session.manifest import SessionManifest

ENV_VAR = "RIG_HISTORY"
DEFAULT_PATH = Path("~/.local/share/rig/history.sqlite")
BUSY_TIMEOUT_S = 30.0

#: schema migrations: (version, SQL statements); applied in order, each version once
MIGRATIONS: list[tuple[int, list[str]]] = [
    (1, [
        """CREATE TABLE sensors (
               sensor_key TEXT PRIMARY KEY, model TEXT, address INTEGER, identity TEXT, serial TEXT,
               first_seen TEXT NOT NULL)""",
        """CREATE TABLE calibrations (
               id INTEGER PRIMARY KEY AUTOINCREMENT,
               sensor_key TEXT NOT NULL REFERENCES sensors(sensor_key),
               recorded_at TEXT NOT NULL, calibrated_at TEXT,
               session_id TEXT, session_path TEXT, calibration_path TEXT,
               procedure_name TEXT, procedure_sha256 TEXT,
               rig TEXT, software_version TEXT,
               temp_mean_c REAL, temp_min_c REAL, temp_max_c REAL,
               model TEXT, method TEXT, steps INTEGER, residual_rms_g REAL, chi2_per_dof REAL,
               verdict TEXT)""",
        """CREATE TABLE parameters (
               calibration_id INTEGER NOT NULL REFERENCES calibrations(id) ON DELETE CASCADE,
               name TEXT NOT NULL, value REAL NOT NULL, sigma REAL, unit TEXT,
               PRIMARY KEY (calibration_id, name))""",
        "CREATE INDEX calibrations_by_sensor ON calibrations(sensor_key, calibrated_at)",
    ]),
    # the session's seal (docs/session-format.md, "Seal") as JSON: the recording this calibration was solved from,
    # as it was made; NULL for a session recorded before sealing existed or solved before it was sealed
    (2, ["ALTER TABLE calibrations ADD COLUMN seal TEXT"]),
    # 1 for a calibration of a session recorded on the simulated or the replay rig (issue 33 item 8): left out of
    # the default view (docs/history.md, "Simulated records"); rows stored before are marked by their rig kind and
    # by the simulated sensor key (``/sim-seed-N``)
    (3, ["ALTER TABLE calibrations ADD COLUMN simulated INTEGER NOT NULL DEFAULT 0",
         "UPDATE calibrations SET simulated = 1 WHERE sensor_key LIKE '%/sim-seed-%' "
         "OR rig LIKE '%\"kind\": \"sim:%' OR rig LIKE '%\"kind\": \"replay:%' "
         "OR rig LIKE '%\"kind\": \"sim\"%' OR rig LIKE '%\"kind\": \"replay\"%'"]),
]
#: the turntable kinds (``rig.turntable.kind`` of the manifest, before any ``:``) of a simulated rig
SIMULATED_RIG_KINDS = ("sim", "replay")
SCHEMA_VERSION = MIGRATIONS[-1][0]


class HistoryError(Exception):
    """A history database problem; ``str()`` is one line; ``exit_code`` as in docs/cli.md."""

    exit_code = 1


class HistoryCorrupt(HistoryError, RigInputError):
    """The file is not a history database, is damaged, or is newer than this software (exit 2)."""

    exit_code = 2

    def __init__(self, path, message) -> None:
        RigInputError.__init__(self, str(path), None, None, message)


class HistoryLocked(HistoryError, OSError):
    """Another process held the database longer than the busy timeout (exit 1)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "history database locked"


def default_path(path=None) -> Path:
    """``path``, else ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``."""
    chosen = path or os.environ.get(ENV_VAR) or DEFAULT_PATH
    return Path(chosen).expanduser()


def _translate(exc: sqlite3.Error, path: Path) -> HistoryError:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    if isinstance(exc, sqlite3.OperationalError) and ("locked" in text or "busy" in text):
        return HistoryLocked(f"{path}: history database is locked by another process ({text}); "
                             "nothing was changed, try again")
    if isinstance(exc, sqlite3.DatabaseError) and not isinstance(exc, sqlite3.OperationalError):
        return HistoryCorrupt(path, f"not a readable rig history database ({text}); it was left untouched")
    if "unable to open" in text or "readonly" in text:
        return HistoryLocked(f"{path}: cannot open the history database ({text})")
    return HistoryCorrupt(path, f"history database error ({text}); it was left untouched")


class History:
    """An open history database (a context manager). Use :func:`open_history`."""

    def __init__(self, path: Path, conn: sqlite3.Connection) -> None:
        self.path, self.conn = path, conn

    def __enter__(self) -> "History":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.conn.close()

    def write(self, fn, *args):
        """Run ``fn(conn, *args)`` in one ``BEGIN IMMEDIATE`` transaction; rolled back on any error."""
        try:
            self.conn.execute("BEGIN IMMEDIATE")
            try:
                out = fn(self.conn, *args)
            except BaseException:
                self.conn.execute("ROLLBACK")
                raise
            self.conn.execute("COMMIT")
            return out
        except sqlite3.Error as exc:
            raise _translate(exc, self.path) from None

    def query(self, sql: str, params=()) -> list[sqlite3.Row]:
        try:
            return self.conn.execute(sql, params).fetchall()
        except sqlite3.Error as exc:
            raise _translate(exc, self.path) from None


def open_history(path=None, *, timeout_s: float = BUSY_TIMEOUT_S, create: bool = True) -> History:
    """Open (and create or migrate) the history database. Raises HistoryCorrupt / HistoryLocked."""
    p = default_path(path)
    if not p.exists() and not create:
        raise HistoryCorrupt(p, "no history database here (nothing recorded yet?)")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        conn = sqlite3.connect(str(p), timeout=timeout_s, isolation_level=None)
    except (OSError, sqlite3.Error) as exc:
        raise HistoryLocked(f"{p}: cannot open the history database ({exc})") from None
    conn.row_factory = sqlite3.Row
    hist = History(p, conn)
    try:
        conn.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
        conn.execute("PRAGMA journal_mode = WAL")
        conn.execute("PRAGMA foreign_keys = ON")
        hist.write(_migrate, p)
    except sqlite3.Error as exc:
        conn.close()
        raise _translate(exc, p) from None
    except HistoryError:
        conn.close()
        raise
    return hist


def _migrate(conn: sqlite3.Connection, path: Path) -> None:
    conn.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
    row = conn.execute("SELECT MAX(version) FROM schema_version").fetchone()
    current = row[0] or 0
    if current > SCHEMA_VERSION:
        raise HistoryCorrupt(path, f"history schema version {current} is newer than this software's "
                                   f"({SCHEMA_VERSION}); upgrade rig")
    for version, steps in MIGRATIONS:
        if version > current:
            for sql in steps:
                conn.execute(sql)
            conn.execute("INSERT INTO schema_version (version) VALUES (?)", (version,))


# ---------------------------------------------------------------------------------------------- parameters

# ---------------------------------------------------------------------------------------------- recording

def _read_manifest(session_dir) -> dict:
    """The session's manifest as a mapping, read as every reader reads it (:meth:`SessionManifest.load`: validated,
    a steps journal folded in)."""
    _, doc = SessionManifest.load(session_dir)
    return doc


def calibration_row(session_dir, calibration_path, *, sensor_id=None, verdict=None, manifest: dict | None = None,
                    calibration=None) -> dict:
    """Everything :func:`record_calibration` stores, as plain data (no database). ``manifest`` (the
    session's manifest as a mapping) and ``calibration`` (the file's content): what the caller holds
    already; each is read from disk only when not given."""
    manifest = manifest if manifest is not None else _read_manifest(session_dir)
    cal = calibration if calibration is not None else calfile.read(calibration_path)
    if verdict is None and cal.acceptance is not None:  # the verdict the file states (rig history --record)
        verdict = "PASS" if cal.acceptance["passed"] else "FAIL"
    sensor = sensor_identity(manifest, cal, sensor_id)
    fit = cal.accelerometer.fit
    temps = temperatures(manifest)
    proc = manifest.get("procedure") or {}
    return {
        "sensor": sensor,
        "calibration": {
            "recorded_at": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "calibrated_at": str(cal.created), "session_id": manifest.get("id") or cal.session,
            "session_path": str(Path(session_dir).resolve()), "calibration_path": str(Path(calibration_path).resolve()),
            "procedure_name": proc.get("name"), "procedure_sha256": proc.get("sha256"),
            "rig": json.dumps(rig_identity(manifest), sort_keys=True),
            "software_version": (cal.software or {}).get("version") or __version__,
            "temp_mean_c": temps[0], "temp_min_c": temps[1], "temp_max_c": temps[2],
            "model": cal.accelerometer.model, "method": fit.method, "steps": fit.steps,
            "residual_rms_g": _fnum(fit.residual_rms_g), "chi2_per_dof": _fnum(fit.chi2_per_dof), "verdict": verdict,
            "seal": seal_json(manifest), "simulated": int(is_simulated(manifest)),
        },
        "parameters": sensor_parameters(cal),
    }


def is_simulated(manifest: dict) -> bool:
    """Whether the session was recorded on the simulated or the replay rig (its turntable kind, e.g.
    ``sim:8smc5-emulator``, ``replay:8smc5-emulator``; a hardware rig's is ``standa-8smc``)."""
    kind = str(rig_identity(manifest).get("kind") or "")
    return kind.split(":")[0] in SIMULATED_RIG_KINDS


#: what makes two records the same calibration: the row's columns but when it was recorded or solved and where
#: the files are (``rig solve`` twice of one session writes the same numbers at another ``created`` time)
SAME_RECORD = ("sensor_key", "session_id", "procedure_name", "procedure_sha256", "rig", "software_version",
               "temp_mean_c", "temp_min_c", "temp_max_c", "model", "method", "steps", "residual_rms_g",
               "chi2_per_dof", "verdict", "simulated")


class Stored(tuple):
    """``(row id, sensor key)`` of a record; ``already``: the calibration was recorded before (that row's id)."""

    already: bool

    def __new__(cls, cid: int, key: str, already: bool = False) -> "Stored":
        out = super().__new__(cls, (cid, key))
        out.already = already
        return out


def _recorded(conn: sqlite3.Connection, c: dict, parameters) -> int | None:
    """The id of a row that holds this calibration already (same session, sensor, fit and parameters), or None.
    A session without an id is never taken for another."""
    if c.get("session_id") is None:
        return None
    want = sorted((str(n), v, s, u) for n, v, s, u in parameters)
    rows = conn.execute(f"SELECT id FROM calibrations WHERE {' AND '.join(f'{k} IS ?' for k in SAME_RECORD)} "
                        "ORDER BY id", tuple(c.get(k) for k in SAME_RECORD)).fetchall()
    for (cid,) in rows:
        have = conn.execute("SELECT name, value, sigma, unit FROM parameters WHERE calibration_id = ? ORDER BY name",
                            (cid,)).fetchall()
        if [tuple(r) for r in have] == want:
            return cid
    return None


def _insert(conn: sqlite3.Connection, row: dict) -> Stored:
    """Insert ``row`` (inside the caller's transaction), unless the history holds the same calibration already:
    a record is idempotent (``rig history --record`` or ``rig solve`` twice of one session adds one row), a
    re-solve that differs is a row of its own."""
    s = row["sensor"]
    c = {"sensor_key": s["key"], **row["calibration"]}
    same = _recorded(conn, c, row["parameters"])
    if same is not None:
        return Stored(same, s["key"], already=True)
    conn.execute("INSERT OR IGNORE INTO sensors (sensor_key, model, address, identity, serial, first_seen) "
                 "VALUES (?, ?, ?, ?, ?, ?)", (s["key"], s["model"], s["address"], s["identity"], s["serial"],
                                               row["calibration"]["recorded_at"]))
    cur = conn.execute(f"INSERT INTO calibrations ({', '.join(c)}) VALUES ({', '.join('?' * len(c))})",
                       tuple(c.values()))
    cid = cur.lastrowid
    conn.executemany("INSERT INTO parameters (calibration_id, name, value, sigma, unit) VALUES (?, ?, ?, ?, ?)",
                     [(cid, *p) for p in row["parameters"]])
    return Stored(cid, s["key"])


def store_calibration(session_dir, calibration_path, *, history=None, sensor_id=None, verdict=None,
                      timeout_s: float = BUSY_TIMEOUT_S, manifest: dict | None = None,
                      calibration=None) -> Stored:
    """Record one calibration; returns (row id, sensor key), a :class:`Stored` whose ``already`` says the
    history held this calibration of this session before (nothing was added: the row's id). Raises
    HistoryError, RigInputError, CalibError. ``manifest``, ``calibration``: as :func:`calibration_row`."""
    row = calibration_row(session_dir, calibration_path, sensor_id=sensor_id, verdict=verdict, manifest=manifest,
                          calibration=calibration)
    return store_row(row, history=history, timeout_s=timeout_s)


def store_row(row: dict, *, history=None, timeout_s: float = BUSY_TIMEOUT_S) -> Stored:
    """Record one :func:`calibration_row` (``sensor``, ``calibration``, ``parameters``) as it is, in one
    transaction: what :func:`store_calibration` does after reading the session (an importer of another lab's
    records, a test building a long history). Raises HistoryError."""
    with open_history(history, timeout_s=timeout_s) as h:
        return h.write(_insert, row)


def record_calibration(session_dir, calibration_path, *, history=None, sensor_id: str | None = None,
                       verdict: str | None = None, timeout_s: float = BUSY_TIMEOUT_S, manifest: dict | None = None,
                       calibration=None) -> str | None:
    """Record a solved calibration in the history; **never raises** (for ``rig run/solve/replay/import``).

    Parameters
    ----------
    session_dir : the session solved (its ``session.yaml`` gives sensor, rig, procedure, temperatures).
    calibration_path : the ``rig-calibration/1`` file written by the solve.
    history : database path (default: ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``).
    sensor_id : a serial or fixture id given by the operator; overrides the key built from the manifest.
    verdict : acceptance verdict (``PASS``/``FAIL``) when the procedure has limits, else None.
    timeout_s : how long to wait for another writer.
    manifest, calibration : the session's manifest (a mapping) and the calibration, when the caller holds
        them (then neither file is read again).

    Returns
    -------
    None when recorded (or recorded before: the same calibration of the same session is one row), else a
    one-line warning (``history not recorded: ...``) for the caller to print;
    the run's own result stands and nothing already stored is lost.
    """
    try:
        store_calibration(session_dir, calibration_path, history=history, sensor_id=sensor_id, verdict=verdict,
                          timeout_s=timeout_s, manifest=manifest, calibration=calibration)
    except Exception as exc:  # noqa: BLE001 - the contract: a history problem never breaks a run
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return f"history not recorded: {first}"
    return record_seal(session_dir, history=history, timeout_s=timeout_s, manifest=manifest)


# ---------------------------------------------------------------------------------------------- seals

def seal_json(manifest: dict) -> str | None:
    """The session's ``seal`` (docs/session-format.md, "Seal") as the history stores it: JSON, keys sorted; None
    when the session has none. A session analysed under ``RIG_UNSEALED=1`` whose seal does not match carries
    ``broken`` (the reader's line) in it."""
    seal = manifest.get("seal")
    return json.dumps(seal, sort_keys=True, default=str) if isinstance(seal, dict) else None


def record_seal(session_dir, *, history=None, timeout_s: float = BUSY_TIMEOUT_S, manifest: dict | None = None) -> str | None:
    """Give the history rows of a session recorded before it was sealed its seal: ``rig run`` solves (and
    records) before it marks the session complete, which seals it. The rows of this session (its directory and
    id) without a seal get the manifest's seal; a seal that did not match (``broken``) is never copied onto
    them. **Never raises**, like :func:`record_calibration`: None when done or nothing to do, else a one-line
    warning. ``manifest``: the session's manifest when the caller holds it (else session.yaml is read)."""
    try:
        manifest = manifest if manifest is not None else _read_manifest(session_dir)
        seal = manifest.get("seal")
        p = default_path(history)
        if not isinstance(seal, dict) or "broken" in seal or not p.exists():
            return None
        with open_history(p, timeout_s=timeout_s, create=False) as h:
            h.write(lambda conn: conn.execute(
                "UPDATE calibrations SET seal = ? WHERE session_path = ? AND session_id IS ? AND seal IS NULL",
                (seal_json(manifest), str(Path(session_dir).resolve()), manifest.get("id"))))
    except Exception as exc:  # noqa: BLE001 - the contract: a history problem never breaks a run
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return f"history seal not recorded: {first}"
    return None


def recorded_seals(session_id: str, *, history=None, timeout_s: float = BUSY_TIMEOUT_S) -> list[dict]:
    """The seals the history holds for session ``session_id``: ``{"recorded_at", "seal"}`` per row with one
    (``rig verify`` compares them with the session's). Empty when there is no history database."""
    p = default_path(history)
    if not p.exists():
        return []
    with open_history(p, timeout_s=timeout_s, create=False) as h:
        rows = h.query("SELECT recorded_at, seal FROM calibrations WHERE session_id = ? AND seal IS NOT NULL "
                       "ORDER BY id", (session_id,))
    out = []
    for r in rows:
        try:
            seal = json.loads(r["seal"])
        except ValueError:
            seal = None
        out.append({"recorded_at": r["recorded_at"], "seal": seal if isinstance(seal, dict) else None})
    return out
