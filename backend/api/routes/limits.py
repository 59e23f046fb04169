"""Fleet alarm limits: read (viewer), replace (admin)."""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter
from sqlalchemy import select

from backend.api.deps import AdminDep, SessionDep, ViewerDep
from backend.api.schemas import LimitsRead, LimitsUpdate
from backend.errors import ERROR_RESPONSES, InvalidInputError
from backend.services.auth import record_audit
from backend.services.limits import ensure_default_limits
from db.models import FleetLimit
from db.types import utc_now

router = APIRouter(prefix="/api/limits", tags=["limits"], responses=ERROR_RESPONSES)

Family = Literal["EN", "LM"]


@router.get("")
def list_limits(
    session: SessionDep, _viewer: ViewerDep, fleet: str = "default"
) -> list[LimitsRead]:
    """The limits of a fleet for both profile families (defaults until edited)."""
    ensure_default_limits(session, fleet)
    session.commit()
    rows = session.scalars(
        select(FleetLimit).where(FleetLimit.fleet == fleet).order_by(FleetLimit.wheel_profile)
    )
    return [LimitsRead.model_validate(row) for row in rows]


@router.put("/{fleet}/{wheel_profile}")
def put_limits(
    fleet: str, wheel_profile: Family, body: LimitsUpdate, session: SessionDep, admin: AdminDep
) -> LimitsRead:
    """Replace the limits of one fleet and profile family; applies to wheels measured next."""
    for stem in ("flange_height", "flange_thickness", "back_to_back"):
        low, high = getattr(body, f"{stem}_min_mm"), getattr(body, f"{stem}_max_mm")
        if low >= high:
            raise InvalidInputError(f"{stem}_min_mm ({low}) must be below {stem}_max_mm ({high})")
    ensure_default_limits(session, fleet)
    row = session.scalars(
        select(FleetLimit).where(
            FleetLimit.fleet == fleet, FleetLimit.wheel_profile == wheel_profile
        )
    ).one()
    before = LimitsRead.model_validate(row).model_dump(mode="json")
    for name, value in body.model_dump().items():
        setattr(row, name, value)
    row.updated_at = utc_now()
    record_audit(
        session,
        admin,
        "limits.update",
        "fleet_limit",
        f"{fleet}/{wheel_profile}",
        {"before": before, "after": body.model_dump()},
    )
    session.commit()
    return LimitsRead.model_validate(row)
