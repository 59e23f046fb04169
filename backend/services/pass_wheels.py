"""Wheel identities, pass wheels and jobs: the rows the ingest paths and the tasks share."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from typing import Any, Protocol, cast

from sqlalchemy import CursorResult, Executable, func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from db.models import TERMINAL_WHEEL_STATES, Frame, Job, Measurement, Pass, PassWheel, Wheel
from db.types import utc_now
from pipeline import PIPELINE_VERSION
from pipeline.archive.manifest import POSITIONS


def rows_changed(session: Session, statement: Executable) -> int:
    """Execute an UPDATE/DELETE and return how many rows it changed."""
    result = cast("CursorResult[Any]", session.execute(statement))
    return result.rowcount


def get_or_create_wheel(session: Session, vehicle_id: str, axle: int, side: str) -> Wheel:
    """The wheel (vehicle_id, axle, side), created when first seen (race-safe)."""
    query = select(Wheel).where(
        Wheel.vehicle_id == vehicle_id, Wheel.axle == axle, Wheel.side == side
    )
    wheel = session.scalar(query)
    if wheel is not None:
        return wheel
    try:
        with session.begin_nested():
            wheel = Wheel(vehicle_id=vehicle_id, axle=axle, side=side)
            session.add(wheel)
    except IntegrityError:
        wheel = session.scalars(query).one()
    return wheel


class PassHeader(Protocol):
    """When and how a train passed: an archive's manifest or a streamed pass's request."""

    @property
    def started_at(self) -> datetime: ...
    @property
    def direction(self) -> str | None: ...
    @property
    def speed_kmh(self) -> float | None: ...


def create_pass(
    session: Session,
    site_id: int,
    calibration_id: int,
    header: PassHeader,
    *,
    source: str,
    state: str,
    frames_per_sensor: int,
    vehicles: list[str],
    archive_sha256: str | None = None,
    odometer_km: dict[str, float] | None = None,
) -> Pass:
    """A new pass at a site, measured with one of its calibrations (added and flushed).

    `odometer_km` holds the vehicles' odometer readings at this pass {vehicle id: km}, if given.
    """
    train_pass = Pass(
        site_id=site_id,
        calibration_id=calibration_id,
        started_at=header.started_at,
        direction=header.direction,
        speed_kmh=header.speed_kmh,
        odometer_km=odometer_km,
        source=source,
        archive_sha256=archive_sha256,
        state=state,
        frames_per_sensor=frames_per_sensor,
        vehicles=vehicles,
    )
    session.add(train_pass)
    session.flush()
    return train_pass


def create_job(session: Session, train_pass: Pass, *, wheels_total: int) -> Job:
    """A measurement job for `train_pass` (queued until its first wheel starts)."""
    job = Job(
        kind="measure_pass",
        pass_id=train_pass.id,
        state="queued",
        wheels_total=wheels_total,
        pipeline_version=PIPELINE_VERSION,
    )
    session.add(job)
    session.flush()
    return job


def refresh_job(session: Session, pass_id: int) -> Job:
    """Recount a pass's job from its wheels and commit; the job is done when the pass is
    closed and every wheel is measured, not measured or failed.

    The job row is locked first (PostgreSQL) and the counts are taken in one UPDATE, so
    concurrent workers finishing wheels of the same pass never write a stale count.
    """
    job = session.scalars(
        select(Job).where(Job.pass_id == pass_id).order_by(Job.id).limit(1).with_for_update()
    ).one()
    total = select(func.count(PassWheel.id)).where(PassWheel.pass_id == pass_id)
    done = total.where(PassWheel.state.in_(TERMINAL_WHEEL_STATES))
    started = total.where(PassWheel.state != "receiving").where(PassWheel.state != "queued")
    session.execute(
        update(Job)
        .where(Job.id == job.id)
        .values(
            wheels_total=total.scalar_subquery(),
            wheels_done=done.scalar_subquery(),
            updated_at=utc_now(),
        )
    )
    session.refresh(job)
    now = utc_now()
    job.progress = job.wheels_done / job.wheels_total if job.wheels_total else 0.0
    pass_closed = session.scalar(select(Pass.state).where(Pass.id == pass_id)) == "closed"
    if job.state == "queued" and (session.scalar(started) or 0) > 0:
        job.state, job.started_at = "running", now
    if pass_closed and job.wheels_done == job.wheels_total and job.state != "done":
        job.state, job.finished_at, job.progress = "done", now, 1.0
        job.started_at = job.started_at or now
    session.commit()
    return job


def wheel_frames(
    session: Session, pass_wheel: PassWheel, positions: Sequence[str] = POSITIONS
) -> list[Frame]:
    """The frames of one wheel in its pass from the sensors at `positions` ("inner",
    "outer"), ordered by sensor, then by sequence number."""
    wheel = pass_wheel.wheel
    sensors = [f"{wheel.side}_{position}" for position in positions]
    return list(
        session.scalars(
            select(Frame)
            .where(
                Frame.pass_id == pass_wheel.pass_id,
                Frame.vehicle_id == wheel.vehicle_id,
                Frame.axle == wheel.axle,
                Frame.sensor.in_(sensors),
            )
            .order_by(Frame.sensor, Frame.seq)
        )
    )


def method_measurement(pass_wheel: PassWheel, method: str) -> Measurement | None:
    """The wheel's result of `method` ("adaptive", "steger"), or None."""
    return next((m for m in pass_wheel.measurements if m.method == method), None)
