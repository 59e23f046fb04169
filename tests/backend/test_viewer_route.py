"""The 3D viewer route: access and errors in words (the scene itself: test_viewer.py and the
browser tests, which open it on a measured wheel)."""

from __future__ import annotations


def test_viewer_route_needs_a_token(client) -> None:
    response = client.get("/api/passes/1/wheels/1/viewer")
    assert response.status_code == 401
    assert "token" in response.json()["detail"]


def test_viewer_of_an_unknown_wheel_is_404_with_words(client, auth) -> None:
    response = client.get("/api/passes/4242/wheels/7/viewer", headers=auth("viewer"))
    assert response.status_code == 404
    assert "4242" in response.json()["detail"]


def test_viewer_route_is_in_the_openapi_document(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    assert "/api/passes/{pass_id}/wheels/{wheel_id}/viewer" in paths
