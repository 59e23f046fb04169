"""HTTP routes, one module per resource (plural nouns)."""

from __future__ import annotations

from fastapi import APIRouter

from backend.api.routes import (
    blobs,
    calibrations,
    health,
    jobs,
    limits,
    passes,
    profiles,
    reports,
    review,
    streams,
    tokens,
    vehicles,
    viewer,
    wheels,
)

ROUTERS: list[APIRouter] = [
    health.router,
    tokens.router,
    calibrations.router,
    limits.router,
    passes.router,
    streams.router,
    jobs.router,
    wheels.router,
    reports.router,
    profiles.router,
    blobs.router,
    viewer.router,
    review.router,
    vehicles.router,
]
