"""A real `wheelscan serve` process the fault tests may SIGKILL and start again, simulated
pass archives that differ from each other, and the checks that nothing is half-written.

Used by tests/faults and benchmarks/load.py.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import signal
import subprocess
import sys
import threading
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import func, select

from backend.cli.token import issue_token
from backend.config import Settings
from db.engine import make_engine, make_session_factory
from db.models import Frame, Job, Measurement, MeasurementFrame, Pass, PassWheel
from pipeline.archive.pass_archive import decode_frame, encode_frame
from tests.scale.topology import free_port, wait_until

ROOT = Path(__file__).resolve().parents[2]
WHEELSCAN = [sys.executable, "-m", "backend.cli"]
START_TIMEOUT_S = 60.0
REQUEST_TIMEOUT_S = 30.0
BLOB_NAME_LENGTH = 64


class LiveServer:
    """`wheelscan serve` on a free loopback port with a data dir (and database) of its own.

    The server runs in a process group of its own: `kill()` SIGKILLs the server process
    alone (as a crash does; its pool workers notice and exit), `close()` ends the group.
    """

    def __init__(
        self,
        data_dir: Path,
        *,
        database_url: str | None = None,
        workers: int = 1,
        tmp_dir: Path | None = None,
        log_dir: Path | None = None,
    ) -> None:
        self.data_dir = data_dir
        self.tmp_dir = tmp_dir or data_dir.parent / f"{data_dir.name}-tmp"
        self.settings = Settings(data_dir=data_dir, database_url=database_url, workers=workers)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = (log_dir or data_dir.parent) / f"{data_dir.name}-server.log"
        self.process: subprocess.Popen[bytes] | None = None
        self._groups: list[int] = []
        self._tokens: dict[str, str] = {}
        self._token_lock = threading.Lock()

    def env(self) -> dict[str, str]:
        env = {
            **os.environ,
            "WHEELSCAN_DATA_DIR": str(self.data_dir),
            "WHEELSCAN_WORKERS": str(self.settings.workers),
            "WHEELSCAN_VIEWER_PORT": str(free_port()),
            "TMPDIR": str(self.tmp_dir),
        }
        env.pop("WHEELSCAN_BROKER_URL", None)
        env.pop("WHEELSCAN_DATABASE_URL", None)
        if self.settings.database_url:
            env["WHEELSCAN_DATABASE_URL"] = self.settings.database_url
        return env

    def start(self) -> None:
        """Start the server and wait until /healthz answers (AssertionError if it does not)."""
        self.data_dir.mkdir(parents=True, exist_ok=True)
        self.tmp_dir.mkdir(parents=True, exist_ok=True)
        command = [*WHEELSCAN, "serve", "--host", "127.0.0.1", "--port", str(self.port)]
        with self.log.open("ab") as sink:
            self.process = subprocess.Popen(
                command,
                env=self.env(),
                stdout=sink,
                stderr=subprocess.STDOUT,
                cwd=ROOT,
                start_new_session=True,
            )
        self._groups.append(self.process.pid)
        wait_until(self._healthy, START_TIMEOUT_S, f"wheelscan serve on {self.url}")

    def _healthy(self) -> bool:
        assert self.process is not None
        if self.process.poll() is not None:
            raise AssertionError(
                f"the server exited with {self.process.returncode}:\n{self.log_tail()}"
            )
        try:
            return httpx.get(f"{self.url}/healthz", timeout=2.0).status_code == 200
        except httpx.TransportError:
            return False

    def kill(self) -> None:
        """SIGKILL the server process (not its pool workers: they must notice by themselves)."""
        assert self.process is not None
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(timeout=10)

    def workers_left(self) -> list[int]:
        """Pids still alive in the process groups this server has had."""
        alive = []
        for pid_dir in Path("/proc").iterdir():
            if not pid_dir.name.isdigit():
                continue
            try:
                fields = (pid_dir / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) in self._groups and fields[0] != "Z":
                alive.append(int(pid_dir.name))
        return alive

    def close(self) -> None:
        """End every process this server started (its groups), leaving nothing behind."""
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)
        for group in self._groups:
            try:
                os.killpg(group, signal.SIGKILL)
            except ProcessLookupError:
                pass

    def log_tail(self, chars: int = 4000) -> str:
        return self.log.read_text(errors="replace")[-chars:] if self.log.exists() else ""

    def token(self, role: str) -> str:
        """A token with `role` in this server's database (made once, by one thread)."""
        with self._token_lock:
            if role not in self._tokens:
                self._tokens[role] = issue_token(self.settings, role, f"faults {role}")
            return self._tokens[role]

    def client(self, role: str = "operator", timeout_s: float = REQUEST_TIMEOUT_S) -> httpx.Client:
        return httpx.Client(
            base_url=self.url,
            headers={"Authorization": f"Bearer {self.token(role)}"},
            timeout=timeout_s,
        )


def upload(client: httpx.Client, archive: bytes, name: str = "pass.zip") -> httpx.Response:
    return client.post("/api/passes", files={"file": (name, archive, "application/zip")})


def wait_for_job(client: httpx.Client, job_id: int, timeout_s: float) -> dict[str, Any]:
    """The job once "done" (AssertionError after `timeout_s`)."""
    seen: dict[str, Any] = {}

    def done() -> bool:
        seen.update(client.get(f"/api/jobs/{job_id}").raise_for_status().json())
        return seen["state"] == "done"

    wait_until(done, timeout_s, f"job {job_id} to finish")
    return seen


def wheels_of(client: httpx.Client, pass_id: int) -> list[dict[str, Any]]:
    return client.get(f"/api/passes/{pass_id}/wheels").raise_for_status().json()


def vary_archive(archive: bytes, index: int, *, distinct_frames: bool = False) -> bytes:
    """The archive as another train: vehicle ids suffixed with `index`, started `index`
    minutes later, so every copy is a new pass with wheels of its own; `distinct_frames`:
    each frame's corner pixel set to `index` too, so the frames are new blobs to store
    (a corner far from the stripe: the measurement does not change)."""
    source = zipfile.ZipFile(io.BytesIO(archive))
    manifest = json.loads(source.read("manifest.json"))
    rename = {v: f"{v}-{index}" for v in manifest["vehicles"]}
    manifest["vehicles"] = [rename[v] for v in manifest["vehicles"]]
    for wheel in manifest["wheels"]:
        wheel["vehicle_id"] = rename[wheel["vehicle_id"]]
    started = manifest["started_at"]
    manifest["started_at"] = f"{started[:14]}{index % 60:02d}{started[16:]}"
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as target:
        for info in source.infolist():
            if info.filename == "manifest.json":
                target.writestr(info.filename, json.dumps(manifest))
            elif distinct_frames and info.filename.endswith(".png"):
                frame = decode_frame(source.read(info), info.filename).copy()
                frame[0, 0] = index % 256
                target.writestr(info, encode_frame(frame))
            else:
                target.writestr(info, source.read(info))
    return out.getvalue()


def manifest_wheels(archive: bytes) -> set[tuple[str, int, str]]:
    """(vehicle_id, axle, side) of every wheel the archive's manifest lists."""
    manifest = json.loads(zipfile.ZipFile(io.BytesIO(archive)).read("manifest.json"))
    return {(w["vehicle_id"], w["axle"], w["side"]) for w in manifest["wheels"]}


@dataclass
class Damage:
    """What a check of a data dir found half-written, lost or left behind."""

    problems: list[str] = field(default_factory=list)

    def add(self, problem: str) -> None:
        self.problems.append(problem)

    def __bool__(self) -> bool:
        return bool(self.problems)


def check_store(data_dir: Path, tmp_dir: Path | None = None) -> Damage:
    """Files: no temporary file left (store, incoming, TMPDIR), every blob named by the
    sha256 of its bytes."""
    damage = Damage()
    store = Settings(data_dir=data_dir).frames_dir
    for path in sorted(store.rglob("*")) if store.exists() else []:
        if path.is_dir():
            continue
        sha256 = path.name[:BLOB_NAME_LENGTH]
        if path.name.startswith(".") or len(sha256) != BLOB_NAME_LENGTH:
            damage.add(f"temporary file left in the store: {path.relative_to(data_dir)}")
        elif hashlib.sha256(path.read_bytes()).hexdigest() != sha256:
            damage.add(f"blob whose bytes do not match its name: {path.relative_to(data_dir)}")
    for folder in (data_dir / "incoming", tmp_dir):
        if folder is not None and folder.exists():
            damage.problems += [f"file left behind: {p}" for p in folder.iterdir()]
    return damage


def check_database(database_url: str, data_dir: Path) -> Damage:
    """Rows: every pass has its wheels, frames and job; every finished wheel its
    measurements; every measurement its points and per-frame artefacts; every referenced
    blob is in the store."""
    damage = Damage()
    store = Settings(data_dir=data_dir).frames_dir
    engine = make_engine(database_url)
    try:
        with make_session_factory(engine)() as session:
            for train_pass in session.scalars(select(Pass)):
                _check_pass(session, train_pass, damage)
            kept = select(Pass.id).where(Pass.frames_removed_at.is_(None))  # not by retention
            for frame in session.scalars(select(Frame).where(Frame.pass_id.in_(kept))):
                if not (store / frame.sha256[:2] / f"{frame.sha256}.png").exists():
                    damage.add(f"frame {frame.id} of pass {frame.pass_id}: blob missing")
            for row in session.scalars(select(MeasurementFrame)):
                sha = row.artefact_sha256
                if not (store / sha[:2] / f"{sha}.npz").exists():
                    damage.add(f"measurement frame {row.id}: artefact blob missing")
    finally:
        engine.dispose()
    return damage


def _check_pass(session: Any, train_pass: Pass, damage: Damage) -> None:
    where = f"pass {train_pass.id}"
    wheels = list(session.scalars(select(PassWheel).where(PassWheel.pass_id == train_pass.id)))
    if not wheels:
        damage.add(f"{where}: no wheels")
    frames = session.scalar(select(func.count(Frame.id)).where(Frame.pass_id == train_pass.id))
    if train_pass.source == "upload" and frames < 2 * len(wheels):
        damage.add(f"{where}: {frames} frames for {len(wheels)} wheels")
    if session.scalar(select(func.count(Job.id)).where(Job.pass_id == train_pass.id)) != 1:
        damage.add(f"{where}: not exactly one job")
    for pass_wheel in wheels:
        measurements = list(pass_wheel.measurements)
        if pass_wheel.state in ("measured", "not_measured") and len(measurements) != 2:
            damage.add(f"{where} wheel {pass_wheel.id}: {len(measurements)} measurements")
        for row in measurements:
            _check_measurement(row, f"{where} wheel {pass_wheel.id} {row.method}", damage)


def _check_measurement(row: Measurement, where: str, damage: Damage) -> None:
    if row.status != "measured":
        return
    points = (row.profile or {}).get("x_mm") or []
    if not points or row.point_count == 0:
        damage.add(f"{where}: measured without profile points")
    if not row.frames:
        damage.add(f"{where}: measured without per-frame artefacts")
