"""Jobs: read one (viewer); progress over WebSockets (token in the query string)."""

from __future__ import annotations

import asyncio

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from sqlalchemy.orm import Session, sessionmaker
from starlette.concurrency import run_in_threadpool

from backend.api.deps import JobDep, RowId, ViewerDep
from backend.api.schemas import JobProgress, JobRead
from backend.api.security import WS_POLICY_VIOLATION
from backend.errors import ERROR_RESPONSES, ServiceError
from backend.services.auth import authenticate, require_role
from backend.services.queries import jobs_progress

router = APIRouter(prefix="/api", tags=["jobs"], responses=ERROR_RESPONSES)

POLL_INTERVAL_S = 0.25
"""How often a progress socket looks at the job rows (the database is the truth)."""


@router.get("/jobs/{job_id}")
def get_job(job: JobDep, _viewer: ViewerDep) -> JobRead:
    """State and progress of a measurement job."""
    return JobRead.model_validate(job)


def _authorised(factory: sessionmaker[Session], token: str | None) -> str | None:
    """None when `token` may read, else the reason."""
    with factory() as session:
        try:
            require_role(authenticate(session, token), "viewer")
        except ServiceError as exc:
            return exc.detail
    return None


def _read_progress(factory: sessionmaker[Session], job_id: int | None) -> list[JobProgress]:
    with factory() as session:
        return jobs_progress(session, job_id)


async def _push_progress(websocket: WebSocket, job_id: int | None) -> None:
    factory = websocket.app.state.session_factory
    reason = await run_in_threadpool(_authorised, factory, websocket.query_params.get("token"))
    if reason is not None:
        await websocket.close(code=WS_POLICY_VIOLATION, reason=reason[:120])
        return
    await websocket.accept()
    sent: dict[int, JobProgress] = {}
    # A socket only learns of a closed client when it sends or receives; the pass list's
    # sends only on a change, so the client's close is awaited beside the polling (else a
    # closed page would leave a task polling the database until the server stops).
    closed = asyncio.ensure_future(_until_closed(websocket))
    try:
        while not closed.done():
            for progress in await run_in_threadpool(_read_progress, factory, job_id):
                if sent.get(progress.job_id) != progress:
                    await websocket.send_json(progress.model_dump())
                    sent[progress.job_id] = progress
            if job_id is not None and (job_id not in sent or sent[job_id].state == "done"):
                await websocket.close()
                return
            await asyncio.wait({closed}, timeout=POLL_INTERVAL_S)
    except WebSocketDisconnect:
        return
    finally:
        closed.cancel()
        if closed.done() and not closed.cancelled():
            closed.exception()  # a receive that failed: the socket is gone all the same


async def _until_closed(websocket: WebSocket) -> None:
    """Return when the client closes (anything else it sends is ignored)."""
    while (await websocket.receive())["type"] != "websocket.disconnect":
        pass


@router.websocket("/ws/jobs/{job_id}")
async def job_socket(websocket: WebSocket, job_id: RowId) -> None:
    """Pushes {"job_id", "pass_id", "state", "progress", "wheels_done", "wheels_total"} on
    every change, and closes once the job is done."""
    await _push_progress(websocket, job_id)


@router.websocket("/ws/passes")
async def passes_socket(websocket: WebSocket) -> None:
    """Pushes the progress of every unfinished job (the pass list's live column)."""
    await _push_progress(websocket, None)
