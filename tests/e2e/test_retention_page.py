"""The wheel page of a pass whose camera frames retention removed: the rest of the page
works and it says in words that the frames went, and when."""

from __future__ import annotations

import json
import subprocess
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import httpx
import pytest
from sqlalchemy import create_engine, update
from websockets.sync.client import connect

from db.models import Pass
from tests.backend.archives import small_archive_bytes
from tests.e2e.conftest import ROOT, WHEELSCAN, Service

pytestmark = [pytest.mark.e2e]


def wait_for_job(service: Service, job_id: int) -> None:
    """Follow the job's progress socket until it reports done (no polling sleeps)."""
    url = service.url.replace("http://", "ws://")
    with connect(f"{url}/api/ws/jobs/{job_id}?token={service.token('viewer')}") as socket:
        while json.loads(socket.recv(timeout=120))["state"] != "done":
            pass


@pytest.fixture(scope="module")
def expired_pass(service: Service, tmp_path_factory: pytest.TempPathFactory) -> int:
    """A small pass uploaded, measured, dated 60 days back, then swept by the CLI."""
    data = small_archive_bytes(tmp_path_factory.mktemp("retention"))
    response = httpx.post(
        f"{service.url}/api/passes",
        headers={"Authorization": f"Bearer {service.token('operator')}"},
        files={"file": ("old.zip", data, "application/zip")},
        timeout=60,
    )
    assert response.status_code == 202, response.text
    accepted = response.json()
    wait_for_job(service, accepted["job_id"])
    engine = create_engine(f"sqlite:///{service.data_dir / 'wheelscan.db'}")
    with engine.begin() as connection:
        connection.execute(
            update(Pass)
            .where(Pass.id == accepted["pass_id"])
            .values(started_at=datetime.now(UTC) - timedelta(days=60))
        )
    engine.dispose()
    swept = subprocess.run(
        [*WHEELSCAN, "retention", "--days", "30"],
        env=service.env,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
        cwd=ROOT,
    )
    assert f"pass {accepted['pass_id']} (started" in swept.stdout
    return int(accepted["pass_id"])


def test_the_wheel_page_says_the_frames_were_removed(
    browser: Any, service: Service, expired_pass: int, screenshots: Path
) -> None:
    context = browser.new_context(viewport={"width": 1600, "height": 1000})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(f"{service.url}/#token={service.token('viewer')}")
    page.locator("header .role").wait_for()
    wheels = httpx.get(
        f"{service.url}/api/passes/{expired_pass}/wheels",
        headers={"Authorization": f"Bearer {service.token('viewer')}"},
        timeout=10,
    ).json()
    wheel_id = wheels[0]["wheel_id"]
    assert wheels[0]["frames_removed_at"] is not None
    page.goto(f"{service.url}/#/passes/{expired_pass}/wheels/{wheel_id}")
    page.locator(f'[data-loaded-wheel="{expired_pass}/{wheel_id}"]').wait_for(timeout=30_000)
    note = page.locator(".layer-note")
    today = datetime.now(UTC).date().isoformat()
    assert f"camera frames removed by retention on {today}" in note.inner_text()
    page.screenshot(path=str(screenshots / "20-wheel-frames-removed.png"))
    context.close()
    assert errors == [], f"uncaught errors in the page: {errors}"
