"""Faults survived, backups restored, hostile requests refused: runs the fault tests
(tests/faults: the server SIGKILLed mid-upload, mid-measurement and mid-report, PostgreSQL
restarted under load, a nearly full disk, oversized bodies) and the backup → restore tests
(tests/backend/test_backup*.py), and reports each test's outcome and time. A passed test
found nothing lost, nothing half-written and the state the user sees clear (see the tests
for what each checks).

Then the figures behind the limits' bars, on SQLite and PostgreSQL: a real `wheelscan
serve`'s peak resident memory above idle while it refuses each oversized or bomb-like
request (bar: 100 MiB), the bytes it read first, and what the refusal left (rows, blobs,
spooled files: bar nothing); and the time to validate an archive of 4,000 frames (bar 2 s).

Run alone with `python -m benchmarks.run hardening`.
"""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable
from pathlib import Path

import httpx
import numpy as np
from sqlalchemy import func, select

from db.engine import make_engine
from db.models import Base
from pipeline.archive.pass_archive import read_pass_archive
from tests.backend.archives import calibration_document, rewrite_zip, small_archive_bytes
from tests.databases import BACKENDS, throwaway_database
from tests.faults.live import LiveServer, check_store
from tests.faults.test_resource_limits import (
    MAX_GROWTH_BYTES,
    MIB,
    UPLOAD_LIMIT_BYTES,
    PeakMemory,
    huge_png,
    send_chunked,
)
from tests.pipeline.archive_helpers import many_frames_zip, padded_png

ROOT = Path(__file__).resolve().parent.parent
SUITES = {
    "faults": ["tests/faults"],
    "backup and restore": ["tests/backend/test_backup.py", "tests/backend/test_backup_errors.py"],
}
_OUTCOME = re.compile(r"^(?P<outcome>PASSED|FAILED|SKIPPED|ERROR) (?P<test>.+?)(?: - .*)?$", re.M)
_DURATION = re.compile(r"^(?P<seconds>[\d.]+)s call\s+(?P<test>.+?)$", re.M)


def _run_suite(paths: list[str]) -> tuple[list[tuple[str, str, float]], float]:
    started_s = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "pytest", *paths, "-q", "-rA", "-p", "no:warnings",
         "--durations=0", "--durations-min=0"],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )  # fmt: skip
    elapsed_s = time.perf_counter() - started_s
    durations = {m["test"]: float(m["seconds"]) for m in _DURATION.finditer(result.stdout)}
    outcomes = [
        (m["test"], m["outcome"], durations.get(m["test"], float("nan")))
        for m in _OUTCOME.finditer(result.stdout)
    ]
    return outcomes, elapsed_s


HOSTILE_BODY_BYTES = 512 * MIB
"""What a hostile client streams at the server (chunked): 16 frame limits, 8 upload limits."""
MANY_FRAMES = 4000
VALIDATION_BAR_S = 2.0


def _rows(database_url: str) -> dict[str, int]:
    engine = make_engine(database_url)
    try:
        with engine.connect() as connection:
            return {
                table.name: connection.scalar(select(func.count()).select_from(table)) or 0
                for table in Base.metadata.sorted_tables
            }
    finally:
        engine.dispose()


def _chunked(head: str) -> Callable[[LiveServer], tuple[int, int]]:
    first = b'--b\r\nContent-Disposition: form-data; name="file"; filename="a.zip"\r\n\r\n'

    def send(server: LiveServer) -> tuple[int, int]:
        body_first = first if "multipart" in head else bytes(MIB)
        return send_chunked(server, head, body_first, HOSTILE_BODY_BYTES)

    return send


def _posted(archive: bytes) -> Callable[[LiveServer], tuple[int, int]]:
    def send(server: LiveServer) -> tuple[int, int]:
        with server.client() as client:
            response = client.post(
                "/api/passes", files={"file": ("pass.zip", archive, "application/zip")}
            )
        return response.status_code, len(archive)

    return send


def _put_frame(frame: bytes, pass_id: int) -> Callable[[LiveServer], tuple[int, int]]:
    def send(server: LiveServer) -> tuple[int, int]:
        with server.client() as client:
            response = client.put(
                f"/api/passes/{pass_id}/frames/left_inner/0",
                params={"vehicle_id": "V1", "axle": 1},
                headers={"Content-Type": "image/png"},
                content=frame,
            )
        return response.status_code, len(frame)

    return send


def _hostile_requests(server: LiveServer, work: Path) -> list[tuple[str, int, Callable]]:
    """(what, expected status, send) of each request the limits must refuse cheaply."""
    token = {
        role: f"Authorization: Bearer {server.token(role)}\r\n" for role in ("viewer", "operator")
    }
    multipart = "POST /api/passes HTTP/1.1\r\nContent-Type: multipart/form-data; boundary=b\r\n"
    blob = f"PUT /api/blobs/{'0' * 64}.png HTTP/1.1\r\nContent-Type: application/octet-stream\r\n"
    bomb = huge_png(30000, 30000)
    archive = small_archive_bytes(work)
    with server.client() as client:
        opened = client.post(
            "/api/passes/stream",
            json={"site": "limits", "started_at": "2026-11-23T12:00:00Z",
                  "calibration": calibration_document()},
        )  # fmt: skip
    opened.raise_for_status()
    pass_id = opened.json()["pass_id"]
    mib = HOSTILE_BODY_BYTES // MIB
    over = f"operator, limit {UPLOAD_LIMIT_BYTES // MIB} MiB"
    in_archive = rewrite_zip(archive, {"frames/left_inner/000001.png": bomb})
    return [
        (f"blob PUT, {mib} MiB chunked (operator)", 413, _chunked(blob + token["operator"])),
        (f"upload, {mib} MiB chunked multipart, no token", 401, _chunked(multipart)),
        (f"upload, {mib} MiB chunked multipart (viewer)", 403,
         _chunked(multipart + token["viewer"])),
        (f"upload, {mib} MiB chunked multipart ({over})", 413,
         _chunked(multipart + token["operator"])),
        (f"frame PUT, 30000x30000 px PNG of {len(bomb) / MIB:.1f} MiB", 422,
         _put_frame(bomb, pass_id)),
        ("upload, that PNG in an archive", 422, _posted(in_archive)),
        ("upload, 4 frames padded with 4 MiB chunks", 422, _posted(_padded(archive, 4 * MIB))),
    ]  # fmt: skip


def _padded(archive: bytes, padding_bytes: int) -> bytes:
    """The archive, deflated, each frame padded before IEND with `padding_bytes` that are
    1/150 noise: under the zip's compression-ratio limit (200), so the frame check is what
    refuses it (13 MiB of such frames once stored 512 MiB)."""
    noise = np.random.default_rng(0)
    out = io.BytesIO()
    with (
        zipfile.ZipFile(io.BytesIO(archive)) as source,
        zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as target,
    ):
        for name in source.namelist():
            data = source.read(name)
            if name.endswith(".png"):
                data = padded_png(data, padding_bytes, noise.bytes(padding_bytes // 150))
            target.writestr(name, data)
    return out.getvalue()


def _refusals(backend: str) -> list[str]:
    """Table rows: each hostile request's status, bytes sent, peak growth, what it left."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="wheelscan-limits-") as folder:
        work = Path(folder)
        with throwaway_database(backend, work) as url:
            os.environ["WHEELSCAN_MAX_UPLOAD_BYTES"] = str(UPLOAD_LIMIT_BYTES)
            server = LiveServer(work / "data", database_url=url if backend != "sqlite" else None)
            try:
                server.start()
                assert server.process is not None
                url = server.settings.resolved_database_url
                requests = _hostile_requests(server, work)
                for what, expected, send in requests:
                    before = _rows(url)
                    peak = PeakMemory(server.process.pid)
                    status, sent = send(server)
                    growth = peak.growth_bytes()
                    after = _rows(url)
                    left = [f"{t} +{after[t] - n}" for t, n in before.items() if after[t] != n]
                    left += check_store(server.data_dir, server.tmp_dir).problems
                    healthy = httpx.get(f"{server.url}/healthz", timeout=10).status_code == 200
                    verdict = "ok" if (
                        status == expected and growth <= MAX_GROWTH_BYTES and not left and healthy
                    ) else "NOT MET"  # fmt: skip
                    rows.append(
                        f"| {backend} | {what} | {status} (expected {expected}) | "
                        f"{sent / MIB:.1f} | {growth / MIB:.1f} | {', '.join(left) or 'nothing'} | "
                        f"{verdict} |"
                    )
            finally:
                server.close()
                os.environ.pop("WHEELSCAN_MAX_UPLOAD_BYTES", None)
    return rows


def _validation_time() -> str:
    with tempfile.TemporaryDirectory(prefix="wheelscan-many-") as folder:
        out = many_frames_zip(Path(folder) / "many.zip", MANY_FRAMES // 4)
        started_s, started_cpu_s = time.perf_counter(), time.process_time()
        read_pass_archive(out).close()
        wall_s = time.perf_counter() - started_s
        cpu_s = time.process_time() - started_cpu_s
    verdict = "met" if wall_s <= VALIDATION_BAR_S else "NOT MET"
    return (
        f"Validating a zip of {MANY_FRAMES:,} frames (40×30 px, headers and pixels decoded): "
        f"{wall_s:.2f} s wall, {cpu_s:.2f} s CPU (bar {VALIDATION_BAR_S:.0f} s: {verdict}; "
        "it took 55 s when the zip was reopened for every member)."
    )


def limits() -> list[str]:
    """Markdown lines: the hostile requests' table and the validation time."""
    table = [row for backend in BACKENDS for row in _refusals(backend)]
    return [
        "### oversized and bomb-like requests refused (`wheelscan serve`)",
        "",
        f"Peak resident memory of the server process above idle (/proc VmHWM) while it "
        f"refuses each request (bar {MAX_GROWTH_BYTES // MIB} MiB), the body bytes the "
        "client got to send before the answer, and the rows, blobs or spooled files the "
        "refusal left (bar: nothing).",
        "",
        "| database | request | status | MiB sent | peak growth MiB | left behind | bars |",
        "|---|---|---|---|---|---|---|",
        *table,
        "",
        _validation_time(),
        "",
    ]


def run() -> str:
    """Markdown section: each fault and backup test, its outcome and its time; the limits."""
    load_before = os.getloadavg()[0]
    lines = ["## Faults survived, backups restored (tests/faults, tests/backend/test_backup*)", ""]
    for name, paths in SUITES.items():
        outcomes, elapsed_s = _run_suite(paths)
        passed = sum(outcome == "PASSED" for _, outcome, _ in outcomes)
        lines += [
            f"### {name}: {passed} of {len(outcomes)} passed in {elapsed_s:.0f} s",
            "",
            "| test | outcome | s |",
            "|---|---|---|",
            *(f"| `{test}` | {outcome} | {seconds:.1f} |" for test, outcome, seconds in outcomes),
            "",
        ]
    lines += limits()
    lines.append(
        f"1-min load average {load_before:.1f} at the start, {os.getloadavg()[0]:.1f} at the "
        "end (2 cores shared with other work)."
    )
    return "\n".join(lines)


if __name__ == "__main__":
    sys.stdout.write(run() + "\n")
