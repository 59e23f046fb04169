"""Vehicles: found by any part of their id, and a vehicle's wheels over its passes."""

from __future__ import annotations

from sqlalchemy import case, func, select
from sqlalchemy.orm import Session

from backend.api.schemas import VehicleHistory, VehiclePass
from backend.errors import NotFoundError
from backend.services.queries import pass_wheels
from db.models import Pass, PassWheel, Wheel

HISTORY_PASSES = 50
"""Newest passes shown in a vehicle's history."""


def search_vehicles(session: Session, text: str, limit: int) -> list[str]:
    """Vehicle ids containing `text` (case-insensitive), exact match first, then by id."""
    exact_first = case((func.lower(Wheel.vehicle_id) == text.lower(), 0), else_=1)
    rows = session.scalars(
        select(Wheel.vehicle_id)
        .where(Wheel.vehicle_id.icontains(text, autoescape=True))
        .group_by(Wheel.vehicle_id)
        .order_by(exact_first, Wheel.vehicle_id)
        .limit(limit)
    )
    return list(rows)


def vehicle_history(session: Session, vehicle_id: str) -> VehicleHistory:
    """The vehicle's wheels in each of its newest passes, newest pass first."""
    rows = session.execute(
        select(PassWheel, Pass)
        .join(Pass, PassWheel.pass_id == Pass.id)
        .join(Wheel, PassWheel.wheel_id == Wheel.id)
        .where(Wheel.vehicle_id == vehicle_id)
        .order_by(Pass.started_at.desc(), Pass.id.desc(), Wheel.axle, Wheel.side)
    ).all()
    if not rows:
        raise NotFoundError(f"vehicle {vehicle_id!r} has no wheels in any pass")
    by_pass: dict[int, tuple[Pass, list[PassWheel]]] = {}
    for pass_wheel, train_pass in rows:
        by_pass.setdefault(train_pass.id, (train_pass, []))[1].append(pass_wheel)
    passes = [
        VehiclePass(
            pass_id=train_pass.id,
            started_at=train_pass.started_at,
            site=train_pass.site.name,
            wheels=pass_wheels(session, train_pass, only=chosen),
        )
        for train_pass, chosen in list(by_pass.values())[:HISTORY_PASSES]
    ]
    return VehicleHistory(vehicle_id=vehicle_id, passes=passes)
