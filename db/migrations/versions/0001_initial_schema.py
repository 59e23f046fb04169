"""initial schema

Revision ID: 0001
Revises:
Create Date: 2026-11-23
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:

    op.create_table(
        "api_token",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=100), nullable=False),
        sa.Column("role", sa.String(length=10), nullable=False),
        sa.Column("token_sha256", sa.String(length=64), nullable=False),
        sa.Column("prefix", sa.String(length=12), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("expires_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("revoked_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("last_used_at", sa.DateTime(timezone=True), nullable=True),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_api_token")),
        sa.UniqueConstraint("token_sha256", name=op.f("uq_api_token_token_sha256")),
    )
    op.create_table(
        "fleet_limit",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("fleet", sa.String(length=100), nullable=False),
        sa.Column("wheel_profile", sa.String(length=5), nullable=False),
        sa.Column("flange_height_min_mm", sa.Float(), nullable=False),
        sa.Column("flange_height_max_mm", sa.Float(), nullable=False),
        sa.Column("flange_thickness_min_mm", sa.Float(), nullable=False),
        sa.Column("flange_thickness_max_mm", sa.Float(), nullable=False),
        sa.Column("qr_min_mm", sa.Float(), nullable=False),
        sa.Column("back_to_back_min_mm", sa.Float(), nullable=False),
        sa.Column("back_to_back_max_mm", sa.Float(), nullable=False),
        sa.Column("updated_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_fleet_limit")),
        sa.UniqueConstraint(
            "fleet", "wheel_profile", name=op.f("uq_fleet_limit_fleet_wheel_profile")
        ),
    )
    op.create_table(
        "site",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=100), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_site")),
        sa.UniqueConstraint("name", name=op.f("uq_site_name")),
    )
    op.create_table(
        "wheel",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("vehicle_id", sa.String(length=100), nullable=False),
        sa.Column("axle", sa.Integer(), nullable=False),
        sa.Column("side", sa.String(length=5), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_wheel")),
        sa.UniqueConstraint(
            "vehicle_id", "axle", "side", name=op.f("uq_wheel_vehicle_id_axle_side")
        ),
    )
    with op.batch_alter_table("wheel", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_wheel_vehicle_id"), ["vehicle_id"], unique=False)

    op.create_table(
        "audit_event",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("token_id", sa.Integer(), nullable=True),
        sa.Column("actor", sa.String(length=100), nullable=False),
        sa.Column("action", sa.String(length=60), nullable=False),
        sa.Column("target_type", sa.String(length=40), nullable=False),
        sa.Column("target_id", sa.String(length=100), nullable=True),
        sa.Column("detail", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(
            ["token_id"],
            ["api_token.id"],
            name=op.f("fk_audit_event_token_id_api_token"),
            ondelete="SET NULL",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_audit_event")),
    )
    with op.batch_alter_table("audit_event", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_audit_event_at"), ["at"], unique=False)

    op.create_table(
        "calibration",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("site_id", sa.Integer(), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("sha256", sa.String(length=64), nullable=False),
        sa.Column("document", sa.JSON(), nullable=False),
        sa.Column("note", sa.Text(), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["site_id"], ["site.id"], name=op.f("fk_calibration_site_id_site"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_calibration")),
        sa.UniqueConstraint("site_id", "version", name=op.f("uq_calibration_site_id_version")),
    )
    with op.batch_alter_table("calibration", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_calibration_site_id"), ["site_id"], unique=False)

    op.create_table(
        "train_pass",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("site_id", sa.Integer(), nullable=False),
        sa.Column("calibration_id", sa.Integer(), nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("direction", sa.String(length=40), nullable=True),
        sa.Column("speed_kmh", sa.Float(), nullable=True),
        sa.Column("fleet", sa.String(length=100), nullable=False),
        sa.Column("source", sa.String(length=10), nullable=False),
        sa.Column("archive_sha256", sa.String(length=64), nullable=True),
        sa.Column("state", sa.String(length=10), nullable=False),
        sa.Column("frames_per_sensor", sa.Integer(), nullable=False),
        sa.Column("vehicles", sa.JSON(), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("closed_at", sa.DateTime(timezone=True), nullable=True),
        sa.ForeignKeyConstraint(
            ["calibration_id"],
            ["calibration.id"],
            name=op.f("fk_train_pass_calibration_id_calibration"),
        ),
        sa.ForeignKeyConstraint(["site_id"], ["site.id"], name=op.f("fk_train_pass_site_id_site")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_train_pass")),
        sa.UniqueConstraint("archive_sha256", name=op.f("uq_train_pass_archive_sha256")),
    )
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_train_pass_site_id"), ["site_id"], unique=False)
        batch_op.create_index(batch_op.f("ix_train_pass_started_at"), ["started_at"], unique=False)

    op.create_table(
        "frame",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("pass_id", sa.Integer(), nullable=False),
        sa.Column("sensor", sa.String(length=20), nullable=False),
        sa.Column("seq", sa.Integer(), nullable=False),
        sa.Column("sha256", sa.String(length=64), nullable=False),
        sa.Column("vehicle_id", sa.String(length=100), nullable=False),
        sa.Column("axle", sa.Integer(), nullable=False),
        sa.Column("width_px", sa.Integer(), nullable=False),
        sa.Column("height_px", sa.Integer(), nullable=False),
        sa.Column("bit_depth", sa.Integer(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["pass_id"],
            ["train_pass.id"],
            name=op.f("fk_frame_pass_id_train_pass"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_frame")),
        sa.UniqueConstraint("pass_id", "sensor", "seq", name=op.f("uq_frame_pass_id_sensor_seq")),
    )
    with op.batch_alter_table("frame", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_frame_sha256"), ["sha256"], unique=False)

    op.create_table(
        "job",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("kind", sa.String(length=20), nullable=False),
        sa.Column("pass_id", sa.Integer(), nullable=False),
        sa.Column("state", sa.String(length=10), nullable=False),
        sa.Column("progress", sa.Float(), nullable=False),
        sa.Column("wheels_total", sa.Integer(), nullable=False),
        sa.Column("wheels_done", sa.Integer(), nullable=False),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("pipeline_version", sa.String(length=20), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("updated_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["pass_id"],
            ["train_pass.id"],
            name=op.f("fk_job_pass_id_train_pass"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_job")),
    )
    with op.batch_alter_table("job", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_job_state"), ["state"], unique=False)

    op.create_table(
        "pass_wheel",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("pass_id", sa.Integer(), nullable=False),
        sa.Column("wheel_id", sa.Integer(), nullable=False),
        sa.Column("state", sa.String(length=15), nullable=False),
        sa.Column("reason", sa.Text(), nullable=True),
        sa.Column("missing_sensors", sa.JSON(), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=True),
        sa.ForeignKeyConstraint(
            ["pass_id"],
            ["train_pass.id"],
            name=op.f("fk_pass_wheel_pass_id_train_pass"),
            ondelete="CASCADE",
        ),
        sa.ForeignKeyConstraint(
            ["wheel_id"], ["wheel.id"], name=op.f("fk_pass_wheel_wheel_id_wheel")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_pass_wheel")),
        sa.UniqueConstraint("pass_id", "wheel_id", name=op.f("uq_pass_wheel_pass_id_wheel_id")),
    )
    with op.batch_alter_table("pass_wheel", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_pass_wheel_state"), ["state"], unique=False)
        batch_op.create_index(batch_op.f("ix_pass_wheel_wheel_id"), ["wheel_id"], unique=False)

    op.create_table(
        "measurement",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("pass_wheel_id", sa.Integer(), nullable=False),
        sa.Column("method", sa.String(length=20), nullable=False),
        sa.Column("status", sa.String(length=15), nullable=False),
        sa.Column("reason", sa.Text(), nullable=True),
        sa.Column("flange_height_mm", sa.Float(), nullable=True),
        sa.Column("flange_thickness_mm", sa.Float(), nullable=True),
        sa.Column("flange_thickness_en_mm", sa.Float(), nullable=True),
        sa.Column("qr_mm", sa.Float(), nullable=True),
        sa.Column("back_to_back_mm", sa.Float(), nullable=True),
        sa.Column("reference_profile", sa.String(length=20), nullable=True),
        sa.Column("sigma_mean_px", sa.Float(), nullable=True),
        sa.Column("sigma_min_px", sa.Float(), nullable=True),
        sa.Column("sigma_max_px", sa.Float(), nullable=True),
        sa.Column("point_count", sa.Integer(), nullable=False),
        sa.Column("quality", sa.JSON(), nullable=False),
        sa.Column("profile", sa.JSON(), nullable=True),
        sa.Column("alarms", sa.JSON(), nullable=False),
        sa.Column("pipeline_version", sa.String(length=20), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["pass_wheel_id"],
            ["pass_wheel.id"],
            name=op.f("fk_measurement_pass_wheel_id_pass_wheel"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_measurement")),
        sa.UniqueConstraint(
            "pass_wheel_id", "method", name=op.f("uq_measurement_pass_wheel_id_method")
        ),
    )
    op.create_table(
        "measurement_frame",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("measurement_id", sa.Integer(), nullable=False),
        sa.Column("sensor", sa.String(length=20), nullable=False),
        sa.Column("seq", sa.Integer(), nullable=False),
        sa.Column("artefact_sha256", sa.String(length=64), nullable=False),
        sa.Column("centre_count", sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(
            ["measurement_id"],
            ["measurement.id"],
            name=op.f("fk_measurement_frame_measurement_id_measurement"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_measurement_frame")),
        sa.UniqueConstraint(
            "measurement_id",
            "sensor",
            "seq",
            name=op.f("uq_measurement_frame_measurement_id_sensor_seq"),
        ),
    )
    with op.batch_alter_table("measurement_frame", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_measurement_frame_measurement_id"), ["measurement_id"], unique=False
        )


def downgrade() -> None:

    with op.batch_alter_table("measurement_frame", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_measurement_frame_measurement_id"))

    op.drop_table("measurement_frame")
    op.drop_table("measurement")
    with op.batch_alter_table("pass_wheel", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_pass_wheel_wheel_id"))
        batch_op.drop_index(batch_op.f("ix_pass_wheel_state"))

    op.drop_table("pass_wheel")
    with op.batch_alter_table("job", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_job_state"))

    op.drop_table("job")
    with op.batch_alter_table("frame", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_frame_sha256"))

    op.drop_table("frame")
    with op.batch_alter_table("train_pass", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_train_pass_started_at"))
        batch_op.drop_index(batch_op.f("ix_train_pass_site_id"))

    op.drop_table("train_pass")
    with op.batch_alter_table("calibration", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_calibration_site_id"))

    op.drop_table("calibration")
    with op.batch_alter_table("audit_event", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_audit_event_at"))

    op.drop_table("audit_event")
    with op.batch_alter_table("wheel", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_wheel_vehicle_id"))

    op.drop_table("wheel")
    op.drop_table("site")
    op.drop_table("fleet_limit")
    op.drop_table("api_token")
