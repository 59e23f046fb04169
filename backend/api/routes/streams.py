"""Live streaming of a pass (README: live streaming): open, put frames, declare, close."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query, Request, Response, status
from starlette.concurrency import run_in_threadpool

from backend.api.deps import OperatorDep, PassDep, RunnerDep, SessionDep, StoreDep
from backend.api.schemas import (
    FramePut,
    FrameRead,
    MissingSensor,
    PassAccepted,
    Sensor,
    StreamOpen,
    WheelStateRead,
)
from backend.errors import ERROR_RESPONSES
from backend.services.streaming import (
    close_pass,
    declare_missing,
    list_frames,
    open_stream,
    put_frame,
)
from db.types import MAX_INTEGER

router = APIRouter(prefix="/api/passes", tags=["streaming"], responses=ERROR_RESPONSES)


@router.post("/stream", status_code=status.HTTP_201_CREATED)
def post_stream(body: StreamOpen, session: SessionDep, operator: OperatorDep) -> PassAccepted:
    """Open a pass to stream frames into."""
    train_pass, job = open_stream(session, body, operator)
    return PassAccepted(pass_id=train_pass.id, job_id=job.id)


@router.put(
    "/{pass_id}/frames/{sensor}/{seq}",
    status_code=status.HTTP_201_CREATED,
    responses={200: {"model": FramePut, "description": "identical frame already stored"}},
)
async def put_pass_frame(
    request: Request,
    response: Response,
    sensor: Sensor,
    seq: Annotated[int, Path(ge=0, le=MAX_INTEGER)],
    train_pass: PassDep,
    session: SessionDep,
    store: StoreDep,
    runner: RunnerDep,
    operator: OperatorDep,
    vehicle_id: Annotated[str, Query(min_length=1, max_length=100)],
    axle: Annotated[int, Query(ge=1, le=MAX_INTEGER)],
) -> FramePut:
    """Store one frame (PNG body); idempotent by sha256, any order, resumable."""
    data = await request.body()  # at most max_frame_bytes (BodySizeLimit)
    stored = await run_in_threadpool(
        put_frame,
        session,
        store,
        train_pass,
        sensor=sensor,
        seq=seq,
        vehicle_id=vehicle_id,
        axle=axle,
        data=data,
        token=operator,
    )
    if stored.queued_pass_wheel_id is not None:
        runner.submit([stored.queued_pass_wheel_id])
    if not stored.created:
        response.status_code = status.HTTP_200_OK
    return FramePut(sha256=stored.sha256, wheel_complete=stored.wheel_complete)


@router.post("/{pass_id}/wheels/missing")
def post_missing(
    body: MissingSensor, train_pass: PassDep, session: SessionDep, operator: OperatorDep
) -> WheelStateRead:
    """Declare that a sensor delivered no frames for a wheel: it is "not measured"."""
    pass_wheel = declare_missing(session, train_pass, body, operator)
    return WheelStateRead(
        vehicle_id=body.vehicle_id,
        axle=body.axle,
        side=body.side,
        state=pass_wheel.state,
        reason=pass_wheel.reason,
    )


@router.get("/{pass_id}/frames")
def get_frames(train_pass: PassDep, session: SessionDep, _operator: OperatorDep) -> list[FrameRead]:
    """Frames stored so far (a sender resuming after a dropped connection skips these)."""
    return [FrameRead.model_validate(frame) for frame in list_frames(session, train_pass)]


@router.post(
    "/{pass_id}/close",
    status_code=status.HTTP_202_ACCEPTED,
    responses={200: {"model": PassAccepted, "description": "the pass was already closed"}},
)
def post_close(
    response: Response, train_pass: PassDep, session: SessionDep, operator: OperatorDep
) -> PassAccepted:
    """Close the pass; incomplete wheels become "not measured". Closing twice answers 200."""
    job, closed_now = close_pass(session, train_pass, operator)
    if not closed_now:
        response.status_code = status.HTTP_200_OK
    return PassAccepted(pass_id=train_pass.id, job_id=job.id)
