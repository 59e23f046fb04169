"""dispositions, measurement margins and the fleet's review thresholds

Revision ID: 0006
Revises: 0005
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("fleet_limit", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("near_limit_fraction", sa.Float(), nullable=False, server_default="0.1")
        )
        batch_op.add_column(
            sa.Column("method_disagreement_mm", sa.Float(), nullable=False, server_default="0.5")
        )
    op.create_table(
        "measurement_margin",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("measurement_id", sa.Integer(), nullable=False),
        sa.Column("parameter", sa.String(length=40), nullable=False),
        sa.Column("value_mm", sa.Float(), nullable=False),
        sa.Column("bound", sa.String(length=3), nullable=False),
        sa.Column("limit_mm", sa.Float(), nullable=False),
        sa.Column("margin_mm", sa.Float(), nullable=False),
        sa.Column("band_mm", sa.Float(), nullable=False),
        sa.Column("margin_fraction", sa.Float(), nullable=False),
        sa.Column("level", sa.String(length=5), nullable=False),
        sa.Column("nearest", sa.Boolean(), nullable=False),
        sa.ForeignKeyConstraint(
            ["measurement_id"],
            ["measurement.id"],
            name=op.f("fk_measurement_margin_measurement_id_measurement"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_measurement_margin")),
        sa.UniqueConstraint(
            "measurement_id",
            "parameter",
            name=op.f("uq_measurement_margin_measurement_id_parameter"),
        ),
    )
    op.create_table(
        "disposition",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("pass_wheel_id", sa.Integer(), nullable=False),
        sa.Column("kind", sa.String(length=25), nullable=False),
        sa.Column("comment", sa.Text(), nullable=True),
        sa.Column("actor", sa.String(length=100), nullable=False),
        sa.Column("token_id", sa.Integer(), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["pass_wheel_id"],
            ["pass_wheel.id"],
            name=op.f("fk_disposition_pass_wheel_id_pass_wheel"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["token_id"],
            ["api_token.id"],
            name=op.f("fk_disposition_token_id_api_token"),
            ondelete="SET NULL",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_disposition")),
    )
    op.create_index(
        op.f("ix_disposition_pass_wheel_id"), "disposition", ["pass_wheel_id"], unique=False
    )


def downgrade() -> None:
    op.drop_index(op.f("ix_disposition_pass_wheel_id"), table_name="disposition")
    op.drop_table("disposition")
    op.drop_table("measurement_margin")
    with op.batch_alter_table("fleet_limit", schema=None) as batch_op:
        batch_op.drop_column("method_disagreement_mm")
        batch_op.drop_column("near_limit_fraction")
