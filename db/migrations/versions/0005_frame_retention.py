"""frame retention: when a pass's raw frames were removed

Revision ID: 0005
Revises: 0004
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("frames_removed_at", sa.DateTime(timezone=True), nullable=True)
        )


def downgrade() -> None:
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.drop_column("frames_removed_at")
