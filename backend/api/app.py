"""The FastAPI application: create_app() wires settings, database, store, runner and routes."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from backend import __version__
from backend.api.outages import install_outage_handlers
from backend.api.routes import ROUTERS
from backend.api.security import (
    AuthLimit,
    BodyLimits,
    BodySizeLimit,
    FailedAuthLimiter,
    FailedAuthTracker,
    SecurityHeaders,
    StrictContentTypes,
    install_log_redaction,
)
from backend.config import Settings, get_settings
from backend.errors import install_error_handlers
from backend.jobs.celery_runner import make_task_runner
from backend.jobs.runner import TaskRunner
from backend.services.ingest import incoming_dir
from backend.services.limits import ensure_default_limits
from backend.services.retention import sweep_periodically
from backend.services.review import backfill_margins
from backend.storage.store import BlobStore, remove_abandoned_temporaries
from db.engine import make_engine, make_session_factory, upgrade_database

logger = logging.getLogger(__name__)


def create_app(settings: Settings | None = None, runner: TaskRunner | None = None) -> FastAPI:
    """Build the service: migrate the database, then serve the API and the front end.

    Parameters
    ----------
    settings : Settings, optional
        Defaults to the process settings (environment variables).
    runner : TaskRunner, optional
        Where per-wheel tasks run; defaults to Celery workers when `settings.broker_url`
        is set, else a process pool of `settings.workers`.
    """
    settings = settings or get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    removed = sum(
        remove_abandoned_temporaries(folder)
        for folder in (settings.frames_dir, incoming_dir(settings))
    )
    if removed:
        logger.warning("removed %d temporary file(s) a crashed process left behind", removed)
    engine = make_engine(settings.resolved_database_url)
    upgrade_database(engine)
    session_factory = make_session_factory(engine)
    with session_factory() as session:
        ensure_default_limits(session)
        session.commit()
        filled = backfill_margins(session)
    if filled:
        logger.info("kept the limit margins of %d earlier measurement(s)", filled)
    task_runner = runner or make_task_runner(settings, session_factory)
    store = BlobStore(settings.frames_dir)

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        resumed = task_runner.resume()
        if resumed:
            logger.info("resumed %d interrupted wheel measurement(s)", resumed)
        retention = None
        if settings.frame_retention_days is not None:
            retention = asyncio.create_task(
                sweep_periodically(
                    session_factory,
                    store,
                    settings.frame_retention_days,
                    settings.retention_sweep_interval_s,
                )
            )
        yield
        if retention is not None:
            retention.cancel()  # waits for a sweep under way: its thread is not interrupted
            with contextlib.suppress(asyncio.CancelledError):
                await retention
        task_runner.shutdown()
        engine.dispose()

    app = FastAPI(
        title="wheelscan",
        summary="Wayside railway wheel profile measurement: passes, wheels, jobs and reports.",
        version=__version__,
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.session_factory = session_factory
    app.state.store = store
    app.state.runner = task_runner
    install_error_handlers(app)
    install_outage_handlers(app)
    app.add_middleware(
        BodySizeLimit, limits=BodyLimits(settings.max_upload_bytes, settings.max_frame_bytes)
    )
    app.state.auth_tracker = FailedAuthTracker(AuthLimit())
    app.add_middleware(StrictContentTypes)
    app.add_middleware(FailedAuthLimiter, tracker=app.state.auth_tracker)
    app.add_middleware(SecurityHeaders)
    install_log_redaction()
    for router in ROUTERS:
        app.include_router(router)
    if settings.frontend_dir.is_dir():
        app.mount("/", StaticFiles(directory=settings.frontend_dir, html=True), name="frontend")
    return app
