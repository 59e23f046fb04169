"""The docker-compose topology as real local processes: Celery workers (`wheelscan worker`),
a private Redis the tests may stop and start, the API in-process, PostgreSQL.

Used by tests/scale and benchmarks/throughput.py.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
import zipfile
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import redis
import uvicorn
from fastapi.testclient import TestClient
from sqlalchemy import select

from backend.api.app import create_app
from backend.config import Settings
from backend.services.auth import create_token
from db.models import Job, Measurement, PassWheel, Wheel
from pipeline.simulation.field import FieldEffects
from pipeline.simulation.passes import write_synthetic_passes
from tests.databases import free_port, redis_server_binary

WHEELSCAN = str(Path(sys.executable).parent / "wheelscan")

TEST_SCALE_ENV = {
    "WHEELSCAN_BROKER_VISIBILITY_TIMEOUT_S": "10",
    "WHEELSCAN_BROKER_RESTORE_INTERVAL_S": "1",
    "WHEELSCAN_LEASE_RETRY_S": "1",
    "WHEELSCAN_RETRY_BACKOFF_MAX_S": "2",
    "WHEELSCAN_SWEEP_INTERVAL_S": "1",
}
"""Short redelivery, retry and sweep delays, so a lost wheel comes back within seconds."""

TASK_OUTCOME = re.compile(r"Task wheelscan\.measure_wheel\[[^\]]+\] succeeded in [^:]+: '(\w+)'")


def wait_until(predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
    """Poll `predicate` (another process's progress) until true; AssertionError on timeout."""
    deadline = time.monotonic() + timeout_s
    pause = threading.Event()
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        pause.wait(0.1)


def synthetic_pass_zip(
    folder: Path,
    vehicles: int,
    axles_per_vehicle: int,
    seed: int = 7,
    field: FieldEffects | None = None,
) -> bytes:
    """A simulated pass archive (`wheelscan synth-pass`; clean frames unless `field`) zipped
    for upload."""
    (pass_dir,) = write_synthetic_passes(
        folder / "pass",
        vehicles=vehicles,
        axles_per_vehicle=axles_per_vehicle,
        seed=seed,
        field=field,
    )
    return zip_pass_folder(pass_dir, folder / "pass.zip")


def zip_pass_folder(pass_dir: Path, archive: Path) -> bytes:
    """A simulated pass folder zipped for upload (stored, its truth.json left out)."""
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_STORED) as out:
        for path in sorted(pass_dir.rglob("*")):
            if path.is_file() and path.name != "truth.json":
                out.write(path, path.relative_to(pass_dir).as_posix())
    return archive.read_bytes()


class RedisServer:
    """A private Redis on a free port; `persistent`: with an append-only file (as in
    docker-compose.yml), else keeping nothing across a restart (as this machine's Redis)."""

    def __init__(self, folder: Path, *, persistent: bool = True) -> None:
        self.binary = redis_server_binary()
        self.folder = folder
        self.port = free_port()
        self.url = f"redis://127.0.0.1:{self.port}/0"
        self.persistent = persistent
        self._process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        command = [self.binary, "--port", str(self.port), "--bind", "127.0.0.1"]
        command += ["--dir", str(self.folder), "--save", ""]
        command += ["--appendonly", "yes", "--appendfsync", "always"] if self.persistent else []
        log = (self.folder / "redis.log").open("ab")
        self._process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
        client = redis.Redis(port=self.port, socket_connect_timeout=1)
        wait_until(lambda: _answers(client), 20, f"redis-server on port {self.port}")

    def stop(self) -> None:
        """Shut down as a restart does (SIGTERM: the append-only file is flushed)."""
        if self._process is not None:
            self._process.terminate()
            self._process.wait(timeout=30)
            self._process = None


def _answers(client: redis.Redis) -> bool:
    try:
        return bool(client.ping())
    except redis.exceptions.ConnectionError:
        return False


class WorkerProcess:
    """One `wheelscan worker --concurrency 1` (its own process group, its own log)."""

    def __init__(self, name: str, env: dict[str, str], folder: Path) -> None:
        self.name = name
        self.log_path = folder / f"worker-{name}.log"
        command = [WHEELSCAN, "worker", "--concurrency", "1", "--hostname", f"{name}@scale"]
        with self.log_path.open("ab") as log:
            self.process = subprocess.Popen(
                command, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
            )

    def wait_ready(self, timeout_s: float = 60) -> None:
        def ready() -> bool:
            if self.process.poll() is not None:
                raise AssertionError(f"worker {self.name} exited:\n{self.log()[-2000:]}")
            return " ready." in self.log()

        wait_until(ready, timeout_s, f"worker {self.name} to start")

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def outcomes(self) -> Counter[str]:
        """How many tasks this worker finished, by the state they returned."""
        return Counter(TASK_OUTCOME.findall(self.log()))

    def kill_pool_children(self) -> int:
        """SIGKILL the worker's pool processes only (as the OOM killer would); returns how
        many. The worker's main process stays up and replaces them."""
        children = [
            int(stat.parent.name)
            for stat in Path("/proc").glob("[0-9]*/stat")
            if _parent_pid(stat) == self.process.pid
        ]
        for pid in children:
            os.kill(pid, signal.SIGKILL)
        return len(children)

    def kill(self) -> None:
        """SIGKILL the worker and its pool child at once (as a power cut would)."""
        os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=30)

    def stop(self) -> None:
        """Warm shutdown: SIGTERM to the worker's main process only, which lets a task
        that is running finish and log its outcome (a SIGTERM to the whole group ends the
        pool child at once); SIGKILL to all after 60 s."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.kill()


def _parent_pid(stat: Path) -> int | None:
    try:
        text = stat.read_text()
    except OSError:
        return None
    return int(text[text.rindex(")") + 2 :].split()[1])


@contextmanager
def workers(
    count: int, env: dict[str, str], folder: Path, prefix: str = "w"
) -> Iterator[list[WorkerProcess]]:
    started = [WorkerProcess(f"{prefix}{index + 1}", env, folder) for index in range(count)]
    try:
        for worker in started:
            worker.wait_ready()
        yield started
    finally:
        for worker in started:
            worker.stop()


def worker_env(settings: Settings, *, fast_redelivery: bool = True) -> dict[str, str]:
    """The environment of a worker process for these settings (with `fast_redelivery`, the
    short delays of TEST_SCALE_ENV; without, the production defaults)."""
    env = {**os.environ, **(TEST_SCALE_ENV if fast_redelivery else {})}
    env["WHEELSCAN_BROKER_URL"] = settings.broker_url or ""
    env["WHEELSCAN_DATABASE_URL"] = settings.resolved_database_url
    env["WHEELSCAN_DATA_DIR"] = str(settings.data_dir)
    return env


@contextmanager
def api(settings: Settings) -> Iterator[TestClient]:
    """The service (in this process) with the runner its settings select."""
    app = create_app(settings)
    with TestClient(app) as client:
        yield client
    app.state.engine.dispose()


@contextmanager
def http_server(client: TestClient) -> Iterator[str]:
    """Serve the app behind `client` over real HTTP on a free port (its lifespan stays with
    the TestClient); yields the base URL."""
    port = free_port()
    config = uvicorn.Config(
        client.app, host="127.0.0.1", port=port, lifespan="off", log_level="warning"
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, name="http-server", daemon=True)
    thread.start()
    wait_until(lambda: server.started, 30, f"the HTTP server on port {port}")
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=30)


def operator_token(client: TestClient, name: str) -> str:
    with client.app.state.session_factory() as session:
        token = create_token(session, role="operator", name=name)[1]
        session.commit()
    return token


def upload(client: TestClient, archive: bytes) -> int:
    """Upload a pass archive with a fresh operator token; returns the pass id."""
    token = operator_token(client, "scale test")
    response = client.post(
        "/api/passes",
        files={"file": ("pass.zip", archive, "application/zip")},
        headers={"Authorization": f"Bearer {token}"},
    )
    assert response.status_code == 202, response.text
    return int(response.json()["pass_id"])


def wheel_states(client: TestClient, pass_id: int) -> dict[int, tuple[str, int]]:
    """state and attempts of every wheel of a pass, by pass-wheel id."""
    with client.app.state.session_factory() as session:
        rows = session.execute(
            select(PassWheel.id, PassWheel.state, PassWheel.attempts).where(
                PassWheel.pass_id == pass_id
            )
        )
        return {row.id: (row.state, row.attempts) for row in rows}


def job_state(client: TestClient, pass_id: int) -> str:
    with client.app.state.session_factory() as session:
        return session.scalars(select(Job.state).where(Job.pass_id == pass_id)).one()


def wait_for_pass(client: TestClient, pass_id: int, timeout_s: float) -> None:
    wait_until(lambda: job_state(client, pass_id) == "done", timeout_s, f"pass {pass_id}")


IGNORED_COLUMNS = {"id", "pass_wheel_id", "created_at"}


def measurement_results(client: TestClient, pass_id: int) -> dict[tuple, dict[str, Any]]:
    """Every stored result of a pass by (vehicle, axle, side, method), ids left out."""
    columns = [c for c in Measurement.__table__.columns if c.name not in IGNORED_COLUMNS]
    query = (
        select(Wheel.vehicle_id, Wheel.axle, Wheel.side, *columns)
        .join(PassWheel, PassWheel.id == Measurement.pass_wheel_id)
        .join(Wheel, Wheel.id == PassWheel.wheel_id)
        .where(PassWheel.pass_id == pass_id)
    )
    with client.app.state.session_factory() as session:
        rows = [row._asdict() for row in session.execute(query)]
    results: dict[tuple, dict[str, Any]] = {}
    for row in rows:
        key = (row.pop("vehicle_id"), row.pop("axle"), row.pop("side"), row["method"])
        assert key not in results, f"{key} stored twice"
        results[key] = row
    return results
