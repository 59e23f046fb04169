"""Vehicles: search by id, and one vehicle's wheels over its passes (viewer)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query

from backend.api.deps import SessionDep, ViewerDep
from backend.api.schemas import VehicleHistory
from backend.errors import ERROR_RESPONSES
from backend.services.vehicles import search_vehicles, vehicle_history

router = APIRouter(prefix="/api/vehicles", tags=["vehicles"], responses=ERROR_RESPONSES)


@router.get("")
def get_vehicles(
    session: SessionDep,
    _viewer: ViewerDep,
    q: Annotated[str, Query(min_length=1, max_length=100, description="part of a vehicle id")],
    limit: Annotated[int, Query(ge=1, le=100)] = 20,
) -> list[str]:
    """Vehicle ids containing `q` (case-insensitive), an exact match first."""
    return search_vehicles(session, q, limit)


@router.get("/{vehicle_id}")
def get_vehicle(
    session: SessionDep,
    _viewer: ViewerDep,
    vehicle_id: Annotated[str, Path(min_length=1, max_length=100)],
) -> VehicleHistory:
    """A vehicle's wheels in each of its passes (newest first): values, levels, dispositions."""
    return vehicle_history(session, vehicle_id)
