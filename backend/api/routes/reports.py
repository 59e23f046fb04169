"""Reports of a pass and of one wheel in a pass: CSV, JSON and PDF (attachments).

The PDF carries an ETag of its content: a browser that holds it gets 304, and the service
renders it again only when a result, the limits or a disposition changed.
"""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Request, Response
from starlette.concurrency import run_in_threadpool

from backend.api.deps import PassDep, PassWheelDep, SessionDep, SettingsDep, ViewerDep
from backend.errors import ERROR_RESPONSES
from backend.services.reports import MEDIA_TYPES, RenderedReport, render_report

router = APIRouter(prefix="/api", tags=["reports"], responses=ERROR_RESPONSES)

Format = Literal["csv", "json", "pdf"]
FILES: dict[int | str, dict[str, Any]] = {
    200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
    304: {"description": "the PDF the browser holds (If-None-Match) is current"},
}


def _response(report: RenderedReport) -> Response:
    headers = (
        {} if report.etag is None else {"ETag": report.etag, "Cache-Control": "private, no-cache"}
    )
    if report.data is None:
        return Response(status_code=304, headers=headers)
    headers["Content-Disposition"] = f'attachment; filename="{report.filename}"'
    return Response(report.data, media_type=report.media_type, headers=headers)


@router.get("/passes/{pass_id}/report.{fmt}", response_class=Response, responses=FILES)
async def get_pass_report(
    request: Request,
    fmt: Format,
    train_pass: PassDep,
    session: SessionDep,
    settings: SettingsDep,
    _viewer: ViewerDep,
) -> Response:
    """The pass report: every wheel with parameters per method, limits, margins, alarms."""
    report = await run_in_threadpool(
        render_report, session, settings.data_dir / "reports", train_pass, fmt, None,
        request.headers.get("if-none-match"),
    )  # fmt: skip
    return _response(report)


@router.get(
    "/passes/{pass_id}/wheels/{wheel_id}/report.{fmt}", response_class=Response, responses=FILES
)
async def get_wheel_report(
    request: Request,
    fmt: Format,
    pass_wheel: PassWheelDep,
    session: SessionDep,
    settings: SettingsDep,
    _viewer: ViewerDep,
) -> Response:
    """The report of one wheel in a pass."""
    report = await run_in_threadpool(
        render_report, session, settings.data_dir / "reports", pass_wheel.train_pass, fmt,
        pass_wheel, request.headers.get("if-none-match"),
    )  # fmt: skip
    return _response(report)
