"""Fleet alarm limits: read (viewer), replace (admin)."""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter

from backend.api.deps import AdminDep, SessionDep, ViewerDep
from backend.api.schemas import LimitsRead, LimitsUpdate
from backend.errors import ERROR_RESPONSES
from backend.services.limits import fleet_limits, replace_limits

router = APIRouter(prefix="/api/limits", tags=["limits"], responses=ERROR_RESPONSES)

Family = Literal["EN", "LM"]


@router.get("")
def list_limits(
    session: SessionDep, _viewer: ViewerDep, fleet: str = "default"
) -> list[LimitsRead]:
    """The limits of a fleet for both profile families (defaults until edited)."""
    return [LimitsRead.model_validate(row) for row in fleet_limits(session, fleet)]


@router.put("/{fleet}/{wheel_profile}")
def put_limits(
    fleet: str, wheel_profile: Family, body: LimitsUpdate, session: SessionDep, admin: AdminDep
) -> LimitsRead:
    """Replace the limits of one fleet and profile family; applies to wheels measured next."""
    return LimitsRead.model_validate(replace_limits(session, admin, fleet, wheel_profile, body))
