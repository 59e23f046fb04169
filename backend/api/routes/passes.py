"""Passes: upload an archive (operator), list, read one, its wheels (viewer)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated

from fastapi import APIRouter, Query, UploadFile, status

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
from backend.api.schemas import Page, PassAccepted, PassSummary, PassWheelRead
from backend.errors import ERROR_RESPONSES, InvalidInputError
from backend.services.ingest import (
    discard,
    existing_upload,
    receive_upload,
    store_archive,
    validate_archive,
)
from backend.services.queries import PassFilter, list_passes, pass_summary, pass_wheels

router = APIRouter(prefix="/api/passes", tags=["passes"], responses=ERROR_RESPONSES)


@router.post("", status_code=status.HTTP_202_ACCEPTED)
def upload_pass(
    file: UploadFile,
    session: SessionDep,
    settings: SettingsDep,
    store: StoreDep,
    runner: RunnerDep,
    operator: OperatorDep,
) -> PassAccepted:
    """Upload a wheelscan-pass/1 zip; it is validated in full before anything is stored.

    The same archive uploaded again returns the pass made from it the first time.
    """
    if file.filename is not None and not file.filename:
        raise InvalidInputError("file: send the pass archive as multipart field 'file'")
    path, archive_sha256 = receive_upload(file.file, settings)
    try:
        found = existing_upload(session, archive_sha256)
        if found is not None:
            return PassAccepted(pass_id=found[0].id, job_id=found[1].id)
        archive = validate_archive(session, path, settings)
        train_pass, job, pass_wheel_ids = store_archive(
            session, store, archive, archive_sha256, operator
        )
    finally:
        discard(path)
    runner.submit(pass_wheel_ids)
    return PassAccepted(pass_id=train_pass.id, job_id=job.id)


@router.get("")
def get_passes(
    session: SessionDep,
    _viewer: ViewerDep,
    site: str | None = None,
    vehicle: str | None = None,
    started_from: Annotated[datetime | None, Query(description="ISO 8601, inclusive")] = None,
    started_to: Annotated[datetime | None, Query(description="ISO 8601, exclusive")] = None,
    alarm: Annotated[
        bool | None, Query(description="only passes with (true) or without alarms")
    ] = None,
    offset: Offset = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> Page[PassSummary]:
    """Passes, newest first, with wheels measured / not measured, alarms and live progress."""
    for name, value in (("started_from", started_from), ("started_to", started_to)):
        if value is not None and value.tzinfo is None:
            raise InvalidInputError(f"{name} must carry a time zone (e.g. 2026-05-01T00:00:00Z)")
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
