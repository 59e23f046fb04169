"""Reports of a pass and of one wheel in a pass: CSV, JSON and PDF (attachments).

The PDF carries an ETag of its content: a browser that holds it gets 304, and the service
renders it again only when a result, the limits or a disposition changed.
"""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Request, Response
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from backend.api.deps import PassDep, PassWheelDep, SessionDep, SettingsDep, ViewerDep
from backend.api.schemas import PassReport
from backend.config import Settings
from backend.errors import ERROR_RESPONSES
from backend.services.reports import report_content, report_csv, report_pdf
from db.models import Pass, PassWheel

router = APIRouter(prefix="/api", tags=["reports"], responses=ERROR_RESPONSES)

Format = Literal["csv", "json", "pdf"]
MEDIA_TYPES = {"csv": "text/csv", "json": "application/json", "pdf": "application/pdf"}
FILES: dict[int | str, dict[str, Any]] = {
    200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
    304: {"description": "the PDF the browser holds (If-None-Match) is current"},
}
DISPOSITIONS: dict[int, str] = {}
"""Dispositions per wheel id shown in the PDF; none until wheels are reviewed."""


def _render(
    session: Session,
    settings: Settings,
    train_pass: Pass,
    fmt: str,
    only: PassWheel | None,
    if_none_match: str | None,
) -> Response:
    stem = f"wheelscan-pass-{train_pass.id}" + (f"-wheel-{only.wheel_id}" if only else "")
    filename = f"{stem}.{fmt}"
    content = report_content(session, train_pass, only, DISPOSITIONS)
    etag = f'"{content.key[:32]}"'
    if fmt == "csv":
        data = report_csv(content.summary, content.wheels)
    elif fmt == "json":
        report = PassReport.model_validate(
            {"pass": content.summary, "limits": content.limits, "wheels": content.wheels}
        )
        data = report.model_dump_json(by_alias=True).encode()
    elif if_none_match == etag:
        return Response(status_code=304, headers={"ETag": etag})
    else:
        data = report_pdf(content, settings.data_dir / "reports")
    headers = {"Content-Disposition": f'attachment; filename="{filename}"'}
    if fmt == "pdf":
        headers |= {"ETag": etag, "Cache-Control": "private, no-cache"}
    return Response(data, media_type=MEDIA_TYPES[fmt], headers=headers)


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
    match = request.headers.get("if-none-match")
    return await run_in_threadpool(_render, session, settings, train_pass, fmt, None, match)


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
    match = request.headers.get("if-none-match")
    train_pass = pass_wheel.train_pass
    return await run_in_threadpool(_render, session, settings, train_pass, fmt, pass_wheel, match)
