"""pre-rendered layers

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-23
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("measurement_frame", schema=None) as batch_op:
        batch_op.add_column(sa.Column("mask_png_sha256", sa.String(length=64), nullable=True))
        batch_op.add_column(sa.Column("sigma_png_sha256", sa.String(length=64), nullable=True))
        batch_op.add_column(sa.Column("sigma_min_px", sa.Float(), nullable=True))
        batch_op.add_column(sa.Column("sigma_max_px", sa.Float(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("measurement_frame", schema=None) as batch_op:
        batch_op.drop_column("sigma_max_px")
        batch_op.drop_column("sigma_min_px")
        batch_op.drop_column("sigma_png_sha256")
        batch_op.drop_column("mask_png_sha256")
