"""Where the calibration history lives and how it is stored (docs/history.md): one SQLite file on the rig's machine
(stdlib ``sqlite3``: a command that records starts without SQLAlchemy) or a server several rigs share through
SQLAlchemy Core (``postgresql+psycopg://...``), the schema migrated by Alembic, a local outbox for a rig that
cannot reach its server. :mod:`rig.lab.history` is the interface the workflows use."""
