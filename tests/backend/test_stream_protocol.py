"""Streaming contract (README: live streaming): status codes, idempotency, resume, close."""

from __future__ import annotations

import hashlib

import numpy as np

from tests.backend.archives import calibration_document, frame_png

OPEN = {
    "site": "stream-site",
    "started_at": "2026-11-23T12:00:00Z",
    "direction": "up",
    "speed_kmh": 5.0,
}


def open_pass(client, auth, **extra) -> dict:
    body = {**OPEN, "calibration": calibration_document(), **extra}
    response = client.post("/api/passes/stream", headers=auth("operator"), json=body)
    assert response.status_code == 201, response.text
    return response.json()


def put(client, auth, pass_id, sensor, seq, data, vehicle="V1", axle=1):
    return client.put(
        f"/api/passes/{pass_id}/frames/{sensor}/{seq}",
        params={"vehicle_id": vehicle, "axle": axle},
        headers={**auth("operator"), "Content-Type": "image/png"},
        content=data,
    )


def test_open_needs_a_calibration_when_the_site_has_none(client, auth) -> None:
    response = client.post("/api/passes/stream", headers=auth("operator"), json=OPEN)
    assert response.status_code == 422
    assert "has no registered calibration" in response.json()["detail"]


def test_open_answers_pass_and_job(client, auth) -> None:
    opened = open_pass(client, auth)
    assert set(opened) == {"pass_id", "job_id"}
    job = client.get(f"/api/jobs/{opened['job_id']}", headers=auth("viewer")).json()
    assert job["pass_id"] == opened["pass_id"] and job["state"] == "queued"


def test_a_frame_is_201_then_200_when_identical_and_409_when_different(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    first = put(client, auth, pass_id, "left_inner", 0, frame_png())
    again = put(client, auth, pass_id, "left_inner", 0, frame_png())
    other = put(client, auth, pass_id, "left_inner", 0, frame_png(row=10))
    assert first.status_code == 201 and again.status_code == 200
    assert (
        first.json()
        == again.json()
        == {
            "sha256": hashlib.sha256(frame_png()).hexdigest(),
            "wheel_complete": False,
        }
    )
    assert other.status_code == 409
    assert "already stored with a different image" in other.json()["detail"]


def test_bad_frames_are_422_and_not_stored(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    cases = {
        "unknown sensor": ("top_inner", frame_png(), "path.sensor: Input should be"),
        "not an image": ("left_inner", b"hello", "is not a PNG image"),
        "wrong size": ("left_inner", frame_png((20, 40)), "40x20 px"),
        "wrong depth": ("left_inner", frame_png(dtype=np.uint16), "16 bit"),
    }
    for sensor, data, fragment in cases.values():
        response = put(client, auth, pass_id, sensor, 0, data)
        assert response.status_code == 422, response.text
        assert fragment in response.json()["detail"]
    assert client.get(f"/api/passes/{pass_id}/frames", headers=auth("operator")).json() == []


def test_an_oversize_frame_is_413(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    too_big = b"\0" * (client.app.state.settings.max_frame_bytes + 1)
    assert put(client, auth, pass_id, "left_inner", 0, too_big).status_code == 413


def test_streaming_needs_an_operator_token(client, auth) -> None:
    response = client.post("/api/passes/stream", headers=auth("viewer"), json=OPEN)
    assert response.status_code == 403


def test_stored_frames_are_listed_for_resume(client, auth) -> None:
    pass_id = open_pass(client, auth, frames_per_sensor=2)["pass_id"]
    put(client, auth, pass_id, "right_outer", 3, frame_png(), vehicle="V7", axle=2)
    listed = client.get(f"/api/passes/{pass_id}/frames", headers=auth("operator")).json()
    assert listed == [
        {
            "sensor": "right_outer",
            "seq": 3,
            "sha256": hashlib.sha256(frame_png()).hexdigest(),
            "vehicle_id": "V7",
            "axle": 2,
        }
    ]


def test_a_declared_missing_sensor_makes_the_wheel_not_measured(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    put(client, auth, pass_id, "left_inner", 0, frame_png())
    response = client.post(
        f"/api/passes/{pass_id}/wheels/missing",
        headers=auth("operator"),
        json={
            "vehicle_id": "V1",
            "axle": 1,
            "side": "left",
            "sensor": "left_outer",
            "reason": "camera timeout",
        },
    )
    assert response.status_code == 200
    assert response.json()["state"] == "not_measured"
    assert response.json()["reason"] == "frames missing: left_outer (camera timeout)"


def test_close_marks_incomplete_wheels_and_is_idempotent(client, auth) -> None:
    opened = open_pass(client, auth, frames_per_sensor=2)
    pass_id = opened["pass_id"]
    put(client, auth, pass_id, "right_inner", 0, frame_png())
    first = client.post(f"/api/passes/{pass_id}/close", headers=auth("operator"))
    second = client.post(f"/api/passes/{pass_id}/close", headers=auth("operator"))
    assert (first.status_code, second.status_code) == (202, 200)
    assert first.json() == second.json() == opened
    wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()
    assert [(w["state"], w["reason"]) for w in wheels] == [
        ("not_measured", "frames missing: right_inner, right_outer")
    ]
    job = client.get(f"/api/jobs/{opened['job_id']}", headers=auth("viewer")).json()
    assert (job["state"], job["wheels_done"], job["wheels_total"], job["progress"]) == (
        "done",
        1,
        1,
        1.0,
    )
    late = put(client, auth, pass_id, "right_inner", 1, frame_png(row=12))
    assert late.status_code == 409
    assert "closed" in late.json()["detail"]


def test_more_frames_than_frames_per_sensor_are_409(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    put(client, auth, pass_id, "left_inner", 0, frame_png())
    response = put(client, auth, pass_id, "left_inner", 1, frame_png(row=12))
    assert response.status_code == 409
    assert "frames_per_sensor" in response.json()["detail"]
