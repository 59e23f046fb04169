"""Access control: every route needs a live token of the right role; writes are audited."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from sqlalchemy import select

from backend.services.limits import DEFAULT_LIMITS_MM
from db.models import AuditEvent


def test_health_needs_no_token(client) -> None:
    response = client.get("/healthz")
    assert response.status_code == 200
    assert response.json()["status"] == "ok"


def test_missing_token_is_401_with_what_to_send(client) -> None:
    response = client.get("/api/passes")
    assert response.status_code == 401
    assert response.json() == {
        "detail": "missing bearer token: send 'Authorization: Bearer <token>'",
        "code": "unauthorized",
    }


def test_unknown_token_is_401(client) -> None:
    response = client.get("/api/passes", headers={"Authorization": "Bearer wst_nope"})
    assert response.status_code == 401
    assert "unknown token" in response.json()["detail"]


@pytest.mark.parametrize(
    ("role", "method", "path"),
    [
        ("viewer", "post", "/api/passes/stream"),
        ("viewer", "post", "/api/passes"),
        ("operator", "get", "/api/tokens"),
        ("operator", "post", "/api/sites"),
        ("operator", "put", "/api/limits/default/EN"),
    ],
)
def test_a_lower_role_is_403_naming_the_role_needed(client, auth, role, method, path) -> None:
    # A well-formed body for the route (multipart for the upload), so only the role is wrong.
    body_kwargs = {"files": {"file": ("a.zip", b"PK")}} if path == "/api/passes" else {"json": {}}
    response = client.request(method, path, headers=auth(role), **body_kwargs)
    assert response.status_code == 403
    body = response.json()
    assert body["code"] == "forbidden"
    assert "needs a" in body["detail"] and role in body["detail"]


@pytest.mark.parametrize(
    ("role", "needed", "method", "path"),
    [
        ("viewer", "operator", "get", "/api/passes/999999/frames"),
        ("viewer", "operator", "post", "/api/passes/999999/close"),
        ("operator", "admin", "post", "/api/sites/no-such-site/calibrations"),
    ],
)
def test_the_role_is_checked_before_a_lookup_could_tell_an_id_exists(
    client, auth, role, needed, method, path
) -> None:
    # The lookup (pass, site) runs with the role the route declares, so a lower role learns
    # nothing: 403, where the role the route needs gets the lookup's 404.
    body_kwargs = {"json": {"document": {}}} if "calibrations" in path else {}
    lower = client.request(method, path, headers=auth(role), **body_kwargs)
    assert lower.status_code == 403, lower.text
    assert needed in lower.json()["detail"]
    allowed = client.request(method, path, headers=auth(needed), **body_kwargs)
    assert allowed.status_code == 404, allowed.text
    assert allowed.json()["code"] == "not_found"


def test_revoked_and_expired_tokens_are_refused(client, auth) -> None:
    created = client.post(
        "/api/tokens", headers=auth("admin"), json={"role": "viewer", "name": "kiosk"}
    )
    assert created.status_code == 201
    token = created.json()["token"]
    viewer = {"Authorization": f"Bearer {token}"}
    assert client.get("/api/passes", headers=viewer).status_code == 200
    assert (
        client.delete(f"/api/tokens/{created.json()['id']}", headers=auth("admin")).status_code
        == 200
    )
    response = client.get("/api/passes", headers=viewer)
    assert response.status_code == 401
    assert "revoked" in response.json()["detail"]


def test_a_token_cannot_be_created_already_expired(client, auth) -> None:
    past = (datetime.now(UTC) - timedelta(days=1)).isoformat()
    response = client.post(
        "/api/tokens",
        headers=auth("admin"),
        json={"role": "viewer", "name": "x", "expires_at": past},
    )
    assert response.status_code == 422
    assert "expires_at must be in the future" in response.json()["detail"]


def test_token_listing_never_shows_secrets(client, auth, tokens) -> None:
    listing = client.get("/api/tokens", headers=auth("admin")).json()
    assert len(listing) == 3
    assert all("token" not in row for row in listing)
    assert all(secret not in str(listing) for secret in tokens.values())


def test_every_write_leaves_an_audit_event(client, auth) -> None:
    client.post("/api/tokens", headers=auth("admin"), json={"role": "operator", "name": "agent"})
    client.put(
        "/api/limits/default/EN",
        headers=auth("admin"),
        json={**DEFAULT_LIMITS_MM["EN"], "flange_height_min_mm": 27.0},
    )
    with client.app.state.session_factory() as session:
        actions = list(session.scalars(select(AuditEvent.action).order_by(AuditEvent.id)))
    assert actions == ["token.create", "limits.update"]
    trail = client.get("/api/audit", headers=auth("admin")).json()
    assert [event["action"] for event in trail] == ["limits.update", "token.create"]
    assert trail[0]["actor"].endswith("(test admin)")
    assert client.get("/api/audit", headers=auth("operator")).status_code == 403


def test_limits_default_to_the_issue_values_and_are_editable(client, auth) -> None:
    limits = {
        row["wheel_profile"]: row
        for row in client.get("/api/limits", headers=auth("viewer")).json()
    }
    assert limits["EN"]["flange_height_min_mm"] == 27.5
    assert limits["EN"]["flange_height_max_mm"] == 36.0
    assert limits["EN"]["flange_thickness_min_mm"] == 22.0
    assert limits["EN"]["qr_min_mm"] == 6.5
    assert limits["EN"]["back_to_back_max_mm"] == 1363.0
    body = {k: v for k, v in limits["LM"].items() if k.endswith("_mm")}
    body["flange_thickness_min_mm"] = 24.0
    response = client.put("/api/limits/default/LM", headers=auth("admin"), json=body)
    assert response.status_code == 200
    assert response.json()["flange_thickness_min_mm"] == 24.0


def test_limits_with_min_above_max_are_refused(client, auth) -> None:
    body = {**DEFAULT_LIMITS_MM["EN"], "flange_height_min_mm": 37.0}
    response = client.put("/api/limits/default/EN", headers=auth("admin"), json=body)
    assert response.status_code == 422
    assert (
        response.json()["detail"]
        == "flange_height_min_mm (37.0) must be below flange_height_max_mm (36.0)"
    )


@pytest.mark.parametrize("role", ["viewer", "operator", "admin"])
def test_me_tells_the_role_of_any_token(client, auth, role) -> None:
    response = client.get("/api/me", headers=auth(role))
    assert response.status_code == 200
    assert response.json()["role"] == role
    assert response.json()["name"] == f"test {role}"
