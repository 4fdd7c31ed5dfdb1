"""Opening a history: the driver its location calls for (a path: stdlib ``sqlite3``; a URL: SQLAlchemy), the
schema version checked with one query, Alembic run only when the schema is older (:mod:`.migrate`)."""

from __future__ import annotations

from rig.lab.history_db.errors import HistoryCorrupt
from rig.lab.history_db.location import HistoryURL, default_path
from rig.lab.history_db.schema import SCHEMA_VERSION
from rig.lab.history_db.sqlite_file import SqliteFile

BUSY_TIMEOUT_S = 30.0


class History:
    """An open history database (a context manager). Use :func:`rig.lab.history.open_history`.

    ``db``: the driver (:class:`~.sqlite_file.SqliteFile` or :class:`~.server.Server`); ``path``: the file, or the
    server's URL with its password masked (what messages name)."""

    def __init__(self, db) -> None:
        self.db = db
        self.path = db.path if db.path is not None else db.where
        self.url = getattr(db, "url", None)

    def __enter__(self) -> "History":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.db.close()

    @property
    def on_server(self) -> bool:
        """Whether the history is a server's (a URL other than ``sqlite:``): a record it cannot take goes to the
        outbox."""
        return self.url is not None and self.db.dialect != "sqlite"

    def write(self, fn, *args):
        """Run ``fn(tx, *args)`` in one transaction (``tx.execute(sql, params)``); rolled back on any error."""
        return self.db.write(fn, *args)

    def query(self, sql: str, params=None, raw_text: bool = False) -> list:
        """The rows of ``sql`` (named ``:parameters``); they read by position and by column name."""
        return self.db.query(sql, params, raw_text)


def open_db(location=None, *, timeout_s: float = BUSY_TIMEOUT_S, create: bool = True) -> History:
    """Open (and create or migrate) the history at ``location`` (a path or a URL; default :func:`default_path`).
    Raises HistoryCorrupt / HistoryLocked (HistoryUnreachable: the server did not answer)."""
    where = default_path(location)
    if isinstance(where, HistoryURL):
        from rig.lab.history_db.server import Server

        db = Server(where.url, timeout_s)
    else:
        if not where.exists() and not create:
            raise HistoryCorrupt(where, "no history database here (nothing recorded yet?)")
        db = SqliteFile(where, timeout_s)
    try:
        version = db.version()
        if version is None and not create and db.path is None:
            raise HistoryCorrupt(db.where, "no rig history in this database (nothing recorded yet?)")
        if (version or 0) > SCHEMA_VERSION:
            raise HistoryCorrupt(db.where, f"history schema version {version} is newer than this software's "
                                           f"({SCHEMA_VERSION}); upgrade rig")
        if version is None and db.path is not None:  # a new file: the steps and the stamp, no Alembic to import
            db.create()
            version = db.version()
        if version != SCHEMA_VERSION:
            from rig.lab.history_db.migrate import upgrade

            upgrade(db, timeout_s)
    except BaseException:
        db.close()
        raise
    return History(db)
