"""Report speed on the demo pass: the pass PDF and each wheel's PDF, rendered and cached.

The demo pass of `wheelscan run-demo` (3 vehicles, 24 wheels, both methods) is simulated,
ingested and measured by the service (SQLite, 2 worker processes); then, through the API,
the pass PDF is rendered from an empty cache several times (median and worst), fetched
again from the cache, and revalidated with its ETag (304); every wheel's PDF is rendered
once from an empty cache. The demo pass's pages are written as PNG (pdftoppm, 70 dpi) to
tests/e2e/screenshots/reports/ to be looked at.

Run alone with `python -m benchmarks.reports` (prints the Markdown section).
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.config import Settings
from backend.ops.demo import load_demo
from backend.services.auth import create_token

VEHICLES = 3
COLD_RUNS = 5
SCREENSHOTS = Path(__file__).resolve().parent.parent / "tests" / "e2e" / "screenshots" / "reports"
PNG_DPI = 70


def _wait_measured(client: TestClient, headers: dict[str, str], pass_id: int) -> None:
    deadline = time.monotonic() + 1800
    while time.monotonic() < deadline:
        job = client.get(f"/api/passes/{pass_id}", headers=headers).json()["job"]
        if job and job["state"] in ("done", "failed"):
            return
        time.sleep(1.0)
    raise TimeoutError(f"demo pass {pass_id} not measured in 30 min")


@dataclass(frozen=True, slots=True)
class Timed:
    """One request: wall and CPU time of this process (the API renders in a thread of it)."""

    wall_s: float
    cpu_s: float
    content: bytes
    etag: str


def _timed_get(client: TestClient, path: str, headers: dict[str, str]) -> Timed:
    wall, cpu = time.perf_counter(), time.process_time()
    response = client.get(path, headers=headers)
    timed = Timed(
        time.perf_counter() - wall, time.process_time() - cpu, response.content,
        response.headers.get("ETag", ""),
    )  # fmt: skip
    response.raise_for_status()
    return timed


def _row(name: str, runs: list[Timed], goal: str) -> str:
    walls = [r.wall_s for r in runs]
    cpus = [r.cpu_s for r in runs]
    return (
        f"| {name} | {len(runs)} | {statistics.median(walls):.3f} s | {max(walls):.3f} s | "
        f"{statistics.median(cpus):.3f} s | {goal} |"
    )


def _pages(pdf: Path) -> int:
    info = subprocess.run(["pdfinfo", str(pdf)], check=True, capture_output=True, text=True)
    pages = next(line for line in info.stdout.splitlines() if line.startswith("Pages"))
    return int(pages.split()[-1])


def _write_screenshots(pdf: Path) -> int:
    shutil.rmtree(SCREENSHOTS, ignore_errors=True)
    SCREENSHOTS.mkdir(parents=True)
    subprocess.run(
        ["pdftoppm", "-r", str(PNG_DPI), "-png", str(pdf), str(SCREENSHOTS / "demo-pass-page")],
        check=True,
    )
    return len(list(SCREENSHOTS.glob("*.png")))


def run() -> str:
    with tempfile.TemporaryDirectory(prefix="bench-reports-") as folder:
        settings = Settings(data_dir=Path(folder), workers=2)
        pass_id = load_demo(settings, vehicles=VEHICLES)
        cache = settings.data_dir / "reports"
        app = create_app(settings)
        with TestClient(app) as client:
            with app.state.session_factory() as session:
                token = create_token(session, role="viewer", name="bench")[1]
                session.commit()
            headers = {"Authorization": f"Bearer {token}"}
            _wait_measured(client, headers, pass_id)
            path = f"/api/passes/{pass_id}/report.pdf"
            load_before = os.getloadavg()[0]
            cold = []
            for _ in range(COLD_RUNS):
                shutil.rmtree(cache, ignore_errors=True)
                cold.append(_timed_get(client, path, headers))
            cached = _timed_get(client, path, headers)
            start = time.perf_counter()
            held = client.get(path, headers={**headers, "If-None-Match": cold[-1].etag})
            revalidated = time.perf_counter() - start
            wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=headers).json()
            shutil.rmtree(cache, ignore_errors=True)
            wheel_runs = [
                _timed_get(
                    client, f"/api/passes/{pass_id}/wheels/{w['wheel_id']}/report.pdf", headers
                )
                for w in wheels
            ]
        pdf = Path(folder) / "pass.pdf"
        pdf.write_bytes(cold[-1].content)
        pages, screenshots = _pages(pdf), _write_screenshots(pdf)
    return "\n".join(
        [
            "## Reports (demo pass)",
            "",
            f"The demo pass ({VEHICLES} vehicles, {len(wheels)} wheels, adaptive and Steger), "
            "measured by the service on SQLite; times through the API (TestClient), the "
            "PDF cache emptied before each rendered run; CPU is this process's (the API "
            "renders in one of its threads), the figure to read when the machine is shared "
            f"(1-min load average {load_before:.1f} on {os.cpu_count()} cores before the runs). "
            f"The pass PDF has {pages} pages, {len(cold[-1].content) / 1e3:.0f} kB; its "
            f"{screenshots} pages are in tests/e2e/screenshots/reports/.",
            "",
            "| request | runs | median | worst | CPU (median) | goal |",
            "|---|---|---|---|---|---|",
            _row("pass PDF, rendered", cold, "≤ 2 s"),
            _row("pass PDF, from the cache", [cached], "–"),
            f"| pass PDF, ETag revalidated ({held.status_code}) | 1 | {revalidated:.3f} s | – | – "
            "| – |",
            _row("wheel PDF, rendered", wheel_runs, "≤ 0.3 s"),
            "",
        ]
    )


if __name__ == "__main__":
    import sys

    sys.stdout.write(run() + "\n")
