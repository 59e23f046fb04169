"""Passes: upload an archive (operator), list, read one, its wheels (viewer)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request, status
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from backend.api.deps import (
    Offset,
    OperatorDep,
    PassDep,
    RunnerDep,
    SessionDep,
    SettingsDep,
    StoreDep,
    ViewerDep,
)
from backend.api.schemas import Page, PassAccepted, PassSummary, PassWheelRead, UtcDateTime
from backend.errors import ERROR_RESPONSES, InvalidInputError
from backend.services.ingest import ingest_upload
from backend.services.queries import PassFilter, list_passes, pass_summary, pass_wheels

router = APIRouter(prefix="/api/passes", tags=["passes"], responses=ERROR_RESPONSES)


UPLOAD_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "required": ["file"],
                    "properties": {
                        "file": {
                            "type": "string",
                            "format": "binary",
                            "minLength": 1,
                            "description": "a wheelscan-pass/1 zip",
                        }
                    },
                }
            }
        },
    }
}
"""The multipart body, documented by hand: the route reads it itself, after authentication."""


@router.post("", status_code=status.HTTP_202_ACCEPTED, openapi_extra=UPLOAD_BODY)
async def upload_pass(
    request: Request,
    session: SessionDep,
    settings: SettingsDep,
    store: StoreDep,
    runner: RunnerDep,
    operator: OperatorDep,
) -> PassAccepted:
    """Upload a wheelscan-pass/1 zip; it is validated in full before anything is stored.

    The token is checked before the body is read; the same archive uploaded again returns
    the pass made from it the first time.
    """
    async with request.form(max_files=1) as form:
        file = form.get("file")
        if not isinstance(file, UploadFile) or not file.filename:
            raise InvalidInputError("file: send the pass archive as multipart field 'file'")
        train_pass, job, pass_wheel_ids = await run_in_threadpool(
            ingest_upload, session, store, settings, file.file, operator
        )
    runner.submit(pass_wheel_ids)
    return PassAccepted(pass_id=train_pass.id, job_id=job.id)


@router.get("")
def get_passes(
    session: SessionDep,
    _viewer: ViewerDep,
    site: str | None = None,
    vehicle: str | None = None,
    started_from: Annotated[
        UtcDateTime | None, Query(description="ISO 8601 with a time zone, inclusive")
    ] = None,
    started_to: Annotated[
        UtcDateTime | None, Query(description="ISO 8601 with a time zone, exclusive")
    ] = None,
    alarm: Annotated[
        bool | None, Query(description="only passes with (true) or without alarms")
    ] = None,
    offset: Offset = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> Page[PassSummary]:
    """Passes, newest first, with wheels measured / not measured, alarms and live progress."""
    where = PassFilter(site, vehicle, started_from, started_to, alarm)
    return list_passes(session, where, offset, limit)


@router.get("/{pass_id}")
def get_pass(train_pass: PassDep, session: SessionDep, _viewer: ViewerDep) -> PassSummary:
    """One pass."""
    return pass_summary(session, train_pass)


@router.get("/{pass_id}/wheels")
def get_pass_wheels(
    train_pass: PassDep, session: SessionDep, _viewer: ViewerDep
) -> list[PassWheelRead]:
    """The wheels of a pass: identity, state, parameters per method, alarms, back-to-back."""
    return pass_wheels(session, train_pass)
