"""Reports of a pass and of one wheel in a pass: CSV, JSON and PDF (attachments)."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Response
from starlette.concurrency import run_in_threadpool

from backend.api.deps import PassDep, PassWheelDep, SessionDep, StoreDep, ViewerDep
from backend.errors import ERROR_RESPONSES
from backend.services.reports import render_report

router = APIRouter(prefix="/api", tags=["reports"], responses=ERROR_RESPONSES)

Format = Literal["csv", "json", "pdf"]
MEDIA_TYPES = {"csv": "text/csv", "json": "application/json", "pdf": "application/pdf"}
FILES: dict[int | str, dict[str, Any]] = {
    200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
}


def _attachment(data: bytes, filename: str, fmt: str) -> Response:
    return Response(
        data,
        media_type=MEDIA_TYPES[fmt],
        headers={"Content-Disposition": f'attachment; filename="{filename}"'},
    )


@router.get("/passes/{pass_id}/report.{fmt}", response_class=Response, responses=FILES)
async def get_pass_report(
    fmt: Format, train_pass: PassDep, session: SessionDep, store: StoreDep, _viewer: ViewerDep
) -> Response:
    """The pass report: every wheel with parameters per method, limits and alarms."""
    data, filename = await run_in_threadpool(render_report, session, store, train_pass, fmt, None)
    return _attachment(data, filename, fmt)


@router.get(
    "/passes/{pass_id}/wheels/{wheel_id}/report.{fmt}", response_class=Response, responses=FILES
)
async def get_wheel_report(
    fmt: Format,
    pass_wheel: PassWheelDep,
    session: SessionDep,
    store: StoreDep,
    _viewer: ViewerDep,
) -> Response:
    """The report of one wheel in a pass."""
    train_pass = pass_wheel.train_pass
    data, filename = await run_in_threadpool(
        render_report, session, store, train_pass, fmt, pass_wheel
    )
    return _attachment(data, filename, fmt)
