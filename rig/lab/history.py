"""The calibration history: every calibration, per sensor (docs/history.md), in one embedded SQLite file or on a
PostgreSQL server several rigs share.

Where: ``--history PATH|URL``, else ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``
(:func:`default_path`); a URL (``postgresql+psycopg://user@host/db``) is opened through SQLAlchemy Core, a path
through the standard library's ``sqlite3`` (:mod:`rig.lab.history_db`). The schema is versioned (table
``schema_version``, the steps :data:`MIGRATIONS`) and migrated by Alembic when it is older, in one transaction
holding the writers' lock. SQLite: WAL journal and a busy timeout; PostgreSQL: its lock timeout and an advisory
lock per write: two writers (two rigs) wait for each other instead of failing; every write is one transaction, so
a crash or a refused write leaves what was stored.

:func:`record_calibration` is the one call the workflows make after a solve: it never raises for a database
problem (it returns a one-line warning instead); a server that cannot be reached gets the record later, from the
local outbox (:mod:`rig.lab.history_db.outbox`), the next time this rig opens it. :func:`open_history` and the
readers raise :class:`HistoryCorrupt` (exit 2: not a database / damaged) or :class:`HistoryLocked` (exit 1).
"""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

from calib.file import calibration as calfile
from calib.file.parameters import finite_or_none as _fnum
from calib.file.parameters import sensor_parameters
from rig import __version__
from rig.lab.history_db import outbox
from rig.lab.history_db.database import BUSY_TIMEOUT_S, History, open_db
from rig.lab.history_db.errors import HistoryCorrupt, HistoryError, HistoryLocked, HistoryUnreachable, first_line
from rig.lab.history_db.location import DEFAULT_PATH, ENV_VAR, HistoryURL, default_path, outbox_path
from rig.lab.history_db.records import SAME_RECORD, Stored, insert, set_seal
from rig.lab.history_db.schema import MIGRATIONS, SCHEMA_VERSION
from rig.lab.identity import rig_identity, sensor_identity, temperatures
from rig.session.manifest import SessionManifest

__all__ = ["BUSY_TIMEOUT_S", "DEFAULT_PATH", "ENV_VAR", "MIGRATIONS", "SAME_RECORD", "SCHEMA_VERSION", "History",
           "HistoryCorrupt", "HistoryError", "HistoryLocked", "HistoryURL", "HistoryUnreachable", "Stored",
           "calibration_row", "default_path", "is_simulated", "open_history", "record_calibration", "record_seal",
           "recorded_seals", "seal_json", "store_calibration", "store_row"]

#: the turntable kinds (``rig.turntable.kind`` of the manifest, before any ``:``) of a simulated rig
SIMULATED_RIG_KINDS = ("sim", "replay")


def open_history(path=None, *, timeout_s: float = BUSY_TIMEOUT_S, create: bool = True) -> History:
    """Open (and create or migrate) the history database. Raises HistoryCorrupt / HistoryLocked
    (HistoryUnreachable: a server that did not answer). A server's history first gets what this rig's outbox
    holds for it (:func:`rig.lab.history_db.outbox.sync`; a sync broken off leaves the rest for the next time)."""
    where = default_path(path)
    if isinstance(where, HistoryURL) and outbox_path(where.url).exists():
        create = True  # a new server database gets what this rig kept for it
    h = open_db(where, timeout_s=timeout_s, create=create)
    if h.on_server:
        outbox.sync_quietly(h, timeout_s)
    return h


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
        return h.write(insert, row)


def record_calibration(session_dir, calibration_path, *, history=None, sensor_id: str | None = None,
                       verdict: str | None = None, timeout_s: float = BUSY_TIMEOUT_S, manifest: dict | None = None,
                       calibration=None) -> str | None:
    """Record a solved calibration in the history; **never raises** (for ``rig run/solve/replay/import``).

    Parameters
    ----------
    session_dir : the session solved (its ``session.yaml`` gives sensor, rig, procedure, temperatures).
    calibration_path : the ``rig-calibration/1`` file written by the solve.
    history : database path or URL (default: ``$RIG_HISTORY``, else ``~/.local/share/rig/history.sqlite``).
    sensor_id : a serial or fixture id given by the operator; overrides the key built from the manifest.
    verdict : acceptance verdict (``PASS``/``FAIL``) when the procedure has limits, else None.
    timeout_s : how long to wait for another writer.
    manifest, calibration : the session's manifest (a mapping) and the calibration, when the caller holds
        them (then neither file is read again).

    Returns
    -------
    None when recorded (or recorded before: the same calibration of the same session is one row), else a
    one-line warning (``history not recorded: ...``; for a server that could not be reached or was busy,
    ``history server not reached: ...; kept in the outbox PATH, sent the next time this rig opens the history``)
    for the caller to print; the run's own result stands and nothing already stored is lost.
    """
    try:
        manifest = manifest if manifest is not None else _read_manifest(session_dir)
        row = calibration_row(session_dir, calibration_path, sensor_id=sensor_id, verdict=verdict, manifest=manifest,
                              calibration=calibration)
        where = default_path(history)
        try:
            store_row(row, history=where, timeout_s=timeout_s)
        except HistoryLocked as exc:
            if not _server_url(where):
                raise
            path, _ = outbox.keep(where.url, row, timeout_s)
            return (f"history server not reached: {first_line(exc)}; kept in the outbox {path}, sent the next time "
                    "this rig opens the history")
    except Exception as exc:  # noqa: BLE001 - the contract: a history problem never breaks a run
        return f"history not recorded: {first_line(exc)}"
    return record_seal(session_dir, history=history, timeout_s=timeout_s, manifest=manifest)


def _server_url(where) -> bool:
    """Whether ``where`` (:func:`default_path`) is a server's history (a URL other than ``sqlite:``)."""
    return isinstance(where, HistoryURL) and not where.url.startswith("sqlite")


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
    them. A server that cannot be reached: the rows in its outbox get it. **Never raises**, like
    :func:`record_calibration`: None when done or nothing to do, else a one-line warning. ``manifest``: the
    session's manifest when the caller holds it (else session.yaml is read)."""
    try:
        manifest = manifest if manifest is not None else _read_manifest(session_dir)
        seal = manifest.get("seal")
        where = default_path(history)
        if not isinstance(seal, dict) or "broken" in seal or not where.exists():
            return None
        args = (seal_json(manifest), str(Path(session_dir).resolve()), manifest.get("id"))
        try:
            with open_history(where, timeout_s=timeout_s, create=False) as h:
                h.write(set_seal, *args)
        except HistoryLocked:
            if not (_server_url(where) and outbox.seal_kept(where.url, *args, timeout_s=timeout_s)):
                raise
    except Exception as exc:  # noqa: BLE001 - the contract: a history problem never breaks a run
        return f"history seal not recorded: {first_line(exc)}"
    return None


def recorded_seals(session_id: str, *, history=None, timeout_s: float = BUSY_TIMEOUT_S) -> list[dict]:
    """The seals the history holds for session ``session_id``: ``{"recorded_at", "seal"}`` per row with one
    (``rig verify`` compares them with the session's). Empty when there is no history database."""
    where = default_path(history)
    if not where.exists():
        return []
    with open_history(where, timeout_s=timeout_s, create=False) as h:
        rows = h.query("SELECT recorded_at, seal FROM calibrations WHERE session_id = :sid AND seal IS NOT NULL "
                       "ORDER BY id", {"sid": session_id})
    out = []
    for r in rows:
        try:
            seal = json.loads(r["seal"])
        except ValueError:
            seal = None
        out.append({"recorded_at": r["recorded_at"], "seal": seal if isinstance(seal, dict) else None})
    return out
