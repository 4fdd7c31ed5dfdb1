"""The outbox: what a rig recorded while its history server could not be reached, kept in a local SQLite history
(:func:`~rig.lab.history_db.location.outbox_path`: one per server, beside the default history) and sent to the
server the next time this rig opens it (:func:`sync`, called by :func:`rig.lab.history.open_history`).

Sending is idempotent: each calibration is stored on the server by the same insert as any record (the same
calibration of the same session is one row), then removed from the outbox; a sync broken off (the server gone
again, the command killed) leaves the rest, and a calibration sent whose removal was lost is found on the server
the next time and only removed."""

from __future__ import annotations

from pathlib import Path

from rig.lab.history_db.database import BUSY_TIMEOUT_S, History, open_db
from rig.lab.history_db.errors import HistoryError
from rig.lab.history_db.location import outbox_path
from rig.lab.history_db.records import Stored, insert, set_seal, stored_row


def keep(url: str, row: dict, timeout_s: float = BUSY_TIMEOUT_S) -> tuple[Path, Stored]:
    """Store ``row`` (a :func:`rig.lab.history.calibration_row`) in the outbox of server ``url``; returns the
    outbox's path and the record there. Raises HistoryError when even the outbox cannot take it."""
    path = outbox_path(url)
    with open_db(path, timeout_s=timeout_s) as box:
        return path, box.write(insert, row)


def seal_kept(url: str, seal: str, session_path: str, session_id, timeout_s: float = BUSY_TIMEOUT_S) -> bool:
    """Give the outbox's rows of a session their seal (the server could not be reached to take it); False when
    there is no outbox."""
    path = outbox_path(url)
    if not path.exists():
        return False
    with open_db(path, timeout_s=timeout_s, create=False) as box:
        box.write(set_seal, seal, session_path, session_id)
    return True


def pending(url: str) -> int:
    """How many calibrations wait in the outbox of server ``url``."""
    path = outbox_path(url)
    if not path.exists():
        return 0
    with open_db(path, create=False) as box:
        return box.query("SELECT COUNT(*) FROM calibrations")[0][0]


def _send(tx, row: dict) -> Stored:
    stored = insert(tx, row)
    seal = row["calibration"].get("seal")
    if stored.already and seal is not None:  # sent before its seal was: the seal now
        tx.execute("UPDATE calibrations SET seal = :seal WHERE id = :cid AND seal IS NULL", {"seal": seal,
                                                                                            "cid": stored[0]})
    return stored


def _forget(tx, cid: int) -> None:
    tx.execute("DELETE FROM parameters WHERE calibration_id = :cid", {"cid": cid})
    tx.execute("DELETE FROM calibrations WHERE id = :cid", {"cid": cid})
    tx.execute("DELETE FROM sensors WHERE sensor_key NOT IN (SELECT sensor_key FROM calibrations)")


def sync(server: History, timeout_s: float = BUSY_TIMEOUT_S) -> int:
    """Send every calibration in the outbox of ``server`` (open) to it, oldest first, each in a transaction of
    its own and removed from the outbox once the server holds it; returns how many were sent. Raises HistoryError
    (what was sent stays sent, the rest stays in the outbox)."""
    path = outbox_path(server.url)
    if not path.exists():
        return 0
    sent = 0
    with open_db(path, timeout_s=timeout_s, create=False) as box:
        for (cid,) in box.query("SELECT id FROM calibrations ORDER BY id"):
            row = box.write(stored_row, cid)
            if row is None:  # sent by another command of this rig meanwhile
                continue
            server.write(_send, row)
            box.write(_forget, cid)
            sent += 1
    return sent


def sync_quietly(server: History, timeout_s: float = BUSY_TIMEOUT_S) -> int | str:
    """:func:`sync`, never raising: the number sent, or the one-line reason it stopped."""
    try:
        return sync(server, timeout_s)
    except HistoryError as exc:
        return str(exc)
