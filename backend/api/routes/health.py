"""Liveness: the service answers and its database does."""

from __future__ import annotations

from fastapi import APIRouter

from backend import __version__
from backend.api.deps import SessionDep
from backend.api.schemas import Health
from backend.services.queries import database_dialect
from pipeline import PIPELINE_VERSION

router = APIRouter(tags=["health"])


@router.get("/healthz")
def get_health(session: SessionDep) -> Health:
    """The service is up and its database answers."""
    return Health(
        status="ok",
        database=database_dialect(session),
        pipeline_version=PIPELINE_VERSION,
        version=__version__,
    )
