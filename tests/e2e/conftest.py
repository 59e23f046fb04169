"""Fixtures of the browser tests: the real service (uvicorn subprocess on a temp data dir with
SQLite), tokens made by the CLI, a simulated 1-vehicle pass, and Debian's headless Chromium
driven by Playwright."""

from __future__ import annotations

import io
import os
import socket
import subprocess
import sys
import time
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
SCREENSHOTS = Path(__file__).resolve().parent / "screenshots"
UPDATE_SCREENSHOTS = "WHEELSCAN_SCREENSHOTS"
"""Set to "update" to write the committed pictures (SCREENSHOTS); otherwise a run writes
them to SCREENSHOTS/latest/ (git-ignored), so testing leaves the checkout clean."""
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
SERVER_START_TIMEOUT_S = 60.0


@dataclass(frozen=True, slots=True)
class Service:
    """A running service and what the tests need to talk to it."""

    url: str
    data_dir: Path
    env: dict[str, str]
    made: dict[str, str] = field(default_factory=dict)

    def token(self, role: str) -> str:
        """A token with `role`, made once per session by `wheelscan token create`."""
        if role in self.made:
            return self.made[role]
        result = subprocess.run(
            [
                *WHEELSCAN,
                "token",
                "create",
                "--role",
                role,
                "--name",
                f"e2e {role}",
            ],
            env=self.env,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
            cwd=ROOT,
        )
        assert result.returncode == 0, result.stderr
        self.made[role] = result.stdout.strip().splitlines()[-1]
        return self.made[role]


WHEELSCAN = [sys.executable, "-m", "backend.cli"]
"""The `wheelscan` command line, run from this checkout's interpreter."""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _wait_healthy(url: str, process: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + SERVER_START_TIMEOUT_S
    while time.monotonic() < deadline:
        if process.poll() is not None:
            pytest.fail(f"the service exited with {process.returncode}:\n{log.read_text()[-3000:]}")
        try:
            if httpx.get(f"{url}/healthz", timeout=1.0).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.2)
    pytest.fail(f"the service did not answer /healthz in {SERVER_START_TIMEOUT_S} s")


@pytest.fixture(scope="session")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """The real service on loopback: `wheelscan serve` with a temp data dir and SQLite."""
    data_dir = tmp_path_factory.mktemp("e2e-data")
    port = _free_port()
    env = {
        **os.environ,
        "WHEELSCAN_DATA_DIR": str(data_dir),
        "WHEELSCAN_WORKERS": "2",  # the default: a pass's wheels measured two at a time
        "WHEELSCAN_VIEWER_PORT": str(_free_port()),
    }
    env.pop("WHEELSCAN_DATABASE_URL", None)
    env.pop("WHEELSCAN_BROKER_URL", None)
    log = data_dir / "server.log"
    with log.open("wb") as sink:
        process = subprocess.Popen(
            [
                *WHEELSCAN,
                "serve",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
            ],
            env=env,
            stdout=sink,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )
    url = f"http://127.0.0.1:{port}"
    try:
        _wait_healthy(url, process, log)
        yield Service(url=url, data_dir=data_dir, env=env)
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()


@pytest.fixture(scope="session")
def pass_archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated pass (1 vehicle, 2 axles: 4 wheels, 1600×1200 frames) zipped for upload."""
    return simulated_pass_archive(tmp_path_factory.mktemp("e2e-pass"))


def simulated_pass_archive(out: Path) -> Path:
    """Simulate the browser tests' pass (1 vehicle, 2 axles: 4 wheels, 1600×1200 frames,
    seed 6) in `out` and zip it for upload (also used by benchmarks/browser.py)."""
    folder = out / "pass"
    result = subprocess.run(
        [
            *WHEELSCAN,
            "synth-pass",
            str(folder),
            "--field",
            "clean",
            "--vehicles",
            "1",
            "--axles",
            "2",
            "--seed",
            "6",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    return zip_pass(folder, out / "e2e-pass.zip")


def zip_pass(folder: Path, archive: Path) -> Path:
    """Zip a simulated pass folder for upload, leaving its ground truth out."""
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and path.name != "truth.json":
                zf.write(path, path.relative_to(folder).as_posix())
    return archive


VIEWPORT_3D = {"width": 1200, "height": 720}
"""The browser window of the tests that open the 3D view: Chromium draws viser's WebGL
scene in software (--disable-gpu) and the tests take pictures of it until it settles, so
its pixels cost time: the view here is some half of its size at 1600×1000, and the page
keeps its two columns (it stacks them below 1100 px)."""


SCENE_LIT_FRACTION = 0.005
"""Share of the 3D view's pixels brighter than grey 100 once the wheel is drawn (the light
grey wheel, the cameras and planes fill some 10 % of it; the empty scene is dark)."""


SCENE_TOP = 0.3
"""The top of the 3D view left out of the comparisons: viser's notices (the software
WebGL toast, which goes after a while, and the connection panel) sit there."""


def grey(png: bytes) -> np.ndarray:
    """The scene part of a 3D view's picture (below SCENE_TOP) in grey levels, 0–255."""
    levels = np.asarray(Image.open(io.BytesIO(png)).convert("L")).astype(np.int16)
    return levels[int(SCENE_TOP * levels.shape[0]) :]


def changed_fraction(a: bytes, b: bytes) -> float:
    """Share of the scene's pixels two pictures of one size differ in by more than 8 grey
    levels (their common part: the view's size may round to a pixel more or less)."""
    first, second = grey(a), grey(b)
    rows, cols = min(first.shape[0], second.shape[0]), min(first.shape[1], second.shape[1])
    return float(np.mean(np.abs(first[:rows, :cols] - second[:rows, :cols]) > 8))


def wait_for_3d_scene(page: Any, timeout_s: float = 120.0) -> bytes:
    """Wait until the wheel page's embedded 3D view shows a scene: viser connected, the
    view lit by the wheel, and two successive pictures of it alike to 1 % of their pixels
    (the scene streamed and faded in); returns that picture (PNG). Conditions, not sleeps:
    the machine may be loaded."""
    page.frame_locator("iframe.viewer-frame").get_by_text("Connected").wait_for(
        timeout=timeout_s * 1000
    )
    view = page.locator("iframe.viewer-frame")
    deadline = time.monotonic() + timeout_s
    previous = None
    while time.monotonic() < deadline:
        picture = view.screenshot(animations="disabled", timeout=timeout_s * 1000)
        lit = float(np.mean(grey(picture) > 100))
        if previous and lit > SCENE_LIT_FRACTION and changed_fraction(previous, picture) < 0.01:
            return picture
        previous = picture
    pytest.fail(f"the 3D view showed no settled scene in {timeout_s:.0f} s")


def change_once_settled(page: Any, reference: bytes, timeout_s: float = 120.0) -> float:
    """The share of the scene's pixels (as `changed_fraction`) in which the wheel page's 3D
    view differs from `reference`, one of its earlier pictures, once the view shows that
    picture again or has settled on another (two successive pictures alike to 1 %). A view
    that still shows `reference` needs one picture, not two: each takes seconds while
    software WebGL draws the open scenes."""
    view = page.locator("iframe.viewer-frame")
    deadline = time.monotonic() + timeout_s
    previous = None
    while time.monotonic() < deadline:
        picture = view.screenshot(animations="disabled", timeout=timeout_s * 1000)
        changed = changed_fraction(reference, picture)
        if changed < 0.01 or (previous and changed_fraction(previous, picture) < 0.01):
            return changed
        previous = picture
    pytest.fail(f"the 3D view settled on no picture in {timeout_s:.0f} s")


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    """Debian's Chromium, headless, under Playwright."""
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing: run `make system-deps` (browser tests NOT run)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        instance = playwright.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield instance
        finally:
            instance.close()


@pytest.fixture(scope="session")
def screenshots() -> Path:
    """Where each view's screenshot is saved: tests/e2e/screenshots/latest/ (git-ignored),
    or the committed pictures in tests/e2e/screenshots/ when WHEELSCAN_SCREENSHOTS=update
    (every run rewrote them, and left the checkout changed). Nothing is emptied: each test
    writes, and so replaces, only its own files, so a run of some tests leaves the others'
    pictures as they were."""
    update = os.environ.get(UPDATE_SCREENSHOTS) == "update"
    folder = SCREENSHOTS if update else SCREENSHOTS / "latest"
    folder.mkdir(parents=True, exist_ok=True)
    return folder
