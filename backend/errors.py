"""Domain exceptions of the service and the one handler that turns them into responses.

Every error body has the same shape: {"detail": str, "code": str}.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request, routing
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import DataError
from starlette.exceptions import HTTPException as StarletteHTTPException

from backend.api.schemas import ErrorRead
from pipeline import PipelineError

logger = logging.getLogger(__name__)


ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    status: {"model": ErrorRead, "description": description}
    for status, description in (
        (400, "the request body could not be parsed"),
        (401, "no token, or an unknown, expired or revoked one"),
        (403, "the token's role is too low for this route"),
        (404, "no such object"),
        (409, "the object's state does not allow this"),
        (413, "the request body is too large"),
        (422, "invalid input"),
        (429, "too many failed authentications from this address"),
        (503, "the database does not answer (restarting); retry after Retry-After"),
        (507, "the disk is full"),
    )
}
"""The error answers every /api route may give, all {"detail", "code"}: documented once,
on each router, so the OpenAPI document lists what the routes really answer."""


class ServiceError(Exception):
    """Base of the errors a request can end with; subclasses fix status and code."""

    status_code = 500
    code = "internal_error"

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail


class NotFoundError(ServiceError):
    status_code = 404
    code = "not_found"


class ConflictError(ServiceError):
    status_code = 409
    code = "conflict"


class GoneError(ServiceError):
    status_code = 410
    code = "gone"


class InvalidInputError(ServiceError):
    status_code = 422
    code = "invalid_input"


class PayloadTooLargeError(ServiceError):
    status_code = 413
    code = "too_large"


class UnauthorizedError(ServiceError):
    status_code = 401
    code = "unauthorized"


class ForbiddenError(ServiceError):
    status_code = 403
    code = "forbidden"


def error_response(
    status_code: int, detail: str, code: str, headers: dict[str, str] | None = None
) -> JSONResponse:
    """The one error body shape (with `headers`, such as a 405's Allow)."""
    headers = dict(headers or {})
    if status_code == 401:
        headers["WWW-Authenticate"] = "Bearer"
    return JSONResponse({"detail": detail, "code": code}, status_code=status_code, headers=headers)


def _format_validation_error(exc: RequestValidationError) -> str:
    parts = []
    for error in exc.errors():
        where = ".".join(str(item) for item in error.get("loc", ()) if item != "body")
        parts.append(f"{where}: {error.get('msg', 'invalid')}" if where else error["msg"])
    return "; ".join(parts) or "invalid request"


def _allowed_methods(request: Request) -> list[str]:
    """Every method some route of this path takes (Starlette names only the first route's)."""
    methods: set[str] = set()
    for context in routing.iter_route_contexts(request.app.routes):
        pattern = getattr(context, "path_regex", None)
        if pattern is not None and pattern.match(request.url.path):
            methods |= set(getattr(context, "methods", None) or ())
    return sorted(methods)


def install_error_handlers(app: FastAPI) -> None:
    """Translate domain, pipeline, validation and HTTP errors into {"detail", "code"}."""

    @app.exception_handler(ServiceError)
    async def _service_error(_request: Request, exc: ServiceError) -> JSONResponse:
        return error_response(exc.status_code, exc.detail, exc.code)

    @app.exception_handler(PipelineError)
    async def _pipeline_error(_request: Request, exc: PipelineError) -> JSONResponse:
        return error_response(422, str(exc), "invalid_input")

    @app.exception_handler(RequestValidationError)
    async def _validation_error(_request: Request, exc: RequestValidationError) -> JSONResponse:
        return error_response(422, _format_validation_error(exc), "invalid_input")

    @app.exception_handler(DataError)
    async def _data_error(_request: Request, exc: DataError) -> JSONResponse:
        # The database refused a value as data (PostgreSQL text with a NUL byte): the
        # request's input, which no schema constraint could express, not a server fault.
        reason = str(exc.orig).splitlines()[0] if exc.orig is not None else "invalid value"
        return error_response(
            422, f"the database cannot store this input: {reason}", "invalid_input"
        )

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        headers = dict(exc.headers or {})
        if exc.status_code == 405:
            headers["Allow"] = ", ".join(_allowed_methods(request))
        return error_response(exc.status_code, str(exc.detail), f"http_{exc.status_code}", headers)

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> JSONResponse:
        logger.exception("unexpected error on %s %s", request.method, request.url.path)
        return error_response(500, f"internal error: {type(exc).__name__}", "internal_error")
