"""History schema version 3 (rig.lab.history_db.schema.MIGRATIONS)."""

from alembic import op

from rig.lab.history_db.schema import apply, revision as _rev

revision = _rev(3)
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    apply(op, 3)


def downgrade() -> None:
    raise NotImplementedError("the history is never migrated down: an older rig refuses a newer history")
