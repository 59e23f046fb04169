"""Hostile and concurrent requests, on SQLite and PostgreSQL: dates that overflow, PNG
headers that lie, bodies without a length, identical requests at once, and refused
requests that must leave nothing behind. Each case was a 500 or a lost invariant once."""

from __future__ import annotations

import io
import json
import logging
import re
import struct
import zipfile
import zlib
from concurrent.futures import ThreadPoolExecutor

import pytest
from sqlalchemy import func, select
from starlette.websockets import WebSocketDisconnect
from uvicorn.logging import AccessFormatter

from backend.api.security import SecretRedactingFilter
from db.models import Frame, Site, Wheel
from tests.backend.archives import calibration_document, frame_png, rewrite_zip
from tests.backend.archives import small_archive_bytes as archive_bytes
from tests.backend.test_security import PATH_VALUES
from tests.backend.test_stream_protocol import OPEN, open_pass, put
from tests.backend.test_upload_validation import assert_refused, store_files, stored_rows, upload
from tests.pipeline.archive_helpers import padded_png

OVERFLOWING_DATES = ("0001-01-01T00:00:00+14:00", "9999-12-31T23:59:59-14:00")


def png_claiming(width_px: int, height_px: int) -> bytes:
    """A grey 8-bit PNG whose IHDR claims width x height over a tiny IDAT (valid CRCs)."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body)
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width_px, height_px, 8, 0, 0, 0, 0)
    idat = zlib.compress(bytes(width_px + 1))  # one row of the many claimed
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    )


def count(client, model) -> int:
    with client.app.state.session_factory() as session:
        return session.scalar(select(func.count()).select_from(model)) or 0


@pytest.mark.parametrize("started_at", OVERFLOWING_DATES)
def test_a_stream_start_beyond_utc_is_refused(client, auth, started_at) -> None:
    body = {**OPEN, "started_at": started_at, "calibration": calibration_document()}
    response = client.post("/api/passes/stream", headers=auth("operator"), json=body)
    assert response.status_code == 422, response.text
    assert "outside years 1–9999" in response.json()["detail"]
    assert count(client, Site) == 0


@pytest.mark.parametrize("name", ["started_from", "started_to"])
@pytest.mark.parametrize("value", [*OVERFLOWING_DATES, "0.5", "1700000000"])
def test_pass_filters_take_only_dates_within_utc(client, auth, name, value) -> None:
    response = client.get("/api/passes", headers=auth("viewer"), params={name: value})
    assert response.status_code == 422, response.text
    assert response.json()["code"] == "invalid_input"


@pytest.mark.parametrize("expires_at", OVERFLOWING_DATES)
def test_a_token_expiry_beyond_utc_is_refused(client, auth, expires_at) -> None:
    body = {"role": "viewer", "name": "x", "expires_at": expires_at}
    response = client.post("/api/tokens", headers=auth("admin"), json=body)
    assert response.status_code == 422, response.text
    assert response.json()["code"] == "invalid_input"
    assert "outside years 1–9999" in response.json()["detail"]


def test_a_frame_header_claiming_billions_of_pixels_is_refused(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    response = put(client, auth, pass_id, "left_inner", 0, png_claiming(60000, 60000))
    assert response.status_code == 422, response.text
    assert "claims 60000x60000 px" in response.json()["detail"]
    response = put(client, auth, pass_id, "left_inner", 0, png_claiming(4000, 3000))
    assert response.status_code == 422, response.text
    assert "is 4000x3000 px 8 bit, but sensor left_inner" in response.json()["detail"]
    assert count(client, Frame) == count(client, Wheel) == 0


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (frame_png() + bytes(4096), "4096 bytes after its IEND chunk"),
        (padded_png(frame_png(), 2**19), "send the frame without padding chunks"),
    ],
)
def test_a_streamed_frame_with_trailing_or_padding_bytes_is_refused(
    client, auth, frame, message
) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    response = put(client, auth, pass_id, "left_inner", 0, frame)
    assert response.status_code == 422, response.text
    assert message in response.json()["detail"]
    assert count(client, Frame) == count(client, Wheel) == 0
    assert store_files(client) == []


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (png_claiming(60000, 60000), "claims 60000x60000 px"),
        (frame_png() + bytes(4096), "4096 bytes after its IEND chunk"),
        (padded_png(frame_png(), 2**19), "send the frame without padding chunks"),
    ],
)
def test_an_archive_frame_with_a_lying_header_or_trailing_bytes_is_refused(
    client, auth, tmp_path, frame, message
) -> None:
    data = rewrite_zip(archive_bytes(tmp_path), {"frames/left_inner/000001.png": frame})
    assert_refused(client, upload(client, auth, data), 422, message)


def test_a_direction_the_database_cannot_hold_is_refused_and_stores_nothing(
    client, auth, tmp_path
) -> None:
    data = archive_bytes(tmp_path)
    manifest = zipfile.ZipFile(io.BytesIO(data)).read("manifest.json").decode()
    for bad in ('"' + "x" * 41 + '"', '"up\\u0000"'):
        edited = manifest.replace('"direction": "up"', f'"direction": {bad}')
        assert edited != manifest
        response = upload(client, auth, rewrite_zip(data, {"manifest.json": edited.encode()}))
        assert_refused(client, response, 422, "direction")


def test_identical_uploads_at_once_all_get_the_same_pass(client, auth, tmp_path) -> None:
    data = archive_bytes(tmp_path)
    with ThreadPoolExecutor(5) as pool:
        responses = list(pool.map(lambda _: upload(client, auth, data), range(5)))
    assert [r.status_code for r in responses] == [202] * 5, [r.text for r in responses]
    assert len({(r.json()["pass_id"], r.json()["job_id"]) for r in responses}) == 1
    assert stored_rows(client)["Pass"] == 1


def test_concurrent_frames_never_exceed_frames_per_sensor(client, auth) -> None:
    pass_id = open_pass(client, auth, frames_per_sensor=1)["pass_id"]
    with ThreadPoolExecutor(20) as pool:
        codes = list(
            pool.map(
                lambda seq: put(client, auth, pass_id, "left_inner", seq, frame_png()).status_code,
                range(20),
            )
        )
    assert sorted(codes) == [201] + [409] * 19
    assert count(client, Frame) == 1


def test_identical_concurrent_frames_are_all_accepted(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    with ThreadPoolExecutor(20) as pool:
        codes = list(
            pool.map(
                lambda _: put(client, auth, pass_id, "left_inner", 0, frame_png()).status_code,
                range(20),
            )
        )
    assert sorted(codes) == [200] * 19 + [201]
    assert count(client, Frame) == 1


def test_a_refused_stream_open_creates_no_site(client, auth) -> None:
    response = client.post("/api/passes/stream", headers=auth("operator"), json=OPEN)
    assert response.status_code == 422
    assert count(client, Site) == 0


def test_a_refused_frame_creates_no_wheel(client, auth) -> None:
    pass_id = open_pass(client, auth)["pass_id"]
    assert put(client, auth, pass_id, "left_inner", 0, frame_png()).status_code == 201
    client.post(f"/api/passes/{pass_id}/close", headers=auth("operator"))
    refused = put(client, auth, pass_id, "right_inner", 0, frame_png(), vehicle="V2")
    assert refused.status_code == 409, refused.text
    assert count(client, Wheel) == 1


def test_a_laser_plane_through_the_camera_centre_is_refused(client, auth, tmp_path) -> None:
    document = calibration_document()
    document["sensors"]["left_inner"]["laser_plane"]["d"] = 0.0
    assert client.post("/api/sites", headers=auth("admin"), json={"name": "s"}).status_code == 201
    response = client.post(
        "/api/sites/s/calibrations", headers=auth("admin"), json={"document": document}
    )
    assert response.status_code == 422
    assert "through the camera centre" in response.json()["detail"]
    data = rewrite_zip(archive_bytes(tmp_path), {"calibration.json": json.dumps(document).encode()})
    response = upload(client, auth, data)
    assert response.status_code == 422 and "through the camera centre" in response.text
    body = {**OPEN, "calibration": document}
    response = client.post("/api/passes/stream", headers=auth("operator"), json=body)
    assert response.status_code == 422 and count(client, Site) == 1  # only "s"


def test_a_socket_for_a_job_id_beyond_the_columns_is_refused(client, tokens) -> None:
    with pytest.raises(WebSocketDisconnect) as refused:
        with client.websocket_connect(f"/api/ws/jobs/{2**63}?token={tokens['viewer']}") as ws:
            ws.receive_json()
    assert refused.value.code == 1008  # policy violation: the id failed validation


def test_a_chunked_blob_is_refused_at_the_limit(client, auth) -> None:
    limit = client.app.state.settings.max_frame_bytes
    sent = []

    def body():
        for _ in range(4 * limit // 65536):
            sent.append(65536)
            yield bytes(65536)

    response = client.put(
        "/api/blobs/" + "0" * 64 + ".png",
        headers={**auth("operator"), "Content-Type": "application/octet-stream"},
        content=body(),
    )
    assert response.status_code == 413, response.text
    assert "larger than" in response.json()["detail"]
    assert store_files(client) == []


def test_a_token_in_the_access_log_is_redacted_and_the_line_still_written() -> None:
    record = logging.LogRecord(
        "uvicorn.access", logging.INFO, __file__, 1, '%s - "%s %s HTTP/%s" %d',
        ("127.0.0.1:5000", "GET", "/api/ws/passes?token=wst_secret", "1.1", 101), None,
    )  # fmt: skip
    assert SecretRedactingFilter().filter(record)
    line = AccessFormatter("%(message)s", use_colors=False).format(record)
    assert line == '127.0.0.1:5000 - "GET /api/ws/passes?token=[redacted] HTTP/1.1" 101'


def test_an_undocumented_method_is_405_with_every_documented_method_in_allow(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    for path, operations in paths.items():
        url = re.sub(r"{(\w+)}", lambda m: PATH_VALUES.get(m.group(1), "1"), path)
        response = client.request("TRACE", url)
        assert response.status_code == 405, (path, response.status_code)
        assert response.json()["code"] == "http_405"
        allowed = set(response.headers["Allow"].split(", "))
        assert {method.upper() for method in operations} <= allowed, (path, allowed)
