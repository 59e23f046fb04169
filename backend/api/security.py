"""Security middleware: failed-authentication rate limiting, response headers, log redaction.

Both middlewares are plain ASGI so they also see requests refused before the routes run.
"""

from __future__ import annotations

import logging
import re
import time
from collections import OrderedDict, deque
from collections.abc import Mapping
from dataclasses import dataclass

from starlette.datastructures import Headers
from starlette.responses import Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from backend.errors import PayloadTooLargeError, error_response

REDACTED = "[redacted]"
_SECRET_PATTERNS = (
    re.compile(r"(?i)(bearer\s+)[^\s\"',]+"),
    re.compile(r"(?i)([?&]token=)[^&\s\"']+"),
    re.compile(r"wst_[A-Za-z0-9_\-]+"),
)
_HOST = re.compile(r"^[A-Za-z0-9.\-\[\]:]{1,255}$")
UNFRAMED_DOC_PATHS = ("/docs", "/redoc")
"""FastAPI's own documentation pages load their scripts from a CDN: no CSP on them."""


@dataclass(frozen=True, slots=True)
class AuthLimit:
    """How many failed authentications a client address may make in a window.

    Attributes
    ----------
    max_failures : int
        Failures allowed per window; the next request from that address gets 429.
    window_s : float
        Length of the sliding window [s].
    max_addresses : int
        Addresses remembered at most (the least recently failing ones are forgotten).
    """

    max_failures: int = 30
    window_s: float = 60.0
    max_addresses: int = 10_000

    def __post_init__(self) -> None:
        if self.max_failures < 1:
            raise ValueError(f"max_failures must be >= 1, got {self.max_failures}")
        if self.window_s <= 0:
            raise ValueError(f"window_s must be > 0, got {self.window_s}")
        if self.max_addresses < 1:
            raise ValueError(f"max_addresses must be >= 1, got {self.max_addresses}")


class FailedAuthTracker:
    """Sliding-window count of failed authentications per client address, bounded in memory."""

    def __init__(self, limit: AuthLimit) -> None:
        self.limit = limit
        self._failures: OrderedDict[str, deque[float]] = OrderedDict()

    def _recent(self, address: str, now_s: float) -> deque[float] | None:
        times = self._failures.get(address)
        if times is None:
            return None
        while times and times[0] <= now_s - self.limit.window_s:
            times.popleft()
        if not times:
            del self._failures[address]
            return None
        return times

    def retry_after_s(self, address: str, now_s: float | None = None) -> float:
        """Seconds until `address` may try again (0 when it is not blocked)."""
        now_s = time.monotonic() if now_s is None else now_s
        times = self._recent(address, now_s)
        if times is None or len(times) < self.limit.max_failures:
            return 0.0
        return max(times[0] + self.limit.window_s - now_s, 0.0)

    def record_failure(self, address: str, now_s: float | None = None) -> None:
        """Count one failed authentication of `address`."""
        now_s = time.monotonic() if now_s is None else now_s
        times = self._recent(address, now_s)
        if times is None:
            times = deque(maxlen=self.limit.max_failures)
            self._failures[address] = times
        times.append(now_s)
        self._failures.move_to_end(address)
        while len(self._failures) > self.limit.max_addresses:
            self._failures.popitem(last=False)

    def __len__(self) -> int:
        return len(self._failures)


def _presents_credentials(scope: Scope) -> bool:
    headers = Headers(scope=scope)
    return "authorization" in headers or b"token=" in scope.get("query_string", b"")


WS_POLICY_VIOLATION = 4401
"""Close code of a WebSocket refused for its token (4000 + the HTTP status)."""
WS_RATE_LIMITED = 4429
"""Close code of a WebSocket refused for its token from an address over the limit."""


def _refusal(address: str, wait_s: float) -> Response:
    response = error_response(
        429,
        f"too many failed authentications from {address}; retry in {wait_s:.0f} s",
        "rate_limited",
    )
    response.headers["Retry-After"] = str(max(int(wait_s + 0.999), 1))
    return response


class FailedAuthLimiter:
    """Count the 401s (and refused WebSocket tokens) of each address; over the limit, its
    failed authentications are answered 429 instead of 401.

    Valid tokens from that address keep working (a depot behind one NAT is not locked out
    by one guesser); requests without any token are not counted: they cannot guess one,
    and the front end makes them before its user has logged in.
    """

    def __init__(self, app: ASGIApp, tracker: FailedAuthTracker) -> None:
        self.app = app
        self.tracker = tracker

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket") or not _presents_credentials(scope):
            await self.app(scope, receive, send)
            return
        address = (scope.get("client") or ("unknown", 0))[0]
        refused = False

        async def watch(message: Message) -> None:
            nonlocal refused
            failed = (message["type"] == "http.response.start" and message["status"] == 401) or (
                message["type"] == "websocket.close" and message.get("code") == WS_POLICY_VIOLATION
            )
            if failed:
                wait_s = self.tracker.retry_after_s(address)
                self.tracker.record_failure(address)
                if wait_s > 0 and message["type"] == "websocket.close":
                    message = {**message, "code": WS_RATE_LIMITED, "reason": "rate limited"}
                elif wait_s > 0:
                    refused = True
                    await _refusal(address, wait_s)(scope, receive, send)
                    return
            if refused and message["type"] == "http.response.body":
                return  # the 401's body, replaced by the 429's
            await send(message)

        await self.app(scope, receive, watch)


BODY_TYPES: tuple[tuple[str, re.Pattern[str], str], ...] = (
    ("PUT", re.compile(r"^/api/passes/[^/]+/frames/"), "image/png"),
    ("PUT", re.compile(r"^/api/blobs/"), "application/octet-stream"),
    ("POST", re.compile(r"^/api/passes/?$"), "multipart/form-data"),
    ("POST", re.compile(r"^/api/wheels/[^/]+/references/?$"), "multipart/form-data"),
)
"""Bodies that are not JSON: (method, path, the one media type accepted)."""
JSON_TYPE = "application/json"


def expected_body_type(method: str, path: str) -> str | None:
    """The media type a request body must have (None: this request takes no body check)."""
    if method not in ("POST", "PUT", "PATCH", "DELETE") or not path.startswith("/api/"):
        return None
    for rule_method, pattern, media_type in BODY_TYPES:
        if method == rule_method and pattern.match(path):
            return media_type
    return JSON_TYPE


MULTIPART_OVERHEAD_BYTES = 64 * 1024
"""Room for multipart headers and boundaries around an upload of the maximum size."""
MAX_JSON_BODY_BYTES = 8 * 2**20
"""Bodies of the JSON routes at most (a calibration document has at most 1 MB)."""


@dataclass(frozen=True, slots=True)
class BodyLimits:
    """Largest request bodies [bytes]: a pass upload, a frame or blob, anything else."""

    upload_bytes: int
    frame_bytes: int
    other_bytes: int = MAX_JSON_BODY_BYTES

    def for_request(self, method: str, path: str) -> int:
        media_type = expected_body_type(method, path)
        if media_type == "multipart/form-data":
            return self.upload_bytes + MULTIPART_OVERHEAD_BYTES
        if media_type in ("image/png", "application/octet-stream"):
            return self.frame_bytes
        return self.other_bytes


class BodyTooLargeError(PayloadTooLargeError):
    """Raised by the counting `receive` when a body grows past its limit."""


def _too_large(received_bytes: int, limit_bytes: int) -> Response:
    return error_response(
        413,
        f"request body of {received_bytes} bytes or more is larger than {limit_bytes} bytes; "
        "raise WHEELSCAN_MAX_UPLOAD_BYTES / WHEELSCAN_MAX_FRAME_BYTES or split it",
        "too_large",
    )


class BodySizeLimit:
    """Refuse (413) a request body larger than its route's limit, by its Content-Length
    before reading, and by counting the bytes as they arrive (chunked bodies): reading
    stops at the limit, so no body is held or spooled beyond it.
    """

    def __init__(self, app: ASGIApp, limits: BodyLimits) -> None:
        self.app = app
        self.limits = limits

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.limits.for_request(scope["method"], scope.get("path", ""))
        declared = Headers(scope=scope).get("content-length", "0")
        if declared.isdigit() and int(declared) > limit:
            await _too_large(int(declared), limit)(scope, receive, send)
            return
        received = 0
        state = {"exceeded": False, "started": False}

        async def counted() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    state["exceeded"] = True
                    raise BodyTooLargeError(f"request body is larger than {limit} bytes")
            return message

        async def answer(message: Message) -> None:
            if state["exceeded"]:  # whatever the app made of the interrupted body: 413
                if message["type"] == "http.response.start":
                    state["started"] = True
                    await _too_large(received, limit)(scope, receive, send)
                return
            state["started"] = state["started"] or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counted, answer)
        except BodyTooLargeError:
            if state["started"]:
                raise
            await _too_large(received, limit)(scope, receive, send)


def _has_body(headers: Headers) -> bool:
    length = headers.get("content-length")
    if length is not None:
        return not length.isdigit() or int(length) > 0
    return "transfer-encoding" in headers


def _url_has_nul(scope: Scope) -> bool:
    return "\x00" in scope.get("path", "") or b"%00" in scope.get("query_string", b"")


class StrictContentTypes:
    """Refuse (415) a request body whose Content-Type is not the one its route reads, and
    (422) a URL holding a NUL character, on every database alike."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] in ("http", "websocket") and _url_has_nul(scope):
            if scope["type"] == "http":
                response = error_response(
                    422, "the URL must not contain NUL characters (%00)", "invalid_input"
                )
                await response(scope, receive, send)
            else:
                await send({"type": "websocket.close", "code": 1008, "reason": "NUL in URL"})
            return
        if scope["type"] == "http":
            expected = expected_body_type(scope["method"], scope.get("path", ""))
            headers = Headers(scope=scope)
            if expected is not None and _has_body(headers):
                given = headers.get("content-type", "").split(";", 1)[0].strip().lower()
                if given != expected:
                    shown = given or "none"
                    response = error_response(
                        415,
                        f"Content-Type must be {expected} for {scope['method']} "
                        f"{scope['path']}, got {shown}",
                        "unsupported_media_type",
                    )
                    await response(scope, receive, send)
                    return
        await self.app(scope, receive, send)


def content_security_policy(host: str | None) -> str:
    """The pages' CSP: own scripts and styles only; the 3D viewer iframe on the same host."""
    frames = "'self'"
    sockets = "'self'"
    if host and _HOST.match(host):
        name = host.rsplit(":", 1)[0] if not host.endswith("]") else host
        frames += f" http://{name}:* https://{name}:*"
        sockets += f" ws://{host} wss://{host}"
    return (
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
        f"connect-src {sockets}; frame-src {frames}; frame-ancestors 'none'; "
        "object-src 'none'; base-uri 'self'; form-action 'self'"
    )


class SecurityHeaders:
    """Add CSP, nosniff, referrer policy and frame refusal to every HTTP response."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        path = scope.get("path", "")
        csp = None
        if not path.startswith(UNFRAMED_DOC_PATHS):
            csp = content_security_policy(Headers(scope=scope).get("host"))

        async def add_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                headers += [
                    (b"x-content-type-options", b"nosniff"),
                    (b"referrer-policy", b"no-referrer"),
                    (b"x-frame-options", b"DENY"),
                    (b"cross-origin-opener-policy", b"same-origin"),
                ]
                if csp is not None:
                    headers.append((b"content-security-policy", csp.encode("latin-1")))
                message = {**message, "headers": headers}
            await send(message)

        await self.app(scope, receive, add_headers)


def redact_secrets(text: str) -> str:
    """`text` with bearer tokens, `token=` query values and wst_ tokens replaced."""
    for pattern in _SECRET_PATTERNS:
        text = pattern.sub(
            lambda m: (m.group(1) if m.groups() else "") + REDACTED,
            text,
        )
    return text


class SecretRedactingFilter(logging.Filter):
    """Rewrite a log record so no token reaches a log (uvicorn logs socket query strings).

    A record's arguments are redacted one by one, so formatters that read them (uvicorn's
    access log takes client, method, path, version and status from `args`) still work.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.msg, str):
            record.msg = redact_secrets(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(
                redact_secrets(arg) if isinstance(arg, str) else arg for arg in record.args
            )
        elif isinstance(record.args, Mapping):
            record.args = {
                key: redact_secrets(arg) if isinstance(arg, str) else arg
                for key, arg in record.args.items()
            }
        return True


LOGGERS_TO_REDACT = ("uvicorn.access", "uvicorn.error", "uvicorn", "backend", "celery", "")


def install_log_redaction() -> None:
    """Attach the redacting filter to the service's loggers and their handlers (idempotent)."""
    for name in LOGGERS_TO_REDACT:
        logger = logging.getLogger(name)
        targets = [logger, *logger.handlers]
        for target in targets:
            if not any(isinstance(f, SecretRedactingFilter) for f in target.filters):
                target.addFilter(SecretRedactingFilter())
