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
    try:
        while True:
            for progress in await run_in_threadpool(_read_progress, factory, job_id):
                if sent.get(progress.job_id) != progress:
                    await websocket.send_json(progress.model_dump())
                    sent[progress.job_id] = progress
            if job_id is not None and (job_id not in sent or sent[job_id].state == "done"):
                await websocket.close()
                return
            await asyncio.sleep(POLL_INTERVAL_S)
    except WebSocketDisconnect:
        return


@router.websocket("/ws/jobs/{job_id}")
async def job_socket(websocket: WebSocket, job_id: RowId) -> None:
    """Pushes {"job_id", "pass_id", "state", "progress", "wheels_done", "wheels_total"} on
    every change, and closes once the job is done."""
    await _push_progress(websocket, job_id)


@router.websocket("/ws/passes")
async def passes_socket(websocket: WebSocket) -> None:
    """Pushes the progress of every unfinished job (the pass list's live column)."""
    await _push_progress(websocket, None)
