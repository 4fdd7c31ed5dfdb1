"""A history behind SQLAlchemy Core: a server several rigs share (``postgresql+psycopg://user@host/db``) or a
SQLite file named by URL (``sqlite:///path``). This module (and with it SQLAlchemy) is imported only when such a
history is opened, or one is migrated (docs/history.md, "Start-up").

The SQL is the file driver's (named ``:parameters``); what differs is spelt by attributes (:attr:`Server.same`,
:attr:`Server.row_order`). The busy timeout is PostgreSQL's ``lock_timeout``; writers take one advisory lock per
transaction, so two rigs recording at once wait for each other as on SQLite (``BEGIN IMMEDIATE``) and a record is
never stored twice."""

from __future__ import annotations

import sqlite3
import time

import sqlalchemy as sa
from sqlalchemy.pool import NullPool

from rig.lab.history_db.errors import HistoryCorrupt, HistoryError, HistoryLocked, HistoryUnreachable, first_line
from rig.lab.history_db.location import masked
from rig.lab.history_db.sqlite_file import translate as sqlite_translate

#: the advisory lock every writer of a PostgreSQL history holds for its transaction ("righ" in ASCII)
WRITER_LOCK = 0x72696768
#: SQLSTATEs of a wait that ran out or a transaction the server broke off to let another through: try again
_BUSY = {"55P03", "40P01", "40001", "57014", "55006"}
#: a server whose connection attempt ran into the connect timeout is not asked again for this long by this process:
#: one command (the record, the seal, the acceptance limit, the report) waits once, not once per use
SLOW_FAILURE_S = 60.0
_slow_failures: dict[str, tuple[float, str]] = {}


class Row(tuple):
    """A result row as ``sqlite3.Row`` reads: by position and by column name; ``keys()``."""

    def __new__(cls, keys: tuple, values) -> "Row":
        out = super().__new__(cls, values)
        out._names = keys
        return out

    def keys(self) -> list[str]:
        return list(self._names)

    def __getitem__(self, key):
        return tuple.__getitem__(self, self._names.index(key) if isinstance(key, str) else key)


def translate(exc: Exception, where: str) -> HistoryError:
    """A SQLAlchemy (DBAPI) error as the history's one-line error: the server not reached and a wait that ran out
    exit 1 (the record goes to the outbox), anything else is the database's problem (exit 2)."""
    orig = getattr(exc, "orig", None) or exc
    if isinstance(orig, sqlite3.Error):
        return sqlite_translate(orig, where)
    code, text = getattr(orig, "sqlstate", None), first_line(orig)
    if code in _BUSY:
        return HistoryLocked(f"{where}: history database is locked by another process ({text}); "
                             "nothing was changed, try again")
    if code is None or code.startswith(("08", "28", "3D", "57P")):
        return HistoryUnreachable(f"{where}: cannot reach the history server ({text})")
    return HistoryCorrupt(where, f"not a readable rig history database ({text}); it was left untouched")


def engine(url: str, timeout_s: float):
    """A SQLAlchemy engine for ``url`` without a pool (a command holds one connection): on PostgreSQL a connect
    timeout and the lock timeout, on SQLite the busy timeout, WAL and ``BEGIN IMMEDIATE``."""
    u = sa.engine.make_url(url)
    if u.get_backend_name() == "sqlite":
        eng = sa.create_engine(u, poolclass=NullPool, connect_args={"timeout": timeout_s})
        sa.event.listen(eng, "connect", lambda dbapi, _: _sqlite_connected(dbapi, timeout_s))
        sa.event.listen(eng, "begin", lambda conn: conn.exec_driver_sql("BEGIN IMMEDIATE"))
        return eng
    ms = int(timeout_s * 1000)
    return sa.create_engine(u, poolclass=NullPool, connect_args={
        "connect_timeout": max(2, min(5, int(timeout_s))), "options": f"-c lock_timeout={ms}",
        "application_name": "rig"})


def _sqlite_connected(dbapi_conn, timeout_s: float) -> None:
    dbapi_conn.isolation_level = None  # the transactions are SQLAlchemy's "begin" event: BEGIN IMMEDIATE
    for pragma in (f"busy_timeout = {int(timeout_s * 1000)}", "journal_mode = WAL", "foreign_keys = ON"):
        dbapi_conn.execute(f"PRAGMA {pragma}")


class Server:
    """An open history behind SQLAlchemy: :meth:`query`, :meth:`write` (one transaction), :meth:`version`."""

    def __init__(self, url: str, timeout_s: float) -> None:
        self.url, self.where, self.path, self.timeout_s = url, masked(url), None, timeout_s
        self._text = sa.text
        failed = _slow_failures.get(url)
        if failed is not None and time.monotonic() - failed[0] < SLOW_FAILURE_S:
            raise HistoryUnreachable(failed[1])
        started = time.monotonic()
        try:
            self.engine = engine(url, timeout_s)
            self.dialect = self.engine.dialect.name
            self.conn = self.engine.connect()
        except sa.exc.ArgumentError as exc:
            raise HistoryCorrupt(self.where, f"not a history database URL ({first_line(exc)})") from None
        except ImportError as exc:  # the driver (psycopg) is an extra: the record waits in the outbox meanwhile
            raise HistoryUnreachable(f"{self.where}: the database driver is not installed ({first_line(exc)}; "
                                     "pip install 'rig-calibration[postgresql]')") from None
        except sa.exc.SQLAlchemyError as exc:
            error = translate(exc, self.where)
            if isinstance(error, HistoryUnreachable) and time.monotonic() - started > 1.0:
                _slow_failures[url] = (time.monotonic(), str(error))
            raise error from None
        self.same = "IS NOT DISTINCT FROM" if self.dialect == "postgresql" else "IS"
        self.row_order = "ctid" if self.dialect == "postgresql" else "rowid"

    def close(self) -> None:
        try:
            self.conn.close()
        finally:
            self.engine.dispose()

    def execute(self, sql: str, params=None) -> list[Row]:
        """Inside :meth:`write`'s transaction: run ``sql`` and return its rows."""
        result = self.conn.execute(self._text(sql), params or {})
        if not result.returns_rows:
            return []
        keys = tuple(result.keys())
        return [Row(keys, r) for r in result]

    def write(self, fn, *args):
        """Run ``fn(self, *args)`` in one transaction holding the writers' lock; rolled back on any error."""
        try:
            with self.conn.begin():
                if self.dialect == "postgresql":
                    self.conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({WRITER_LOCK})")
                return fn(self, *args)
        except sa.exc.SQLAlchemyError as exc:
            raise translate(exc, self.where) from None

    def query(self, sql: str, params=None, raw_text: bool = False) -> list[Row]:
        """The rows of ``sql`` (read in a transaction of their own). ``raw_text``: ignored (a server's text is
        always valid UTF-8)."""
        try:
            with self.conn.begin():
                return self.execute(sql, params)
        except sa.exc.SQLAlchemyError as exc:
            raise translate(exc, self.where) from None

    def version(self) -> int | None:
        """The schema version (``MAX(version)`` of ``schema_version``); None: no history in this database yet."""
        probe = ("SELECT to_regclass('schema_version') IS NOT NULL" if self.dialect == "postgresql" else
                 "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'")
        if not self.query(probe)[0][0]:
            return None
        return self.query("SELECT MAX(version) FROM schema_version")[0][0] or 0

    def execute_many(self, sql: str, rows: list[dict]) -> None:
        """Inside :meth:`write`'s transaction: run ``sql`` once per row of parameters."""
        if rows:
            self.conn.execute(self._text(sql), rows)

    def insert_id(self, sql: str, params: dict) -> int:
        """Inside :meth:`write`'s transaction: run the ``INSERT`` ``sql``; the new row's id."""
        return self.execute(sql + " RETURNING id", params)[0][0]
