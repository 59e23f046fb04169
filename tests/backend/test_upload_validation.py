"""Uploads: every bad archive is a 4xx that says what to fix, and nothing is half-stored."""

from __future__ import annotations

import hashlib
import io
import json
import zipfile

import numpy as np
import pytest
from sqlalchemy import func, select

from db.models import Calibration, Frame, Job, Pass, PassWheel, Site
from tests.backend.archives import (
    calibration_document,
    frame_png,
    manifest_of,
    rewrite_zip,
    small_archive_bytes,
    zip_bomb_bytes,
)


def upload(client, auth, data: bytes, role: str = "operator"):
    return client.post(
        "/api/passes", headers=auth(role), files={"file": ("pass.zip", data, "application/zip")}
    )


def stored_rows(client) -> dict[str, int]:
    with client.app.state.session_factory() as session:
        return {
            model.__name__: session.scalar(select(func.count()).select_from(model))
            for model in (Site, Calibration, Pass, Frame, PassWheel, Job)
        }


def store_files(client) -> list[str]:
    root = client.app.state.store.root
    return sorted(p.name for p in root.rglob("*") if p.is_file()) if root.exists() else []


def assert_refused(client, response, status: int, *fragments: str) -> None:
    assert response.status_code == status, response.text
    body = response.json()
    assert set(body) == {"detail", "code"}
    for fragment in fragments:
        assert fragment in body["detail"], body["detail"]
    assert all(count == 0 for count in stored_rows(client).values()), stored_rows(client)
    assert store_files(client) == []


def test_a_file_that_is_not_a_zip_is_refused(client, auth) -> None:
    assert_refused(client, upload(client, auth, b"GIF89a not a zip"), 422, "not a readable zip")


def test_an_empty_upload_is_refused(client, auth) -> None:
    assert_refused(client, upload(client, auth, b""), 422, "empty")


def test_a_zip_bomb_is_refused(client, auth) -> None:
    assert_refused(client, upload(client, auth, zip_bomb_bytes()), 422, "compression ratio")


def test_an_oversize_upload_is_413(client, auth) -> None:
    too_big = b"\0" * (client.app.state.settings.max_upload_bytes + 1)
    assert_refused(client, upload(client, auth, too_big), 413, "upload is larger than")


def test_an_oversize_body_is_413_before_it_is_read(client, auth) -> None:
    far_too_big = b"\0" * (client.app.state.settings.max_upload_bytes + 100_000)
    assert_refused(client, upload(client, auth, far_too_big), 413, "request body of")


@pytest.mark.parametrize("name", ["../evil.png", "/etc/evil.png", "frames/../../evil.png"])
def test_path_traversal_in_the_archive_is_refused(client, auth, tmp_path, name) -> None:
    data = rewrite_zip(small_archive_bytes(tmp_path), {}, add={name: b"x"})
    assert_refused(client, upload(client, auth, data), 422, "pass archive:")


def test_a_missing_manifest_is_refused(client, auth, tmp_path) -> None:
    data = rewrite_zip(small_archive_bytes(tmp_path), {"manifest.json": None})
    assert_refused(client, upload(client, auth, data), 422, "lacks manifest.json")


def test_a_manifest_that_is_not_json_is_refused(client, auth, tmp_path) -> None:
    data = rewrite_zip(small_archive_bytes(tmp_path), {"manifest.json": b"{nope"})
    assert_refused(client, upload(client, auth, data), 422, "manifest.json is not valid JSON")


def test_a_manifest_without_wheels_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    manifest = manifest_of(original)
    del manifest["wheels"]
    data = rewrite_zip(original, {"manifest.json": json.dumps(manifest).encode()})
    assert_refused(client, upload(client, auth, data), 422, "manifest lacks 'wheels'")


def test_an_unknown_side_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    manifest = manifest_of(original)
    manifest["wheels"][0]["side"] = "middle"
    data = rewrite_zip(original, {"manifest.json": json.dumps(manifest).encode()})
    assert_refused(client, upload(client, auth, data), 422, "middle")


def test_an_uncalibrated_sensor_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    calibration = calibration_document()
    del calibration["sensors"]["right_outer"]
    data = rewrite_zip(original, {"calibration.json": json.dumps(calibration).encode()})
    assert_refused(client, upload(client, auth, data), 422, "right_outer")


def first_frame_path(data: bytes) -> str:
    return manifest_of(data)["wheels"][0]["frames"]["inner"][0]


def test_a_frame_that_is_not_an_image_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    data = rewrite_zip(original, {first_frame_path(original): b"not a png at all, really not"})
    assert_refused(client, upload(client, auth, data), 422, "is not a PNG image")


def test_a_frame_of_the_wrong_size_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    data = rewrite_zip(original, {first_frame_path(original): frame_png((31, 40))})
    assert_refused(client, upload(client, auth, data), 422, "40x31 px", "calibrated for 40x30")


def test_a_frame_of_the_wrong_bit_depth_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    data = rewrite_zip(original, {first_frame_path(original): frame_png(dtype=np.uint16)})
    assert_refused(client, upload(client, auth, data), 422, "16 bit", "8 bit")


def test_a_colour_frame_is_refused(client, auth, tmp_path) -> None:
    original = small_archive_bytes(tmp_path)
    import cv2

    ok, colour = cv2.imencode(".png", np.zeros((30, 40, 3), np.uint8))
    data = rewrite_zip(original, {first_frame_path(original): colour.tobytes()})
    assert_refused(client, upload(client, auth, data), 422, "grey PNG")


def test_an_archive_without_calibration_needs_a_registered_one(client, auth, tmp_path) -> None:
    data = small_archive_bytes(tmp_path, with_calibration=False)
    assert_refused(client, upload(client, auth, data), 422, "has no registered calibration")


def test_a_multipart_body_without_file_is_refused(client, auth) -> None:
    response = client.post(
        "/api/passes",
        headers=auth("operator"),
        files={"archive": ("p.zip", b"PK", "application/zip")},
    )
    assert response.status_code == 422
    assert "file" in response.json()["detail"]


def test_upload_needs_an_operator_token(client, auth, tmp_path) -> None:
    assert_refused(
        client, upload(client, auth, small_archive_bytes(tmp_path), "viewer"), 403, "operator"
    )


def test_a_repeated_upload_returns_the_existing_pass(client, auth, tmp_path) -> None:
    data = small_archive_bytes(tmp_path)
    first = upload(client, auth, data)
    # The wheels' artefacts reach the store while they are measured: list it once they are.
    client.app.state.runner.drain()
    files_after_first = store_files(client)
    second = upload(client, auth, data)
    client.app.state.runner.drain()
    assert first.status_code == second.status_code == 202
    assert first.json() == second.json()
    rows = stored_rows(client)
    assert rows["Pass"] == 1 and rows["Frame"] == 4 and rows["PassWheel"] == 2
    assert store_files(client) == files_after_first


def test_a_valid_upload_stores_frames_once_by_content(client, auth, tmp_path) -> None:
    response = upload(client, auth, small_archive_bytes(tmp_path))
    assert response.status_code == 202
    with zipfile.ZipFile(io.BytesIO(small_archive_bytes(tmp_path))) as archive:
        frames = {archive.read(n) for n in archive.namelist() if n.startswith("frames/")}
    digests = {hashlib.sha256(frame).hexdigest() for frame in frames}
    # The wheels' measured artefacts join the store too; the frames are the blobs rows name.
    client.app.state.runner.drain()
    with client.app.state.session_factory() as session:
        assert set(session.scalars(select(Frame.sha256))) == digests
    assert sorted(n for n in store_files(client) if n.split(".")[0] in digests) == sorted(
        f"{digest}.png" for digest in digests
    )


def test_a_registered_calibration_serves_archives_without_one(client, auth, tmp_path) -> None:
    assert (
        client.post("/api/sites", headers=auth("admin"), json={"name": "test-site"}).status_code
        == 201
    )
    registered = client.post(
        "/api/sites/test-site/calibrations",
        headers=auth("admin"),
        json={"document": calibration_document(), "note": "commissioning"},
    )
    assert registered.status_code == 201
    assert registered.json()["version"] == 1
    response = upload(client, auth, small_archive_bytes(tmp_path, with_calibration=False))
    assert response.status_code == 202


def test_an_invalid_calibration_is_refused_with_its_fault(client, auth) -> None:
    client.post("/api/sites", headers=auth("admin"), json={"name": "s"})
    document = calibration_document()
    document["sensors"]["left_inner"]["bit_depth"] = 12
    response = client.post(
        "/api/sites/s/calibrations", headers=auth("admin"), json={"document": document}
    )
    assert response.status_code == 422
    assert "bit_depth must be 8 or 16" in response.json()["detail"]


def test_calibration_versions_are_never_edited_in_place(client, auth) -> None:
    client.post("/api/sites", headers=auth("admin"), json={"name": "s"})
    document = calibration_document()
    first = client.post(
        "/api/sites/s/calibrations", headers=auth("admin"), json={"document": document}
    )
    again = client.post(
        "/api/sites/s/calibrations", headers=auth("admin"), json={"document": document}
    )
    document["sensors"]["left_inner"]["laser_plane"]["d"] = 501.0
    changed = client.post(
        "/api/sites/s/calibrations", headers=auth("admin"), json={"document": document}
    )
    assert first.json()["id"] == again.json()["id"]
    assert changed.json()["version"] == 2
    versions = client.get("/api/sites/s/calibrations", headers=auth("viewer")).json()
    assert [v["version"] for v in versions] == [2, 1]
    assert versions[1]["document"]["sensors"]["left_inner"]["laser_plane"]["d"] == 500.0
