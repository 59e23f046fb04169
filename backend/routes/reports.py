"""Reports of a pass and of a wheel in a pass: CSV, JSON and PDF."""

from __future__ import annotations

from fastapi import APIRouter

router = APIRouter(prefix="/api", tags=["reports"])
