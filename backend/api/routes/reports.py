"""Reports of a pass and of one wheel in a pass: CSV, JSON and PDF (attachments)."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Response
from sqlalchemy import select
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from backend.api.deps import PassDep, PassWheelDep, SessionDep, StoreDep, ViewerDep
from backend.api.schemas import PassReport, PassWheelRead
from backend.errors import ERROR_RESPONSES
from backend.services.limits import WHEEL_PROFILES, limits_for
from backend.services.queries import pass_summary, pass_wheels
from backend.services.reports import load_wheel_figures, report_csv, report_pdf
from backend.storage.store import BlobStore
from db.models import Frame, Pass, PassWheel
from db.types import utc_now

router = APIRouter(prefix="/api", tags=["reports"], responses=ERROR_RESPONSES)

Format = Literal["csv", "json", "pdf"]
MEDIA_TYPES = {"csv": "text/csv", "json": "application/json", "pdf": "application/pdf"}
FILES: dict[int | str, dict[str, Any]] = {
    200: {"content": {m: {} for m in MEDIA_TYPES.values()}},
}


def _frames_of(session: Session, train_pass: Pass, wheel: PassWheelRead) -> list[Frame]:
    """The wheel's frames for the PDF thumbnails; none once retention removed them."""
    if train_pass.frames_removed_at is not None:
        return []
    return list(
        session.scalars(
            select(Frame)
            .where(
                Frame.pass_id == train_pass.id,
                Frame.vehicle_id == wheel.vehicle_id,
                Frame.axle == wheel.axle,
                Frame.sensor.in_((f"{wheel.side}_inner", f"{wheel.side}_outer")),
            )
            .order_by(Frame.sensor, Frame.seq)
        )
    )


def _render(
    session: Session,
    store: BlobStore,
    train_pass: Pass,
    fmt: str,
    only: PassWheel | None,
) -> tuple[bytes, str]:
    summary = pass_summary(session, train_pass)
    wheels = pass_wheels(session, train_pass)
    if only is not None:
        wheels = [w for w in wheels if w.wheel_id == only.wheel_id]
    stem = f"wheelscan-pass-{train_pass.id}" + (f"-wheel-{only.wheel_id}" if only else "")
    limits = {f: limits_for(session, train_pass.fleet, f) for f in WHEEL_PROFILES}
    if fmt == "csv":
        return report_csv(summary, wheels), f"{stem}.csv"
    if fmt == "json":
        report = PassReport.model_validate({"pass": summary, "limits": limits, "wheels": wheels})
        return report.model_dump_json(by_alias=True).encode(), f"{stem}.json"
    by_wheel = {pw.wheel_id: pw for pw in train_pass.wheels}
    figures = [
        load_wheel_figures(
            store,
            wheel,
            by_wheel[wheel.wheel_id].measurements,
            _frames_of(session, train_pass, wheel),
        )
        for wheel in wheels
    ]
    title = "Wheel profile report" if only else "Train pass wheel report"
    generated = f"{utc_now():%Y-%m-%d %H:%M} UTC"
    pdf = report_pdf(summary, wheels, limits, figures, title=title, generated_at=generated)
    return pdf, f"{stem}.pdf"


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
    data, filename = await run_in_threadpool(_render, session, store, train_pass, fmt, None)
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
    data, filename = await run_in_threadpool(_render, session, store, train_pass, fmt, pass_wheel)
    return _attachment(data, filename, fmt)
