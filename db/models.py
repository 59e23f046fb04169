"""ORM models (SQLAlchemy 2, typed). Units live in column names; times are UTC.

Entities (docs/service.md): site, calibration (versioned, never edited in place),
pass, frame (content-addressed by sha256), wheel (identity vehicle_id + axle + side, so
trends follow one wheel across passes), pass wheel (one wheel in one pass: its task state),
measurement (pass wheel x method), measurement frame (per-frame artefacts), job, API token,
audit event, fleet limits, measurement margins and dispositions.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import (
    JSON,
    Float,
    ForeignKey,
    Integer,
    MetaData,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship

from db.types import UtcDateTime, utc_now

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

SENSORS = ("left_inner", "left_outer", "right_inner", "right_outer")
"""Sensor names of a station, as in the calibration file and the frame paths."""

ROLES = ("viewer", "operator", "admin")
"""API token roles, each including the rights of the ones before it."""

WHEEL_STATES = ("receiving", "queued", "running", "measured", "not_measured", "failed")
"""Life of a wheel in a pass; the last three are terminal."""

TERMINAL_WHEEL_STATES = ("measured", "not_measured", "failed")

JOB_STATES = ("queued", "running", "done", "failed")


class Base(DeclarativeBase):
    """Declarative base with a constraint naming convention (stable migration names)."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {datetime: UtcDateTime(), dict[str, Any]: JSON, list[Any]: JSON}


class Site(Base):
    """A wayside measuring station."""

    __tablename__ = "site"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    rail_profile: Mapped[str] = mapped_column(String(10), default="60E1", server_default="60E1")
    rail_inclination: Mapped[str] = mapped_column(String(5), default="1:40", server_default="1:40")
    gauge_mm: Mapped[float] = mapped_column(Float, default=1435.0, server_default="1435.0")
    created_at: Mapped[datetime] = mapped_column(default=utc_now)

    calibrations: Mapped[list[Calibration]] = relationship(
        back_populates="site", order_by="Calibration.version"
    )


class Calibration(Base):
    """One version of a site's calibration (wheelscan-calibration/1); never edited in place.

    `registered` versions were registered by an admin: the newest is the site's current one.
    A calibration that came inside an uploaded archive is kept (unregistered) for that pass.
    """

    __tablename__ = "calibration"
    __table_args__ = (UniqueConstraint("site_id", "version"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("site.id", ondelete="CASCADE"), index=True)
    version: Mapped[int] = mapped_column(Integer)
    sha256: Mapped[str] = mapped_column(String(64))
    document: Mapped[dict[str, Any]]
    note: Mapped[str | None] = mapped_column(Text)
    registered: Mapped[bool] = mapped_column(default=True)
    created_at: Mapped[datetime] = mapped_column(default=utc_now)

    site: Mapped[Site] = relationship(back_populates="calibrations")


class Pass(Base):
    """One train passing a site: uploaded as an archive or streamed frame by frame."""

    __tablename__ = "train_pass"

    id: Mapped[int] = mapped_column(primary_key=True)
    site_id: Mapped[int] = mapped_column(ForeignKey("site.id"), index=True)
    calibration_id: Mapped[int] = mapped_column(ForeignKey("calibration.id"))
    started_at: Mapped[datetime] = mapped_column(index=True)
    direction: Mapped[str | None] = mapped_column(String(40))
    speed_kmh: Mapped[float | None] = mapped_column(Float)
    fleet: Mapped[str] = mapped_column(String(100), default="default")
    source: Mapped[str] = mapped_column(String(10))
    archive_sha256: Mapped[str | None] = mapped_column(String(64), unique=True)
    state: Mapped[str] = mapped_column(String(10), default="open")
    frames_per_sensor: Mapped[int] = mapped_column(Integer, default=1)
    vehicles: Mapped[list[Any] | None]
    odometer_km: Mapped[dict[str, Any] | None]
    """Odometer readings of the pass's vehicles that reported one, {vehicle_id: km}."""
    created_at: Mapped[datetime] = mapped_column(default=utc_now)
    closed_at: Mapped[datetime | None]
    frames_removed_at: Mapped[datetime | None]
    """When frame retention removed the raw frames (measurement results are kept)."""

    site: Mapped[Site] = relationship()
    calibration: Mapped[Calibration] = relationship()
    wheels: Mapped[list[PassWheel]] = relationship(
        back_populates="train_pass", order_by="PassWheel.id"
    )


class Frame(Base):
    """One camera frame of a pass; the image bytes live in the store under their sha256."""

    __tablename__ = "frame"
    __table_args__ = (UniqueConstraint("pass_id", "sensor", "seq"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    pass_id: Mapped[int] = mapped_column(ForeignKey("train_pass.id", ondelete="CASCADE"))
    sensor: Mapped[str] = mapped_column(String(20))
    seq: Mapped[int] = mapped_column(Integer)
    sha256: Mapped[str] = mapped_column(String(64), index=True)
    vehicle_id: Mapped[str] = mapped_column(String(100))
    axle: Mapped[int] = mapped_column(Integer)
    width_px: Mapped[int] = mapped_column(Integer)
    height_px: Mapped[int] = mapped_column(Integer)
    bit_depth: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(default=utc_now)


class Wheel(Base):
    """A physical wheel, identified across passes by vehicle, axle and side."""

    __tablename__ = "wheel"
    __table_args__ = (UniqueConstraint("vehicle_id", "axle", "side"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    vehicle_id: Mapped[str] = mapped_column(String(100), index=True)
    axle: Mapped[int] = mapped_column(Integer)
    side: Mapped[str] = mapped_column(String(5))


class PassWheel(Base):
    """One wheel in one pass: the unit of measurement work, with its task state."""

    __tablename__ = "pass_wheel"
    __table_args__ = (UniqueConstraint("pass_id", "wheel_id"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    pass_id: Mapped[int] = mapped_column(ForeignKey("train_pass.id", ondelete="CASCADE"))
    wheel_id: Mapped[int] = mapped_column(ForeignKey("wheel.id"), index=True)
    state: Mapped[str] = mapped_column(String(15), default="receiving", index=True)
    reason: Mapped[str | None] = mapped_column(Text)
    missing_sensors: Mapped[list[Any]] = mapped_column(default=list)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]

    train_pass: Mapped[Pass] = relationship(back_populates="wheels")
    wheel: Mapped[Wheel] = relationship()
    measurements: Mapped[list[Measurement]] = relationship(
        back_populates="pass_wheel", order_by="Measurement.method"
    )


class Measurement(Base):
    """The result of one extraction method on one wheel of one pass."""

    __tablename__ = "measurement"
    __table_args__ = (UniqueConstraint("pass_wheel_id", "method"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    pass_wheel_id: Mapped[int] = mapped_column(ForeignKey("pass_wheel.id", ondelete="CASCADE"))
    method: Mapped[str] = mapped_column(String(20))
    status: Mapped[str] = mapped_column(String(15))
    reason: Mapped[str | None] = mapped_column(Text)
    flange_height_mm: Mapped[float | None] = mapped_column(Float)
    flange_thickness_mm: Mapped[float | None] = mapped_column(Float)
    flange_thickness_10_mm: Mapped[float | None] = mapped_column(Float)
    qr_mm: Mapped[float | None] = mapped_column(Float)
    back_to_back_mm: Mapped[float | None] = mapped_column(Float)
    back_face_track_x_mm: Mapped[float | None] = mapped_column(Float)
    tread_hollow_mm: Mapped[float | None] = mapped_column(Float)
    flange_angle_deg: Mapped[float | None] = mapped_column(Float)
    rim_width_mm: Mapped[float | None] = mapped_column(Float)
    tread_reason: Mapped[str | None] = mapped_column(Text)
    equivalent_conicity: Mapped[float | None] = mapped_column(Float)
    conicity: Mapped[dict[str, Any] | None]
    reference_profile: Mapped[str | None] = mapped_column(String(20))
    sigma_mean_px: Mapped[float | None] = mapped_column(Float)
    sigma_min_px: Mapped[float | None] = mapped_column(Float)
    sigma_max_px: Mapped[float | None] = mapped_column(Float)
    point_count: Mapped[int] = mapped_column(Integer, default=0)
    quality: Mapped[dict[str, Any]] = mapped_column(default=dict)
    profile: Mapped[dict[str, Any] | None]
    alarms: Mapped[list[Any]] = mapped_column(default=list)
    alarm_count: Mapped[int] = mapped_column(Integer, default=0)
    pipeline_version: Mapped[str] = mapped_column(String(20))
    created_at: Mapped[datetime] = mapped_column(default=utc_now)

    pass_wheel: Mapped[PassWheel] = relationship(back_populates="measurements")
    frames: Mapped[list[MeasurementFrame]] = relationship(
        back_populates="measurement",
        order_by=lambda: (MeasurementFrame.sensor, MeasurementFrame.seq),
    )
    margins: Mapped[list[MeasurementMargin]] = relationship(
        back_populates="measurement", cascade="all, delete-orphan", passive_deletes=True
    )


class MeasurementMargin(Base):
    """One checked parameter of a measurement and its margin to the nearest limit, kept
    with the alarms (against the limits in force when it was measured). `nearest` marks
    the measurement's smallest margin as a fraction of its band: the worst-wheels order.
    No index on the margin itself: with one, planners walked every pass's margins in
    order rather than start from the few pass wheels a filter leaves."""

    __tablename__ = "measurement_margin"
    __table_args__ = (UniqueConstraint("measurement_id", "parameter"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    measurement_id: Mapped[int] = mapped_column(ForeignKey("measurement.id", ondelete="CASCADE"))
    parameter: Mapped[str] = mapped_column(String(40))
    value_mm: Mapped[float] = mapped_column(Float)
    bound: Mapped[str] = mapped_column(String(3))
    limit_mm: Mapped[float] = mapped_column(Float)
    margin_mm: Mapped[float] = mapped_column(Float)
    band_mm: Mapped[float] = mapped_column(Float)
    margin_fraction: Mapped[float] = mapped_column(Float)
    level: Mapped[str] = mapped_column(String(5))
    nearest: Mapped[bool] = mapped_column(default=False)

    measurement: Mapped[Measurement] = relationship(back_populates="margins")


class MeasurementFrame(Base):
    """Per-frame artefacts of a measurement (centres, mask, sigma map) in the store, with
    the full-size mask and coloured σ map pre-rendered as PNG blobs by the worker."""

    __tablename__ = "measurement_frame"
    __table_args__ = (UniqueConstraint("measurement_id", "sensor", "seq"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    measurement_id: Mapped[int] = mapped_column(
        ForeignKey("measurement.id", ondelete="CASCADE"), index=True
    )
    sensor: Mapped[str] = mapped_column(String(20))
    seq: Mapped[int] = mapped_column(Integer)
    artefact_sha256: Mapped[str] = mapped_column(String(64))
    centre_count: Mapped[int] = mapped_column(Integer)
    mask_png_sha256: Mapped[str | None] = mapped_column(String(64))
    sigma_png_sha256: Mapped[str | None] = mapped_column(String(64))
    sigma_min_px: Mapped[float | None] = mapped_column(Float)
    sigma_max_px: Mapped[float | None] = mapped_column(Float)

    measurement: Mapped[Measurement] = relationship(back_populates="frames")


class Job(Base):
    """Measurement work for one pass; the database row is the truth about its progress."""

    __tablename__ = "job"

    id: Mapped[int] = mapped_column(primary_key=True)
    kind: Mapped[str] = mapped_column(String(20), default="measure_pass")
    pass_id: Mapped[int] = mapped_column(ForeignKey("train_pass.id", ondelete="CASCADE"))
    state: Mapped[str] = mapped_column(String(10), default="queued", index=True)
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    wheels_total: Mapped[int] = mapped_column(Integer, default=0)
    wheels_done: Mapped[int] = mapped_column(Integer, default=0)
    error: Mapped[str | None] = mapped_column(Text)
    pipeline_version: Mapped[str] = mapped_column(String(20))
    created_at: Mapped[datetime] = mapped_column(default=utc_now)
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    updated_at: Mapped[datetime] = mapped_column(default=utc_now)


class ApiToken(Base):
    """A bearer token; only its sha256 is stored."""

    __tablename__ = "api_token"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(100))
    role: Mapped[str] = mapped_column(String(10))
    token_sha256: Mapped[str] = mapped_column(String(64), unique=True)
    prefix: Mapped[str] = mapped_column(String(12))
    created_at: Mapped[datetime] = mapped_column(default=utc_now)
    expires_at: Mapped[datetime | None]
    revoked_at: Mapped[datetime | None]
    last_used_at: Mapped[datetime | None]


class AuditEvent(Base):
    """One write through the API or the CLI: who, what, on which object."""

    __tablename__ = "audit_event"

    id: Mapped[int] = mapped_column(primary_key=True)
    at: Mapped[datetime] = mapped_column(default=utc_now, index=True)
    token_id: Mapped[int | None] = mapped_column(ForeignKey("api_token.id", ondelete="SET NULL"))
    actor: Mapped[str] = mapped_column(String(100))
    action: Mapped[str] = mapped_column(String(60))
    target_type: Mapped[str] = mapped_column(String(40))
    target_id: Mapped[str | None] = mapped_column(String(100))
    detail: Mapped[dict[str, Any]] = mapped_column(default=dict)


class FleetLimit(Base):
    """Alarm limits of a fleet for one wheel profile family (EN or LM) [mm]."""

    __tablename__ = "fleet_limit"
    __table_args__ = (UniqueConstraint("fleet", "wheel_profile"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    fleet: Mapped[str] = mapped_column(String(100))
    wheel_profile: Mapped[str] = mapped_column(String(5))
    flange_height_min_mm: Mapped[float] = mapped_column(Float)
    flange_height_max_mm: Mapped[float] = mapped_column(Float)
    flange_thickness_min_mm: Mapped[float] = mapped_column(Float)
    flange_thickness_max_mm: Mapped[float] = mapped_column(Float)
    qr_min_mm: Mapped[float] = mapped_column(Float)
    back_to_back_min_mm: Mapped[float] = mapped_column(Float)
    back_to_back_max_mm: Mapped[float] = mapped_column(Float)
    conicity_max: Mapped[float] = mapped_column(Float, default=0.4, server_default="0.4")
    updated_at: Mapped[datetime] = mapped_column(default=utc_now)
    near_limit_fraction: Mapped[float] = mapped_column(Float, default=0.1)
    """Amber band: this fraction of each limit band inside its limits."""
    method_disagreement_mm: Mapped[float] = mapped_column(Float, default=0.5)
    """A wheel whose adaptive and Steger values differ by more is flagged [mm]."""


DISPOSITION_KINDS = ("re_profile", "monitor", "false_alarm", "measurement_doubtful", "comment")
"""What an operator decided about a wheel of a pass; "false_alarm" needs a reason."""


class Disposition(Base):
    """An operator's decision on one wheel of one pass; the newest one is in force (a
    wheel without any is "open"). Each is also an audit event."""

    __tablename__ = "disposition"

    id: Mapped[int] = mapped_column(primary_key=True)
    pass_wheel_id: Mapped[int] = mapped_column(
        ForeignKey("pass_wheel.id", ondelete="CASCADE"), index=True
    )
    kind: Mapped[str] = mapped_column(String(25))
    comment: Mapped[str | None] = mapped_column(Text)
    actor: Mapped[str] = mapped_column(String(100))
    token_id: Mapped[int | None] = mapped_column(ForeignKey("api_token.id", ondelete="SET NULL"))
    created_at: Mapped[datetime] = mapped_column(default=utc_now)


class HandheldReference(Base):
    """A wheel's profile measured with a handheld gauge (MiniProf, LLJ-4A, Calipri…): the
    points in the profile frame, Sh/Sd/qR computed from them by the wayside code, and the
    instrument's own values where its file gave them [mm]."""

    __tablename__ = "handheld_reference"
    __table_args__ = (UniqueConstraint("wheel_id", "sha256"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    wheel_id: Mapped[int] = mapped_column(ForeignKey("wheel.id", ondelete="CASCADE"), index=True)
    filename: Mapped[str] = mapped_column(String(255))
    sha256: Mapped[str] = mapped_column(String(64))
    """Of the uploaded file: the same file for the same wheel is stored once."""
    instrument: Mapped[str | None] = mapped_column(String(100))
    measured_on: Mapped[str | None] = mapped_column(String(60))
    """Date and time as the file's header wrote them."""
    measured_at: Mapped[datetime]
    """When the gauge measured (given at import; the upload time otherwise)."""
    x_mm: Mapped[list[Any]]
    z_mm: Mapped[list[Any]]
    z_offset_mm: Mapped[float] = mapped_column(Float)
    flange_height_mm: Mapped[float] = mapped_column(Float)
    flange_thickness_mm: Mapped[float] = mapped_column(Float)
    flange_thickness_10_mm: Mapped[float] = mapped_column(Float)
    qr_mm: Mapped[float] = mapped_column(Float)
    parameter_quality: Mapped[str] = mapped_column(String(15))
    instrument_flange_height_mm: Mapped[float | None] = mapped_column(Float)
    instrument_flange_thickness_mm: Mapped[float | None] = mapped_column(Float)
    instrument_qr_mm: Mapped[float | None] = mapped_column(Float)
    created_at: Mapped[datetime] = mapped_column(default=utc_now)
