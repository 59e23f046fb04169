"""Frame retention: raw frames of old passes go, results stay, shared blobs stay, all audited."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select

from backend.api.app import create_app
from backend.services.retention import remove_expired_frames, retention_cutoff, sweep_periodically
from db.models import AuditEvent, Frame, MeasurementFrame, Pass
from db.types import utc_now
from tests.backend.archives import (
    calibration_document,
    frame_png,
    manifest_of,
    rewrite_zip,
    small_archive_bytes,
)
from tests.backend.test_measurement_e2e import wait_for_job

NOW = datetime(2026, 12, 1, 12, 0, tzinfo=UTC)
RETENTION_DAYS = 30.0
SWEEP_BOUND_S = 2.0
"""How long the periodic sweep runs in its test: its first sweep starts at once."""


def upload(client, auth, tokens, data: bytes, started_at: datetime) -> int:
    """Upload and measure an archive; its pass is dated `started_at`. Returns the pass id."""
    response = client.post(
        "/api/passes", headers=auth("operator"), files={"file": ("p.zip", data, "application/zip")}
    )
    assert response.status_code == 202, response.text
    wait_for_job(client, tokens["viewer"], response.json()["job_id"])
    pass_id = response.json()["pass_id"]
    with client.app.state.session_factory() as session:
        session.get(Pass, pass_id).started_at = started_at
        session.commit()
    return pass_id


def frame_shas(client, pass_id: int) -> set[str]:
    with client.app.state.session_factory() as session:
        return set(session.scalars(select(Frame.sha256).where(Frame.pass_id == pass_id)))


def apply_retention(client, *, dry_run: bool = False):
    with client.app.state.session_factory() as session:
        return remove_expired_frames(
            session, client.app.state.store, RETENTION_DAYS, dry_run=dry_run, now=NOW
        )


def wheels_without_retention_mark(client, auth, pass_id: int) -> list[dict]:
    wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=auth("viewer")).json()
    return [{k: v for k, v in wheel.items() if k != "frames_removed_at"} for wheel in wheels]


@pytest.fixture
def old_pass(client, auth, tokens, tmp_path: Path) -> int:
    return upload(client, auth, tokens, small_archive_bytes(tmp_path), NOW - timedelta(days=60))


def test_the_cutoff_is_the_retention_before_now() -> None:
    assert retention_cutoff(30, NOW) == datetime(2026, 11, 1, 12, 0, tzinfo=UTC)
    with pytest.raises(ValueError, match="retention_days must be > 0, got 0"):
        retention_cutoff(0, NOW)


def test_old_frames_are_removed_and_every_result_is_kept(client, auth, old_pass) -> None:
    store = client.app.state.store
    shas = frame_shas(client, old_pass)
    results_before = wheels_without_retention_mark(client, auth, old_pass)
    sizes = sum(store.path_for(sha, ".png").stat().st_size for sha in shas)

    (removal,) = apply_retention(client)

    assert removal.pass_id == old_pass and removal.frames == 4
    assert removal.blobs_kept_shared == 0
    assert set(removal.removed_sha256) >= shas
    assert removal.bytes_removed >= sizes
    assert not any(store.has(sha, ".png") for sha in removal.removed_sha256)
    assert frame_shas(client, old_pass) == shas, "frame rows stay"
    assert wheels_without_retention_mark(client, auth, old_pass) == results_before
    summary = client.get(f"/api/passes/{old_pass}", headers=auth("viewer")).json()
    assert summary["frames_removed_at"].startswith("2026-12-01T12:00:00")
    with client.app.state.session_factory() as session:
        layers = session.scalars(select(MeasurementFrame)).all()
        assert layers and all(row.mask_png_sha256 is None for row in layers)
    assert apply_retention(client) == [], "a pass is swept once"


def test_a_removed_frame_is_410_with_words_and_the_other_views_still_work(
    client, auth, old_pass
) -> None:
    apply_retention(client)
    wheel = f"/api/passes/{old_pass}/wheels/1"
    response = client.get(f"{wheel}/frames/inner.png", headers=auth("viewer"))
    assert response.status_code == 410
    assert response.json() == {
        "detail": f"frames of pass {old_pass} were removed by retention on 2026-12-01; "
        "the measurement results are kept",
        "code": "gone",
    }
    for view in ("mask/inner.png", "centres/inner", "profile", "report.pdf", "report.json"):
        assert client.get(f"{wheel}/{view}", headers=auth("viewer")).status_code == 200, view
    report = client.get(f"/api/passes/{old_pass}/report.pdf", headers=auth("viewer"))
    assert report.status_code == 200


def test_each_pass_leaves_an_audit_event_of_what_went(client, auth, old_pass) -> None:
    (removal,) = apply_retention(client)
    with client.app.state.session_factory() as session:
        (event,) = session.scalars(
            select(AuditEvent).where(AuditEvent.action == "retention.remove_frames")
        ).all()
    assert (event.target_type, event.target_id, event.actor) == ("pass", str(old_pass), "retention")
    assert event.at == NOW
    assert event.detail["blobs_removed"] == removal.blobs_removed
    assert event.detail["bytes_removed"] == removal.bytes_removed
    assert event.detail["frames"] == 4 and event.detail["retention_days"] == RETENTION_DAYS
    assert event.detail["cutoff"] == "2026-11-01T12:00:00+00:00"
    assert sorted(event.detail["removed_sha256"]) == sorted(removal.removed_sha256)


def test_blobs_shared_with_a_newer_pass_are_kept(client, auth, tokens, tmp_path) -> None:
    data = small_archive_bytes(tmp_path)
    manifest = manifest_of(data) | {"started_at": "2026-11-30T12:00:00Z"}
    newer = rewrite_zip(data, {"manifest.json": json.dumps(manifest).encode()})
    old_id = upload(client, auth, tokens, data, NOW - timedelta(days=60))
    new_id = upload(client, auth, tokens, newer, NOW - timedelta(days=1))
    shared = frame_shas(client, old_id)
    assert shared == frame_shas(client, new_id), "the same frames in both passes"

    (removal,) = apply_retention(client)

    assert removal.pass_id == old_id
    assert removal.blobs_removed == 0 and removal.blobs_kept_shared >= len(shared)
    assert all(client.app.state.store.has(sha, ".png") for sha in shared)
    newer_frame = client.get(
        f"/api/passes/{new_id}/wheels/1/frames/inner.png", headers=auth("viewer")
    )
    assert newer_frame.status_code == 200
    older_frame = client.get(
        f"/api/passes/{old_id}/wheels/1/frames/inner.png", headers=auth("viewer")
    )
    assert older_frame.status_code == 410


def test_blobs_shared_by_two_expired_passes_go_with_the_second(
    client, auth, tokens, tmp_path
) -> None:
    data = small_archive_bytes(tmp_path)
    manifest = manifest_of(data) | {"started_at": "2026-10-02T12:00:00Z"}
    second = rewrite_zip(data, {"manifest.json": json.dumps(manifest).encode()})
    first_id = upload(client, auth, tokens, data, NOW - timedelta(days=90))
    second_id = upload(client, auth, tokens, second, NOW - timedelta(days=60))
    shared = frame_shas(client, first_id)

    first, second_removal = apply_retention(client)

    assert (first.pass_id, second_removal.pass_id) == (first_id, second_id)
    assert first.blobs_removed == 0 and second_removal.blobs_removed >= len(shared)
    assert not any(client.app.state.store.has(sha, ".png") for sha in shared)


def test_a_dry_run_removes_nothing_and_tells_the_same(client, auth, old_pass) -> None:
    store = client.app.state.store
    shas = frame_shas(client, old_pass)

    (planned,) = apply_retention(client, dry_run=True)

    assert all(store.has(sha, ".png") for sha in shas)
    summary = client.get(f"/api/passes/{old_pass}", headers=auth("viewer")).json()
    assert summary["frames_removed_at"] is None
    frame = client.get(f"/api/passes/{old_pass}/wheels/1/frames/inner.png", headers=auth("viewer"))
    assert frame.status_code == 200
    with client.app.state.session_factory() as session:
        assert session.scalars(select(MeasurementFrame.mask_png_sha256)).all()[0] is not None
        actions = session.scalars(select(AuditEvent.action)).all()
    assert "retention.remove_frames" not in actions
    assert apply_retention(client) == [planned]


def test_recent_and_unfinished_passes_keep_their_frames(client, auth, tokens, tmp_path) -> None:
    recent = upload(client, auth, tokens, small_archive_bytes(tmp_path), NOW - timedelta(days=2))
    opened = client.post(
        "/api/passes/stream",
        headers=auth("operator"),
        json={
            "site": "test-site",
            "started_at": "2026-01-01T00:00:00Z",
            "calibration": calibration_document(),
        },
    )
    assert opened.status_code == 201, opened.text
    streaming = opened.json()["pass_id"]
    put = client.put(
        f"/api/passes/{streaming}/frames/left_inner/0?vehicle_id=V9&axle=1",
        headers={**auth("operator"), "Content-Type": "image/png"},
        content=frame_png(row=7),
    )
    assert put.status_code == 201, put.text

    assert apply_retention(client) == []
    for pass_id in (recent, streaming):
        assert all(client.app.state.store.has(sha, ".png") for sha in frame_shas(client, pass_id))


def test_the_cli_verb_dry_runs_then_removes(client, auth, old_pass) -> None:
    settings = client.app.state.settings
    shas = frame_shas(client, old_pass)
    command = [
        sys.executable, "-m", "backend.cli", "retention", "--days", "30",
        "--data", str(settings.data_dir), "--database-url", settings.resolved_database_url,
    ]  # fmt: skip
    dry = subprocess.run([*command, "--dry-run"], capture_output=True, text=True, check=True)
    assert f"pass {old_pass} (started" in dry.stdout and "would remove" in dry.stdout
    assert all(client.app.state.store.has(sha, ".png") for sha in shas)

    done = subprocess.run(command, capture_output=True, text=True, check=True)

    assert "removed" in done.stdout and "1 pass(es) older than 30 days" in done.stdout
    assert not any(client.app.state.store.has(sha, ".png") for sha in shas)
    with client.app.state.session_factory() as session:
        event = session.scalars(
            select(AuditEvent).where(AuditEvent.action == "retention.remove_frames")
        ).one()
    assert event.actor == "cli"


def test_the_cli_verb_without_a_retention_says_what_to_set(tmp_path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "backend.cli", "retention", "--data", str(tmp_path)],
        capture_output=True,
        text=True,
        env={"PATH": "/usr/bin:/bin"},
    )
    assert result.returncode == 2
    assert "set WHEELSCAN_FRAME_RETENTION_DAYS or pass --days" in result.stderr


def test_the_openapi_document_lists_410_on_frame_images_only(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    frame = paths["/api/passes/{pass_id}/wheels/{wheel_id}/frames/{position}.png"]["get"]
    mask = paths["/api/passes/{pass_id}/wheels/{wheel_id}/mask/{position}.png"]["get"]
    assert "410" in frame["responses"] and "410" not in mask["responses"]


def test_the_periodic_sweep_applies_retention_at_once_and_keeps_going(
    client, auth, old_pass
) -> None:
    with client.app.state.session_factory() as session:
        session.get(Pass, old_pass).started_at = utc_now() - timedelta(days=60)
        session.commit()
    sweeps = sweep_periodically(
        client.app.state.session_factory, client.app.state.store, 30.0, interval_s=3600.0
    )
    # The loop never ends by itself; cancelling it waits for a sweep under way (its thread
    # is not interrupted), so after the bound the first sweep has run whatever the load.
    with pytest.raises(TimeoutError):
        asyncio.run(asyncio.wait_for(sweeps, timeout=SWEEP_BOUND_S))
    summary = client.get(f"/api/passes/{old_pass}", headers=auth("viewer")).json()
    assert summary["frames_removed_at"] is not None
    with client.app.state.session_factory() as session:
        actors = session.scalars(
            select(AuditEvent.actor).where(AuditEvent.action == "retention.remove_frames")
        ).all()
    assert actors == ["retention sweep"]


def test_the_server_starts_and_stops_its_sweep_when_retention_is_set(client) -> None:
    settings = client.app.state.settings.model_copy(update={"frame_retention_days": 30.0})
    with TestClient(create_app(settings)) as server:
        assert server.get("/healthz").status_code == 200
