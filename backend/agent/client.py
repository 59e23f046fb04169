"""The agent's side of the public streaming API (README: live streaming); nothing else."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from datetime import datetime

import httpx

from backend.agent.spool import FrameItem, MissingItem, PassOpen

STREAM_ROLES = ("operator", "admin")
_RETRY_STATUS = (500, 502, 503, 504)


class ServerUnavailable(OSError):
    """The server cannot be reached or is failing now; retrying later may succeed.

    `delivered` is False only when the request certainly never reached the server.
    """

    def __init__(self, message: str, *, delivered: bool) -> None:
        super().__init__(message)
        self.delivered = delivered


class TokenRefused(PermissionError):
    """The server refused the token (401/403): nothing will succeed until it is fixed."""


class RequestRejected(ValueError):
    """The server rejected a request for good (4xx other than 401/403)."""

    def __init__(self, status: int, code: str, detail: str) -> None:
        super().__init__(f"{status} {code}: {detail}")
        self.status = status
        self.code = code


@dataclass(frozen=True, slots=True)
class PutResult:
    """The server's answer to one frame PUT."""

    created: bool
    wheel_complete: bool


class StreamClient:
    """One HTTP connection (kept alive) to the server's streaming routes.

    Parameters
    ----------
    server : str
        Base URL, e.g. "http://127.0.0.1:8000".
    token : str
        Bearer token with role operator.
    timeout_s : float
        Read timeout of one request (above the server's 30 s SQLite busy timeout); connect: 5 s.
    """

    def __init__(self, server: str, token: str, *, timeout_s: float = 60.0) -> None:
        self._http = httpx.Client(
            base_url=server,
            headers={"Authorization": f"Bearer {token}"},
            timeout=httpx.Timeout(timeout_s, connect=min(timeout_s, 5.0)),
        )
        self.server = server

    def close(self) -> None:
        """Close the connection pool."""
        self._http.close()

    def check_token(self) -> str:
        """Return the token's role; TokenRefused when it cannot stream."""
        role = str(self._call("GET", "/api/me").json().get("role"))
        if role not in STREAM_ROLES:
            raise TokenRefused(f"token has role {role!r}; streaming needs role operator")
        return role

    def open_pass(self, request: PassOpen) -> int:
        """POST /api/passes/stream; returns the pass id."""
        return int(self._call("POST", "/api/passes/stream", json=asdict(request)).json()["pass_id"])

    def find_pass(self, request: PassOpen) -> int | None:
        """The id of a still-receiving pass of this site opened at exactly this time, if any.

        Used after an open whose answer was lost, so a retry does not open a second pass.
        """
        params = {"site": request.site, "started_from": request.started_at, "limit": 50}
        listing = self._call("GET", "/api/passes", params=params).json()
        items = listing["items"] if isinstance(listing, dict) else listing
        wanted = datetime.fromisoformat(request.started_at)
        for item in items:
            started = datetime.fromisoformat(str(item["started_at"]).replace("Z", "+00:00"))
            if started == wanted and item.get("state") == "open":
                return int(item["id"])
        return None

    def put_frame(self, pass_id: int, item: FrameItem, png: bytes) -> PutResult:
        """PUT one frame (idempotent: 200 when the server has the identical frame)."""
        response = self._call(
            "PUT",
            f"/api/passes/{pass_id}/frames/{item.sensor}/{item.seq}",
            params={"vehicle_id": item.vehicle_id, "axle": item.axle},
            content=png,
            headers={"Content-Type": "image/png"},
        )
        return PutResult(response.status_code == 201, bool(response.json().get("wheel_complete")))

    def declare_missing(self, pass_id: int, item: MissingItem) -> None:
        """POST a missing-sensor declaration for one wheel."""
        body = {
            "vehicle_id": item.vehicle_id,
            "axle": item.axle,
            "side": item.side,
            "sensor": item.sensor,
            "reason": item.reason,
        }
        self._call("POST", f"/api/passes/{pass_id}/wheels/missing", json=body)

    def stored_frames(self, pass_id: int) -> set[tuple[str, int, str]]:
        """What the server holds of a pass, as (sensor, seq, sha256)."""
        rows = self._call("GET", f"/api/passes/{pass_id}/frames").json()
        return {(str(r["sensor"]), int(r["seq"]), str(r["sha256"])) for r in rows}

    def close_pass(self, pass_id: int) -> int:
        """POST close (closing twice is fine); returns the measuring job's id."""
        return int(self._call("POST", f"/api/passes/{pass_id}/close").json()["job_id"])

    def _call(self, method: str, path: str, **kwargs: object) -> httpx.Response:
        try:
            response = self._http.request(method, path, **kwargs)  # type: ignore[arg-type]
        except httpx.ConnectError as exc:
            raise ServerUnavailable(f"{self.server} unreachable: {exc}", delivered=False) from None
        except httpx.TransportError as exc:
            text = str(exc) or type(exc).__name__
            raise ServerUnavailable(
                f"{self.server} connection lost: {text}", delivered=True
            ) from None
        if response.status_code < 400:
            return response
        code, detail = _error_body(response)
        if response.status_code in (401, 403):
            raise TokenRefused(f"server refused the token ({response.status_code}: {detail})")
        if response.status_code in _RETRY_STATUS:
            raise ServerUnavailable(
                f"{self.server} failing ({response.status_code}: {detail})", delivered=True
            )
        raise RequestRejected(response.status_code, code, detail)


def _error_body(response: httpx.Response) -> tuple[str, str]:
    try:
        body = response.json()
    except ValueError:
        return "http_error", response.text[:200] or response.reason_phrase
    if not isinstance(body, dict):
        return "http_error", str(body)[:200]
    return str(body.get("code", "http_error")), str(body.get("detail", ""))[:500]
