"""Bodies and frames that would exhaust a real server (`wheelscan serve`): each is refused
while the server's peak resident memory stays within 100 MiB of idle, and nothing is
written for it (no store blob, no upload spooled to disk)."""

from __future__ import annotations

import json
import select
import socket
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.backend.archives import calibration_document, rewrite_zip, small_archive_bytes
from tests.faults.live import LiveServer, check_store
from tests.scale.topology import wait_until

MIB = 2**20
MAX_GROWTH_BYTES = 100 * MIB
"""Peak resident memory a refused request may add to the idle server."""
UPLOAD_LIMIT_BYTES = 64 * MIB
SENT_BYTES = 256 * MIB
"""What a hostile client tries to send: four times the upload limit, eight times a frame's."""


def huge_png(width_px: int, height_px: int) -> bytes:
    """A valid, all-black grey PNG of width x height px (deflated to a few MB)."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    deflate = zlib.compressobj(9)
    row = bytes(width_px + 1)  # filter byte 0 and the row's pixels
    idat = b"".join(deflate.compress(row) for _ in range(height_px)) + deflate.flush()
    header = struct.pack(">IIBBBBB", width_px, height_px, 8, 0, 0, 0, 0)
    body = chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    return b"\x89PNG\r\n\x1a\n" + body


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("WHEELSCAN_MAX_UPLOAD_BYTES", str(UPLOAD_LIMIT_BYTES))
        live = LiveServer(tmp_path_factory.mktemp("limits") / "data")
        live.start()
    yield live
    live.close()


@pytest.fixture(scope="module")
def bomb_frame() -> bytes:
    """30000 x 30000 px in about 1 MB: 860 MiB once decoded."""
    return huge_png(30000, 30000)


class PeakMemory:
    """Peak resident memory of a process above its resident memory now (/proc, Linux)."""

    def __init__(self, pid: int) -> None:
        self.status = Path(f"/proc/{pid}/status")
        Path(f"/proc/{pid}/clear_refs").write_text("5")  # resets VmHWM to VmRSS
        self.idle_bytes = self._field("VmRSS")

    def _field(self, name: str) -> int:
        for line in self.status.read_text().splitlines():
            if line.startswith(name + ":"):
                return int(line.split()[1]) * 1024
        raise AssertionError(f"{name} not in {self.status}")

    def growth_bytes(self) -> int:
        return self._field("VmHWM") - self.idle_bytes


def send_chunked(server: LiveServer, head: str, first: bytes, total_bytes: int) -> tuple[int, int]:
    """Stream a chunked body of `total_bytes` (`first`, then zeros) until the server answers.

    Returns the status and how many body bytes were sent before the answer.
    """
    sock = socket.create_connection(("127.0.0.1", server.port), timeout=60)
    sock.sendall(f"{head}Host: x\r\nTransfer-Encoding: chunked\r\n\r\n".encode())
    piece = bytes(MIB)
    sent = 0
    answer = b""
    with sock:
        while sent < total_bytes:
            data = first if sent == 0 else piece
            try:
                sock.sendall(f"{len(data):x}\r\n".encode() + data + b"\r\n")
            except (BrokenPipeError, ConnectionResetError):
                break
            sent += len(data)
            if select.select([sock], [], [], 0)[0]:
                break
        else:
            sock.sendall(b"0\r\n\r\n")
        while b"\r\n" not in answer:
            received = sock.recv(65536)
            if not received:
                break
            answer += received
    return int(answer.split(b" ", 2)[1]), sent


def _token(server: LiveServer, role: str) -> str:
    return f"Authorization: Bearer {server.token(role)}\r\n"


def test_a_chunked_blob_stops_at_the_frame_limit(server: LiveServer) -> None:
    peak = PeakMemory(server.process.pid)
    head = f"PUT /api/blobs/{'0' * 64}.png HTTP/1.1\r\n{_token(server, 'operator')}"
    head += "Content-Type: application/octet-stream\r\n"
    status, sent = send_chunked(server, head, bytes(MIB), SENT_BYTES)
    assert status == 413
    assert sent < SENT_BYTES
    assert peak.growth_bytes() <= MAX_GROWTH_BYTES, peak.growth_bytes() / MIB
    assert not check_store(server.data_dir, server.tmp_dir)


@pytest.mark.parametrize("role", [None, "viewer", "operator"])
def test_a_chunked_multipart_upload_is_authenticated_first_and_stops_at_the_limit(
    server: LiveServer, role: str | None
) -> None:
    peak = PeakMemory(server.process.pid)
    head = "POST /api/passes HTTP/1.1\r\nContent-Type: multipart/form-data; boundary=b\r\n"
    head += _token(server, role) if role else ""
    first = b'--b\r\nContent-Disposition: form-data; name="file"; filename="a.zip"\r\n\r\n'
    status, sent = send_chunked(server, head, first, SENT_BYTES)
    assert status == {None: 401, "viewer": 403, "operator": 413}[role]
    assert sent < SENT_BYTES
    assert peak.growth_bytes() <= MAX_GROWTH_BYTES, peak.growth_bytes() / MIB
    assert not check_store(server.data_dir, server.tmp_dir)  # nothing spooled, nothing left


def test_a_streamed_frame_of_a_huge_size_is_refused_from_its_header(
    server: LiveServer, bomb_frame: bytes
) -> None:
    with server.client() as client:
        opened = client.post(
            "/api/passes/stream",
            json={
                "site": "limits",
                "started_at": "2026-11-23T12:00:00Z",
                "calibration": calibration_document(),
            },
        )
        assert opened.status_code == 201, opened.text
        peak = PeakMemory(server.process.pid)
        response = client.put(
            f"/api/passes/{opened.json()['pass_id']}/frames/left_inner/0",
            params={"vehicle_id": "V1", "axle": 1},
            headers={"Content-Type": "image/png"},
            content=bomb_frame,
        )
    assert response.status_code == 422, response.text
    assert "30000x30000 px" in response.json()["detail"]
    assert peak.growth_bytes() <= MAX_GROWTH_BYTES, peak.growth_bytes() / MIB


def test_an_archive_with_a_huge_frame_is_refused_from_its_header(
    server: LiveServer, bomb_frame: bytes, tmp_path: Path
) -> None:
    archive = rewrite_zip(
        small_archive_bytes(tmp_path), {"frames/left_inner/000001.png": bomb_frame}
    )
    with server.client() as client:
        peak = PeakMemory(server.process.pid)
        response = client.post(
            "/api/passes", files={"file": ("pass.zip", archive, "application/zip")}
        )
    assert response.status_code == 422, response.text
    assert "30000x30000 px" in response.json()["detail"]
    assert peak.growth_bytes() <= MAX_GROWTH_BYTES, peak.growth_bytes() / MIB
    with server.client("viewer") as client:
        passes = client.get("/api/passes").json()["items"]
    assert [p["source"] for p in passes] in ([], ["stream"])  # no uploaded pass
    assert not check_store(server.data_dir, server.tmp_dir)
    assert json.loads(httpx.get(f"{server.url}/healthz").text)["status"] == "ok"


def test_a_token_in_the_url_is_logged_redacted(server: LiveServer) -> None:
    secret = "wst_" + "s3cret" * 6
    httpx.get(f"{server.url}/api/passes", params={"token": secret}, timeout=10)
    wait_until(lambda: "/api/passes?token=" in server.log_tail(), 10, "the access log line")
    log = server.log_tail(10**7)
    assert "token=[redacted]" in log and secret not in log
    assert "Logging error" not in log
