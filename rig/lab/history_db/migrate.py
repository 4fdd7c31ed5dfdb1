"""Bringing a history's schema to :data:`~rig.lab.history_db.schema.SCHEMA_VERSION` with Alembic (imported only
when a migration is needed: a history at the current version is checked with one query and opened without it,
and a new SQLite file is created by :meth:`~rig.lab.history_db.sqlite_file.SqliteFile.create`, the same steps
stamped at the head revision).

A history written before Alembic (a ``schema_version`` table, no ``alembic_version``) is stamped at its version
first, then upgraded like any other. The whole migration is one transaction holding the writers' lock (SQLite
``BEGIN IMMEDIATE``, PostgreSQL's advisory lock), and the version is read again under it: two rigs opening a new
history at once migrate it once."""

from __future__ import annotations

from pathlib import Path

import sqlalchemy as sa
from alembic import command
from alembic.config import Config

from rig.lab.history_db.errors import HistoryCorrupt
from rig.lab.history_db.schema import SCHEMA_VERSION, revision
from rig.lab.history_db.server import WRITER_LOCK, engine, translate

SCRIPTS = Path(__file__).resolve().parent / "migrations"


def upgrade(db, timeout_s: float) -> None:
    """Migrate the history ``db`` (an open driver: its file, or its URL) to the current schema, on a connection of
    its own. Raises HistoryCorrupt (a newer schema, a database that is not a history), HistoryLocked."""
    where = db.where
    url = sa.engine.URL.create("sqlite", database=str(db.path)) if db.path is not None else db.url
    eng = engine(url, timeout_s)
    try:
        with eng.begin() as conn:
            _upgrade(conn, where)
    except sa.exc.SQLAlchemyError as exc:
        raise translate(exc, where) from None
    finally:
        eng.dispose()


def _upgrade(conn, where: str) -> None:
    postgresql = conn.dialect.name == "postgresql"
    if postgresql:
        conn.exec_driver_sql(f"SELECT pg_advisory_xact_lock({WRITER_LOCK})")
    tables = set(conn.dialect.get_table_names(conn))
    current = conn.exec_driver_sql("SELECT MAX(version) FROM schema_version").scalar() or 0 \
        if "schema_version" in tables else 0
    if current > SCHEMA_VERSION:
        raise HistoryCorrupt(where, f"history schema version {current} is newer than this software's "
                                    f"({SCHEMA_VERSION}); upgrade rig")
    cfg = Config()
    cfg.set_main_option("script_location", str(SCRIPTS))
    cfg.attributes["connection"] = conn
    if current and "alembic_version" not in tables:  # written before Alembic: its version is its revision
        command.stamp(cfg, revision(current))
    command.upgrade(cfg, "head")
