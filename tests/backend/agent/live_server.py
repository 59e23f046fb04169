"""The real service as a uvicorn subprocess on a temporary data folder (never a mock).

It runs in its own process group so a test can SIGKILL it (and its measurement worker
processes) mid-pass and start it again on the same port and data folder.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

from backend.services.auth import create_token
from db.engine import make_engine, make_session_factory

START_TIMEOUT_S = 60.0


def free_port() -> int:
    """A TCP port on the loopback interface that nobody listens on now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class LiveServer:
    """`python -m uvicorn backend.api.app:create_app --factory` on 127.0.0.1."""

    def __init__(self, data_dir: Path) -> None:
        self.data_dir = data_dir
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = data_dir.parent / f"{data_dir.name}-server.log"
        self._process: subprocess.Popen[bytes] | None = None
        self.tokens: dict[str, str] = {}

    def start(self) -> None:
        """Start the server and wait until it answers /healthz."""
        env = {
            **os.environ,
            "WHEELSCAN_DATA_DIR": str(self.data_dir),
            "WHEELSCAN_WORKERS": "1",
        }
        env.pop("WHEELSCAN_DATABASE_URL", None)
        env.pop("WHEELSCAN_BROKER_URL", None)
        command = [sys.executable, "-m", "uvicorn", "backend.api.app:create_app", "--factory"]
        command += ["--host", "127.0.0.1", "--port", str(self.port), "--log-level", "warning"]
        with open(self.log_path, "ab") as log:
            self._process = subprocess.Popen(
                command, env=env, stdout=log, stderr=log, start_new_session=True
            )
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                raise RuntimeError(f"server exited: {self.log_path.read_text()[-2000:]}")
            try:
                if httpx.get(f"{self.url}/healthz", timeout=1.0).status_code == 200:
                    break
            except httpx.TransportError:
                time.sleep(0.1)
        else:
            raise RuntimeError(f"server did not answer within {START_TIMEOUT_S} s")
        if not self.tokens:
            self.tokens = self._make_tokens()

    def kill(self) -> None:
        """SIGKILL the server and its worker processes (no clean shutdown)."""
        if self._process is not None and self._process.poll() is None:
            os.killpg(self._process.pid, signal.SIGKILL)
            self._process.wait()

    def stop(self) -> None:
        """SIGTERM the server group and wait for it."""
        if self._process is not None and self._process.poll() is None:
            os.killpg(self._process.pid, signal.SIGTERM)
            try:
                self._process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.kill()

    def headers(self, role: str = "operator") -> dict[str, str]:
        """Authorization header of this server's token with `role`."""
        return {"Authorization": f"Bearer {self.tokens[role]}"}

    def _make_tokens(self) -> dict[str, str]:
        engine = make_engine(f"sqlite:///{(self.data_dir / 'wheelscan.db').resolve()}")
        try:
            with make_session_factory(engine)() as session:
                made = {
                    role: create_token(session, role=role, name=f"agent test {role}")[1]
                    for role in ("viewer", "operator")
                }
                session.commit()
        finally:
            engine.dispose()
        return made
