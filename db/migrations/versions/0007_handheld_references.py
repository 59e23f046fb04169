"""handheld references: a wheel's profile measured with a handheld gauge

Revision ID: 0007
Revises: 0006
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "handheld_reference",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("wheel_id", sa.Integer(), nullable=False),
        sa.Column("filename", sa.String(length=255), nullable=False),
        sa.Column("sha256", sa.String(length=64), nullable=False),
        sa.Column("instrument", sa.String(length=100), nullable=True),
        sa.Column("measured_on", sa.String(length=60), nullable=True),
        sa.Column("measured_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("x_mm", sa.JSON(), nullable=False),
        sa.Column("z_mm", sa.JSON(), nullable=False),
        sa.Column("z_offset_mm", sa.Float(), nullable=False),
        sa.Column("flange_height_mm", sa.Float(), nullable=False),
        sa.Column("flange_thickness_mm", sa.Float(), nullable=False),
        sa.Column("flange_thickness_en_mm", sa.Float(), nullable=False),
        sa.Column("qr_mm", sa.Float(), nullable=False),
        sa.Column("parameter_quality", sa.String(length=15), nullable=False),
        sa.Column("instrument_flange_height_mm", sa.Float(), nullable=True),
        sa.Column("instrument_flange_thickness_mm", sa.Float(), nullable=True),
        sa.Column("instrument_qr_mm", sa.Float(), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["wheel_id"],
            ["wheel.id"],
            name=op.f("fk_handheld_reference_wheel_id_wheel"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_handheld_reference")),
        sa.UniqueConstraint(
            "wheel_id", "sha256", name=op.f("uq_handheld_reference_wheel_id_sha256")
        ),
    )
    op.create_index(
        op.f("ix_handheld_reference_wheel_id"), "handheld_reference", ["wheel_id"], unique=False
    )


def downgrade() -> None:
    op.drop_index(op.f("ix_handheld_reference_wheel_id"), table_name="handheld_reference")
    op.drop_table("handheld_reference")
