"""Security: every route's role (from the route table), rate limiting of failed
authentications, headers, CORS, content types, hashed and expiring tokens, no secret in logs,
and archive extraction that cannot be tricked."""

from __future__ import annotations

import io
import logging
import re
import zipfile
from datetime import timedelta

import pytest
from fastapi import routing
from fastapi.testclient import TestClient
from sqlalchemy import select
from starlette.websockets import WebSocketDisconnect

from backend.api.security import (
    WS_POLICY_VIOLATION,
    WS_RATE_LIMITED,
    AuthLimit,
    FailedAuthTracker,
    redact_secrets,
)
from backend.services.auth import create_token
from db.models import ROLES, ApiToken
from db.types import utc_now
from tests.backend.archives import frame_png, small_archive_bytes

PUBLIC_ROUTES = {
    ("GET", "/healthz"),
    ("GET", "/openapi.json"),
    ("GET", "/docs"),
    ("GET", "/docs/oauth2-redirect"),
    ("GET", "/redoc"),
}
"""Routes anyone may call; every other route must check a role."""
SOCKET_ROUTES = {"/api/ws/jobs/{job_id}", "/api/ws/passes"}
"""WebSockets check the `token` query parameter themselves (tested below)."""
PATH_VALUES = {"position": "inner", "fmt": "csv", "sensor": "left_inner", "name": "a" * 64}


def _required_roles(dependant) -> set[str]:
    found = set()
    for sub in dependant.dependencies:
        name = getattr(sub.call, "__name__", "").removeprefix("require_")
        if name in ROLES:
            found.add(name)
        found |= _required_roles(sub)
    return found


def route_table(app) -> list[tuple[str, str, str | None]]:
    """(method, path, role needed) of every HTTP route; None for an unchecked one."""
    table = []
    for context in routing.iter_route_contexts(app.routes):
        route = context.original_route
        if isinstance(route, routing.APIRoute):
            roles = _required_roles(route.dependant)
            role = max(roles, key=ROLES.index) if roles else None
            table += [(method, route.path, role) for method in sorted(route.methods)]
        elif isinstance(route, routing.APIWebSocketRoute):
            assert route.path in SOCKET_ROUTES, f"new WebSocket {route.path}: add an auth test"
        elif hasattr(route, "methods"):
            table += [(method, route.path, None) for method in sorted(route.methods - {"HEAD"})]
    return table


def concrete(path: str) -> str:
    return re.sub(r"{(\w+)}", lambda m: PATH_VALUES.get(m.group(1), "987654"), path)


def test_every_route_refuses_a_missing_token_and_each_lower_role(client, auth) -> None:
    table = route_table(client.app)
    assert len(table) > 30
    unchecked = {(m, p) for m, p, role in table if role is None} - PUBLIC_ROUTES
    assert not unchecked, f"routes without a role check: {sorted(unchecked)}"
    for method, path, role in table:
        if role is None:
            continue
        url = concrete(path)
        response = client.request(method, url)
        assert response.status_code == 401, (method, path, response.status_code)
        for lower in ROLES[: ROLES.index(role)]:
            response = client.request(method, url, headers=auth(lower))
            assert response.status_code == 403, (method, path, lower, response.status_code)
        allowed = client.request(method, url, headers=auth(role))
        assert allowed.status_code not in (401, 403), (method, path, role, allowed.text)


@pytest.mark.parametrize("path", ["/api/ws/jobs/1", "/api/ws/passes"])
def test_sockets_refuse_a_missing_or_unknown_token(client, path) -> None:
    for query in ("", "?token=wst_unknown"):
        with pytest.raises(WebSocketDisconnect) as refused:
            with client.websocket_connect(path + query) as socket:
                socket.receive_json()
        assert refused.value.code == WS_POLICY_VIOLATION


def test_tokens_are_stored_hashed_and_expire(client) -> None:
    with client.app.state.session_factory() as session:
        row, plaintext = create_token(
            session, role="viewer", name="short", expires_at=utc_now() + timedelta(hours=1)
        )
        session.commit()
        stored = session.scalars(select(ApiToken)).all()
        assert all(plaintext not in (t.token_sha256, t.prefix, t.name) for t in stored)
        assert len(row.token_sha256) == 64 and row.prefix == plaintext[:12]
        headers = {"Authorization": f"Bearer {plaintext}"}
        assert client.get("/api/me", headers=headers).status_code == 200
        row.expires_at = utc_now() - timedelta(seconds=1)
        session.commit()
    response = client.get("/api/me", headers=headers)
    assert response.status_code == 401 and "expired" in response.json()["detail"]


def test_repeated_failed_authentication_is_rate_limited_per_address(client, auth) -> None:
    limit = client.app.state.auth_tracker.limit
    guesser = TestClient(client.app, client=("203.0.113.7", 4000))
    bad = {"Authorization": "Bearer wst_guess"}
    codes = [guesser.get("/api/me", headers=bad).status_code for _ in range(limit.max_failures)]
    assert codes == [401] * limit.max_failures
    refused = guesser.get("/api/me", headers=bad)
    assert refused.status_code == 429 and int(refused.headers["Retry-After"]) >= 1
    assert refused.json()["code"] == "rate_limited"
    # A valid token from the same address (a depot behind one NAT) is not locked out.
    assert guesser.get("/api/me", headers=auth("viewer")).status_code == 200
    assert client.get("/api/me", headers=auth("viewer")).status_code == 200


def test_failed_socket_authentications_count_towards_the_limit(client, auth, tokens) -> None:
    limit = client.app.state.auth_tracker.limit
    guesser = TestClient(client.app, client=("203.0.113.8", 4000))
    codes = []
    for _ in range(limit.max_failures + 1):
        with pytest.raises(WebSocketDisconnect) as refused:
            with guesser.websocket_connect("/api/ws/passes?token=wst_guess") as socket:
                socket.receive_json()
        codes.append(refused.value.code)
    assert codes == [WS_POLICY_VIOLATION] * limit.max_failures + [WS_RATE_LIMITED]
    assert guesser.get("/api/me", headers={"Authorization": "Bearer x"}).status_code == 429
    assert guesser.get("/api/me", headers=auth("viewer")).status_code == 200
    with guesser.websocket_connect(f"/api/ws/passes?token={tokens['viewer']}"):
        pass  # accepted


def test_the_failure_tracker_forgets_old_failures_and_bounds_its_memory() -> None:
    tracker = FailedAuthTracker(AuthLimit(max_failures=2, window_s=10.0, max_addresses=3))
    tracker.record_failure("a", now_s=0.0)
    tracker.record_failure("a", now_s=1.0)
    assert tracker.retry_after_s("a", now_s=2.0) == pytest.approx(8.0)
    assert tracker.retry_after_s("a", now_s=10.5) == 0.0
    for i in range(10):
        tracker.record_failure(f"addr{i}", now_s=20.0)
    assert len(tracker) == 3


def test_pages_carry_security_headers_and_cors_stays_closed(client) -> None:
    page = client.get("/", headers={"Origin": "https://evil.example"})
    assert page.status_code == 200
    csp = page.headers["Content-Security-Policy"]
    assert "script-src 'self'" in csp and "frame-ancestors 'none'" in csp
    assert "frame-src 'self' http://testserver:*" in csp
    assert page.headers["X-Content-Type-Options"] == "nosniff"
    assert page.headers["Referrer-Policy"] == "no-referrer"
    assert "access-control-allow-origin" not in page.headers
    preflight = client.options(
        "/api/passes",
        headers={"Origin": "https://evil.example", "Access-Control-Request-Method": "GET"},
    )
    assert "access-control-allow-origin" not in preflight.headers


@pytest.mark.parametrize(
    ("method", "path", "content_type"),
    [
        ("PUT", "/api/passes/1/frames/left_inner/0?vehicle_id=V1&axle=1", "text/plain"),
        ("PUT", "/api/passes/1/frames/left_inner/0?vehicle_id=V1&axle=1", "application/json"),
        ("POST", "/api/passes", "application/zip"),
        ("POST", "/api/tokens", "text/plain"),
    ],
)
def test_a_body_of_the_wrong_content_type_is_415(client, auth, method, path, content_type) -> None:
    headers = {**auth("admin"), "Content-Type": content_type}
    response = client.request(method, path, headers=headers, content=frame_png())
    assert response.status_code == 415
    assert "Content-Type must be" in response.json()["detail"]


def test_no_token_reaches_the_logs(client, auth, tokens, tmp_path, caplog) -> None:
    caplog.set_level(logging.DEBUG)
    client.get("/api/me", headers=auth("viewer"))
    client.get("/api/me", headers={"Authorization": "Bearer wst_wrongguess"})
    upload = client.post(
        "/api/passes",
        headers=auth("operator"),
        files={"file": ("pass.zip", small_archive_bytes(tmp_path), "application/zip")},
    )
    assert upload.status_code == 202
    with pytest.raises(WebSocketDisconnect):
        with client.websocket_connect(f"/api/ws/jobs/{upload.json()['job_id']}?token=wst_x"):
            pass
    logged = caplog.text + "".join(str(r.args) for r in caplog.records)
    for secret in (*tokens.values(), "wst_wrongguess"):
        assert secret not in logged
    access = 'GET /api/ws/passes?token=wst_abc&x=1 "Bearer wst_def"'
    assert "wst_" not in redact_secrets(access)


def _zip_with(tmp_path, member: zipfile.ZipInfo, data: bytes) -> bytes:
    out = io.BytesIO()
    base = small_archive_bytes(tmp_path)
    with zipfile.ZipFile(io.BytesIO(base)) as source, zipfile.ZipFile(out, "w") as target:
        for info in source.infolist():
            target.writestr(info, source.read(info))
        target.writestr(member, data)
    return out.getvalue()


def _symlink_member() -> zipfile.ZipInfo:
    info = zipfile.ZipInfo("frames/link.png")
    info.external_attr = (0o120777) << 16
    return info


@pytest.mark.parametrize(
    ("member", "data", "message"),
    [
        (_symlink_member(), b"/etc/passwd", "symlinks are refused"),
        (zipfile.ZipInfo("frames/huge.png"), b"\x01" * (1024 * 1024 + 1), "larger than"),
        (zipfile.ZipInfo("manifest.json"), b"{}", "twice"),
    ],
    ids=["symlink", "oversize-member", "duplicate"],
)
def test_unsafe_archive_members_are_refused_and_nothing_is_stored(
    client, auth, tmp_path, member, data, message
) -> None:
    archive = _zip_with(tmp_path, member, data)
    response = client.post(
        "/api/passes",
        headers=auth("operator"),
        files={"file": ("pass.zip", archive, "application/zip")},
    )
    assert response.status_code == 422 and message in response.json()["detail"], response.text
    assert client.get("/api/passes", headers=auth("viewer")).json()["total"] == 0
    root = client.app.state.store.root
    assert not root.exists() or not any(p.is_file() for p in root.rglob("*"))


def _patch_member(data: bytes, name: str, central_at: int, local_at: int, value: bytes) -> bytes:
    """`data` with a field of member `name` overwritten in its central and local headers."""
    raw = bytearray(data)
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        local = archive.getinfo(name).header_offset
    offset = raw.find(b"PK\x01\x02")
    while offset >= 0:
        name_length = int.from_bytes(raw[offset + 28 : offset + 30], "little")
        if raw[offset + 46 : offset + 46 + name_length] == name.encode():
            raw[offset + central_at : offset + central_at + len(value)] = value
        offset = raw.find(b"PK\x01\x02", offset + 4)
    raw[local + local_at : local + local_at + len(value)] = value
    return bytes(raw)


@pytest.mark.parametrize(
    ("central_at", "local_at", "value", "message"),
    [(24, 22, (16).to_bytes(4, "little"), "cannot be read"), (8, 6, b"\x01", "encrypted")],
    ids=["understated-size", "encrypted"],
)
def test_a_member_with_lying_or_encrypted_headers_is_refused(
    client, auth, tmp_path, central_at, local_at, value, message
) -> None:
    data = _patch_member(
        small_archive_bytes(tmp_path), "manifest.json", central_at, local_at, value
    )
    response = client.post(
        "/api/passes",
        headers=auth("operator"),
        files={"file": ("pass.zip", data, "application/zip")},
    )
    assert response.status_code == 422 and message in response.json()["detail"], response.text
    assert client.get("/api/passes", headers=auth("viewer")).json()["total"] == 0
