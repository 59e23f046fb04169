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

import shutil
import statistics
import subprocess
import tempfile
import time
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


def _timed_get(client: TestClient, path: str, headers: dict[str, str]) -> tuple[float, bytes, str]:
    start = time.perf_counter()
    response = client.get(path, headers=headers)
    elapsed = time.perf_counter() - start
    response.raise_for_status()
    return elapsed, response.content, response.headers.get("ETag", "")


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
        with TestClient(create_app(settings)) as client:
            with client.app.state.session_factory() as session:
                token = create_token(session, role="viewer", name="bench")[1]
                session.commit()
            headers = {"Authorization": f"Bearer {token}"}
            _wait_measured(client, headers, pass_id)
            path = f"/api/passes/{pass_id}/report.pdf"
            cold = []
            for _ in range(COLD_RUNS):
                shutil.rmtree(cache, ignore_errors=True)
                seconds, pdf_bytes, etag = _timed_get(client, path, headers)
                cold.append(seconds)
            cached, _, _ = _timed_get(client, path, headers)
            start = time.perf_counter()
            held = client.get(path, headers={**headers, "If-None-Match": etag})
            revalidated = time.perf_counter() - start
            wheels = client.get(f"/api/passes/{pass_id}/wheels", headers=headers).json()
            shutil.rmtree(cache, ignore_errors=True)
            wheel_s = [
                _timed_get(
                    client, f"/api/passes/{pass_id}/wheels/{w['wheel_id']}/report.pdf", headers
                )[0]
                for w in wheels
            ]
        pdf = Path(folder) / "pass.pdf"
        pdf.write_bytes(pdf_bytes)
        pages, screenshots = _pages(pdf), _write_screenshots(pdf)
    return "\n".join(
        [
            "## Reports (demo pass)",
            "",
            f"The demo pass ({VEHICLES} vehicles, {len(wheels)} wheels, adaptive and Steger), "
            "measured by the service on SQLite; times through the API (TestClient), the "
            f"PDF cache emptied before each cold run. The pass PDF has {pages} pages, "
            f"{len(pdf_bytes) / 1e3:.0f} kB; its {screenshots} pages are in "
            "tests/e2e/screenshots/reports/.",
            "",
            "| request | runs | median | worst | goal |",
            "|---|---|---|---|---|",
            f"| pass PDF, rendered | {COLD_RUNS} | {statistics.median(cold):.2f} s | "
            f"{max(cold):.2f} s | ≤ 2 s |",
            f"| pass PDF, from the cache | 1 | {cached * 1e3:.0f} ms | – | – |",
            f"| pass PDF, ETag revalidated ({held.status_code}) | 1 | "
            f"{revalidated * 1e3:.0f} ms | – | – |",
            f"| wheel PDF, rendered | {len(wheel_s)} | {statistics.median(wheel_s):.3f} s | "
            f"{max(wheel_s):.3f} s | ≤ 0.3 s |",
            "",
        ]
    )


if __name__ == "__main__":
    import sys

    sys.stdout.write(run() + "\n")
