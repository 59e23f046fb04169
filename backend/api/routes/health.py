"""Liveness: the service answers and its database does."""

from __future__ import annotations

from fastapi import APIRouter
from sqlalchemy import text

from backend import __version__
from backend.api.deps import SessionDep
from backend.api.schemas import Health
from pipeline import PIPELINE_VERSION

router = APIRouter(tags=["health"])


@router.get("/healthz")
def get_health(session: SessionDep) -> Health:
    """The service is up and its database answers."""
    session.execute(text("SELECT 1"))
    return Health(
        status="ok",
        database=session.get_bind().dialect.name,
        pipeline_version=PIPELINE_VERSION,
        version=__version__,
    )
