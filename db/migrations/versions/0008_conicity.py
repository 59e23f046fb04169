"""conicity: tread and rim parameters, axle equivalent conicity, its limit, site rails

Revision ID: 0008
Revises: 0007
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None

MEASUREMENT_COLUMNS = (
    ("tread_hollow_mm", sa.Float()),
    ("flange_angle_deg", sa.Float()),
    ("rim_width_mm", sa.Float()),
    ("tread_reason", sa.Text()),
    ("equivalent_conicity", sa.Float()),
    ("conicity", sa.JSON()),
)


def upgrade() -> None:
    with op.batch_alter_table("measurement", schema=None) as batch_op:
        for name, kind in MEASUREMENT_COLUMNS:
            batch_op.add_column(sa.Column(name, kind, nullable=True))
    with op.batch_alter_table("fleet_limit", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("conicity_max", sa.Float(), nullable=False, server_default="0.4")
        )
    with op.batch_alter_table("site", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("rail_profile", sa.String(10), nullable=False, server_default="60E1")
        )
        batch_op.add_column(
            sa.Column("rail_inclination", sa.String(5), nullable=False, server_default="1:40")
        )
        batch_op.add_column(
            sa.Column("gauge_mm", sa.Float(), nullable=False, server_default="1435.0")
        )


def downgrade() -> None:
    with op.batch_alter_table("site", schema=None) as batch_op:
        for name in ("gauge_mm", "rail_inclination", "rail_profile"):
            batch_op.drop_column(name)
    with op.batch_alter_table("fleet_limit", schema=None) as batch_op:
        batch_op.drop_column("conicity_max")
    with op.batch_alter_table("measurement", schema=None) as batch_op:
        for name, _kind in reversed(MEASUREMENT_COLUMNS):
            batch_op.drop_column(name)
