"""Read models: pass summaries, the filtered pass list, and the wheels of a pass."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import cast

from sqlalchemy import Select, func, select
from sqlalchemy.orm import Session

from backend.api.schemas import JobProgress, MethodResult, Page, PassSummary, PassWheelRead, Side
from db.models import Frame, Job, Measurement, Pass, PassWheel, Site, Wheel

PRIMARY_METHOD = "adaptive"
"""The product's method: pass-level alarm counts come from it (Steger is the baseline)."""

METHODS = ("adaptive", "steger")


@dataclass(frozen=True, slots=True)
class PassFilter:
    site: str | None = None
    vehicle: str | None = None
    started_from: datetime | None = None
    started_to: datetime | None = None
    alarm: bool | None = None


def job_progress(job: Job) -> JobProgress:
    return JobProgress(
        job_id=job.id,
        pass_id=job.pass_id,
        state=job.state,
        progress=job.progress,
        wheels_done=job.wheels_done,
        wheels_total=job.wheels_total,
    )


def _alarm_count(session: Session, pass_id: int) -> int:
    count = session.scalar(
        select(func.coalesce(func.sum(Measurement.alarm_count), 0))
        .join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
        .where(PassWheel.pass_id == pass_id, Measurement.method == PRIMARY_METHOD)
    )
    return int(count or 0)


def pass_summary(session: Session, train_pass: Pass) -> PassSummary:
    """One row of the pass list: identity, wheel counts, alarms and live job progress."""
    states = dict(
        session.execute(
            select(PassWheel.state, func.count(PassWheel.id))
            .where(PassWheel.pass_id == train_pass.id)
            .group_by(PassWheel.state)
        ).all()
    )
    vehicles = list(train_pass.vehicles or [])
    if not vehicles:
        rows = session.scalars(
            select(Wheel.vehicle_id)
            .join(PassWheel, PassWheel.wheel_id == Wheel.id)
            .where(PassWheel.pass_id == train_pass.id)
            .order_by(PassWheel.id)
        )
        vehicles = list(dict.fromkeys(rows))
    job = session.scalars(select(Job).where(Job.pass_id == train_pass.id).limit(1)).first()
    return PassSummary.model_validate(
        {
            "id": train_pass.id,
            "site": train_pass.site.name,
            "started_at": train_pass.started_at,
            "direction": train_pass.direction,
            "speed_kmh": train_pass.speed_kmh,
            "fleet": train_pass.fleet,
            "source": train_pass.source,
            "state": train_pass.state,
            "calibration_version": train_pass.calibration.version,
            "vehicles": vehicles,
            "wheels_total": sum(states.values()),
            "wheels_measured": states.get("measured", 0),
            "wheels_not_measured": states.get("not_measured", 0) + states.get("failed", 0),
            "alarm_count": _alarm_count(session, train_pass.id),
            "job": job_progress(job) if job else None,
            "frames_removed_at": train_pass.frames_removed_at,
        }
    )


def _filtered(query: Select, where: PassFilter) -> Select:
    if where.site is not None:
        query = query.join(Site, Pass.site_id == Site.id).where(Site.name == where.site)
    if where.vehicle is not None:
        query = query.where(
            Pass.id.in_(
                select(PassWheel.pass_id)
                .join(Wheel, PassWheel.wheel_id == Wheel.id)
                .where(Wheel.vehicle_id == where.vehicle)
            )
        )
    if where.started_from is not None:
        query = query.where(Pass.started_at >= where.started_from)
    if where.started_to is not None:
        query = query.where(Pass.started_at < where.started_to)
    if where.alarm is not None:
        with_alarm = (
            select(PassWheel.pass_id)
            .join(Measurement, Measurement.pass_wheel_id == PassWheel.id)
            .where(Measurement.method == PRIMARY_METHOD, Measurement.alarm_count > 0)
        )
        query = query.where(Pass.id.in_(with_alarm) if where.alarm else Pass.id.not_in(with_alarm))
    return query


def list_passes(session: Session, where: PassFilter, offset: int, limit: int) -> Page[PassSummary]:
    """Passes matching `where`, newest first."""
    total = session.scalar(_filtered(select(func.count(Pass.id)), where))
    rows = session.scalars(
        _filtered(select(Pass), where)
        .order_by(Pass.started_at.desc(), Pass.id.desc())
        .offset(offset)
        .limit(limit)
    )
    items = [pass_summary(session, row) for row in rows]
    return Page[PassSummary](items=items, total=total or 0, offset=offset, limit=limit)


def method_result(measurement: Measurement) -> MethodResult:
    return MethodResult.model_validate(measurement, from_attributes=True)


def pass_wheels(session: Session, train_pass: Pass) -> list[PassWheelRead]:
    """Every wheel of a pass in train order, with its results per method."""
    counts: dict[tuple[str, int, str], int] = {}
    for vehicle_id, axle, sensor, count in session.execute(
        select(Frame.vehicle_id, Frame.axle, Frame.sensor, func.count(Frame.id))
        .where(Frame.pass_id == train_pass.id)
        .group_by(Frame.vehicle_id, Frame.axle, Frame.sensor)
    ):
        counts[(vehicle_id, axle, sensor)] = count
    result = []
    for pass_wheel in train_pass.wheels:
        wheel = pass_wheel.wheel
        results = [method_result(m) for m in pass_wheel.measurements]
        primary = [r for r in results if r.method == PRIMARY_METHOD]
        result.append(
            PassWheelRead(
                wheel_id=wheel.id,
                vehicle_id=wheel.vehicle_id,
                axle=wheel.axle,
                side=cast(Side, wheel.side),
                state=pass_wheel.state,
                reason=pass_wheel.reason,
                missing_sensors=list(pass_wheel.missing_sensors or []),
                frames={
                    f"{wheel.side}_{p}": counts.get(
                        (wheel.vehicle_id, wheel.axle, f"{wheel.side}_{p}"), 0
                    )
                    for p in ("inner", "outer")
                },
                results=results,
                alarm_count=len(primary[0].alarms) if primary else 0,
                frames_removed_at=train_pass.frames_removed_at,
            )
        )
    return result
