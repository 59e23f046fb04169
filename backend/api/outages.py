"""A database that does not answer and a disk that is full, as clear answers.

While PostgreSQL restarts (or its connection pool is exhausted, or SQLite's file stays
locked past its busy timeout) a request gets 503 {"code": "database_unavailable"} with a
Retry-After header; the engine's pool_pre_ping replaces the dead connections, so the service
recovers by itself once the database is back. A write that finds the disk full gets 507
{"code": "insufficient_storage"}. Both are logged as one warning line, not a traceback;
every other error goes on to the one handler of unexpected errors (`backend.errors`).
"""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from backend.errors import error_response
from backend.transient import DATABASE_ERRORS, is_disk_full

logger = logging.getLogger(__name__)

RETRY_AFTER_S = 5


def _caused_by_full_disk(exc: BaseException) -> bool:
    cause = exc.__cause__ or exc.__context__
    while cause is not None:
        if is_disk_full(cause):
            return True
        cause = cause.__cause__ or cause.__context__
    return False


def _disk_full(request: Request) -> JSONResponse:
    logger.warning("disk full on %s %s", request.method, request.url.path)
    return error_response(
        507,
        "the service's disk is full: nothing was stored; free space (or raise the quota) "
        "and send the request again",
        "insufficient_storage",
    )


def install_outage_handlers(app: FastAPI) -> None:
    """Answer 503 while the database is unavailable and 507 while the disk is full
    (after `backend.errors.install_error_handlers`, whose HTTP-error answer it wraps)."""

    @app.exception_handler(OSError)
    async def _os_error(request: Request, exc: OSError) -> JSONResponse:
        if not is_disk_full(exc):
            raise exc  # not an outage: the handler of unexpected errors answers 500
        return _disk_full(request)

    async def _database_error(request: Request, exc: Exception) -> JSONResponse:
        if is_disk_full(exc):
            return _disk_full(request)
        logger.warning(
            "database unavailable on %s %s: %s",
            request.method,
            request.url.path,
            str(getattr(exc, "orig", exc) or type(exc).__name__).splitlines()[0],
        )
        response = error_response(
            503,
            f"the database is not answering; send the request again in {RETRY_AFTER_S} s",
            "database_unavailable",
        )
        response.headers["Retry-After"] = str(RETRY_AFTER_S)
        return response

    for error in DATABASE_ERRORS:
        app.add_exception_handler(error, _database_error)

    answer_http_error = app.exception_handlers[StarletteHTTPException]

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        # FastAPI answers 400 "error parsing the body" when spooling a multipart body
        # to TMPDIR fails; on a full disk that is the disk's fault, not the client's.
        if _caused_by_full_disk(exc):
            return _disk_full(request)
        return await answer_http_error(request, exc)  # type: ignore[misc,no-any-return]
