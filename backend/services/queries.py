"""Read models: pass summaries, the filtered pass list, and the wheels of a pass."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Literal, cast

from sqlalchemy import Select, func, select, text
from sqlalchemy.orm import Session

from backend.api.schemas import JobProgress, MethodResult, Page, PassSummary, PassWheelRead, Side
from backend.services.margins import PARAMETERS
from backend.services.review import (
    PRIMARY_METHOD,
    disagreement_thresholds,
    method_disagreements,
    wheel_reviews,
)
from db.models import Frame, Job, Measurement, MeasurementMargin, Pass, PassWheel, Site, Wheel

LABELS = {p.key: p.label for p in PARAMETERS}
Level = Literal["ok", "near", "alarm", "none"]

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


def database_dialect(session: Session) -> str:
    """The database's dialect name ("sqlite", "postgresql") once it has answered a query."""
    session.execute(text("SELECT 1"))
    return session.get_bind().dialect.name


def jobs_progress(session: Session, job_id: int | None = None) -> list[JobProgress]:
    """The progress of job `job_id` (empty if there is none), or with None of every
    unfinished job, newest first (200 at most)."""
    if job_id is not None:
        job = session.get(Job, job_id)
        return [job_progress(job)] if job else []
    active = session.scalars(
        select(Job).where(Job.state != "done").order_by(Job.id.desc()).limit(200)
    )
    return [job_progress(job) for job in active]


def _alarm_count(session: Session, pass_id: int) -> int:
    count = session.scalar(
        select(func.coalesce(func.sum(Measurement.alarm_count), 0))
        .join(PassWheel, Measurement.pass_wheel_id == PassWheel.id)
        .where(PassWheel.pass_id == pass_id, Measurement.method == PRIMARY_METHOD)
    )
    return int(count or 0)


def _levels(session: Session, pass_id: int) -> tuple[int, list[str]]:
    """Wheels of a pass near a limit and in none, and the values in alarm in words."""
    rows = session.execute(
        select(PassWheel.id, Wheel, MeasurementMargin)
        .join(Wheel, PassWheel.wheel_id == Wheel.id)
        .join(Measurement, Measurement.pass_wheel_id == PassWheel.id)
        .join(MeasurementMargin, MeasurementMargin.measurement_id == Measurement.id)
        .where(
            PassWheel.pass_id == pass_id,
            Measurement.method == PRIMARY_METHOD,
            MeasurementMargin.level != "ok",
        )
        .order_by(PassWheel.id, MeasurementMargin.margin_fraction)
    ).all()
    alarmed = {pw for pw, _, m in rows if m.level == "alarm"}
    near = {pw for pw, _, m in rows if m.level == "near"} - alarmed
    values = [
        f"{w.vehicle_id} axle {w.axle} {w.side}: {LABELS.get(m.parameter, m.parameter)} "
        f"{m.value_mm:.2f} mm"
        for _, w, m in rows
        if m.level == "alarm"
    ]
    return len(near), values


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
    near_limit_count, alarm_values = _levels(session, train_pass.id)
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
            "near_limit_count": near_limit_count,
            "alarm_values": alarm_values,
        }
    )


def _filtered(query: Select, where: PassFilter) -> Select:
    if where.site is not None:
        query = query.join(Site, Pass.site_id == Site.id).where(
            Site.name.icontains(where.site, autoescape=True)
        )
    if where.vehicle is not None:
        query = query.where(
            Pass.id.in_(
                select(PassWheel.pass_id)
                .join(Wheel, PassWheel.wheel_id == Wheel.id)
                .where(Wheel.vehicle_id.icontains(where.vehicle, autoescape=True))
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


def pass_wheels(
    session: Session, train_pass: Pass, only: list[PassWheel] | None = None
) -> list[PassWheelRead]:
    """Every wheel of a pass (or the `only` ones) in train order, with its results per
    method, margins, disposition in force and method disagreement."""
    chosen = train_pass.wheels if only is None else only
    counts: dict[tuple[str, int, str], int] = {}
    for vehicle_id, axle, sensor, count in session.execute(
        select(Frame.vehicle_id, Frame.axle, Frame.sensor, func.count(Frame.id))
        .where(Frame.pass_id == train_pass.id)
        .group_by(Frame.vehicle_id, Frame.axle, Frame.sensor)
    ):
        counts[(vehicle_id, axle, sensor)] = count
    reviews = wheel_reviews(session, chosen)
    thresholds_mm = disagreement_thresholds(session, train_pass.fleet)
    result = []
    for pass_wheel in chosen:
        wheel = pass_wheel.wheel
        results = [method_result(m) for m in pass_wheel.measurements]
        primary = [r for r in results if r.method == PRIMARY_METHOD]
        review = reviews[pass_wheel.id]
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
                level=cast(Level, review.level),
                margins=review.margins,
                disposition=review.disposition,
                method_disagreement=method_disagreements(results, thresholds_mm),
            )
        )
    return result
