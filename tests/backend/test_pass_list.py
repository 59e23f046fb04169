"""The pass list: filters, newest first, live progress; the OpenAPI document; progress sockets."""

from __future__ import annotations

import asyncio
from types import SimpleNamespace

import pytest
from starlette.websockets import WebSocketDisconnect

from backend.api.routes import ROUTERS, jobs
from db.models import Measurement, PassWheel
from tests.backend.archives import calibration_document, frame_png


def open_pass(
    client, auth, site: str, started_at: str, vehicle: str, odometer_km: dict | None = None
) -> int:
    body = {
        "site": site,
        "started_at": started_at,
        "frames_per_sensor": 2,
        "calibration": calibration_document(),
    } | ({"odometer_km": odometer_km} if odometer_km is not None else {})
    pass_id = client.post("/api/passes/stream", headers=auth("operator"), json=body).json()[
        "pass_id"
    ]
    response = client.put(
        f"/api/passes/{pass_id}/frames/left_inner/0",
        params={"vehicle_id": vehicle, "axle": 1},
        headers={**auth("operator"), "Content-Type": "image/png"},
        content=frame_png(),
    )
    assert response.status_code == 201
    return pass_id


@pytest.fixture
def passes(client, auth) -> dict[str, int]:
    made = {
        "a_old": open_pass(client, auth, "A", "2026-05-01T08:00:00Z", "V1"),
        "a_new": open_pass(client, auth, "A", "2026-05-03T08:00:00Z", "V2"),
        "b_mid": open_pass(client, auth, "B", "2026-05-02T08:00:00+02:00", "V1"),
    }
    with client.app.state.session_factory() as session:
        pass_wheel = session.query(PassWheel).filter_by(pass_id=made["b_mid"]).one()
        session.add(
            Measurement(
                pass_wheel_id=pass_wheel.id,
                method="adaptive",
                status="measured",
                flange_height_mm=37.0,
                alarms=[{"parameter": "flange_height_mm", "message": "above"}],
                alarm_count=1,
                pipeline_version="test",
            )
        )
        session.commit()
    return made


def listed(client, auth, **params) -> list[int]:
    response = client.get("/api/passes", headers=auth("viewer"), params=params)
    assert response.status_code == 200, response.text
    return [item["id"] for item in response.json()["items"]]


def test_passes_are_listed_newest_first(client, auth, passes) -> None:
    assert listed(client, auth) == [passes["a_new"], passes["b_mid"], passes["a_old"]]


def test_passes_filter_by_site_vehicle_dates_and_alarm(client, auth, passes) -> None:
    assert listed(client, auth, site="A") == [passes["a_new"], passes["a_old"]]
    assert listed(client, auth, vehicle="V1") == [passes["b_mid"], passes["a_old"]]
    window = {"started_from": "2026-05-02T00:00:00Z", "started_to": "2026-05-03T00:00:00Z"}
    assert listed(client, auth, **window) == [passes["b_mid"]]
    assert listed(client, auth, alarm="true") == [passes["b_mid"]]
    assert listed(client, auth, alarm="false") == [passes["a_new"], passes["a_old"]]


def test_a_date_without_time_zone_is_refused(client, auth, passes) -> None:
    response = client.get(
        "/api/passes", headers=auth("viewer"), params={"started_from": "2026-05-02T00:00:00"}
    )
    assert response.status_code == 422
    assert "timezone" in response.json()["detail"]


def test_a_listed_pass_shows_its_wheels_alarms_and_job(client, auth, passes) -> None:
    item = client.get(f"/api/passes/{passes['b_mid']}", headers=auth("viewer")).json()
    assert item["site"] == "B" and item["vehicles"] == ["V1"]
    assert item["started_at"] == "2026-05-02T06:00:00Z"
    assert (item["wheels_total"], item["alarm_count"], item["state"]) == (1, 1, "open")
    assert item["job"]["state"] == "queued"


def test_an_unknown_pass_is_404(client, auth) -> None:
    response = client.get("/api/passes/999", headers=auth("viewer"))
    assert response.status_code == 404
    assert response.json() == {"detail": "pass 999 not found", "code": "not_found"}


def test_the_openapi_document_lists_every_route(client) -> None:
    documented = {
        (path, method.upper())
        for path, operations in client.get("/openapi.json").json()["paths"].items()
        for method in operations
    }
    served = {
        (route.path, method)
        for router in ROUTERS
        for route in router.routes
        if hasattr(route, "methods")
        for method in route.methods - {"HEAD"}
    }
    assert len(served) > 30 and served <= documented


def test_the_job_socket_pushes_progress_until_done(client, auth, tokens, passes) -> None:
    pass_id = passes["a_old"]
    job_id = client.get(f"/api/passes/{pass_id}", headers=auth("viewer")).json()["job"]["job_id"]
    client.post(f"/api/passes/{pass_id}/close", headers=auth("operator"))
    with client.websocket_connect(f"/api/ws/jobs/{job_id}?token={tokens['viewer']}") as socket:
        message = socket.receive_json()
    assert message == {
        "job_id": job_id,
        "pass_id": pass_id,
        "state": "done",
        "progress": 1.0,
        "wheels_done": 1,
        "wheels_total": 1,
    }


def test_the_passes_socket_pushes_unfinished_jobs(client, tokens, passes) -> None:
    with client.websocket_connect(f"/api/ws/passes?token={tokens['viewer']}") as socket:
        seen = {socket.receive_json()["pass_id"] for _ in range(3)}
    assert seen == set(passes.values())


def test_a_socket_without_a_valid_token_is_closed(client) -> None:
    with pytest.raises(WebSocketDisconnect) as closed:
        with client.websocket_connect("/api/ws/passes?token=nope") as socket:
            socket.receive_json()
    assert closed.value.code == 4401


class _ClosingSocket:
    """A progress socket whose client closes after `open_s` while nothing changes."""

    def __init__(self, open_s: float) -> None:
        self.open_s = open_s
        self.query_params = {"token": "t"}
        self.app = SimpleNamespace(state=SimpleNamespace(session_factory=None))
        self.sent: list[dict] = []

    async def accept(self) -> None:
        pass

    async def receive(self) -> dict:
        await asyncio.sleep(self.open_s)
        return {"type": "websocket.disconnect", "code": 1001}

    async def send_json(self, data: dict) -> None:
        self.sent.append(data)


def test_a_progress_socket_ends_when_its_client_closes_though_nothing_changes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The pass list's socket sends only on a change; once its page is closed it must stop
    polling the database (it once polled until the server stopped, and held the server's
    shutdown in "Waiting for background tasks to complete")."""
    polls = []
    monkeypatch.setattr(jobs, "_authorised", lambda _factory, _token: None)
    monkeypatch.setattr(jobs, "_read_progress", lambda _factory, _job: polls.append(1) or [])
    socket = _ClosingSocket(open_s=3 * jobs.POLL_INTERVAL_S)
    asyncio.run(asyncio.wait_for(jobs._push_progress(socket, None), timeout=10))  # type: ignore[arg-type]
    assert 2 <= len(polls) <= 6 and socket.sent == []
