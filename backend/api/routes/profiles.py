"""Profiles in and out: a wheel's fused profile as CSV/DXF/.whl, handheld references of a
wheel, and the wayside-against-handheld comparison (one wheel, or Table 2 over passes)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Form, Query, Response, UploadFile, status
from pydantic import Field

from backend.api.deps import OperatorDep, PassWheelDep, SessionDep, ViewerDep, WheelDep
from backend.api.schemas import AgreementRead, ReferenceComparison, ReferenceRead
from backend.errors import ERROR_RESPONSES
from backend.services.agreement_report import agreement_csv, agreement_pdf
from backend.services.profile_export import MEDIA_TYPES, export_profile
from backend.services.references import (
    MAX_PROFILE_FILE_BYTES,
    add_reference,
    agreement,
    compare_with_reference,
    wheel_references,
)
from db.types import MAX_INTEGER

router = APIRouter(prefix="/api", tags=["profiles"], responses=ERROR_RESPONSES)

ProfileFormat = Literal["csv", "dxf", "whl"]
Method = Literal["adaptive", "steger"]
FILES: dict[int | str, dict[str, Any]] = {
    200: {"content": {m: {} for m in (*MEDIA_TYPES.values(), "application/pdf")}},
}


def _attachment(data: bytes, filename: str, media_type: str) -> Response:
    headers = {"Content-Disposition": f'attachment; filename="{filename}"'}
    return Response(data, media_type=media_type, headers=headers)


@router.get(
    "/passes/{pass_id}/wheels/{wheel_id}/profile.{fmt}", response_class=Response, responses=FILES
)
def get_profile_file(
    fmt: ProfileFormat, pass_wheel: PassWheelDep, _viewer: ViewerDep, method: Method = "adaptive"
) -> Response:
    """The wheel's fused profile of one method in the profile frame [mm]: CSV with a
    commented header, DXF (one 2-D polyline) or MiniProf-style ASCII `.whl`."""
    exported = export_profile(pass_wheel, method, fmt)
    return _attachment(exported.data, exported.filename, exported.media_type)


@router.post("/wheels/{wheel_id}/references", status_code=status.HTTP_201_CREATED)
def post_reference(
    wheel: WheelDep,
    file: UploadFile,
    session: SessionDep,
    operator: OperatorDep,
    measured_at: Annotated[
        datetime | None, Form(description="when the gauge measured (ISO 8601 with zone)")
    ] = None,
) -> ReferenceRead:
    """Import a handheld-gauge profile of the wheel (MiniProf `.whl`/`.prr` ASCII, or CSV
    of x, z). Its Sh, Sd and qR are computed by the wayside code; sparse flanks are
    interpolated and flagged. The same file again returns the stored reference."""
    data = file.file.read(MAX_PROFILE_FILE_BYTES + 1)
    row = add_reference(session, wheel, file.filename or "", data, measured_at, operator)
    return ReferenceRead.model_validate(row)


@router.get("/wheels/{wheel_id}/references")
def get_references(wheel: WheelDep, session: SessionDep, _viewer: ViewerDep) -> list[ReferenceRead]:
    """The wheel's handheld references, newest measurement first."""
    return wheel_references(session, wheel.id)


@router.get("/passes/{pass_id}/wheels/{wheel_id}/reference-comparison")
def get_reference_comparison(
    pass_wheel: PassWheelDep, session: SessionDep, _viewer: ViewerDep
) -> ReferenceComparison:
    """The wheel's results against its handheld reference nearest in time to the pass:
    wayside − handheld per parameter and method (no reference: `reference` null)."""
    return compare_with_reference(session, pass_wheel)


PassIds = Annotated[
    list[Annotated[int, Field(ge=1, le=MAX_INTEGER)]] | None,
    Query(description="only these passes (default all)"),
]


@router.get("/references/agreement")
def get_agreement(
    session: SessionDep, _viewer: ViewerDep, pass_id: PassIds = None
) -> AgreementRead:
    """Wayside against handheld over every wheel with a reference (paper's Table 2 form):
    per parameter and method the mean difference, MAE, Std, max error and n [mm]."""
    return agreement(session, pass_id)


@router.get("/references/agreement.{fmt}", response_class=Response, responses=FILES)
def get_agreement_file(
    fmt: Literal["csv", "pdf"], session: SessionDep, _viewer: ViewerDep, pass_id: PassIds = None
) -> Response:
    """The agreement table as CSV or PDF."""
    table = agreement(session, pass_id)
    if fmt == "csv":
        return _attachment(agreement_csv(table), "wheelscan-agreement.csv", "text/csv")
    return _attachment(agreement_pdf(table), "wheelscan-agreement.pdf", "application/pdf")
