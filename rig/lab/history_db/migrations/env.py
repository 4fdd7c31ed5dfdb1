"""Alembic's environment for the history: it migrates on the connection :mod:`rig.lab.history_db.migrate`
passes (``config.attributes["connection"]``), inside that connection's transaction (which holds the writer's
lock: SQLite's ``BEGIN IMMEDIATE``, PostgreSQL's advisory lock), so two rigs never migrate at once."""

from alembic import context

context.configure(connection=context.config.attributes["connection"], transactional_ddl=True)
with context.begin_transaction():
    context.run_migrations()
