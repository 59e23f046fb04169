"""pass odometer: the vehicles' odometer readings at a pass, {vehicle_id: km}

Revision ID: 0010
Revises: 0009
Create Date: 2026-12-02
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0010"
down_revision = "0009"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.add_column(sa.Column("odometer_km", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.drop_column("odometer_km")
