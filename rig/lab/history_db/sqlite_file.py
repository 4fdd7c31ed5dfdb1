"""A history in one SQLite file, through the standard library's ``sqlite3`` (a command that records a calibration
starts without importing SQLAlchemy: docs/history.md, "Start-up"). WAL journal, a busy timeout, every write one
``BEGIN IMMEDIATE`` transaction. The SQL is the same the server driver runs (named ``:parameters``)."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

from rig.lab.history_db.errors import HistoryCorrupt, HistoryError, HistoryLocked, first_line
from rig.lab.history_db.schema import ALEMBIC_TABLE, MIGRATIONS, SCHEMA_VERSION, VERSION_TABLE, revision


def translate(exc: sqlite3.Error, path: Path) -> HistoryError:
    """A ``sqlite3`` error as the history's one-line error (locked: exit 1; not a database, damaged: exit 2)."""
    text = first_line(exc)
    if isinstance(exc, sqlite3.OperationalError) and ("locked" in text or "busy" in text):
        return HistoryLocked(f"{path}: history database is locked by another process ({text}); "
                             "nothing was changed, try again")
    if isinstance(exc, sqlite3.DatabaseError) and not isinstance(exc, sqlite3.OperationalError):
        return HistoryCorrupt(path, f"not a readable rig history database ({text}); it was left untouched")
    if "unable to open" in text or "readonly" in text:
        return HistoryLocked(f"{path}: cannot open the history database ({text})")
    return HistoryCorrupt(path, f"history database error ({text}); it was left untouched")


class SqliteFile:
    """An open history file: :meth:`query`, :meth:`write` (one transaction), :meth:`version`."""

    dialect = "sqlite"
    #: the parameters' insertion order (a parameter table has no column for it)
    row_order = "rowid"
    #: NULL-safe equality
    same = "IS"

    def __init__(self, path: Path, timeout_s: float) -> None:
        self.path, self.where, self.timeout_s = path, str(path), timeout_s
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self.conn = sqlite3.connect(str(path), timeout=timeout_s, isolation_level=None)
        except (OSError, sqlite3.Error) as exc:
            raise HistoryLocked(f"{path}: cannot open the history database ({exc})") from None
        self.conn.row_factory = sqlite3.Row
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                self.conn.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
                self.conn.execute("PRAGMA journal_mode = WAL")
                self.conn.execute("PRAGMA foreign_keys = ON")
                break
            except sqlite3.OperationalError as exc:
                # a database another writer is creating or switching to WAL answers "locked" at once, without
                # the busy handler (seen with two writers starting on an empty file): wait for it as a writer does
                if _busy(exc) and time.monotonic() < deadline:
                    time.sleep(0.02)
                    continue
                self.conn.close()
                raise translate(exc, path) from None
            except sqlite3.Error as exc:
                self.conn.close()
                raise translate(exc, path) from None

    def close(self) -> None:
        self.conn.close()

    def execute(self, sql: str, params=None) -> list:
        """Inside :meth:`write`'s transaction: run ``sql`` and return its rows."""
        return self.conn.execute(sql, params or {}).fetchall()

    def write(self, fn, *args):
        """Run ``fn(self, *args)`` in one ``BEGIN IMMEDIATE`` transaction; rolled back on any error."""
        try:
            self.conn.execute("BEGIN IMMEDIATE")
            try:
                out = fn(self, *args)
            except BaseException:
                self.conn.execute("ROLLBACK")
                raise
            self.conn.execute("COMMIT")
            return out
        except sqlite3.Error as exc:
            raise translate(exc, self.path) from None

    def query(self, sql: str, params=None, raw_text: bool = False) -> list[sqlite3.Row]:
        """The rows of ``sql``; ``raw_text``: text read as bytes (decoded by the caller, so text that is not UTF-8
        is a note instead of an error of the whole query)."""
        before = self.conn.text_factory
        if raw_text:
            self.conn.text_factory = bytes
        try:
            return self.conn.execute(sql, params or {}).fetchall()
        except sqlite3.Error as exc:
            raise translate(exc, self.path) from None
        finally:
            self.conn.text_factory = before

    def version(self) -> int | None:
        """The schema version (``MAX(version)`` of ``schema_version``); None: no history here yet."""
        try:
            row = self.conn.execute("SELECT MAX(version) FROM schema_version").fetchone()
        except sqlite3.OperationalError as exc:
            if "no such table" in str(exc):
                return None
            raise translate(exc, self.path) from None
        except sqlite3.Error as exc:
            raise translate(exc, self.path) from None
        return row[0] or 0

    def execute_many(self, sql: str, rows: list[dict]) -> None:
        """Inside :meth:`write`'s transaction: run ``sql`` once per row of parameters."""
        self.conn.executemany(sql, rows)

    def insert_id(self, sql: str, params: dict) -> int:
        """Inside :meth:`write`'s transaction: run the ``INSERT`` ``sql``; the new row's id (``lastrowid``: no
        ``RETURNING``, which SQLite has only since 3.35)."""
        return self.conn.execute(sql, params).lastrowid

    def create(self) -> None:
        """Create the schema in a new file, without Alembic (a first record starts as fast as any other): every
        step of :data:`MIGRATIONS` and the Alembic revision they make, stamped, in one ``BEGIN IMMEDIATE``
        transaction; what Alembic makes of an empty file (``tests/rig/lab/test_history_backends.py`` compares
        the two). Nothing when another process created it meanwhile."""
        def steps(tx) -> None:
            if tx.version() is not None:
                return
            tx.conn.execute(VERSION_TABLE)
            for version, sqls in MIGRATIONS:
                for sql in sqls:
                    tx.conn.execute(sql)
                tx.conn.execute("INSERT INTO schema_version (version) VALUES (?)", (version,))
            tx.conn.execute(ALEMBIC_TABLE)
            tx.conn.execute("INSERT INTO alembic_version (version_num) VALUES (?)", (revision(SCHEMA_VERSION),))
        self.write(steps)


def _busy(exc: sqlite3.Error) -> bool:
    """Whether SQLite said another connection holds the database (locked, busy), which waiting may end."""
    text = str(exc).lower()
    return "locked" in text or "busy" in text
