"""The 3D view of a wheel: builds its viser scene and returns the URL the page embeds."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Annotated, Literal

from fastapi import APIRouter, FastAPI, Query, Request
from fastapi.concurrency import run_in_threadpool
from pydantic import BaseModel

from backend.api.deps import PassWheelDep, SessionDep, SettingsDep, StoreDep, ViewerDep
from backend.errors import ERROR_RESPONSES
from backend.services.viewer import WheelViewer, load_wheel_scene_data


@asynccontextmanager
async def stop_viewer_on_shutdown(app: FastAPI) -> AsyncIterator[None]:
    """Stop the viser server (started on first use) with the app: its threads would
    otherwise keep the process alive after the HTTP server stopped."""
    yield
    viewer: WheelViewer | None = getattr(app.state, "viewer", None)
    if viewer is not None:
        viewer.stop()


router = APIRouter(
    prefix="/api", tags=["3D viewer"], lifespan=stop_viewer_on_shutdown, responses=ERROR_RESPONSES
)


class ViewerRead(BaseModel):
    """Where the 3D view of a wheel is served (embed `url` in an iframe)."""

    url: str
    wheel_id: int
    method: str


@router.get("/passes/{pass_id}/wheels/{wheel_id}/viewer")
async def get_wheel_viewer(
    request: Request,
    _viewer: ViewerDep,
    pass_wheel: PassWheelDep,
    session: SessionDep,
    store: StoreDep,
    settings: SettingsDep,
    method: Annotated[Literal["adaptive", "steger"], Query()] = "adaptive",
) -> ViewerRead:
    """Show the wheel in the 3D viewer; returns the viewer's URL (for an iframe).

    The token is checked before the wheel is looked up, so no one learns which wheels exist
    without one."""
    data = await run_in_threadpool(load_wheel_scene_data, session, store, pass_wheel, method)
    viewer: WheelViewer = getattr(request.app.state, "viewer", None) or WheelViewer(settings)
    request.app.state.viewer = viewer
    port = await run_in_threadpool(viewer.show, data)
    host = request.url.hostname or settings.viewer_host
    return ViewerRead(url=f"http://{host}:{port}/", wheel_id=data.wheel_id, method=method)
