"""sd 10 name: flange_thickness_en_mm is flange_thickness_10_mm, the pipeline's name

Revision ID: 0009
Revises: 0008
Create Date: 2026-12-02
"""

from __future__ import annotations

from alembic import op

revision = "0009"
down_revision = "0008"
branch_labels = None
depends_on = None

OLD, NEW = "flange_thickness_en_mm", "flange_thickness_10_mm"
TABLES = ("measurement", "handheld_reference")


def _rename(old: str, new: str) -> None:
    for table in TABLES:
        with op.batch_alter_table(table, schema=None) as batch_op:
            batch_op.alter_column(old, new_column_name=new)
    op.execute(f"UPDATE measurement_margin SET parameter = '{new}' WHERE parameter = '{old}'")


def upgrade() -> None:
    _rename(OLD, NEW)


def downgrade() -> None:
    _rename(NEW, OLD)
